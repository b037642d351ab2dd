// One `shrm prefilter` job (embedded, or remote with `server`), shared by `shrm prefilter` and
// `shrm batch` (docs/cli.md).
#ifndef SHRM_CLIENT_PREFILTER_JOB_H_
#define SHRM_CLIENT_PREFILTER_JOB_H_

#include <string>

#include "absl/status/status.h"
#include "client/cli_common.h"

namespace shrm::cli {

struct PrefilterArgs {
  EnvArgs env;
  std::string brdf;
  double epsilon = 0.03;
  std::string orders;  // "F,P"
  std::string kind = "global";
  int size = 0;
  std::string output;
  std::string report;
  std::string preview;
  bool half = false;
  int threads = 0;
  bool json = false;
  bool verbose = false;
  std::string server;
  bool quiet = false;  // batch: no stage lines, nothing on stdout
};

struct PrefilterJobOutcome {
  int f_b = -1, p_b = -1;  // the orders of the written SHRM
  int retries = 0;         // remote: attempts beyond the first (transient errors, missing blobs)
};

// Validates the options, runs the job and writes its outputs (all or none). Unless `quiet`,
// prints the summary (or the --json report) on stdout. `outcome` may be null.
absl::Status RunPrefilterJob(const PrefilterArgs& a, PrefilterJobOutcome* outcome = nullptr);

}  // namespace shrm::cli

#endif  // SHRM_CLIENT_PREFILTER_JOB_H_
