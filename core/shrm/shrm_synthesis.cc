#include "core/shrm/shrm_synthesis.h"

#include <fftw3.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"
#include "core/transform/sht.h"

namespace shrm {
namespace {

constexpr double kSqrt2 = 1.41421356237309504880;

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

// Runs `body(begin, end)` over [0, n) split into `threads` contiguous chunks.
template <typename Body>
void ParallelFor(int n, int threads, Body&& body) {
  threads = std::max(1, std::min(threads, n));
  if (threads == 1) {
    body(0, n);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const int b = static_cast<int>(static_cast<long>(n) * t / threads);
    const int e = static_cast<int>(static_cast<long>(n) * (t + 1) / threads);
    pool.emplace_back([&body, b, e] { body(b, e); });
  }
  for (auto& th : pool) th.join();
}

// Lagrange weights of the 4-point cubic through nodes -1, 0, 1, 2 at t in [0, 1).
void LagrangeWeights(double t, double w[4]) {
  w[0] = -t * (t - 1) * (t - 2) / 6;
  w[1] = (t + 1) * (t - 1) * (t - 2) / 2;
  w[2] = -(t + 1) * t * (t - 2) / 2;
  w[3] = (t + 1) * t * (t - 1) / 6;
}

// Real SH coefficients of one texel in its local frame evaluated at the world view.
double DotSh(std::span<const double> y, const float* coeffs, int count, int channels, int c) {
  double s = 0;
  for (int k = 0; k < count; ++k) s += y[k] * coeffs[static_cast<size_t>(k) * channels + c];
  return s;
}

// Interpolation taps of every texel centre of an S x S cube on the (na x 2 na) grid: first grid
// row (padded index, rows row .. row + 3), the four beta columns and the Lagrange weights. They
// depend only on (S, na), so they are computed once per process and cached (like an FFT plan).
struct TexelTaps {
  int row = 0;
  int col[4] = {0, 0, 0, 0};
  double wa[4] = {0, 0, 0, 0};
  double wb[4] = {0, 0, 0, 0};
};

std::shared_ptr<const std::vector<TexelTaps>> GetTexelTaps(int face_size, int na) {
  static std::mutex mu;
  static std::map<std::pair<int, int>, std::shared_ptr<const std::vector<TexelTaps>>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[{face_size, na}];
  if (slot) return slot;
  auto taps = std::make_shared<std::vector<TexelTaps>>(static_cast<size_t>(kCubeFaceCount) *
                                                       face_size * face_size);
  const int nb = 2 * na;
  for (int face = 0; face < kCubeFaceCount; ++face)
    for (int y = 0; y < face_size; ++y)
      for (int x = 0; x < face_size; ++x) {
        TexelTaps& t = (*taps)[(static_cast<size_t>(face) * face_size + y) * face_size + x];
        double alpha, beta;
        ShrmAnglesFromWorld(CubeTexelDirection(face, x, y, face_size), &alpha, &beta);
        const double u = alpha * na / kPi - 0.5;
        const int j0 = std::clamp(static_cast<int>(std::floor(u)), -1, na - 1);
        LagrangeWeights(u - j0, t.wa);
        t.row = j0 - 1 + 2;  // padded row index of node -1
        double v = beta * nb / (2 * kPi);
        if (v < 0) v += nb;
        const int k0 = std::min(static_cast<int>(std::floor(v)), nb - 1);
        LagrangeWeights(v - k0, t.wb);
        for (int b = 0; b < 4; ++b) t.col[b] = ((k0 - 1 + b) % nb + nb) % nb;
      }
  slot = taps;
  return slot;
}

// 4 x 4 Lagrange interpolation of one texel's coefficients from the grid (N = stride, 0: any).
template <int N>
void Interpolate(const ShrmSynthesizer::Grid& g, const TexelTaps& t, double* acc, float* dst) {
  const int stride = N > 0 ? N : g.stride;
  for (int i = 0; i < stride; ++i) acc[i] = 0.0;
  for (int a = 0; a < 4; ++a) {
    const float* grid_row = g.values.data() + static_cast<size_t>(t.row + a) * g.nb * stride;
    for (int b = 0; b < 4; ++b) {
      const double w = t.wa[a] * t.wb[b];
      const float* src = grid_row + static_cast<size_t>(t.col[b]) * stride;
      for (int i = 0; i < stride; ++i) acc[i] += w * src[i];
    }
  }
  for (int i = 0; i < stride; ++i) dst[i] = static_cast<float>(acc[i]);
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

void WignerColumns(int lmax, int qmax, double alpha, std::span<double> out) {
  WignerColumnTables(lmax, qmax).Compute(alpha, out);
}

void ShrmAnglesFromWorld(const Vec3& world_dir, double* alpha, double* beta) {
  const Vec3 s = ShFrameFromWorld(world_dir);
  *alpha = std::atan2(std::hypot(s.x, s.y), s.z);
  *beta = std::atan2(s.y, s.x);
}

Mat3 ShrmLocalFrame(double alpha, double beta) { return RotationZ(beta) * RotationY(alpha); }

absl::StatusOr<ShrmSynthesizer> ShrmSynthesizer::Create(int light_lmax, int channels,
                                                        std::span<const double> light,
                                                        const BrdfCoefficients& brdf, int lmax,
                                                        int pmax) {
  if (light_lmax < 0 || brdf.lmax < 0 || brdf.pmax < 0) {
    return absl::InvalidArgumentError(absl::StrCat("SHRM: negative order (lighting lmax ",
                                                   light_lmax, ", BRDF lmax ", brdf.lmax, ", pmax ",
                                                   brdf.pmax, ")"));
  }
  if (lmax < -1 || pmax < -1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM: negative order F_B = ", lmax, " or P_B = ", pmax));
  }
  if (channels < 1) {
    return absl::InvalidArgumentError(absl::StrCat("SHRM: channels = ", channels));
  }
  if (light.size() != static_cast<size_t>(ShCount(light_lmax)) * channels) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM: lighting has ", light.size(), " values, expected (lmax + 1)^2 * ",
                     "channels = ", static_cast<size_t>(ShCount(light_lmax)) * channels));
  }
  if (brdf.channels != 1 && brdf.channels != channels) {
    return absl::InvalidArgumentError(absl::StrCat("SHRM: mismatched channels: BRDF has ",
                                                   brdf.channels, ", lighting ", channels));
  }
  const size_t expected_rho =
      static_cast<size_t>(brdf.lmax + 1) * (brdf.pmax + 1) * (brdf.pmax + 1) * brdf.channels;
  if (brdf.values.size() != expected_rho) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SHRM: BRDF coefficients have ", brdf.values.size(), " values, expected ", expected_rho));
  }
  const int f = lmax < 0 ? std::min(light_lmax, brdf.lmax) : lmax;
  const int p = pmax < 0 ? brdf.pmax : pmax;
  if (f > light_lmax || f > brdf.lmax || p > brdf.pmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM: orders F_B = ", f, ", P_B = ", p, " exceed the inputs (lighting lmax ",
                     light_lmax, ", BRDF lmax ", brdf.lmax, ", pmax ", brdf.pmax, ")"));
  }
  if (p > kMaxRotationLmax || f > kMaxWignerLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM: orders too large: F_B = ", f, ", P_B = ", p));
  }
  ShrmSynthesizer s;
  s.lmax_ = f;
  s.pmax_ = p;
  s.channels_ = channels;
  s.reparam_ = brdf.reparam;
  s.light_.assign(static_cast<size_t>(2 * f + 1) * (f + 1) * channels, {0.0, 0.0});
  std::vector<double> real(ShCount(light_lmax));
  std::vector<std::complex<double>> cplx(ShCount(light_lmax));
  for (int c = 0; c < channels; ++c) {
    for (int k = 0; k < ShCount(light_lmax); ++k)
      real[k] = light[static_cast<size_t>(k) * channels + c];
    RealToComplex(light_lmax, real, cplx);
    for (int l = 0; l <= f; ++l)
      for (int m = -l; m <= l; ++m)
        s.light_[((static_cast<size_t>(m + f)) * (f + 1) + l) * channels + c] = cplx[ShIndex(l, m)];
  }
  s.rho_.assign(static_cast<size_t>(p + 1) * (p + 1) * (f + 1) * channels, 0.0);
  for (int pp = 0; pp <= p; ++pp)
    for (int q = 0; q <= pp; ++q) {
      if (q != 0 && brdf.reparam == ReparamKind::kTangent) continue;
      for (int l = q; l <= f; ++l)
        for (int c = 0; c < channels; ++c)
          s.rho_[((static_cast<size_t>(pp) * (p + 1) + q) * (f + 1) + l) * channels + c] =
              brdf.at(l, pp, q, brdf.channels == 1 ? 0 : c);
    }
  return s;
}

