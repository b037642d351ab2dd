// Fast approximate SH rotation by a truncated Taylor expansion of the y-rotation matrix.
//
// Paper: Krivanek, Konttinen, Pattanaik, Bouatouch, Zara, "Fast Approximation to Spherical
// Harmonic Rotation" (2006):
//  - sec. 3: R_y(beta) ~ I + beta dR/dbeta(0) + beta^2/2 d^2R/dbeta^2(0); 1st order, the
//    "1.5th" order (only the diagonal of the second derivative) and the 2nd order; sparse
//    storage (the sub-diagonal of the antisymmetric first derivative, the diagonal and the +-2
//    off-diagonals of the second); the full rotation Rz(alpha) R'_y(beta) Rz(gamma);
//  - Fig. 2: the derivative matrices of bands 1-3 (tested literally);
//  - sec. 3.1: error = singular values of R_y(beta) - R'_y(beta), and the error of one vector;
//  - sec. 4.2 / App. C: the limiting angle beta_lim below which the approximation is used.
//
// The derivative matrices are computed analytically, not by App. A's Ivanic-Ruedenberg
// recursion: in the real basis R_y(beta) = exp(beta A) per band, A = dR/dbeta(0) being the real
// form of -i J_y. With our conventions (docs/conventions.md) A is tridiagonal with,
// at ShIndex i of (l, m), the sub-diagonal S_i = A[i][i-1]:
//   m >= 2: -sqrt((l - m + 1)(l + m)) / 2,   m = 1: -sqrt(l (l + 1) / 2),   m = 0 or -l: 0,
//   -l < m <= -1: +sqrt((l + m)(l - m + 1)) / 2,
// the super-diagonal A[i][i+1] = -S_{i+1}, and d^2R/dbeta^2(0) = A^2 is pentadiagonal with zero
// +-1 diagonals: diagonal -S_i^2 - S_{i+1}^2, +-2 diagonals S_i S_{i-1}.
// Relation to the paper's Fig. 2: our first derivative is the negative of theirs and our second
// derivative equals theirs (their beta is our -beta; see docs/conventions.md).
#ifndef SHRM_CORE_SH_TAYLOR_ROTATION_H_
#define SHRM_CORE_SH_TAYLOR_ROTATION_H_

#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/sh/rotation.h"

namespace shrm {

enum class TaylorOrder {
  kFirst,       // I + beta A
  kOneAndHalf,  // I + beta A + beta^2/2 diag(A^2)     (the paper's "1.5th" order)
  kSecond,      // I + beta A + beta^2/2 A^2
};

// Precomputed derivative diagonals for bands 0..lmax (the paper's order n = lmax + 1).
class TaylorYRotation {
 public:
  // InvalidArgument for lmax < 0 or lmax > kMaxWignerLmax (O(lmax^2) memory).
  static absl::StatusOr<TaylorYRotation> Create(int lmax);

  int lmax() const { return lmax_; }

  // Sparse storage, ShCount(lmax) + 1 entries each (a trailing 0 pad), ShIndex order:
  // sub_diagonal()[i] = dR/dbeta(0)[i][i-1] (0 at the first index of each band; the
  // super-diagonal is -sub_diagonal()[i+1] by antisymmetry; the paper's dySubDiag),
  // second_diagonal()[i] = d^2R/dbeta^2(0)[i][i] (the paper's ddyDiag),
  // second_off2()[i] = d^2R/dbeta^2(0)[i][i-2] = [i-2][i] (0 when i-2 is in another band).
  std::span<const double> sub_diagonal() const { return sub_; }
  std::span<const double> second_diagonal() const { return diag2_; }
  std::span<const double> second_off2() const { return off2_; }

  // out = R'_y(beta) in for the three orders; ShCount(lmax) entries, in/out may not alias.
  // Hot paths: sizes are checked by assert only.
  void ApplyFirst(double beta, std::span<const double> in, std::span<double> out) const;
  void Apply15(double beta, std::span<const double> in, std::span<double> out) const;
  void ApplySecond(double beta, std::span<const double> in, std::span<double> out) const;
  void Apply(TaylorOrder order, double beta, std::span<const double> in,
             std::span<double> out) const;

