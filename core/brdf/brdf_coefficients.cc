#include "core/brdf/brdf_coefficients.h"

#include <algorithm>
#include <limits>

namespace shrm {

const char* ViewVariableName(ViewVariable v) {
  return v == ViewVariable::kNormal ? "normal" : "view";
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