std::complex<double> ShrmSynthesizer::Blmpq(int l, int m, int p, int q, int c) const {
  if (l < 0 || l > lmax_ || p < 0 || p > pmax_ || std::abs(m) > l || std::abs(q) > std::min(l, p))
    return {0.0, 0.0};
  return light_[(static_cast<size_t>(m + lmax_) * (lmax_ + 1) + l) * channels_ + c] *
         Rho(l, p, q, c);
}

std::vector<double> ShrmSynthesizer::TruncatedEnergy(int f, int p) const {
  std::vector<double> e(channels_, 0.0);
  f = std::min(f, lmax_);
  p = std::min(p, pmax_);
  for (int c = 0; c < channels_; ++c)
    for (int l = 0; l <= f; ++l) {
      double light = 0;
      for (int m = -l; m <= l; ++m)
        light +=
            std::norm(light_[(static_cast<size_t>(m + lmax_) * (lmax_ + 1) + l) * channels_ + c]);
      double rho = 0;
      for (int pp = 0; pp <= p; ++pp)
        for (int q = -std::min(l, pp); q <= std::min(l, pp); ++q) {
          const double r = Rho(l, pp, q, c);
          rho += r * r;
        }
      e[c] += 4 * kPi / (2 * l + 1) * light * rho;
    }
  return e;
}

