#include "core/shrm/shrm_synthesis.h"

#include <fftw3.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"
#include "core/sh/wigner_columns.h"
#include "core/shrm/cube_resample.h"
#include "core/transform/real_fft.h"
#include "core/transform/sht.h"

namespace shrm {

namespace {
// The azimuthal DFTs of SynthesizeRows (its fft_plan argument): ComplexFft, or FFTW's plan.
struct RowFft {
  std::shared_ptr<const internal::ComplexFft> complex;
  fftw_plan fftw = nullptr;
  int series = 0;
};
}  // namespace

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
  s.view_ = brdf.view;
  if (!brdf.fresnel.empty()) {
    if (brdf.fresnel.size() != static_cast<size_t>(kFresnelIntervals + 1) * brdf.channels) {
      return absl::InvalidArgumentError(absl::StrCat("SHRM: BRDF Fresnel table has ",
                                                     brdf.fresnel.size(), " values, expected ",
                                                     (kFresnelIntervals + 1) * brdf.channels));
    }
    s.fresnel_.assign(brdf.fresnel.begin(), brdf.fresnel.end());
  }
  s.light_.assign(static_cast<size_t>(2 * f + 1) * (f + 1) * channels, {0.0, 0.0});
  // Degrees up to f only: the lighting is in degree-major order, so its first (f + 1)^2 values are
  // those (the lighting can go much higher: degree 511 for a split-sum level of degree 241).
  std::vector<double> real(ShCount(f));
  std::vector<std::complex<double>> cplx(ShCount(f));
  for (int c = 0; c < channels; ++c) {
    for (int k = 0; k < ShCount(f); ++k) real[k] = light[static_cast<size_t>(k) * channels + c];
    RealToComplex(f, real, cplx);
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
  s.rho_pairs_.resize(2 * s.rho_.size());
  for (size_t i = 0; i < s.rho_.size(); ++i)
    s.rho_pairs_[2 * i] = s.rho_pairs_[2 * i + 1] = s.rho_[i];
  return s;
}

double ShrmSynthesizer::Fresnel(double cos_n, int c) const {
  return FresnelFactor(fresnel_, cos_n, c);
}

std::complex<double> ShrmSynthesizer::Blmpq(int l, int m, int p, int q, int c) const {
  if (l < 0 || l > lmax_ || p < 0 || p > pmax_ || std::abs(m) > l || std::abs(q) > std::min(l, p))
    return {0.0, 0.0};
  return light_[(static_cast<size_t>(m + lmax_) * (lmax_ + 1) + l) * channels_ + c] *
         Rho(l, p, q, c);
}

double ShrmSynthesizer::BandEnergy(int l, int p, int c) const {
  double light = 0;
  for (int m = -l; m <= l; ++m)
    light += std::norm(light_[(static_cast<size_t>(m + lmax_) * (lmax_ + 1) + l) * channels_ + c]);
  double rho = 0;
  for (int pp = 0; pp <= p; ++pp)
    for (int q = -std::min(l, pp); q <= std::min(l, pp); ++q) {
      const double r = Rho(l, pp, q, c);
      rho += r * r;
    }
  return 4 * kPi / (2 * l + 1) * light * rho;
}

std::vector<double> ShrmSynthesizer::TruncatedEnergy(int f, int p) const {
  std::vector<double> e(channels_, 0.0);
  f = std::min(f, lmax_);
  p = std::min(p, pmax_);
  for (int c = 0; c < channels_; ++c)
    for (int l = 0; l <= f; ++l) e[c] += BandEnergy(l, p, c);
  return e;
}

int ShrmSynthesizer::InterpolationRows(ShrmKind kind, double tolerance) const {
  const int f = lmax_, pm = pmax_;
  const int generic = FftFriendlyRings(std::max(32, 4 * (f + pm + 1)));
  if (!(tolerance > 0)) return generic;
  // The global kind's coefficients are turned by Rot(alpha, beta) (eq. 5.14), which adds up to P
  // to each frequency in both angles: band l is taken at frequency l + P.
  const int shift = kind == ShrmKind::kGlobal ? pm : 0;
  std::vector<double> band(f + 1, 0.0);
  for (int l = 0; l <= f; ++l)
    for (int c = 0; c < channels_; ++c) band[l] += BandEnergy(l, pm, c);
  return CubicGridRows(band, shift, tolerance, f + pm + 1, generic);
}

int CubicGridRows(std::span<const double> band, int shift, double tolerance, int min_rows,
                  int max_rows) {
  // Cubic (4-point Lagrange) interpolation of frequency k on spacing h = pi / na errs by
  // (k h)^4 |w(x)| / 24 of its amplitude along each axis, w(x) = (x + 1) x (x - 1) (x - 2) the
  // node polynomial between the middle nodes (RMS over x: 0.404), at most about twice the
  // amplitude once k h passes ~2; the two axes add, and the bands' errors add as the
  // truncation's do.
  constexpr double kCubicRmsPerAxis = 0.404 / 24;
  constexpr double kLargestBandError = 2;
  double total = 0;
  for (double e : band) total += e;
  if (!(total > 0) || !(tolerance > 0)) return FftFriendlyRings(max_rows);
  for (int na = FftFriendlyRings(std::max(32, min_rows)); na < max_rows;
       na = FftFriendlyRings(na + 8)) {
    const double h = kPi / na;
    double err = 0;
    for (size_t l = 1; l < band.size(); ++l) {
      const double kh = static_cast<double>(l + shift) * h;
      const double e = std::min(kLargestBandError, 2 * kCubicRmsPerAxis * kh * kh * kh * kh);
      err += e * e * band[l];
    }
    if (err <= tolerance * tolerance * total) return na;
  }
  return FftFriendlyRings(max_rows);
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
  return RadianceAtArgument(kind, index_dir, ShrmViewArgument(view_, index_dir, view));
}

std::array<double, 3> ShrmSynthesizer::RadianceAtArgument(ShrmKind kind, const Vec3& index_dir,
                                                          const Vec3& argument) const {
  double alpha, beta;
  ShrmAnglesFromWorld(index_dir, &alpha, &beta);
  const int n = ShCount(pmax_);
  std::vector<double> coeffs(static_cast<size_t>(n) * channels_);
  CoefficientsAt(kind, alpha, beta, coeffs);
  Vec3 w = ShFrameFromWorld(argument);
  if (kind == ShrmKind::kLocal) w = ShrmLocalFrame(alpha, beta).Transposed() * w;
  const std::vector<double> y = EvalSh(pmax_, w);
  std::array<double, 3> out{0, 0, 0};
  for (int c = 0; c < std::min(channels_, 3); ++c) {
    for (int k = 0; k < n; ++k) out[c] += y[k] * coeffs[static_cast<size_t>(k) * channels_ + c];
    out[c] *= Fresnel(FresnelCosine(view_, index_dir, argument), c);
  }
  return out;
}

void ShrmSynthesizer::BandContributionsAt(const Vec3& index_dir, const Vec3& view,
                                          std::span<double> out) const {
  BandContributionsAtArgument(index_dir, ShrmViewArgument(view_, index_dir, view), out);
}

void ShrmSynthesizer::BandContributionsAtArgument(const Vec3& index_dir, const Vec3& argument,
                                                  std::span<double> out) const {
  const int f = lmax_, pm = pmax_, ch = channels_;
  const int qmax = std::min(pm, f);
  double alpha, beta;
  ShrmAnglesFromWorld(index_dir, &alpha, &beta);
  // Per-thread columns (every entry read below, l >= max(|m|, q), is written by Compute).
  thread_local std::vector<double> d;
  d.resize(WignerColumnCount(f, qmax));
  BandWignerTables().Compute(alpha, d);
  const Vec3 w = ShrmLocalFrame(alpha, beta).Transposed() * ShFrameFromWorld(argument);
  const std::vector<double> y = EvalSh(pm, w);
  // e^{i m beta} L_lm for every (m, l, c), then per l the sums over m
  //   S_lq = sum_m e^{i m beta} L_lm d^l_mq(alpha)   (q = 0 .. min(l, P)),
  // so the local coefficient of band l is rho_lpq S_lq (eq. 5.23 with one l), q >= 0 only: the
  // real SH value is c_p0 Y_p0 + sqrt2 sum_{q > 0} (Re c_pq Y_pq - Im c_pq Y_p,-q) (ComplexToReal).
  std::vector<std::complex<double>> el(static_cast<size_t>(2 * f + 1) * (f + 1) * ch);
  for (int m = -f; m <= f; ++m) {
    const std::complex<double> e = std::polar(1.0, m * beta);
    const size_t base = static_cast<size_t>(m + f) * (f + 1) * ch;
    for (size_t k = 0; k < static_cast<size_t>(f + 1) * ch; ++k)
      el[base + k] = e * light_[base + k];
  }
  std::vector<std::complex<double>> sq(static_cast<size_t>(qmax + 1) * ch);
  for (int l = 0; l <= f; ++l) {
    const int ql = std::min(l, qmax);
    std::fill(sq.begin(), sq.end(), std::complex<double>(0, 0));
    for (int q = 0; q <= ql; ++q)
      for (int m = -l; m <= l; ++m) {
        const double dv = d[WignerColumnIndex(f, qmax, l, m, q)];
        const std::complex<double>* lm = &el[(static_cast<size_t>(m + f) * (f + 1) + l) * ch];
        for (int c = 0; c < ch; ++c) sq[static_cast<size_t>(q) * ch + c] += dv * lm[c];
      }
    for (int p = 0; p <= pm; ++p)
      for (int c = 0; c < ch; ++c) {
        double v = Rho(l, p, 0, c) * sq[c].real() * y[ShIndex(p, 0)];
        for (int q = 1; q <= std::min(p, ql); ++q) {
          const std::complex<double> cpq = Rho(l, p, q, c) * sq[static_cast<size_t>(q) * ch + c];
          v += kSqrt2 * (cpq.real() * y[ShIndex(p, q)] - cpq.imag() * y[ShIndex(p, -q)]);
        }
        out[(static_cast<size_t>(l) * (pm + 1) + p) * ch + c] = v;
      }
  }
  ScaleByFresnel(index_dir, argument, out.data());
}

void ShrmSynthesizer::ScaleByFresnel(const Vec3& index_dir, const Vec3& argument,
                                     double* bands) const {
  if (fresnel_.empty()) return;
  const size_t per_channel = static_cast<size_t>(lmax_ + 1) * (pmax_ + 1);
  for (int c = 0; c < channels_; ++c) {
    const double a = Fresnel(FresnelCosine(view_, index_dir, argument), c);
    for (size_t i = 0; i < per_channel; ++i) bands[i * channels_ + c] *= a;
  }
}

const WignerColumnTables& ShrmSynthesizer::BandWignerTables() const {
  std::call_once(band_tables_->once, [&] {
    band_tables_->tables = std::make_unique<WignerColumnTables>(lmax_, std::min(pmax_, lmax_));
  });
  return *band_tables_->tables;
}

void ShrmSynthesizer::BandContributionsAtArguments(std::span<const Vec3> index_dirs,
                                                   std::span<const Vec3> arguments,
                                                   std::span<double> out) const {
  const size_t n = std::min(index_dirs.size(), arguments.size());
  for (size_t k = 0; k < n; k += kWignerBlock) {
    const int nb = static_cast<int>(std::min<size_t>(kWignerBlock, n - k));
    BandContributionsBlock(index_dirs.data() + k, arguments.data() + k, nb,
                           out.data() + k * BandCount());
    for (int r = 0; r < nb; ++r)
      ScaleByFresnel(index_dirs[k + r], arguments[k + r], out.data() + (k + r) * BandCount());
  }
}

void ShrmSynthesizer::LSumsBlock(const double* alpha, const double* beta, int n,
                                 std::vector<Lanes>& sre, std::vector<Lanes>& sim) const {
  // For the block's angles side by side (lane r; lanes r >= n repeat angle n - 1): per m,
  // E[l][c][r] = e^{i m beta_r} L_lm, then for each q the Wigner column d^l_mq(alpha_r) from the
  // recurrence, consumed degree by degree: S[q][l][c][r] += d^l_mq(alpha_r) E[l][c][r].
  // Real lighting gives L_{l,-m} = (-1)^m conj(L_lm), so E_{-m} = (-1)^m conj(E_m): the columns
  // (m, q) and (-m, q) are taken together, S_lq += (d_m + (-1)^m d_-m) Re E_m
  //                                             + i (d_m - (-1)^m d_-m) Im E_m.
  constexpr int B = kWignerBlock;
  const int f = lmax_, ch = channels_;
  const int qr = RhoQmax();
  const WignerColumnTables& tables = BandWignerTables();
  const WignerColumnTables::BlockAngles angles = tables.Angles(alpha, n);
  thread_local std::vector<Lanes> ere, eim;
  const size_t row = ch;
  ere.resize((f + 1) * row);
  eim.resize((f + 1) * row);
  sre.assign((qr + 1) * (f + 1) * row, Lanes{});
  sim.assign((qr + 1) * (f + 1) * row, Lanes{});
  // e^{i m beta} by the angle-addition recurrence from e^{i beta}: m rotations of rounding,
  // below 1e-13 at m = 256 (a sine and a cosine per m and lane took a sixth of a P = 0 band
  // table's time).
  Lanes c1, s1, cm, sm;
  for (int r = 0; r < B; ++r) {
    c1[r] = std::cos(beta[r]);
    s1[r] = std::sin(beta[r]);
    cm[r] = 1;
    sm[r] = 0;
  }
  for (int m = 0; m <= f; ++m) {
    if (m > 0) {
      const Lanes c = cm * c1 - sm * s1;
      sm = sm * c1 + cm * s1;
      cm = c;
    }
    const std::complex<double>* lm = light_.data() + static_cast<size_t>(m + f) * (f + 1) * ch;
    for (int l = m; l <= f; ++l)
      for (int c = 0; c < ch; ++c) {
        const double lr = lm[l * ch + c].real(), li = lm[l * ch + c].imag();
        ere[l * row + c] = cm * lr - sm * li;
        eim[l * row + c] = cm * li + sm * lr;
      }
    const double sign = m % 2 ? -1.0 : 1.0;
    for (int q = 0; q <= std::min(qr, f); ++q) {
      Lanes* qre = sre.data() + static_cast<size_t>(q) * (f + 1) * row;
      Lanes* qim = sim.data() + static_cast<size_t>(q) * (f + 1) * row;
      auto add = [&](int l, const Lanes& dre, const Lanes& dim) {
        const Lanes* er = ere.data() + l * row;
        const Lanes* ei = eim.data() + l * row;
        Lanes* tr = qre + l * row;
        Lanes* ti = qim + l * row;
        for (int c = 0; c < ch; ++c) {
          tr[c] += dre * er[c];
          ti[c] += dim * ei[c];
        }
      };
      if (m == 0) {
        tables.VisitColumn(angles, 0, q, [&](int l, const Lanes& d) { add(l, d, d); });
      } else {
        tables.VisitColumnPair(angles, m, q, [&](int l, const Lanes& dp, const Lanes& dm) {
          add(l, dp + sign * dm, dp - sign * dm);
        });
      }
    }
  }
}

void ShrmSynthesizer::BandContributionsBlock(const Vec3* index_dirs, const Vec3* arguments, int n,
                                             double* out) const {
  // BandContributionsAtArgument for the block's points side by side (lane r = point r; lanes
  // r >= n repeat point n - 1): the l-sums S_lq of LSumsBlock, then per point, l and p the real
  // SH combination of rho_lpq S_lq with Y_pq(w_r).
  constexpr int B = kWignerBlock;
  const int f = lmax_, pm = pmax_, ch = channels_;
  const int qr = RhoQmax();
  double alpha[B], beta[B];
  for (int r = 0; r < B; ++r)
    ShrmAnglesFromWorld(index_dirs[std::min(r, n - 1)], &alpha[r], &beta[r]);
  thread_local std::vector<Lanes> sre, sim;
  LSumsBlock(alpha, beta, n, sre, sim);
  const size_t row = ch;
  // Per l: T[p][c] = Re(rho_lp0 S_l0) Y_p0 + sqrt2 sum_{0 < q <= p} rho_lpq (Re S_lq Y_pq -
  // Im S_lq Y_p,-q) (the real SH value of the complex expansion, ComplexToReal), all points at
  // once, then each point's terms to its output.
  std::vector<Lanes> y(ShCount(pm));
  for (int r = 0; r < B; ++r) {
    const int k = std::min(r, n - 1);
    const std::vector<double> yr =
        EvalSh(pm, ShrmLocalFrame(alpha[r], beta[r]).Transposed() * ShFrameFromWorld(arguments[k]));
    for (int i = 0; i < ShCount(pm); ++i) y[i][r] = yr[i];
  }
  const size_t count = BandCount();
  std::vector<Lanes> t((pm + 1) * row);
  for (int l = 0; l <= f; ++l) {
    std::fill(t.begin(), t.end(), Lanes{});
    for (int q = 0; q <= std::min(l, qr); ++q) {
      const Lanes* qre = sre.data() + (static_cast<size_t>(q) * (f + 1) + l) * row;
      const Lanes* qim = sim.data() + (static_cast<size_t>(q) * (f + 1) + l) * row;
      for (int p = q; p <= pm; ++p) {
        const Lanes yp = y[ShIndex(p, q)], ym = y[ShIndex(p, -q)];
        for (int c = 0; c < ch; ++c) {
          const double w = q == 0 ? Rho(l, p, 0, c) : kSqrt2 * Rho(l, p, q, c);
          t[p * row + c] += w * (q == 0 ? qre[c] * yp : qre[c] * yp - qim[c] * ym);
        }
      }
    }
    for (int r = 0; r < n; ++r) {
      double* o = out + r * count + static_cast<size_t>(l) * (pm + 1) * ch;
      for (size_t i = 0; i < (pm + 1) * row; ++i) o[i] = t[i][r];
    }
  }
}

void ShrmSynthesizer::SynthesizeRows(ShrmKind kind, const double* alphas, int rows, int nb,
                                     int grid_stride, void* fft_plan,
                                     const WignerColumnTables& tables,
                                     const WignerColumnTables& ptables, RowScratch& scratch,
                                     float* rows_out) const {
  constexpr int B = kWignerBlock;
  const int f = lmax_, pm = pmax_, ch = channels_;
  const int qmax = std::min(pm, f);
  // The orders q whose rho_lpq can be nonzero: all, or only q = 0 for the tangent
  // reparameterization (Create leaves the others zero); the l-sums of the rest are zero.
  const int qrho = RhoQmax();
  const int n = ShCount(pm);
  const int stride = n * ch;
  // Step 1 (eq. 5.24, the l-sum) for the block of rows at once: the Wigner columns of all rows
  // side by side (lane r = row r), so each product L_lm rho_lpq is formed once and applied to
  // every row with one vector FMA.
  //   bm[((m + F) * n + ShIndex(p, q)) * ch + c][r] = sum_l L_lm rho_lpq d^l_mq(alpha_r)
  // (q >= 0 here; the global kind's q < 0 below, by symmetry).
  // Each column d^l_mq (l >= max(|m|, q)) is made just before its sums, into one (F + 1) x B
  // buffer that stays in cache: all of them made first (as before session 27) are
  // megabytes, written and read back through memory once per block.
  const WignerColumnTables::BlockAngles angles = tables.Angles(alphas, rows);
  double* col = scratch.buf->cols.data();
  const size_t nm = 2 * f + 1;  // layout bre[((ShIndex(p, q) * ch + c) * B + r) * nm + m + F]
  double* bre = scratch.buf->bre.data();
  double* bim = scratch.buf->bim.data();
  // q outside m: the rho_lpq of one q (p >= q, every l) stay in cache across the m loop (all of
  // them, re-read per m, are megabytes at the default job's orders).
  for (int q = 0; q <= qrho; ++q) {
    for (int m = -f; m <= f; ++m) {
      const std::complex<double>* lm = light_.data() + static_cast<size_t>(m + f) * (f + 1) * ch;
      tables.VisitColumn(angles, m, q, [&](int l, const WignerColumnTables::Lanes& v) {
        std::memcpy(col + l * B, &v, sizeof v);
      });
      const double* d = col;
      const int l0 = std::max(std::abs(m), std::abs(q));
      for (int p = std::abs(q); p <= pm; ++p) {
        const double* rho =
            rho_.data() + (static_cast<size_t>(p) * (pm + 1) + std::abs(q)) * (f + 1) * ch;
#if defined(__AVX512F__)
        if (ch == 3) {
          // The three channels at once: w[l] = (Re, Im) L_lm rho_lpq per channel, six products
          // a degree formed together, then six independent FMA chains over the degrees (the
          // chain per channel and part alone waits on the FMA's latency every step).
          double* w = scratch.buf->w.data();
          const double* lv = reinterpret_cast<const double*>(lm) + l0 * 6;
          const double* r2 = rho_pairs_.data() + 2 * (rho - rho_.data()) + l0 * 6;
          for (int i = 0; i < (f + 1 - l0) * 6; ++i) w[i] = lv[i] * r2[i];
          __m512d a0 = _mm512_setzero_pd(), a1 = a0, a2 = a0, a3 = a0, a4 = a0, a5 = a0;
          for (int l = l0; l <= f; ++l) {
            const __m512d dl = _mm512_loadu_pd(d + l * B);
            const double* wl = w + (l - l0) * 6;
            a0 = _mm512_fmadd_pd(_mm512_set1_pd(wl[0]), dl, a0);
            a1 = _mm512_fmadd_pd(_mm512_set1_pd(wl[1]), dl, a1);
            a2 = _mm512_fmadd_pd(_mm512_set1_pd(wl[2]), dl, a2);
            a3 = _mm512_fmadd_pd(_mm512_set1_pd(wl[3]), dl, a3);
            a4 = _mm512_fmadd_pd(_mm512_set1_pd(wl[4]), dl, a4);
            a5 = _mm512_fmadd_pd(_mm512_set1_pd(wl[5]), dl, a5);
          }
          const __m512d acc[6] = {a0, a1, a2, a3, a4, a5};
          for (int c = 0; c < 3; ++c) {
            alignas(64) double re[B], im[B];
            _mm512_store_pd(re, acc[2 * c]);
            _mm512_store_pd(im, acc[2 * c + 1]);
            const size_t o = ((static_cast<size_t>(ShIndex(p, q)) * ch + c) * B) * nm + (m + f);
            for (int r = 0; r < B; ++r) {
              bre[o + r * nm] = re[r];
              bim[o + r * nm] = im[r];
            }
          }
          continue;
        }
#endif
        for (int c = 0; c < ch; ++c) {
          alignas(64) double re[B], im[B];
#if defined(__AVX512F__)
          static_assert(B == 8, "one AVX-512 vector of doubles per block");
          __m512d vre = _mm512_setzero_pd(), vim = _mm512_setzero_pd();
          for (int l = l0; l <= f; ++l) {
            const double w = rho[l * ch + c];
            const __m512d dl = _mm512_loadu_pd(d + l * B);
            vre = _mm512_fmadd_pd(_mm512_set1_pd(lm[l * ch + c].real() * w), dl, vre);
            vim = _mm512_fmadd_pd(_mm512_set1_pd(lm[l * ch + c].imag() * w), dl, vim);
          }
          _mm512_store_pd(re, vre);
          _mm512_store_pd(im, vim);
#else
          for (int r = 0; r < B; ++r) re[r] = im[r] = 0.0;
          for (int l = l0; l <= f; ++l) {
            const double w = rho[l * ch + c];
            const double wr = lm[l * ch + c].real() * w, wi = lm[l * ch + c].imag() * w;
            const double* dl = d + l * B;
            for (int r = 0; r < B; ++r) {
              re[r] += wr * dl[r];
              im[r] += wi * dl[r];
            }
          }
#endif
          const size_t o = ((static_cast<size_t>(ShIndex(p, q)) * ch + c) * B) * nm + (m + f);
          for (int r = 0; r < B; ++r) {
            bre[o + r * nm] = re[r];
            bim[o + r * nm] = im[r];
          }
        }
      }
    }
  }
  if (kind == ShrmKind::kGlobal) {
    // q < 0 from q > 0: with L_{l,-m} = (-1)^m conj(L_lm) (real lighting), rho_{l,p,-q} = rho_lpq
    // and d^l_{-m,-q} = (-1)^{m-q} d^l_mq, B_{m,p,q} = (-1)^q conj(B_{-m,p,-q}) (half of the
    // l-sums; tests/shrm_synthesis_test.cc checks the grid against the direct eq. 5.23 / 5.14).
    for (int q = 1; q <= qrho; ++q) {
      const double sign = q % 2 == 0 ? 1.0 : -1.0;
      for (int p = q; p <= pm; ++p)
        for (int c = 0; c < ch; ++c)
          for (int r = 0; r < B; ++r) {
            const size_t pos = ((static_cast<size_t>(ShIndex(p, q)) * ch + c) * B + r) * nm;
            const size_t neg = ((static_cast<size_t>(ShIndex(p, -q)) * ch + c) * B + r) * nm;
            for (size_t i = 0; i < nm; ++i) {
              bre[neg + i] = sign * bre[pos + nm - 1 - i];
              bim[neg + i] = -sign * bim[pos + nm - 1 - i];
            }
          }
    }
  }
  // Step 2 per row: the series over m (shifted by s for the global kind, eq. 5.14), one batched
  // FFT (the sum over m with e^{i m beta}), real SH out.
  std::complex<double>* work = scratch.work;
  auto bin = [nb](int m) { return m < 0 ? m + nb : m; };  // |m| < nb here
  for (int r = 0; r < rows; ++r) {
    // Every series gets the bins m - s, |m| <= F, written below, the same bins for every row; the
    // others were zeroed once (the FFT is out of place, so they stay zero).
    auto bm_at = [&](int p, int q, int c) {
      return ((static_cast<size_t>(ShIndex(p, q)) * ch + c) * B + r) * nm;
    };
    if (kind == ShrmKind::kLocal) {
      for (int p = 0; p <= pm; ++p)
        for (int q = 0; q <= std::min(p, qmax); ++q) {
          const int t = p * (p + 1) / 2 + q;
          for (int c = 0; c < ch; ++c) {
            std::complex<double>* w = work + static_cast<size_t>(t * ch + c) * nb;
            if (q > qrho) {  // rho_lpq = 0
              for (int m = -f; m <= f; ++m) w[bin(m)] = {0.0, 0.0};
              continue;
            }
            const double* re = bre + bm_at(p, q, c);
            const double* im = bim + bm_at(p, q, c);
            for (int m = -f; m <= f; ++m) w[bin(m)] = {re[m + f], im[m + f]};
          }
        }
    } else {
      ptables.Compute(alphas[r], scratch.buf->dp);
      const std::span<const double> dp = scratch.buf->dp;
      double* sre = scratch.buf->sre.data();
      double* sim = scratch.buf->sim.data();
      for (int p = 0; p <= pm; ++p)
        for (int s = 0; s <= p; ++s) {
          const int t = p * (p + 1) / 2 + s;
          for (int c = 0; c < ch; ++c) {
            const int qn = std::min(p, qrho);
#if defined(__AVX512F__)
            // 32 of the nm sums at a time in registers (eight FMA chains), the same products
            // in the same order as the loop below.
            for (size_t i0 = 0; i0 < nm; i0 += 32) {
              __mmask8 keep[4];
              __m512d ar[4], ai[4];
              for (int j = 0; j < 4; ++j) {
                const size_t i = i0 + 8 * j;
                const size_t lanes = i < nm ? std::min<size_t>(8, nm - i) : 0;
                keep[j] = static_cast<__mmask8>((1u << lanes) - 1);
                ar[j] = ai[j] = _mm512_setzero_pd();
              }
              for (int q = -qn; q <= qn; ++q) {
                const __m512d w = _mm512_set1_pd(dp[WignerColumnIndex(pm, pm, p, s, q)]);
                const double* re = bre + bm_at(p, q, c) + i0;
                const double* im = bim + bm_at(p, q, c) + i0;
                for (int j = 0; j < 4; ++j) {
                  ar[j] = _mm512_fmadd_pd(w, _mm512_maskz_loadu_pd(keep[j], re + 8 * j), ar[j]);
                  ai[j] = _mm512_fmadd_pd(w, _mm512_maskz_loadu_pd(keep[j], im + 8 * j), ai[j]);
                }
              }
              for (int j = 0; j < 4; ++j) {
                _mm512_mask_storeu_pd(sre + i0 + 8 * j, keep[j], ar[j]);
                _mm512_mask_storeu_pd(sim + i0 + 8 * j, keep[j], ai[j]);
              }
            }
#else
            for (size_t i = 0; i < nm; ++i) sre[i] = sim[i] = 0.0;
            for (int q = -qn; q <= qn; ++q) {
              const double w = dp[WignerColumnIndex(pm, pm, p, s, q)];
              const double* re = bre + bm_at(p, q, c);
              const double* im = bim + bm_at(p, q, c);
              for (size_t i = 0; i < nm; ++i) {
                sre[i] += w * re[i];
                sim[i] += w * im[i];
              }
            }
#endif
            std::complex<double>* w = work + static_cast<size_t>(t * ch + c) * nb;
            for (int m = -f; m <= f; ++m) w[bin(m - s)] = {sre[m + f], sim[m + f]};
          }
        }
    }
    const auto& row_fft = *static_cast<const RowFft*>(fft_plan);
    if (row_fft.complex) {
      row_fft.complex->Backward(work, scratch.out, row_fft.series);
    } else {
      fftw_execute_dft(row_fft.fftw, reinterpret_cast<fftw_complex*>(work),
                       reinterpret_cast<fftw_complex*>(scratch.out));
    }
    float* row_out = rows_out + static_cast<size_t>(r) * nb * grid_stride;
    if (grid_stride > stride) {
      for (int k = 0; k < nb; ++k)
        std::fill_n(row_out + static_cast<size_t>(k) * grid_stride + stride, grid_stride - stride,
                    0.0f);
    }
    // The series (one per p, q, c, over the row's nb columns) into the row's texel-major
    // values, a tile of kTile columns at a time: a column's values lie grid_stride floats apart
    // (7.5 KB at (56, 24)), so series by series over the whole row, each value was a cache
    // line of its own and the row (2.4 MB there) left the cache before its lines were filled:
    // most of the synthesis's time at high orders. A tile's columns stay in cache while every
    // series writes them, and each series is read a few lines at a time.
    constexpr int kTile = 8;
    for (int k0 = 0; k0 < nb; k0 += kTile) {
      const int k1 = std::min(nb, k0 + kTile);
      for (int p = 0; p <= pm; ++p)
        for (int q = 0; q <= p; ++q) {
          const int t = p * (p + 1) / 2 + q;
          for (int c = 0; c < ch; ++c) {
            const std::complex<double>* series = scratch.out + static_cast<size_t>(t * ch + c) * nb;
            if (q == 0) {
              float* o = row_out + ShIndex(p, 0) * ch + c;
              for (int k = k0; k < k1; ++k)
                o[static_cast<size_t>(k) * grid_stride] = static_cast<float>(series[k].real());
            } else {
              float* op = row_out + ShIndex(p, q) * ch + c;
              float* on = row_out + ShIndex(p, -q) * ch + c;
              for (int k = k0; k < k1; ++k) {
                op[static_cast<size_t>(k) * grid_stride] =
                    static_cast<float>(kSqrt2 * series[k].real());
                on[static_cast<size_t>(k) * grid_stride] =
                    static_cast<float>(-kSqrt2 * series[k].imag());
              }
            }
          }
        }
    }
  }
}

absl::Status ShrmSynthesizer::CheckGridRows(ShrmKind kind, int na) const {
  const int extra = kind == ShrmKind::kGlobal ? pmax_ : 0;
  if (na < lmax_ + extra + 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHRM grid: ", na, " alpha samples cannot resolve degree ", lmax_ + extra,
                     " (need >= ", lmax_ + extra + 1, ")"));
  }
  return absl::OkStatus();
}

