// Atomic output: every file shrm writes goes to a temporary name in the destination's folder and
// is renamed over the destination only when complete, so a failed run never leaves a partial or
// corrupted output (and never destroys an existing one).
#ifndef SHRM_CORE_IO_ATOMIC_FILE_H_
#define SHRM_CORE_IO_ATOMIC_FILE_H_

#include <fstream>
#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace shrm {

// "<stem>.tmp-<pid><ext>" next to `path`: same folder (so the rename is atomic), unique per
// process, same extension. The name is remembered until CommitTempFile or DiscardTempFile takes
// it, for RemoveTempFilesOnSignal.
std::string TempPathFor(const std::string& path);
// Renames `tmp` over `path`; on failure removes `tmp` and returns Unavailable naming `path`.
absl::Status CommitTempFile(const std::string& tmp, const std::string& path);
// Removes `tmp` if it exists (after a failed write).
void DiscardTempFile(const std::string& tmp);
// Writes `bytes` to `path` atomically.
absl::Status WriteFileAtomically(const std::string& path, std::string_view bytes);

// Makes SIGINT, SIGTERM and SIGHUP (those not ignored: a command run with nohup keeps ignoring
// SIGHUP) remove the temporary files TempPathFor named and no commit or discard has taken yet,
// then end the process as the signal would have (exit status 128 + the signal). Without it, a
// command interrupted while writing (Ctrl-C during a 200 MB SHRM's write) left its temporaries
// beside the outputs; the outputs themselves are never touched either way. For programs' main();
// the handler only unlinks (async-signal-safe) names it can read without locks. At most
// kMaxTrackedTempFiles names are held at once (more are written as before, untracked).
void RemoveTempFilesOnSignal();
inline constexpr int kMaxTrackedTempFiles = 256;

// The same for a file written piece by piece (a large output streamed from its encoder instead of
// held whole in memory): Append, then Commit once; destroyed uncommitted, the temporary file is
// removed and `path` is left as it was.
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(std::string path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
  void Append(std::string_view bytes);
  // Unavailable naming the path when any write failed or the rename does.
  absl::Status Commit();

 private:
  std::string path_, tmp_;
  std::ofstream out_;
  bool done_ = false;
};

}  // namespace shrm

#endif  // SHRM_CORE_IO_ATOMIC_FILE_H_
