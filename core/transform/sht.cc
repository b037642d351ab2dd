#include "core/transform/sht.h"

#include <fftw3.h>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <atomic>
#include <cmath>
#include <complex>
#include <map>
#include <mutex>
#include <thread>
#include <tuple>
#include <type_traits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/transform/fftw_wisdom.h"
#include "core/transform/real_fft.h"

namespace shrm {
namespace {

// Sectoral Legendre values below this are flushed to zero (avoids denormals near the poles).
constexpr double kSectoralFlush = 1e-280;
// Ring pairs are padded to a multiple of the vector width.
constexpr int kLanes = 4;
// Ring pairs per RealFft batch, for up to kMaxBatchChannels channels (ShtPlan::ForwardImpl).
constexpr int kBatchPairs = 2;
constexpr int kMaxBatchChannels = 4;
// 4 doubles; alignment lowered to 8 so that views into std::vector<double> are valid.
using V4 = double __attribute__((vector_size(32), aligned(8)));

int PadPairs(int n) { return (n + kLanes - 1) / kLanes * kLanes; }

// Runs fn(task, worker) for task in [0, n) on up to num_threads threads (dynamic scheduling).
template <typename Fn>
void ParallelFor(int n, int num_threads, const Fn& fn) {
  const int t = std::max(1, std::min(num_threads, n));
  if (t == 1) {
    for (int i = 0; i < n; ++i) fn(i, 0);
    return;
  }
  std::atomic<int> next{0};
  auto worker = [&](int w) {
    for (int i; (i = next.fetch_add(1, std::memory_order_relaxed)) < n;) fn(i, w);
  };
  std::vector<std::thread> threads;
  threads.reserve(t - 1);
  for (int w = 1; w < t; ++w) threads.emplace_back(worker, w);
  worker(0);
  for (auto& th : threads) th.join();
}

// A ring of interleaved RGB (float or double) and its three channel rows (`w` doubles each, one
// after another): the transforms' layouts on either side of the FFTs. Float rings sixteen pixels
// at a time with AVX-512 (a value is converted exactly as the scalar loop converts it), the rest
// one by one.
#if defined(__AVX512F__)
// Lane l of interleaved vector v (0..2) holds element e = (16 v + l) / 3 of channel
// c = (16 v + l) % 3. Two two-source permutes make a vector: the first of the red and green rows,
// the second of that and the blue row (entry 16 + e picks the second source's lane e).
struct Rgb16Tables {
  alignas(64) int32_t rg[3][16], b[3][16];   // interleaving
  alignas(64) int32_t lo[3][16], hi[3][16];  // deinterleaving: channel c from vectors 0, 1 then 2
  constexpr Rgb16Tables() : rg(), b(), lo(), hi() {
    for (int v = 0; v < 3; ++v) {
      for (int l = 0; l < 16; ++l) {
        const int j = 16 * v + l, e = j / 3, c = j % 3;
        rg[v][l] = c == 0 ? e : c == 1 ? 16 + e : 0;
        b[v][l] = c == 2 ? 16 + e : l;
      }
    }
    for (int c = 0; c < 3; ++c) {
      for (int e = 0; e < 16; ++e) {
        const int j = 3 * e + c;  // its place in the 48 interleaved values
        lo[c][e] = j < 32 ? j : 0;
        hi[c][e] = j < 32 ? e : 16 + (j - 32);
      }
    }
  }
};
constexpr Rgb16Tables kRgb16;
#endif

template <typename T>
void DeinterleaveRgb(const T* src, int w, double* dst) {
  int i = 0;
#if defined(__AVX512F__)
  if constexpr (std::is_same_v<T, float>) {
    for (; i + 16 <= w; i += 16) {
      const __m512 in0 = _mm512_loadu_ps(src + 3 * i), in1 = _mm512_loadu_ps(src + 3 * i + 16),
                   in2 = _mm512_loadu_ps(src + 3 * i + 32);
      for (int c = 0; c < 3; ++c) {
        const __m512 t = _mm512_permutex2var_ps(
            in0, _mm512_load_si512(reinterpret_cast<const __m512i*>(kRgb16.lo[c])), in1);
        const __m512 v = _mm512_permutex2var_ps(
            t, _mm512_load_si512(reinterpret_cast<const __m512i*>(kRgb16.hi[c])), in2);
        alignas(64) float f[16];
        _mm512_store_ps(f, v);
        double* d = dst + static_cast<size_t>(c) * w + i;
        _mm512_storeu_pd(d, _mm512_maskz_cvtps_pd(0xFF, _mm256_load_ps(f)));
        _mm512_storeu_pd(d + 8, _mm512_maskz_cvtps_pd(0xFF, _mm256_load_ps(f + 8)));
      }
    }
  }
#endif
  for (; i < w; ++i) {
    dst[i] = static_cast<double>(src[3 * i]);
    dst[w + i] = static_cast<double>(src[3 * i + 1]);
    dst[2 * w + i] = static_cast<double>(src[3 * i + 2]);
  }
}

template <typename T>
void InterleaveRgb(const double* src, int w, T* dst) {
  int i = 0;
#if defined(__AVX512F__)
  if constexpr (std::is_same_v<T, float>) {
    for (; i + 16 <= w; i += 16) {
      alignas(64) float f[3][16];
      for (int c = 0; c < 3; ++c) {
        const double* row = src + static_cast<size_t>(c) * w + i;
        _mm256_store_ps(f[c], _mm512_maskz_cvtpd_ps(0xFF, _mm512_loadu_pd(row)));
        _mm256_store_ps(f[c] + 8, _mm512_maskz_cvtpd_ps(0xFF, _mm512_loadu_pd(row + 8)));
      }
      const __m512 r = _mm512_load_ps(f[0]), g = _mm512_load_ps(f[1]), b = _mm512_load_ps(f[2]);
      for (int v = 0; v < 3; ++v) {
        const __m512 t = _mm512_permutex2var_ps(
            r, _mm512_load_si512(reinterpret_cast<const __m512i*>(kRgb16.rg[v])), g);
        _mm512_storeu_ps(
            dst + 3 * i + 16 * v,
            _mm512_permutex2var_ps(
                t, _mm512_load_si512(reinterpret_cast<const __m512i*>(kRgb16.b[v])), b));
      }
    }
  }
#endif
  for (; i < w; ++i) {
    for (int c = 0; c < 3; ++c) dst[3 * i + c] = static_cast<T>(src[c * w + i]);
  }
}

// FFTW-allocated (SIMD-aligned) scratch buffer.
template <typename T>
struct FftwBuffer {
  explicit FftwBuffer(size_t n)
      : data(static_cast<T*>(fftw_malloc(sizeof(T) * std::max<size_t>(n, 1)))) {}
  ~FftwBuffer() { fftw_free(data); }
  FftwBuffer(const FftwBuffer&) = delete;
  FftwBuffer& operator=(const FftwBuffer&) = delete;
  T* data;
};

// Ring pairs of a symmetric quadrature: x, sectoral starts, per-pair weights.
ShtPlan::RingSet MakeRingSet(const RingQuadrature& q, int lmax) {
  const int h = static_cast<int>(q.theta.size());
  ShtPlan::RingSet r;
  r.num_pairs = (h + 1) / 2;
  r.has_equator = (h % 2) == 1;
  const int pp = PadPairs(r.num_pairs);
  r.x.assign(pp, 0.0);
  r.sectoral.assign(static_cast<size_t>(lmax + 1) * pp, 0.0);
  // The recurrence's factors, the same for every pair.
  std::vector<double> factor(lmax + 1, 0.0);
  for (int m = 1; m <= lmax; ++m) factor[m] = -std::sqrt((2.0 * m + 1.0) / (2.0 * m));
  // Order by order, every pair's value of the order contiguous (the table's layout), in vector
  // lanes: v_p <- v_p (factor_m sin theta_p), the same products as pair by pair.
  std::vector<double> v(r.num_pairs, std::sqrt(1.0 / (4.0 * kPi)));  // lambda_0^0
  for (int p = 0; p < r.num_pairs; ++p) r.x[p] = q.cos_theta[p];
  const double* sin_theta = q.sin_theta.data();
  for (int m = 0; m <= lmax; ++m) {
    double* row = r.sectoral.data() + static_cast<size_t>(m) * pp;
    const double f = factor[m];
    for (int p = 0; p < r.num_pairs; ++p) {
      double value = m > 0 ? v[p] * (f * sin_theta[p]) : v[p];
      if (std::abs(value) < kSectoralFlush) value = 0.0;
      v[p] = value;
      row[p] = value;
    }
  }
  return r;
}

std::string GridName(const ShtGrid& g) {
  return absl::StrCat(g.width, "x", g.height,
                      g.kind == ShtGridKind::kEquiangular ? " equiangular" : " Gauss-Legendre");
}

}  // namespace

// FFTW plans for one ring pair (2 * channels real rings), each made on its first use: most plans
// serve one direction only (an analysis, or a synthesis grid), and planning one took about as
// long as a transform of the split-sum set's rough levels.
struct ShtPlan::FftwState {
  int width = 0, howmany = 0;
  std::once_flag r2c_once, c2r_once;
  fftw_plan r2c = nullptr;  // real [2ch][W] -> complex [2ch][W/2+1]
  fftw_plan c2r = nullptr;  // the inverse batch
  ~FftwState() {
    std::lock_guard<std::mutex> lock(FftwPlannerMutex());
    if (r2c) fftw_destroy_plan(r2c);
    if (c2r) fftw_destroy_plan(c2r);
  }
  // The plan of a direction (null if FFTW could not make it), planned on buffers of the layout
  // and alignment that the transforms execute it on, from the build's wisdom where it has some
  // for the size (core/transform/fftw_wisdom.h: the same plan without the planner's search).
  fftw_plan Get(bool forward) {
    std::call_once(forward ? r2c_once : c2r_once, [&] {
      const internal::RingFft fft{width, howmany, forward};
      std::lock_guard<std::mutex> lock(FftwPlannerMutex());
      if (const char* wisdom = internal::BuiltInWisdom(fft)) fftw_import_wisdom_from_string(wisdom);
      (forward ? r2c : c2r) = internal::PlanRingFft(fft);
    });
    return forward ? r2c : c2r;
  }
};

std::mutex& FftwPlannerMutex() {
  static std::mutex* mu = new std::mutex;
  return *mu;
}

double ShtColumnAzimuth(int width, int i) { return 1.5 * kPi - 2.0 * kPi * (i + 0.5) / width; }

Vec3 ShtGridDirection(const ShtGrid& grid, int i, int j) {
  double theta;
  if (grid.kind == ShtGridKind::kEquiangular) {
    theta = kPi * (j + 0.5) / grid.height;
  } else {
    theta = GaussLegendreRule(grid.height).theta[j];
  }
  const double p = 2.0 * kPi * ((i + 0.5) / grid.width - 0.5);
  const double st = std::sin(theta);
  return {st * std::sin(p), std::cos(theta), -st * std::cos(p)};
}

int ShtMaxDegree(const ShtGrid& grid) { return std::min(grid.height - 1, (grid.width - 1) / 2); }

size_t ShtPlan::map_size() const {
  return static_cast<size_t>(grid_.width) * grid_.height * channels_;
}
size_t ShtPlan::coeff_size() const { return static_cast<size_t>(ShCount(lmax_)) * channels_; }

ShtPlan::~ShtPlan() = default;

absl::StatusOr<std::shared_ptr<const ShtPlan>> ShtPlan::Create(const ShtGrid& grid, int lmax,
                                                               int channels,
                                                               ShtQuadrature quadrature) {
  return CreateImpl(grid, lmax, channels, /*synthesis=*/false, quadrature);
}

absl::StatusOr<std::shared_ptr<const ShtPlan>> ShtPlan::CreateForSynthesis(const ShtGrid& grid,
                                                                           int lmax, int channels) {
  return CreateImpl(grid, lmax, channels, /*synthesis=*/true, ShtQuadrature::kExact);
}

absl::StatusOr<std::shared_ptr<const ShtPlan>> ShtPlan::CreateImpl(const ShtGrid& grid, int lmax,
                                                                   int channels, bool synthesis,
                                                                   ShtQuadrature quadrature) {
  if (grid.width < 1 || grid.height < 1) {
    return absl::InvalidArgumentError(absl::StrCat("SHT: empty grid ", grid.width, "x", grid.height,
                                                   " (width and height must be >= 1)"));
  }
  if (lmax < 0) {
    return absl::InvalidArgumentError(absl::StrCat("SHT: negative degree lmax = ", lmax));
  }
  if (channels < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: channels must be >= 1 (got ", channels, ")"));
  }
  const int w = grid.width, h = grid.height;
  const bool resolvable = lmax <= h - 1 && w >= 2 * lmax + 1;
  if (!synthesis && !resolvable) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SHT: degree lmax = ", lmax, " exceeds the limit of the ", GridName(grid),
        " grid (needs lmax <= H - 1 = ", h - 1, " and W >= 2 lmax + 1 = ", 2 * lmax + 1,
        "; max degree here is ", ShtMaxDegree(grid), ")"));
  }
  auto plan = std::shared_ptr<ShtPlan>(new ShtPlan());
  plan->grid_ = grid;
  plan->lmax_ = lmax;
  plan->channels_ = channels;
  plan->supports_forward_ = resolvable;

  const RingQuadrature q =
      grid.kind == ShtGridKind::kEquiangular ? FejerFirstRule(h) : GaussLegendreRule(h);
  plan->rings_ = MakeRingSet(q, lmax);
  const int np = plan->rings_.num_pairs;
  const bool resample = resolvable && grid.kind == ShtGridKind::kEquiangular && h < 2 * lmax + 1 &&
                        quadrature == ShtQuadrature::kExact;
  plan->ring_scale_.assign(PadPairs(np), 0.0);
  for (int p = 0; p < np; ++p) {
    plan->ring_scale_[p] = 2.0 * kPi / w * (resample ? 1.0 : q.weight[p]);
  }

  // Recurrence lambda_l^m = a (x lambda_{l-1}^m - b lambda_{l-2}^m), l >= m + 1.
  // Degree by degree, the orders m < l of a degree contiguous (LegendreIndex is l-major): the
  // inner loop runs in vector lanes (the same correctly rounded divisions and square roots).
  plan->rec_a_.assign(LegendreCount(lmax), 0.0);
  plan->rec_b_.assign(LegendreCount(lmax), 0.0);
  for (int l = 1; l <= lmax; ++l) {
    const double ll = static_cast<double>(l) * l, l1 = l - 1.0;
    double* a = plan->rec_a_.data() + LegendreIndex(l, 0);
    double* b = plan->rec_b_.data() + LegendreIndex(l, 0);
    for (int m = 0; m < l; ++m) {
      const double mm = static_cast<double>(m) * m;
      a[m] = std::sqrt((4.0 * ll - 1.0) / (ll - mm));
      b[m] = std::sqrt((l1 * l1 - mm) / (4.0 * l1 * l1 - 1.0));
    }
  }

  if (resample) {
    // Virtual Fejer-1 grid with hv = 2 lmax + 2 rings (exact for degree 2 lmax; even: no equator).
    const int hv = 2 * lmax + 2;
    const RingQuadrature qv = FejerFirstRule(hv);
    plan->virtual_rings_ = MakeRingSet(qv, lmax);
    const int nv = plan->virtual_rings_.num_pairs;
    plan->virtual_scale_.assign(PadPairs(nv), 0.0);
    for (int v = 0; v < nv; ++v) plan->virtual_scale_[v] = qv.weight[v];
    // Trigonometric tables up to frequency H.
    std::vector<double> cp(static_cast<size_t>(np) * (h + 1)), sp(cp.size());
    std::vector<double> cv(static_cast<size_t>(nv) * (h + 1)), sv(cv.size());
    for (int p = 0; p < np; ++p) {
      for (int n = 0; n <= h; ++n) {
        cp[p * (h + 1) + n] = std::cos(n * q.theta[p]);
        sp[p * (h + 1) + n] = std::sin(n * q.theta[p]);
      }
    }
    for (int v = 0; v < nv; ++v) {
      for (int n = 0; n <= h; ++n) {
        cv[v * (h + 1) + n] = std::cos(n * qv.theta[v]);
        sv[v * (h + 1) + n] = std::sin(n * qv.theta[v]);
      }
    }
    // Even m: cosine series, a_n = (c_n / H) sum_k g_k cos(n theta_k), n < H (DCT-II);
    // odd m: sine series, b_n = (s_n / H) sum_k g_k sin(n theta_k), 1 <= n <= H (DST-II).
    // Pair sums/differences select the frequency parity (see the header comment).
    for (int kind = 0; kind < 4; ++kind) {
      const bool odd_m = kind >= 2, out_o = kind % 2 == 1;
      std::vector<double>& mat = plan->resample_[kind];
      mat.assign(static_cast<size_t>(nv) * np, 0.0);
      for (int v = 0; v < nv; ++v) {
        for (int p = 0; p < np; ++p) {
          double sum = 0;
          if (!odd_m) {
            for (int n = out_o ? 1 : 0; n < h; n += 2) {
              const double c = n == 0 ? 1.0 : 2.0;
              sum += c * cv[v * (h + 1) + n] * cp[p * (h + 1) + n];
            }
          } else {
            for (int n = out_o ? 2 : 1; n <= h; n += 2) {
              const double c = n == h ? 1.0 : 2.0;
              sum += c * sv[v * (h + 1) + n] * sp[p * (h + 1) + n];
            }
          }
          mat[static_cast<size_t>(v) * np + p] = 2.0 * sum / h;
        }
      }
    }
  }

  plan->fftw_ = std::make_unique<FftwState>();
  plan->fftw_->width = w;
  plan->fftw_->howmany = 2 * channels;
  plan->real_fft_ = internal::RealFft::Get(w);
  return std::shared_ptr<const ShtPlan>(std::move(plan));
}