absl::StatusOr<ShrmSynthesizer::Grid> ShrmSynthesizer::BuildGrid(ShrmKind kind, int na,
                                                                 int threads) const {
  if (absl::Status s = CheckGridRows(kind, na); !s.ok()) return s;
  if (threads < 1)
    return absl::InvalidArgumentError(absl::StrCat("SHRM grid: threads = ", threads));
  Grid g;
  g.na = na;
  g.nb = 2 * na;
  g.stride = ShCount(pmax_) * channels_;
  const int rows = na + 4;
  g.values.assign(static_cast<size_t>(rows) * g.nb * g.stride, 0.0f);
  SynthesizeSlabs(kind, na, rows, threads, g.stride, g.values.data(), [](int, int) {});
  return g;
}

void ShrmSynthesizer::SynthesizeSlabs(ShrmKind kind, int na, int owned, int threads,
                                      int grid_stride, float* out,
                                      const std::function<void(int, int)>& emit,
                                      SynthesisScratch* keep) const {
  const int nb = 2 * na, rows = na + 4;
  const int nseries = (pmax_ + 1) * (pmax_ + 2) / 2 * channels_;
  const size_t work_size = static_cast<size_t>(nseries) * nb;
  // The rows' azimuthal DFTs: ComplexFft for small grids of 7-smooth sizes (every grid
  // FftFriendlyRings gives), FFTW otherwise. ComplexFft needs no planner (FFTW's costs a process
  // about 2 ms on first use) but executes about 1.45 times slower than FFTW's codelets (measured
  // here: FFTW about 0.17 ns per unit of rows x series x n log2 n): up to kMaxComplexFftVolume
  // units (under a millisecond of FFTW's time) the planner costs more than the difference, and a
  // live session, which plans FFTW from its own wisdom each frame, loses at most 0.4 ms.
  constexpr double kMaxComplexFftVolume = 5e6;
  RowFft row_fft;
  row_fft.series = nseries;
  const double volume = static_cast<double>(rows) * nseries * nb * std::log2(std::max(nb, 2));
  if (volume <= kMaxComplexFftVolume) row_fft.complex = internal::ComplexFft::Get(nb);
  fftw_complex *probe = nullptr, *probe_out = nullptr;
  if (!row_fft.complex) {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    probe = fftw_alloc_complex(work_size);
    probe_out = fftw_alloc_complex(work_size);
    int n[1] = {nb};
    row_fft.fftw = fftw_plan_many_dft(1, n, nseries, probe, nullptr, 1, nb, probe_out, nullptr, 1,
                                      nb, FFTW_BACKWARD, FFTW_ESTIMATE);
  }
  void* const plan = &row_fft;
  const int qrho = RhoQmax();
  const WignerColumnTables tables(lmax_, qrho), ptables(pmax_, pmax_);
  constexpr int B = kWignerBlock;
  std::vector<RowScratch> scratches(std::max(1, threads));
  SynthesisScratch local;
  std::vector<SynthesisScratch::RowBuffers>& buffers = (keep != nullptr ? keep : &local)->rows;
  if (buffers.size() < scratches.size()) buffers.resize(scratches.size());
  for (size_t i = 0; i < scratches.size(); ++i) scratches[i].buf = &buffers[i];
  for (RowScratch& scratch : scratches) {
    {
      std::lock_guard<std::mutex> lock(FftwPlannerMutex());
      scratch.work = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(work_size));
      scratch.out = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(work_size));
    }
    std::fill(scratch.work, scratch.work + work_size, std::complex<double>(0, 0));
    // (Sized only: SynthesizeRows writes every value it reads.)
    scratch.buf->cols.resize(static_cast<size_t>(lmax_ + 1) * B);
    scratch.buf->dp.resize(WignerColumnCount(pmax_, pmax_));
    const size_t nbm = static_cast<size_t>(2 * lmax_ + 1) * ShCount(pmax_) * channels_ * B;
    scratch.buf->bre.resize(nbm);
    scratch.buf->bim.resize(nbm);
    scratch.buf->sre.resize(2 * lmax_ + 1);
    scratch.buf->sim.resize(2 * lmax_ + 1);
    scratch.buf->w.resize(static_cast<size_t>(lmax_ + 1) * 2 * channels_);
  }
  const size_t row_floats = static_cast<size_t>(nb) * grid_stride;
  for (int row_begin = 0; row_begin < rows - 3; row_begin += owned) {
    const int row_end = std::min(row_begin + owned + 3, rows);
    // Rows [row_begin, row_begin + 3) are the previous slab's last three (a row depends on its
    // alpha alone, whichever block made it): moved up, not made again (they were 3 of every 16
    // rows at (56, 24)).
    int made = row_begin;
    if (row_begin > 0) {
      std::memmove(out, out + static_cast<size_t>(owned) * row_floats,
                   3 * row_floats * sizeof(float));
      made = row_begin + 3;
    }
    const int blocks = (row_end - made + B - 1) / B;
    std::atomic<int> next_scratch{0};
    ParallelChunks(blocks, threads, [&](int begin, int end) {
      RowScratch& scratch = scratches[next_scratch++];
      for (int blk = begin; blk < end; ++blk) {
        const int r0 = made + blk * B, nrows = std::min(B, row_end - r0);
        double alphas[B];
        for (int r = 0; r < nrows; ++r) alphas[r] = kPi * (r0 + r - 2 + 0.5) / na;
        SynthesizeRows(kind, alphas, nrows, nb, grid_stride, plan, tables, ptables, scratch,
                       out + static_cast<size_t>(r0 - row_begin) * nb * grid_stride);
      }
    });
    emit(row_begin, row_end - row_begin);
  }
  for (RowScratch& scratch : scratches) {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    fftw_free(scratch.work);
    fftw_free(scratch.out);
  }
  if (row_fft.fftw != nullptr) {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    fftw_destroy_plan(row_fft.fftw);
    fftw_free(probe);
    fftw_free(probe_out);
  }
}

