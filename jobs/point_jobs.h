// The reference and irradiance jobs (`shrm reference`, `shrm irradiance`, the service's Reference
// and Irradiance calls): brute-force reflected radiance at one (N or T, V) over the map's pixels,
// and the Lambertian irradiance coefficients E_lm = A_l L_lm, l <= 2 (Ramamoorthi & Hanrahan's
// irradiance environment maps; docs/shrm.md).
#ifndef SHRM_JOBS_POINT_JOBS_H_
#define SHRM_JOBS_POINT_JOBS_H_

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/base/geometry.h"
#include "core/envmap/envmap.h"
#include "core/ibl/split_sum.h"
#include "core/io/image.h"
#include "core/shrm/radiance_cube.h"

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

// Normals the irradiance job checks its coefficients at when none is given (`shrm irradiance
// --verify`, IrradianceRequest.verify), and the most it may ask for.
inline constexpr int kDefaultIrradianceVerify = 64;
inline constexpr int kMaxIrradianceVerify = 100000;
// The measured error of irradiance coefficients E_lm (IrradianceSh9's layout): E(n) / pi =
// sum_lm E_lm Y_lm(n) / pi, sampled on a 16 x 16 cube and looked up bilinearly, against the
// Lambertian pixel sum of the map (rotated by `rotation`) at `count` seeded normals
// (ibl::MeasureLevelError: relative per channel, with the floor of the split-sum checks). This is
// the l <= 2 truncation itself (Ramamoorthi & Hanrahan's 1-3% "on average" is an energy figure;
// per normal, 3-10% on the bundled maps): stated, not a tolerance. count = 0 gives zeros.
// `table`: the map's ibl::PixelSumTable when the caller has one.
ibl::LevelError MeasureIrradianceSh9(const EnvMap& map, const Mat3& rotation,
                                     std::span<const double> e9, int count, int threads,
                                     const ibl::PixelSumTable* table = nullptr);
// That check as one of ibl::MeasureLevelErrors' (for a job that measures several levels in one
// pass): the cube of E / pi into `level`, which must outlive the check; by default the 16 x 16
// cube and normals of MeasureIrradianceSh9. The IBL job gives its irradiance cube's face size and
// check seed instead: the same normals, whose pixel sums its irradiance check then shares.
inline constexpr uint64_t kIrradianceSh9Seed = 0x5eed'1b10'0003 + 1000;
absl::StatusOr<ibl::LevelCheck> IrradianceSh9Check(std::span<const double> e9, int count,
                                                   ibl::SpecularLevel* level, int face_size = 16,
                                                   uint64_t seed = kIrradianceSh9Seed);

// A radiance cube as a horizontal-cross image (4S x 3S: [. +Y . .] [-X +Z +X -Z] [. -Y . .], GL
// face orientation, as core/envmap reads it back; grey cubes repeated in RGB): the file of
// `shrm render`, `shrm live --view` and the Live call's view maps (EncodeImage kExrFloat).
Image RadianceCrossImage(const RadianceCube& cube);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_POINT_JOBS_H_
