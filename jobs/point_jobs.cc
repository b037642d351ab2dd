#include "jobs/point_jobs.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
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

ibl::LevelError MeasureIrradianceSh9(const EnvMap& map, const Mat3& rotation,
                                     std::span<const double> e9, int count, int threads) {
  // The check's seed (the IBL job's SH9 check uses the same normals).
  constexpr uint64_t kSeed = 0x5eed'1b10'0003 + 1000;
  constexpr int kFace = 16;
  ibl::SpecularLevel level;
  level.face_size = kFace;
  level.roughness = level.alpha = 1;
  absl::StatusOr<RadianceCube> cube = IrradianceCube(e9, 3, kFace);
  if (!cube.ok()) return {};  // e9 of the wrong size: nothing measured
  level.cube = *std::move(cube);
  for (float& v : level.cube.data) v = static_cast<float>(v / kPi);  // E / pi: the Lambert sum
  return ibl::MeasureLevelError(map, ibl::SpecularLobe::kLambert, level, rotation, count, kSeed,
                                threads);
}

}  // namespace shrm::jobs