namespace {

// lambda_m^m (the sectoral start) into cur and 0 into prev, on every ring pair.
void StartColumn(int nv, const V4* sect, V4* prev, V4* cur) {
  for (int v = 0; v < nv; ++v) {
    prev[v] = V4{0, 0, 0, 0};
    cur[v] = sect[v];
  }
}

// One step of the recurrence: cur = lambda_l^m from cur = lambda_{l-1}^m and prev = lambda_{l-2}^m.
void AdvanceColumn(int l, int m, int nv, const V4* x, const double* rec_a, const double* rec_b,
                   V4* prev, V4* cur) {
  const double a = rec_a[LegendreIndex(l, m)], b = rec_b[LegendreIndex(l, m)];
  for (int v = 0; v < nv; ++v) {
    const V4 nx = a * (x[v] * cur[v] - b * prev[v]);
    prev[v] = cur[v];
    cur[v] = nx;
  }
}

// Polar rings where lambda_l^m is negligible. For a fixed ring, lambda_l^m(cos theta) is
// exponentially small in l until l reaches about m / sin theta (outside the classical region of
// the Legendre equation), then oscillates with an amplitude of order one. Values below
// kNegligible (the normalized lambda reach sqrt((2l + 1) / 4 pi), a few units, on the rings
// nearer the equator that every sum includes) change a sum by less than 1e-30 of the largest
// ring data it holds, some 1e-14 of a double's rounding. A column starts at the first pair vector
// any of whose lanes has a non-negligible sectoral start; the vectors before it (nearer the poles)
// only advance their recurrence, four degrees per pass, until one of their values passes the
// threshold, from which pass on they take part in the sums. At degree 392 on a 512-ring map this
// skips 17% of the analysis's sums (measured; the region outside the turning point holds a third
// of them, but most of it is within 30 orders of magnitude of the turning point's values).
constexpr double kNegligible = 1e-30;

bool AnyNotNegligible(V4 a) {
  const auto big = (a > kNegligible) | (a < -kNegligible);
  return (big[0] | big[1] | big[2] | big[3]) != 0;
}

// The first pair vector whose sectoral start is not negligible (nv if none is).
int FirstActive(int nv, const V4* sect) {
  int v = 0;
  while (v < nv && !AnyNotNegligible(sect[v])) ++v;
  return v;
}

// The recurrence's coefficients of degrees l + 1 .. l + 4 of order m (zero past lmax), and one
// ring-pair vector's values lambda_l .. lambda_{l+3} from lambda_{l-1} and lambda_l.
struct FourDegrees {
  double a[4], b[4];
  FourDegrees(int l, int m, int lmax, const double* rec_a, const double* rec_b) {
    for (int i = 0; i < 4; ++i) {
      const bool exists = l + 1 + i <= lmax;
      a[i] = exists ? rec_a[LegendreIndex(l + 1 + i, m)] : 0.0;
      b[i] = exists ? rec_b[LegendreIndex(l + 1 + i, m)] : 0.0;
    }
  }
  // c[i] = lambda_{l+i} for i < 4; returns lambda_{l+4}.
  [[gnu::always_inline]] V4 Values(V4 x, V4 prev, V4 cur, V4 c[4]) const {
    c[0] = cur;
    c[1] = a[0] * (x * c[0] - b[0] * prev);
    c[2] = a[1] * (x * c[1] - b[1] * c[0]);
    c[3] = a[2] * (x * c[2] - b[2] * c[1]);
    return a[3] * (x * c[3] - b[3] * c[2]);
  }
};

// Advances the recurrence of the pair vectors [0, first) by four degrees (as FourDegrees::Values
// does for the others); returns the new first active vector: the first of them one of whose
// lambda_{l+3}, lambda_{l+4} is not negligible, else `first`.
int AdvanceNegligible(const FourDegrees& rec, int first, const V4* x, V4* prev, V4* cur) {
  int active = first;
  for (int v = 0; v < first; ++v) {
    V4 c[4];
    const V4 next = rec.Values(x[v], prev[v], cur[v], c);
    prev[v] = c[3];
    cur[v] = next;
    if (active == first && (AnyNotNegligible(c[3]) || AnyNotNegligible(next))) active = v;
  }
  return active;
}

// One m of the analysis's theta stage for K = 2 x channels arrays (re, im per channel): degrees
// l and l + 1 (the E and O arrays) in one pass over the pairs, each of the 2K dot products in its
// own accumulator. Each sum still runs over the pairs in order, lane by lane, as one degree at a
// time did; what changes is that the 2K sums no longer wait on one another (one chain of dependent
// adds per sum was the stage's limit). `emit(l, sums)` gets
// the K lane-vectors of degree l.
template <int K, typename Emit>
void AnalysisColumn(int m, int lmax, int nv, const V4* x, const V4* sect, const double* rec_a,
                    const double* rec_b, const V4* e, const V4* o, V4* prev, V4* cur,
                    const Emit& emit) {
  StartColumn(nv, sect, prev, cur);
  int l = m;
  // Four degrees per pass where the recurrence's coefficients exist: each E/O value loaded once
  // serves two degrees. Pair vectors before `active_from` are negligible so far (kNegligible).
  int active_from = FirstActive(nv, sect);
  for (; l + 3 <= lmax; l += 4) {
    const FourDegrees rec(l, m, lmax, rec_a, rec_b);
    V4 se0[K], so1[K], se2[K], so3[K];
    for (int k = 0; k < K; ++k) se0[k] = so1[k] = se2[k] = so3[k] = V4{0, 0, 0, 0};
    const int next_from = AdvanceNegligible(rec, active_from, x, prev, cur);
    for (int v = active_from; v < nv; ++v) {
      V4 c[4];
      const V4 next = rec.Values(x[v], prev[v], cur[v], c);
      for (int k = 0; k < K; ++k) {
        const V4 ek = e[static_cast<size_t>(k) * nv + v];
        const V4 ok = o[static_cast<size_t>(k) * nv + v];
        se0[k] += c[0] * ek;
        se2[k] += c[2] * ek;
        so1[k] += c[1] * ok;
        so3[k] += c[3] * ok;
      }
      prev[v] = c[3];
      cur[v] = next;
    }
    emit(l, se0);
    emit(l + 1, so1);
    emit(l + 2, se2);
    emit(l + 3, so3);
    active_from = next_from;
  }
  for (; l + 1 <= lmax; l += 2) {
    // cur = lambda_l (l - m even: E), prev = lambda_{l-1}; lambda_{l+1} pairs with O.
    const double a1 = rec_a[LegendreIndex(l + 1, m)], b1 = rec_b[LegendreIndex(l + 1, m)];
    const bool more = l + 2 <= lmax;
    const double a2 = more ? rec_a[LegendreIndex(l + 2, m)] : 0.0;
    const double b2 = more ? rec_b[LegendreIndex(l + 2, m)] : 0.0;
    V4 se[K], so[K];
    for (int k = 0; k < K; ++k) se[k] = so[k] = V4{0, 0, 0, 0};
    for (int v = 0; v < nv; ++v) {
      const V4 c0 = cur[v];
      const V4 c1 = a1 * (x[v] * c0 - b1 * prev[v]);
      for (int k = 0; k < K; ++k) {
        se[k] += c0 * e[static_cast<size_t>(k) * nv + v];
        so[k] += c1 * o[static_cast<size_t>(k) * nv + v];
      }
      prev[v] = c1;
      cur[v] = a2 * (x[v] * c1 - b2 * c0);
    }
    emit(l, se);
    emit(l + 1, so);
  }
  if (l <= lmax) {  // the last degree alone (lmax - m even): cur = lambda_l, E
    V4 se[K];
    for (int k = 0; k < K; ++k) se[k] = V4{0, 0, 0, 0};
    for (int v = 0; v < nv; ++v) {
      for (int k = 0; k < K; ++k) se[k] += cur[v] * e[static_cast<size_t>(k) * nv + v];
    }
    emit(l, se);
  }
}

// One m of the synthesis's theta stage: E += q_l lambda_l for even l - m, O += the odd ones, four
// degrees per pass over the pairs (then two, then one), so that each E/O value is loaded and stored
// once per four degrees instead of once per degree. Each value still gets the same terms in the
// same order (one fused multiply-add per degree), so the result is that of one degree at a time.
// `load(l, q)` fills the K values q_lm (re, im per channel) of degree l.
template <int K, typename Load, typename Prefetch>
void SynthesisColumn(int m, int lmax, int nv, const V4* x, const V4* sect, const double* rec_a,
                     const double* rec_b, const Load& load, const Prefetch& prefetch, V4* e, V4* o,
                     V4* prev, V4* cur) {
  StartColumn(nv, sect, prev, cur);
  int l = m;
  // Pair vectors before `active_from` are negligible so far (kNegligible): their E/O get nothing.
  int active_from = FirstActive(nv, sect);
  // The column's E/O start as whatever the buffer held: the first pass of four degrees writes
  // them (zeros where it adds nothing), the later ones add; a column of fewer than four degrees
  // is zeroed first. (The sums are those from a zeroed buffer: each starts from +0.)
  const auto zero = [&](int v_end) {
    for (int k = 0; k < K; ++k) {
      for (int v = 0; v < v_end; ++v) {
        e[static_cast<size_t>(k) * nv + v] = V4{0, 0, 0, 0};
        o[static_cast<size_t>(k) * nv + v] = V4{0, 0, 0, 0};
      }
    }
  };
  if (l + 3 > lmax) zero(nv);
  const auto pass = [&]<bool kFirst>(std::bool_constant<kFirst>) {
    const FourDegrees rec(l, m, lmax, rec_a, rec_b);
    double q0[K], q1[K], q2[K], q3[K];
    // The next pass's coefficients (a cache line or two apart per degree) are fetched while this
    // pass runs.
    for (int n = l + 4; n < std::min(l + 8, lmax + 1); ++n) prefetch(n);
    load(l, q0);
    load(l + 1, q1);
    load(l + 2, q2);
    load(l + 3, q3);
    if constexpr (kFirst) zero(active_from);
    const int next_from = AdvanceNegligible(rec, active_from, x, prev, cur);
    for (int v = active_from; v < nv; ++v) {
      V4 c[4];
      const V4 next = rec.Values(x[v], prev[v], cur[v], c);
      for (int k = 0; k < K; ++k) {
        V4& ek = e[static_cast<size_t>(k) * nv + v];
        V4& ok = o[static_cast<size_t>(k) * nv + v];
        V4 te, to;
        if constexpr (kFirst) {
          te = V4{0, 0, 0, 0};
          to = V4{0, 0, 0, 0};
        } else {
          te = ek;
          to = ok;
        }
        te += q0[k] * c[0];
        to += q1[k] * c[1];
        te += q2[k] * c[2];
        to += q3[k] * c[3];
        ek = te;
        ok = to;
      }
      prev[v] = c[3];
      cur[v] = next;
    }
    active_from = next_from;
  };
  if (l + 3 <= lmax) {
    pass(std::true_type{});
    l += 4;
  }
  for (; l + 3 <= lmax; l += 4) pass(std::false_type{});
  // The last one to three degrees, one at a time (cur = lambda_l already on entry).
  for (const int first = l; l <= lmax; ++l) {
    if (l > first) AdvanceColumn(l, m, nv, x, rec_a, rec_b, prev, cur);
    double q[K];
    load(l, q);
    V4* d = (l - m) % 2 == 0 ? e : o;
    for (int k = 0; k < K; ++k) {
      V4* dk = d + static_cast<size_t>(k) * nv;
      for (int v = 0; v < nv; ++v) dk[v] += q[k] * cur[v];
    }
  }
}

}  // namespace

