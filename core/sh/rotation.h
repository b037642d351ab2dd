// Exact rotation of real SH coefficient vectors.
//
// Paper: Krivanek et al., "Fast Approximation to Spherical Harmonic Rotation" (2006):
//  - sec. 2.2: the rotation is Upsilon = R Lambda with a block-diagonal R, one (2l+1)^2 block
//    per band (Fig. 1); the zxzxz-rotation of Kautz et al. 2002 (y-rotation by beta written as
//    x(-pi/2) z(beta) x(+pi/2), the two x matrices fixed and precomputed);
//  - sec. 3: zyz Euler decomposition R = Rz(alpha) Ry(beta) Rz(gamma);
//  - App. B: z-rotation without a matrix, sin/cos(m alpha) by the multiple-angle recurrence.
// The band blocks are built from the Wigner small-d of core/sh/wigner.h and the real<->complex
// unitary per band.
//
// Conventions (docs/conventions.md): rotations act on directions in the SH frame
// (pole z_s) and are active: a rotation Rot maps f to f_rot(w) = f(Rot^-1 w), whose real SH
// coefficients are D(Rot) c. Euler angles are zyz, active, right-handed:
// Rot = RotationZ(alpha) * RotationY(beta) * RotationZ(gamma) (core/base/geometry.h).
// In these conventions the real z-rotation is, for m > 0,
//   c'_m = cos(m a) c_m - sin(m a) c_{-m},   c'_{-m} = sin(m a) c_m + cos(m a) c_{-m},
// i.e. App. B of the paper with alpha -> -alpha (the paper's matrices are the inverse, passive
// ones; see the conventions document).
#ifndef SHRM_CORE_SH_ROTATION_H_
#define SHRM_CORE_SH_ROTATION_H_

#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace shrm {

// Largest degree of the rotation objects, which hold full band tables: WignerTableSize(256) =
// 22.6M doubles (181 MB) while building. (WignerSmallD::ComputeBand goes further.)
inline constexpr int kMaxRotationLmax = 256;

// zyz Euler angles of Rot = Rz(alpha) Ry(beta) Rz(gamma); beta in [0, pi], alpha and gamma in
// (-pi, pi]. At the gimbal points beta = 0 and beta = pi only alpha + gamma (resp. alpha - gamma)
// is determined; there gamma = 0.
struct EulerZYZ {
  double alpha = 0, beta = 0, gamma = 0;
};

// Cosines and sines of the zyz angles, and beta itself, obtained without any trigonometric call
// except one atan2 for beta (used on the per-pixel paths). Same gimbal choice as EulerZYZ.
struct ZyzCosSin {
  double cos_alpha = 1, sin_alpha = 0;
  double cos_beta = 1, sin_beta = 0;
  double cos_gamma = 1, sin_gamma = 0;
  double beta = 0;
};

// Rotation matrix <-> unit quaternion (Shepperd's method: the largest of w, x, y, z is computed
// from the diagonal, so the result is accurate for every rotation). The input must be a rotation
// matrix; the returned quaternion has w >= 0 when possible and unit norm.
Quaternion QuaternionFromMatrix(const Mat3& rot);
// zyz decomposition, computed from the quaternion q = (w, x, y, z):
//   w = cos(b/2) cos((a+g)/2), z = cos(b/2) sin((a+g)/2),
//   y = sin(b/2) cos((a-g)/2), x = -sin(b/2) sin((a-g)/2),
// which stays accurate near the gimbal points (unlike acos of R_zz and atan2 of small entries).
// The quaternion need not be normalized (nonzero).
EulerZYZ EulerFromQuaternion(const Quaternion& q);
EulerZYZ EulerFromMatrix(const Mat3& rot);
Mat3 MatrixFromEuler(const EulerZYZ& e);
ZyzCosSin ZyzCosSinFromMatrix(const Mat3& rot);
ZyzCosSin ZyzCosSinFromEuler(const EulerZYZ& e);

// OK if `rot` is a proper rotation: |R R^T - I| and |det R - 1| below `tol` (entrywise).
absl::Status ValidateRotationMatrix(const Mat3& rot, double tol = 1e-6);

// Band blocks of the real rotation matrix D(Rot) for bands 0..lmax: layout of the Wigner tables
// (WignerBandOffset(l) + WignerBlockIndex(l, m, m'), row m = output coefficient, column m' =
// input coefficient), size WignerTableSize(lmax). Block l = Zr(alpha) Yr(beta) Zr(gamma), with
// Yr built from d^l(beta):
//   Yr_00 = d_00, Yr_m0 = sqrt2 d_m0, Yr_0m' = sqrt2 d_0m',
//   Yr_mm' = d_mm' + (-1)^m' d_m,-m',  Yr_-m,-m' = d_mm' - (-1)^m' d_m,-m'   (m, m' > 0),
// and no coupling between the cosine (m >= 0) and sine (m < 0) halves.
// Preconditions: 0 <= lmax <= kMaxRotationLmax, out.size() >= WignerTableSize(lmax).
void RealRotationBlocks(int lmax, const EulerZYZ& e, std::span<double> out);
void RealRotationBlocks(int lmax, const Mat3& rot, std::span<double> out);

