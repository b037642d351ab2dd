// SHRM synthesis (Ramamoorthi & Hanrahan, "Frequency Space Environment Map Rendering"):
//   eq. 5.7 / step 2 of sec. 5.6.2: B_lmpq = L_lm rho_lpq (no Lambda_l with the conventions of
//            docs/conventions.md and docs/shrm.md; fused into the synthesis);
//   eqs. 5.23-5.24: the local SHRM, separable: a Wigner-d sum over l on an equiangular alpha grid,
//            then an FFT over m for beta,
//              B_mpq(alpha) = sum_l L_lm rho_lpq d^l_mq(alpha),
//              B_pq(alpha, beta) = sum_m e^{i m beta} B_mpq(alpha);
//   eq. 5.14: the global SHRM, B^_ps = sum_q B_pq D^p_sq(Rot), Rot = Rz(beta) Ry(alpha); on the
//            grid it is the same FFT with shifted frequencies:
//              B^_ps(alpha, beta) = sum_m e^{i (m - s) beta} sum_q d^p_sq(alpha) B_mpq(alpha);
//   eqs. 5.10-5.11: evaluation, B(R, V) = sum B_pq Y_pq(Rot^T V) (local) = sum B^_pq Y_pq(V)
//            (global), V in the SH frame: here exactly at one (alpha, beta) (RadianceAt); on a
//            cube by core/shrm/shrm_eval.h (ShrmEvalAt, included below).
// (alpha, beta) are the SH angles (docs/conventions.md) of the texel direction R (the reflection
// vector; the tangent T for ReparamKind::kTangent, where only q = 0 terms exist).
// Outputs are real SH per texel (ComplexToReal of the complex per-texel expansion), float
// storage, double accumulation. Design notes (grid size, interpolation, poles): docs/shrm.md.
// The Wigner columns d^l_mq(alpha), |q| <= P, of eqs. 5.24 and 5.14 are core/sh/wigner_columns.h;
// the cubic resampling of the grid onto the cube is core/shrm/cube_resample.h (internal).
#ifndef SHRM_CORE_SHRM_SHRM_SYNTHESIS_H_
#define SHRM_CORE_SHRM_SHRM_SYNTHESIS_H_

#include <algorithm>
#include <array>
#include <complex>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf_coefficients.h"
#include "core/sh/wigner_columns.h"
#include "core/shrm/shrm_eval.h"  // ShrmAnglesFromWorld, ShrmLocalFrame, ShrmEvalAt, ...
#include "core/shrm/shrm_map.h"
#include "core/transform/sht.h"

