#include "core/shrm/shrm_analysis.h"

#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/geometry.h"
#include "core/sh/sh.h"
#include "core/shrm/orders.h"

namespace shrm {
namespace {

// rho energy of band l up to p (per channel), q != 0 twice.
double RhoBand(const BrdfCoefficients& b, int l, int p, int c) {
  double e = 0;
  for (int pp = 0; pp <= std::min(p, b.pmax); ++pp)
    for (int q = -std::min(l, pp); q <= std::min(l, pp); ++q) {
      const double r = b.at(l, pp, q, c);
      e += r * r;
    }
  return e;
}

double RhoTotal(const BrdfCoefficients& b, int c) {
  if (static_cast<int>(b.total_energy.size()) == b.channels) return b.total_energy[c];
  double e = 0;
  for (int l = 0; l <= b.lmax; ++l) e += RhoBand(b, l, b.pmax, c);
  return e;
}

}  // namespace

double BrdfCapturedFraction(const BrdfCoefficients& brdf, int f, int p) {
  double num = 0, den = 0;
  for (int c = 0; c < brdf.channels; ++c) {
    for (int l = 0; l <= std::min(f, brdf.lmax); ++l) num += RhoBand(brdf, l, p, c);
    den += RhoTotal(brdf, c);
  }
  return den > 0 ? num / den : 1.0;
}

absl::StatusOr<ShrmAnalysis> AnalyzeShrm(int light_lmax, int channels,
                                         std::span<const double> light,
                                         std::span<const double> light_total,
                                         const BrdfCoefficients& brdf,
                                         const ShrmAnalysisOptions& options) {
  const double eps = options.epsilon;
  if (!(eps > 0 && eps < 1))
    return absl::InvalidArgumentError(absl::StrCat("analysis: epsilon ", eps, " not in (0, 1)"));
  if (light_lmax < 0 || brdf.lmax < 0 || brdf.pmax < 0 || channels < 1)
    return absl::InvalidArgumentError(absl::StrCat("analysis: negative order or channels (",
                                                   light_lmax, ", ", brdf.lmax, ", ", brdf.pmax,
                                                   ", ", channels, ")"));
  if (light.size() != static_cast<size_t>(ShCount(light_lmax)) * channels)
    return absl::InvalidArgumentError(
        absl::StrCat("analysis: lighting has ", light.size(), " values"));
  if (!light_total.empty() && static_cast<int>(light_total.size()) != channels)
    return absl::InvalidArgumentError("analysis: light_total must have one value per channel");
  if (brdf.channels != 1 && brdf.channels != channels)
    return absl::InvalidArgumentError(absl::StrCat("analysis: mismatched channels: BRDF ",
                                                   brdf.channels, ", lighting ", channels));
  if (options.f_brdf > brdf.lmax || options.p_brdf > brdf.pmax || options.f_brdf < -1 ||
      options.p_brdf < -1)
    return absl::InvalidArgumentError("analysis: given BRDF orders outside the coefficients");

  ShrmAnalysis a;
  a.epsilon = eps;
  // Lighting: per-channel band energies and totals, summed.
  const std::vector<double> bands = BandEnergies(light_lmax, channels, light);
  std::vector<double> lband(static_cast<size_t>(light_lmax + 1) * channels);
  std::vector<double> ltot(channels, 0.0);
  for (int l = 0; l <= light_lmax; ++l)
    for (int c = 0; c < channels; ++c) lband[l * channels + c] = bands[l * channels + c];
  for (int c = 0; c < channels; ++c) {
    if (!light_total.empty()) {
      ltot[c] = light_total[c];
    } else {
      for (int l = 0; l <= light_lmax; ++l) ltot[c] += lband[l * channels + c];
    }
    a.light_total += ltot[c];
  }
  std::vector<double> lsum(light_lmax + 1, 0.0);
  for (int l = 0; l <= light_lmax; ++l)
    for (int c = 0; c < channels; ++c) lsum[l] += lband[l * channels + c];
  a.f_light = OrderForTolerance(lsum, a.light_total, eps);
  auto light_captured = [&](int f) { return CapturedFraction(lsum, a.light_total, f); };

  // BRDF: smallest P, then smallest F.
  if (options.f_brdf >= 0 && options.p_brdf >= 0) {
    a.f_brdf = options.f_brdf;
    a.p_brdf = options.p_brdf;
    a.brdf_tolerance_met = BrdfCapturedFraction(brdf, a.f_brdf, a.p_brdf) >= 1 - eps;
  } else {
    a.brdf_tolerance_met = false;
    a.f_brdf = brdf.lmax;
    a.p_brdf = brdf.pmax;
    for (int p = 0; p <= brdf.pmax; ++p)
      if (BrdfCapturedFraction(brdf, brdf.lmax, p) >= 1 - eps) {
        a.p_brdf = p;
        for (int f = 0; f <= brdf.lmax; ++f)
          if (BrdfCapturedFraction(brdf, f, p) >= 1 - eps) {
            a.f_brdf = f;
            break;
          }
        a.brdf_tolerance_met = true;
        break;
      }
  }
  for (int c = 0; c < brdf.channels; ++c) a.brdf_total += RhoTotal(brdf, c);

  const int fmax = std::min(light_lmax, brdf.lmax);
  a.f_b = options.explicit_orders
              ? std::min(a.f_brdf, fmax)
              : std::min(a.f_light < 0 ? a.f_brdf : std::min(a.f_light, a.f_brdf), fmax);
  a.p_b = a.p_brdf;
  a.suggested_face_size = std::max(1, 10 * a.f_b);
  a.suggested_view_size = std::max(1, 10 * a.p_b);
  a.reference_f = fmax;

  // Energy of B per band (all channels; grey BRDFs apply to every lighting channel).
  auto bc = [&](int c) { return brdf.channels == 1 ? 0 : c; };
  // RhoBand at P_B and at the computed pmax, per BRDF channel and band, once: the curves below
  // ask for them O(F^2) times (the same sums, so the same values as calling RhoBand there).
  const int nlb = brdf.lmax + 1;
  std::vector<double> rho_pb(static_cast<size_t>(brdf.channels) * nlb),
      rho_pmax(static_cast<size_t>(brdf.channels) * nlb), rho_total(brdf.channels);
  for (int c = 0; c < brdf.channels; ++c) {
    for (int l = 0; l <= brdf.lmax; ++l) {
      rho_pb[c * nlb + l] = RhoBand(brdf, l, a.p_b, c);
      rho_pmax[c * nlb + l] = RhoBand(brdf, l, brdf.pmax, c);
    }
    rho_total[c] = RhoTotal(brdf, c);
  }
  // BrdfCapturedFraction(brdf, f, P_B) from the tables (its sums in its order).
  auto captured_at_pb = [&](int f) {
    double num = 0, den = 0;
    for (int c = 0; c < brdf.channels; ++c) {
      for (int l = 0; l <= std::min(f, brdf.lmax); ++l) num += rho_pb[c * nlb + l];
      den += rho_total[c];
    }
    return den > 0 ? num / den : 1.0;
  };
  std::vector<double> eb(fmax + 1, 0.0);  // E_B band l at P_B
  for (int l = 0; l <= fmax; ++l)
    for (int c = 0; c < channels; ++c)
      eb[l] += 4 * kPi / (2 * l + 1) * lband[l * channels + c] * rho_pb[bc(c) * nlb + l];
  std::vector<double> eb_cum(fmax + 1);
  for (int l = 0; l <= fmax; ++l) eb_cum[l] = eb[l] + (l ? eb_cum[l - 1] : 0.0);

  // Eq. 5.19 generalized to (F, P): the energy of B outside l <= f, p <= P_B is bounded by
  //  (a) the l > f tail: (4 pi / (2f + 3)) (eps_L L_tot)(residual rho energy), as in eq. 5.19;
  //  (b) the p > P_B tail for l <= f: sum_l (4 pi / (2l + 1)) |L_l|^2 rho_{l, p > P_B}, exact
  //      for the computed coefficients (p <= brdf.pmax), plus the rho energy outside the computed
  //      set times the largest (4 pi / (2l + 1)) |L_l|^2 (worst case: all of it in that band).
  auto bound = [&](int f) {
    double res = 0;
    for (int c = 0; c < channels; ++c) {
      double lcap = 0;
      for (int l = 0; l <= std::min(f, light_lmax); ++l) lcap += lband[l * channels + c];
      const double* pb = &rho_pb[bc(c) * nlb];
      const double* pmax = &rho_pmax[bc(c) * nlb];
      double rcap = 0;
      for (int l = 0; l <= std::min(f, brdf.lmax); ++l) rcap += pb[l];
      const double lres = std::max(0.0, ltot[c] - lcap);
      const double rres = std::max(0.0, rho_total[bc(c)] - rcap);
      res += 4 * kPi / (2 * f + 3) * lres * rres;
      double computed = 0, worst_weight = 0;
      for (int l = 0; l <= brdf.lmax; ++l) computed += pmax[l];
      const double outside = std::max(0.0, rho_total[bc(c)] - computed);
      for (int l = 0; l <= std::min({f, light_lmax, brdf.lmax}); ++l) {
        const double w = 4 * kPi / (2 * l + 1) * lband[l * channels + c];
        res += w * (pmax[l] - pb[l]);
        worst_weight = std::max(worst_weight, w);
      }
      res += worst_weight * outside;
    }
    const double e = eb_cum[std::min(f, fmax)];
    return res + e > 0 ? res / (e + res) : 0.0;
  };

  a.eps_light = 1 - light_captured(a.f_b);
  a.eps_brdf = 1 - BrdfCapturedFraction(brdf, a.f_b, a.p_b);
  a.eps_estimate = std::min(a.eps_light, a.eps_brdf);
  a.eps_bound = bound(a.f_b);
  for (int f = 0; f <= fmax; ++f) {
    ShrmAnalysis::CurvePoint pt;
    pt.f = f;
    pt.light = light_captured(f);
    pt.brdf = captured_at_pb(f);
    pt.b = eb_cum[fmax] > 0 ? eb_cum[f] / eb_cum[fmax] : 1.0;
    pt.min_estimate = 1 - std::min(1 - pt.light, 1 - pt.brdf);
    pt.bound = 1 - bound(f);
    a.curves.push_back(pt);
  }
  return a;
}

}  // namespace shrm