  // Dense (2l+1)^2 row-major blocks of band l <= lmax: dR/dbeta(0), d^2R/dbeta^2(0) and the
  // approximation R'_y(beta) of the given order (for tests and the error analysis).
  std::vector<double> FirstDerivativeBlock(int l) const;
  std::vector<double> SecondDerivativeBlock(int l) const;
  std::vector<double> ApproximateBlock(TaylorOrder order, int l, double beta) const;

 private:
  TaylorYRotation() = default;
  int lmax_ = 0;
  std::vector<double> sub_, diag2_, off2_;
};

// Paper sec. 3, steps 1-4: out ~ D(rot) in with the z-rotations exact (App. B) and the
// y-rotation by the Taylor expansion of `order`: out = Zr(alpha) R'_y(beta) Zr(gamma) in.
// Accurate only for small zyz beta. in/out may not alias.
void RotateShTaylor(const TaylorYRotation& taylor, TaylorOrder order, const Mat3& rot,
                    std::span<const double> in, std::span<double> out);
void RotateShTaylor(const TaylorYRotation& taylor, TaylorOrder order, const ZyzCosSin& angles,
                    std::span<const double> in, std::span<double> out);

// Singular values (descending) of a rows x cols row-major matrix by one-sided Jacobi (Hestenes)
// rotations in double; for the small per-band matrices of the error analysis.
std::vector<double> SingularValues(int rows, int cols, std::span<const double> a);

// Paper sec. 3.1: the singular values of E(beta) = R_y(beta) - R'_y(beta) over all bands
// 0..lmax (an n^2 x n^2 block-diagonal matrix, n = lmax + 1). `max` is the largest error over
// unit coefficient vectors; `mean` is the mean of all n^2 singular values (band 0 contributes
// a zero), the paper's "average error".
struct TaylorErrorStats {
  double max = 0;
  double mean = 0;
};
TaylorErrorStats TaylorYErrorStats(const TaylorYRotation& taylor, TaylorOrder order, double beta);
// ||R_y(beta) c - R'_y(beta) c||_2 for one coefficient vector c (ShCount(lmax) entries).
double TaylorYErrorForVector(const TaylorYRotation& taylor, TaylorOrder order, double beta,
                             std::span<const double> coeffs);

// Paper App. C: beta_lim = 1.25 a (radians) for the radiance-caching error a and r / R_i = 0.1.
constexpr double BetaLimFromCachingError(double a) { return 1.25 * a; }
// Default limiting angle: 0.125 rad (7.16 degrees), App. C with a = 0.1. There the 1.5th order
// error for a unit cos^7 lobe is 0.023 (n = 5) to 0.028 (n = 10), the worst case over unit
// vectors (max singular value) 0.06 (n = 5) to 0.35 (n = 10); see docs/results.md.
inline constexpr double kDefaultTaylorBetaLim = BetaLimFromCachingError(0.1);

// Paper sec. 4.2: the approximate rotation when the zyz beta of the rotation is < beta_lim, the
// exact zxzxz-rotation otherwise.
class LimitedAngleRotation {
 public:
  // InvalidArgument for lmax outside [0, kMaxRotationLmax] or beta_lim outside [0, pi] (or NaN).
  static absl::StatusOr<LimitedAngleRotation> Create(int lmax,
                                                     double beta_lim = kDefaultTaylorBetaLim,
                                                     TaylorOrder order = TaylorOrder::kOneAndHalf);

  int lmax() const { return taylor_.lmax(); }
  double beta_lim() const { return beta_lim_; }
  TaylorOrder order() const { return order_; }

  // out ~ D(rot) in; returns true if the Taylor approximation was used. in/out may not alias.
  bool Apply(const Mat3& rot, std::span<const double> in, std::span<double> out) const;

 private:
  LimitedAngleRotation(TaylorYRotation taylor, ZxzxzRotation exact, double beta_lim,
                       TaylorOrder order)
      : taylor_(std::move(taylor)), exact_(std::move(exact)), beta_lim_(beta_lim), order_(order) {}
  TaylorYRotation taylor_;
  ZxzxzRotation exact_;
  double beta_lim_;
  TaylorOrder order_;
};

}  // namespace shrm

#endif  // SHRM_CORE_SH_TAYLOR_ROTATION_H_
