#include "core/sh/rotation.h"

#include <cassert>
#include <cmath>
#include <memory>
#include <numeric>

#include "absl/strings/str_cat.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"

namespace shrm {
namespace {

// Below this sin(beta/2) (resp. cos(beta/2)) the rotation is taken as an exact gimbal point.
constexpr double kGimbalTol = 1e-15;
// |entry| below which an entry of the fixed x(pi/2) matrix is structurally zero.
constexpr double kStructuralZero = 1e-12;

double WrapAngle(double a) {
  a = std::remainder(a, 2 * kPi);
  return a <= -kPi ? a + 2 * kPi : a;
}

// Shepperd's method: the largest of |w|, |x|, |y|, |z| comes from the diagonal. The result is
// a unit quaternion up to the rounding of `rot`'s orthonormality (not renormalized).
Quaternion QuaternionFromMatrixUnnormalized(const Mat3& rot) {
  const auto& m = rot.m;
  const double tr = m[0][0] + m[1][1] + m[2][2];
  if (tr > 0) {
    const double s = 2 * std::sqrt(tr + 1), r = 1 / s;
    return {0.25 * s, (m[2][1] - m[1][2]) * r, (m[0][2] - m[2][0]) * r, (m[1][0] - m[0][1]) * r};
  }
  if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2 * std::sqrt(1 + m[0][0] - m[1][1] - m[2][2]), r = 1 / s;
    return {(m[2][1] - m[1][2]) * r, 0.25 * s, (m[0][1] + m[1][0]) * r, (m[0][2] + m[2][0]) * r};
  }
  if (m[1][1] > m[2][2]) {
    const double s = 2 * std::sqrt(1 + m[1][1] - m[0][0] - m[2][2]), r = 1 / s;
    return {(m[0][2] - m[2][0]) * r, (m[0][1] + m[1][0]) * r, 0.25 * s, (m[1][2] + m[2][1]) * r};
  }
  const double s = 2 * std::sqrt(1 + m[2][2] - m[0][0] - m[1][1]), r = 1 / s;
  return {(m[1][0] - m[0][1]) * r, (m[0][2] + m[2][0]) * r, (m[1][2] + m[2][1]) * r, 0.25 * s};
}

// cos/sin of the zyz angles from the quaternion (see rotation.h); beta only if asked.
ZyzCosSin CosSinFromQuaternion(const Quaternion& q, bool with_beta) {
  const double r1 = std::sqrt(q.w * q.w + q.z * q.z);  // cos(beta/2) |q|
  const double r2 = std::sqrt(q.x * q.x + q.y * q.y);  // sin(beta/2) |q|
  const double n = r1 + r2;
  ZyzCosSin out;
  double cs, ss, cd, sd;  // cos/sin of s = (a + g)/2 and d = (a - g)/2
  if (r2 <= kGimbalTol * n) {
    cs = q.w / r1, ss = q.z / r1, cd = cs, sd = ss;
    out.cos_beta = 1, out.sin_beta = 0, out.beta = 0;
  } else if (r1 <= kGimbalTol * n) {
    cd = q.y / r2, sd = -q.x / r2, cs = cd, ss = sd;
    out.cos_beta = -1, out.sin_beta = 0, out.beta = kPi;
  } else {
    cs = q.w / r1, ss = q.z / r1, cd = q.y / r2, sd = -q.x / r2;
    const double inv_n2 = 1.0 / (r1 * r1 + r2 * r2);
    out.cos_beta = (r1 * r1 - r2 * r2) * inv_n2;
    out.sin_beta = 2 * r1 * r2 * inv_n2;
    if (with_beta) out.beta = 2 * std::atan2(r2, r1);
  }
  out.cos_alpha = cs * cd - ss * sd;
  out.sin_alpha = ss * cd + cs * sd;
  out.cos_gamma = cs * cd + ss * sd;
  out.sin_gamma = ss * cd - cs * sd;
  return out;
}

// cos(m a), sin(m a) for m = 0..lmax by the paper's App. B recurrence.
void MultipleAngles(int lmax, double c, double s, double* cm, double* sm) {
  cm[0] = 1, sm[0] = 0;
  if (lmax >= 1) cm[1] = c, sm[1] = s;
  const double c2 = 2 * c;
  for (int m = 2; m <= lmax; ++m) {
    cm[m] = c2 * cm[m - 1] - cm[m - 2];
    sm[m] = c2 * sm[m - 1] - sm[m - 2];
  }
}

const WignerSmallD& CachedSmallD(int lmax) {
  thread_local std::unique_ptr<WignerSmallD> cache;
  if (!cache || cache->lmax() != lmax) {
    cache = std::make_unique<WignerSmallD>(*WignerSmallD::Create(lmax));
  }
  return *cache;
}

// Real rotation blocks for cos/sin of alpha, gamma and the small-d table of beta.
void BlocksFromSmallD(int lmax, const double* d, const double* ca, const double* sa,
                      const double* cg, const double* sg, double* out) {
  const double sqrt2 = std::sqrt(2.0);
  for (int l = 0; l <= lmax; ++l) {
    const int w = 2 * l + 1;
    const double* dl = d + WignerBandOffset(l);
    double* r = out + WignerBandOffset(l);
    auto D = [dl, w, l](int m, int mp) { return dl[(m + l) * w + (mp + l)]; };
    auto R = [r, w, l](int m, int mp) -> double& { return r[(m + l) * w + (mp + l)]; };
    std::fill(r, r + w * w, 0.0);
    R(0, 0) = D(0, 0);
    for (int m = 1; m <= l; ++m) {
      R(m, 0) = sqrt2 * D(m, 0);
      R(0, m) = sqrt2 * D(0, m);
      for (int mp = 1; mp <= l; ++mp) {
        const double a = D(m, mp), b = (mp & 1) ? -D(m, -mp) : D(m, -mp);
        R(m, mp) = a + b;
        R(-m, -mp) = a - b;
      }
    }
    // Left factor Zr(alpha) mixes rows (m, -m); right factor Zr(gamma) mixes columns.
    for (int m = 1; m <= l; ++m) {
      double* top = &R(m, -l);
      double* bot = &R(-m, -l);
      for (int k = 0; k < w; ++k) {
        const double p = top[k], q = bot[k];
        top[k] = ca[m] * p - sa[m] * q;
        bot[k] = sa[m] * p + ca[m] * q;
      }
    }
    for (int row = 0; row < w; ++row) {
      double* rr = r + row * w + l;
      for (int m = 1; m <= l; ++m) {
        const double p = rr[m], q = rr[-m];
        rr[m] = cg[m] * p + sg[m] * q;
        rr[-m] = -sg[m] * p + cg[m] * q;
      }
    }
  }
}

void BlocksFromCosSin(int lmax, const ZyzCosSin& t, double beta, double* out) {
  thread_local std::vector<double> d, trig;
  d.resize(WignerTableSize(lmax));
  trig.resize(4 * (lmax + 1));
  CachedSmallD(lmax).Compute(beta, d);
  double* ca = trig.data();
  double* sa = ca + lmax + 1;
  double* cg = sa + lmax + 1;
  double* sg = cg + lmax + 1;
  MultipleAngles(lmax, t.cos_alpha, t.sin_alpha, ca, sa);
  MultipleAngles(lmax, t.cos_gamma, t.sin_gamma, cg, sg);
  BlocksFromSmallD(lmax, d.data(), ca, sa, cg, sg, out);
}

bool Overlap(std::span<const double> a, std::span<double> b) {
  return a.data() < b.data() + b.size() && b.data() < a.data() + a.size();
}

}  // namespace

