#include "jobs/point_jobs.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/base/cubemap.h"
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

absl::StatusOr<ibl::LevelCheck> IrradianceSh9Check(std::span<const double> e9, int count,
                                                   ibl::SpecularLevel* level, int face_size,
                                                   uint64_t seed) {
  level->face_size = face_size;
  level->roughness = level->alpha = 1;
  SHRM_ASSIGN_OR_RETURN(RadianceCube cube, IrradianceCube(e9, 3, face_size));
  level->cube = std::move(cube);
  for (float& v : level->cube.data) v = static_cast<float>(v / kPi);  // E / pi: the Lambert sum
  return ibl::LevelCheck{ibl::SpecularLobe::kLambert, level, count, seed};
}

ibl::LevelError MeasureIrradianceSh9(const EnvMap& map, const Mat3& rotation,
                                     std::span<const double> e9, int count, int threads,
                                     const ibl::PixelSumTable* table) {
  ibl::SpecularLevel level;
  const absl::StatusOr<ibl::LevelCheck> check = IrradianceSh9Check(e9, count, &level);
  if (!check.ok()) return {};  // e9 of the wrong size: nothing measured
  return ibl::MeasureLevelErrors(map, {&*check, 1}, rotation, threads, table)[0];
}

Image RadianceCrossImage(const RadianceCube& cube) {
  const int s = cube.face_size;
  Image img;
  img.width = 4 * s;
  img.height = 3 * s;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(img.width) * img.height * 3, 0.0f);
  // (column, row) cell of each GL face in the horizontal cross.
  constexpr int kCell[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
  for (int f = 0; f < kCubeFaceCount; ++f)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x)
        for (int c = 0; c < 3; ++c)
          img.pixels[((static_cast<size_t>(kCell[f][1]) * s + y) * img.width + kCell[f][0] * s +
                      x) *
                         3 +
                     c] = cube.data[cube.Index(f, x, y, std::min(c, cube.channels - 1))];
  return img;
}

}  // namespace shrm::jobs
