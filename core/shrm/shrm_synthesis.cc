#include "core/shrm/shrm_synthesis.h"

#include <fftw3.h>

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <tuple>
#include <type_traits>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
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

// Reserves `n` floats in `v` and, for large buffers on Linux, asks for transparent huge pages on
// the 2 MB-aligned part of the new (untouched) storage before it is first written. THP is usually
// in "madvise" mode, and first-touch page faults on 4 KB pages dominate writing a fresh 10-20 MB
// cube (~0.35 ms per MB measured on the benchmark VM, ~0.09 ms per MB with 2 MB pages). A hint
// only: no effect on the values, ignored where unsupported.
void ReserveLargeBuffer(std::vector<float>& v, size_t n) {
  v.clear();
  v.reserve(n);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHuge = uintptr_t{2} << 20;
  if (n * sizeof(float) >= 2 * kHuge) {
    const uintptr_t b = reinterpret_cast<uintptr_t>(v.data());
    const uintptr_t e = b + n * sizeof(float);
    const uintptr_t hb = (b + kHuge - 1) & ~(kHuge - 1), he = e & ~(kHuge - 1);
    if (he > hb) madvise(reinterpret_cast<void*>(hb), he - hb, MADV_HUGEPAGE);
  }
#endif
}

// Real SH coefficients of one texel in its local frame evaluated at the world view.
double DotSh(std::span<const double> y, const float* coeffs, int count, int channels, int c) {
  double s = 0;
  for (int k = 0; k < count; ++k) s += y[k] * coeffs[static_cast<size_t>(k) * channels + c];
  return s;
}

// Column convention of a grid: kShrm = BuildGrid's beta_k = 2 pi k / nb; kSht = a lat-long
// map of core/transform/sht.h (SH azimuth of column i: 3 pi / 2 - 2 pi (i + 1/2) / nb).
enum class GridColumns { kShrm, kSht };

// Interpolation taps of every texel centre of an S x S cube on an (na x nb = 2 na) grid with two
// padding rows beyond each pole: padded row of node -1 (rows row .. row + 3), beta column of node
// 0 (columns k0 - 1 .. k0 + 2, periodic) and the fractional offsets in alpha and beta (the cubic
// Lagrange weights are recomputed from them, so a tap is 16 bytes: 1.5 MB at S_B = 128 instead of
// 8.6 MB of double weights). They depend only on (S, na, columns), so they are computed once per
// process and cached (like an FFT plan).
struct TexelTaps {
  int32_t row = 0;
  int32_t k0 = 0;
  float ta = 0, tb = 0;
};

std::shared_ptr<const std::vector<TexelTaps>> GetTexelTaps(int face_size, int na,
                                                           GridColumns columns) {
  static std::mutex mu;
  static std::map<std::tuple<int, int, int>, std::shared_ptr<const std::vector<TexelTaps>>> cache;
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[{face_size, na, static_cast<int>(columns)}];
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
        t.ta = static_cast<float>(u - j0);
        t.row = j0 - 1 + 2;  // padded row index of node -1
        double v = columns == GridColumns::kShrm ? beta * nb / (2 * kPi)
                                                 : (1.5 * kPi - beta) * nb / (2 * kPi) - 0.5;
        v = std::fmod(v, static_cast<double>(nb));
        if (v < 0) v += nb;
        const int k0 = std::min(static_cast<int>(std::floor(v)), nb - 1);
        t.tb = static_cast<float>(v - k0);
        t.k0 = k0;
      }
  slot = taps;
  return slot;
}

// Lagrange weights of the 4-point cubic through nodes -1, 0, 1, 2 at t in [0, 1) (float: the
// weights enter a float sum of 16 products).
inline void LagrangeWeightsF(float t, float w[4]) {
  const float tp = t + 1, tm = t - 1, tm2 = t - 2;
  w[0] = -t * tm * tm2 * (1.0f / 6);
  w[1] = tp * tm * tm2 * 0.5f;
  w[2] = -tp * t * tm2 * 0.5f;
  w[3] = tp * t * tm * (1.0f / 6);
}

