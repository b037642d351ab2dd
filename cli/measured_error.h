// The measured error a job's report states (its own check against the brute-force reference,
// `--verify`), as the batch summary shows it: relative RMS and largest relative error. A
// prefilter reports its front pairs (N.V >= 0.3, the per-direction tolerance's measure); an IBL
// set, its worst level over every cube it wrote. Unknown (-1) when the job did not measure.
#ifndef SHRM_CLI_MEASURED_ERROR_H_
#define SHRM_CLI_MEASURED_ERROR_H_

#include <algorithm>
#include <nlohmann/json.hpp>

namespace shrm::cli {

struct MeasuredError {
  double rms = -1, max = -1;
  bool known() const { return rms >= 0; }
};

// From a prefilter report's "measured" (jobs/prefilter_job.cc).
inline MeasuredError PrefilterMeasuredError(const nlohmann::json& report) {
  MeasuredError e;
  if (!report.contains("measured") || !report["measured"].contains("front")) return e;
  const nlohmann::json& front = report["measured"]["front"];
  e.rms = front.value("rms", -1.0);
  e.max = front.value("max", -1.0);
  return e;
}

// From an IBL report (ibl.json): the largest RMS and largest error over the levels of the
// specular, sheen and irradiance cubes that carry a "measured".
inline MeasuredError IblMeasuredError(const nlohmann::json& report) {
  MeasuredError e;
  for (const char* cube : {"specular", "sheen", "irradiance"}) {
    if (!report.contains(cube) || !report[cube].contains("levels")) continue;
    for (const nlohmann::json& level : report[cube]["levels"]) {
      if (!level.contains("measured")) continue;
      e.rms = std::max(e.rms, level["measured"].value("rms", -1.0));
      e.max = std::max(e.max, level["measured"].value("max", -1.0));
    }
  }
  return e;
}

}  // namespace shrm::cli

#endif  // SHRM_CLI_MEASURED_ERROR_H_
