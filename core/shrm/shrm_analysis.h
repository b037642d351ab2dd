// Orders and error estimates of an SHRM (Ramamoorthi & Hanrahan sec. 5.5):
//   eq. 5.16: F_L, the smallest lighting order capturing 1 - eps of integral L^2;
//   eqs. 5.17/5.18: (F_rho, P_rho), the smallest P and then the smallest F such that
//             sum_{l<=F, p<=P, |q|<=min(l,p)} rho_lpq^2 >= (1 - eps) rho_tot (q != 0 counted
//             twice);
//   minimum rule: F_B = min(F_L, F_rho), P_B = P_rho, eps_B ~ min(eps_L, eps_rho);
//   eq. 5.19 (conservative bound), in the norm of docs/shrm.md where the energy of B over
//             (R, view) is sum (4 pi / (2l + 1)) |B_lmpq|^2 (B_lmpq = L_lm rho_lpq, no Lambda):
//             B_res(F) = sum_c (4 pi / (2F + 3)) (eps_L L_tot)_c (eps_rho(F, P_B) rho_tot)_c
//             (the l > F tail) plus the p > P_B tail of l <= F (exact for the computed rho_lpq,
//             worst-case band weight for rho energy outside them),
//             eps_B <= B_res / (E_B(F, P_B) + B_res);
//   sec. 5.5.2: S_B ~ 10 F_B (and T_B ~ 10 P_B);
//   Fig. 5.5: accuracy curves vs F (lighting, BRDF, B relative to the highest available order,
//             the minimum estimate and the bound).
// Channels are combined by summing their energies (RGB energy).
#ifndef SHRM_CORE_SHRM_SHRM_ANALYSIS_H_
#define SHRM_CORE_SHRM_SHRM_ANALYSIS_H_

#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/brdf/brdf_coefficients.h"

namespace shrm {

// Fraction of the BRDF energy captured by l <= f, p <= p (all channels summed, q != 0 twice).
// total: brdf.total_energy summed over channels, or the sum of all stored coefficients when
// total_energy is empty.
double BrdfCapturedFraction(const BrdfCoefficients& brdf, int f, int p);

struct ShrmAnalysisOptions {
  double epsilon = 0.03;
  // BRDF orders from elsewhere (e.g. core/brdf's SelectBrdfOrders); -1 = select here.
  int f_brdf = -1;
  int p_brdf = -1;
  // The orders were chosen by the user: F_B = f_brdf, P_B = p_brdf (no minimum rule); the
  // estimates and the bound are evaluated at those orders.
  bool explicit_orders = false;
};

struct ShrmAnalysis {
  double epsilon = 0;
  int f_light = -1;  // -1: not reached within the lighting's degree (then F_B = F_rho)
  int f_brdf = 0, p_brdf = 0;
  bool brdf_tolerance_met = true;
  int f_b = 0, p_b = 0;
  double eps_light = 0;                    // 1 - captured lighting energy at F_B
  double eps_brdf = 0;                     // 1 - captured BRDF energy at (F_B, P_B)
  double eps_estimate = 0;                 // min(eps_light, eps_brdf)
  double eps_bound = 0;                    // eq. 5.19 at F_B
  int suggested_face_size = 0;             // S_B ~ 10 F_B
  int suggested_view_size = 0;             // T_B ~ 10 P_B (at least 1)
  double light_total = 0, brdf_total = 0;  // summed over channels
  int reference_f = 0;                     // highest order available for B's accuracy curve
  struct CurvePoint {
    int f = 0;
    double light = 0;         // captured lighting fraction (eq. 5.16)
    double brdf = 0;          // captured BRDF fraction at P_B
    double b = 0;             // E_B(f, P_B) / E_B(reference_f, P_B)
    double min_estimate = 0;  // 1 - min(eps_L, eps_rho)
    double bound = 0;         // 1 - eps_bound (eq. 5.19)
  };
  std::vector<CurvePoint> curves;  // f = 0 .. reference_f
};

// light: real L_lm (degree light_lmax, channel-interleaved); light_total: integral L_c^2 dw per
// channel (MapEnergy of core/shrm/orders.h), or empty to use the coefficient sum.
// Errors: epsilon not in (0, 1), negative orders, size or channel mismatches.
absl::StatusOr<ShrmAnalysis> AnalyzeShrm(int light_lmax, int channels,
                                         std::span<const double> light,
                                         std::span<const double> light_total,
                                         const BrdfCoefficients& brdf,
                                         const ShrmAnalysisOptions& options = {});

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_ANALYSIS_H_
