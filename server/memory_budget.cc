#include "server/memory_budget.h"

#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <utility>

#include "absl/strings/str_cat.h"
#include "proto/status_details.h"

namespace shrm::server {
namespace {

// Clients wait this long before sending a job refused for memory again (a running job's stage
// takes seconds).
constexpr absl::Duration kMemoryRetryAfter = absl::Seconds(1);
constexpr uint64_t kMiB = uint64_t{1} << 20;

uint64_t CeilMiB(uint64_t bytes) { return (bytes + kMiB - 1) / kMiB; }

// The first line of `path` as a byte count; 0 when absent, "max" or not a number.
uint64_t ReadLimitFile(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) return 0;
  if (line.empty() || line == "max") return 0;
  uint64_t v = 0;
  for (char c : line) {
    if (c < '0' || c > '9') return v;
    if (v > (UINT64_MAX - 9) / 10) return 0;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  return v;
}

// A "Key:   N kB" line of a /proc status-like file, in bytes; 0 when absent.
uint64_t ReadKbField(const std::string& path, std::string_view key) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.compare(0, key.size(), key) != 0 || line.size() <= key.size() ||
        line[key.size()] != ':') {
      continue;
    }
    std::istringstream fields(line.substr(key.size() + 1));
    uint64_t kb = 0;
    fields >> kb;
    return kb * 1024;
  }
  return 0;
}

}  // namespace

MemoryBudget::MemoryBudget(uint64_t job_bytes, std::string budget_text)
    : job_bytes_(job_bytes), budget_text_(std::move(budget_text)) {}

uint64_t MemoryBudget::reserved() const {
  std::lock_guard<std::mutex> lock(mu_);
  return reserved_;
}

uint64_t MemoryBudget::peak_reserved() const {
  std::lock_guard<std::mutex> lock(mu_);
  return peak_;
}

absl::Status MemoryBudget::Take(uint64_t holding, uint64_t bytes, std::string_view what) {
  const uint64_t need = holding + bytes;
  if (job_bytes_ > 0 && (need > job_bytes_ || need < holding)) {
    return wire::WithErrorReason(
        absl::InvalidArgumentError(absl::StrCat(
            "the job needs about ", CeilMiB(need), " MiB (", std::string(what), "), more than the ",
            job_bytes_ / kMiB, " MiB this server gives jobs (", budget_text_,
            "): make the map, the face size or the orders smaller, or run it on a larger server")),
        wire::kReasonJobTooLarge, "needed_mib", absl::StrCat(CeilMiB(need)));
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (job_bytes_ > 0 && reserved_ + bytes > job_bytes_) {
    return wire::WithRetryDelay(
        wire::WithErrorReason(
            absl::ResourceExhaustedError(absl::StrCat(
                "server busy: the job needs about ", CeilMiB(bytes), " MiB more (",
                std::string(what), "), and ", (job_bytes_ - std::min(reserved_, job_bytes_)) / kMiB,
                " of ", job_bytes_ / kMiB, " MiB are free now (", budget_text_,
                "); retry after about ", absl::ToInt64Milliseconds(kMemoryRetryAfter), " ms")),
            wire::kReasonMemoryBusy, "needed_mib", absl::StrCat(CeilMiB(bytes))),
        kMemoryRetryAfter);
  }
  reserved_ += bytes;
  peak_ = std::max(peak_, reserved_);
  return absl::OkStatus();
}

void MemoryBudget::Give(uint64_t bytes) {
  std::lock_guard<std::mutex> lock(mu_);
  reserved_ -= std::min(bytes, reserved_);
}

MemoryBudget::Reservation::~Reservation() {
  if (bytes_ > 0) budget_->Give(bytes_);
}

absl::Status MemoryBudget::Reservation::Add(uint64_t bytes, std::string_view what) {
  if (absl::Status s = budget_->Take(bytes_, bytes, what); !s.ok()) return s;
  bytes_ += bytes;
  return absl::OkStatus();
}

SystemMemory SystemMemoryLimit() {
  SystemMemory out;
  out.bytes = ReadKbField("/proc/meminfo", "MemTotal");
  out.source = "MemTotal";
  // The cgroup path of this process: "0::/path" (v2), or "N:memory:/path" (v1).
  std::ifstream cgroup("/proc/self/cgroup");
  std::string line;
  while (std::getline(cgroup, line)) {
    std::string dir;
    std::string file;
    if (line.rfind("0::", 0) == 0) {
      dir = "/sys/fs/cgroup" + line.substr(3);
      file = "memory.max";
    } else if (const size_t at = line.find(":memory:"); at != std::string::npos) {
      dir = "/sys/fs/cgroup/memory" + line.substr(at + 8);
      file = "memory.limit_in_bytes";
    } else {
      continue;
    }
    // The limit of every ancestor applies; a namespaced /proc/self/cgroup says "/" for the
    // container's own root.
    while (true) {
      const uint64_t v = ReadLimitFile(dir + "/" + file);
      if (v > 0 && v < out.bytes) {
        out.bytes = v;
        out.source = absl::StrCat("the cgroup's ", file, " (", dir, ")");
      }
      const size_t slash = dir.find_last_of('/');
      if (slash == std::string::npos || dir.size() <= std::string("/sys/fs/cgroup").size()) break;
      dir.resize(slash);
    }
  }
  return out;
}

uint64_t ProcessRssBytes() { return ReadKbField("/proc/self/status", "VmRSS"); }
uint64_t ProcessPeakRssBytes() { return ReadKbField("/proc/self/status", "VmHWM"); }

}  // namespace shrm::server