namespace {

#if defined(__AVX512F__)
constexpr bool kSimdExpansion = true;
// BuildZonalGlobalCube's texel: out[16 k + i] = w[w_base[k] + w_lane[16 k + i]] x
// b[b_lane[16 k + i]] for every chunk k (b: 32 floats, w and out with a chunk's slack).
void ExpandZonalTexel(const float* w, const float* b, int chunks, const int32_t* w_base,
                      const int32_t* w_lane, const int32_t* b_lane, float* out) {
  const __m512 b_lo = _mm512_loadu_ps(b), b_hi = _mm512_loadu_ps(b + 16);
  for (int k = 0; k < chunks; ++k) {
    // The zero-masking form with every lane kept: the plain intrinsic's _mm512_undefined_ps
    // trips GCC 12's -Wmaybe-uninitialized once inlined (the same instruction either way).
    const __m512 wv = _mm512_maskz_permutexvar_ps(0xFFFF, _mm512_loadu_si512(w_lane + 16 * k),
                                                  _mm512_loadu_ps(w + w_base[k]));
    const __m512 bv = _mm512_permutex2var_ps(b_lo, _mm512_loadu_si512(b_lane + 16 * k), b_hi);
    _mm512_storeu_ps(out + 16 * k, _mm512_mul_ps(wv, bv));
  }
}
#else
constexpr bool kSimdExpansion = false;
void ExpandZonalTexel(const float*, const float*, int, const int32_t*, const int32_t*,
                      const int32_t*, float*) {}
#endif

// The output storage of a cube: the scratch's released buffer when it is large enough (resize to
// the same size writes nothing; the resampling then writes every value), else a fresh one.
void AllocateCubeData(ShrmCube& cube, SynthesisScratch* scratch) {
  if (scratch != nullptr && scratch->cube.capacity() >= cube.size()) {
    cube.data = std::move(scratch->cube);
    scratch->cube = {};
    cube.data.resize(cube.size());
    return;
  }
  internal::ReserveLargeBuffer(cube.data, cube.size());
  cube.data.resize(cube.size());
}

}  // namespace

