// The manifest of `shrm batch` (docs/cli.md "batch"): maps x BRDFs, job options, output naming.
// Each job is a prefilter job of the job layer (jobs/prefilter_job.h) with its output paths, or,
// in a manifest of "kind": "ibl", an IBL job (jobs/ibl_job.h) per map with its output folder.
#ifndef SHRM_CLI_BATCH_MANIFEST_H_
#define SHRM_CLI_BATCH_MANIFEST_H_

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "jobs/ibl_job.h"
#include "jobs/prefilter_job.h"

namespace shrm::cli {

// "options" of the manifest: the job options every job shares, and which outputs to write.
struct BatchOptions {
  bool ibl = false;        // "kind": "ibl"
  jobs::PrefilterJob job;  // env.files and brdf are per job
  jobs::IblJob ibl_job;    // kind ibl: env.files is per job
  bool report = false;
  bool preview = false;
  bool ktx2 = false;         // also <stem>.shrm.ktx2
  bool report_html = false;  // <stem>.report.html per job, and the batch's index page
};

struct BatchJob {
  int index = 0;
  std::string map;        // as resolved (manifest folder / entry)
  std::string map_entry;  // as written in the manifest
  std::string brdf;       // as written
  std::string canonical_brdf;
  bool ibl = false;  // an IBL job (ibl_job, output: a folder) instead of a prefilter job (job)
  jobs::PrefilterJob job;
  jobs::IblJob ibl_job;
  std::string output, report, preview, ktx2, report_html;
  // Outcome.
  std::string status = "pending";  // ok, skipped, failed
  std::string orders;
  double seconds = 0;
  int retries = 0;                              // remote: attempts beyond the first
  double measured_rms = -1, measured_max = -1;  // the job's own check (-1: not measured)
  std::string thumbnail_png_base64;             // of its visual report (index page)
  std::string message;
};

// The manifest's JSON text parsed (`shrm batch` reads the file, then this): InvalidArgument
// "not JSON: ..." for any parse failure, including numbers out of range (1e400).
absl::StatusOr<nlohmann::json> ParseManifestText(std::string_view text);

// Reads and validates a manifest whose relative paths are relative to `dir`; every problem is
// appended to *errors with its JSON path ("$.options.epsilon: ..."), and no job is made then.
void ParseManifest(const nlohmann::json& manifest, const std::filesystem::path& dir,
                   BatchOptions* options, std::vector<BatchJob>* jobs,
                   std::vector<std::string>* errors);

}  // namespace shrm::cli

#endif  // SHRM_CLI_BATCH_MANIFEST_H_
