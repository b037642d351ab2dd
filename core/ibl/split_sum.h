// The split-sum prefiltered radiance of image-based lighting (Karis 2013, "Real Shading in Unreal
// Engine 4", sec. "Image Based Lighting"; Filament's cmgen and Khronos' glTF-IBL-Sampler compute
// the same integral by importance sampling), computed exactly in frequency space.
//
// With the split-sum assumption N = V = R, the prefiltered radiance of a lobe with normal
// distribution D and roughness alpha is the normalized, N.L-weighted integral
//   L_pref(R) = integral L(l) D(R.h) (R.l)+ dl / integral D(R.h) (R.l)+ dl,   h = (R + l) / |R +
//   l|,
// which is what both tools' estimators sum(L(l_i) N.l_i) / sum(N.l_i) converge to: they draw
// h with density D(N.h) (N.h) and l = reflect(-V, h), whose density in l is D / 4 when V = N
// (glTF-IBL-Sampler filter.frag, Filament CubemapIBL::roughnessFilter). The angle between h and R
// is half the angle theta between l and R, so the kernel depends on theta alone (zonal about R):
//   K(cos theta) = D(cos(theta / 2)) cos theta  for cos theta > 0, else 0.
// A zonal kernel convolves in SH space by a factor per degree (Funk-Hecke; Ramamoorthi &
// Hanrahan, "An Efficient Representation for Irradiance Environment Maps", eq. 7):
//   L_pref(R) = sum_lm g_l L_lm Y_lm(R),  g_l = integral K P_l(cos theta) dw / integral K dw,
// g_0 = 1. g_l is computed here by Gauss-Legendre quadrature in theta on panels graded towards
// the peak of the lobe (no sampling), and each mip level is synthesized from g_l L_lm by the P = 0
// SHRM path (core/shrm/shrm_synthesis.h: inverse SHT onto an equiangular grid, cubic resampling
// onto the cube's texel centres).
//
// Lobes (alpha = perceptual roughness^2 in both, as the consumers define them):
//  - GGX (Trowbridge-Reitz): D(c) = alpha^2 / (pi ((alpha^2 - 1) c^2 + 1)^2);
//  - Charlie sheen (Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF"):
//    D(c) = (2 + 1 / alpha) (1 - c^2)^(1 / (2 alpha)) / (2 pi) (glTF-IBL-Sampler passes
//    alpha = roughness^2 to it as well);
//  - Lambert: K = cos theta (the irradiance E / pi; g_l = A_l / pi with Ramamoorthi & Hanrahan's
//    A_l, "An Efficient Representation for Irradiance Environment Maps", eq. 8).
//
// Roughness per mip level (perceptual roughness r, t = level / (levels - 1)):
//  - kFilament: cmgen and Filament's iblprefilter, r = 1 - sqrt(1 - t) (the inverse of the
//    shader's lod = (levels - 1) r (2 - r)); default levels down to a 16 x 16 face
//    (cmgen's IBL_DEFAULT_MIN_LOD_SIZE), i.e. log2(S) - 3;
//  - kGltf: glTF-IBL-Sampler and the Khronos sample viewer, r = t (lod = r (mipCount - 1));
//    default levels floor(log2(S)) (the sampler's default mip count);
//  - kExplicit: the caller's list, one r per level;
//  - kBabylon: Babylon.js's EXT_lights_image_based loader (lodGenerationScale = (levels - 1) /
//    log2(S)) and PBR shader (lod = log2(S alpha) x lodGenerationScale, pbrIBLFunctions
//    getLodFromAlphaG): level k >= 1 holds alpha = S^(k / (levels - 1) - 1), r = sqrt(alpha)
//    (with the full chain alpha = 2^k / S); default levels log2(S) + 1 (down to 1 x 1, as
//    Babylon's own prefiltering).
// The base level (r = 0) is the map itself, resampled bilinearly at the texel centres (what both
// tools do); a level with r > 0 but a lobe narrower than its texels is still convolved.
//
// Degree per level: the map's coefficients L_lm are computed once, up to the largest degree the
// map resolves (ShtMaxDegree of its lat-long grid, e.g. 511 for 1024 x 512) or, for a split-sum
// set, up to the degree D its lobes need (SplitSumLightDegree: the energy above D bounded by
// Parseval's identity from the pixels); level k uses the smallest F_k <= D whose dropped energy,
// sum_{F < l <= D} g_l^2 E_l (E_l = sum_m |L_lm|^2, luminance) plus the bound of what lies above
// D, is at most tolerance^2 of the level's total sum_l g_l^2 E_l, i.e. an RMS over the sphere of
// at most `tolerance` relative to the level's RMS radiance (reported per level as
// truncation_estimate). The per-direction error is measured against SplitSumReference() in
// tests/split_sum_test.cc and docs/ibl.md.
#ifndef SHRM_CORE_IBL_SPLIT_SUM_H_
#define SHRM_CORE_IBL_SPLIT_SUM_H_

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/envmap/envmap.h"
#include "core/ibl/light_peaks.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/radiance_cube.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm::ibl {