Quaternion QuaternionFromMatrix(const Mat3& rot) {
  Quaternion q = QuaternionFromMatrixUnnormalized(rot);
  if (q.w < 0) q = {-q.w, -q.x, -q.y, -q.z};
  const double inv = 1.0 / std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
  return {q.w * inv, q.x * inv, q.y * inv, q.z * inv};
}

EulerZYZ EulerFromQuaternion(const Quaternion& q) {
  const double r1 = std::sqrt(q.w * q.w + q.z * q.z);
  const double r2 = std::sqrt(q.x * q.x + q.y * q.y);
  const double n = r1 + r2;
  double s, d;
  EulerZYZ e;
  if (r2 <= kGimbalTol * n) {
    s = d = std::atan2(q.z, q.w);
    e.beta = 0;
  } else if (r1 <= kGimbalTol * n) {
    s = d = std::atan2(-q.x, q.y);
    e.beta = kPi;
  } else {
    s = std::atan2(q.z, q.w);
    d = std::atan2(-q.x, q.y);
    e.beta = 2 * std::atan2(r2, r1);
  }
  e.alpha = WrapAngle(s + d);
  e.gamma = WrapAngle(s - d);
  return e;
}

EulerZYZ EulerFromMatrix(const Mat3& rot) { return EulerFromQuaternion(QuaternionFromMatrix(rot)); }

