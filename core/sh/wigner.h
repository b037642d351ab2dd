// Wigner rotation matrices: the small-d matrices d^l_{mm'}(beta), the complex D^l_{mm'} and the
// unitary that links complex and real SH.
//
// Papers: Krivanek et al., "Fast Approximation to Spherical Harmonic Rotation" (sec. 2.2: the
// block-diagonal rotation matrix R with one block per band); the project's MATH notes
// ("Rotations") for the D convention; the recurrence in l is the Edmonds three-term recurrence (as
// used by Kostelec & Rockmore, "FFTs on the rotation group", eq. 4.5), started at l = max(|m|,
// |m'|) from the closed form d^j_{j,m'}(beta) = sqrt(C(2j, j - m')) cos^{j+m'}(beta/2)
// (-sin(beta/2))^{j-m'}.
//
// Conventions (docs/conventions.md):
//  - D^l_{mq}(Rot) is defined by Y_lq(Rot^-1 w) = sum_m D^l_{mq}(Rot) Y_lm(w) (complex SH of
//    core/sh/sh.h, Condon-Shortley phase), so the coefficients of f(Rot^-1 w) are D c.
//  - For Rot = Rz(alpha) Ry(beta) Rz(gamma) (active, right-handed, zyz):
//    D^l_{mm'} = e^{-i m alpha} d^l_{mm'}(beta) e^{-i m' gamma}, with the standard real small-d
//    (Wikipedia / Sakurai): d^1_{m,0}(beta) = (sin b / sqrt2, cos b, -sin b / sqrt2), m = -1, 0, 1.
//  - Tables of all bands 0..lmax are stored band after band, each band a row-major
//    (2l+1) x (2l+1) block indexed [(m + l) (2l + 1) + (m' + l)], starting at WignerBandOffset(l).
#ifndef SHRM_CORE_SH_WIGNER_H_
#define SHRM_CORE_SH_WIGNER_H_

#include <complex>
#include <span>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm {

// Largest degree the factories accept (memory of a full table grows as lmax^3).
inline constexpr int kMaxWignerLmax = 1024;

// Offset of band l in a table of per-band (2l+1)^2 blocks: sum_{k<l} (2k+1)^2.
constexpr long WignerBandOffset(int l) {
  return static_cast<long>(l) * (2L * l - 1) * (2L * l + 1) / 3;
}
// Number of entries of a table of bands 0..lmax.
constexpr long WignerTableSize(int lmax) { return WignerBandOffset(lmax + 1); }
// Index of (m, m') inside the block of band l.
constexpr int WignerBlockIndex(int l, int m, int mp) { return (m + l) * (2 * l + 1) + (mp + l); }

// Precomputed square-root tables for the three-term recurrence in l
//   d^{l+1}_{mm'} = A_l [(cos b - m m' / (l (l + 1))) d^l_{mm'} - C_l d^{l-1}_{mm'}],
//   A_l = (l+1)(2l+1) / sqrt(((l+1)^2 - m^2)((l+1)^2 - m'^2)),
//   C_l = sqrt((l^2 - m^2)(l^2 - m'^2)) / (l (2l + 1)).
// The recurrence runs upward in l from the closed-form start value at l = max(|m|, |m'|); it is
// stable (checked to l = 256 by orthogonality and by the composition d(a) d(b) = d(a + b)).
// Only the wedge m >= |m'| is computed; the rest follows from d_{m'm} = (-1)^{m-m'} d_{mm'} and
// d_{-m,-m'} = (-1)^{m-m'} d_{mm'}. Cost O(lmax^3 / 3) per angle. Thread-compatible (const
// methods are safe to call concurrently).
class WignerSmallD {
 public:
  // Fails for lmax < 0 or lmax > kMaxWignerLmax.
  static absl::StatusOr<WignerSmallD> Create(int lmax);

  int lmax() const { return lmax_; }

  // All bands 0..lmax of d(beta), beta in radians (any real value), into `out` of size
  // WignerTableSize(lmax()) laid out as described at the top of this file.
  void Compute(double beta, std::span<double> out) const;
  // Only band l <= lmax() of d(beta), into `out` of size (2l+1)^2 (memory O(l^2), time O(l^3)).
  void ComputeBand(int l, double beta, std::span<double> out) const;

 private:
  explicit WignerSmallD(int lmax);
  // Runs the recurrence; `store(l, m, mp, value)` receives each wedge value.
  template <typename Store>
  void Run(int lmax, double beta, Store&& store) const;

  int lmax_ = 0;
  int stride_ = 0;                  // lmax + 2
  std::vector<double> sqrt_diff_;   // [k * stride + |m|] = sqrt(k^2 - m^2), k <= lmax + 1
  std::vector<double> isqrt_diff_;  // 1 / sqrt(k^2 - m^2) for k > |m|, else 0
  std::vector<double> sqrt_int_;    // sqrt(k), k <= 2 lmax + 2
  std::vector<double> isqrt_int_;   // 1 / sqrt(k), k >= 1
  std::vector<double> f_;           // (l + 1)(2l + 1)
  std::vector<double> inv_ll1_;     // 1 / (l (l + 1)), 0 for l = 0
  std::vector<double> inv_l2l1_;    // 1 / (l (2l + 1)), 0 for l = 0
};

// Convenience: all bands 0..lmax of d(beta) (builds the tables once per thread and lmax).
// Precondition: 0 <= lmax <= kMaxWignerLmax.
std::vector<double> WignerSmallDTable(int lmax, double beta);

// Complex D^l_{mm'}(alpha, beta, gamma) = e^{-i m alpha} d^l_{mm'}(beta) e^{-i m' gamma} for all
// bands (same layout as the d table). Precondition: 0 <= lmax <= kMaxWignerLmax.
std::vector<std::complex<double>> WignerDTable(int lmax, double alpha, double beta, double gamma);

// Per band l, the unitary U with Y^real_a = sum_m U_{a m} Y_m (rows: real index a = -l..l,
// columns: complex m = -l..l), for the real SH of core/sh/sh.h. Row-major (2l+1)^2.
// Real coefficients are r = conj(U) c, and a rotation's real block is conj(U) D^l U^T.
std::vector<std::complex<double>> RealShUnitary(int l);

// Real rotation block conj(U) D^l U^T of band l from a complex block (row-major (2l+1)^2);
// the imaginary part, which must vanish, is discarded. A slow, definitional path for tests.
std::vector<double> RealBlockFromComplex(int l, std::span<const std::complex<double>> d_block);

// Textbook twins for tests (Wigner's explicit factorial sum, evaluated in long double; accurate
// only for small l, about l <= 20):
//   d^l_{mm'}(b) = sum_k (-1)^{m-m'+k} sqrt((l+m)!(l-m)!(l+m')!(l-m')!) /
//                  ((l+m'-k)! k! (m-m'+k)! (l-m-k)!) cos(b/2)^{2l+m'-m-2k} sin(b/2)^{m-m'+2k}.
double WignerSmallDSlow(int l, int m, int mp, double beta);
std::complex<double> WignerDSlow(int l, int m, int mp, double alpha, double beta, double gamma);

}  // namespace shrm

#endif  // SHRM_CORE_SH_WIGNER_H_
