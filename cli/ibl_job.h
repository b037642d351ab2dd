// One `shrm ibl` run (embedded, or remote with `server`), shared by `shrm ibl` and `shrm batch`
// (docs/cli.md): the job (jobs/ibl_job.h) plus what only the command decides (the output
// folder, threads, printing, the server). Both paths write the same bytes (jobs/ibl_outputs.h).
#ifndef SHRM_CLI_IBL_JOB_H_
#define SHRM_CLI_IBL_JOB_H_

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "cli/cli_common.h"
#include "cli/measured_error.h"
#include "jobs/ibl_job.h"

namespace shrm::cli {

// The flags of `shrm ibl` as given (text, before the job layer reads them).
struct IblArgs {
  EnvArgs env;
  std::string preset = "filament";
  std::string roughness;  // "r0,r1,..." for the explicit preset
  int size = jobs::kDefaultIblFaceSize;
  int levels = 0;
  bool sheen = false;
  std::string format = "rgba16f";
  int irradiance_size = jobs::kDefaultIrradianceSize;
  int dfg_size = jobs::kDefaultDfgSize;
  double tolerance = jobs::kDefaultIblTolerance;
  int verify = jobs::kDefaultIblVerify;
  std::string sh_window = "auto";
  std::string dfg = "auto";
  std::string containers = "ktx2";
  bool preview = false;
};

// What the command does with a job besides computing it.
struct IblCommandRun {
  std::string output;  // the folder
  int threads = 0;
  bool json = false;
  bool verbose = false;
  std::string server;
  bool quiet = false;  // batch: no stage lines, nothing on stdout
};

struct IblJobOutcome {
  int levels = 0;          // of the specular chain written
  int retries = 0;         // remote: attempts beyond the first
  MeasuredError measured;  // the worst level's, when --verify measured it
  bool written = false;    // every file was written (an error after it: the tolerance missed)
};

// Adds the job's options (jobs/job_options.h, IblJobOptions) to `sub`.
void AddIblJobOptions(CLI::App* sub, IblArgs* args);
// The flags as a job (InvalidArgument naming the flag).
absl::StatusOr<jobs::IblJob> IblJobFromArgs(const IblArgs& args);
// Parses a `shrm ibl` command line (without the program name, starting with "ibl") into its job,
// without running it (tests/job_front_ends_test.cc).
absl::StatusOr<jobs::IblJob> ParseIblCommandLine(std::vector<std::string> args);

// Validates the job and the output folder, runs the job and writes its files into the folder
// (all or none; the folder is created only after the job succeeded). Unless `run.quiet`, prints
// the summary (or the --json report). FailedPrecondition (the files written) when a level misses
// the tolerance (jobs::IblOutcome). `outcome` may be null.
absl::Status RunIblJob(const jobs::IblJob& job, const IblCommandRun& run,
                       IblJobOutcome* outcome = nullptr);

}  // namespace shrm::cli

#endif  // SHRM_CLI_IBL_JOB_H_