namespace shrm {

// The smallest grid size >= na that is a multiple of 8 and whose FFT length 2 na has no prime
// factor above 7 (e.g. 232 -> 240: an FFT of 2 x 232 = 16 x 29 costs ~1.7x that of 480).
int FftFriendlyRings(int na);

// The fewest FFT-friendly grid rows na in [min_rows, max_rows) (at least 32) whose cubic
// interpolation error stays within `tolerance` of the field's RMS, for a field whose band l
// carries energy band[l] at frequency l + shift in each angle: the error model of docs/shrm.md
// ("Grid, interpolation, poles"). FftFriendlyRings(max_rows) when none does.
int CubicGridRows(std::span<const double> band, int shift, double tolerance, int min_rows,
                  int max_rows);

// Storage kept by a caller across BuildCube calls (grown as needed, never shrunk): the padded
// grid and the P = 0 inverse transform's work array, reused instead of allocated (and
// first-touched: ~17 us a page on this machine) per call. A split-sum chain shares one across its
// levels, a live session across its frames (core/ibl/split_sum.h, core/live/live_session.h).
struct SynthesisScratch {
  std::vector<float> grid;
  ShtScratch sht;
  // The zonal path's per-texel q = 0 coefficients (BuildCube, tangent reparameterization).
  std::vector<float> zonal;
  // The zonal path's per-texel sqrt(4 pi / (2p + 1)) Y_ps(T) for the cube of zonal_w_face_size
  // and zonal_w_pmax (they depend on nothing else): made by the first cube, reused by the next.
  std::vector<float> zonal_w;
  int zonal_w_face_size = 0, zonal_w_pmax = -1;
  // The P > 0 grid path's per-worker row buffers (Wigner columns, the l-sums per m: 5.4 MB a
  // worker at (70, 9)), kept across calls instead of allocated and zero-filled per cube; every
  // value a call reads it writes first.
  struct RowBuffers {
    std::vector<double> cols, dp, bre, bim, sre, sim, w;
  };
  std::vector<RowBuffers> rows;
  // A released cube's storage (e.g. a live frame no longer held): BuildCube takes it for its
  // output when its capacity suffices (every value is written again), instead of zero-filling
  // a fresh buffer. Left empty once taken.
  std::vector<float> cube;
};

// How far a slab of the synthesis grid may exceed ShrmGridOptions::max_grid_bytes so that every
// thread has a Wigner block of it (jobs/memory_estimate.h counts the slab at this bound).
inline constexpr size_t kSlabGrowthForThreads = 2;

struct ShrmGridOptions {
  // Equiangular grid rows in alpha over [0, pi] (pixel centres alpha_j = pi (j + 1/2) / N);
  // 0 = automatic: max(32, 4 (F + P + 1)) rounded up to a multiple of 8, then to the next
  // multiple of 8 with no prime factor above 7 (FFT-friendly 2 N). The beta grid
  // has 2 N columns (N >= F + P + 1 is required so the FFT over m does not alias).
  int alpha_samples = 0;
  int threads = 1;
  // P = 0 only: synthesize B_00 on the grid with the inverse SHT (core/transform/sht.h) of the
  // coefficients sqrt(4 pi / (2l + 1)) rho_l L_lm instead of the Wigner / FFT rows (same grid,
  // same interpolation; faster for every F). false = the general path (tests compare the two).
  // The same switch (with path kAuto) takes a q = 0-only global cube (Kajiya-Kay) through the
  // zonal path (BuildZonalGlobalCube), whose B_p0 are such syntheses.
  bool p0_sht_path = true;
  // P > 0: how the texels' coefficients are made. kGrid: the grid and the cubic resampling above.
  // kDirect: each texel centre exactly (eq. 5.23, then the rotation of eq. 5.14 for the global
  // kind; the l-sums of kWignerBlock texels per Wigner pass, as BandContributionsAtArguments),
  // whose cost grows with the texels instead of the grid (F + P)^2: cheaper for a small S_B and
  // a large P. kAuto: the cheaper by the cost model of DirectCubeIsCheaper.
  enum class CubePath { kAuto, kGrid, kDirect };
  CubePath path = CubePath::kAuto;
  // P > 0: when the whole padded grid ((na + 4) x 2 na nodes x (P + 1)^2 x channels floats) would
  // exceed this many bytes, BuildCube synthesizes it in slabs of rows within this size, each
  // resampled before the next is made (identical values; the grid depends on F + P, not on
  // S_B, e.g. 0.8 GB at (42, 21) even for a 16 x 16 cube). 0 = always whole.
  // A slab may grow to kSlabGrowthForThreads times this so that each of `threads` threads gets a
  // Wigner block of it (the grid's rows are made kWignerBlock at a time).
  size_t max_grid_bytes = size_t{64} << 20;
  // The caller's storage (SynthesisScratch) for the grid (either path); nullptr = allocated per
  // call.
  SynthesisScratch* scratch = nullptr;
};

// The SHRM of one lighting and one BRDF: L_lm (complex, converted from the real input) and
// rho_lpq, i.e. B_lmpq = L_lm rho_lpq, truncated to l <= F (lmax) and p <= P (pmax).
class ShrmSynthesizer {
 public:
  // light: real SH L_lm, light[ShIndex(l, m) * channels + c], degree light_lmax, in the SH frame
  // (e.g. ForwardSht or LightingCoefficients). brdf.channels must be 1 or `channels`.
  // lmax = F_B (-1: min(light_lmax, brdf.lmax)), pmax = P_B (-1: brdf.pmax); they are clamped to
  // neither: lmax > min(light_lmax, brdf.lmax) or pmax > brdf.pmax is an error.
  // Errors (InvalidArgument): negative orders, channels < 1, size mismatches, mismatched channels.
  static absl::StatusOr<ShrmSynthesizer> Create(int light_lmax, int channels,
                                                std::span<const double> light,
                                                const BrdfCoefficients& brdf, int lmax = -1,
                                                int pmax = -1);

  int lmax() const { return lmax_; }
  int pmax() const { return pmax_; }
  int channels() const { return channels_; }
  ReparamKind reparam() const { return reparam_; }
  ViewVariable view() const { return view_; }
  // The Fresnel factor of kNormal values at N.R = cos_n (1 without a table; brdf_coefficients.h).
  double Fresnel(double cos_n, int c) const;
  // The largest order |q| whose rho_lpq can be nonzero: min(P, F), or 0 for the tangent
  // reparameterization (whose coefficients Create keeps for q = 0 only).
  int RhoQmax() const { return reparam_ == ReparamKind::kTangent ? 0 : std::min(pmax_, lmax_); }

