// Fast spherical harmonic transforms (SHT) of multi-channel lat-long maps: analysis (map ->
// real SH coefficients) and synthesis (coefficients -> map, or -> arbitrary directions).
//
// Implements the separation-of-variables SHT used by Ramamoorthi & Hanrahan ("An Efficient
// Representation for Irradiance Environment Maps", sec. 3: L_lm = integral L(w) Y_lm(w) dw) and
// by Driscoll & Healy (1994) / libsharp (Reinecke & Seljebotn 2013, eqs. 1-6):
//   L_lm = sum_j w_j lambda_l^m(cos theta_j) G_m(theta_j),                          (1)
//   G_m(theta_j) = (2 pi / W) sum_i f(theta_j, phi_i) e^{-i m phi_i},                  (2)
// i.e. a DFT along each ring (FFTW, eq. 2) followed by a quadrature in theta (eq. 1), with the
// north/south symmetry lambda_l^m(-x) = (-1)^(l+m) lambda_l^m(x) halving the Legendre work.
// The complex coefficients of eq. (1) are turned into the real basis of core/sh/sh.h:
//   r_l0 = c_l0, r_lm = sqrt2 Re c_lm, r_{l,-m} = -sqrt2 Im c_lm (m > 0).
//
// Grid convention (docs/conventions.md). World frame right-handed, +Y up. A W x H image has pixel
// (i, j) (column i, row j from the top) at
//   u = (i + 0.5) / W,  p = 2 pi (u - 0.5),  theta = theta_j (ring polar angle from +Y),
//   world direction d = (sin theta sin p, cos theta, -sin theta cos p).
// The SH frame is x_s = +X, y_s = -Z, z_s = +Y, so the SH polar angle is theta and the SH azimuth
// is phi_s = pi/2 - p = 3 pi / 2 - 2 pi (i + 0.5) / W (it runs clockwise seen from +Y).
// Ring angles theta_j:
//  - ShtGridKind::kEquiangular: pixel centres theta_j = pi (j + 0.5) / H, the nodes of Fejer's
//    first rule (an ordinary equirectangular image);
//  - ShtGridKind::kGaussLegendre: theta_j = arccos(x_j), x_j the roots of P_H (north first).
//
// Exactness (band-limited data of degree <= F, W >= 2F + 1):
//  - Gauss-Legendre rings: plain quadrature (1) is exact for F <= H - 1.
//  - Equiangular rings with H >= 2F + 1: plain Fejer-1 quadrature (1) is exact (the integrand is
//    a polynomial of degree <= 2F in cos theta).
//  - Equiangular rings with F < H < 2F + 1: each G_m(theta) is first resampled exactly (it is a
//    cosine series for even m and a sine series for odd m, of degree <= F < H; DCT-II / DST-II
//    interpolation on the pixel-centre nodes, cf. ducc0's analysis_2d) onto 2F + 2 virtual
//    Fejer-1 rings, where (1) is exact. For data that is not band-limited this path integrates the
//    trigonometric interpolant of each G_m instead of the Fejer-1 interpolant of the integrand.
//
// Data layout:
//  - maps are row-major, channel-interleaved: value(i, j, c) = map[(j * W + i) * channels + c];
//  - coefficients are double, coeff[ShIndex(l, m) * channels + c], (lmax + 1)^2 * channels
//    values (real SH of core/sh/sh.h, Condon-Shortley phase, evaluated in the SH frame).
//
// Threads: a plan is immutable after creation and every method is const and thread-safe (FFTW
// new-array execute functions on per-call buffers). FFTW planning is serialized by
// FftwPlannerMutex(). Methods taking `num_threads` split rings and then m values across that many
// std::threads; the result does not depend on num_threads (bit-for-bit).
//
// Accuracy: all sums are accumulated in double; float maps are converted to double before the FFT.
// Legendre values are produced by the stable three-term recurrence in l started from sectoral
// values; sectoral values below 1e-280 are flushed to zero, which is harmless for lmax <= ~800.
#ifndef SHRM_CORE_TRANSFORM_SHT_H_
#define SHRM_CORE_TRANSFORM_SHT_H_

#include <cstddef>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace shrm {
namespace internal {
class RealFft;
}  // namespace internal

// How the H rings of a lat-long grid are placed in theta (the azimuth mapping is always the
// pixel-centre column formula in the header comment).
enum class ShtGridKind {
  kEquiangular,    // theta_j = pi (j + 0.5) / H (equirectangular image, Fejer's first rule)
  kGaussLegendre,  // cos(theta_j) = roots of the Legendre polynomial P_H
};

// How Forward() integrates in theta on an equiangular grid with H < 2 lmax + 1:
//  - kExact: the theta-resampling path of the header comment (exact for band-limited data of
//    degree <= H - 1);
//  - kPixelSum: the grid's own Fejer-1 rule at every degree, i.e. the projection of the pixel
//    samples, L_lm = sum_ij (2 pi / W) w_j f_ij Y_lm(d_ij): what a brute-force sum over the pixels
//    with their solid angles gives (LightingCoefficientsDirect of a lat-long map), so that a
//    zonal convolution of these coefficients is the pixel sum with the truncated kernel. About
//    2x less Legendre work and no resampling; exact for band-limited data only for
//    H >= 2 lmax + 1 (where both are the same). Gauss-Legendre grids ignore it.
enum class ShtQuadrature { kExact, kPixelSum };

