#include "core/sh/wigner.h"

#include <cmath>
#include <cstdlib>
#include <memory>

#include "absl/strings/str_cat.h"

namespace shrm {

absl::StatusOr<WignerSmallD> WignerSmallD::Create(int lmax) {
  if (lmax < 0 || lmax > kMaxWignerLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("WignerSmallD: lmax = ", lmax, " outside [0, ", kMaxWignerLmax, "]"));
  }
  return WignerSmallD(lmax);
}

WignerSmallD::WignerSmallD(int lmax) : lmax_(lmax), stride_(lmax + 2) {
  sqrt_diff_.assign(static_cast<size_t>(stride_) * stride_, 0.0);
  isqrt_diff_.assign(sqrt_diff_.size(), 0.0);
  for (int k = 0; k <= lmax + 1; ++k) {
    for (int m = 0; m <= k; ++m) {
      const double v = std::sqrt(static_cast<double>(k - m) * (k + m));
      sqrt_diff_[k * stride_ + m] = v;
      isqrt_diff_[k * stride_ + m] = m < k ? 1.0 / v : 0.0;
    }
  }
  sqrt_int_.resize(2 * lmax + 3);
  isqrt_int_.resize(2 * lmax + 3);
  for (int k = 0; k < 2 * lmax + 3; ++k) {
    sqrt_int_[k] = std::sqrt(static_cast<double>(k));
    isqrt_int_[k] = k > 0 ? 1.0 / sqrt_int_[k] : 0.0;
  }
  f_.resize(lmax + 1);
  inv_ll1_.resize(lmax + 1);
  inv_l2l1_.resize(lmax + 1);
  for (int l = 0; l <= lmax; ++l) {
    f_[l] = static_cast<double>(l + 1) * (2 * l + 1);
    inv_ll1_[l] = l > 0 ? 1.0 / (static_cast<double>(l) * (l + 1)) : 0.0;
    inv_l2l1_[l] = l > 0 ? 1.0 / (static_cast<double>(l) * (2 * l + 1)) : 0.0;
  }
}

template <typename Store>
void WignerSmallD::Run(int lmax, double beta, Store&& store) const {
  const double c = std::cos(0.5 * beta), s = std::sin(0.5 * beta);
  // cos(b) - m m'/(l(l+1)) is formed as (l(l+1) - m m')/(l(l+1)) - 2 sin^2(b/2), without the
  // cancellation of 1 - m m'/(l(l+1)) near b = 0 (and with c^2 - s^2 near b = pi).
  const bool near_pi = std::abs(c) < std::abs(s);
  const double one_minus_cb = 2 * s * s, one_plus_cb = 2 * c * c;
  const bool from_cos = std::abs(c) >= std::abs(s);
  const double ratio = from_cos ? -s / c : -c / s;
  const double c2 = c * c, s2 = s * s;
  double pc = 1.0, ps = 1.0;  // c^{2m}, s^{2m}
  thread_local std::vector<double> start;
  start.resize(2 * lmax + 1);
  for (int m = 0; m <= lmax; ++m) {
    // start[k] = d^m_{m, m-k} = sqrt(C(2m, k)) c^{2m-k} (-s)^k, k = 0..2m, from the larger end.
    if (from_cos) {
      double v = pc;
      start[0] = v;
      for (int k = 0; k < 2 * m; ++k) {
        v *= sqrt_int_[2 * m - k] * isqrt_int_[k + 1] * ratio;
        start[k + 1] = v;
      }
    } else {
      double v = ps;
      start[2 * m] = v;
      for (int k = 2 * m; k > 0; --k) {
        v *= sqrt_int_[k] * isqrt_int_[2 * m - k + 1] * ratio;
        start[k - 1] = v;
      }
    }
    const double* isq_m = isqrt_diff_.data() + m;
    const double* sq_m = sqrt_diff_.data() + m;
    for (int mp = -m; mp <= m; ++mp) {
      const int amp = std::abs(mp);
      const double* isq_mp = isqrt_diff_.data() + amp;
      const double* sq_mp = sqrt_diff_.data() + amp;
      const double mmp = static_cast<double>(m) * mp;
      double dl = start[m - mp], dlm1 = 0.0;
      store(m, m, mp, dl);
      for (int l = m; l < lmax; ++l) {
        const int k = (l + 1) * stride_, k0 = l * stride_;
        const double a = f_[l] * isq_m[k] * isq_mp[k];
        const double cc = sq_m[k0] * sq_mp[k0] * inv_l2l1_[l];
        const double ll1 = static_cast<double>(l) * (l + 1);
        const double x = l == 0    ? std::cos(beta)
                         : near_pi ? one_plus_cb - (ll1 + mmp) * inv_ll1_[l]
                                   : (ll1 - mmp) * inv_ll1_[l] - one_minus_cb;
        const double next = a * (x * dl - cc * dlm1);
        store(l + 1, m, mp, next);
        dlm1 = dl;
        dl = next;
      }
    }
    pc *= c2;
    ps *= s2;
  }
}