Mat3 MatrixFromEuler(const EulerZYZ& e) {
  return RotationZ(e.alpha) * RotationY(e.beta) * RotationZ(e.gamma);
}

ZyzCosSin ZyzCosSinFromMatrix(const Mat3& rot) {
  return CosSinFromQuaternion(QuaternionFromMatrixUnnormalized(rot), /*with_beta=*/true);
}

ZyzCosSin ZyzCosSinFromEuler(const EulerZYZ& e) {
  return {std::cos(e.alpha),
          std::sin(e.alpha),
          std::cos(e.beta),
          std::sin(e.beta),
          std::cos(e.gamma),
          std::sin(e.gamma),
          e.beta};
}

absl::Status ValidateRotationMatrix(const Mat3& rot, double tol) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (!std::isfinite(rot.m[i][j])) {
        return absl::InvalidArgumentError("rotation matrix has a non-finite entry");
      }
  const Mat3 g = rot * rot.Transposed();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (std::abs(g.m[i][j] - (i == j ? 1.0 : 0.0)) > tol) {
        return absl::InvalidArgumentError(
            absl::StrCat("matrix is not orthonormal: (R R^T)[", i, "][", j, "] = ", g.m[i][j]));
      }
  const auto& m = rot.m;
  const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  if (std::abs(det - 1) > tol) {
    return absl::InvalidArgumentError(absl::StrCat("matrix is not a proper rotation: det = ", det));
  }
  return absl::OkStatus();
}

void RealRotationBlocks(int lmax, const EulerZYZ& e, std::span<double> out) {
  assert(lmax >= 0 && lmax <= kMaxRotationLmax);
  assert(static_cast<long>(out.size()) >= WignerTableSize(lmax));
  BlocksFromCosSin(lmax, ZyzCosSinFromEuler(e), e.beta, out.data());
}

void RealRotationBlocks(int lmax, const Mat3& rot, std::span<double> out) {
  assert(lmax >= 0 && lmax <= kMaxRotationLmax);
  assert(static_cast<long>(out.size()) >= WignerTableSize(lmax));
  const ZyzCosSin t = ZyzCosSinFromMatrix(rot);
  BlocksFromCosSin(lmax, t, t.beta, out.data());
}

void RotateShZ(int lmax, double cos_alpha, double sin_alpha, std::span<const double> in,
               std::span<double> out) {
  assert(lmax >= 0 && static_cast<int>(in.size()) >= ShCount(lmax) &&
         static_cast<int>(out.size()) >= ShCount(lmax));
  const double* x = in.data();
  double* y = out.data();
  for (int l = 0; l <= lmax; ++l) y[l * (l + 1)] = x[l * (l + 1)];
  // m-major order keeps cos/sin(m alpha) of App. B's recurrence in registers.
  const double c2 = 2 * cos_alpha;
  double cm = cos_alpha, sm = sin_alpha, cprev = 1, sprev = 0;
  for (int m = 1; m <= lmax; ++m) {
    for (int l = m; l <= lmax; ++l) {
      const int c = l * (l + 1);
      const double p = x[c + m], q = x[c - m];
      y[c + m] = cm * p - sm * q;
      y[c - m] = sm * p + cm * q;
    }
    const double cn = c2 * cm - cprev, sn = c2 * sm - sprev;
    cprev = cm, sprev = sm, cm = cn, sm = sn;
  }
}

void RotateShZ(int lmax, double alpha, std::span<const double> in, std::span<double> out) {
  RotateShZ(lmax, std::cos(alpha), std::sin(alpha), in, out);
}

void RotateShY(int lmax, double beta, std::span<const double> in, std::span<double> out) {
  ShRotation::Create(lmax, EulerZYZ{0, beta, 0}).Apply(in, out);
}