// A W x H lat-long grid.
struct ShtGrid {
  int width = 0;   // W, pixels per ring (columns)
  int height = 0;  // H, rings (rows), north pole first
  ShtGridKind kind = ShtGridKind::kEquiangular;

  friend bool operator==(const ShtGrid&, const ShtGrid&) = default;
};

// World direction of pixel (i, j) of `grid` (see the header comment). Rings of a Gauss grid come
// from GaussLegendreRule(H); this recomputes them, so use it in tests and setup code only.
Vec3 ShtGridDirection(const ShtGrid& grid, int i, int j);

// SH azimuth of column i: phi_s = 3 pi / 2 - 2 pi (i + 0.5) / W.
double ShtColumnAzimuth(int width, int i);

// Largest degree whose analysis on `grid` is exact for band-limited data: min(H - 1, (W - 1) / 2).
int ShtMaxDegree(const ShtGrid& grid);

// The mutex that every FFTW planner call (plan creation and destruction) in shrm must hold; only
// the fftw_execute* functions are thread-safe.
std::mutex& FftwPlannerMutex();

// Work storage of ShtPlan::Inverse kept by a caller across calls (grown as needed, never shrunk):
// a caller that synthesizes again and again (a live session's frames, a chain's levels) reuses
// it instead of allocating, and first-touching, the theta stage's array (one block of ring
// pairs: 32 pairs x every m) on every call.
struct ShtScratch {
  std::vector<double> theta;
  std::vector<double> coeffs;  // the coefficients in the theta stage's order
};

// Precomputed state of the transforms on one grid at one degree for one channel count: FFTW
// plans (a batch of 2 * channels real rings, one north/south ring pair), quadrature weights,
// sectoral Legendre starts and recurrence coefficients, and, for equiangular grids with H < 2F + 1,
// the theta-resampling matrices. Memory: O((F + 1) * H + F^2) doubles (plus O(H^2) for the
// resampling matrices, which exist only when H <= 2F).
class ShtPlan {
 public:
  // Plan for analysis and synthesis. Errors (InvalidArgument): W or H < 1 ("empty grid"),
  // lmax < 0, channels < 1, lmax > H - 1 or W < 2 lmax + 1 (the grid cannot resolve the degree).
  static absl::StatusOr<std::shared_ptr<const ShtPlan>> Create(
      const ShtGrid& grid, int lmax, int channels,
      ShtQuadrature quadrature = ShtQuadrature::kExact);
  // Plan for synthesis only: any W, H >= 1 (frequencies above W / 2 alias as a real sampled
  // signal does). Forward() on such a plan fails with FailedPrecondition when the grid cannot
  // resolve lmax.
  static absl::StatusOr<std::shared_ptr<const ShtPlan>> CreateForSynthesis(const ShtGrid& grid,
                                                                           int lmax, int channels);
  ~ShtPlan();
  ShtPlan(const ShtPlan&) = delete;
  ShtPlan& operator=(const ShtPlan&) = delete;

  // The grid, degree and channel count the plan was made for.
  const ShtGrid& grid() const { return grid_; }
  int lmax() const { return lmax_; }
  int channels() const { return channels_; }
  // True when analysis is supported (lmax <= ShtMaxDegree(grid)).
  bool supports_forward() const { return supports_forward_; }
  // Sizes of the map (W * H * channels) and coefficient ((lmax + 1)^2 * channels) arrays.
  size_t map_size() const;
  size_t coeff_size() const;
  // True when the equiangular theta-resampling path (H < 2 lmax + 1) is used by Forward().
  bool resamples_theta() const { return !virtual_rings_.x.empty(); }

  // Analysis, eqs. (1)-(2): `coeffs` (coeff_size() values) receives L_lm of `map` (map_size()
  // values). Errors: InvalidArgument for size mismatches or num_threads < 1, FailedPrecondition
  // for a synthesis-only plan that cannot resolve lmax.
  absl::Status Forward(std::span<const float> map, std::span<double> coeffs,
                       int num_threads = 1) const;
  absl::Status Forward(std::span<const double> map, std::span<double> coeffs,
                       int num_threads = 1) const;

  // Synthesis: map(i, j, c) = sum_lm coeff[ShIndex(l, m) * channels + c] Y_lm(d_ij), the inverse
  // of Forward() for band-limited data. Errors: InvalidArgument for size mismatches or
  // num_threads < 1.
  // `scratch` (optional): the work array kept by the caller across calls (ShtScratch).
  absl::Status Inverse(std::span<const double> coeffs, std::span<float> map, int num_threads = 1,
                       ShtScratch* scratch = nullptr) const;
  absl::Status Inverse(std::span<const double> coeffs, std::span<double> map, int num_threads = 1,
                       ShtScratch* scratch = nullptr) const;

