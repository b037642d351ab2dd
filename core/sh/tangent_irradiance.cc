#include "core/sh/tangent_irradiance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/sh/hbasis.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

// Entrywise tolerance of the orthonormality check of world_from_tangent (float-built frames).
constexpr double kFrameTol = 1e-6;
// Highest SH band that feeds the H-basis (T_h's l = 4 block, App. A; A_3 = 0).
constexpr int kHBandLimit = 4;

// Degree L of a complete coefficient vector of ShCount(L) entries, or -1.
int CompleteDegree(size_t size) {
  const int n = static_cast<int>(std::lround(std::sqrt(static_cast<double>(size))));
  return n >= 1 && static_cast<size_t>(n) * n == size ? n - 1 : -1;
}

double Det(const Mat3& a) {
  const auto& m = a.m;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
         m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

// Tangent-space irradiance SH of bands 0..lmax (lmax <= degree of the input, checked by callers).
absl::Status TangentIrradiance(std::span<const double> world_radiance_sh,
                               const Mat3& world_from_tangent, int lmax, std::span<double> out) {
  // A mirrored frame (t x b = -n) is the proper frame (t, -b, n) followed by y -> -y.
  Mat3 proper = world_from_tangent;
  const bool mirrored = Det(world_from_tangent) < 0;
  if (mirrored) {
    for (int r = 0; r < 3; ++r) proper.m[r][1] = -proper.m[r][1];
  }
  if (absl::Status s = ValidateRotationMatrix(proper, kFrameTol); !s.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("world_from_tangent must have orthonormal columns (t, b, n): ", s.message()));
  }
  // Q maps tangent-space directions to the world's SH frame (x_s = X, y_s = -Z, z_s = Y), so
  // L_tangent(d) = L(Q d) = L(Rot^-1 d) with Rot = Q^T: coefficients D(Q^T) c (rotation.h).
  const Mat3 sh_from_world{{{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}}};
  const Mat3 q = sh_from_world * proper;
  RotateSh(lmax, q.Transposed(), world_radiance_sh.first(ShCount(lmax)), out);
  for (int l = 0; l <= lmax; ++l) {
    const double a = LambertianBandFactor(l);
    for (int m = -l; m <= l; ++m) {
      // y -> -y maps phi to -phi: the sine (m < 0) coefficients change sign.
      out[ShIndex(l, m)] *= (mirrored && m < 0) ? -a : a;
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status TangentIrradianceSh(std::span<const double> world_radiance_sh,
                                 const Mat3& world_from_tangent, int lmax, std::span<double> out) {
  if (lmax < 0 || lmax > kMaxRotationLmax) {
    return absl::InvalidArgumentError(absl::StrCat("tangent irradiance: lmax = ", lmax,
                                                   " is out of range; valid range [0, ",
                                                   kMaxRotationLmax, "]"));
  }
  const int degree = CompleteDegree(world_radiance_sh.size());
  if (degree < lmax) {
    return absl::InvalidArgumentError(absl::StrCat(
        "tangent irradiance: world_radiance_sh has ", world_radiance_sh.size(),
        " coefficients; expected a complete (L + 1)^2 vector with L >= lmax = ", lmax));
  }
  if (out.size() != static_cast<size_t>(ShCount(lmax))) {
    return absl::InvalidArgumentError(absl::StrCat("tangent irradiance: out has ", out.size(),
                                                   " entries, expected ", ShCount(lmax)));
  }
  return TangentIrradiance(world_radiance_sh, world_from_tangent, lmax, out);
}

absl::Status TangentIrradianceH(std::span<const double> world_radiance_sh,
                                const Mat3& world_from_tangent, int num_h, std::span<double> out) {
  if (num_h != kHBasis4Count && num_h != kHBasisCount) {
    return absl::InvalidArgumentError(
        absl::StrCat("tangent irradiance: num_h = ", num_h, " must be 4 (H_4) or 6 (H_6)"));
  }
  if (out.size() != static_cast<size_t>(num_h)) {
    return absl::InvalidArgumentError(
        absl::StrCat("tangent irradiance: out has ", out.size(), " entries, expected ", num_h));
  }
  const int degree = CompleteDegree(world_radiance_sh.size());
  if (degree < 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        "tangent irradiance: world_radiance_sh has ", world_radiance_sh.size(),
        " coefficients; the H-basis needs a complete (L + 1)^2 vector with L >= 2 (9 or more)"));
  }
  const int lmax = std::min(degree, kHBandLimit);
  std::array<double, ShCount(kHBandLimit)> sh{};
  const std::span<double> e(sh.data(), ShCount(lmax));
  SHRM_RETURN_IF_ERROR(TangentIrradiance(world_radiance_sh, world_from_tangent, lmax, e));
  // T_h for degrees 2..4, built once.
  static const std::array<HBasisConversion, kHBandLimit - 1>* conversions = [] {
    return new std::array<HBasisConversion, kHBandLimit - 1>{
        *HBasisConversion::Create(2), *HBasisConversion::Create(3), *HBasisConversion::Create(4)};
  }();
  return (*conversions)[lmax - 2].Apply(e, out);
}

}  // namespace shrm