void RotateSh(int lmax, const Mat3& rot, std::span<const double> in, std::span<double> out) {
  assert(lmax >= 0 && lmax <= kMaxRotationLmax);
  // One cached zxzxz operator per thread and lmax: the fastest exact path for a fresh rotation.
  thread_local std::vector<std::unique_ptr<ZxzxzRotation>> cache;
  if (static_cast<int>(cache.size()) <= lmax) cache.resize(lmax + 1);
  if (!cache[lmax]) cache[lmax] = std::make_unique<ZxzxzRotation>(*ZxzxzRotation::Create(lmax));
  cache[lmax]->Apply(rot, in, out);
}

absl::Status RotateShChecked(int lmax, const Mat3& rot, std::span<const double> in,
                             std::span<double> out) {
  if (lmax < 0 || lmax > kMaxRotationLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("RotateSh: lmax = ", lmax, " outside [0, ", kMaxRotationLmax, "]"));
  }
  if (static_cast<long>(in.size()) < ShCount(lmax) ||
      static_cast<long>(out.size()) < ShCount(lmax)) {
    return absl::InvalidArgumentError(absl::StrCat("RotateSh: need ", ShCount(lmax),
                                                   " coefficients, got in ", in.size(), ", out ",
                                                   out.size()));
  }
  if (Overlap(in, out)) return absl::InvalidArgumentError("RotateSh: in and out alias");
  if (absl::Status s = ValidateRotationMatrix(rot); !s.ok()) return s;
  RotateSh(lmax, rot, in, out);
  return absl::OkStatus();
}

ShRotation ShRotation::Create(int lmax, const Mat3& rot) {
  assert(lmax >= 0 && lmax <= kMaxRotationLmax);
  ShRotation r;
  r.lmax_ = lmax;
  r.blocks_.resize(WignerTableSize(lmax));
  RealRotationBlocks(lmax, rot, r.blocks_);
  return r;
}

ShRotation ShRotation::Create(int lmax, const EulerZYZ& euler) {
  assert(lmax >= 0 && lmax <= kMaxRotationLmax);
  ShRotation r;
  r.lmax_ = lmax;
  r.blocks_.resize(WignerTableSize(lmax));
  RealRotationBlocks(lmax, euler, r.blocks_);
  return r;
}

absl::StatusOr<ShRotation> ShRotation::CreateChecked(int lmax, const Mat3& rot) {
  if (lmax < 0 || lmax > kMaxRotationLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("ShRotation: lmax = ", lmax, " outside [0, ", kMaxRotationLmax, "]"));
  }
  if (absl::Status s = ValidateRotationMatrix(rot); !s.ok()) return s;
  return Create(lmax, rot);
}

void ShRotation::Apply(std::span<const double> in, std::span<double> out) const {
  assert(static_cast<int>(in.size()) >= ShCount(lmax_) &&
         static_cast<int>(out.size()) >= ShCount(lmax_));
  const double* x = in.data();
  double* y = out.data();
  const double* b = blocks_.data();
  for (int l = 0; l <= lmax_; ++l) {
    const int w = 2 * l + 1;
    const double* xl = x + l * l;
    double* yl = y + l * l;
    for (int i = 0; i < w; ++i) {
      const double* row = b + i * w;
      double acc = 0;
      for (int j = 0; j < w; ++j) acc += row[j] * xl[j];
      yl[i] = acc;
    }
    b += w * w;
  }
}

std::span<const double> ShRotation::Band(int l) const {
  return std::span<const double>(blocks_).subspan(WignerBandOffset(l), (2 * l + 1) * (2 * l + 1));
}