ShrmCube ShrmSynthesizer::NewCube(ShrmKind kind, int face_size, SynthesisScratch* scratch) const {
  ShrmCube cube;
  cube.kind = kind;
  cube.index = reparam_;
  cube.view = view_;
  cube.fresnel = fresnel_;
  cube.face_size = face_size;
  cube.pmax = pmax_;
  cube.channels = channels_;
  AllocateCubeData(cube, scratch);
  return cube;
}

int FftFriendlyRings(int na) {
  auto smooth = [](int v) {
    for (int p : {2, 3, 5, 7})
      while (v % p == 0) v /= p;
    return v == 1;
  };
  na = (std::max(na, 1) + 7) / 8 * 8;
  while (!smooth(na)) na += 8;
  return na;
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
    na = FftFriendlyRings(std::max(32, 4 * (lmax_ + pmax_ + 1)));
  }
  if (pmax_ == 0 && options.p0_sht_path) {
    return BuildCubeP0(kind, face_size, na, options.threads, options.scratch);
  }
  if (pmax_ > 0 && kind == ShrmKind::kGlobal && RhoQmax() == 0 && options.p0_sht_path &&
      options.path == ShrmGridOptions::CubePath::kAuto) {
    // The zonal coefficients have degree F only; the grid keeps the general path's rows (its
    // interpolation error falls with them, and the SHT's share of the time is small).
    return BuildZonalGlobalCube(face_size, na, options.threads, options.scratch);
  }
  if (pmax_ > 0 && (options.path == ShrmGridOptions::CubePath::kDirect ||
                    (options.path == ShrmGridOptions::CubePath::kAuto &&
                     DirectCubeIsCheaper(kind, face_size, na)))) {
    return BuildCubeDirect(kind, face_size, options.threads, options.scratch);
  }
  if (absl::Status s = CheckGridRows(kind, na); !s.ok()) return s;
  // Above the resampling's fixed-stride kernels (P <= 3 with 3 channels: up to 48 floats) the
  // grid's nodes are padded to whole 64-byte lines (16 floats) on a 64-byte aligned buffer, so
  // that its loads never straddle two lines (P = 5: 5.0 -> 4.4 ms for a 64 x 64 x 6 cube).
  const int nb = 2 * na, stride = ShCount(pmax_) * channels_, rows = na + 4;
  const int grid_stride = stride > 48 ? (stride + 15) / 16 * 16 : stride;
  const size_t row_bytes = static_cast<size_t>(nb) * grid_stride * sizeof(float);
  // Slabs (when the whole grid would be large): each owns the stencil starts
  // [first, first + owned) and holds 3 more rows, the next slab's first three (carried over, so
  // each slab makes `owned` rows: whole Wigner blocks of kWignerBlock).
  const bool whole = options.max_grid_bytes == 0 || rows * row_bytes <= options.max_grid_bytes;
  // A slab's Wigner blocks are what its threads share: one a thread where the rows fit in
  // twice the limit (kSlabGrowthForThreads). A slab of a single block ran on one thread whatever
  // `threads` said: forest.exr microfacet sigma 0.1 at (87, 24), 240 rows of 3.6 MB, took 3.5 s
  // on two threads as on one, and 2.1-2.3 s with two blocks a slab (the same cube).
  const auto blocks_within = [&](size_t bytes) {
    return (static_cast<int>(bytes / row_bytes) - 3) / kWignerBlock;
  };
  const int slab_blocks = std::max(
      {1, blocks_within(options.max_grid_bytes),
       std::min(options.threads, blocks_within(kSlabGrowthForThreads * options.max_grid_bytes))});
  const int owned = whole ? rows : slab_blocks * kWignerBlock;
  SynthesisScratch local;
  std::vector<float>& storage = options.scratch != nullptr ? options.scratch->grid : local.grid;
  constexpr size_t kLineFloats = 16;
  storage.resize(static_cast<size_t>(std::min(owned + 3, rows)) * nb * grid_stride + kLineFloats);
  float* grid = storage.data();
  grid += (kLineFloats - (reinterpret_cast<uintptr_t>(grid) / sizeof(float)) % kLineFloats) %
          kLineFloats;
  ShrmCube cube = NewCube(kind, face_size, options.scratch);
  SynthesizeSlabs(
      kind, na, owned, options.threads, grid_stride, grid,
      [&](int first, int count) {
        internal::ResampleToCubeFromRows(grid, first, count, na, stride, grid_stride,
                                         internal::GridColumns::kShrm, options.threads, cube);
      },
      options.scratch);
  return cube;
}