void WignerSmallD::Compute(double beta, std::span<double> out) const {
  double* o = out.data();
  Run(lmax_, beta, [o](int l, int m, int mp, double v) {
    const long off = WignerBandOffset(l);
    const int w = 2 * l + 1;
    const double sv = ((m - mp) & 1) ? -v : v;
    o[off + (m + l) * w + (mp + l)] = v;
    o[off + (mp + l) * w + (m + l)] = sv;
    o[off + (-m + l) * w + (-mp + l)] = sv;
    o[off + (-mp + l) * w + (-m + l)] = v;
  });
}

void WignerSmallD::ComputeBand(int l, double beta, std::span<double> out) const {
  double* o = out.data();
  const int w = 2 * l + 1;
  Run(l, beta, [o, l, w](int ll, int m, int mp, double v) {
    if (ll != l) return;
    const double sv = ((m - mp) & 1) ? -v : v;
    o[(m + l) * w + (mp + l)] = v;
    o[(mp + l) * w + (m + l)] = sv;
    o[(-m + l) * w + (-mp + l)] = sv;
    o[(-mp + l) * w + (-m + l)] = v;
  });
}

std::vector<double> WignerSmallDTable(int lmax, double beta) {
  thread_local std::unique_ptr<WignerSmallD> cache;
  if (!cache || cache->lmax() != lmax) {
    cache = std::make_unique<WignerSmallD>(*WignerSmallD::Create(lmax));
  }
  std::vector<double> out(WignerTableSize(lmax));
  cache->Compute(beta, out);
  return out;
}

std::vector<std::complex<double>> WignerDTable(int lmax, double alpha, double beta, double gamma) {
  const std::vector<double> d = WignerSmallDTable(lmax, beta);
  std::vector<std::complex<double>> out(d.size());
  for (int l = 0; l <= lmax; ++l) {
    const long off = WignerBandOffset(l);
    for (int m = -l; m <= l; ++m) {
      for (int mp = -l; mp <= l; ++mp) {
        const long i = off + WignerBlockIndex(l, m, mp);
        out[i] = std::polar(d[i], -m * alpha - mp * gamma);
      }
    }
  }
  return out;
}

std::vector<std::complex<double>> RealShUnitary(int l) {
  const int w = 2 * l + 1;
  std::vector<std::complex<double>> u(w * w);
  const double h = 1.0 / std::sqrt(2.0);
  u[WignerBlockIndex(l, 0, 0)] = 1.0;
  for (int m = 1; m <= l; ++m) {
    const double sign = (m & 1) ? -1.0 : 1.0;
    u[WignerBlockIndex(l, m, m)] = h;
    u[WignerBlockIndex(l, m, -m)] = sign * h;
    u[WignerBlockIndex(l, -m, m)] = std::complex<double>(0, -h);
    u[WignerBlockIndex(l, -m, -m)] = std::complex<double>(0, sign * h);
  }
  return u;
}

std::vector<double> RealBlockFromComplex(int l, std::span<const std::complex<double>> d_block) {
  const int w = 2 * l + 1;
  const std::vector<std::complex<double>> u = RealShUnitary(l);
  // t = D U^T, then R = conj(U) t.
  std::vector<std::complex<double>> t(w * w);
  for (int p = 0; p < w; ++p)
    for (int b = 0; b < w; ++b) {
      std::complex<double> acc = 0;
      for (int q = 0; q < w; ++q) acc += d_block[p * w + q] * u[b * w + q];
      t[p * w + b] = acc;
    }
  std::vector<double> r(w * w);
  for (int a = 0; a < w; ++a)
    for (int b = 0; b < w; ++b) {
      std::complex<double> acc = 0;
      for (int p = 0; p < w; ++p) acc += std::conj(u[a * w + p]) * t[p * w + b];
      r[a * w + b] = acc.real();
    }
  return r;
}

double WignerSmallDSlow(int l, int m, int mp, double beta) {
  auto fact = [](int n) {
    long double f = 1;
    for (int i = 2; i <= n; ++i) f *= i;
    return f;
  };
  const long double c = std::cos(static_cast<long double>(beta) / 2);
  const long double s = std::sin(static_cast<long double>(beta) / 2);
  const long double pre = std::sqrt(fact(l + m) * fact(l - m) * fact(l + mp) * fact(l - mp));
  long double sum = 0;
  for (int k = std::max(0, mp - m); k <= std::min(l + mp, l - m); ++k) {
    const long double term = pre /
                             (fact(l + mp - k) * fact(k) * fact(m - mp + k) * fact(l - m - k)) *
                             std::pow(c, 2 * l + mp - m - 2 * k) * std::pow(s, m - mp + 2 * k);
    sum += ((m - mp + k) & 1) ? -term : term;
  }
  return static_cast<double>(sum);
}

std::complex<double> WignerDSlow(int l, int m, int mp, double alpha, double beta, double gamma) {
  return std::polar(WignerSmallDSlow(l, m, mp, beta), -m * alpha - mp * gamma);
}

}  // namespace shrm
