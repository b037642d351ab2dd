// Helpers shared by the libFuzzer harnesses (docs/fuzzing.md): the project's readers take paths,
// as the CLI and the daemon (blob files in its spool) call them, so a harness writes the fuzzer's
// bytes to files in a private scratch folder (on tmpfs when there is one) and passes the paths.
#ifndef SHRM_FUZZ_FUZZ_UTIL_H_
#define SHRM_FUZZ_FUZZ_UTIL_H_

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace shrm::fuzz {

// A folder of this process, created on first use ("/dev/shm/shrm-fuzz-<pid>" or under
// $TMPDIR) and removed at exit.
const std::string& ScratchDir();

// Writes `bytes` to ScratchDir()/name (replacing it) and returns the path. Aborts on an I/O error
// (a broken harness, not a finding).
std::string WriteScratchFile(std::string_view name, std::string_view bytes);

// Aborts with `what` when `condition` is false: a harness's own invariant (a round trip that
// does not return what went in) reported to libFuzzer as a crash.
void Check(bool condition, std::string_view what);

inline std::string_view AsView(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace shrm::fuzz

#endif  // SHRM_FUZZ_FUZZ_UTIL_H_
