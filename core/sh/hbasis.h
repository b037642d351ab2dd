// The H-basis: a polynomial, hemispherically orthonormal basis for irradiance signals.
//
// Paper: Habel & Wimmer, "Efficient Irradiance Normal Mapping" (I3D 2010):
//  - eqs. 8-13: H^1..H^6 (H_4 = the first four, H_6 = all six), polynomials in the unit normal
//    n = (x, y, z) of the local (tangent) frame, hemisphere z >= 0:
//      H1 = 1/sqrt(2pi),              H2 = -sqrt(3/2pi) y,   H3 = sqrt(3/2pi) (2z - 1),
//      H4 = -sqrt(3/2pi) x,           H5 = sqrt(15/2pi) x y, H6 = (1/2) sqrt(15/2pi) (x^2 - y^2).
//    H1, H2, H4, H5, H6 are sqrt2 times the real SH Y_00, Y_1-1, Y_11, Y_2-2, Y_22 (sh.h, with
//    the Condon-Shortley phase: hence the minus signs); H3 is the HSH H_1^0 (hsh.h).
//  - eq. 14 and App. A: T_h, the SH -> H matrix (projection of the real SH onto H^i over the
//    hemisphere). Our copy of the paper does not print the App. A (l = 4) block, so it is
//    computed here by exact quadrature, like every other column.
//  - eqs. 4-7: irradiance E(n) = integral over the hemisphere around n of L(w) (n . w) dw, in SH
//    by scaling band l of the radiance by the Lambertian kernel factor (Funk-Hecke). The paper's
//    eq. 6 factors a^l = 1, 2/3, 1/4, 0, -1/24 are A_l / pi, so its eq. 7 yields E / pi; the
//    functions below return E itself (A_l = pi a^l) unless the name says otherwise.
//  - eq. 16: IMSE = integral over the hemisphere of (approximation - E)^2.
// Conventions: docs/conventions.md. The hemisphere frame and (theta, phi) are as in hsh.h.
#ifndef SHRM_CORE_SH_HBASIS_H_
#define SHRM_CORE_SH_HBASIS_H_

#include <array>
#include <functional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/sh/hsh.h"

namespace shrm {

// Number of functions in the full H-basis (H_6); the reduced H_4 uses the first four.
inline constexpr int kHBasisCount = 6;
inline constexpr int kHBasis4Count = 4;

// Eqs. 8-13: H^1..H^6 at the unit normal n (local frame; the functions are polynomials and are
// evaluated as written for any n, but are orthonormal only over z >= 0). out[i] = H^{i+1}(n).
std::array<double, kHBasisCount> EvalHBasis(const Vec3& n);

// Eq. 15: E_H(n) = sum_i h_i H^i(n). Errors: coeffs.size() not 4 (H_4) or 6 (H_6).
absl::StatusOr<double> EvalHBasisSeries(std::span<const double> coeffs, const Vec3& n);

// Projection of a hemispherical function onto H^1..H^6 by `rule` (exact for polynomial f of
// degree D in (x, y, z) if 2 rule.num_theta() - 1 >= D + 2 and rule.num_phi() > D + 2).
std::array<double, kHBasisCount> ProjectHBasis(const HemisphereRule& rule,
                                               const std::function<double(const Vec3&)>& f);

// T_h (eq. 14, extended to any SH degree; the l = 4 columns are App. A): the 6 x ShCount(sh_lmax)
// matrix T[i][ShIndex(l, m)] = integral over the hemisphere of H^{i+1} Y_lm, computed by a
// product rule that is exact for these polynomial integrands. Build once and reuse.
class HBasisConversion {
 public:
  // Errors: sh_lmax < 0.
  static absl::StatusOr<HBasisConversion> Create(int sh_lmax);

  int sh_lmax() const { return sh_lmax_; }
  int cols() const { return ShCount(sh_lmax_); }
  // T[row][col], row 0..5 = H^1..H^6, col = ShIndex(l, m).
  double operator()(int row, int col) const {
    return matrix_[static_cast<size_t>(row) * cols() + col];
  }
  // Row-major 6 x cols().
  const std::vector<double>& matrix() const { return matrix_; }

  // h = T sh, truncated to h.size() rows (4 for H_4, 6 for H_6). For a signal band-limited to
  // degree sh_lmax this is its exact projection onto H_4 / H_6 over the hemisphere.
  // Errors: sh.size() != cols(), h.size() not 4 or 6.
  absl::Status Apply(std::span<const double> sh, std::span<double> h) const;

 private:
  explicit HBasisConversion(int sh_lmax) : sh_lmax_(sh_lmax) {}
  int sh_lmax_ = 0;
  std::vector<double> matrix_;
};

// Lambertian (clamped-cosine) kernel factor A_l such that E_lm = A_l L_lm (Ramamoorthi &
// Hanrahan 2001): A_0 = pi, A_1 = 2pi/3, A_l = 0 for odd l > 1, and for even l
// A_l = 2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) * l! / (2^l ((l/2)!)^2)  (A_2 = pi/4,
// A_4 = -pi/24). Returns 0 for l < 0.
double LambertianBandFactor(int l);
// The H-basis paper's eq. 6 factor a^l = A_l / pi (a^0 = 1, a^1 = 2/3, a^2 = 1/4, a^3 = 0,
// a^4 = -1/24).
double HabelBandFactor(int l);

// Irradiance SH from radiance SH (eqs. 5-7 with A_l, i.e. E, not E/pi):
// irradiance[ShIndex(l, m)] = A_l radiance[ShIndex(l, m)]. The coefficients live in the frame of
// the radiance (the paper rotates into tangent space first). In-place is allowed.
// Errors: lmax < 0, sizes != ShCount(lmax).
absl::Status IrradianceShFromRadianceSh(int lmax, std::span<const double> radiance,
                                        std::span<double> irradiance);

// Eq. 16: integral over the hemisphere of (approx(n) - truth(n))^2, by `rule` (exact for
// polynomial approx and truth of degree D if 2 rule.num_theta() - 1 >= 2D and
// rule.num_phi() > 2D).
double HemisphereImse(const HemisphereRule& rule, const std::function<double(const Vec3&)>& approx,
                      const std::function<double(const Vec3&)>& truth);

}  // namespace shrm

#endif  // SHRM_CORE_SH_HBASIS_H_