  // Eq. 5.7 (no Lambda): B_lmpq = L_lm rho_lpq (complex), any signs of m and q.
  std::complex<double> Blmpq(int l, int m, int p, int q, int c) const;
  // Energy of the order-(F, P) truncation in the L2 norm over (R, view) (docs/shrm.md):
  // sum_{l<=F, p<=P} (4 pi / (2l + 1)) |B_lmpq|^2 per channel, for F <= lmax(), P <= pmax().
  std::vector<double> TruncatedEnergy(int f, int p) const;
  // The fewest grid rows (ShrmGridOptions::alpha_samples: FFT-friendly, >= F + P + 1, at most
  // BuildCube's automatic max(32, 4 (F + P + 1))) whose cubic interpolation error, estimated per
  // band from the coefficients' energy, is within `tolerance` (relative RMS over the sphere of
  // index directions, every coefficient of every channel) of the SHRM's RMS. The automatic rule
  // bounds the top band's error whatever its energy; a spectrum that falls by orders of magnitude
  // before F (the BRDF's rho_lpq and the lighting's) needs fewer rows. tolerance <= 0: the
  // automatic rule's count.
  int InterpolationRows(ShrmKind kind, double tolerance) const;

  // Direct (exact) evaluation at one (alpha, beta), eq. 5.23 with the library's Wigner tables:
  // complex B_pq (local) at out[ShIndex(p, q) * channels + c].
  void LocalComplexAt(double alpha, double beta, std::span<std::complex<double>> out) const;
  // Real SH coefficients (ShCount(pmax) * channels) of the local or global SHRM at (alpha, beta);
  // global = RotateSh(Rot) of the local ones.
  void CoefficientsAt(ShrmKind kind, double alpha, double beta, std::span<double> out) const;
  // B(R, V) with R (or T) and V world directions, by CoefficientsAt (no resampling).
  std::array<double, 3> RadianceAt(ShrmKind kind, const Vec3& index_dir, const Vec3& view) const;
  // The same with the argument of Y_pq given (V or N, world, unit; ShrmViewArgument).
  std::array<double, 3> RadianceAtArgument(ShrmKind kind, const Vec3& index_dir,
                                           const Vec3& argument) const;
  // The terms of B(R, V) by band: out[(l * (pmax() + 1) + p) * channels() + c] is the part of
  // the value at (index_dir, view) that comes from lighting band l and view band p, so that the
  // sum over l <= F, p <= P is the order-(F, P) value (the sum over all bands = RadianceAt, of
  // either kind: the kinds differ in the texel's frame, not in B). Cost O(F^2 P + F P^2), by the
  // Wigner columns |q| <= P. out.size() >= (lmax() + 1) (pmax() + 1) channels(). Drives the
  // per-direction accuracy estimate of core/shrm/tolerance.h.
  void BandContributionsAt(const Vec3& index_dir, const Vec3& view, std::span<double> out) const;
  // The same with the argument of Y_pq given (V or N, world, unit; ShrmViewArgument).
  void BandContributionsAtArgument(const Vec3& index_dir, const Vec3& argument,
                                   std::span<double> out) const;
  // The same at n = index_dirs.size() points (arguments.size() == n): point k's terms at
  // out[k * BandCount() ...]; out.size() >= n BandCount(). kWignerBlock points share one pass of
  // the Wigner recurrence, each degree consumed as it is made (no column storage): the values of
  // BandContributionsAtArgument up to rounding, many times faster for a set of points.
  void BandContributionsAtArguments(std::span<const Vec3> index_dirs,
                                    std::span<const Vec3> arguments, std::span<double> out) const;
  // (lmax() + 1) (pmax() + 1) channels(): the terms of one point.
  size_t BandCount() const { return static_cast<size_t>(lmax_ + 1) * (pmax_ + 1) * channels_; }

