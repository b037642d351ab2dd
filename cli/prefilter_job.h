// One `shrm prefilter` run (embedded, or remote with `server`), shared by `shrm prefilter` and
// `shrm batch` (docs/cli.md): the job (jobs/prefilter_job.h) plus what only the command decides
// (output paths, threads, printing, the server).
#ifndef SHRM_CLI_PREFILTER_JOB_H_
#define SHRM_CLI_PREFILTER_JOB_H_

#include <CLI/CLI.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "cli/cli_common.h"
#include "cli/measured_error.h"
#include "jobs/prefilter_job.h"

namespace shrm::cli {

// The flags of `shrm prefilter` as given (text, before the job layer reads them).
struct PrefilterArgs {
  EnvArgs env;
  std::string brdf;
  // The order rule: at most one of the three (none: the job's default, the tolerance rule).
  std::optional<double> epsilon;
  std::string orders;  // "F,P"
  std::optional<double> tolerance;
  int verify = jobs::kDefaultVerify;
  std::string window = RingingWindowName(RingingWindow::kAuto);
  std::string view_variable = "auto";
  std::string kind = jobs::ShrmKindName(ShrmKind::kGlobal);
  int size = 0;
  bool half = false;
  std::string peak_lights = PeakLightsName(PeakLights::kAuto);
  double max_size_mb = jobs::kDefaultMaxSizeMb;
};

// What the command does with a job besides computing it.
struct PrefilterRun {
  std::string output;
  std::string report;
  std::string preview;
  std::string report_html;  // the visual report (jobs/report_html.h)
  std::string ktx2;         // the SHRM also as KTX2 (docs/formats.md "SHRM in KTX2")
  int threads = 0;
  bool json = false;
  bool verbose = false;
  std::string server;
  bool quiet = false;  // batch: no stage lines, nothing on stdout
};

struct PrefilterJobOutcome {
  int f_b = -1, p_b = -1;  // the orders of the written SHRM
  int retries = 0;         // remote: attempts beyond the first (transient errors, missing blobs)
  MeasuredError measured;  // the report's, when --verify measured it
  std::string thumbnail_png_base64;  // with report_html: the spheres, for a batch's index
  // Every output was written (an error after it is the tolerance missed: jobs::ToleranceOutcome).
  bool written = false;
};

// Adds the job's options (jobs/job_options.h) to `sub`.
void AddPrefilterJobOptions(CLI::App* sub, PrefilterArgs* args);
// The flags as a job (InvalidArgument naming the flag).
absl::StatusOr<jobs::PrefilterJob> PrefilterJobFromArgs(const PrefilterArgs& args);
// Parses a `shrm prefilter` command line (without the program name, starting with "prefilter")
// into its job, without running it (tests/job_front_ends_test.cc).
absl::StatusOr<jobs::PrefilterJob> ParsePrefilterCommandLine(std::vector<std::string> args);

// Validates the job and the outputs, runs the job and writes its outputs (all or none). Unless
// `run.quiet`, prints the summary (or the --json report) on stdout. `outcome` may be null.
absl::Status RunPrefilterJob(const jobs::PrefilterJob& job, const PrefilterRun& run,
                             PrefilterJobOutcome* outcome = nullptr);

}  // namespace shrm::cli

#endif  // SHRM_CLI_PREFILTER_JOB_H_
