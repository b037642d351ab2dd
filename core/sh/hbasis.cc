#include "core/sh/hbasis.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/sh/sh.h"

namespace shrm {

std::array<double, kHBasisCount> EvalHBasis(const Vec3& n) {
  const double c1 = 1.0 / std::sqrt(2.0 * kPi);
  const double c3 = std::sqrt(3.0 / (2.0 * kPi));
  const double c15 = std::sqrt(15.0 / (2.0 * kPi));
  return {c1,                                    // eq. 8
          -c3 * n.y,                             // eq. 9
          c3 * (2.0 * n.z - 1.0),                // eq. 10
          -c3 * n.x,                             // eq. 11
          c15 * n.x * n.y,                       // eq. 12
          0.5 * c15 * (n.x * n.x - n.y * n.y)};  // eq. 13
}

absl::StatusOr<double> EvalHBasisSeries(std::span<const double> coeffs, const Vec3& n) {
  if (coeffs.size() != kHBasis4Count && coeffs.size() != kHBasisCount) {
    return absl::InvalidArgumentError(
        absl::StrCat("H-basis expansions have 4 or 6 coefficients, got ", coeffs.size()));
  }
  const auto h = EvalHBasis(n);
  double sum = 0;
  for (size_t i = 0; i < coeffs.size(); ++i) sum += coeffs[i] * h[i];
  return sum;
}

std::array<double, kHBasisCount> ProjectHBasis(const HemisphereRule& rule,
                                               const std::function<double(const Vec3&)>& f) {
  std::array<double, kHBasisCount> out{};
  for (int j = 0; j < rule.num_theta(); ++j) {
    const double w = rule.weight[j] * rule.dphi;
    for (int k = 0; k < rule.num_phi(); ++k) {
      const Vec3 n = rule.Direction(j, k);
      const double v = w * f(n);
      const auto h = EvalHBasis(n);
      for (int i = 0; i < kHBasisCount; ++i) out[i] += v * h[i];
    }
  }
  return out;
}

absl::StatusOr<HBasisConversion> HBasisConversion::Create(int sh_lmax) {
  if (sh_lmax < 0) {
    return absl::InvalidArgumentError(absl::StrCat("SH degree must be >= 0, got ", sh_lmax));
  }
  HBasisConversion conv(sh_lmax);
  // Integrands H^i Y_lm are polynomials of degree <= sh_lmax + 2 in (x, y, z).
  const int degree = sh_lmax + 2;
  SHRM_ASSIGN_OR_RETURN(HemisphereRule rule, MakeHemisphereRule(degree / 2 + 1, degree + 1));
  const int nc = conv.cols();
  conv.matrix_.assign(static_cast<size_t>(kHBasisCount) * nc, 0.0);
  std::vector<double> y(nc);
  for (int j = 0; j < rule.num_theta(); ++j) {
    const double w = rule.weight[j] * rule.dphi;
    for (int k = 0; k < rule.num_phi(); ++k) {
      const Vec3 n = rule.Direction(j, k);
      EvalSh(sh_lmax, n, y);
      const auto h = EvalHBasis(n);
      for (int i = 0; i < kHBasisCount; ++i)
        for (int c = 0; c < nc; ++c)
          conv.matrix_[static_cast<size_t>(i) * nc + c] += w * h[i] * y[c];
    }
  }
  return conv;
}

absl::Status HBasisConversion::Apply(std::span<const double> sh, std::span<double> h) const {
  if (sh.size() != static_cast<size_t>(cols())) {
    return absl::InvalidArgumentError(
        absl::StrCat("expected ", cols(), " SH coefficients, got ", sh.size()));
  }
  if (h.size() != kHBasis4Count && h.size() != kHBasisCount) {
    return absl::InvalidArgumentError(
        absl::StrCat("H-basis expansions have 4 or 6 coefficients, got ", h.size()));
  }
  for (size_t i = 0; i < h.size(); ++i) {
    double sum = 0;
    for (int c = 0; c < cols(); ++c) sum += (*this)(static_cast<int>(i), c) * sh[c];
    h[i] = sum;
  }
  return absl::OkStatus();
}

double LambertianBandFactor(int l) {
  if (l < 0) return 0.0;
  if (l == 0) return kPi;
  if (l == 1) return 2.0 * kPi / 3.0;
  if (l % 2 == 1) return 0.0;
  double central = 1.0;  // l! / (2^l ((l/2)!)^2) = prod_{k=1..l/2} (2k - 1) / (2k)
  for (int k = 1; k <= l / 2; ++k) central *= (2.0 * k - 1.0) / (2.0 * k);
  const double sign = ((l / 2 - 1) % 2 == 0) ? 1.0 : -1.0;
  return 2.0 * kPi * sign / ((l + 2.0) * (l - 1.0)) * central;
}

double HabelBandFactor(int l) { return LambertianBandFactor(l) / kPi; }

absl::Status IrradianceShFromRadianceSh(int lmax, std::span<const double> radiance,
                                        std::span<double> irradiance) {
  if (lmax < 0)
    return absl::InvalidArgumentError(absl::StrCat("SH degree must be >= 0, got ", lmax));
  if (radiance.size() != static_cast<size_t>(ShCount(lmax)) ||
      irradiance.size() != static_cast<size_t>(ShCount(lmax))) {
    return absl::InvalidArgumentError(absl::StrCat("expected ", ShCount(lmax),
                                                   " coefficients, got ", radiance.size(), " and ",
                                                   irradiance.size()));
  }
  for (int l = 0; l <= lmax; ++l) {
    const double a = LambertianBandFactor(l);
    for (int m = -l; m <= l; ++m) irradiance[ShIndex(l, m)] = a * radiance[ShIndex(l, m)];
  }
  return absl::OkStatus();
}

double HemisphereImse(const HemisphereRule& rule, const std::function<double(const Vec3&)>& approx,
                      const std::function<double(const Vec3&)>& truth) {
  double sum = 0;
  for (int j = 0; j < rule.num_theta(); ++j) {
    double ring = 0;
    for (int k = 0; k < rule.num_phi(); ++k) {
      const Vec3 n = rule.Direction(j, k);
      const double d = approx(n) - truth(n);
      ring += d * d;
    }
    sum += rule.weight[j] * ring;
  }
  return sum * rule.dphi;
}

}  // namespace shrm