// 4 x 4 Lagrange interpolation of one texel's coefficients from the grid (N = stride, 0: any).
// Float products and accumulation of the 16 taps (the weights sum to 1 and are bounded by ~1.2
// in magnitude, so the rounding error is ~1e-7 of the largest neighbouring value, far below the
// cubic interpolation error); AVX-512 kernels for the fixed strides of P = 0..3 with 3 channels.
template <int N>
inline void Interpolate(const float* values, int nb, int runtime_stride, const TexelTaps& t,
                        float* dst) {
  float wa[4], wb[4];
  LagrangeWeightsF(t.ta, wa);
  LagrangeWeightsF(t.tb, wb);
  int cols[4];
  for (int b = 0; b < 4; ++b) {
    int k = t.k0 - 1 + b;
    k += k < 0 ? nb : 0;
    k -= k >= nb ? nb : 0;
    cols[b] = k;
  }
#if defined(__AVX512F__)
  if constexpr (N == 3) {
    if (t.k0 >= 1 && t.k0 + 2 < nb) {
      // The 4 columns x 3 channels of a row are 12 contiguous floats: one masked load per row,
      // then the beta weights and a sum over the 4 column groups.
      __m512 acc = _mm512_setzero_ps();
      const float* base = values + (static_cast<size_t>(t.row) * nb + (t.k0 - 1)) * 3;
      for (int a = 0; a < 4; ++a)
        acc = _mm512_fmadd_ps(_mm512_set1_ps(wa[a]),
                              _mm512_maskz_loadu_ps(0x0FFF, base + static_cast<size_t>(a) * nb * 3),
                              acc);
      const __m512 wbv = _mm512_set_ps(0, 0, 0, 0, wb[3], wb[3], wb[3], wb[2], wb[2], wb[2], wb[1],
                                       wb[1], wb[1], wb[0], wb[0], wb[0]);
      acc = _mm512_mul_ps(acc, wbv);
      const __m512i idx_a =
          _mm512_set_epi32(15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 8, 7, 6);
      const __m512i idx_b =
          _mm512_set_epi32(15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 5, 4, 3);
      const __m512i idx_c =
          _mm512_set_epi32(15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 15, 11, 10, 9);
      const __m512 sum =
          _mm512_add_ps(_mm512_add_ps(acc, _mm512_maskz_permutexvar_ps(0x7, idx_b, acc)),
                        _mm512_add_ps(_mm512_maskz_permutexvar_ps(0x7, idx_a, acc),
                                      _mm512_maskz_permutexvar_ps(0x7, idx_c, acc)));
      _mm512_mask_storeu_ps(dst, 0x7, sum);
      return;
    }
  }
  if constexpr (N > 0) {
    constexpr int kVec = (N + 15) / 16;
    constexpr int kTail = N - 16 * (kVec - 1);  // lanes of the last vector, 1 .. 16
    const __mmask16 tail = static_cast<__mmask16>(kTail == 16 ? 0xFFFFu : (1u << kTail) - 1);
    __m512 acc[kVec];
    for (int i = 0; i < kVec; ++i) acc[i] = _mm512_setzero_ps();
    for (int a = 0; a < 4; ++a) {
      const float* grid_row = values + static_cast<size_t>(t.row + a) * nb * N;
      for (int b = 0; b < 4; ++b) {
        const __m512 w = _mm512_set1_ps(wa[a] * wb[b]);
        const float* src = grid_row + static_cast<size_t>(cols[b]) * N;
        for (int i = 0; i < kVec - 1; ++i)
          acc[i] = _mm512_fmadd_ps(w, _mm512_loadu_ps(src + 16 * i), acc[i]);
        acc[kVec - 1] =
            _mm512_fmadd_ps(w, _mm512_maskz_loadu_ps(tail, src + 16 * (kVec - 1)), acc[kVec - 1]);
      }
    }
    for (int i = 0; i < kVec - 1; ++i) _mm512_storeu_ps(dst + 16 * i, acc[i]);
    _mm512_mask_storeu_ps(dst + 16 * (kVec - 1), tail, acc[kVec - 1]);
    return;
  }
#endif
  const int stride = N > 0 ? N : runtime_stride;
  float small[64];
  std::vector<float> big;
  float* acc = small;
  if (stride > 64) {
    big.resize(stride);
    acc = big.data();
  }
  for (int i = 0; i < stride; ++i) acc[i] = 0.0f;
  for (int a = 0; a < 4; ++a) {
    const float* grid_row = values + static_cast<size_t>(t.row + a) * nb * stride;
    for (int b = 0; b < 4; ++b) {
      const float w = wa[a] * wb[b];
      const float* src = grid_row + static_cast<size_t>(cols[b]) * stride;
      for (int i = 0; i < stride; ++i) acc[i] += w * src[i];
    }
  }
  for (int i = 0; i < stride; ++i) dst[i] = acc[i];
}

