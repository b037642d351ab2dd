// BRDF coefficients rho-hat_lpq after reparameterization by the reflection vector (SHRM paper
// sec. 5.3.1, eq. 5.22), in the conventions of docs/conventions.md ("BRDF coefficients"):
//
//   rho_lpq = double integral rho-hat(w_i', w_o') Y_lq(w_i') conj(Y_pq(w_o')) dw_i' dw_o'
//           = (2 pi)^2 double-integral c_q(t_i, t_o) f_lq(t_i) f_pq(t_o) sin t_i sin t_o,
//   c_q(t_i, t_o) = (1/2pi) integral rho-hat(t_i, t_o, phi) cos(q phi) dphi,
//
// with complex SH Y_lq = f_lq e^{i q phi} and phi = phi_i' - phi_o'. For isotropic BRDFs rho-hat
// is even in phi, so rho_lpq is real and rho_{l,p,-q} = rho_{l,p,q}: only q >= 0 is stored.
// rho-hat = sum rho_lpq conj(Y_lq(w_i')) Y_pq(w_o'), |q| <= min(l, p).
#ifndef SHRM_CORE_BRDF_BRDF_COEFFICIENTS_H_
#define SHRM_CORE_BRDF_BRDF_COEFFICIENTS_H_

#include <cstddef>
#include <cstdlib>
#include <span>
#include <vector>

#include "core/base/geometry.h"

namespace shrm {

// Which direction the BRDF is reparameterized by (the pole of the local frame).
enum class ReparamKind {
  kReflection,  // R = 2 (N.V) N - V: every model but Kajiya-Kay
  kTangent,     // the tangent T (Kajiya-Kay): only q = 0 terms
};

// The variable of the view expansion in R's frame (docs/shrm.md "The view variable").
//   kView:   w_o' = Rot(R)^T V, the paper's eqs. 5.10 and 5.22.
//   kNormal: n' = Rot(R)^T N with N = (R + V) / |R + V| the normal that reflects V into R:
//            n' has the azimuth of w_o' and theta_n' = theta_o' / 2, so the sphere of views maps
//            onto the hemisphere theta_n' <= pi / 2; below its equator rho-hat takes a C^1
//            extension (brdf_projection.cc AddViewNode). V = -R (N.V = 0) is the whole equator
//            instead of one point where the limit depends on the side it is approached from:
//            grazing views converge in P. Reflection models only (kTangent keeps kView).
// The convolution B_lmpq = L_lm rho_lpq is the same for both: only rho_lpq and the argument of
// Y_pq in the evaluation differ.
enum class ViewVariable { kView, kNormal };
const char* ViewVariableName(ViewVariable v);  // "view", "normal"

// Fresnel normalization (docs/shrm.md "Fresnel normalization"): the coefficients of a model with
// a Fresnel factor (both view variables) expand rho-hat / w(N.V) instead of rho-hat, w the
// model's Fresnel factor at the mirror configuration, V.H = N.V (Brdf::MirrorFresnel; Schlick's
// f0 + (1 - f0)(1 - N.V)^5 for GGX), tabulated here; an evaluation multiplies the expansion by
// w(N.V) (FresnelCosine: N.V = N.R = cos theta_n' in kNormal, cos(theta_o' / 2) in kView).
// Dividing by w takes out the rise to grazing (25-fold for f0 = 0.04) that a truncated expansion
// in the view variable would otherwise ring with into the front, where the values are 25 times
// smaller: what remains is the lobe's shape, the shadowing and the horizon's cut. In kView the
// energy of eqs. 5.17/5.18 (total_energy) is that of rho-hat / w too, so the epsilon rule's
// captured fraction measures the truncation of what is expanded.
//   Table: kFresnelIntervals + 1 nodes at N.R = 1 - k / K per channel (values[k * channels + c]),
//   uniform in N.R as Schlick's polynomial is (no inverse trigonometry in a shader), each a
//   float (the files' precision, so that the projection and every evaluation divide and
//   multiply by the same numbers), floored at kFresnelFloor of the channel's largest; between
//   nodes the Catmull-Rom cubic of FresnelAt (C^1, so rho-hat / w stays C^1; ghost nodes beyond
//   both ends on the quadratic through the three nearest: v_-1 = 3 (v_0 - v_1) + v_2). An empty
//   table is w = 1 (models without a Fresnel factor, files written before it).
inline constexpr int kFresnelIntervals = 128;
inline constexpr double kFresnelFloor = 1e-4;
// w at cos theta_n' (clamped to [0, 1]) for channel c of a table with `channels` channels; 1 for
// an empty table.
double FresnelAt(std::span<const double> table, int channels, double cos_theta_n, int c);
double FresnelAt(std::span<const float> table, int channels, double cos_theta_n, int c);
// Channels per node of a table of `size` values (0 for an empty one).
inline int FresnelChannels(size_t size) { return static_cast<int>(size / (kFresnelIntervals + 1)); }
// w for channel c of a stored table (ShrmCube::fresnel), its channels inferred from its size and
// c clamped to them (a 1-channel table serves every channel); 1 for an empty table.
double FresnelFactor(std::span<const float> table, double cos_theta_n, int c);
// N.V, the table's argument, at an evaluation's index direction r (R, unit) and argument (unit):
// the normal N in kNormal (N.R = N.V), the view V in kView (|R + V| = 2 N.V; no cancellation as
// the dot product's (1 + R.V) / 2 would have near grazing).
inline double FresnelCosine(ViewVariable view, const Vec3& r, const Vec3& argument) {
  return view == ViewVariable::kNormal ? r.Dot(argument) : 0.5 * (r + argument).Norm();
}

struct BrdfCoefficients {
  int lmax = 0;      // F_rho: l <= lmax
  int pmax = 0;      // P_rho: p <= pmax
  int channels = 1;  // 1 (grey analytic models) or 3 (RGB tables)
  ReparamKind reparam = ReparamKind::kReflection;
  ViewVariable view = ViewVariable::kView;
  // rho_lpq for 0 <= q <= min(l, p) (zero elsewhere), at Index(l, p, q, c).
  std::vector<double> values;
  // Per channel: the full energy double-integral of rho-hat^2 over both spheres (the right side
  // of eqs. 5.17/5.18 without the (1 - epsilon)), computed in the angular domain so that the
  // captured fraction sum |rho_lpq|^2 / total_energy measures the truncation error.
  std::vector<double> total_energy;
  // The Fresnel table above (empty: no normalization).
  std::vector<double> fresnel;

  size_t Index(int l, int p, int q, int c) const {
    return ((static_cast<size_t>(l) * (pmax + 1) + p) * (pmax + 1) + q) * channels + c;
  }
  // rho_{l,p,q} for any sign of q (isotropic symmetry).
  double at(int l, int p, int q, int c = 0) const {
    const int aq = std::abs(q);
    if (aq > l || aq > p) return 0.0;
    return values[Index(l, p, aq, c)];
  }
};

// Captured fraction of eqs. 5.17/5.18 for orders (F, P):
//   sum_{l <= F, p <= P, |q| <= min(l, p)} rho_lpq^2 / total_energy
// (q != 0 counted twice, rho_{l,p,-q} = rho_{l,p,q}), clamped to F <= lmax, P <= pmax. For
// channel < 0 the minimum over channels (the worst channel) is returned.
double CapturedFraction(const BrdfCoefficients& coeffs, int F, int P, int channel = -1);

// The same coefficients restricted to l <= F, p <= P (total_energy unchanged).
BrdfCoefficients TruncateBrdfCoefficients(const BrdfCoefficients& coeffs, int F, int P);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_BRDF_COEFFICIENTS_H_