absl::StatusOr<ZxzxzRotation> ZxzxzRotation::Create(int lmax) {
  if (lmax < 0 || lmax > kMaxRotationLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("ZxzxzRotation: lmax = ", lmax, " outside [0, ", kMaxRotationLmax, "]"));
  }
  ZxzxzRotation z;
  z.lmax_ = lmax;
  // RotationX(pi/2) = Rz(-pi/2) Ry(pi/2) Rz(pi/2).
  std::vector<double> x(WignerTableSize(lmax));
  RealRotationBlocks(lmax, EulerZYZ{-kPi / 2, kPi / 2, kPi / 2}, x);
  for (int l = 0; l <= lmax; ++l) {
    const int w = 2 * l + 1;
    const double* b = x.data() + WignerBandOffset(l);
    // Connected components of the bipartite row/column graph of the nonzeros.
    std::vector<int> parent(2 * w);
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&parent](int a) {
      while (parent[a] != a) a = parent[a] = parent[parent[a]];
      return a;
    };
    for (int i = 0; i < w; ++i)
      for (int j = 0; j < w; ++j)
        if (std::abs(b[i * w + j]) > kStructuralZero) parent[find(i)] = find(w + j);
    std::vector<int> roots;
    for (int k = 0; k < 2 * w; ++k)
      if (find(k) == k) roots.push_back(k);
    for (int root : roots) {
      SubBlock sb;
      sb.row_offset = static_cast<int>(z.row_index_.size());
      sb.col_offset = static_cast<int>(z.col_index_.size());
      sb.value_offset = static_cast<int>(z.values_.size());
      std::vector<int> rows, cols;
      for (int i = 0; i < w; ++i)
        if (find(i) == root) rows.push_back(i);
      for (int j = 0; j < w; ++j)
        if (find(w + j) == root) cols.push_back(j);
      sb.rows = static_cast<int>(rows.size());
      sb.cols = static_cast<int>(cols.size());
      if (sb.rows == 0 || sb.cols == 0) continue;
      for (int r : rows)
        for (int c : cols) {
          const double v = b[r * w + c];
          z.values_.push_back(std::abs(v) > kStructuralZero ? v : 0.0);
        }
      for (int c = 0; c < sb.cols; ++c)
        for (int r = 0; r < sb.rows; ++r)
          z.values_t_.push_back(z.values_[sb.value_offset + r * sb.cols + c]);
      for (int r : rows) z.row_index_.push_back(r + l * l);
      for (int c : cols) z.col_index_.push_back(c + l * l);
      z.blocks_.push_back(sb);
    }
  }
  return z;
}

long ZxzxzRotation::NonZeros() const {
  long n = 0;
  for (const SubBlock& b : blocks_) n += static_cast<long>(b.rows) * b.cols;
  return n;
}

ZxzxzRotation::BlockView ZxzxzRotation::View(const SubBlock& b, bool transposed) const {
  const double* values = transposed ? values_t_.data() : values_.data();
  return {values + b.value_offset,
          transposed ? row_index_.data() + b.row_offset : col_index_.data() + b.col_offset,
          transposed ? col_index_.data() + b.col_offset : row_index_.data() + b.row_offset,
          transposed ? b.rows : b.cols, transposed ? b.cols : b.rows};
}

// Dot-product form in both directions (X^T uses the transposed copy). Vectorizing these short
// loops (a few entries per sub-block row) costs more in prologues than it saves: measured 20%
// slower at n = 10, hence the attribute.
__attribute__((optimize("no-tree-vectorize"))) void ZxzxzRotation::ApplyX(bool transposed,
                                                                          const double* in,
                                                                          double* out) const {
  double tmp[2 * kMaxRotationLmax + 1];
  for (const SubBlock& b : blocks_) {
    const auto [v, src, dst, ns, nd] = View(b, transposed);
    for (int j = 0; j < ns; ++j) tmp[j] = in[src[j]];
    for (int i = 0; i < nd; ++i) {
      const double* row = v + i * ns;
      double acc = 0;
      for (int j = 0; j < ns; ++j) acc += row[j] * tmp[j];
      out[dst[i]] = acc;
    }
  }
}