bool ShrmSynthesizer::DirectCubeIsCheaper(ShrmKind kind, int face_size, int na) const {
  // Estimated milliseconds on one core (least squares over 9 measured configurations, F 14-128,
  // P 5-31, S 32-96, global and local; each path within about 30% of its measured time, the
  // grid's underestimated up to 1.8x at P = 31; docs/shrm.md "Direct cubes"):
  //   grid:   its l-sums, na (2F + 2) (F + 1) pairs(p, q) / 2, and the FFTs and resampling of
  //           2 na^2 nodes of (P + 1)^3;
  //   direct: the l-sums of the texel blocks, the rho contraction and the (global) rotation and
  //           per-coefficient work of each of the 6 S^2 texels.
  const double f = lmax_ + 1.0, p = pmax_ + 1.0, q = RhoQmax() + 1.0;
  const double pairs = q == 1 ? p : p * (p + 1) / 2;
  const double texels = 6.0 * face_size * face_size;
  const double grid = 2.17e-6 * na * (2 * f) * f * pairs / 2 + 8.4e-7 * 2.0 * na * na * p * p * p;
  // The direct path's terms as fitted, times kDirectSpeedup: session 27 vectorized its rho sums
  // and batched its rotations, and the three configurations of tolerance_bench BM_CubePath then
  // took 0.54, 0.55 and 0.74 of the estimate ((36, 31) S 40: 608 ms; (56, 24) S 72: 2,028 ms;
  // (14, 5) S 64: 54 ms), the grid's unchanged or less.
  constexpr double kDirectSpeedup = 0.55;
  const double direct =
      kDirectSpeedup *
      (1.3e-5 * texels / kWignerBlock * f * f * q / 2 + 8.7e-7 * texels * f * p * q / 2 +
       (kind == ShrmKind::kGlobal ? 6.5e-7 * texels * p * p * p : 0.0) + 4.2e-5 * texels * p * p);
  return direct < grid;
}

