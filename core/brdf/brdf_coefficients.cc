#include "core/brdf/brdf_coefficients.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace shrm {

const char* ViewVariableName(ViewVariable v) {
  return v == ViewVariable::kNormal ? "normal" : "view";
}

namespace {

template <typename T>
double FresnelAtImpl(std::span<const T> table, int channels, double cos_theta_n, int c) {
  constexpr int K = kFresnelIntervals;
  if (channels < 1 || table.size() != static_cast<size_t>(K + 1) * channels) return 1.0;
  const double t = (1.0 - std::clamp(cos_theta_n, 0.0, 1.0)) * K;
  const int k = std::clamp(static_cast<int>(t), 0, K - 1);
  const double u = std::clamp(t - k, 0.0, 1.0);
  auto at = [&](int i) {
    return static_cast<double>(table[static_cast<size_t>(i) * channels + c]);
  };
  const double p1 = at(k), p2 = at(k + 1);
  // Ghost nodes beyond both ends: the quadratic through the three nearest.
  const double p0 = k == 0 ? 3.0 * (p1 - p2) + at(2) : at(k - 1);
  const double p3 = k + 2 <= K ? at(k + 2) : 3.0 * (p2 - p1) + at(K - 2);
  const double v =
      p1 +
      0.5 * u * (p2 - p0 + u * (2 * p0 - 5 * p1 + 4 * p2 - p3 + u * (3 * (p1 - p2) + p3 - p0)));
  // The cubic may overshoot between nodes of a steep table: never below half the smaller node.
  return std::max(v, 0.5 * std::min(p1, p2));
}

}  // namespace

double FresnelAt(std::span<const double> table, int channels, double cos_theta_n, int c) {
  return FresnelAtImpl(table, channels, cos_theta_n, c);
}
double FresnelAt(std::span<const float> table, int channels, double cos_theta_n, int c) {
  return FresnelAtImpl(table, channels, cos_theta_n, c);
}

double FresnelFactor(std::span<const float> table, double cos_theta_n, int c) {
  const int ch = FresnelChannels(table.size());
  if (ch < 1) return 1.0;
  return FresnelAtImpl(table, ch, cos_theta_n, std::min(c, ch - 1));
}

double CapturedFraction(const BrdfCoefficients& coeffs, int F, int P, int channel) {
  F = std::min(F, coeffs.lmax);
  P = std::min(P, coeffs.pmax);
  if (F < 0 || P < 0) return 0.0;
  double worst = std::numeric_limits<double>::infinity();
  for (int c = 0; c < coeffs.channels; ++c) {
    if (channel >= 0 && c != channel) continue;
    double sum = 0;
    for (int l = 0; l <= F; ++l) {
      for (int p = 0; p <= P; ++p) {
        for (int q = 0; q <= std::min(l, p); ++q) {
          const double v = coeffs.values[coeffs.Index(l, p, q, c)];
          sum += (q == 0 ? 1.0 : 2.0) * v * v;
        }
      }
    }
    const double total = c < static_cast<int>(coeffs.total_energy.size())
                             ? coeffs.total_energy[c]
                             : std::numeric_limits<double>::quiet_NaN();
    // A channel with no energy (e.g. a black channel) is captured exactly.
    const double fraction = total > 0 ? sum / total : 1.0;
    worst = std::min(worst, fraction);
  }
  return worst;
}

BrdfCoefficients TruncateBrdfCoefficients(const BrdfCoefficients& coeffs, int F, int P) {
  BrdfCoefficients out;
  out.lmax = std::clamp(F, 0, coeffs.lmax);
  out.pmax = std::clamp(P, 0, coeffs.pmax);
  out.channels = coeffs.channels;
  out.reparam = coeffs.reparam;
  out.view = coeffs.view;
  out.total_energy = coeffs.total_energy;
  out.fresnel = coeffs.fresnel;
  out.values.assign(
      static_cast<size_t>(out.lmax + 1) * (out.pmax + 1) * (out.pmax + 1) * out.channels, 0.0);
  for (int l = 0; l <= out.lmax; ++l) {
    for (int p = 0; p <= out.pmax; ++p) {
      for (int q = 0; q <= std::min(l, p); ++q) {
        for (int c = 0; c < out.channels; ++c) {
          out.values[out.Index(l, p, q, c)] = coeffs.values[coeffs.Index(l, p, q, c)];
        }
      }
    }
  }
  return out;
}

}  // namespace shrm