// kLambert is the clamped cosine (K = (R.l)+, no D): the diffuse irradiance divided by pi, i.e.
// the cosine-weighted mean radiance (glTF-IBL-Sampler's "lambertian" output); its alpha is
// ignored (give any alpha > 0, e.g. a chain of roughness 1).
enum class SpecularLobe { kGgx, kCharlie, kLambert };

// "ggx", "charlie", "lambert".
const char* SpecularLobeName(SpecularLobe lobe);
absl::StatusOr<SpecularLobe> ParseSpecularLobe(std::string_view name);

enum class RoughnessPreset { kFilament, kGltf, kExplicit, kBabylon };

// "filament", "gltf", "explicit", "babylon" ("explicit" only names a caller-given list).
const char* RoughnessPresetName(RoughnessPreset preset);
absl::StatusOr<RoughnessPreset> ParseRoughnessPreset(std::string_view name);

// The largest base face size and the smallest face a level may have.
inline constexpr int kMaxIblFaceSize = 4096;

// Face size and perceptual roughness of every level of a mip chain (level 0 first).
struct MipChain {
  RoughnessPreset preset = RoughnessPreset::kFilament;
  std::vector<int> face_size;     // S >> level
  std::vector<double> roughness;  // perceptual roughness r (alpha = r^2)
  int levels() const { return static_cast<int>(face_size.size()); }
};

// The chain of `preset` for base face size S (a power of two, 1 <= S <= kMaxIblFaceSize) and
// `levels` levels (0: the preset's default; at most log2(S) + 1). kExplicit takes `roughness`
// (levels = its size, or must equal it; each in [0, 1], non-decreasing). Errors
// (InvalidArgument) name the value and the rule.
absl::StatusOr<MipChain> MakeMipChain(RoughnessPreset preset, int face_size, int levels,
                                      std::span<const double> roughness = {});

// The lobe's normal distribution D(cos theta_h) for alpha > 0 (kLambert: 1 / pi).
double LobeNdf(SpecularLobe lobe, double alpha, double cos_h);

// The split-sum kernel (unnormalized): D(cos(theta / 2)) cos theta for cos theta > 0, else 0.
double SplitSumKernel(SpecularLobe lobe, double alpha, double cos_theta);

// g_l, l = 0..lmax, normalized so that g_0 = 1 (see the header comment); alpha > 0.
std::vector<double> SplitSumZonal(SpecularLobe lobe, double alpha, int lmax);

// integral K dw over the sphere (the normalization of g_l), by SplitSumZonal's quadrature.
double SplitSumKernelIntegral(SpecularLobe lobe, double alpha);
// The lobe's kernel for the peaks' direct sums (light_peaks.h), normalized by
// SplitSumKernelIntegral as g_0 = 1 normalizes the SH path.
PeakKernel SplitSumPeakKernel(SpecularLobe lobe, double alpha);

