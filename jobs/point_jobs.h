// The reference and irradiance jobs (`shrm reference`, `shrm irradiance`, the service's Reference
// and Irradiance calls): brute-force reflected radiance at one (N or T, V) over the map's pixels,
// and the Lambertian irradiance coefficients E_lm = A_l L_lm, l <= 2 (Ramamoorthi & Hanrahan's
// irradiance environment maps; docs/shrm.md).
#ifndef SHRM_JOBS_POINT_JOBS_H_
#define SHRM_JOBS_POINT_JOBS_H_

#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/base/geometry.h"
#include "core/envmap/envmap.h"

namespace shrm::jobs {

// |length - 1| below which a direction counts as unit (a few ulps of rounding): such vectors are
// used as they are, so a direction sent over the wire gives the embedded run's sum bit for bit.
inline constexpr double kUnitTolerance = 1e-14;

// `v` as a unit vector; InvalidArgument naming `what` for a zero or non-finite vector.
absl::StatusOr<Vec3> UnitDirection(const Vec3& v, absl::string_view what);

// The irradiance job's result: E_lm for l <= 2 in the SH frame (docs/conventions.md), 9 x RGB,
// rgb[(l(l+1)+m) * 3 + c], from the map's L_lm rotated by `rotation`.
inline constexpr int kIrradianceCoefficientCount = 27;
absl::StatusOr<std::vector<double>> IrradianceSh9(const EnvMap& map, const Mat3& rotation,
                                                  int threads);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_POINT_JOBS_H_
