#include "core/sh/sh.h"

#include <cassert>
#include <cmath>

#include "core/base/constants.h"

namespace shrm {

Vec3 DirectionFromAngles(double theta, double phi) {
  const double st = std::sin(theta);
  return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
}

void AnglesFromDirection(const Vec3& d, double* theta, double* phi) {
  const double rho = std::hypot(d.x, d.y);
  *theta = std::atan2(rho, d.z);
  *phi = std::atan2(d.y, d.x);
}

void NormalizedLegendre(int lmax, double x, double s, std::span<double> out) {
  assert(lmax >= 0 && static_cast<int>(out.size()) >= LegendreCount(lmax));
  double pmm = std::sqrt(1.0 / (4.0 * kPi));  // lambda_0^0
  for (int m = 0; m <= lmax; ++m) {
    if (m > 0) pmm *= -std::sqrt((2.0 * m + 1.0) / (2.0 * m)) * s;
    out[LegendreIndex(m, m)] = pmm;
    if (m == lmax) break;
    double p2 = pmm;                                 // lambda_{l-2}^m
    double p1 = std::sqrt(2.0 * m + 3.0) * x * pmm;  // lambda_{m+1}^m
    out[LegendreIndex(m + 1, m)] = p1;
    for (int l = m + 2; l <= lmax; ++l) {
      const double ll = static_cast<double>(l) * l, mm = static_cast<double>(m) * m;
      const double a = std::sqrt((4.0 * ll - 1.0) / (ll - mm));
      const double b =
          std::sqrt(((l - 1.0) * (l - 1.0) - mm) / (4.0 * (l - 1.0) * (l - 1.0) - 1.0));
      const double p = a * (x * p1 - b * p2);
      out[LegendreIndex(l, m)] = p;
      p2 = p1;
      p1 = p;
    }
  }
}

void NormalizedLegendre(int lmax, double cos_theta, std::span<double> out) {
  const double s = std::sqrt(std::max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
  NormalizedLegendre(lmax, cos_theta, s, out);
}

void EvalSh(int lmax, const Vec3& dir, std::span<double> out) {
  assert(static_cast<int>(out.size()) >= ShCount(lmax));
  const double r = dir.Norm();
  const double z = dir.z / r;
  const double rho = std::hypot(dir.x, dir.y) / r;
  // cos(m phi), sin(m phi) by the multiple-angle recurrence on the unit vector (x, y) / rho.
  double c1 = 1.0, s1 = 0.0;
  if (rho > 0) {
    c1 = dir.x / (r * rho);
    s1 = dir.y / (r * rho);
  }
  std::vector<double> plm(LegendreCount(lmax));
  NormalizedLegendre(lmax, z, rho, plm);
  RealShFromLegendre(lmax, plm, c1, s1, 1.0, out);
}

void RealShFromLegendre(int lmax, std::span<const double> lambda, double cos_phi, double sin_phi,
                        double scale, std::span<double> out) {
  const double scale2 = scale * kSqrt2;
  double cm = 1.0, sm = 0.0;
  for (int m = 0; m <= lmax; ++m) {
    if (m > 0) {
      const double cn = cm * cos_phi - sm * sin_phi;
      sm = sm * cos_phi + cm * sin_phi;
      cm = cn;
    }
    for (int l = m; l <= lmax; ++l) {
      const double p = lambda[LegendreIndex(l, m)];
      if (m == 0) {
        out[ShIndex(l, 0)] = scale * p;
      } else {
        out[ShIndex(l, m)] = scale2 * p * cm;
        out[ShIndex(l, -m)] = scale2 * p * sm;
      }
    }
  }
}

void EvalSh(int lmax, double theta, double phi, std::span<double> out) {
  EvalSh(lmax, DirectionFromAngles(theta, phi), out);
}

std::vector<double> EvalSh(int lmax, const Vec3& dir) {
  std::vector<double> out(ShCount(lmax));
  EvalSh(lmax, dir, out);
  return out;
}

void EvalShBatch(int lmax, std::span<const Vec3> dirs, std::span<double> out) {
  const size_t n = dirs.size();
  assert(out.size() >= static_cast<size_t>(ShCount(lmax)) * n);
  std::vector<double> z(n), rho(n), c1(n), s1(n), cm(n), sm(n), pmm(n), p1(n), p2(n);
  for (size_t k = 0; k < n; ++k) {
    const Vec3& d = dirs[k];
    const double r = d.Norm();
    z[k] = d.z / r;
    rho[k] = std::hypot(d.x, d.y) / r;
    c1[k] = rho[k] > 0 ? d.x / (r * rho[k]) : 1.0;
    s1[k] = rho[k] > 0 ? d.y / (r * rho[k]) : 0.0;
    cm[k] = 1.0;
    sm[k] = 0.0;
    pmm[k] = std::sqrt(1.0 / (4.0 * kPi));
  }
  auto row = [&](int l, int m) { return out.data() + static_cast<size_t>(ShIndex(l, m)) * n; };
  for (int m = 0; m <= lmax; ++m) {
    if (m > 0) {
      const double f = -std::sqrt((2.0 * m + 1.0) / (2.0 * m));
      for (size_t k = 0; k < n; ++k) {
        pmm[k] *= f * rho[k];
        const double cn = cm[k] * c1[k] - sm[k] * s1[k];
        sm[k] = sm[k] * c1[k] + cm[k] * s1[k];
        cm[k] = cn;
      }
    }
    // Writes lambda_l^m (in p) into the real-SH rows of degree l.
    auto emit = [&](int l, const double* p) {
      if (m == 0) {
        double* o = row(l, 0);
        for (size_t k = 0; k < n; ++k) o[k] = p[k];
      } else {
        double* oc = row(l, m);
        double* os = row(l, -m);
        for (size_t k = 0; k < n; ++k) {
          oc[k] = kSqrt2 * p[k] * cm[k];
          os[k] = kSqrt2 * p[k] * sm[k];
        }
      }
    };
    emit(m, pmm.data());
    if (m == lmax) break;
    const double a1 = std::sqrt(2.0 * m + 3.0);
    for (size_t k = 0; k < n; ++k) {
      p2[k] = pmm[k];
      p1[k] = a1 * z[k] * pmm[k];
    }
    emit(m + 1, p1.data());
    for (int l = m + 2; l <= lmax; ++l) {
      const double ll = static_cast<double>(l) * l, mm = static_cast<double>(m) * m;
      const double a = std::sqrt((4.0 * ll - 1.0) / (ll - mm));
      const double b =
          std::sqrt(((l - 1.0) * (l - 1.0) - mm) / (4.0 * (l - 1.0) * (l - 1.0) - 1.0));
      for (size_t k = 0; k < n; ++k) {
        const double p = a * (z[k] * p1[k] - b * p2[k]);
        p2[k] = p1[k];
        p1[k] = p;
      }
      emit(l, p1.data());
    }
  }
}

namespace {

long double FactorialL(int n) {
  long double f = 1;
  for (int k = 2; k <= n; ++k) f *= k;
  return f;
}

// P_l^m(x) with the Condon-Shortley phase: (-1)^m (1-x^2)^{m/2} d^m/dx^m P_l(x), where
// P_l(x) = 2^-l sum_k (-1)^k C(l,k) C(2l-2k, l) x^{l-2k} (explicit sum; textbook).
long double AssociatedLegendreSlow(int l, int m, long double theta) {
  const long double x = std::cos(theta);
  long double dsum = 0;
  for (int k = 0; 2 * k <= l; ++k) {
    const int power = l - 2 * k;
    if (power < m) continue;
    const long double c =
        FactorialL(2 * l - 2 * k) / (FactorialL(k) * FactorialL(l - k) * FactorialL(l - 2 * k));
    // d^m/dx^m x^power = power!/(power-m)! x^{power-m}
    const long double term = c * FactorialL(power) / FactorialL(power - m) *
                             std::pow(x, static_cast<long double>(power - m));
    dsum += (k % 2 ? -term : term);
  }
  dsum /= std::pow(2.0L, static_cast<long double>(l));
  const long double s = std::pow(std::sin(theta), static_cast<long double>(m));  // (1-x^2)^{m/2}
  return (m % 2 ? -1.0L : 1.0L) * s * dsum;
}

long double KSlow(int l, int m) {
  return std::sqrt((2.0L * l + 1.0L) / (4.0L * static_cast<long double>(kPi)) * FactorialL(l - m) /
                   FactorialL(l + m));
}

}  // namespace

std::complex<double> EvalComplexShSlow(int l, int m, double theta, double phi) {
  const int am = std::abs(m);
  const long double v =
      KSlow(l, am) * AssociatedLegendreSlow(l, am, static_cast<long double>(theta));
  std::complex<double> y = static_cast<double>(v) * std::polar(1.0, am * phi);
  if (m < 0) y = (am % 2 ? -1.0 : 1.0) * std::conj(y);
  return y;
}

double EvalShSlow(int l, int m, double theta, double phi) {
  const int am = std::abs(m);
  const long double v =
      KSlow(l, am) * AssociatedLegendreSlow(l, am, static_cast<long double>(theta));
  if (m == 0) return static_cast<double>(v);
  if (m > 0)
    return static_cast<double>(std::sqrt(2.0L) * v * std::cos(static_cast<long double>(m) * phi));
  return static_cast<double>(std::sqrt(2.0L) * v * std::sin(static_cast<long double>(am) * phi));
}

std::complex<double> EvalComplexSh(int l, int m, double theta, double phi) {
  const int am = std::abs(m);
  std::vector<double> plm(LegendreCount(l));
  NormalizedLegendre(l, std::cos(theta), std::abs(std::sin(theta)), plm);
  std::complex<double> y = plm[LegendreIndex(l, am)] * std::polar(1.0, am * phi);
  if (m < 0) y = (am % 2 ? -1.0 : 1.0) * std::conj(y);
  return y;
}

void EvalComplexSh(int lmax, double theta, double phi, std::span<std::complex<double>> out) {
  std::vector<double> plm(LegendreCount(lmax));
  NormalizedLegendre(lmax, std::cos(theta), std::abs(std::sin(theta)), plm);
  for (int l = 0; l <= lmax; ++l) {
    for (int m = 0; m <= l; ++m) {
      const std::complex<double> y = plm[LegendreIndex(l, m)] * std::polar(1.0, m * phi);
      out[ShIndex(l, m)] = y;
      if (m > 0) out[ShIndex(l, -m)] = (m % 2 ? -1.0 : 1.0) * std::conj(y);
    }
  }
}

void ComplexToReal(int lmax, std::span<const std::complex<double>> c, std::span<double> r) {
  for (int l = 0; l <= lmax; ++l) {
    r[ShIndex(l, 0)] = c[ShIndex(l, 0)].real();
    for (int m = 1; m <= l; ++m) {
      r[ShIndex(l, m)] = kSqrt2 * c[ShIndex(l, m)].real();
      r[ShIndex(l, -m)] = -kSqrt2 * c[ShIndex(l, m)].imag();
    }
  }
}

void RealToComplex(int lmax, std::span<const double> r, std::span<std::complex<double>> c) {
  for (int l = 0; l <= lmax; ++l) {
    c[ShIndex(l, 0)] = r[ShIndex(l, 0)];
    for (int m = 1; m <= l; ++m) {
      const std::complex<double> v(r[ShIndex(l, m)] / kSqrt2, -r[ShIndex(l, -m)] / kSqrt2);
      c[ShIndex(l, m)] = v;
      c[ShIndex(l, -m)] = (m % 2 ? -1.0 : 1.0) * std::conj(v);
    }
  }
}

double EvalShSeries(int lmax, std::span<const double> coeffs, const Vec3& dir) {
  std::vector<double> y(ShCount(lmax));
  EvalSh(lmax, dir, y);
  double sum = 0;
  for (int i = 0; i < ShCount(lmax); ++i) sum += coeffs[i] * y[i];
  return sum;
}

}  // namespace shrm
