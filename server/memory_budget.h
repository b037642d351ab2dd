// Memory-aware admission (docs/server.md, "Memory"): the daemon's jobs reserve what their stages
// will hold (jobs/memory_estimate.h) from a budget before the stages run. A reservation that does
// not fit the memory free now is refused with RESOURCE_EXHAUSTED (reason MEMORY_BUSY, a retry
// delay: clients send the job again); one larger than everything jobs may ever hold is refused
// with INVALID_ARGUMENT (reason JOB_TOO_LARGE, final), naming the need and the limit. Nothing
// waits, so jobs holding memory never wait for each other.
//
// The budget is the daemon's whole resident memory (--memory-mib; by default three quarters of
// the cgroup's limit, or of the machine's memory): what jobs may reserve is the budget less the
// daemon's memory at start, the caches' bound and a reserve for calls and transfers.
#ifndef SHRM_SERVER_MEMORY_BUDGET_H_
#define SHRM_SERVER_MEMORY_BUDGET_H_

#include <cstdint>
#include <mutex>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace shrm::server {

// What the service keeps for everything that is not a job's stage: gRPC's buffers of calls in
// flight (uploads and transfers: chunks of 1 MiB), the request logs, the allocator's slack.
inline constexpr uint64_t kServiceReserveBytes = uint64_t{128} << 20;

class MemoryBudget {
 public:
  // `job_bytes`: what jobs may hold together; 0 = no limit. `budget_text` names the budget in
  // messages (e.g. "--memory-mib 2048").
  MemoryBudget(uint64_t job_bytes, std::string budget_text);
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  // The bytes one job holds; released on destruction. Not thread-safe itself (one job's thread).
  class Reservation {
   public:
    explicit Reservation(MemoryBudget* budget) : budget_(budget) {}
    ~Reservation();
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;
    // Adds `bytes` for `what` (e.g. "decoding the map"): OK, or the refusals above.
    absl::Status Add(uint64_t bytes, std::string_view what);
    uint64_t bytes() const { return bytes_; }

   private:
    MemoryBudget* budget_;
    uint64_t bytes_ = 0;
  };

  uint64_t job_bytes() const { return job_bytes_; }
  uint64_t reserved() const;
  // The most reserved at once so far.
  uint64_t peak_reserved() const;

 private:
  absl::Status Take(uint64_t holding, uint64_t bytes, std::string_view what);
  void Give(uint64_t bytes);
  const uint64_t job_bytes_;
  const std::string budget_text_;
  mutable std::mutex mu_;  // guards reserved_ and peak_
  uint64_t reserved_ = 0;
  uint64_t peak_ = 0;
};

// The memory limit that applies to this process: the smallest cgroup limit on its path (v2
// memory.max, or v1 memory.limit_in_bytes), else the machine's MemTotal; `source` says which.
struct SystemMemory {
  uint64_t bytes = 0;
  std::string source;
};
SystemMemory SystemMemoryLimit();

// This process's resident memory now and its peak (VmRSS, VmHWM of /proc/self/status); 0 when
// unknown.
uint64_t ProcessRssBytes();
uint64_t ProcessPeakRssBytes();

}  // namespace shrm::server

#endif  // SHRM_SERVER_MEMORY_BUDGET_H_