// Resamples a padded grid (rows -2 .. na + 1, nb = 2 na columns, `stride` floats per node) onto
// the texel centres of `cube` (already sized).
void ResampleToCube(const float* values, int na, int stride, GridColumns columns, int threads,
                    ShrmCube& cube) {
  const int face_size = cube.face_size, nb = 2 * na;
  const std::shared_ptr<const std::vector<TexelTaps>> taps = GetTexelTaps(face_size, na, columns);
  const int rows_total = kCubeFaceCount * face_size;
  auto run = [&]<int N>(std::integral_constant<int, N>) {
    ParallelChunks(rows_total, threads, [&](int begin, int end) {
      for (size_t texel = static_cast<size_t>(begin) * face_size;
           texel < static_cast<size_t>(end) * face_size; ++texel)
        Interpolate<N>(values, nb, stride, (*taps)[texel], cube.data.data() + texel * stride);
    });
  };
  switch (stride) {  // fixed trip counts for P = 0..3 with 3 channels
    case 3:
      run(std::integral_constant<int, 3>{});
      break;
    case 12:
      run(std::integral_constant<int, 12>{});
      break;
    case 27:
      run(std::integral_constant<int, 27>{});
      break;
    case 48:
      run(std::integral_constant<int, 48>{});
      break;
    default:
      run(std::integral_constant<int, 0>{});
  }
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

void WignerColumnTables::ComputeBlock(const double* alpha, int n, double* out) const {
  // The recurrence of Compute() run on kWignerBlock angles at once (lane r = alpha[r]; lanes
  // r >= n repeat alpha[n - 1]): the coefficients do not depend on alpha, so the recurrence
  // vectorizes across the lanes.
  constexpr int B = kWignerBlock;
  const int lmax = lmax_, qmax = qmax_;
  double c[B], sn[B], x[B];
  for (int r = 0; r < B; ++r) {
    const double a = alpha[std::min(r, n - 1)];
    c[r] = std::cos(a / 2);
    sn[r] = std::sin(a / 2);
    x[r] = std::cos(a);
  }
  for (int q = -qmax; q <= qmax; ++q) {
    for (int m = -lmax; m <= lmax; ++m) {
      double* col = out + WignerColumnIndex(lmax, qmax, 0, m, q) * B;
      const int l0 = std::max(std::abs(m), std::abs(q));
      for (int i = 0; i < std::min(l0, lmax + 1) * B; ++i) col[i] = 0.0;
      if (l0 > lmax) continue;
      const double b = start_[static_cast<size_t>(q + qmax) * (2 * lmax + 1) + (m + lmax)];
      double prev[B], cur[B];
      for (int r = 0; r < B; ++r) {
        double d0;
        if (std::abs(m) >= std::abs(q)) {
          if (m >= 0) {
            d0 = ((m - q) & 1 ? -1.0 : 1.0) * b * IntPow(c[r], l0 + q) * IntPow(sn[r], l0 - q);
          } else {
            d0 = b * IntPow(c[r], l0 - q) * IntPow(sn[r], l0 + q);
          }
        } else if (q > 0) {
          d0 = b * IntPow(c[r], l0 + m) * IntPow(sn[r], l0 - m);
        } else {
          d0 = ((m + l0) & 1 ? -1.0 : 1.0) * b * IntPow(c[r], l0 - m) * IntPow(sn[r], l0 + m);
        }
        col[l0 * B + r] = d0;
        prev[r] = 0;
        cur[r] = d0;
      }
      const size_t base = WignerColumnIndex(lmax, qmax, 0, m, q);
      const double* a = a_.data() + base;
      const double* cl = c_.data() + base;
      const double* sh = shift_.data() + base;
      for (int l = l0; l < lmax; ++l) {
        const double al = a[l], cll = cl[l], shl = sh[l];
        double* next = col + (l + 1) * B;
        for (int r = 0; r < B; ++r) {
          next[r] = al * ((x[r] - shl) * cur[r] - cll * prev[r]);
          prev[r] = cur[r];
          cur[r] = next[r];
        }
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

void ShrmSynthesizer::SynthesizeRows(ShrmKind kind, const double* alphas, int rows, int nb,
                                     void* fft_plan, const WignerColumnTables& tables,
                                     const WignerColumnTables& ptables, RowScratch& scratch,
                                     float* rows_out) const {
  constexpr int B = kWignerBlock;
  const int f = lmax_, pm = pmax_, ch = channels_;
  const int qmax = std::min(pm, f);
  const int n = ShCount(pm);
  const int stride = n * ch;
  // Step 1 (eq. 5.24, the l-sum) for the block of rows at once: the Wigner columns of all rows
  // side by side (lane r = row r), so each product L_lm rho_lpq is formed once and applied to
  // every row with one vector FMA.
  //   bm[((m + F) * n + ShIndex(p, q)) * ch + c][r] = sum_l L_lm rho_lpq d^l_mq(alpha_r)
  // (|q| <= p; only q >= 0 for the local kind).
  tables.ComputeBlock(alphas, rows, scratch.cols.data());
  const int qlo = kind == ShrmKind::kLocal ? 0 : -qmax;
  const size_t nm = 2 * f + 1;  // layout bre[((ShIndex(p, q) * ch + c) * B + r) * nm + m + F]
  double* bre = scratch.bre.data();
  double* bim = scratch.bim.data();
  for (int m = -f; m <= f; ++m) {
    const std::complex<double>* lm = light_.data() + static_cast<size_t>(m + f) * (f + 1) * ch;
    for (int q = qlo; q <= qmax; ++q) {
      const double* d = scratch.cols.data() + WignerColumnIndex(f, qmax, 0, m, q) * B;
      const int l0 = std::max(std::abs(m), std::abs(q));
      for (int p = std::abs(q); p <= pm; ++p) {
        const double* rho =
            rho_.data() + (static_cast<size_t>(p) * (pm + 1) + std::abs(q)) * (f + 1) * ch;
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
            const double* re = bre + bm_at(p, q, c);
            const double* im = bim + bm_at(p, q, c);
            std::complex<double>* w = work + static_cast<size_t>(t * ch + c) * nb;
            for (int m = -f; m <= f; ++m) w[bin(m)] = {re[m + f], im[m + f]};
          }
        }
    } else {
      ptables.Compute(alphas[r], scratch.dp);
      const std::span<const double> dp = scratch.dp;
      double* sre = scratch.sre.data();
      double* sim = scratch.sim.data();
      for (int p = 0; p <= pm; ++p)
        for (int s = 0; s <= p; ++s) {
          const int t = p * (p + 1) / 2 + s;
          for (int c = 0; c < ch; ++c) {
            for (size_t i = 0; i < nm; ++i) sre[i] = sim[i] = 0.0;
            for (int q = -std::min(p, qmax); q <= std::min(p, qmax); ++q) {
              const double w = dp[WignerColumnIndex(pm, pm, p, s, q)];
              const double* re = bre + bm_at(p, q, c);
              const double* im = bim + bm_at(p, q, c);
              for (size_t i = 0; i < nm; ++i) {
                sre[i] += w * re[i];
                sim[i] += w * im[i];
              }
            }
            std::complex<double>* w = work + static_cast<size_t>(t * ch + c) * nb;
            for (int m = -f; m <= f; ++m) w[bin(m - s)] = {sre[m + f], sim[m + f]};
          }
        }
    }
    fftw_execute_dft(static_cast<fftw_plan>(fft_plan), reinterpret_cast<fftw_complex*>(work),
                     reinterpret_cast<fftw_complex*>(scratch.out));
    float* row_out = rows_out + static_cast<size_t>(r) * nb * stride;
    for (int p = 0; p <= pm; ++p)
      for (int q = 0; q <= p; ++q) {
        const int t = p * (p + 1) / 2 + q;
        for (int c = 0; c < ch; ++c) {
          const std::complex<double>* series = scratch.out + static_cast<size_t>(t * ch + c) * nb;
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
  fftw_complex *probe, *probe_out;
  {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    probe = fftw_alloc_complex(work_size);
    probe_out = fftw_alloc_complex(work_size);
    int n[1] = {g.nb};
    plan = fftw_plan_many_dft(1, n, nseries, probe, nullptr, 1, g.nb, probe_out, nullptr, 1, g.nb,
                              FFTW_BACKWARD, FFTW_ESTIMATE);
  }
  const int qmax = std::min(pmax_, lmax_);
  const WignerColumnTables tables(lmax_, qmax), ptables(pmax_, pmax_);
  constexpr int B = kWignerBlock;
  const int blocks = (rows + B - 1) / B;
  ParallelChunks(blocks, threads, [&](int begin, int end) {
    RowScratch scratch;
    {
      std::lock_guard<std::mutex> lock(FftwPlannerMutex());
      scratch.work = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(work_size));
      scratch.out = reinterpret_cast<std::complex<double>*>(fftw_alloc_complex(work_size));
    }
    std::fill(scratch.work, scratch.work + work_size, std::complex<double>(0, 0));
    scratch.cols.resize(WignerColumnCount(lmax_, qmax) * B);
    scratch.dp.resize(WignerColumnCount(pmax_, pmax_));
    const size_t nbm = static_cast<size_t>(2 * lmax_ + 1) * ShCount(pmax_) * channels_ * B;
    scratch.bre.assign(nbm, 0.0);
    scratch.bim.assign(nbm, 0.0);
    scratch.sre.assign(2 * lmax_ + 1, 0.0);
    scratch.sim.assign(2 * lmax_ + 1, 0.0);
    for (int blk = begin; blk < end; ++blk) {
      const int r0 = blk * B, nrows = std::min(B, rows - r0);
      double alphas[B];
      for (int r = 0; r < nrows; ++r) alphas[r] = kPi * (r0 + r - 2 + 0.5) / na;
      SynthesizeRows(kind, alphas, nrows, g.nb, plan, tables, ptables, scratch,
                     g.values.data() + static_cast<size_t>(r0) * g.nb * g.stride);
    }
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    fftw_free(scratch.work);
    fftw_free(scratch.out);
  });
  {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    fftw_destroy_plan(plan);
    fftw_free(probe);
    fftw_free(probe_out);
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
    // ... and on to the next multiple of 8 whose FFT length 2 na has no prime factor above 7
    // (e.g. 104 -> 112, 232 -> 240: an FFT of 2 * 232 = 16 * 29 costs ~1.7x that of 480).
    auto smooth = [](int v) {
      for (int p : {2, 3, 5, 7})
        while (v % p == 0) v /= p;
      return v == 1;
    };
    while (!smooth(na)) na += 8;
  }
  if (pmax_ == 0 && options.p0_sht_path) return BuildCubeP0(kind, face_size, na, options.threads);
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
  ReserveLargeBuffer(cube.data, cube.size());
  cube.data.resize(cube.size());
  ResampleToCube(g.values.data(), na, g.stride, GridColumns::kShrm, options.threads, cube);
  return cube;
}

absl::StatusOr<ShrmCube> ShrmSynthesizer::BuildCubeP0(ShrmKind kind, int face_size, int na,
                                                      int threads) const {
  // P = 0: B_00(alpha, beta) = sum_lm L_lm rho_l00 d^l_m0(alpha) e^{i m beta}
  //                          = sum_lm sqrt(4 pi / (2l + 1)) rho_l00 L_lm Y_lm(alpha, beta)
  // (d^l_m0(b) = sqrt(4 pi/(2l+1)) Y_lm(b, 0), docs/conventions.md), a plain SH synthesis of degree
  // F of the real coefficients sqrt(4 pi/(2l+1)) rho_l00 L_lm (the factor depends on l only, so
  // it commutes with ComplexToReal). Local = global for P = 0 (D^0 = 1). It runs on the same
  // equiangular (na x 2 na) grid with the optimized inverse SHT (Legendre recurrences + real
  // FFTs), then the same cubic resampling with the lat-long column convention.
  if (na < lmax_ + 1) {
    return absl::InvalidArgumentError(absl::StrCat("SHRM grid: ", na,
                                                   " alpha samples cannot resolve degree ", lmax_,
                                                   " (need >= ", lmax_ + 1, ")"));
  }
  const int f = lmax_, ch = channels_, nb = 2 * na;
  std::vector<double> real(static_cast<size_t>(ShCount(f)) * ch);
  {
    std::vector<std::complex<double>> cplx(ShCount(f));
    std::vector<double> one(ShCount(f));
    for (int c = 0; c < ch; ++c) {
      for (int l = 0; l <= f; ++l)
        for (int m = -l; m <= l; ++m)
          cplx[ShIndex(l, m)] = light_[(static_cast<size_t>(m + f) * (f + 1) + l) * ch + c];
      ComplexToReal(f, cplx, one);
      for (int l = 0; l <= f; ++l) {
        const double k = std::sqrt(4 * kPi / (2 * l + 1)) * Rho(l, 0, 0, c);
        for (int m = -l; m <= l; ++m)
          real[static_cast<size_t>(ShIndex(l, m)) * ch + c] = k * one[ShIndex(l, m)];
      }
    }
  }
  auto plan = GetShtPlan(ShtGrid{nb, na, ShtGridKind::kEquiangular}, f, ch);
  if (!plan.ok()) return plan.status();
  const size_t row = static_cast<size_t>(nb) * ch;
  std::vector<float> values(row * (na + 4));
  if (absl::Status st =
          (*plan)->Inverse(real, std::span<float>(values.data() + 2 * row, na * row), threads);
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
  ShrmCube cube;
  cube.kind = kind;
  cube.index = reparam_;
  cube.face_size = face_size;
  cube.pmax = 0;
  cube.channels = ch;
  ReserveLargeBuffer(cube.data, cube.size());
  cube.data.resize(cube.size());
  ResampleToCube(values.data(), na, ch, GridColumns::kSht, threads, cube);
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