// Theta stage, eq. (1): coeffs(l, m) = sum_p lambda_l^m(x_p) (E_p or O_p), E/O by parity of l-m.
// eo layout: [((m * 2 + parity) * channels + c) * 2 + re/im][pair], pairs padded with zeros.
void ShtPlan::LegendreAnalysis(const RingSet& rings, std::span<const double> eo,
                               std::span<double> coeffs, int num_threads) const {
  const int pp = PadPairs(rings.num_pairs);
  const int nv = pp / kLanes;
  const int ch = channels_;
  const size_t m_stride = static_cast<size_t>(2) * ch * 2 * pp;
  ParallelFor(lmax_ + 1, num_threads, [&](int m, int) {
    std::vector<double> prev_store(pp), cur_store(pp);
    V4* prev = reinterpret_cast<V4*>(prev_store.data());
    V4* cur = reinterpret_cast<V4*>(cur_store.data());
    const V4* x = reinterpret_cast<const V4*>(rings.x.data());
    const V4* sect =
        reinterpret_cast<const V4*>(rings.sectoral.data() + static_cast<size_t>(m) * pp);
    const V4* e = reinterpret_cast<const V4*>(eo.data() + m * m_stride);
    const V4* o = e + static_cast<size_t>(ch) * 2 * nv;
    const auto emit = [&](int l, const V4* acc) {
      for (int c = 0; c < ch; ++c) {
        const V4 sr = acc[2 * c], si = acc[2 * c + 1];
        const double re = (sr[0] + sr[1]) + (sr[2] + sr[3]);
        const double im = (si[0] + si[1]) + (si[2] + si[3]);
        if (m == 0) {
          coeffs[static_cast<size_t>(ShIndex(l, 0)) * ch + c] = re;
        } else {
          coeffs[static_cast<size_t>(ShIndex(l, m)) * ch + c] = kSqrt2 * re;
          coeffs[static_cast<size_t>(ShIndex(l, -m)) * ch + c] = -kSqrt2 * im;
        }
      }
    };
    const double* ra = rec_a_.data();
    const double* rb = rec_b_.data();
    switch (ch) {
      case 1:
        AnalysisColumn<2>(m, lmax_, nv, x, sect, ra, rb, e, o, prev, cur, emit);
        break;
      case 3:
        AnalysisColumn<6>(m, lmax_, nv, x, sect, ra, rb, e, o, prev, cur, emit);
        break;
      case 4:
        AnalysisColumn<8>(m, lmax_, nv, x, sect, ra, rb, e, o, prev, cur, emit);
        break;
      default: {
        // Other channel counts: one degree at a time (the same sums, in the same order).
        std::vector<double> acc_store(static_cast<size_t>(2) * ch * kLanes);
        V4* acc = reinterpret_cast<V4*>(acc_store.data());
        StartColumn(nv, sect, prev, cur);
        for (int l = m; l <= lmax_; ++l) {
          if (l > m) AdvanceColumn(l, m, nv, x, ra, rb, prev, cur);
          const V4* d = (l - m) % 2 == 0 ? e : o;
          for (int k = 0; k < 2 * ch; ++k) {
            V4 s = {0, 0, 0, 0};
            const V4* dk = d + static_cast<size_t>(k) * nv;
            for (int v = 0; v < nv; ++v) s += cur[v] * dk[v];
            acc[k] = s;
          }
          emit(l, acc);
        }
      }
    }
  });
}

