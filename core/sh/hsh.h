// Hemispherical harmonics (HSH): basis, evaluation, projection, SH <-> HSH conversion, rotation.
//
// Paper: Gautron, Krivanek, Pattanaik, Bouatouch, "A Novel Hemispherical Basis for Accurate and
// Efficient Rendering" (EGSR 2004):
//  - eqs. 5-9: H_l^m(theta, phi) = the real SH of eq. 3 with P_l^m(cos theta) replaced by the
//    shifted P_l^m(2 cos theta - 1) and K_l^m by Ktilde_l^m = sqrt2 K_l^m (eq. 9: 2pi instead of
//    4pi). Hence the identity used throughout:
//        H_l^m(theta, phi) = sqrt2 Y_l^m(theta', phi),  cos theta' = 2 cos theta - 1,
//    with sin theta' = 2 sqrt(cos theta (1 - cos theta)) (computed without cancellation).
//  - sec. 4, first method: rotation through SH (HSH -> SH by C^T, RotateSh, SH -> HSH by C).
//  - eq. 15: accuracy = fraction of the hemispherical energy captured by the coefficients.
//  - eq. 18: C[(l,m),(l',m')] = integral over the upper hemisphere of H_l^m Y_l'^m'.
//    NOTE: the 9x9 matrix printed in sec. 6.1 does not follow from eqs. 3-9 and 18 (e.g. it
//    prints 0.41 for C[(0,0),(1,0)], whose exact value is sqrt(3) / (2 sqrt2) = 0.612); we compute
//    C from eq. 18 and test it by its defining property.
//
// Conventions (docs/conventions.md):
//  - The hemisphere is z >= 0 (theta in [0, pi/2]) of a local frame that uses the same
//    (theta, phi) <-> (x, y, z) map as sh.h's SH frame; real SH with the Condon-Shortley phase,
//    exactly as sh.h (so H_1^1 = -sqrt(3/pi) sqrt(z (1 - z)) cos phi, with the minus sign).
//  - Coefficients use the SH layout: index ShIndex(l, m) = l (l + 1) + m, HshCount(lmax) =
//    (lmax + 1)^2 coefficients for degrees 0..lmax. The paper's "order n" is lmax + 1.
//  - Integrals are over solid angle, d omega = sin theta d theta d phi.
#ifndef SHRM_CORE_SH_HSH_H_
#define SHRM_CORE_SH_HSH_H_

#include <functional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/sh/sh.h"

namespace shrm {

// Number of HSH coefficients of degrees 0..lmax (same layout as SH).
constexpr int HshCount(int lmax) { return ShCount(lmax); }

// ---------------------------------------------------------------------------------------------
// Evaluation (eq. 8).

// All H_l^m(theta, phi), 0 <= l <= lmax, in ShIndex order into out[0 .. HshCount(lmax)).
// Errors: lmax < 0, out too small, theta outside [0, pi/2] (a tolerance of 1e-12 is clamped).
absl::Status EvalHsh(int lmax, double theta, double phi, std::span<double> out);
// Same at a direction of the local frame (need not be normalized, must be nonzero); the
// direction must lie in the upper hemisphere (z >= -1e-12 |dir|, clamped to z = 0).
absl::Status EvalHsh(int lmax, const Vec3& dir, std::span<double> out);
// Many directions at once. `out` is direction-minor like EvalShBatch:
// out[ShIndex(l, m) * dirs.size() + k] = H_l^m(dirs[k]).
absl::Status EvalHshBatch(int lmax, std::span<const Vec3> dirs, std::span<double> out);
// Textbook twin for tests: eqs. 5-9 literally, with explicit Legendre polynomial sums and
// factorials in long double. Accurate for small degrees (l <= ~15). theta in [0, pi/2].
double EvalHshSlow(int l, int m, double theta, double phi);
// sum_i coeffs[i] H_i(dir) for an expansion of degree lmax.
absl::StatusOr<double> EvalHshSeries(int lmax, std::span<const double> coeffs, const Vec3& dir);

// ---------------------------------------------------------------------------------------------
// Hemisphere quadrature.

// A product rule on the upper hemisphere: Gauss-Legendre in x = cos theta on [0, 1] (num_theta
// nodes) times num_phi equispaced azimuths phi_k = 2 pi k / num_phi. Integral of g over the
// hemisphere ~= sum_{j,k} weight[j] * dphi * g(theta_j, phi_k).
// Exactness: every g(theta, phi) = p(cos theta) e^{i q phi} with p a polynomial of degree
// < 2 num_theta and |q| < num_phi; hence every polynomial in (x, y, z) of degree
// D <= 2 num_theta - 1 when num_phi > D, and every product H_l^m H_l'^m' (or H_l^m times an
// HSH expansion of degree l') when num_theta >= (l + l') / 2 + 1 and num_phi > l + l'.
struct HemisphereRule {
  std::vector<double> theta;      // polar angles in (0, pi/2), increasing
  std::vector<double> cos_theta;  // x_j
  std::vector<double> sin_theta;  // sqrt(1 - x_j^2), computed without cancellation
  std::vector<double> weight;     // Gauss weights on [0, 1] (sum 1)
  std::vector<double> phi;        // azimuths, num_phi of them
  double dphi = 0;                // 2 pi / num_phi