namespace {

// RotateShZ for k vectors in ApplyMany's layout (x may be y), vector j by its own angle
// (cos_angle[j], sin_angle[j]): the same recurrence and products per vector.
void RotateShZMany(int lmax, int k, const double* cos_angle, const double* sin_angle,
                   const double* x, double* y) {
  if (x != y) {
    for (int l = 0; l <= lmax; ++l)
      for (int j = 0; j < k; ++j) y[l * (l + 1) * k + j] = x[l * (l + 1) * k + j];
  }
  thread_local std::vector<double> state;
  state.resize(5 * static_cast<size_t>(k));
  double* c2 = state.data();
  double* cm = c2 + k;
  double* sm = cm + k;
  double* cprev = sm + k;
  double* sprev = cprev + k;
  for (int j = 0; j < k; ++j) {
    c2[j] = 2 * cos_angle[j];
    cm[j] = cos_angle[j];
    sm[j] = sin_angle[j];
    cprev[j] = 1;
    sprev[j] = 0;
  }
  for (int m = 1; m <= lmax; ++m) {
    for (int l = m; l <= lmax; ++l) {
      const int c = l * (l + 1);
      const double* xp = x + (c + m) * k;
      const double* xq = x + (c - m) * k;
      double* yp = y + (c + m) * k;
      double* yq = y + (c - m) * k;
      for (int j = 0; j < k; ++j) {
        const double p = xp[j], q = xq[j];
        yp[j] = cm[j] * p - sm[j] * q;
        yq[j] = sm[j] * p + cm[j] * q;
      }
    }
    for (int j = 0; j < k; ++j) {
      const double cn = c2[j] * cm[j] - cprev[j], sn = c2[j] * sm[j] - sprev[j];
      cprev[j] = cm[j], sprev[j] = sm[j], cm[j] = cn, sm[j] = sn;
    }
  }
}

}  // namespace

void ZxzxzRotation::ApplyXMany(bool transposed, int k, const double* in, double* out) const {
  for (const SubBlock& b : blocks_) {
    const auto [v, src, dst, ns, nd] = View(b, transposed);
    for (int i = 0; i < nd; ++i) {
      const double* row = v + i * ns;
      double* o = out + static_cast<size_t>(dst[i]) * k;
      for (int j = 0; j < k; ++j) o[j] = 0;
      for (int s = 0; s < ns; ++s) {
        const double w = row[s];
        const double* x = in + static_cast<size_t>(src[s]) * k;
        for (int j = 0; j < k; ++j) o[j] += w * x[j];
      }
    }
  }
}

void ZxzxzRotation::ApplyMany(std::span<const ZyzCosSin> angles, const double* in,
                              double* out) const {
  const int k = static_cast<int>(angles.size());
  thread_local std::vector<double> t, cs;
  t.resize(static_cast<size_t>(ShCount(lmax_)) * k);
  cs.resize(6 * static_cast<size_t>(k));
  double* cg = cs.data();
  double* sg = cg + k;
  double* cb = sg + k;
  double* sb = cb + k;
  double* ca = sb + k;
  double* sa = ca + k;
  for (int j = 0; j < k; ++j) {
    cg[j] = angles[j].cos_gamma, sg[j] = angles[j].sin_gamma;
    cb[j] = angles[j].cos_beta, sb[j] = angles[j].sin_beta;
    ca[j] = angles[j].cos_alpha, sa[j] = angles[j].sin_alpha;
  }
  RotateShZMany(lmax_, k, cg, sg, in, out);
  ApplyXMany(false, k, out, t.data());
  RotateShZMany(lmax_, k, cb, sb, t.data(), t.data());
  ApplyXMany(true, k, t.data(), out);
  RotateShZMany(lmax_, k, ca, sa, out, out);
}

void ZxzxzRotation::ApplyY(double cos_beta, double sin_beta, std::span<const double> in,
                           std::span<double> out) const {
  thread_local std::vector<double> t;
  t.resize(ShCount(lmax_));
  ApplyX(false, in.data(), t.data());
  RotateShZ(lmax_, cos_beta, sin_beta, t, t);
  ApplyX(true, t.data(), out.data());
}

void ZxzxzRotation::Apply(const ZyzCosSin& a, std::span<const double> in,
                          std::span<double> out) const {
  thread_local std::vector<double> t;
  t.resize(ShCount(lmax_));
  RotateShZ(lmax_, a.cos_gamma, a.sin_gamma, in, out);
  ApplyX(false, out.data(), t.data());
  RotateShZ(lmax_, a.cos_beta, a.sin_beta, t, t);
  ApplyX(true, t.data(), out.data());
  RotateShZ(lmax_, a.cos_alpha, a.sin_alpha, out, out);
}

void ZxzxzRotation::Apply(const Mat3& rot, std::span<const double> in,
                          std::span<double> out) const {
  Apply(CosSinFromQuaternion(QuaternionFromMatrixUnnormalized(rot), /*with_beta=*/false), in, out);
}

}  // namespace shrm