template <typename T>
absl::Status ShtPlan::ForwardImpl(std::span<const T> map, std::span<double> coeffs,
                                  int num_threads) const {
  if (!supports_forward_) {
    return absl::FailedPreconditionError(
        absl::StrCat("SHT: this synthesis-only plan cannot analyse degree ", lmax_, " on the ",
                     GridName(grid_), " grid (max degree ", ShtMaxDegree(grid_), ")"));
  }
  if (num_threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: num_threads must be >= 1 (got ", num_threads, ")"));
  }
  if (map.size() != map_size()) {
    return absl::InvalidArgumentError(absl::StrCat("SHT: map has ", map.size(),
                                                   " values, expected W*H*channels = ", map_size(),
                                                   " for ", GridName(grid_)));
  }
  if (coeffs.size() != coeff_size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: coefficient array has ", coeffs.size(),
                     " values, expected (lmax+1)^2*channels = ", coeff_size()));
  }
  const fftw_plan r2c = real_fft_ ? nullptr : fftw_->Get(/*forward=*/true);
  if (!real_fft_ && r2c == nullptr) return absl::InternalError("SHT: FFTW planning failed");
  const int w = grid_.width, h = grid_.height, ch = channels_, lmax = lmax_;
  const int np = rings_.num_pairs, pp = PadPairs(np);
  const int nc = w / 2 + 1;
  const size_t m_stride = static_cast<size_t>(2) * ch * 2 * pp;
  // Every value is written below (the padding pairs as zeros), so the buffer starts uninitialized.
  const size_t eo_size = m_stride * (lmax + 1);
  std::unique_ptr<double[]> eo_store(new double[eo_size]);
  const std::span<double> eo(eo_store.get(), eo_size);
  // Phase of eq. (2) for phi_s(i) = 3 pi / 2 - 2 pi (i + 1/2) / W:
  // sum_i f_i e^{-i m phi_s(i)} = e^{-i m (3 pi / 2 - pi / W)} conj(DFT(f)_m).
  std::vector<std::complex<double>> phase(lmax + 1);
  for (int m = 0; m <= lmax; ++m) phase[m] = std::polar(1.0, -m * (1.5 * kPi - kPi / w));

  // Phi stage: one FFT batch per ring pair, then E = G_n + G_s and O = G_n - G_s written for a
  // block of pairs at a time: each (m, parity, channel, re/im) row gets kPairsPerTask consecutive
  // values, a whole cache line, instead of one value per line per pair (the buffer is larger than
  // the caches, so single values cost a line's traffic each).
  constexpr int kPairsPerTask = 8;
  const int num_tasks = (pp + kPairsPerTask - 1) / kPairsPerTask;
  const int workers = std::max(1, std::min(num_threads, num_tasks));
  // RealFft's batches: two pairs' 4 ch rows (three channels: 12 rows, every lane of its vectors
  // busy; one pair's 6 would leave a quarter idle).
  const int batch = real_fft_ && ch <= kMaxBatchChannels ? kBatchPairs : 1;
  // Each pair's spectra start on a 64-byte boundary (FFTW's SIMD alignment, as planned).
  const size_t pair_spectra = (static_cast<size_t>(2) * ch * nc + 3) / 4 * 4;
  std::vector<std::unique_ptr<FftwBuffer<double>>> in_bufs(workers);
  std::vector<std::unique_ptr<FftwBuffer<fftw_complex>>> out_bufs(workers);
  ParallelFor(num_tasks, workers, [&](int task, int worker) {
    if (!in_bufs[worker]) {
      // Two pairs' rows: RealFft takes them in one batch (kBatchPairs).
      in_bufs[worker] =
          std::make_unique<FftwBuffer<double>>(static_cast<size_t>(kBatchPairs) * 2 * ch * w);
      out_bufs[worker] = std::make_unique<FftwBuffer<fftw_complex>>(pair_spectra * kPairsPerTask);
    }
    const int p_begin = task * kPairsPerTask;
    const int p_end = std::min(np, p_begin + kPairsPerTask);
    for (int p = p_begin; p < p_end; ++p) {
      fftw_complex* out = out_bufs[worker]->data + (p - p_begin) * pair_spectra;
      double* in = in_bufs[worker]->data + static_cast<size_t>((p - p_begin) % batch) * 2 * ch * w;
      const bool equator = rings_.has_equator && p == np - 1;
      for (int half = 0; half < 2; ++half) {
        double* dst = in + static_cast<size_t>(half) * ch * w;
        if (half == 1 && equator) {
          std::fill(dst, dst + static_cast<size_t>(ch) * w, 0.0);
          continue;
        }
        const int j = half == 0 ? p : h - 1 - p;
        const T* src = map.data() + static_cast<size_t>(j) * w * ch;
        if (ch == 1) {
          for (int i = 0; i < w; ++i) dst[i] = static_cast<double>(src[i]);
        } else if (ch == 3) {
          DeinterleaveRgb(src, w, dst);
        } else {
          for (int i = 0; i < w; ++i) {
            for (int c = 0; c < ch; ++c) dst[c * w + i] = static_cast<double>(src[i * ch + c]);
          }
        }
      }
      // Prefetch the next pair's rows so that the memory reads overlap with this pair's FFTs.
      if (p + 1 < np) {
        const size_t row_bytes = static_cast<size_t>(w) * ch * sizeof(T);
        const char* r1 =
            reinterpret_cast<const char*>(map.data() + static_cast<size_t>(p + 1) * w * ch);
        const char* r2 =
            reinterpret_cast<const char*>(map.data() + static_cast<size_t>(h - 2 - p) * w * ch);
        for (size_t b = 0; b < row_bytes; b += 64) {
          __builtin_prefetch(r1 + b);
          __builtin_prefetch(r2 + b);
        }
      }
      if (!real_fft_) {
        fftw_execute_dft_r2c(r2c, in, out);
      } else if (batch == 1) {
        real_fft_->Forward(in, reinterpret_cast<std::complex<double>*>(out), 2 * ch);
      } else if ((p - p_begin) % batch == batch - 1 || p + 1 == p_end) {
        // The batch's pairs (this one and those before it in the buffer): 2 ch rows each.
        const int first = p - (p - p_begin) % batch, rows = (p - first + 1) * 2 * ch;
        const double* in_rows[kBatchPairs * 2 * kMaxBatchChannels];
        std::complex<double>* out_rows[kBatchPairs * 2 * kMaxBatchChannels];
        for (int r = 0; r < rows; ++r) {
          const int q = r / (2 * ch), k = r % (2 * ch);
          in_rows[r] = in_bufs[worker]->data + (static_cast<size_t>(q) * 2 * ch + k) * w;
          out_rows[r] = reinterpret_cast<std::complex<double>*>(
              out_bufs[worker]->data + (first + q - p_begin) * pair_spectra + k * nc);
        }
        real_fft_->Forward(in_rows, out_rows, rows);
      }
    }
    const int p_pad = std::min(pp, p_begin + kPairsPerTask);  // padding pairs get zeros
    for (int m = 0; m <= lmax; ++m) {
      double* e = eo.data() + m * m_stride;
      double* o = e + static_cast<size_t>(ch) * 2 * pp;
      for (int c = 0; c < ch; ++c) {
        double* er = e + static_cast<size_t>(2 * c) * pp;
        double* ei = er + pp;
        double* orr = o + static_cast<size_t>(2 * c) * pp;
        double* oi = orr + pp;
        for (int p = p_begin; p < p_end; ++p) {
          const fftw_complex* out = out_bufs[worker]->data + (p - p_begin) * pair_spectra;
          const std::complex<double> ph = phase[m] * ring_scale_[p];
          const fftw_complex& dn = out[static_cast<size_t>(c) * nc + m];
          const fftw_complex& ds = out[static_cast<size_t>(ch + c) * nc + m];
          const std::complex<double> gn = ph * std::complex<double>(dn[0], -dn[1]);
          const std::complex<double> gs = ph * std::complex<double>(ds[0], -ds[1]);
          er[p] = gn.real() + gs.real();
          ei[p] = gn.imag() + gs.imag();
          orr[p] = gn.real() - gs.real();
          oi[p] = gn.imag() - gs.imag();
        }
        for (int p = p_end; p < p_pad; ++p) er[p] = ei[p] = orr[p] = oi[p] = 0.0;
      }
    }
  });

  if (!resamples_theta()) {
    LegendreAnalysis(rings_, eo, coeffs, num_threads);
    return absl::OkStatus();
  }
  // Exact theta resampling onto the virtual Fejer-1 rings (equiangular grids with H <= 2 lmax).
  const int nvp = virtual_rings_.num_pairs, vpp = PadPairs(nvp);
  const size_t vm_stride = static_cast<size_t>(2) * ch * 2 * vpp;
  std::vector<double> veo(vm_stride * (lmax + 1), 0.0);
  ParallelFor(lmax + 1, num_threads, [&](int m, int) {
    for (int par = 0; par < 2; ++par) {
      const std::vector<double>& mat = resample_[2 * (m % 2) + par];
      for (int k = 0; k < 2 * ch; ++k) {
        const double* src = eo.data() + m * m_stride + (static_cast<size_t>(par) * 2 * ch + k) * pp;
        double* dst = veo.data() + m * vm_stride + (static_cast<size_t>(par) * 2 * ch + k) * vpp;
        for (int v = 0; v < nvp; ++v) {
          const double* row = mat.data() + static_cast<size_t>(v) * np;
          double sum = 0;
          for (int p = 0; p < np; ++p) sum += row[p] * src[p];
          dst[v] = virtual_scale_[v] * sum;
        }
      }
    }
  });
  LegendreAnalysis(virtual_rings_, veo, coeffs, num_threads);
  return absl::OkStatus();
}