void ShrmSynthesizer::LocalComplexAt(double alpha, double beta,
                                     std::span<std::complex<double>> out) const {
  const int f = lmax_, pm = pmax_, ch = channels_;
  const std::vector<double> d = WignerSmallDTable(f, alpha);
  std::fill(out.begin(), out.begin() + static_cast<size_t>(ShCount(pm)) * ch,
            std::complex<double>(0, 0));
  for (int m = -f; m <= f; ++m) {
    const std::complex<double> e = std::polar(1.0, m * beta);
    for (int p = 0; p <= pm; ++p)
      for (int q = -p; q <= p; ++q)
        for (int c = 0; c < ch; ++c) {
          std::complex<double> acc = 0;
          for (int l = std::max(std::abs(m), std::abs(q)); l <= f; ++l)
            acc += light_[(static_cast<size_t>(m + f) * (f + 1) + l) * ch + c] * Rho(l, p, q, c) *
                   d[WignerBandOffset(l) + WignerBlockIndex(l, m, q)];
          out[static_cast<size_t>(ShIndex(p, q)) * ch + c] += e * acc;
        }
  }
}

void ShrmSynthesizer::CoefficientsAt(ShrmKind kind, double alpha, double beta,
                                     std::span<double> out) const {
  const int n = ShCount(pmax_), ch = channels_;
  std::vector<std::complex<double>> cplx(static_cast<size_t>(n) * ch);
  LocalComplexAt(alpha, beta, cplx);
  std::vector<std::complex<double>> one(n);
  std::vector<double> real(n), rotated(n);
  const Mat3 rot = ShrmLocalFrame(alpha, beta);
  for (int c = 0; c < ch; ++c) {
    for (int k = 0; k < n; ++k) one[k] = cplx[static_cast<size_t>(k) * ch + c];
    ComplexToReal(pmax_, one, real);
    if (kind == ShrmKind::kGlobal) {
      RotateSh(pmax_, rot, real, rotated);
      real.swap(rotated);
    }
    for (int k = 0; k < n; ++k) out[static_cast<size_t>(k) * ch + c] = real[k];
  }
}

std::array<double, 3> ShrmSynthesizer::RadianceAt(ShrmKind kind, const Vec3& index_dir,
                                                  const Vec3& view) const {
  double alpha, beta;
  ShrmAnglesFromWorld(index_dir, &alpha, &beta);
  const int n = ShCount(pmax_);
  std::vector<double> coeffs(static_cast<size_t>(n) * channels_);
  CoefficientsAt(kind, alpha, beta, coeffs);
  Vec3 w = ShFrameFromWorld(view);
  if (kind == ShrmKind::kLocal) w = ShrmLocalFrame(alpha, beta).Transposed() * w;
  const std::vector<double> y = EvalSh(pmax_, w);
  std::array<double, 3> out{0, 0, 0};
  for (int c = 0; c < std::min(channels_, 3); ++c)
    for (int k = 0; k < n; ++k) out[c] += y[k] * coeffs[static_cast<size_t>(k) * channels_ + c];
  return out;
}

