#include "core/sh/hsh.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/base/status_macros.h"
#include "core/sh/quadrature.h"
#include "core/sh/rotation.h"

namespace shrm {
namespace {

// Directions / angles this far below the horizon are treated as on it (rounding slack).
constexpr double kHorizonSlack = 1e-12;
// Extra Gauss nodes for the odd-m integrands of C (geometric convergence, ratio < 4^-2 per node).
constexpr int kOddMExtraNodes = 24;

absl::Status CheckLmax(int lmax, const char* what) {
  if (lmax < 0) return absl::InvalidArgumentError(absl::StrCat(what, " must be >= 0, got ", lmax));
  return absl::OkStatus();
}

absl::Status CheckSize(size_t got, size_t want, const char* what) {
  if (got != want) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " has ", got, " entries, expected ", want));
  }
  return absl::OkStatus();
}

// Gauss-Legendre nodes t_j (decreasing in (0, 1)) and weights (sum 1) on [0, 1]: the rule of
// quadrature.h mapped by t = (1 + x) / 2, with 1 - t = sin^2(theta / 2) kept accurate.
void GaussLegendreUnit(int n, std::vector<double>* t, std::vector<double>* w,
                       std::vector<double>* one_minus_t) {
  const RingQuadrature q = GaussLegendreRule(n);
  t->resize(n);
  w->resize(n);
  one_minus_t->resize(n);
  for (int i = 0; i < n; ++i) {
    const double half = std::sin(0.5 * q.theta[i]);
    (*t)[i] = 0.5 * (1.0 + q.cos_theta[i]);
    (*one_minus_t)[i] = half * half;
    (*w)[i] = 0.5 * q.weight[i];
  }
}

// Shifted Legendre table lambda_l^m(2c - 1) from c = cos theta and 1 - c (both accurate).
void ShiftedLegendre(int lmax, double c, double one_minus_c, std::span<double> out) {
  const double s = 2.0 * std::sqrt(std::max(0.0, c * one_minus_c));
  NormalizedLegendre(lmax, c - one_minus_c, s, out);
}

// Writes H = sqrt2 Y(shifted) from a shifted Legendre table and the azimuth (cos phi, sin phi).
void FillHsh(int lmax, std::span<const double> lambda, double cphi, double sphi,
             std::span<double> out) {
  RealShFromLegendre(lmax, lambda, cphi, sphi, kSqrt2, out);
}

long double Factorial(int n) {
  long double f = 1;
  for (int k = 2; k <= n; ++k) f *= k;
  return f;
}

long double Binomial(int n, int k) { return Factorial(n) / (Factorial(k) * Factorial(n - k)); }

}  // namespace

absl::Status EvalHsh(int lmax, double theta, double phi, std::span<double> out) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  if (out.size() < static_cast<size_t>(HshCount(lmax))) {
    return absl::InvalidArgumentError("EvalHsh: output span too small");
  }
  if (!(theta >= -kHorizonSlack && theta <= kPi / 2 + kHorizonSlack)) {
    return absl::InvalidArgumentError(
        absl::StrCat("EvalHsh: theta = ", theta, " is outside the hemisphere [0, pi/2]"));
  }
  theta = std::clamp(theta, 0.0, kPi / 2);
  const double c = std::cos(theta);
  const double half = std::sin(0.5 * theta);
  thread_local std::vector<double> lambda;
  lambda.resize(LegendreCount(lmax));
  ShiftedLegendre(lmax, c, 2.0 * half * half, lambda);
  FillHsh(lmax, lambda, std::cos(phi), std::sin(phi), out);
  return absl::OkStatus();
}

absl::Status EvalHsh(int lmax, const Vec3& dir, std::span<double> out) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  if (out.size() < static_cast<size_t>(HshCount(lmax))) {
    return absl::InvalidArgumentError("EvalHsh: output span too small");
  }
  const double r = dir.Norm();
  if (!(r > 0) || !(dir.z >= -kHorizonSlack * r)) {
    return absl::InvalidArgumentError("EvalHsh: direction is zero or below the horizon");
  }
  const double z = std::max(0.0, dir.z / r);
  const double rho = std::hypot(dir.x, dir.y) / r;
  thread_local std::vector<double> lambda;
  lambda.resize(LegendreCount(lmax));
  ShiftedLegendre(lmax, z, rho * rho / (1.0 + z), lambda);
  const double cphi = rho > 0 ? dir.x / (r * rho) : 1.0;
  const double sphi = rho > 0 ? dir.y / (r * rho) : 0.0;
  FillHsh(lmax, lambda, cphi, sphi, out);
  return absl::OkStatus();
}

