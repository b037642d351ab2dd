#include "core/sh/taylor_rotation.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"

namespace shrm {

absl::StatusOr<TaylorYRotation> TaylorYRotation::Create(int lmax) {
  if (lmax < 0 || lmax > kMaxWignerLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("TaylorYRotation: lmax = ", lmax, " outside [0, ", kMaxWignerLmax, "]"));
  }
  TaylorYRotation t;
  t.lmax_ = lmax;
  const int n = ShCount(lmax);
  t.sub_.assign(n + 1, 0.0);
  t.diag2_.assign(n + 1, 0.0);
  t.off2_.assign(n + 1, 0.0);
  for (int l = 1; l <= lmax; ++l) {
    for (int m = -l + 1; m <= l; ++m) {
      double s = 0;
      if (m >= 2) {
        s = -0.5 * std::sqrt(static_cast<double>(l - m + 1) * (l + m));
      } else if (m == 1) {
        s = -std::sqrt(0.5 * l * (l + 1));
      } else if (m <= -1) {
        s = 0.5 * std::sqrt(static_cast<double>(l + m) * (l - m + 1));
      }
      t.sub_[ShIndex(l, m)] = s;
    }
  }
  for (int i = 0; i < n; ++i) {
    t.diag2_[i] = -t.sub_[i] * t.sub_[i] - t.sub_[i + 1] * t.sub_[i + 1];
    if (i >= 2) t.off2_[i] = t.sub_[i] * t.sub_[i - 1];
  }
  return t;
}

void TaylorYRotation::ApplyFirst(double beta, std::span<const double> in,
                                 std::span<double> out) const {
  const int n = ShCount(lmax_);
  assert(static_cast<int>(in.size()) >= n && static_cast<int>(out.size()) >= n);
  const double* x = in.data();
  const double* s = sub_.data();
  double* y = out.data();
  y[0] = x[0];
  for (int i = 1; i < n - 1; ++i) y[i] = x[i] + beta * (s[i] * x[i - 1] - s[i + 1] * x[i + 1]);
  if (n > 1) y[n - 1] = x[n - 1] + beta * s[n - 1] * x[n - 2];
}

void TaylorYRotation::Apply15(double beta, std::span<const double> in,
                              std::span<double> out) const {
  // The paper's shRotYdiff15().
  const int n = ShCount(lmax_);
  assert(static_cast<int>(in.size()) >= n && static_cast<int>(out.size()) >= n);
  const double bb = 0.5 * beta * beta;
  const double* x = in.data();
  const double* s = sub_.data();
  const double* d2 = diag2_.data();
  double* y = out.data();
  y[0] = x[0];
  for (int i = 1; i < n - 1; ++i) {
    y[i] = x[i] * (1.0 + bb * d2[i]) + beta * (s[i] * x[i - 1] - s[i + 1] * x[i + 1]);
  }
  if (n > 1) y[n - 1] = x[n - 1] * (1.0 + bb * d2[n - 1]) + beta * s[n - 1] * x[n - 2];
}

void TaylorYRotation::ApplySecond(double beta, std::span<const double> in,
                                  std::span<double> out) const {
  const int n = ShCount(lmax_);
  assert(static_cast<int>(in.size()) >= n && static_cast<int>(out.size()) >= n);
  const double bb = 0.5 * beta * beta;
  const double* s = sub_.data();
  const double* d2 = diag2_.data();
  const double* o2 = off2_.data();
  auto x = [&in, n](int i) { return i >= 0 && i < n ? in[i] : 0.0; };
  auto o = [o2, n](int i) { return i < n ? o2[i] : 0.0; };
  for (int i = 0; i < n; ++i) {
    out[i] = x(i) * (1.0 + bb * d2[i]) + beta * (s[i] * x(i - 1) - s[i + 1] * x(i + 1)) +
             bb * (o2[i] * x(i - 2) + o(i + 2) * x(i + 2));
  }
}

void TaylorYRotation::Apply(TaylorOrder order, double beta, std::span<const double> in,
                            std::span<double> out) const {
  switch (order) {
    case TaylorOrder::kFirst:
      return ApplyFirst(beta, in, out);
    case TaylorOrder::kOneAndHalf:
      return Apply15(beta, in, out);
    case TaylorOrder::kSecond:
      return ApplySecond(beta, in, out);
  }
}

std::vector<double> TaylorYRotation::FirstDerivativeBlock(int l) const {
  const int w = 2 * l + 1, base = l * l;
  std::vector<double> a(w * w, 0.0);
  for (int r = 1; r < w; ++r) {
    a[r * w + r - 1] = sub_[base + r];
    a[(r - 1) * w + r] = -sub_[base + r];
  }
  return a;
}

std::vector<double> TaylorYRotation::SecondDerivativeBlock(int l) const {
  const int w = 2 * l + 1, base = l * l;
  std::vector<double> a(w * w, 0.0);
  for (int r = 0; r < w; ++r) {
    a[r * w + r] = diag2_[base + r];
    if (r >= 2) a[r * w + r - 2] = a[(r - 2) * w + r] = off2_[base + r];
  }
  return a;
}

std::vector<double> TaylorYRotation::ApproximateBlock(TaylorOrder order, int l, double beta) const {
  const int w = 2 * l + 1;
  std::vector<double> a = FirstDerivativeBlock(l);
  const std::vector<double> b = SecondDerivativeBlock(l);
  for (int i = 0; i < w * w; ++i) a[i] *= beta;
  for (int r = 0; r < w; ++r) {
    a[r * w + r] += 1.0;
    for (int c = 0; c < w; ++c) {
      const bool use =
          order == TaylorOrder::kSecond || (order == TaylorOrder::kOneAndHalf && r == c);
      if (use) a[r * w + c] += 0.5 * beta * beta * b[r * w + c];
    }
  }
  return a;
}