  // Implementation types (public so that sht.cc's helpers can name them). A RingSet holds the
  // north/south ring pairs of a symmetric quadrature; arrays are padded with zeros to a multiple
  // of 4 pairs (the SIMD width of the Legendre kernels), so sectoral rows have that padded length.
  struct RingSet {
    int num_pairs = 0;             // ring pairs (north ring p, south ring H - 1 - p)
    bool has_equator = false;      // H odd: the last pair is the equator ring alone
    std::vector<double> x;         // cos(theta) of the north ring of each pair
    std::vector<double> sectoral;  // lambda_m^m(x_p) at [m * num_pairs + p]
  };
  // Owns the FFTW plans; destroyed under FftwPlannerMutex().
  struct FftwState;

 private:
  // Use Create() / CreateForSynthesis().
  ShtPlan() = default;
  // Shared validation and precomputation; `synthesis` skips the sampling-limit check.
  static absl::StatusOr<std::shared_ptr<const ShtPlan>> CreateImpl(const ShtGrid& grid, int lmax,
                                                                   int channels, bool synthesis,
                                                                   ShtQuadrature quadrature);
  // Analysis / synthesis for float and double maps: a phi stage (one r2c / c2r FFT batch per ring
  // pair) and a theta stage (Legendre recurrences), with the per-m buffer
  // E/O[m][parity][channel][re, im][pair] between them. The analysis runs each stage whole
  // (parallel over pairs, then over m); the synthesis runs both per block of 32 ring pairs
  // (parallel over blocks), so that its buffer holds one block.
  template <typename T>
  absl::Status ForwardImpl(std::span<const T> map, std::span<double> coeffs, int num_threads) const;
  template <typename T>
  absl::Status InverseImpl(std::span<const double> coeffs, std::span<T> map, int num_threads,
                           ShtScratch* scratch) const;
  // Theta stage of the analysis: eq. (1) for every m on ring pairs `rings` from the E/O buffer
  // (E_p = G_m(north) + G_m(south) for even l - m, O_p = the difference for odd l - m).
  void LegendreAnalysis(const RingSet& rings, std::span<const double> eo, std::span<double> coeffs,
                        int num_threads) const;

  ShtGrid grid_;
  int lmax_ = 0;
  int channels_ = 0;
  bool supports_forward_ = false;
  RingSet rings_;                      // the grid's own rings
  RingSet virtual_rings_;              // 2 lmax + 2 Fejer-1 rings of the resampling path
  std::vector<double> ring_scale_;     // per pair: (2 pi / W) w_p (w_p = 1 when resampling)
  std::vector<double> virtual_scale_;  // per virtual pair: Fejer-1 weight
  // Resampling matrices [kind][virtual pair q][pair p], kind = 2 * (m odd) + (output is O).
  std::vector<double> resample_[4];
  std::vector<double> rec_a_, rec_b_;  // lambda_l^m = a (x lambda_{l-1}^m - b lambda_{l-2}^m)
  std::unique_ptr<FftwState> fftw_;
  // The ring DFTs without FFTW's planner where the width allows (core/transform/real_fft.h;
  // null: FFTW's plans).
  std::shared_ptr<const internal::RealFft> real_fft_;
};

// Process-wide cache of analysis plans keyed by (W, H, kind, lmax, channels, quadrature); plans
// are created on first use (with ShtPlan::Create, same errors) and kept for the life of the
// process.
absl::StatusOr<std::shared_ptr<const ShtPlan>> GetShtPlan(
    const ShtGrid& grid, int lmax, int channels, ShtQuadrature quadrature = ShtQuadrature::kExact);

// Convenience wrappers around GetShtPlan(): analysis of a W x H map (grid.width, grid.height)
// returning (lmax + 1)^2 * channels coefficients, and synthesis onto `grid` returning
// W * H * channels doubles.
absl::StatusOr<std::vector<double>> ForwardSht(const ShtGrid& grid, int lmax, int channels,
                                               std::span<const float> map, int num_threads = 1,
                                               ShtQuadrature quadrature = ShtQuadrature::kExact);
absl::StatusOr<std::vector<double>> ForwardSht(const ShtGrid& grid, int lmax, int channels,
                                               std::span<const double> map, int num_threads = 1,
                                               ShtQuadrature quadrature = ShtQuadrature::kExact);
absl::StatusOr<std::vector<double>> InverseSht(const ShtGrid& grid, int lmax, int channels,
                                               std::span<const double> coeffs, int num_threads = 1);

// Synthesis at arbitrary WORLD directions (converted with ShFrameFromWorld; they need not be
// normalized but must be nonzero): out[k * channels + c] = sum_lm coeffs[ShIndex(l, m) * channels
// + c] Y_lm(dirs[k]). `coeffs` has (lmax + 1)^2 * channels values, `out` dirs.size() * channels.
// Errors: InvalidArgument for lmax < 0, channels < 1, num_threads < 1 or size mismatches.
absl::Status SynthesizeAtDirections(int lmax, int channels, std::span<const double> coeffs,
                                    std::span<const Vec3> world_dirs, std::span<double> out,
                                    int num_threads = 1);

}  // namespace shrm

#endif  // SHRM_CORE_TRANSFORM_SHT_H_