  // Fast path (sec. 5.6.2 step 3): the SHRM on the equiangular (alpha, beta) grid, then resampled
  // onto the texel centres of a cube map of face_size S_B by 4 x 4 Lagrange (cubic) interpolation
  // in (alpha, beta). For P = 0 the grid is by default one inverse SHT of the real coefficients
  // sqrt(4 pi / (2l + 1)) rho_l00 L_lm (ShrmGridOptions::p0_sht_path). The output buffer of large
  // cubes is hinted for transparent huge pages (first-touch page faults). Errors: face_size < 1,
  // bad grid options.
  absl::StatusOr<ShrmCube> BuildCube(ShrmKind kind, int face_size,
                                     const ShrmGridOptions& options = {}) const;

  // The grid itself: real coefficients grid[((j + 2) * nb + k) * stride + ShIndex(p,q) * ch + c],
  // stride = ShCount(pmax) * channels, rows j = -2 .. na + 1 (two padding rows beyond each pole,
  // the trigonometric-polynomial continuation to alpha < 0 and alpha > pi), alpha_j = pi (j + 1/2)
  // / na, beta_k = 2 pi k / nb.
  struct Grid {
    int na = 0, nb = 0;
    int stride = 0;
    std::vector<float> values;
  };
  absl::StatusOr<Grid> BuildGrid(ShrmKind kind, int na, int threads = 1) const;

  // The P = 0 path of BuildCube from real SH coefficients given directly: a cube of `channels`
  // values per texel, sum_lm real[ShIndex(l, m) * channels + c] Y_lm at each texel centre (l <=
  // f), by the same grid (options.alpha_samples rows, 0: BuildCube's rule for P = 0), inverse SHT
  // and cubic resampling. For a zonal convolution (a split-sum level: g_l L_lm) without a
  // synthesizer, whose complex lighting (2F + 1) (F + 1) values per channel, 5.6 MB at F = 241,
  // it does not need. Equal to BuildCube of a synthesizer with rho_l00 = k_l sqrt((2l + 1) / (4
  // pi)) and real = k_l L_lm up to the rounding of BuildCube's complex round trip. Errors: f < 0,
  // channels < 1, a size mismatch, BuildCube's.
  static absl::StatusOr<ShrmCube> RealZonalCube(int f, int channels, std::span<const double> real,
                                                int face_size, const ShrmGridOptions& options);

 private:
  ShrmSynthesizer() = default;
  // Band l's term of TruncatedEnergy(., p) for channel c.
  double BandEnergy(int l, int p, int c) const;
  // InvalidArgument when na alpha rows cannot resolve the grid's degree (F, + P when global).
  absl::Status CheckGridRows(ShrmKind kind, int na) const;
  // The padded grid (row r is alpha_{r - 2}, rows 0 .. na + 3) in slabs: slab s holds rows
  // [first, first + count) with first = s x owned and count = min(owned + 3, na + 4 - first),
  // written to `out` (count x 2 na x grid_stride floats, reused for every slab; a node's
  // ShCount(P) x channels values first, zeros after them), then emit(first, count) is called.
  // A slab's first 3 rows are the previous slab's last 3, moved to the top of `out` rather than
  // made again. owned >= na + 1 makes one slab of the whole grid.
  void SynthesizeSlabs(ShrmKind kind, int na, int owned, int threads, int grid_stride, float* out,
                       const std::function<void(int first, int count)>& emit,
                       SynthesisScratch* keep = nullptr) const;
  // The P = 0 path of BuildCube (ShrmGridOptions::p0_sht_path).
  // A cube of this synthesizer's kind of coefficients, its storage from AllocateCubeData (the
  // scratch's released buffer when large enough).
  ShrmCube NewCube(ShrmKind kind, int face_size, SynthesisScratch* scratch) const;
  // The kDirect path of BuildCube (ShrmGridOptions::path).
  absl::StatusOr<ShrmCube> BuildCubeDirect(ShrmKind kind, int face_size, int threads,
                                           SynthesisScratch* scratch) const;
  // Whether kDirect is estimated cheaper than the grid of na rows for this face size.
  bool DirectCubeIsCheaper(ShrmKind kind, int face_size, int na) const;
  absl::StatusOr<ShrmCube> BuildCubeP0(ShrmKind kind, int face_size, int na, int threads,
                                       SynthesisScratch* scratch) const;
  // The inverse SHT of the zonal filters rho_{l,p,0} (p < zonal) times the lighting, onto the
  // padded equiangular grid of BuildCubeP0 (zonal x channels values per node, channel p * ch + c):
  // B_p0(alpha, beta) = sum_lm sqrt(4 pi / (2l + 1)) rho_lp0 L_lm Y_lm(alpha, beta).
  absl::Status ZonalGrid(int zonal, int na, int threads, SynthesisScratch& work) const;
  // The padded grid of real coefficients `real` (degree f, `values` per coefficient), into
  // work.grid: ZonalGrid's transform and padding rows.
  static absl::Status RealGrid(int f, int values, std::span<const double> real, int na, int threads,
                               SynthesisScratch& work);
  // na equiangular rows resolve degree F (the zonal grids).
  absl::Status CheckZonalRows(int na) const;
  // The global cube of a q = 0-only BRDF (the tangent reparameterization, RhoQmax() = 0): its
  // local coefficients B_p0 are zonal (ZonalGrid, resampled to the texels), and the global ones
  // follow per texel by the addition theorem, c_ps(T) = B_p0(T) sqrt(4 pi / (2p + 1)) Y_ps(T).
  absl::StatusOr<ShrmCube> BuildZonalGlobalCube(int face_size, int na, int threads,
                                                SynthesisScratch* scratch) const;
  // Per-thread buffers of SynthesizeRows.
  struct RowScratch {
    SynthesisScratch::RowBuffers* buf = nullptr;  // the worker's (the caller's scratch's or local)
    std::complex<double>* work = nullptr;         // FFT input, nseries * nb (FFTW-allocated)
    std::complex<double>* out = nullptr;          // FFT output, same size
  };
  static constexpr int kWignerBlock = WignerColumnTables::kWignerBlock;
  // Coefficients of `rows` <= kWignerBlock consecutive grid rows (alphas[r]) for all nb columns
  // into rows_out (rows * nb * grid_stride floats).
  void SynthesizeRows(ShrmKind kind, const double* alphas, int rows, int nb, int grid_stride,
                      void* fft_plan, const WignerColumnTables& tables,
                      const WignerColumnTables& ptables, RowScratch& scratch,
                      float* rows_out) const;