absl::StatusOr<ShrmCube> ShrmSynthesizer::BuildCubeDirect(ShrmKind kind, int face_size, int threads,
                                                          SynthesisScratch* scratch) const {
  ShrmCube cube = NewCube(kind, face_size, scratch);
  constexpr int B = kWignerBlock;
  const int size = face_size, n = 6 * size * size;
  const int f = lmax_, pm = pmax_, ch = channels_, qr = RhoQmax();
  const int count = ShCount(pm);
  const size_t row = ch;
  ParallelChunks((n + B - 1) / B, threads, [&](int begin, int end) {
    std::vector<Lanes> sre, sim, bre(static_cast<size_t>(count) * ch), bim(bre.size());
    std::vector<std::complex<double>> cplx(count);
    std::vector<double> real(count), batch_in, batch_out;
    std::vector<ZyzCosSin> angles;
    std::optional<ZxzxzRotation> rotation;
    if (kind == ShrmKind::kGlobal) rotation = *ZxzxzRotation::Create(pm);
    for (int b = begin; b < end; ++b) {
      const int t0 = b * B, nb = std::min(B, n - t0);
      double alpha[B], beta[B];
      for (int r = 0; r < B; ++r) {
        const int t = t0 + std::min(r, nb - 1);
        const int face = t / (size * size), rem = t % (size * size);
        ShrmAnglesFromWorld(CubeTexelDirection(face, rem % size, rem / size, size), &alpha[r],
                            &beta[r]);
      }
      LSumsBlock(alpha, beta, nb, sre, sim);
      // Eq. 5.23 at the block's texels side by side (lane r): B_pq = sum_l rho_lpq S_lq for
      // q >= 0 (all ComplexToReal reads: the real field has B_p,-q = (-1)^q conj(B_pq)).
      for (int p = 0; p <= pm; ++p)
        for (int q = 0; q <= std::min(p, qr); ++q)
          for (int c = 0; c < ch; ++c) {
            Lanes re{}, im{};
            const double* rho =
                rho_.data() + (static_cast<size_t>(p) * (pm + 1) + q) * (f + 1) * ch + c;
            const Lanes* sr = sre.data() + static_cast<size_t>(q) * (f + 1) * row + c;
            const Lanes* si = sim.data() + static_cast<size_t>(q) * (f + 1) * row + c;
            for (int l = q; l <= f; ++l) {
              const double w = rho[l * ch];
              re += w * sr[l * row];
              im += w * si[l * row];
            }
            bre[static_cast<size_t>(ShIndex(p, q)) * ch + c] = re;
            bim[static_cast<size_t>(ShIndex(p, q)) * ch + c] = im;
          }
      // Then real SH per texel and channel, and the global kind's rotations of the block's
      // nb x ch vectors at once.
      const int k = nb * ch;
      batch_in.resize(static_cast<size_t>(count) * k);
      batch_out.resize(batch_in.size());
      angles.resize(k);
      for (int r = 0; r < nb; ++r) {
        const ZyzCosSin frame = kind == ShrmKind::kGlobal
                                    ? ZyzCosSinFromMatrix(ShrmLocalFrame(alpha[r], beta[r]))
                                    : ZyzCosSin{};
        for (int c = 0; c < ch; ++c) {
          std::fill(cplx.begin(), cplx.end(), std::complex<double>(0, 0));
          for (int p = 0; p <= pm; ++p)
            for (int q = 0; q <= std::min(p, qr); ++q) {
              const size_t i = static_cast<size_t>(ShIndex(p, q)) * ch + c;
              cplx[ShIndex(p, q)] = {bre[i][r], bim[i][r]};
            }
          ComplexToReal(pm, cplx, real);
          for (int i = 0; i < count; ++i)
            batch_in[static_cast<size_t>(i) * k + r * ch + c] = real[i];
          angles[r * ch + c] = frame;
        }
      }
      const double* src = batch_in.data();
      if (kind == ShrmKind::kGlobal) {
        rotation->ApplyMany(angles, batch_in.data(), batch_out.data());
        src = batch_out.data();
      }
      for (int r = 0; r < nb; ++r) {
        const int t = t0 + r, face = t / (size * size), rem = t % (size * size);
        for (int c = 0; c < ch; ++c)
          for (int i = 0; i < count; ++i)
            cube.data[cube.Index(face, rem % size, rem / size, i, c)] =
                static_cast<float>(src[static_cast<size_t>(i) * k + r * ch + c]);
      }
    }
  });
  return cube;
}

