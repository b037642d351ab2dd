#include "viewer/irradiance_cpu.h"

#include <cmath>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/sh/hbasis.h"
#include "core/sh/sh.h"
#include "core/sh/tangent_irradiance.h"

namespace shrm::viewer {

std::string_view IrradianceBasisName(IrradianceBasis b) {
  switch (b) {
    case IrradianceBasis::kH4:
      return "h4";
    case IrradianceBasis::kH6:
      return "h6";
    case IrradianceBasis::kSh9:
      return "sh9";
  }
  return "?";
}

absl::StatusOr<IrradianceBasis> ParseIrradianceBasis(std::string_view name) {
  for (IrradianceBasis b : {IrradianceBasis::kH4, IrradianceBasis::kH6, IrradianceBasis::kSh9})
    if (name == IrradianceBasisName(b)) return b;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown irradiance basis '", std::string(name), "'; valid: h4, h6, sh9"));
}

int IrradianceCoefficientCount(IrradianceBasis b) {
  return b == IrradianceBasis::kH4 ? kHBasis4Count : b == IrradianceBasis::kH6 ? kHBasisCount : 9;
}

int IrradianceLightLmax(IrradianceBasis b) { return b == IrradianceBasis::kSh9 ? 2 : 4; }

absl::Status TangentIrradianceRgb(std::span<const double> world_sh_rgb,
                                  const Mat3& world_from_tangent, IrradianceBasis b,
                                  std::span<double> out) {
  const int have = static_cast<int>(std::lround(std::sqrt(world_sh_rgb.size() / 3.0))) - 1;
  if (have < 2 || static_cast<size_t>(ShCount(have)) * 3 != world_sh_rgb.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("irradiance: ", world_sh_rgb.size(),
                     " values is not a complete RGB SH vector of degree >= 2"));
  }
  const int lmax = std::min(have, IrradianceLightLmax(b));
  const int n = IrradianceCoefficientCount(b);
  if (out.size() != static_cast<size_t>(n) * 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("irradiance: out has ", out.size(), " values, expected ", n * 3));
  }
  std::vector<double> in(ShCount(lmax)), coeffs(n);
  for (int c = 0; c < 3; ++c) {
    for (int k = 0; k < ShCount(lmax); ++k) in[k] = world_sh_rgb[3 * k + c];
    if (b == IrradianceBasis::kSh9) {
      SHRM_RETURN_IF_ERROR(TangentIrradianceSh(in, world_from_tangent, 2, coeffs));
    } else {
      SHRM_RETURN_IF_ERROR(TangentIrradianceH(in, world_from_tangent, n, coeffs));
    }
    for (int i = 0; i < n; ++i) out[3 * i + c] = coeffs[i];
  }
  return absl::OkStatus();
}

std::array<double, 3> EvalTangentIrradiance(IrradianceBasis b, std::span<const double> coeffs_rgb,
                                            const Vec3& tangent_normal) {
  const Vec3 m = tangent_normal.Normalized();
  std::array<double, 9> y{};
  if (b == IrradianceBasis::kSh9) {
    EvalSh(2, m, y);
  } else {
    const std::array<double, kHBasisCount> h = EvalHBasis(m);
    std::copy(h.begin(), h.end(), y.begin());
  }
  std::array<double, 3> e{};
  for (int i = 0; i < IrradianceCoefficientCount(b); ++i)
    for (int c = 0; c < 3; ++c) e[c] += coeffs_rgb[3 * i + c] * y[i];
  return e;
}

std::array<double, 3> IrradianceAlbedo(const Brdf* brdf) {
  std::array<double, 3> a{1, 1, 1};
  if (brdf == nullptr || !absl::StartsWith(brdf->spec(), "lambert")) return a;
  const Vec3 z{0, 0, 1};
  for (int c = 0; c < 3; ++c)
    a[c] = kPi * brdf->Transfer(z, z, z, std::min(c, brdf->channels() - 1));
  return a;
}

absl::StatusOr<std::array<double, 3>> IrradiancePixel(std::span<const double> world_sh_rgb,
                                                      const Mat3& world_from_tangent,
                                                      IrradianceBasis b, const Vec3& tangent_normal,
                                                      const std::array<double, 3>& albedo) {
  std::vector<double> coeffs(static_cast<size_t>(IrradianceCoefficientCount(b)) * 3);
  SHRM_RETURN_IF_ERROR(TangentIrradianceRgb(world_sh_rgb, world_from_tangent, b, coeffs));
  std::array<double, 3> e = EvalTangentIrradiance(b, coeffs, tangent_normal);
  for (int c = 0; c < 3; ++c) e[c] *= albedo[c] / kPi;
  return e;
}

}  // namespace shrm::viewer