absl::Status EvalHshBatch(int lmax, std::span<const Vec3> dirs, std::span<double> out) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  const size_t n = dirs.size();
  if (out.size() < static_cast<size_t>(HshCount(lmax)) * n) {
    return absl::InvalidArgumentError("EvalHshBatch: output span too small");
  }
  // H(w) = sqrt2 Y(s(w)) with the shifted direction
  // s = (2 x sqrt(z / (1 + z)), 2 y sqrt(z / (1 + z)), 2 z - 1), a unit vector.
  std::vector<Vec3> shifted(n);
  for (size_t k = 0; k < n; ++k) {
    const Vec3& d = dirs[k];
    const double r = d.Norm();
    if (!(r > 0) || !(d.z >= -kHorizonSlack * r)) {
      return absl::InvalidArgumentError(
          absl::StrCat("EvalHshBatch: direction ", k, " is zero or below the horizon"));
    }
    const double z = std::max(0.0, d.z / r);
    const double rho2 = (d.x * d.x + d.y * d.y) / (r * r);
    const double f = 2.0 * std::sqrt(z / (1.0 + z)) / r;
    shifted[k] = {f * d.x, f * d.y, z - rho2 / (1.0 + z)};
  }
  EvalShBatch(lmax, shifted, out);
  const size_t total = static_cast<size_t>(HshCount(lmax)) * n;
  for (size_t i = 0; i < total; ++i) out[i] *= kSqrt2;
  return absl::OkStatus();
}

double EvalHshSlow(int l, int m, double theta, double phi) {
  const int am = std::abs(m);
  if (l < 0 || am > l) return 0.0;
  const long double c = std::cos(static_cast<long double>(theta));
  const long double x = 2.0L * c - 1.0L;  // eq. 6
  // m-th derivative of P_l(x) = 2^-l sum_k (-1)^k C(l,k) C(2l-2k,l) x^(l-2k).
  long double deriv = 0;
  for (int k = 0; 2 * k <= l; ++k) {
    const int n = l - 2 * k;
    if (n < am) continue;
    const long double term = ((k % 2) ? -1.0L : 1.0L) * Binomial(l, k) *
                             Binomial(2 * l - 2 * k, l) * Factorial(n) / Factorial(n - am) *
                             std::pow(x, n - am);
    deriv += term;
  }
  deriv /= std::pow(2.0L, l);
  // P_l^m with the Condon-Shortley phase (-1)^m, as sh.h.
  const long double one_minus_x2 = 4.0L * c * (1.0L - c);  // 1 - x^2 cancels near the horizon
  const long double p = ((am % 2) ? -1.0L : 1.0L) * std::pow(one_minus_x2, am / 2.0L) * deriv;
  // Eq. 9.
  const long double k_tilde =
      std::sqrt((2.0L * l + 1.0L) * Factorial(l - am) /
                (2.0L * std::numbers::pi_v<long double> * Factorial(l + am)));
  const long double sqrt2 = std::numbers::sqrt2_v<long double>;
  if (m > 0) return static_cast<double>(sqrt2 * k_tilde * std::cos(m * (long double)phi) * p);
  if (m < 0) return static_cast<double>(sqrt2 * k_tilde * std::sin(-m * (long double)phi) * p);
  return static_cast<double>(k_tilde * p);
}

absl::StatusOr<double> EvalHshSeries(int lmax, std::span<const double> coeffs, const Vec3& dir) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  SHRM_RETURN_IF_ERROR(CheckSize(coeffs.size(), HshCount(lmax), "EvalHshSeries coeffs"));
  thread_local std::vector<double> basis;
  basis.resize(HshCount(lmax));
  SHRM_RETURN_IF_ERROR(EvalHsh(lmax, dir, basis));
  double sum = 0;
  for (int i = 0; i < HshCount(lmax); ++i) sum += coeffs[i] * basis[i];
  return sum;
}