void ShrmSynthesizer::SynthesizeRow(ShrmKind kind, double alpha, int nb, void* fft_plan,
                                    const WignerColumnTables& tables,
                                    const WignerColumnTables& ptables, std::span<double> cols,
                                    std::span<double> dp, std::complex<double>* work,
                                    float* row_out) const {
  const int f = lmax_, pm = pmax_, ch = channels_;
  const int qmax = std::min(pm, f);
  const int npq = (pm + 1) * (pm + 2) / 2;  // (p, q >= 0) pairs
  const int nseries = npq * ch;
  const int stride = ShCount(pm) * ch;
  std::fill(work, work + static_cast<size_t>(nseries) * nb, std::complex<double>(0, 0));
  tables.Compute(alpha, cols);
  auto bin = [nb](int m) { return ((m % nb) + nb) % nb; };
  auto lrow = [&](int m) { return light_.data() + static_cast<size_t>(m + f) * (f + 1) * ch; };
  if (kind == ShrmKind::kLocal) {
    for (int p = 0; p <= pm; ++p)
      for (int q = 0; q <= std::min(p, qmax); ++q) {
        const int t = p * (p + 1) / 2 + q;
        for (int m = -f; m <= f; ++m) {
          const double* d = cols.data() + WignerColumnIndex(f, qmax, 0, m, q);
          const std::complex<double>* lm = lrow(m);
          const double* rho = rho_.data() + (static_cast<size_t>(p) * (pm + 1) + q) * (f + 1) * ch;
          for (int c = 0; c < ch; ++c) {
            double re = 0, im = 0;
            for (int l = std::max(std::abs(m), q); l <= f; ++l) {
              const double w = rho[l * ch + c] * d[l];
              re += lm[l * ch + c].real() * w;
              im += lm[l * ch + c].imag() * w;
            }
            work[static_cast<size_t>(t * ch + c) * nb + bin(m)] = {re, im};
          }
        }
      }
  } else {
    // B_mpq(alpha) for all |q| <= p, then the shift sum over q with d^p_sq(alpha).
    const int n = ShCount(pm);
    std::vector<std::complex<double>> bm(static_cast<size_t>(2 * f + 1) * n * ch, {0, 0});
    for (int m = -f; m <= f; ++m) {
      const std::complex<double>* lm = lrow(m);
      for (int p = 0; p <= pm; ++p)
        for (int q = -std::min(p, qmax); q <= std::min(p, qmax); ++q) {
          const double* d = cols.data() + WignerColumnIndex(f, qmax, 0, m, q);
          const double* rho =
              rho_.data() + (static_cast<size_t>(p) * (pm + 1) + std::abs(q)) * (f + 1) * ch;
          for (int c = 0; c < ch; ++c) {
            double re = 0, im = 0;
            for (int l = std::max(std::abs(m), std::abs(q)); l <= f; ++l) {
              const double w = rho[l * ch + c] * d[l];
              re += lm[l * ch + c].real() * w;
              im += lm[l * ch + c].imag() * w;
            }
            bm[(static_cast<size_t>(m + f) * n + ShIndex(p, q)) * ch + c] = {re, im};
          }
        }
    }
    ptables.Compute(alpha, dp);
    for (int p = 0; p <= pm; ++p)
      for (int s = 0; s <= p; ++s) {
        const int t = p * (p + 1) / 2 + s;
        for (int m = -f; m <= f; ++m)
          for (int c = 0; c < ch; ++c) {
            std::complex<double> acc = 0;
            for (int q = -std::min(p, qmax); q <= std::min(p, qmax); ++q)
              acc += dp[WignerColumnIndex(pm, pm, p, s, q)] *
                     bm[(static_cast<size_t>(m + f) * n + ShIndex(p, q)) * ch + c];
            work[static_cast<size_t>(t * ch + c) * nb + bin(m - s)] += acc;
          }
      }
  }
  fftw_execute_dft(static_cast<fftw_plan>(fft_plan), reinterpret_cast<fftw_complex*>(work),
                   reinterpret_cast<fftw_complex*>(work));
  for (int p = 0; p <= pm; ++p)
    for (int q = 0; q <= p; ++q) {
      const int t = p * (p + 1) / 2 + q;
      for (int c = 0; c < ch; ++c) {
        const std::complex<double>* series = work + static_cast<size_t>(t * ch + c) * nb;
        if (q == 0) {
          float* o = row_out + ShIndex(p, 0) * ch + c;
          for (int k = 0; k < nb; ++k)
            o[static_cast<size_t>(k) * stride] = static_cast<float>(series[k].real());
        } else {
          float* op = row_out + ShIndex(p, q) * ch + c;
          float* on = row_out + ShIndex(p, -q) * ch + c;
          for (int k = 0; k < nb; ++k) {
            op[static_cast<size_t>(k) * stride] = static_cast<float>(kSqrt2 * series[k].real());
            on[static_cast<size_t>(k) * stride] = static_cast<float>(-kSqrt2 * series[k].imag());
          }
        }
      }
    }
}