// Paper App. B: z-rotation by alpha of a real SH vector in O(n^2), no matrix; sin/cos(m alpha)
// by the recurrence s_m = 2 cos(a) s_{m-1} - s_{m-2}. `in` and `out` may be the same span.
// Preconditions: lmax >= 0, both spans of size >= ShCount(lmax).
void RotateShZ(int lmax, double alpha, std::span<const double> in, std::span<double> out);
void RotateShZ(int lmax, double cos_alpha, double sin_alpha, std::span<const double> in,
               std::span<double> out);

// Exact y-rotation by beta (band matrices Yr from d(beta)); in/out may not alias.
void RotateShY(int lmax, double beta, std::span<const double> in, std::span<double> out);

// out = D(rot) in: exact rotation of real SH coefficients (ShIndex order, ShCount(lmax) each).
// `rot` must be a rotation matrix; in/out may not alias. Runs the zxzxz-rotation (operator
// cached per thread and lmax), the fastest exact path for a fresh rotation (5x faster than
// building the band matrices at lmax 9); use ShRotation to rotate many vectors by one rotation.
// Preconditions (hot path, checked only by assert): lmax >= 0, spans large enough.
void RotateSh(int lmax, const Mat3& rot, std::span<const double> in, std::span<double> out);
// The same with the arguments validated (negative or huge lmax, short spans, non-rotation).
absl::Status RotateShChecked(int lmax, const Mat3& rot, std::span<const double> in,
                             std::span<double> out);

// Precomputed exact rotation: the band blocks of D(rot), applied by dense block products
// (2 * sum_l (2l+1)^2 flops per vector).
class ShRotation {
 public:
  // Preconditions: 0 <= lmax <= kMaxRotationLmax, `rot` a rotation matrix (assert only).
  static ShRotation Create(int lmax, const Mat3& rot);
  static ShRotation Create(int lmax, const EulerZYZ& euler);
  // Validating factory: InvalidArgument for a bad lmax or a non-rotation matrix.
  static absl::StatusOr<ShRotation> CreateChecked(int lmax, const Mat3& rot);

  int lmax() const { return lmax_; }
  // out = D in; in/out ShCount(lmax) entries (at least), may not alias.
  void Apply(std::span<const double> in, std::span<double> out) const;
  // Block of band l (row-major (2l+1)^2; row = output m, column = input m').
  std::span<const double> Band(int l) const;

 private:
  ShRotation() = default;
  int lmax_ = 0;
  std::vector<double> blocks_;
};

// zxzxz-rotation (Kautz et al. 2002, paper sec. 2.2): with X = D(RotationX(pi/2)),
//   D(Rz(a) Ry(b) Rz(g)) = Zr(a) X^T Zr(b) X Zr(g),
// since RotationX(-pi/2) RotationZ(b) RotationX(pi/2) = RotationY(b). X is fixed and has only a
// quarter of its entries nonzero: each band splits into four dense sub-blocks (parities under
// x -> -x and under the reflections y -> -y / z -> -z that X swaps), stored densely with their
// row/column index lists. Applying a fresh rotation needs no matrix construction and no
// trigonometric call (cos/sin of the angles come from the quaternion).
class ZxzxzRotation {
 public:
  static absl::StatusOr<ZxzxzRotation> Create(int lmax);

  int lmax() const { return lmax_; }
  // out = D(rot) in (rot a rotation matrix); in/out may not alias.
  void Apply(const Mat3& rot, std::span<const double> in, std::span<double> out) const;
  void Apply(const ZyzCosSin& angles, std::span<const double> in, std::span<double> out) const;
  // Apply for k vectors at once, each with its own rotation (angles[j], Apply's form), in the
  // layout in[i * k + j] = coefficient i of vector j (out likewise; they may not alias): the
  // same arithmetic per vector, run across the vectors (the fixed X read once for all of them).
  void ApplyMany(std::span<const ZyzCosSin> angles, const double* in, double* out) const;
  // out = Yr(beta) in, exact, through X^T Zr(beta) X.
  void ApplyY(double cos_beta, double sin_beta, std::span<const double> in,
              std::span<double> out) const;
  // Number of stored nonzeros of X (for the complexity comparison of paper sec. 3.2).
  long NonZeros() const;

 private:
  struct SubBlock {
    int rows = 0, cols = 0;
    int row_offset = 0, col_offset = 0;  // into row_index_ / col_index_
    int value_offset = 0;                // into values_ (rows x cols, row-major)
  };
  ZxzxzRotation() = default;
  // A sub-block in the direction applied: its rows (ns values each), the source and destination
  // coefficient indices.
  struct BlockView {
    const double* values;
    const int* src;
    const int* dst;
    int ns, nd;
  };
  BlockView View(const SubBlock& b, bool transposed) const;
  // out[rows] = (transposed ? B^T : B) in[cols] over all sub-blocks of X.
  void ApplyX(bool transposed, const double* in, double* out) const;
  // The same for k vectors in ApplyMany's layout.
  void ApplyXMany(bool transposed, int k, const double* in, double* out) const;

  int lmax_ = 0;
  std::vector<SubBlock> blocks_;
  std::vector<int> row_index_, col_index_;  // absolute ShIndex of sub-block rows / columns
  std::vector<double> values_;              // sub-blocks, row-major
  std::vector<double> values_t_;            // the same sub-blocks transposed (column-major)
};

}  // namespace shrm

#endif  // SHRM_CORE_SH_ROTATION_H_