template <typename T>
absl::Status ShtPlan::InverseImpl(std::span<const double> coeffs, std::span<T> map, int num_threads,
                                  ShtScratch* scratch) const {
  if (num_threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: num_threads must be >= 1 (got ", num_threads, ")"));
  }
  if (coeffs.size() != coeff_size()) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: coefficient array has ", coeffs.size(),
                     " values, expected (lmax+1)^2*channels = ", coeff_size()));
  }
  if (map.size() != map_size()) {
    return absl::InvalidArgumentError(absl::StrCat("SHT: map has ", map.size(),
                                                   " values, expected W*H*channels = ", map_size(),
                                                   " for ", GridName(grid_)));
  }
  const fftw_plan c2r = real_fft_ ? nullptr : fftw_->Get(/*forward=*/false);
  if (!real_fft_ && c2r == nullptr) return absl::InternalError("SHT: FFTW planning failed");
  const int w = grid_.width, h = grid_.height, ch = channels_, lmax = lmax_;
  const int np = rings_.num_pairs, pp = PadPairs(np);
  const int nc = w / 2 + 1;
  // The ring pairs in blocks: the theta stage of one block (every m, the block's pairs) into a
  // buffer of the block's size, then the phi stage of its pairs from that buffer while it is in
  // the cache. The whole theta stage's output at once (degree 241 on 384 rings: 4.5 MB) was
  // written to memory, read back by the phi stage, and was fresh memory the kernel zeroed on
  // first touch. Each (m, pair)'s sums are those of the whole-sphere order: the same values.
  constexpr int kBlockPairs = 32;  // a multiple of kLanes and of kPairsPerTask below
  constexpr int kPairsPerTask = 8;
  // Smaller blocks (down to one task of pairs) when there would be fewer blocks than threads:
  // the blocks are the unit of parallel work. The values do not depend on the block size.
  int block_pairs = kBlockPairs;
  while (block_pairs > kPairsPerTask && (pp + block_pairs - 1) / block_pairs < num_threads) {
    block_pairs -= kPairsPerTask;
  }
  const int num_blocks = (pp + block_pairs - 1) / block_pairs;
  const int workers = std::max(1, std::min(num_threads, num_blocks));
  ShtScratch local;
  ShtScratch& work = scratch != nullptr ? *scratch : local;
  std::vector<double>& eo_first = work.theta;
  std::vector<std::vector<double>> eo_more(workers - 1);
  // With more than one block, the coefficients as the theta stage reads them: q_lm by m then l
  // (2 ch values each: Re, Im per channel; q_l0 = r_l0, q_lm = sqrt2 (r_lm - i r_{l,-m})), so
  // that each block reads each m's run in order; the (l, m) layout puts consecutive degrees of
  // one m a row apart (at degree 342, 2.8 MB read a cache line per value by each of 12 blocks:
  // slower than the whole-sphere stage it replaced).
  const int kq = 2 * ch;
  const bool pack = num_blocks > 1;
  std::vector<size_t> m_first(lmax + 2, 0);
  for (int m = 0; m <= lmax; ++m) m_first[m + 1] = m_first[m] + (lmax - m + 1);
  std::vector<double>& packed = work.coeffs;
  if (pack) {
    packed.resize(m_first[lmax + 1] * kq);
    for (int l = 0; l <= lmax; ++l) {
      const double* row = coeffs.data() + static_cast<size_t>(ShIndex(l, 0)) * ch;  // (l, 0)
      for (int m = 0; m <= l; ++m) {
        double* q = packed.data() + (m_first[m] + (l - m)) * kq;
        for (int c = 0; c < ch; ++c) {
          if (m == 0) {
            q[2 * c] = row[c];
            q[2 * c + 1] = 0.0;
          } else {
            q[2 * c] = kSqrt2 * row[static_cast<ptrdiff_t>(m) * ch + c];
            q[2 * c + 1] = -kSqrt2 * row[-static_cast<ptrdiff_t>(m) * ch + c];
          }
        }
      }
    }
  }

  // Phi stage: f_i = Re sum_m h_m e^{i m phi_s(i)} = Re sum_m q_m e^{-2 pi i m i / W} with
  // q_m = h_m e^{i m (3 pi / 2 - pi / W)}; fold into the half-spectrum of a real signal.
  std::vector<std::complex<double>> phase(lmax + 1);
  for (int m = 0; m <= lmax; ++m) phase[m] = std::polar(1.0, m * (1.5 * kPi - kPi / w));
  // Each pair's spectra start on a 64-byte boundary (FFTW's SIMD alignment, as planned).
  const size_t pair_spectra = (static_cast<size_t>(2) * ch * nc + 3) / 4 * 4;
  std::vector<std::unique_ptr<FftwBuffer<double>>> re_bufs(workers);
  std::vector<std::unique_ptr<FftwBuffer<fftw_complex>>> co_bufs(workers);
  ParallelFor(num_blocks, workers, [&](int block, int worker) {
    const int v_first = block * block_pairs;             // the block's first pair
    const int bp = std::min(block_pairs, pp - v_first);  // its pairs, padding included
    const int nv = bp / kLanes;
    const size_t m_stride = static_cast<size_t>(2) * ch * 2 * bp;
    std::vector<double>& eo = worker == 0 ? eo_first : eo_more[worker - 1];
    // (Not cleared: each column is written before it is added to, SynthesisColumn.)
    if (eo.size() < m_stride * (lmax + 1)) eo.resize(m_stride * (lmax + 1));

    // Theta stage: h_m(x_p) = sum_l lambda_l^m(x_p) q_lm split by parity of l - m, with
    // q_l0 = r_l0 and q_lm = sqrt2 (r_lm - i r_{l,-m}), so that f = Re sum_m h_m e^{i m phi}.
    std::vector<double> prev_store(bp), cur_store(bp);
    V4* prev = reinterpret_cast<V4*>(prev_store.data());
    V4* cur = reinterpret_cast<V4*>(cur_store.data());
    const V4* x = reinterpret_cast<const V4*>(rings_.x.data() + v_first);
    const double* ra = rec_a_.data();
    const double* rb = rec_b_.data();
    for (int m = 0; m <= lmax; ++m) {
      const V4* sect = reinterpret_cast<const V4*>(rings_.sectoral.data() +
                                                   static_cast<size_t>(m) * pp + v_first);
      V4* e = reinterpret_cast<V4*>(eo.data() + m * m_stride);
      V4* o = e + static_cast<size_t>(ch) * 2 * nv;
      // q[2c] = Re q_lm, q[2c + 1] = Im q_lm of channel c.
      const double* qm = pack ? packed.data() + m_first[m] * kq : nullptr;
      const auto load = [&](int l, double* q) {
        if (pack) {
          std::copy_n(qm + static_cast<size_t>(l - m) * kq, kq, q);
          return;
        }
        for (int c = 0; c < ch; ++c) {
          if (m == 0) {
            q[2 * c] = coeffs[static_cast<size_t>(ShIndex(l, 0)) * ch + c];
            q[2 * c + 1] = 0.0;
          } else {
            q[2 * c] = kSqrt2 * coeffs[static_cast<size_t>(ShIndex(l, m)) * ch + c];
            q[2 * c + 1] = -kSqrt2 * coeffs[static_cast<size_t>(ShIndex(l, -m)) * ch + c];
          }
        }
      };
      const auto prefetch = [&](int l) {
        if (pack) {
          __builtin_prefetch(qm + static_cast<size_t>(l - m) * kq);
          return;
        }
        __builtin_prefetch(&coeffs[static_cast<size_t>(ShIndex(l, m)) * ch]);
        if (m > 0) __builtin_prefetch(&coeffs[static_cast<size_t>(ShIndex(l, -m)) * ch]);
      };
      switch (ch) {
        case 1:
          SynthesisColumn<2>(m, lmax, nv, x, sect, ra, rb, load, prefetch, e, o, prev, cur);
          break;
        case 3:
          SynthesisColumn<6>(m, lmax, nv, x, sect, ra, rb, load, prefetch, e, o, prev, cur);
          break;
        case 4:
          SynthesisColumn<8>(m, lmax, nv, x, sect, ra, rb, load, prefetch, e, o, prev, cur);
          break;
        default: {
          // Other channel counts: one degree at a time (the same sums, in the same order).
          std::vector<double> q(static_cast<size_t>(2) * ch);
          std::fill(eo.begin() + m * m_stride, eo.begin() + (m + 1) * m_stride, 0.0);
          StartColumn(nv, sect, prev, cur);
          for (int l = m; l <= lmax; ++l) {
            if (l > m) AdvanceColumn(l, m, nv, x, ra, rb, prev, cur);
            load(l, q.data());
            V4* d = (l - m) % 2 == 0 ? e : o;
            for (int k = 0; k < 2 * ch; ++k) {
              V4* dk = d + static_cast<size_t>(k) * nv;
              for (int v = 0; v < nv; ++v) dk[v] += q[k] * cur[v];
            }
          }
        }
      }
    }

    // The phi stage of the block's pairs, kPairsPerTask at a time, so that each (m, parity,
    // channel, re/im) row is read a cache line at a time.
    if (!re_bufs[worker]) {
      re_bufs[worker] = std::make_unique<FftwBuffer<double>>(static_cast<size_t>(2) * ch * w);
      co_bufs[worker] = std::make_unique<FftwBuffer<fftw_complex>>(pair_spectra * kPairsPerTask);
    }
    double* re = re_bufs[worker]->data;
    fftw_complex* co_block = co_bufs[worker]->data;
    const int block_end = std::min(np, v_first + bp);
    for (int p_begin = v_first; p_begin < block_end; p_begin += kPairsPerTask) {
      const int p_end = std::min(block_end, p_begin + kPairsPerTask);
      std::fill(&co_block[0][0], &co_block[0][0] + pair_spectra * kPairsPerTask * 2, 0.0);
      for (int m = 0; m <= lmax; ++m) {
        const double* e = eo.data() + m * m_stride;
        const double* o = e + static_cast<size_t>(ch) * 2 * bp;
        const int k1 = m % w;
        const int k2 = (w - k1) % w;
        for (int c = 0; c < ch; ++c) {
          const double* er = e + static_cast<size_t>(2 * c) * bp;
          const double* ei = er + bp;
          const double* orr = o + static_cast<size_t>(2 * c) * bp;
          const double* oi = orr + bp;
          for (int p = p_begin; p < p_end; ++p) {
            fftw_complex* co = co_block + (p - p_begin) * pair_spectra;
            const int i = p - v_first;
            const std::complex<double> he(er[i], ei[i]);
            const std::complex<double> ho(orr[i], oi[i]);
            for (int half = 0; half < 2; ++half) {
              const std::complex<double> q = (half == 0 ? he + ho : he - ho) * phase[m];
              fftw_complex* xs = co + static_cast<size_t>(half * ch + c) * nc;
              if (m == 0) {
                xs[0][0] += q.real();
                continue;
              }
              // Re(q z^-m) = (q z^-m + conj(q) z^m) / 2 on the full spectrum, z = e^{2 pi i / W}.
              if (k1 <= w / 2) {
                xs[k1][0] += 0.5 * q.real();
                xs[k1][1] -= 0.5 * q.imag();
              }
              if (k2 <= w / 2) {
                xs[k2][0] += 0.5 * q.real();
                xs[k2][1] += 0.5 * q.imag();
              }
            }
          }
        }
      }
      for (int p = p_begin; p < p_end; ++p) {
        const bool equator = rings_.has_equator && p == np - 1;
        fftw_complex* spectra = co_block + (p - p_begin) * pair_spectra;
        if (real_fft_) {
          real_fft_->Inverse(reinterpret_cast<const std::complex<double>*>(spectra), re, 2 * ch);
        } else {
          fftw_execute_dft_c2r(c2r, spectra, re);
        }
        for (int half = 0; half < (equator ? 1 : 2); ++half) {
          const int j = half == 0 ? p : h - 1 - p;
          T* dst = map.data() + static_cast<size_t>(j) * w * ch;
          const double* src = re + static_cast<size_t>(half) * ch * w;
          if (ch == 3) {
            InterleaveRgb(src, w, dst);
            continue;
          }
          for (int i = 0; i < w; ++i) {
            for (int c = 0; c < ch; ++c) dst[i * ch + c] = static_cast<T>(src[c * w + i]);
          }
        }
      }
    }
  });
  return absl::OkStatus();
}