Vec3 HemisphereRule::Direction(int j, int k) const {
  return {sin_theta[j] * std::cos(phi[k]), sin_theta[j] * std::sin(phi[k]), cos_theta[j]};
}

absl::StatusOr<HemisphereRule> MakeHemisphereRule(int num_theta, int num_phi) {
  if (num_theta < 1 || num_phi < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "hemisphere rule needs num_theta, num_phi >= 1, got ", num_theta, ", ", num_phi));
  }
  HemisphereRule rule;
  std::vector<double> one_minus_x;
  GaussLegendreUnit(num_theta, &rule.cos_theta, &rule.weight, &one_minus_x);
  rule.theta.resize(num_theta);
  rule.sin_theta.resize(num_theta);
  for (int j = 0; j < num_theta; ++j) {
    const double x = rule.cos_theta[j];
    rule.sin_theta[j] = std::sqrt(one_minus_x[j] * (1.0 + x));
    rule.theta[j] = std::atan2(rule.sin_theta[j], x);
  }
  rule.dphi = 2.0 * kPi / num_phi;
  rule.phi.resize(num_phi);
  for (int k = 0; k < num_phi; ++k) rule.phi[k] = rule.dphi * k;
  return rule;
}

double HemisphereEnergy(const HemisphereRule& rule, const HemisphereFunction& f) {
  double sum = 0;
  for (int j = 0; j < rule.num_theta(); ++j) {
    double ring = 0;
    for (int k = 0; k < rule.num_phi(); ++k) {
      const double v = f(rule.theta[j], rule.phi[k]);
      ring += v * v;
    }
    sum += rule.weight[j] * ring;
  }
  return sum * rule.dphi;
}

absl::StatusOr<std::vector<double>> ProjectHshSamples(int lmax, const HemisphereRule& rule,
                                                      std::span<const double> samples) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  const int nt = rule.num_theta(), np = rule.num_phi();
  SHRM_RETURN_IF_ERROR(CheckSize(samples.size(), static_cast<size_t>(nt) * np, "samples"));
  std::vector<double> coeffs(HshCount(lmax), 0.0);
  std::vector<double> lambda(LegendreCount(lmax));
  std::vector<double> a(lmax + 1), b(lmax + 1);
  for (int j = 0; j < nt; ++j) {
    // Azimuthal Fourier sums of ring j.
    std::fill(a.begin(), a.end(), 0.0);
    std::fill(b.begin(), b.end(), 0.0);
    for (int k = 0; k < np; ++k) {
      const double v = samples[static_cast<size_t>(j) * np + k];
      const double c1 = std::cos(rule.phi[k]), s1 = std::sin(rule.phi[k]);
      double cm = 1.0, sm = 0.0;
      for (int m = 0; m <= lmax; ++m) {
        if (m > 0) {
          const double cn = cm * c1 - sm * s1;
          sm = sm * c1 + cm * s1;
          cm = cn;
        }
        a[m] += v * cm;
        b[m] += v * sm;
      }
    }
    const double x = rule.cos_theta[j];
    const double omx = rule.sin_theta[j] * rule.sin_theta[j] / (1.0 + x);
    ShiftedLegendre(lmax, x, omx, lambda);
    const double w = rule.weight[j] * rule.dphi;
    for (int m = 0; m <= lmax; ++m) {
      for (int l = m; l <= lmax; ++l) {
        const double p = lambda[LegendreIndex(l, m)] * w;
        if (m == 0) {
          coeffs[ShIndex(l, 0)] += kSqrt2 * p * a[0];
        } else {
          coeffs[ShIndex(l, m)] += 2.0 * p * a[m];
          coeffs[ShIndex(l, -m)] += 2.0 * p * b[m];
        }
      }
    }
  }
  return coeffs;
}