// The slow twin: the prefiltered radiance at unit world direction r by a sum over the map's
// native samples, sum L_k K(r.d_k) Omega_k / sum K(r.d_k) Omega_k. For alpha = 0, the map's
// bilinear radiance at r.
std::array<double, 3> SplitSumReference(const EnvMap& map, SpecularLobe lobe, double alpha,
                                        const Vec3& r);

// SplitSumReference for many directions at once, for the jobs' own checks: the map's samples
// in blocks of single-precision structure-of-arrays (direction, solid angle, radiance), the
// kernel written in e = |r - d|^2 = 2 (1 - r.d), which keeps its peak exact in single precision
// (GGX: K ~ (1 - e / 2)+ / (alpha^2 + (1 - alpha^2) e / 4)^2, no cancellation near r = d), each
// block's sums in single precision and the totals in double; blocks wholly behind the kernel's
// hemisphere are skipped by a bounding cone (their K is 0 exactly). Agrees with
// SplitSumReference to ~1e-6 relative (tests/split_sum_test.cc); a 16-direction check of a
// 1024 x 512 map costs a few ms where SplitSumReference took tens.
// A lat-long map's blocks are runs of up to kBlock pixels of one row, made when they are summed
// from the map's own pixels (kept by reference: the map must outlive the table) and per-row and
// per-column tables of the directions (EnvMap::ForEachSample's formula): no copy of the map, whose
// 28 bytes per pixel (14 MB at 1024 x 512) cost the job more in first-touch page faults than
// remaking the blocks does. Other layouts' samples are copied into the blocks.
class PixelSumTable {
 public:
  explicit PixelSumTable(const EnvMap& map);
  // The prefiltered radiance at each unit world direction (alpha > 0).
  std::vector<std::array<double, 3>> Prefiltered(SpecularLobe lobe, double alpha,
                                                 std::span<const Vec3> dirs, int threads = 1) const;
  // Prefiltered for several lobes and direction sets in one pass over the map (each block of
  // pixels made once for all of them): out[q][i] for queries[q].dirs[i].
  struct Query {
    SpecularLobe lobe;
    double alpha;
    std::span<const Vec3> dirs;
  };
  std::vector<std::vector<std::array<double, 3>>> PrefilteredMany(std::span<const Query> queries,
                                                                  int threads = 1) const;

 private:
  static constexpr int kBlock = 256;
  struct Cone {
    Vec3 axis;          // unit
    double sin_radius;  // sine of the largest angle between the axis and a member
  };
  // One block's members: kBlock entries each (padded with zero solid angles).
  struct BlockData {
    alignas(64) float x[kBlock], y[kBlock], z[kBlock], omega[kBlock], r[kBlock], g[kBlock],
        b[kBlock];
  };
  // Block `blk` of a lat-long map, written into `out`.
  void MakeLatLongBlock(int blk, BlockData& out) const;
  int blocks_ = 0;
  std::vector<Cone> cones_;
  // Lat-long maps.
  std::optional<LatLongSampler> lat_long_;
  int blocks_per_row_ = 0;
  // Other layouts: per block, kBlock entries each (the last block padded with zero solid angles).
  std::vector<float> x_, y_, z_, omega_, r_, g_, b_;
};

// The estimate cmgen and glTF-IBL-Sampler compute, for comparison (tests, benchmarks): GGX half
// vectors from the density D (n.h) by a `samples`-point Hammersley set, l = reflect(-n, h),
// sum L(l) (n.l) / sum (n.l) with L the map's bilinear radiance (without their mip-filtered
// lookups, which trade this noise for bias).
std::array<double, 3> ImportanceSampledGgx(const EnvMap& map, double alpha, const Vec3& n,
                                           int samples);