absl::Status ShtPlan::Forward(std::span<const float> map, std::span<double> coeffs,
                              int num_threads) const {
  return ForwardImpl<float>(map, coeffs, num_threads);
}
absl::Status ShtPlan::Forward(std::span<const double> map, std::span<double> coeffs,
                              int num_threads) const {
  return ForwardImpl<double>(map, coeffs, num_threads);
}
absl::Status ShtPlan::Inverse(std::span<const double> coeffs, std::span<float> map, int num_threads,
                              ShtScratch* scratch) const {
  return InverseImpl<float>(coeffs, map, num_threads, scratch);
}
absl::Status ShtPlan::Inverse(std::span<const double> coeffs, std::span<double> map,
                              int num_threads, ShtScratch* scratch) const {
  return InverseImpl<double>(coeffs, map, num_threads, scratch);
}

absl::StatusOr<std::shared_ptr<const ShtPlan>> GetShtPlan(const ShtGrid& grid, int lmax,
                                                          int channels, ShtQuadrature quadrature) {
  using Key = std::tuple<int, int, int, int, int, int>;
  static std::mutex* mu = new std::mutex;
  static auto* cache = new std::map<Key, std::shared_ptr<const ShtPlan>>;
  const Key key{grid.width, grid.height, static_cast<int>(grid.kind),
                lmax,       channels,    static_cast<int>(quadrature)};
  std::lock_guard<std::mutex> lock(*mu);
  auto it = cache->find(key);
  if (it != cache->end()) return it->second;
  auto plan = ShtPlan::Create(grid, lmax, channels, quadrature);
  if (!plan.ok()) return plan.status();
  cache->emplace(key, *plan);
  return *plan;
}

