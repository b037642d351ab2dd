// The `shrm` command: frequency-space prefiltering of HDR environment maps, embedded
// (in-process). Subcommands: analyze, prefilter, eval, reference, render, explicit, irradiance,
// ibl, info, batch, live, sky (cli/commands.h). docs/cli.md documents every option and the exit
// codes.
#include <cstdio>
#include <cstdlib>

#include "cli/commands.h"
#include "core/io/atomic_file.h"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SHRM_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define SHRM_SANITIZED 1
#endif
#endif

int main(int argc, char** argv) {
  // Ctrl-C (or a service manager's SIGTERM) while outputs are written removes their temporaries.
  shrm::RemoveTempFilesOnSignal();
  const int rc = shrm::cli::RunShrm(argc, argv);
#ifndef SHRM_SANITIZED
  // Every output is complete (written and renamed) and every stream flushed here: the static
  // destructors (locale caches, CLI11's validators, FFTW's and the Legendre tables' caches, pools
  // of idle threads) only give memory back, ~1 ms of a short command (docs/architecture.md
  // "Start-up"). Sanitized builds exit normally, so LeakSanitizer still runs.
  std::fflush(nullptr);
  std::_Exit(rc);
#else
  return rc;
#endif
}