struct SpecularOptions {
  SpecularLobe lobe = SpecularLobe::kGgx;
  MipChain chain;
  // Relative RMS over the sphere allowed for the degree truncation of each level (see the
  // header comment); in (0, 1).
  // 1e-4 keeps the per-direction relative RMS against the pixel sum below 1e-3 on the bundled
  // maps (measured 1e-4 to 8e-4, tests/split_sum_test.cc): the sphere RMS averages the error over
  // bright and dark directions alike.
  double tolerance = 1e-4;
  // Cap on the degree (0: the map's own limit).
  int max_degree = 0;
  // The lighting rotated actively by this world rotation (core/envmap/lighting.h).
  Mat3 rotation = Mat3::Identity();
  int threads = 1;
  // The synthesis's storage, kept by the caller across calls (a live session's frames); nullptr
  // = one for the call, shared by its levels.
  SynthesisScratch* scratch = nullptr;
};

struct SpecularLevel {
  int face_size = 0;
  double roughness = 0;  // perceptual
  double alpha = 0;      // roughness^2
  int degree = -1;       // F used (-1: the base level, resampled)
  // Estimated relative RMS of the truncation over the sphere (0 for the base level).
  double truncation_estimate = 0;
  RadianceCube cube;  // radiance at the texel centres (3 channels)
};

struct SpecularChain {
  SpecularLobe lobe = SpecularLobe::kGgx;
  int light_degree = 0;  // degree of the coefficients computed from the map
  // The peaks summed directly (SpecularLight::peaks): how many, and the luminance above which
  // pixels were split (0: none).
  int peaks = 0;
  double peak_threshold = 0;
  std::vector<SpecularLevel> levels;
};

// Measured error of one level against SplitSumReference at `count` texel centres drawn from a
// seeded generator (std::mt19937_64(seed), uniform over the cube's texels): relative error per
// direction on luminance, |got - ref| / max(|ref|, 0.01 mean |ref|) (the accuracy issue's
// definition), its RMS and largest value. The base level (alpha = 0) is measured against the map's
// bilinear radiance. count = 0 gives zeros.
struct LevelError {
  int count = 0;
  double rms = 0;
  double max = 0;
};
// `table` (optional) is the map's PixelSumTable, shared by the checks of one job; without it
// one is built for the call.
LevelError MeasureLevelError(const EnvMap& map, SpecularLobe lobe, const SpecularLevel& level,
                             const Mat3& rotation, int count, uint64_t seed, int threads = 1,
                             const PixelSumTable* table = nullptr);
// MeasureLevelError of several levels of one map and rotation, their pixel sums in one pass over
// the map (PixelSumTable::PrefilteredMany): the same figures as one call per level.
struct LevelCheck {
  SpecularLobe lobe;
  const SpecularLevel* level;
  int count;
  uint64_t seed;
};
std::vector<LevelError> MeasureLevelErrors(const EnvMap& map, std::span<const LevelCheck> checks,
                                           const Mat3& rotation, int threads = 1,
                                           const PixelSumTable* table = nullptr);

// The map's lighting coefficients to the largest degree it resolves (capped by `max_degree` > 0,
// and by kMaxRotationLmax when rotated), with the luminance energy per degree: computed once and
// shared by every chain of a job.
struct SpecularLight {
  int degree = 0;
  Mat3 rotation = Mat3::Identity();
  std::vector<double> coeffs;  // L_lm, coeffs[ShIndex(l, m) * 3 + c]
  std::vector<double> energy;  // E_l = sum_m |luminance L_lm|^2
  // What lies above `degree` when the light stops short of what the map resolves: the degree
  // the map resolves (SpecularLightDegree without a cap; = degree when nothing is left out) and
  // the luminance energy of the whole map, LightMoments::total (0: not known, nothing is assumed
  // above `degree`). PrefilterSpecular bounds each level's dropped energy above `degree` by
  // max_{degree < j <= map_degree} g_j^2 (total_energy - sum_l energy[l]).
  int map_degree = 0;
  double total_energy = 0;
  // The map's brightest pixels split off (light_peaks.h; world directions after `rotation`):
  // when not empty, `coeffs`, `energy`, `map_degree` and `total_energy` are those of the rest of
  // the map, and PrefilterSpecular adds the peaks' direct sums to every convolved level.
  LightPeaks peaks;
};
absl::StatusOr<SpecularLight> ComputeSpecularLight(const EnvMap& map, const Mat3& rotation,
                                                   int max_degree, int threads);