namespace {
template <typename T>
absl::StatusOr<std::vector<double>> ForwardShtImpl(const ShtGrid& grid, int lmax, int channels,
                                                   std::span<const T> map, int num_threads,
                                                   ShtQuadrature quadrature) {
  auto plan = GetShtPlan(grid, lmax, channels, quadrature);
  if (!plan.ok()) return plan.status();
  std::vector<double> coeffs((*plan)->coeff_size());
  absl::Status s = (*plan)->Forward(map, std::span<double>(coeffs), num_threads);
  if (!s.ok()) return s;
  return coeffs;
}
}  // namespace

absl::StatusOr<std::vector<double>> ForwardSht(const ShtGrid& grid, int lmax, int channels,
                                               std::span<const float> map, int num_threads,
                                               ShtQuadrature quadrature) {
  return ForwardShtImpl<float>(grid, lmax, channels, map, num_threads, quadrature);
}
absl::StatusOr<std::vector<double>> ForwardSht(const ShtGrid& grid, int lmax, int channels,
                                               std::span<const double> map, int num_threads,
                                               ShtQuadrature quadrature) {
  return ForwardShtImpl<double>(grid, lmax, channels, map, num_threads, quadrature);
}

absl::StatusOr<std::vector<double>> InverseSht(const ShtGrid& grid, int lmax, int channels,
                                               std::span<const double> coeffs, int num_threads) {
  auto plan = GetShtPlan(grid, lmax, channels);
  if (!plan.ok()) return plan.status();
  std::vector<double> map((*plan)->map_size());
  absl::Status s = (*plan)->Inverse(coeffs, std::span<double>(map), num_threads);
  if (!s.ok()) return s;
  return map;
}

