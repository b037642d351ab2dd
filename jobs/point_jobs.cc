#include "jobs/point_jobs.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/shrm/shrm_explicit.h"

namespace shrm::jobs {

absl::StatusOr<Vec3> UnitDirection(const Vec3& v, absl::string_view what) {
  const double len = v.Norm();
  if (!std::isfinite(len) || len < 1e-12) {
    return absl::InvalidArgumentError(absl::StrCat(what, " must be a nonzero finite vector"));
  }
  if (std::abs(len - 1) <= kUnitTolerance) return v;
  return v * (1.0 / len);
}

absl::StatusOr<std::vector<double>> IrradianceSh9(const EnvMap& map, const Mat3& rotation,
                                                  int threads) {
  SHRM_ASSIGN_OR_RETURN(std::vector<double> light, LightingCoefficients(map, 2, rotation, threads));
  return IrradianceCoefficients(2, 3, light);
}

}  // namespace shrm::jobs
