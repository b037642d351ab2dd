// BRDF coefficients rho_lpq by the separable algorithm of the SHRM paper's eq. 5.22, their
// energy (right-hand sides of eqs. 5.17/5.18) and the order selection of sec. 5.6.2.
//
//   c_q(t_i, t_o) = (1/2pi) integral rho-hat(t_i, t_o, phi) cos(q phi) dphi
//   rho_lpq = (2 pi)^2 double-integral c_q(t_i, t_o) f_lq(t_i) f_pq(t_o) sin t_i sin t_o
// (docs/conventions.md, brdf_coefficients.h). Radially symmetric BRDFs (Phong) take the 1D path
// rho_{l00} = sqrt(4 pi) rho_l, rho_l = 2 pi integral rho-hat(t) lambda_l^0(cos t) sin t dt
// (eq. 5.17's rho_l), all other (l, p, q) zero.
//
// Order selection (eqs. 5.17/5.18, sec. 5.6.2): coefficients at generous (F_max, P_max), grown
// until the captured fraction reaches 1 - epsilon; then the smallest P for which some
// F <= F_max reaches it, then the smallest F for that P.
#ifndef SHRM_CORE_BRDF_BRDF_PROJECTION_H_
#define SHRM_CORE_BRDF_BRDF_PROJECTION_H_

#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_coefficients.h"

namespace shrm {

inline constexpr int kMaxBrdfLmax = 512;
inline constexpr int kMaxBrdfPmax = 64;

// Quadrature sizes; 0 picks the default (docs/brdf.md, "Sampling").
struct BrdfSampling {
  // Gauss-Legendre nodes in cos theta_i' over [-1, 1]; default max(4 lmax, 64, 3 h), h the
  // model's bandwidth_hint().lmax (its sharpness), so small lmax still resolves a sharp lobe.
  int theta_i = 0;
  // Gauss-Legendre nodes in cos theta_o' over [-1, 1]; default max(4 pmax + 16, 48).
  int theta_o = 0;
  // Azimuth nodes on [0, pi]; default max(2 pmax + 24, 32). Horizon-clipped models: Gauss-Legendre
  // on the visible arc [0, phi*] (no jump inside the rule); others: the trapezoid rule on
  // 2 * phi equispaced nodes around the circle (exact for cos(k phi), k < 2 phi).
  int phi = 0;
  // Radially symmetric 1D path: composite Gauss-Legendre panels in theta over [0, pi]
  // (an even number, so pi/2 is a panel edge); default max(128, 2 lmax, 2 h), 10 nodes each.
  int radial_panels = 0;
  // Energy integral: composite Gauss-Legendre panels in theta_i' (default max(48, lmax, h)) and in
  // theta_o' (default 12), `energy_panel_order` nodes each (default 8), and energy_phi azimuth
  // nodes on [0, pi] (default 32), same rule kinds as above. 1D path: max(256, 4 lmax, 4 h) panels.
  // Horizon-clipped models (microfacet, GGX, Ward, ...) split the theta_i' panels where the
  // visible azimuth arc starts and stops shrinking and smooth both ends by a substitution; there
  // the defaults are max(24, lmax, h) panels over [0, pi], 6 in theta_o' and 16 azimuth
  // nodes. energy_uniform_panels = true integrates them on the uniform panels above instead (the
  // slower rule the split one is tested against).
  int energy_panels_i = 0;
  int energy_panels_o = 0;
  int energy_panel_order = 0;
  int energy_phi = 0;
  bool energy_uniform_panels = false;
  // Horizon-clipped models (microfacet, GGX, Ward, Lafortune, ...) take the split rule for their
  // coefficients by default: per theta_o' node, theta_i' split where the visible arc starts to
  // shrink and where it closes, Gauss-Legendre on each piece (the second smoothed by a
  // substitution), the energy from the same evaluations. There theta_i is the nodes of the fully
  // visible piece (default max(16, (lmax + h) / 2 + 8), the shrinking piece half of it, >= 16),
  // theta_o default max(4 pmax + 16, 40) and phi max(2 pmax + 8, 16) nodes on the visible arc.
  // coefficients_uniform = true takes the single rules above instead (and BrdfEnergy): the
  // slower rule the split one is tested against.
  bool coefficients_uniform = false;
};

// The view variable a BRDF's coefficients take when `requested` is asked for: kView for
// radially symmetric models (P = 0: the view does not enter) and tangent models (no normal
// reflects V into T); `requested` otherwise.
ViewVariable EffectiveViewVariable(const Brdf& brdf, ViewVariable requested);

// Coefficients for l <= lmax, p <= pmax (0 <= lmax <= kMaxBrdfLmax, 0 <= pmax <= kMaxBrdfPmax),
// all channels, in the view variable EffectiveViewVariable(brdf, view) (brdf_coefficients.h),
// with total_energy filled by the independent angular-domain integral of rho-hat^2 over the same
// variable (kNormal: the sum of the squares of the coefficients computed, since the energy of the
// extension below n''s equator, brdf_projection.cc, has a cross term the angular rules do not
// give). Errors: InvalidArgument for out-of-range orders or sampling sizes, and for an
// anisotropic Ward (alpha_x != alpha_y: the reparameterization of sec. 5.3.1 needs isotropy).
absl::StatusOr<BrdfCoefficients> ComputeBrdfCoefficients(const Brdf& brdf, int lmax, int pmax,
                                                         const BrdfSampling& sampling = {},
                                                         ViewVariable view = ViewVariable::kView);

// The Fresnel table of kNormal coefficients (brdf_coefficients.h): Brdf::MirrorFresnel at the
// table's nodes, per channel, floored and rounded to float; empty for models without a Fresnel
// factor. ComputeBrdfCoefficients fills BrdfCoefficients::fresnel with it (both view variables).
std::vector<double> FresnelTable(const Brdf& brdf);

// The energy double-integral of rho-hat^2 over both spheres, per channel (eqs. 5.17/5.18 right
// sides without (1 - epsilon); 5.17's 2 pi integral rho-hat^2 sin t dt times 4 pi for the 1D case,
// so that it equals the sum of rho_lpq^2 in all cases). Models with a Fresnel table (FresnelTable):
// the energy of rho-hat / w(N.V), what the coefficients expand.
std::vector<double> BrdfEnergy(const Brdf& brdf, int lmax_hint, const BrdfSampling& sampling = {},
                               ViewVariable view = ViewVariable::kView);

struct BrdfOrderOptions {
  int initial_fmax = 0;   // 0: brdf.bandwidth_hint().lmax
  int initial_pmax = -1;  // -1: brdf.bandwidth_hint().pmax (0 for radially symmetric BRDFs)
  int max_fmax = 256;
  int max_pmax = 32;
  BrdfSampling sampling;
};

struct BrdfOrders {
  int F = 0;  // F_rho: l <= F
  int P = 0;  // P_rho: p <= P
  double epsilon = 0;
  double captured = 0;            // CapturedFraction(coefficients, F, P) >= 1 - epsilon
  int fmax = 0, pmax = 0;         // orders the coefficients were computed at
  BrdfCoefficients coefficients;  // at (fmax, pmax)
};

// Errors: InvalidArgument (epsilon not in (0, 1), bad options); OutOfRange when even
// (max_fmax, max_pmax) does not capture 1 - epsilon.
absl::StatusOr<BrdfOrders> SelectBrdfOrders(const Brdf& brdf, double epsilon,
                                            const BrdfOrderOptions& options = {});

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_BRDF_PROJECTION_H_
