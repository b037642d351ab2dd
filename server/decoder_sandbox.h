// Decoding of untrusted image files in separate processes: the defence against a query of death
// (docs/server.md, "The query of death"). Before shrmd decodes an uploaded map for the first time,
// a child process decodes it (OpenImageIO / OpenEXR, with the header checks of core/io/image.h)
// under resource limits; only a file that decodes there cleanly is decoded in the daemon. A file
// that crashes the decoder, or exceeds its memory or time limit, kills only the child: the job gets
// INVALID_ARGUMENT (reason DECODER_CRASHED, final: clients do not send it again), and the daemon
// and its other jobs go on.
//
// The children are forked from a small "zygote" process that shrmd forks early in main(), before
// it starts any thread (forking a multi-threaded gRPC server is unsafe: a child could inherit a
// lock another thread held; the only threads then are those libraries start at load time, idle).
// For each check the zygote forks a monitor, the monitor forks the decoder and reports how it
// ended; the answer comes back on a socket pair made for the check, so checks run concurrently.
#ifndef SHRM_SERVER_DECODER_SANDBOX_H_
#define SHRM_SERVER_DECODER_SANDBOX_H_

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "absl/container/flat_hash_map.h"
#include "absl/container/flat_hash_set.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/io/image.h"

namespace shrm::server {

// The limits of one decoding child.
struct DecodeLimits {
  ImageLimits image;                   // the header checks (as in-process decoding)
  uint64_t memory_bytes = 8ull << 30;  // RLIMIT_AS of the child (not under AddressSanitizer)
  absl::Duration timeout = absl::Seconds(300);  // wall clock (SIGALRM) and CPU time (RLIMIT_CPU)
  // Testing only: a file that starts with kTestPoisonMagic makes the child abort(), one that
  // starts with kTestHangMagic makes it sleep until its time limit.
  bool test_hooks = false;
};
inline constexpr char kTestPoisonMagic[] = "SHRM-TEST-POISON";
inline constexpr char kTestHangMagic[] = "SHRM-TEST-HANG";

class DecoderSandbox {
 public:
  // Forks the zygote. FailedPrecondition when the program has started threads since its static
  // initialization (gRPC, worker pools): call it early in main().
  static absl::StatusOr<std::unique_ptr<DecoderSandbox>> Start();
  ~DecoderSandbox();  // closes the control socket (the zygote exits) and reaps the zygote
  DecoderSandbox(const DecoderSandbox&) = delete;
  DecoderSandbox& operator=(const DecoderSandbox&) = delete;

  // Decodes `path` (ProbeImage, then ReadImageRgb) in a child process. OK; the decoder's own
  // error (as in-process decoding would return it); InvalidArgument with reason DECODER_CRASHED
  // when the child died (the signal named), ran out of time or memory; Internal when the zygote
  // is gone. Thread-safe.
  absl::Status Check(const std::string& path, const DecodeLimits& limits);

  // Checks run so far (tests: a quarantined blob is not checked again).
  int64_t checks() const { return checks_.load(); }
  pid_t zygote_pid() const { return zygote_; }

 private:
  DecoderSandbox(int control, pid_t zygote) : control_(control), zygote_(zygote) {}
  int control_;
  pid_t zygote_;
  std::atomic<int64_t> checks_{0};
};

// The sandbox and what it learnt per blob (content-addressed, so the answer never changes):
// blobs that decoded cleanly are not checked again; a blob that killed a decoder is refused at
// once with the same answer (quarantined for the life of the daemon; a restarted daemon checks it
// again in a child, which costs a child, never the daemon). Other decoder errors are not kept:
// in-process decoding returns them as well. The clean set is bounded (65,536 blobs, then it starts
// again). Thread-safe.
class DecodeGuard {
 public:
  // `sandbox` null: no isolation (Vet returns OK).
  DecodeGuard(DecoderSandbox* sandbox, const DecodeLimits& limits)
      : sandbox_(sandbox), limits_(limits) {}
  // The blob `sha256` stored at `path`, checked against `image` (the header limits of the job's
  // decoding): OK, or the sandbox's error (reason DECODER_CRASHED with metadata "sha256" for a
  // crash).
  absl::Status Vet(const std::string& sha256, const std::string& path, const ImageLimits& image);

 private:
  DecoderSandbox* const sandbox_;
  const DecodeLimits limits_;
  std::mutex mu_;  // guards clean_ and refused_
  absl::flat_hash_set<std::string> clean_;
  absl::flat_hash_map<std::string, absl::Status> refused_;
};

}  // namespace shrm::server

#endif  // SHRM_SERVER_DECODER_SANDBOX_H_