absl::StatusOr<ShrmSynthesizer::Grid> ShrmSynthesizer::BuildGrid(ShrmKind kind, int na,
                                                                 int threads) const {
  const int extra = kind == ShrmKind::kGlobal ? pmax_ : 0;
  if (na < lmax_ + extra + 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM grid: ", na, " alpha samples cannot resolve degree ", lmax_ + extra,
                     " (need >= ", lmax_ + extra + 1, ")"));
  }
  if (threads < 1)
    return absl::InvalidArgumentError(absl::StrCat("SHRM grid: threads = ", threads));
  Grid g;
  g.na = na;
  g.nb = 2 * na;
  g.stride = ShCount(pmax_) * channels_;
  const int rows = na + 4;
  g.values.assign(static_cast<size_t>(rows) * g.nb * g.stride, 0.0f);
  const int nseries = (pmax_ + 1) * (pmax_ + 2) / 2 * channels_;
  const size_t work_size = static_cast<size_t>(nseries) * g.nb;
  fftw_plan plan;
  fftw_complex* probe;
  {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    probe = fftw_alloc_complex(work_size);
    int n[1] = {g.nb};
    plan = fftw_plan_many_dft(1, n, nseries, probe, nullptr, 1, g.nb, probe, nullptr, 1, g.nb,
                              FFTW_BACKWARD, FFTW_ESTIMATE);
  }
  const int qmax = std::min(pmax_, lmax_);
  const WignerColumnTables tables(lmax_, qmax), ptables(pmax_, pmax_);
  ParallelFor(rows, threads, [&](int begin, int end) {
    fftw_complex* work;
    {
      std::lock_guard<std::mutex> lock(FftwPlannerMutex());
      work = fftw_alloc_complex(work_size);
    }
    std::vector<double> cols(WignerColumnCount(lmax_, qmax)), dp(WignerColumnCount(pmax_, pmax_));
    for (int r = begin; r < end; ++r) {
      const int j = r - 2;
      const double alpha = kPi * (j + 0.5) / na;
      SynthesizeRow(kind, alpha, g.nb, plan, tables, ptables, cols, dp,
                    reinterpret_cast<std::complex<double>*>(work),
                    g.values.data() + static_cast<size_t>(r) * g.nb * g.stride);
    }
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    fftw_free(work);
  });
  {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    fftw_destroy_plan(plan);
    fftw_free(probe);
  }
  return g;
}

absl::StatusOr<ShrmCube> ShrmSynthesizer::BuildCube(ShrmKind kind, int face_size,
                                                    const ShrmGridOptions& options) const {
  if (face_size < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM cube: face size S_B = ", face_size, " (must be >= 1)"));
  }
  if (options.alpha_samples < 0 || options.threads < 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SHRM cube: alpha_samples = ", options.alpha_samples, ", threads = ", options.threads));
  }
  int na = options.alpha_samples;
  if (na == 0) {
    // The grid resolves a band-limited field of degree F (+ P for the global shift); 4 samples per
    // wavelength of degree F + P + 1 keep the 4-point Lagrange error ~(F h)^4 / 40 < 1e-3 of the
    // top band (docs/shrm.md), independent of S_B.
    na = std::max(32, 4 * (lmax_ + pmax_ + 1));
    na = (na + 7) / 8 * 8;
  }
  Grid g;
  {
    auto grid = BuildGrid(kind, na, options.threads);
    if (!grid.ok()) return grid.status();
    g = std::move(grid).value();
  }
  ShrmCube cube;
  cube.kind = kind;
  cube.index = reparam_;
  cube.face_size = face_size;
  cube.pmax = pmax_;
  cube.channels = channels_;
  cube.data.assign(cube.size(), 0.0f);
  const int stride = g.stride;
  const std::shared_ptr<const std::vector<TexelTaps>> taps = GetTexelTaps(face_size, na);
  const int rows_total = kCubeFaceCount * face_size;
  ParallelFor(rows_total, options.threads, [&](int begin, int end) {
    std::vector<double> acc(stride);
    for (int row = begin; row < end; ++row) {
      for (int x = 0; x < face_size; ++x) {
        const size_t texel = static_cast<size_t>(row) * face_size + x;
        const TexelTaps& t = (*taps)[texel];
        float* dst = cube.data.data() + texel * stride;
        switch (stride) {  // fixed trip counts for P = 0..3 with 3 channels
          case 3:
            Interpolate<3>(g, t, acc.data(), dst);
            break;
          case 12:
            Interpolate<12>(g, t, acc.data(), dst);
            break;
          case 27:
            Interpolate<27>(g, t, acc.data(), dst);
            break;
          case 48:
            Interpolate<48>(g, t, acc.data(), dst);
            break;
          default:
            Interpolate<0>(g, t, acc.data(), dst);
        }
      }
    }
  });
  return cube;
}