void RotateShTaylor(const TaylorYRotation& taylor, TaylorOrder order, const ZyzCosSin& angles,
                    std::span<const double> in, std::span<double> out) {
  const int lmax = taylor.lmax();
  thread_local std::vector<double> t;
  t.resize(ShCount(lmax));
  RotateShZ(lmax, angles.cos_gamma, angles.sin_gamma, in, out);
  taylor.Apply(order, angles.beta, out, t);
  RotateShZ(lmax, angles.cos_alpha, angles.sin_alpha, t, out);
}

void RotateShTaylor(const TaylorYRotation& taylor, TaylorOrder order, const Mat3& rot,
                    std::span<const double> in, std::span<double> out) {
  RotateShTaylor(taylor, order, ZyzCosSinFromMatrix(rot), in, out);
}

std::vector<double> SingularValues(int rows, int cols, std::span<const double> a) {
  // Column-major working copy; rotate column pairs until all are mutually orthogonal.
  std::vector<double> u(static_cast<size_t>(rows) * cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) u[j * rows + i] = a[i * cols + j];
  constexpr double kOrthTol = 1e-15;  // relative off-diagonal Gram entry treated as zero
  for (int sweep = 0; sweep < 60; ++sweep) {
    bool rotated = false;
    for (int p = 0; p < cols; ++p) {
      for (int q = p + 1; q < cols; ++q) {
        double* up = &u[p * rows];
        double* uq = &u[q * rows];
        double alpha = 0, beta = 0, gamma = 0;
        for (int i = 0; i < rows; ++i) {
          alpha += up[i] * up[i];
          beta += uq[i] * uq[i];
          gamma += up[i] * uq[i];
        }
        if (std::abs(gamma) <= kOrthTol * std::sqrt(alpha * beta) || gamma == 0) continue;
        rotated = true;
        const double zeta = (beta - alpha) / (2 * gamma);
        const double t = std::copysign(1.0, zeta) / (std::abs(zeta) + std::sqrt(1 + zeta * zeta));
        const double c = 1 / std::sqrt(1 + t * t), s = c * t;
        for (int i = 0; i < rows; ++i) {
          const double x = up[i], y = uq[i];
          up[i] = c * x - s * y;
          uq[i] = s * x + c * y;
        }
      }
    }
    if (!rotated) break;
  }
  std::vector<double> sv(cols);
  for (int j = 0; j < cols; ++j) {
    double n = 0;
    for (int i = 0; i < rows; ++i) n += u[j * rows + i] * u[j * rows + i];
    sv[j] = std::sqrt(n);
  }
  std::sort(sv.begin(), sv.end(), std::greater<double>());
  if (rows < cols) sv.resize(rows);
  return sv;
}

TaylorErrorStats TaylorYErrorStats(const TaylorYRotation& taylor, TaylorOrder order, double beta) {
  const int lmax = taylor.lmax();
  const ShRotation exact = ShRotation::Create(lmax, EulerZYZ{0, beta, 0});
  TaylorErrorStats st;
  double sum = 0;
  for (int l = 0; l <= lmax; ++l) {
    const int w = 2 * l + 1;
    std::vector<double> e = taylor.ApproximateBlock(order, l, beta);
    const std::span<const double> r = exact.Band(l);
    for (int i = 0; i < w * w; ++i) e[i] = r[i] - e[i];
    for (double s : SingularValues(w, w, e)) {
      st.max = std::max(st.max, s);
      sum += s;
    }
  }
  st.mean = sum / ShCount(lmax);
  return st;
}

double TaylorYErrorForVector(const TaylorYRotation& taylor, TaylorOrder order, double beta,
                             std::span<const double> coeffs) {
  const int n = ShCount(taylor.lmax());
  std::vector<double> exact(n), approx(n);
  RotateShY(taylor.lmax(), beta, coeffs, exact);
  taylor.Apply(order, beta, coeffs, approx);
  double e = 0;
  for (int i = 0; i < n; ++i) e += (exact[i] - approx[i]) * (exact[i] - approx[i]);
  return std::sqrt(e);
}

absl::StatusOr<LimitedAngleRotation> LimitedAngleRotation::Create(int lmax, double beta_lim,
                                                                  TaylorOrder order) {
  if (!(beta_lim >= 0 && beta_lim <= kPi)) {
    return absl::InvalidArgumentError(
        absl::StrCat("LimitedAngleRotation: beta_lim = ", beta_lim, " outside [0, pi]"));
  }
  absl::StatusOr<TaylorYRotation> taylor = TaylorYRotation::Create(lmax);
  if (!taylor.ok()) return taylor.status();
  absl::StatusOr<ZxzxzRotation> exact = ZxzxzRotation::Create(lmax);
  if (!exact.ok()) return exact.status();
  return LimitedAngleRotation(*std::move(taylor), *std::move(exact), beta_lim, order);
}

bool LimitedAngleRotation::Apply(const Mat3& rot, std::span<const double> in,
                                 std::span<double> out) const {
  const ZyzCosSin angles = ZyzCosSinFromMatrix(rot);
  if (angles.beta < beta_lim_) {
    RotateShTaylor(taylor_, order_, angles, in, out);
    return true;
  }
  exact_.Apply(angles, in, out);
  return false;
}

}  // namespace shrm