absl::StatusOr<ShrmCube> ShrmSynthesizer::BuildCubeP0(ShrmKind kind, int face_size, int na,
                                                      int threads,
                                                      SynthesisScratch* scratch) const {
  // P = 0: B_00(alpha, beta) = sum_lm L_lm rho_l00 d^l_m0(alpha) e^{i m beta}
  //                          = sum_lm sqrt(4 pi / (2l + 1)) rho_l00 L_lm Y_lm(alpha, beta)
  // (d^l_m0(b) = sqrt(4 pi/(2l+1)) Y_lm(b, 0), docs/conventions.md), a plain SH synthesis of degree
  // F of the real coefficients sqrt(4 pi/(2l+1)) rho_l00 L_lm (the factor depends on l only, so
  // it commutes with ComplexToReal). Local = global for P = 0 (D^0 = 1). It runs on the same
  // equiangular (na x 2 na) grid with the optimized inverse SHT (Legendre recurrences + real
  // FFTs), then the same cubic resampling with the lat-long column convention.
  if (absl::Status st = CheckZonalRows(na); !st.ok()) return st;
  SynthesisScratch local;
  SynthesisScratch& work = scratch != nullptr ? *scratch : local;
  if (absl::Status st = ZonalGrid(1, na, threads, work); !st.ok()) return st;
  ShrmCube cube = NewCube(kind, face_size, scratch);
  internal::ResampleToCube(work.grid.data(), na, channels_, internal::GridColumns::kSht, threads,
                           cube);
  return cube;
}

absl::StatusOr<ShrmCube> ShrmSynthesizer::RealZonalCube(int f, int channels,
                                                        std::span<const double> real, int face_size,
                                                        const ShrmGridOptions& options) {
  if (f < 0 || channels < 1 ||
      real.size() != static_cast<size_t>(ShCount(f)) * static_cast<size_t>(channels)) {
    return absl::InvalidArgumentError(absl::StrCat("zonal cube: ", real.size(),
                                                   " coefficients for degree ", f, " and ",
                                                   channels, " channels"));
  }
  if (face_size < 1 || options.alpha_samples < 0 || options.threads < 1) {
    return absl::InvalidArgumentError(absl::StrCat("zonal cube: face size ", face_size,
                                                   ", alpha_samples = ", options.alpha_samples,
                                                   ", threads = ", options.threads));
  }
  // BuildCube's rule for P = 0.
  const int na = options.alpha_samples > 0 ? options.alpha_samples
                                           : FftFriendlyRings(std::max(32, 4 * (f + 1)));
  if (na < f + 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SHRM grid: ", na, " alpha samples cannot resolve degree ", f, " (need >= ", f + 1, ")"));
  }
  SynthesisScratch local;
  SynthesisScratch& work = options.scratch != nullptr ? *options.scratch : local;
  if (absl::Status st = RealGrid(f, channels, real, na, options.threads, work); !st.ok()) {
    return st;
  }
  ShrmCube cube;
  cube.kind = ShrmKind::kGlobal;
  cube.face_size = face_size;
  cube.pmax = 0;
  cube.channels = channels;
  AllocateCubeData(cube, options.scratch);
  internal::ResampleToCube(work.grid.data(), na, channels, internal::GridColumns::kSht,
                           options.threads, cube);
  return cube;
}

absl::Status ShrmSynthesizer::CheckZonalRows(int na) const {
  if (na >= lmax_ + 1) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("SHRM grid: ", na,
                                                 " alpha samples cannot resolve degree ", lmax_,
                                                 " (need >= ", lmax_ + 1, ")"));
}

absl::Status ShrmSynthesizer::ZonalGrid(int zonal, int na, int threads,
                                        SynthesisScratch& work) const {
  const int f = lmax_, ch = channels_, zc = zonal * ch;
  std::vector<double> real(static_cast<size_t>(ShCount(f)) * zc);
  {
    std::vector<std::complex<double>> cplx(ShCount(f));
    std::vector<double> one(ShCount(f));
    for (int c = 0; c < ch; ++c) {
      for (int l = 0; l <= f; ++l)
        for (int m = -l; m <= l; ++m)
          cplx[ShIndex(l, m)] = light_[(static_cast<size_t>(m + f) * (f + 1) + l) * ch + c];
      ComplexToReal(f, cplx, one);
      for (int p = 0; p < zonal; ++p)
        for (int l = 0; l <= f; ++l) {
          const double k = std::sqrt(4 * kPi / (2 * l + 1)) * Rho(l, p, 0, c);
          for (int m = -l; m <= l; ++m)
            real[static_cast<size_t>(ShIndex(l, m)) * zc + p * ch + c] = k * one[ShIndex(l, m)];
        }
    }
  }
  return RealGrid(f, zc, real, na, threads, work);
}