// The degree ComputeSpecularLight uses for `map` (rotated: at most kMaxRotationLmax).
int SpecularLightDegree(const EnvMap& map, const Mat3& rotation, int max_degree);
// The light of coefficients already computed: `unrotated` are the map's L_lm to `degree`
// (LightingCoefficients with kPixelSum, unrotated), rotated here by `rotation` (RotateLighting);
// with the energy per degree, and SpecularLight::map_degree / total_energy as given (map_degree
// < degree: taken as `degree`). Equal, bit for bit, to ComputeSpecularLight (or
// ComputeSplitSumLight) of the same map at that degree (a live session keeps the unrotated
// coefficients and turns them per frame).
absl::StatusOr<SpecularLight> SpecularLightFromCoefficients(int degree, const Mat3& rotation,
                                                            std::vector<double> unrotated,
                                                            int map_degree = 0,
                                                            double total_energy = 0);

// The luminance moments of a lat-long map's pixels under the forward transform's own quadrature
// (ShtQuadrature::kPixelSum, the Fejer-1 rule: weight (2 pi / W) w_j per pixel of ring j):
// e0 = (sum Y w)^2 / (4 pi), the energy E_0 of the constant band, and total = sum Y^2 w, by
// Parseval's identity the sum of E_l over every degree the pixels hold (measured on the bundled
// maps: sum_{l <= 511} E_l is 93-99.9% of it; the rest lies above the map's degree). Rotations
// change neither. known = false for other layouts, whose transform runs on a lat-long grid
// resampled inside LightingCoefficients.
struct LightMoments {
  bool known = false;
  double e0 = 0;
  double total = 0;
};
LightMoments MapLightMoments(const EnvMap& map);
// The moments of what a split's light is computed from (PeakSplit's own sums when known, else
// MapLightMoments of `source`: the rest, or the map when nothing was split).
LightMoments SplitLightMoments(const PeakSplit& split, const EnvMap& source);

// The prefiltered mip chain, from `light` when given (its rotation must be options.rotation; the
// base level is resampled from `map`). Errors: InvalidArgument for a bad chain, tolerance,
// degree or thread count, and LightingCoefficients' errors.
absl::StatusOr<SpecularChain> PrefilterSpecular(const EnvMap& map, const SpecularOptions& options,
                                                const SpecularLight* light = nullptr);

