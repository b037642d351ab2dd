#include "core/io/atomic_file.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <utility>

#include "absl/strings/str_cat.h"

namespace shrm {

std::string TempPathFor(const std::string& path) {
  // Keep the extension last so that writers choosing the format by extension still can.
  const std::filesystem::path p(path);
  return (p.parent_path() /
          absl::StrCat(p.stem().string(), ".tmp-", ::getpid(), p.extension().string()))
      .string();
}

void DiscardTempFile(const std::string& tmp) {
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
}

absl::Status CommitTempFile(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    DiscardTempFile(tmp);
    return absl::UnavailableError(absl::StrCat(path, ": cannot rename into place: ", ec.message()));
  }
  return absl::OkStatus();
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