absl::StatusOr<std::vector<double>> ProjectHsh(int lmax, const HemisphereRule& rule,
                                               const HemisphereFunction& f) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  const int nt = rule.num_theta(), np = rule.num_phi();
  std::vector<double> samples(static_cast<size_t>(nt) * np);
  for (int j = 0; j < nt; ++j)
    for (int k = 0; k < np; ++k)
      samples[static_cast<size_t>(j) * np + k] = f(rule.theta[j], rule.phi[k]);
  return ProjectHshSamples(lmax, rule, samples);
}

absl::StatusOr<double> CapturedEnergyFraction(std::span<const double> coeffs, double energy) {
  if (!(energy > 0)) {
    return absl::InvalidArgumentError(absl::StrCat("energy must be > 0, got ", energy));
  }
  double sum = 0;
  for (double c : coeffs) sum += c * c;
  return sum / energy;
}

// ---------------------------------------------------------------------------------------------

ShHshConversion::ShHshConversion(int hsh_lmax, int sh_lmax)
    : hsh_lmax_(hsh_lmax), sh_lmax_(sh_lmax) {}

absl::StatusOr<ShHshConversion> ShHshConversion::Create(int hsh_lmax, int sh_lmax) {
  SHRM_RETURN_IF_ERROR(CheckLmax(hsh_lmax, "HSH degree"));
  SHRM_RETURN_IF_ERROR(CheckLmax(sh_lmax, "SH degree"));
  ShHshConversion conv(hsh_lmax, sh_lmax);
  const int mmax = std::min(hsh_lmax, sh_lmax);
  const int lmax = std::max(hsh_lmax, sh_lmax);
  // Eq. 18 with x = t^2: 2 pi sqrt2 sum_j w_j 2 t_j lambda_l^m(2 t_j^2 - 1) lambda_l'^m(t_j^2).
  const int n = hsh_lmax + sh_lmax + 1 + kOddMExtraNodes;
  std::vector<double> t, w, omt;
  GaussLegendreUnit(n, &t, &w, &omt);
  const int hrows = hsh_lmax + 1, scols = sh_lmax + 1;
  std::vector<double> hval(static_cast<size_t>(n) * LegendreCount(lmax));
  std::vector<double> sval(static_cast<size_t>(n) * LegendreCount(lmax));
  for (int j = 0; j < n; ++j) {
    const double tj = t[j];
    const double one_minus_t2 = omt[j] * (1.0 + tj);
    const double x = tj * tj;
    std::span<double> hs(hval.data() + static_cast<size_t>(j) * LegendreCount(lmax),
                         LegendreCount(lmax));
    std::span<double> ss(sval.data() + static_cast<size_t>(j) * LegendreCount(lmax),
                         LegendreCount(lmax));
    ShiftedLegendre(hsh_lmax, x, one_minus_t2, hs);
    NormalizedLegendre(sh_lmax, x, std::sqrt(one_minus_t2 * (1.0 + x)), ss);
  }
  conv.blocks_.resize(mmax + 1);
  for (int m = 0; m <= mmax; ++m) {
    std::vector<double>& block = conv.blocks_[m];
    const int nr = hrows - m, nc = scols - m;
    block.assign(static_cast<size_t>(nr) * nc, 0.0);
    for (int j = 0; j < n; ++j) {
      const double wj = 2.0 * kPi * kSqrt2 * w[j] * 2.0 * t[j];
      const double* hs = hval.data() + static_cast<size_t>(j) * LegendreCount(lmax);
      const double* ss = sval.data() + static_cast<size_t>(j) * LegendreCount(lmax);
      for (int l = m; l <= hsh_lmax; ++l) {
        const double hv = wj * hs[LegendreIndex(l, m)];
        double* row = block.data() + static_cast<size_t>(l - m) * nc;
        for (int lp = m; lp <= sh_lmax; ++lp) row[lp - m] += hv * ss[LegendreIndex(lp, m)];
      }
    }
  }
  return conv;
}

double ShHshConversion::Block(int m, int l, int lp) const {
  return blocks_[m][static_cast<size_t>(l - m) * (sh_lmax_ + 1 - m) + (lp - m)];
}