absl::Status SynthesizeAtDirections(int lmax, int channels, std::span<const double> coeffs,
                                    std::span<const Vec3> world_dirs, std::span<double> out,
                                    int num_threads) {
  if (lmax < 0) {
    return absl::InvalidArgumentError(absl::StrCat("SHT: negative degree lmax = ", lmax));
  }
  if (channels < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: channels must be >= 1 (got ", channels, ")"));
  }
  if (num_threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: num_threads must be >= 1 (got ", num_threads, ")"));
  }
  const size_t nco = static_cast<size_t>(ShCount(lmax)) * channels;
  if (coeffs.size() != nco) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: coefficient array has ", coeffs.size(),
                     " values, expected (lmax+1)^2*channels = ", nco));
  }
  if (out.size() != world_dirs.size() * channels) {
    return absl::InvalidArgumentError(
        absl::StrCat("SHT: output has ", out.size(),
                     " values, expected directions*channels = ", world_dirs.size() * channels));
  }
  for (size_t k = 0; k < world_dirs.size(); ++k) {
    const Vec3& d = world_dirs[k];
    if (!(d.Dot(d) > 0.0) || !std::isfinite(d.Dot(d))) {
      return absl::InvalidArgumentError(
          absl::StrCat("SHT: direction ", k, " is zero or not finite"));
    }
  }
  constexpr int kChunk = 64;
  const int n = static_cast<int>(world_dirs.size());
  const int num_chunks = (n + kChunk - 1) / kChunk;
  const int ncount = ShCount(lmax);
  ParallelFor(num_chunks, num_threads, [&](int chunk, int) {
    const int k0 = chunk * kChunk, k1 = std::min(n, k0 + kChunk), nk = k1 - k0;
    std::vector<Vec3> dirs(nk);
    for (int k = 0; k < nk; ++k) dirs[k] = ShFrameFromWorld(world_dirs[k0 + k].Normalized());
    std::vector<double> y(static_cast<size_t>(ncount) * nk);
    EvalShBatch(lmax, dirs, y);
    std::vector<double> acc(static_cast<size_t>(nk) * channels, 0.0);
    for (int i = 0; i < ncount; ++i) {
      const double* yi = y.data() + static_cast<size_t>(i) * nk;
      for (int c = 0; c < channels; ++c) {
        const double ci = coeffs[static_cast<size_t>(i) * channels + c];
        for (int k = 0; k < nk; ++k) acc[static_cast<size_t>(k) * channels + c] += ci * yi[k];
      }
    }
    std::copy(acc.begin(), acc.end(), out.begin() + static_cast<ptrdiff_t>(k0) * channels);
  });
  return absl::OkStatus();
}

}  // namespace shrm