namespace {

// Value of texel (face, x, y) of `cube` for the view (SH frame), channel-wise into out.
void TexelValue(const ShrmCube& cube, int face, int x, int y, const Vec3& view_sh,
                std::span<const double> y_global, double weight, std::array<double, 3>& out) {
  const int n = cube.coeff_count();
  const float* coeffs = cube.data.data() + cube.Index(face, x, y, 0, 0);
  if (cube.kind == ShrmKind::kGlobal) {
    for (int c = 0; c < std::min(cube.channels, 3); ++c)
      out[c] += weight * DotSh(y_global, coeffs, n, cube.channels, c);
    return;
  }
  double alpha, beta;
  ShrmAnglesFromWorld(CubeTexelDirection(face, x, y, cube.face_size), &alpha, &beta);
  const Vec3 w = ShrmLocalFrame(alpha, beta).Transposed() * view_sh;
  double ybuf[256];
  std::vector<double> yvec;
  std::span<double> ys;
  if (n <= 256) {
    ys = std::span<double>(ybuf, n);
  } else {
    yvec.resize(n);
    ys = yvec;
  }
  EvalSh(cube.pmax, w, ys);
  for (int c = 0; c < std::min(cube.channels, 3); ++c)
    out[c] += weight * DotSh(ys, coeffs, n, cube.channels, c);
}

// Texel of `face` at integer coordinates that may lie one step outside the face: the texel of the
// adjacent face containing the extrapolated centre direction.
void ResolveTexel(int face, int x, int y, int size, int* of, int* ox, int* oy) {
  if (x >= 0 && x < size && y >= 0 && y < size) {
    *of = face;
    *ox = x;
    *oy = y;
    return;
  }
  const Vec3 d = CubeFaceDirection(face, (x + 0.5) / size, (y + 0.5) / size);
  double s, t;
  CubeFaceCoordinates(d, of, &s, &t);
  *ox = std::clamp(static_cast<int>(std::floor(s * size)), 0, size - 1);
  *oy = std::clamp(static_cast<int>(std::floor(t * size)), 0, size - 1);
}

}  // namespace

std::array<double, 3> ShrmEvalAt(const ShrmCube& cube, const Vec3& index_dir, const Vec3& view) {
  std::array<double, 3> out{0, 0, 0};
  const int size = cube.face_size;
  if (size < 1 || cube.data.size() != cube.size()) return out;
  int face;
  double s, t;
  CubeFaceCoordinates(index_dir, &face, &s, &t);
  const double x = s * size - 0.5, y = t * size - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const Vec3 view_sh = ShFrameFromWorld(view);
  std::vector<double> y_global;
  if (cube.kind == ShrmKind::kGlobal) y_global = EvalSh(cube.pmax, view_sh);
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      if (w == 0) continue;
      int tf, tx, ty;
      ResolveTexel(face, x0 + dx, y0 + dy, size, &tf, &tx, &ty);
      TexelValue(cube, tf, tx, ty, view_sh, y_global, w, out);
    }
  return out;
}

std::array<double, 3> ShrmEval(const ShrmCube& cube, const Vec3& n, const Vec3& v) {
  if (cube.index == ReparamKind::kTangent) return ShrmEvalAt(cube, n, v);
  const Vec3 r = n * (2 * n.Dot(v)) - v;
  return ShrmEvalAt(cube, r, v);
}

std::array<double, 3> ShrmTexelRadiance(const ShrmCube& cube, int face, int x, int y,
                                        const Vec3& view) {
  std::array<double, 3> out{0, 0, 0};
  const Vec3 view_sh = ShFrameFromWorld(view);
  std::vector<double> y_global;
  if (cube.kind == ShrmKind::kGlobal) y_global = EvalSh(cube.pmax, view_sh);
  TexelValue(cube, face, x, y, view_sh, y_global, 1.0, out);
  return out;
}

}  // namespace shrm