double ShHshConversion::operator()(int row, int col) const {
  const int l = static_cast<int>(std::sqrt(static_cast<double>(row)));
  const int m = row - l * (l + 1);
  const int lp = static_cast<int>(std::sqrt(static_cast<double>(col)));
  const int mp = col - lp * (lp + 1);
  if (m != mp || std::abs(m) >= static_cast<int>(blocks_.size())) return 0.0;
  return Block(std::abs(m), l, lp);
}

std::vector<double> ShHshConversion::Dense() const {
  std::vector<double> dense(static_cast<size_t>(rows()) * cols());
  for (int r = 0; r < rows(); ++r)
    for (int c = 0; c < cols(); ++c) dense[static_cast<size_t>(r) * cols() + c] = (*this)(r, c);
  return dense;
}

absl::Status ShHshConversion::ShToHsh(std::span<const double> sh, std::span<double> hsh) const {
  SHRM_RETURN_IF_ERROR(CheckSize(sh.size(), cols(), "SH coefficients"));
  SHRM_RETURN_IF_ERROR(CheckSize(hsh.size(), rows(), "HSH coefficients"));
  std::fill(hsh.begin(), hsh.end(), 0.0);
  const int mmax = static_cast<int>(blocks_.size()) - 1;
  for (int m = -mmax; m <= mmax; ++m) {
    const int am = std::abs(m);
    for (int l = am; l <= hsh_lmax_; ++l) {
      double sum = 0;
      for (int lp = am; lp <= sh_lmax_; ++lp) sum += Block(am, l, lp) * sh[ShIndex(lp, m)];
      hsh[ShIndex(l, m)] = sum;
    }
  }
  return absl::OkStatus();
}

absl::Status ShHshConversion::HshToSh(std::span<const double> hsh, std::span<double> sh) const {
  SHRM_RETURN_IF_ERROR(CheckSize(hsh.size(), rows(), "HSH coefficients"));
  SHRM_RETURN_IF_ERROR(CheckSize(sh.size(), cols(), "SH coefficients"));
  std::fill(sh.begin(), sh.end(), 0.0);
  const int mmax = static_cast<int>(blocks_.size()) - 1;
  for (int m = -mmax; m <= mmax; ++m) {
    const int am = std::abs(m);
    for (int l = am; l <= hsh_lmax_; ++l) {
      const double h = hsh[ShIndex(l, m)];
      for (int lp = am; lp <= sh_lmax_; ++lp) sh[ShIndex(lp, m)] += Block(am, l, lp) * h;
    }
  }
  return absl::OkStatus();
}

absl::Status RotateHsh(const ShHshConversion& conv, const Mat3& rot, std::span<const double> in,
                       std::span<double> out) {
  SHRM_RETURN_IF_ERROR(CheckSize(in.size(), conv.rows(), "RotateHsh input"));
  SHRM_RETURN_IF_ERROR(CheckSize(out.size(), conv.rows(), "RotateHsh output"));
  std::vector<double> sh(conv.cols()), rotated(conv.cols());
  SHRM_RETURN_IF_ERROR(conv.HshToSh(in, sh));
  RotateSh(conv.sh_lmax(), rot, sh, rotated);
  return conv.ShToHsh(rotated, out);
}

absl::Status RotateHshZ(int lmax, double angle, std::span<const double> in, std::span<double> out) {
  SHRM_RETURN_IF_ERROR(CheckLmax(lmax, "HSH degree"));
  SHRM_RETURN_IF_ERROR(CheckSize(in.size(), HshCount(lmax), "RotateHshZ input"));
  SHRM_RETURN_IF_ERROR(CheckSize(out.size(), HshCount(lmax), "RotateHshZ output"));
  for (int l = 0; l <= lmax; ++l) {
    out[ShIndex(l, 0)] = in[ShIndex(l, 0)];
    for (int m = 1; m <= l; ++m) {
      // f = a cos(m phi) + b sin(m phi)  ->  f(phi - angle).
      const double a = in[ShIndex(l, m)], b = in[ShIndex(l, -m)];
      const double c = std::cos(m * angle), s = std::sin(m * angle);
      out[ShIndex(l, m)] = a * c - b * s;
      out[ShIndex(l, -m)] = a * s + b * c;
    }
  }
  return absl::OkStatus();
}

}  // namespace shrm