absl::Status ShrmSynthesizer::RealGrid(int f, int zc, std::span<const double> real, int na,
                                       int threads, SynthesisScratch& work) {
  const int nb = 2 * na;
  // The synthesis does not depend on the analysis quadrature; the pixel-sum plan skips the exact
  // rule's theta-resampling matrices (grids of fewer than 2F + 1 rings), which only the analysis
  // uses and which cost more than the synthesis itself.
  auto plan =
      GetShtPlan(ShtGrid{nb, na, ShtGridKind::kEquiangular}, f, zc, ShtQuadrature::kPixelSum);
  if (!plan.ok()) return plan.status();
  const size_t row = static_cast<size_t>(nb) * zc;
  // Every row is written below (the transform's na rows, then the four padding rows).
  std::vector<float>& values = work.grid;
  values.resize(row * (na + 4));
  if (absl::Status st = (*plan)->Inverse(real, std::span<float>(values.data() + 2 * row, na * row),
                                         threads, &work.sht);
      !st.ok())
    return st;
  // Padding rows: alpha = -d is alpha = d at beta + pi (half a period of columns), alpha = pi + d
  // is alpha = pi - d at beta + pi.
  auto mirror = [&](int dst_row, int src_row) {
    const float* src = values.data() + (src_row + 2) * row;
    float* dst = values.data() + (dst_row + 2) * row;
    const size_t half = row / 2;
    std::copy(src, src + half, dst + half);
    std::copy(src + half, src + row, dst);
  };
  mirror(-1, 0);
  mirror(-2, 1);
  mirror(na, na - 1);
  mirror(na + 1, na - 2);
  return absl::OkStatus();
}

absl::StatusOr<ShrmCube> ShrmSynthesizer::BuildZonalGlobalCube(int face_size, int na, int threads,
                                                               SynthesisScratch* scratch) const {
  if (absl::Status st = CheckZonalRows(na); !st.ok()) return st;
  SynthesisScratch local;
  SynthesisScratch& work = scratch != nullptr ? *scratch : local;
  const int pm = pmax_, ch = channels_, zonal = pm + 1, zc = zonal * ch;
  if (absl::Status st = ZonalGrid(zonal, na, threads, work); !st.ok()) return st;
  // B_p0 at every texel centre: a P = 0 cube of zonal x channels values.
  ShrmCube z;
  z.kind = ShrmKind::kLocal;
  z.face_size = face_size;
  z.pmax = 0;
  z.channels = zc;
  z.data = std::move(work.zonal);
  z.data.resize(z.size());
  internal::ResampleToCube(work.grid.data(), na, zc, internal::GridColumns::kSht, threads, z);
  ShrmCube cube = NewCube(ShrmKind::kGlobal, face_size, scratch);
  const int n = ShCount(pm), size = face_size;
  std::vector<double> kp(zonal);
  for (int p = 0; p < zonal; ++p) kp[p] = std::sqrt(4 * kPi / (2 * p + 1));
  const size_t texel_values = static_cast<size_t>(n) * ch;
  // A texel's values are out[j] = w[j / ch] b[p(j / ch) ch + j % ch], j < n ch, w[k] =
  // sqrt(4 pi / (2p + 1)) Y_ps(T) (k = ShIndex(p, s)), b = the texel's zonal values. With
  // AVX-512 and (P + 1) ch <= 32 (b in two registers), 16 j at a time: w's window from w[j0 / ch]
  // and b by two permutes of precomputed lane indices.
  constexpr int kLanes = 16;
  const int chunks = static_cast<int>((texel_values + kLanes - 1) / kLanes);
  const bool vector_path = kSimdExpansion && zc <= 32;
  std::vector<int32_t> w_base(chunks), w_lane(static_cast<size_t>(chunks) * kLanes),
      b_lane(static_cast<size_t>(chunks) * kLanes);
  for (int k = 0; k < chunks; ++k) {
    w_base[k] = k * kLanes / ch;
    for (int i = 0; i < kLanes; ++i) {
      const int j = std::min<int>(k * kLanes + i, static_cast<int>(texel_values) - 1);
      const int kk = j / ch, p = static_cast<int>(std::sqrt(static_cast<double>(kk)));
      w_lane[k * kLanes + i] = kk - w_base[k];
      b_lane[k * kLanes + i] = p * ch + j % ch;
    }
  }
  // w of every texel, [texel][k] floats (a row's texels contiguous, kLanes of slack at the end
  // for the vector path's window loads): kept in the caller's scratch when there is one (it
  // depends only on S_B and P_B, so a live session's frames compute it once), else made row by
  // row into a buffer.
  const size_t texels = static_cast<size_t>(kCubeFaceCount) * size * size;
  float* w_table = nullptr;
  bool w_ready = false;
  if (scratch != nullptr) {
    w_ready = scratch->zonal_w_face_size == size && scratch->zonal_w_pmax == pm &&
              scratch->zonal_w.size() == texels * n + kLanes;
    if (!w_ready) {
      scratch->zonal_w.assign(texels * n + kLanes, 0.0f);
      scratch->zonal_w_face_size = size;
      scratch->zonal_w_pmax = pm;
    }
    w_table = scratch->zonal_w.data();
  }
  // A row's w: sqrt(4 pi / (2p + 1)) Y_ps(T) (EvalShBatch: y[ShIndex(p, s) * size + x]).
  auto row_weights = [&](int face, int yy, std::vector<Vec3>& dirs, std::vector<double>& y,
                         float* w) {
    for (int x = 0; x < size; ++x)
      dirs[x] = ShFrameFromWorld(CubeTexelDirection(face, x, yy, size));
    EvalShBatch(pm, dirs, y);
    for (int p = 0; p <= pm; ++p)
      for (int k = p * p; k < (p + 1) * (p + 1); ++k)
        for (int x = 0; x < size; ++x)
          w[static_cast<size_t>(x) * n + k] =
              static_cast<float>(kp[p] * y[static_cast<size_t>(k) * size + x]);
  };
  // Texels go to the cube in blocks of kBlock: a block's values (kBlock x n x ch floats, 15.5 KB
  // at (P, ch) = (8, 3)) are made in a buffer that stays in L1, then streamed (StreamFloats).
  constexpr int kBlock = 16;
  ParallelChunks(kCubeFaceCount * size, threads, [&](int begin, int end) {
    std::vector<Vec3> dirs(size);
    std::vector<double> y(static_cast<size_t>(n) * size);
    std::vector<float> w_row(w_table != nullptr ? 0 : static_cast<size_t>(size) * n + kLanes);
    std::vector<float> buffer(kBlock * texel_values + kLanes), bz(32, 0.0f);
    for (int row = begin; row < end; ++row) {
      const int face = row / size, yy = row % size;
      float* w = w_table != nullptr ? w_table + static_cast<size_t>(row) * size * n : w_row.data();
      if (!w_ready) row_weights(face, yy, dirs, y, w);
      float* dst = cube.data.data() + cube.Index(face, 0, yy, 0, 0);
      for (int x0 = 0; x0 < size; x0 += kBlock) {
        const int count = std::min(kBlock, size - x0);
        for (int i = 0; i < count; ++i) {
          const int x = x0 + i;
          const float* b = z.data.data() + z.Index(face, x, yy, 0, 0);
          const float* wx = w + static_cast<size_t>(x) * n;
          float* out = buffer.data() + static_cast<size_t>(i) * texel_values;
          if (vector_path) {
            std::copy(b, b + zc, bz.begin());
            ExpandZonalTexel(wx, bz.data(), chunks, w_base.data(), w_lane.data(), b_lane.data(),
                             out);
            continue;
          }
          for (int p = 0; p <= pm; ++p)
            for (int k = p * p; k < (p + 1) * (p + 1); ++k)
              for (int c = 0; c < ch; ++c) out[k * ch + c] = wx[k] * b[p * ch + c];
        }
        internal::StreamFloats(buffer.data(), count * texel_values, dst + x0 * texel_values);
      }
    }
  });
  work.zonal = std::move(z.data);
  return cube;
}

}  // namespace shrm