  int num_theta() const { return static_cast<int>(theta.size()); }
  int num_phi() const { return static_cast<int>(phi.size()); }
  // Node (j, k) as a unit vector of the local frame.
  Vec3 Direction(int j, int k) const;
};

// Errors: num_theta < 1 or num_phi < 1.
absl::StatusOr<HemisphereRule> MakeHemisphereRule(int num_theta, int num_phi);

// A real function on the upper hemisphere, called with theta in [0, pi/2].
using HemisphereFunction = std::function<double(double theta, double phi)>;

// Integral over the hemisphere of f^2 by the rule (the denominator of eq. 15).
double HemisphereEnergy(const HemisphereRule& rule, const HemisphereFunction& f);

// ---------------------------------------------------------------------------------------------
// Projection (the HSH coefficients of eq. 21 / 17).

// h_l^m = integral over the hemisphere of f H_l^m, by `rule`. Exact (up to rounding) when f is
// an HSH expansion of degree L or a polynomial in cos theta times e^{i q phi} and the rule
// satisfies the exactness conditions above. Errors: lmax < 0.
absl::StatusOr<std::vector<double>> ProjectHsh(int lmax, const HemisphereRule& rule,
                                               const HemisphereFunction& f);
// Same from samples f(theta_j, phi_k) at the rule's nodes, samples[j * num_phi + k].
// Errors: lmax < 0, samples.size() != num_theta * num_phi.
absl::StatusOr<std::vector<double>> ProjectHshSamples(int lmax, const HemisphereRule& rule,
                                                      std::span<const double> samples);

// Eq. 15: sum_i coeffs[i]^2 / energy, the fraction of the energy of f captured by its
// (orthonormal-basis) coefficients; `energy` = integral of f^2 over the function's domain.
// Errors: energy <= 0.
absl::StatusOr<double> CapturedEnergyFraction(std::span<const double> coeffs, double energy);

// ---------------------------------------------------------------------------------------------
// SH <-> HSH conversion (eq. 18).

// The (HshCount(hsh_lmax) x ShCount(sh_lmax)) matrix C of eq. 18, rectangular when sh_lmax >
// hsh_lmax (sec. 4 recommends more SH than HSH coefficients). C is block diagonal in m
// (C[(l,m),(l',m')] = 0 for m != m'), and the block for m equals the block for -m; only the
// blocks are stored. Each entry
//   C[(l,m),(l',m)] = 2 pi sqrt2 integral_0^1 lambda_l^|m|(2x - 1) lambda_l'^|m|(x) dx
// (lambda = K P with CS phase) is integrated after the substitution x = t^2: for even m the
// integrand is then a polynomial in t (Gauss-Legendre exact); for odd m it is a polynomial times
// (1 + t^2)^{|m|/2}, analytic on a neighbourhood of [0, 1] (branch points t = +-i), where
// Gauss-Legendre converges geometrically; the node count is chosen so that the truncation
// error is below double rounding. (In x itself odd-m integrands contain sqrt(x (1 + x)) and are
// not polynomials.)
// Build once and reuse.
class ShHshConversion {
 public:
  // Errors: hsh_lmax < 0 or sh_lmax < 0.
  static absl::StatusOr<ShHshConversion> Create(int hsh_lmax, int sh_lmax);

  int hsh_lmax() const { return hsh_lmax_; }
  int sh_lmax() const { return sh_lmax_; }
  int rows() const { return HshCount(hsh_lmax_); }
  int cols() const { return ShCount(sh_lmax_); }
  // C[row][col], row = ShIndex(l, m) of the HSH, col = ShIndex(l', m') of the SH.
  double operator()(int row, int col) const;
  // Dense row-major copy (rows() x cols()), for inspection and tests.
  std::vector<double> Dense() const;

  // hsh = C sh: the HSH projection of the upper-hemisphere restriction of the SH expansion.
  // Errors: sh.size() != cols() or hsh.size() != rows().
  absl::Status ShToHsh(std::span<const double> sh, std::span<double> hsh) const;
  // sh = C^T hsh: the SH projection (degree sh_lmax) of the HSH expansion extended by zero to
  // the lower hemisphere. Errors: sizes as above.
  absl::Status HshToSh(std::span<const double> hsh, std::span<double> sh) const;

 private:
  ShHshConversion(int hsh_lmax, int sh_lmax);
  // Block |m|: rows l = |m|..hsh_lmax, cols l' = |m|..sh_lmax, row-major.
  double Block(int m, int l, int lp) const;

  int hsh_lmax_ = 0;
  int sh_lmax_ = 0;
  std::vector<std::vector<double>> blocks_;  // indexed by |m| in [0, min(hsh_lmax, sh_lmax)]
};

// ---------------------------------------------------------------------------------------------
// Rotation (sec. 4).

// Sec. 4, first method: out = C R C^T in, with C = conv (the intermediate SH degree is
// conv.sh_lmax(); make it larger than conv.hsh_lmax()) and R the real-SH rotation of RotateSh
// (core/sh/rotation.h): coefficients of f(rot^-1 w). What rotates below the horizon is
// discarded. As sh_lmax grows the result converges to the HSH projection of
// w -> [rot^-1 w in upper hemisphere] f_hsh(rot^-1 w), f_hsh the input expansion.
// Errors: in/out sizes != HshCount(conv.hsh_lmax()).
absl::Status RotateHsh(const ShHshConversion& conv, const Mat3& rot, std::span<const double> in,
                       std::span<double> out);

// Exact rotation about the pole by `angle` (coefficients of f(theta, phi - angle)): the z
// rotation of HSH is the z rotation of SH (sec. 4), applied to each (m, -m) pair.
// Errors: lmax < 0, in/out sizes != HshCount(lmax). In-place (in == out) is allowed.
absl::Status RotateHshZ(int lmax, double angle, std::span<const double> in, std::span<double> out);

}  // namespace shrm

#endif  // SHRM_CORE_SH_HSH_H_
