#include "core/sh/wigner_columns.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdlib>

namespace shrm {
namespace {

// x^n for an integer n >= 0 (x may be negative: alpha < 0 on the padding rows).
double IntPow(double x, int n) {
  double r = 1.0;
  while (n > 0) {
    if (n & 1) r *= x;
    x *= x;
    n >>= 1;
  }
  return r;
}

// sqrt(C(2l, k)) without overflow for the degrees used here (l <= 1024).
double SqrtBinomial(int two_l, int k) {
  return std::exp(0.5 *
                  (std::lgamma(two_l + 1.0) - std::lgamma(k + 1.0) - std::lgamma(two_l - k + 1.0)));
}

}  // namespace

WignerColumnTables::WignerColumnTables(int lmax, int qmax) : lmax_(lmax), qmax_(qmax) {
  assert(qmax >= 0 && qmax <= lmax);
  const size_t n = WignerColumnCount(lmax, qmax);
  a_.assign(n, 0.0);
  c_.assign(n, 0.0);
  shift_.assign(n, 0.0);
  start_.assign(static_cast<size_t>(2 * qmax + 1) * (2 * lmax + 1), 0.0);
  for (int q = -qmax; q <= qmax; ++q)
    for (int m = -lmax; m <= lmax; ++m) {
      const int l0 = std::max(std::abs(m), std::abs(q));
      if (l0 > lmax) continue;
      const int k = std::abs(m) >= std::abs(q) ? l0 + q : l0 + m;
      start_[static_cast<size_t>(q + qmax) * (2 * lmax + 1) + (m + lmax)] = SqrtBinomial(2 * l0, k);
      const double mm = static_cast<double>(m) * m, qq = static_cast<double>(q) * q;
      for (int l = l0; l < lmax; ++l) {
        const double l1 = l + 1.0;
        const size_t i = WignerColumnIndex(lmax, qmax, l, m, q);
        a_[i] = l1 * (2 * l + 1) / std::sqrt((l1 * l1 - mm) * (l1 * l1 - qq));
        c_[i] = l > 0 ? std::sqrt((l * l - mm) * (l * l - qq)) / (l * (2.0 * l + 1)) : 0.0;
        shift_[i] = l > 0 ? static_cast<double>(m) * q / (l * l1) : 0.0;
      }
    }
}

void WignerColumnTables::Compute(double alpha, std::span<double> out) const {
  const int lmax = lmax_, qmax = qmax_;
  assert(out.size() >= WignerColumnCount(lmax, qmax));
  const double c = std::cos(alpha / 2), s = std::sin(alpha / 2), x = std::cos(alpha);
  for (int q = -qmax; q <= qmax; ++q) {
    for (int m = -lmax; m <= lmax; ++m) {
      double* col = out.data() + WignerColumnIndex(lmax, qmax, 0, m, q);
      const int l0 = std::max(std::abs(m), std::abs(q));
      for (int l = 0; l < std::min(l0, lmax + 1); ++l) col[l] = 0.0;
      if (l0 > lmax) continue;
      // Closed forms at l = max(|m|, |q|) (Wigner's sum has a single term there).
      const double b = start_[static_cast<size_t>(q + qmax) * (2 * lmax + 1) + (m + lmax)];
      double d0;
      if (std::abs(m) >= std::abs(q)) {
        if (m >= 0) {
          d0 = ((m - q) & 1 ? -1.0 : 1.0) * b * IntPow(c, l0 + q) * IntPow(s, l0 - q);
        } else {
          d0 = b * IntPow(c, l0 - q) * IntPow(s, l0 + q);
        }
      } else if (q > 0) {
        d0 = b * IntPow(c, l0 + m) * IntPow(s, l0 - m);
      } else {
        d0 = ((m + l0) & 1 ? -1.0 : 1.0) * b * IntPow(c, l0 - m) * IntPow(s, l0 + m);
      }
      col[l0] = d0;
      const size_t base = WignerColumnIndex(lmax, qmax, 0, m, q);
      const double* a = a_.data() + base;
      const double* cl = c_.data() + base;
      const double* sh = shift_.data() + base;
      double prev = 0, cur = d0;
      for (int l = l0; l < lmax; ++l) {
        const double next = a[l] * ((x - sh[l]) * cur - cl[l] * prev);
        col[l + 1] = next;
        prev = cur;
        cur = next;
      }
    }
  }
}

WignerColumnTables::BlockAngles WignerColumnTables::Angles(const double* alpha, int n) const {
  BlockAngles a;
  Lanes c, s;
  for (int r = 0; r < kWignerBlock; ++r) {
    const double t = alpha[std::min(r, n - 1)];
    c[r] = std::cos(t / 2);
    s[r] = std::sin(t / 2);
    a.x[r] = std::cos(t);
  }
  a.cpow.resize(2 * lmax_ + 1);
  a.spow.resize(2 * lmax_ + 1);
  a.cpow[0] = a.spow[0] = Lanes{} + 1.0;
  for (int k = 1; k <= 2 * lmax_; ++k) {
    a.cpow[k] = a.cpow[k - 1] * c;
    a.spow[k] = a.spow[k - 1] * s;
  }
  return a;
}

WignerColumnTables::Lanes WignerColumnTables::StartColumn(const BlockAngles& a, int m,
                                                          int q) const {
  // The closed forms of Compute(), with the powers from the block's tables.
  const int l0 = std::max(std::abs(m), std::abs(q));
  const double b = start_[static_cast<size_t>(q + qmax_) * (2 * lmax_ + 1) + (m + lmax_)];
  if (std::abs(m) >= std::abs(q)) {
    if (m >= 0) return ((m - q) & 1 ? -b : b) * a.cpow[l0 + q] * a.spow[l0 - q];
    return b * a.cpow[l0 - q] * a.spow[l0 + q];
  }
  if (q > 0) return b * a.cpow[l0 + m] * a.spow[l0 - m];
  return ((m + l0) & 1 ? -b : b) * a.cpow[l0 - m] * a.spow[l0 + m];
}

void WignerColumns(int lmax, int qmax, double alpha, std::span<double> out) {
  WignerColumnTables(lmax, qmax).Compute(alpha, out);
}

}  // namespace shrm
