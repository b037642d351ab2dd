// The analyze job (`shrm analyze`, the service's Analyze call): orders and error estimates
// (SHRM paper sec. 5.5) of a BRDF, or of a map and a BRDF, for several tolerances; the
// lighting-only analysis (eqs. 5.15-5.16) runs in-process only (docs/cli.md).
#ifndef SHRM_JOBS_ANALYZE_JOB_H_
#define SHRM_JOBS_ANALYZE_JOB_H_

#include <nlohmann/json.hpp>
#include <vector>

#include "absl/status/status.h"

namespace shrm::jobs {

// The tolerances analysed when none are given.
inline const std::vector<double> kDefaultAnalyzeEpsilons = {0.2, 0.1, 0.05, 0.01};

// Each tolerance in (0, 1).
[[nodiscard]] absl::Status ValidateAnalyzeEpsilons(const std::vector<double>& epsilons);

// One BRDF-only result (`analyze --brdf --json`): epsilon, F_rho, P_rho, eps_brdf, and F_B, P_B
// equal to them, with the lighting's keys null.
nlohmann::json BrdfOrdersJson(double epsilon, int f_rho, int p_rho, double eps_brdf);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_ANALYZE_JOB_H_