// The split-sum set of one lighting state, before storage: what `shrm ibl` computes from its
// light (jobs/ibl_job.h) and a live session for each lighting state (core/live/live_session.h).
struct SplitSumSetOptions {
  MipChain chain;            // of the specular (and sheen) chain
  double tolerance = 1e-4;   // SpecularOptions::tolerance
  bool sheen = false;        // also the Charlie chain
  int irradiance_size = 32;  // face size of the irradiance cube (kLambert, one level)
};
struct SplitSumSet {
  SpecularChain specular;
  SpecularChain sheen;  // no levels unless options.sheen
  SpecularChain irradiance;
  // Radiance L_lm, l <= 2, RGB (light.coeffs' first 27 values; zeros above a tiny map's degree),
  // unwindowed.
  std::vector<double> radiance_sh9;
};
// The smallest degree D of the map's coefficients that a split-sum set needs, so that the map
// need not be transformed to the largest degree it resolves (for a 1024 x 512 map, 511: 23 ms
// on one core) when the set's lobes drop its high bands anyway: for every level with alpha > 0
// of the set's chains (GGX, Charlie when options.sheen, the Lambert irradiance), the bound of its
// energy above D, max_{D < j <= limit} g_j^2 (total - e0), is at most kLightTailShare x
// tolerance^2 of e0 (which no level's total is below, g_0 = 1). The level's degree is then chosen
// with the bound counted as dropped energy (PrefilterSpecular). `limit`, returned when the
// moments are not known, is SpecularLightDegree(map, rotation, 0). Measured (tolerance 1e-3 /
// 30, the job's default, Filament chain from 256): courtyard 392 of 511; city and interior keep
// 510-511 (their sun's energy and the horizon kink of the roughest lobes reach every band).
inline constexpr double kLightTailShare = 0.1;
int SplitSumLightDegree(const EnvMap& map, const Mat3& rotation, const SplitSumSetOptions& options,
                        const LightMoments& moments);
// ComputeSpecularLight to SplitSumLightDegree, with the moments' total energy: the light `shrm
// ibl` uses. It first transforms to kFirstTryBelow degrees less and keeps that light when, by its
// own energies, every level of the set leaves within kFirstTryShare x tolerance^2 of its total
// above it (the levels' degrees then grow by a few at most); else it transforms to D. Measured
// (the job's defaults): the first try is kept on the four bundled maps, courtyard 392 -> 328,
// forest 423 -> 359, city and interior 510 -> 446; the levels' degrees change by 0-12 and their
// estimates stay within the tolerance; the transform's theta stage costs about D^2.
inline constexpr int kFirstTryBelow = 64;
inline constexpr double kFirstTryShare = 0.3;
// The degrees ComputeSplitSumLight transforms to: `first` (kFirstTryBelow below `full`, 0 when
// none is tried: unknown moments, a low `full`, or options.sheen on a map whose peaks were not
// split (`peaks_split`): the Charlie lobes of a whole map with a sun kept every band to its limit
// on the bundled maps), then `full` = SplitSumLightDegree unless the first suffices.
struct SplitSumLightTry {
  int first = 0;
  int full = 0;
};
SplitSumLightTry SplitSumLightTries(const EnvMap& map, const Mat3& rotation,
                                    const SplitSumSetOptions& options, const LightMoments& moments,
                                    bool peaks_split = false);
// True when the light of a first try suffices: with its energies, every level of the set (GGX and
// Charlie per roughness > 0, the Lambert irradiance) leaves within kFirstTryShare x tolerance^2
// of its total above light.degree (the bound PrefilterSpecular counts as dropped).
bool SplitSumLightSuffices(const SpecularLight& light, const SplitSumSetOptions& options);
// With the map's peaks split off (SplitLightPeaks), all of the above applies to the rest of the
// map, and the light carries the peaks.
absl::StatusOr<SpecularLight> ComputeSplitSumLight(const EnvMap& map, const Mat3& rotation,
                                                   const SplitSumSetOptions& options, int threads);

// The set from `light` (the map's, with its rotation; the base levels are resampled from `map`).
// `progress` (optional) is called at the start of each stage ("specular", ["sheen"],
// "irradiance"; its error stops the call) and `timings` (optional) gets each stage's time.
// Errors: PrefilterSpecular's.
absl::StatusOr<SplitSumSet> PrefilterSplitSumSet(const EnvMap& map, const SpecularLight& light,
                                                 const SplitSumSetOptions& options, int threads,
                                                 const PrefilterProgress& progress = nullptr,
                                                 std::vector<StageTiming>* timings = nullptr,
                                                 SynthesisScratch* scratch = nullptr);

}  // namespace shrm::ibl

#endif  // SHRM_CORE_IBL_SPLIT_SUM_H_
