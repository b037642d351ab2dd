#include "jobs/analyze_job.h"

#include "absl/strings/str_cat.h"

namespace shrm::jobs {

absl::Status ValidateAnalyzeEpsilons(const std::vector<double>& epsilons) {
  for (double e : epsilons) {
    if (!(e > 0 && e < 1)) {
      return absl::InvalidArgumentError(absl::StrCat("epsilon values must be in (0, 1), got ", e));
    }
  }
  return absl::OkStatus();
}

nlohmann::json BrdfOrdersJson(double epsilon, int f_rho, int p_rho, double eps_brdf) {
  return {{"epsilon", epsilon},   {"F_rho", f_rho},       {"P_rho", p_rho},
          {"eps_brdf", eps_brdf}, {"F_L", nullptr},       {"F_B", f_rho},
          {"P_B", p_rho},         {"eps_light", nullptr}, {"eps_bound", nullptr}};
}

}  // namespace shrm::jobs
