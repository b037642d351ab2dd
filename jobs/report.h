// JSON renderings of pipeline results: the body of every job's report (the CLI's --report and
// --json, the service's report_json), so that every front end writes the same keys.
#ifndef SHRM_JOBS_REPORT_H_
#define SHRM_JOBS_REPORT_H_

#include <nlohmann/json.hpp>
#include <string>

#include "absl/status/status.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_analysis.h"

namespace shrm::jobs {

// Orders and error estimates with the keys F_L (null when not reached), F_rho, P_rho, F_B, P_B,
// eps_light, eps_brdf, eps_estimate, eps_bound, suggested_face_size, suggested_view_size,
// epsilon, and the accuracy curves (Fig. 5.5) under "curves".
nlohmann::json AnalysisJson(const ShrmAnalysis& a);
nlohmann::json TimingsJson(const std::vector<StageTiming>& timings);

// Writes `j` (pretty-printed) to `path` atomically (temporary file, then rename).
[[nodiscard]] absl::Status WriteJsonFile(const std::string& path, const nlohmann::json& j);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_REPORT_H_
