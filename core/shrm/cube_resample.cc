#include "core/shrm/cube_resample.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <tuple>
#include <type_traits>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "core/base/cubemap.h"
#include "core/base/geometry.h"
#include "core/base/parallel.h"
#include "core/brdf/vector_math.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_eval.h"

namespace shrm::internal {
namespace {

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
  // The texel centres' (alpha, beta) of +X and +Y; the other faces' follow by symmetry
  // (ShrmAnglesFromWorld, GL faces): the side faces are +X turned about the vertical, alpha the
  // same and beta + pi (-X), - pi / 2 (+Z), + pi / 2 (-Z); -Y is +Y mirrored, pi - alpha and
  // -beta, at the same texel. (Within a few ulp of the direct angles: the taps are floats.)
  // ShrmAnglesFromWorld's angles, their atan2 calls over whole faces at once (VectorAtan2).
  const size_t per_face = static_cast<size_t>(face_size) * face_size;
  std::vector<double> side_alpha(per_face), side_beta(per_face), top_alpha(per_face),
      top_beta(per_face);
  {
    std::vector<double> polar_y(per_face), polar_x(per_face), azimuth_y(per_face),
        azimuth_x(per_face);
    for (const int face : {kPosX, kPosY}) {
      for (int y = 0; y < face_size; ++y)
        for (int x = 0; x < face_size; ++x) {
          const size_t i = static_cast<size_t>(y) * face_size + x;
          const Vec3 d = ShFrameFromWorld(CubeTexelDirection(face, x, y, face_size));
          // (A unit vector's components: no overflow or underflow for hypot to guard against.)
          polar_y[i] = std::sqrt(d.x * d.x + d.y * d.y);
          polar_x[i] = d.z;
          azimuth_y[i] = d.y;
          azimuth_x[i] = d.x;
        }
      const int n = static_cast<int>(per_face);
      VectorAtan2(polar_y.data(), polar_x.data(), (face == kPosX ? side_alpha : top_alpha).data(),
                  n);
      VectorAtan2(azimuth_y.data(), azimuth_x.data(), (face == kPosX ? side_beta : top_beta).data(),
                  n);
    }
  }
  for (int face = 0; face < kCubeFaceCount; ++face)
    for (int y = 0; y < face_size; ++y)
      for (int x = 0; x < face_size; ++x) {
        const size_t i = static_cast<size_t>(y) * face_size + x;
        TexelTaps& t = (*taps)[static_cast<size_t>(face) * per_face + i];
        double alpha, beta;
        switch (face) {
          case kPosY:
            alpha = top_alpha[i], beta = top_beta[i];
            break;
          case kNegY:
            alpha = kPi - top_alpha[i], beta = -top_beta[i];
            break;
          default:
            alpha = side_alpha[i];
            beta = side_beta[i] + (face == kNegX   ? kPi
                                   : face == kPosZ ? -0.5 * kPi
                                   : face == kNegZ ? 0.5 * kPi
                                                   : 0.0);
            break;
        }
        const double u = alpha * na / kPi - 0.5;
        const int j0 = std::clamp(static_cast<int>(std::floor(u)), -1, na - 1);
        t.ta = static_cast<float>(u - j0);
        t.row = j0 - 1 + 2;  // padded row index of node -1
        double v = columns == GridColumns::kShrm ? beta * nb / (2 * kPi)
                                                 : (1.5 * kPi - beta) * nb / (2 * kPi) - 0.5;
        // fmod(v, nb), then a turn added to a negative result, without fmod where v lies within
        // a turn of [0, nb) (beta is within (-1.5 pi, 2 pi]): v - nb is then exact (Sterbenz),
        // fmod's own result, and fmod(v, nb) = v for -nb < v < 0.
        const double turn = nb;
        if (v >= turn && v < 2 * turn) {
          v -= turn;
        } else if (v < 0 && v > -turn) {
          v += turn;
        } else if (!(v >= 0 && v < turn)) {
          v = std::fmod(v, turn);
          if (v < 0) v += turn;
        }
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
template <int N, int G>
inline void Interpolate(const float* values, int nb, int runtime_stride, int grid_stride,
                        const TexelTaps& t, float* dst) {
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
      const float* grid_row = values + static_cast<size_t>(t.row + a) * nb * G;
      for (int b = 0; b < 4; ++b) {
        const __m512 w = _mm512_set1_ps(wa[a] * wb[b]);
        const float* src = grid_row + static_cast<size_t>(cols[b]) * G;
        for (int i = 0; i < kVec - 1; ++i)
          acc[i] = _mm512_fmadd_ps(w, _mm512_loadu_ps(src + 16 * i), acc[i]);
        acc[kVec - 1] =
            _mm512_fmadd_ps(w, _mm512_maskz_loadu_ps(tail, src + 16 * (kVec - 1)), acc[kVec - 1]);
      }
    }
    for (int i = 0; i < kVec - 1; ++i) _mm512_storeu_ps(dst + 16 * i, acc[i]);
    _mm512_mask_storeu_ps(dst + 16 * (kVec - 1), tail, acc[kVec - 1]);
    return;
  } else {
    // Any stride (P >= 4: (P + 1)^2 x 3 floats): blocks of 16 lanes, the 16 taps in the order of
    // the fixed strides' kernel (a-major). The scalar loop below cannot keep its accumulators in
    // registers (they might alias the grid) and took ~10 ms for a 64 x 64 x 6 cube at P = 5.
    // With grid_stride a multiple of 16 on a 64-byte aligned grid every load is one cache line
    // (108 floats per node at P = 5 put most loads across two).
    const float* src[16];
    float w[16];
    for (int a = 0; a < 4; ++a) {
      const float* grid_row = values + static_cast<size_t>(t.row + a) * nb * grid_stride;
      for (int b = 0; b < 4; ++b) {
        src[a * 4 + b] = grid_row + static_cast<size_t>(cols[b]) * grid_stride;
        w[a * 4 + b] = wa[a] * wb[b];
      }
    }
    for (int i0 = 0; i0 < runtime_stride; i0 += 16) {
      const int n = std::min(16, runtime_stride - i0);
      const __mmask16 m = static_cast<__mmask16>(n == 16 ? 0xFFFFu : (1u << n) - 1);
      __m512 acc = _mm512_setzero_ps();
      for (int k = 0; k < 16; ++k) {
        acc = _mm512_fmadd_ps(_mm512_set1_ps(w[k]), _mm512_maskz_loadu_ps(m, src[k] + i0), acc);
      }
      _mm512_mask_storeu_ps(dst + i0, m, acc);
    }
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
  const int gs = G > 0 ? G : grid_stride;
  for (int a = 0; a < 4; ++a) {
    const float* grid_row = values + static_cast<size_t>(t.row + a) * nb * gs;
    for (int b = 0; b < 4; ++b) {
      const float w = wa[a] * wb[b];
      const float* src = grid_row + static_cast<size_t>(cols[b]) * gs;
      for (int i = 0; i < stride; ++i) acc[i] += w * src[i];
    }
  }
  for (int i = 0; i < stride; ++i) dst[i] = acc[i];
}

// Calls fn(std::integral_constant<int, N>, std::integral_constant<int, G>) with N = stride and
// G = grid_stride for the strides of P = 0..5 with 3 channels as BuildCube lays them out (packed
// up to P = 3, padded to whole 64-byte lines above: fixed trip counts), else N = G = 0.
template <typename Fn>
void DispatchStride(int stride, int grid_stride, Fn&& fn) {
  using std::integral_constant;
  const auto is = [&](int n, int g) { return stride == n && grid_stride == g; };
  if (is(3, 3)) return fn(integral_constant<int, 3>{}, integral_constant<int, 3>{});
  if (is(12, 12)) return fn(integral_constant<int, 12>{}, integral_constant<int, 12>{});
  if (is(27, 27)) return fn(integral_constant<int, 27>{}, integral_constant<int, 27>{});
  if (is(48, 48)) return fn(integral_constant<int, 48>{}, integral_constant<int, 48>{});
  if (is(75, 80)) return fn(integral_constant<int, 75>{}, integral_constant<int, 80>{});
  if (is(108, 112)) return fn(integral_constant<int, 108>{}, integral_constant<int, 112>{});
  fn(integral_constant<int, 0>{}, integral_constant<int, 0>{});
}

}  // namespace

void ResampleToCube(const float* values, int na, int stride, GridColumns columns, int threads,
                    ShrmCube& cube) {
  // The whole grid is one slab owning every stencil start.
  ResampleToCubeFromRows(values, 0, na + 4, na, stride, stride, columns, threads, cube);
}

void ResampleToCubeFromRows(const float* rows, int first_row, int row_count, int na, int stride,
                            int grid_stride, GridColumns columns, int threads, ShrmCube& cube) {
  const int face_size = cube.face_size, nb = 2 * na;
  const std::shared_ptr<const std::vector<TexelTaps>> taps = GetTexelTaps(face_size, na, columns);
  const int rows_total = kCubeFaceCount * face_size;
  const int last_start = first_row + row_count - 3;  // owned stencil starts: [first_row, last)
  DispatchStride(stride, grid_stride,
                 [&]<int N, int G>(std::integral_constant<int, N>, std::integral_constant<int, G>) {
                   ParallelChunks(rows_total, threads, [&](int begin, int end) {
                     for (size_t texel = static_cast<size_t>(begin) * face_size;
                          texel < static_cast<size_t>(end) * face_size; ++texel) {
                       TexelTaps t = (*taps)[texel];
                       if (t.row < first_row || t.row >= last_start) continue;
                       t.row -= first_row;
                       Interpolate<N, G>(rows, nb, stride, grid_stride, t,
                                         cube.data.data() + texel * stride);
                     }
                   });
                 });
}

void StreamFloats(const float* src, size_t n, float* dst) {
#if defined(__AVX512F__)
  size_t i = 0;
  while (i < n && reinterpret_cast<uintptr_t>(dst + i) % 64 != 0) {
    dst[i] = src[i];
    ++i;
  }
  for (; i + 16 <= n; i += 16) _mm512_stream_ps(dst + i, _mm512_loadu_ps(src + i));
  for (; i < n; ++i) dst[i] = src[i];
  _mm_sfence();
#else
  std::copy(src, src + n, dst);
#endif
}

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

}  // namespace shrm::internal
