#include "core/io/atomic_file.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace shrm {
namespace {

// The temporary names handed out and not yet committed or discarded, for the signal handler:
// slots of C strings that are written with a compare-and-swap and never freed (a handler on
// another thread may be reading one; a name is ~100 bytes, and a command makes a few per output),
// so the handler reads only whole, valid names without a lock.
std::atomic<const char*> g_temp_names[kMaxTrackedTempFiles];
// The names taken out of the slots: kept, so that they stay valid for a handler that read one
// just before (and reachable, so that leak checkers do not count them).
std::mutex g_retired_mutex;
std::vector<const char*>* g_retired = new std::vector<const char*>;

void TrackTempName(const std::string& name) {
  char* copy = strdup(name.c_str());
  if (copy == nullptr) return;
  for (std::atomic<const char*>& slot : g_temp_names) {
    const char* expected = nullptr;
    if (slot.compare_exchange_strong(expected, copy)) return;
  }
  std::free(copy);  // all slots taken: untracked
}

void ForgetTempName(const std::string& name) {
  for (std::atomic<const char*>& slot : g_temp_names) {
    const char* held = slot.load();
    if (held != nullptr && name == held && slot.compare_exchange_strong(held, nullptr)) {
      const std::lock_guard<std::mutex> lock(g_retired_mutex);
      g_retired->push_back(held);
      return;
    }
  }
}

void RemoveTempFilesAndReraise(int sig) {
  for (std::atomic<const char*>& slot : g_temp_names) {
    if (const char* name = slot.load()) ::unlink(name);
  }
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

}  // namespace

std::string TempPathFor(const std::string& path) {
  // Keep the extension last so that writers choosing the format by extension still can.
  const std::filesystem::path p(path);
  std::string name = (p.parent_path() /
                      absl::StrCat(p.stem().string(), ".tmp-", ::getpid(), p.extension().string()))
                         .string();
  TrackTempName(name);
  return name;
}

void DiscardTempFile(const std::string& tmp) {
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
  ForgetTempName(tmp);
}

absl::Status CommitTempFile(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    DiscardTempFile(tmp);
    return absl::UnavailableError(absl::StrCat(path, ": cannot rename into place: ", ec.message()));
  }
  ForgetTempName(tmp);
  return absl::OkStatus();
}

void RemoveTempFilesOnSignal() {
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction current {};
    if (::sigaction(sig, nullptr, &current) != 0 || current.sa_handler == SIG_IGN) continue;
    struct sigaction action {};
    action.sa_handler = RemoveTempFilesAndReraise;
    sigemptyset(&action.sa_mask);
    ::sigaction(sig, &action, nullptr);
  }
}

absl::Status WriteFileAtomically(const std::string& path, std::string_view bytes) {
  AtomicFileWriter out(path);
  out.Append(bytes);
  return out.Commit();
}

AtomicFileWriter::AtomicFileWriter(std::string path)
    : path_(std::move(path)), tmp_(TempPathFor(path_)), out_(tmp_, std::ios::binary) {}

AtomicFileWriter::~AtomicFileWriter() {
  if (!done_) {
    out_.close();
    DiscardTempFile(tmp_);
  }
}

void AtomicFileWriter::Append(std::string_view bytes) {
  out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

absl::Status AtomicFileWriter::Commit() {
  done_ = true;
  out_.close();
  if (!out_) {
    DiscardTempFile(tmp_);
    return absl::UnavailableError(absl::StrCat(path_, ": cannot write"));
  }
  return CommitTempFile(tmp_, path_);
}

}  // namespace shrm