  int lmax_ = 0, pmax_ = 0, channels_ = 3;
  // The Wigner column recurrences of BandContributionsAt (|q| <= min(P, F)), built on its first
  // call and shared by copies (immutable once built).
  struct BandTables {
    std::once_flag once;
    std::unique_ptr<WignerColumnTables> tables;
  };
  std::shared_ptr<BandTables> band_tables_ = std::make_shared<BandTables>();
  const WignerColumnTables& BandWignerTables() const;
  using Lanes = WignerColumnTables::Lanes;
  // S[(q * (F + 1) + l) * channels + c][r] = sum_m e^{i m beta_r} L_lm d^l_mq(alpha_r), q = 0 ..
  // RhoQmax() (real parts in sre, imaginary in sim), for n <= kWignerBlock angles (lanes r >= n
  // repeat angle n - 1).
  void LSumsBlock(const double* alpha, const double* beta, int n, std::vector<Lanes>& sre,
                  std::vector<Lanes>& sim) const;
  // BandContributionsAtArguments for n <= kWignerBlock points.
  // bands (BandCount() values of one point) times the Fresnel factor at N.V (FresnelCosine).
  void ScaleByFresnel(const Vec3& index_dir, const Vec3& argument, double* bands) const;
  void BandContributionsBlock(const Vec3* index_dirs, const Vec3* arguments, int n,
                              double* out) const;
  ReparamKind reparam_ = ReparamKind::kReflection;
  ViewVariable view_ = ViewVariable::kView;
  std::vector<float> fresnel_;  // the coefficients' Fresnel table (ShrmCube::fresnel)
  // Complex lighting: light_[((m + F) * (F + 1) + l) * channels + c] (zero for l < |m|).
  std::vector<std::complex<double>> light_;
  // rho_lpq per channel (grey BRDFs expanded): rho_[((p * (P + 1) + q) * (F + 1) + l) * ch + c],
  // q >= 0 (rho_{l,p,-q} = rho_lpq); zero for q > min(l, p) and for q != 0 with kTangent.
  std::vector<double> rho_;
  // rho_ with every value twice, rho_pairs_[2 i] = rho_pairs_[2 i + 1] = rho_[i]: the factor of
  // each (Re, Im) pair of the complex lighting's layout, so the grid's l-sums form their
  // products L_lm rho_lpq as one flat vector product.
  std::vector<double> rho_pairs_;
  double Rho(int l, int p, int q, int c) const {
    return rho_[((static_cast<size_t>(p) * (pmax_ + 1) + (q < 0 ? -q : q)) * (lmax_ + 1) + l) *
                    channels_ +
                c];
  }
};

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_SYNTHESIS_H_
