#include "core/ibl/split_sum.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>
#include <random>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/brdf/vector_math.h"
#include "core/envmap/lighting.h"
#include "core/ibl/light_peaks.h"
#include "core/ibl/quarter_power.h"
#include "core/sh/quadrature.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/transform/sht.h"

namespace shrm::ibl {
namespace {

constexpr int kPanelNodes = 16;
// Luminance weights (Rec. 709) of the energy per degree that drives the degree choice.
constexpr std::array<double, 3> kLuma = {0.2126, 0.7152, 0.0722};

bool IsPowerOfTwo(int v) { return v > 0 && (v & (v - 1)) == 0; }

int Log2(int v) {
  int k = 0;
  while ((1 << (k + 1)) <= v) ++k;
  return k;
}

// Panel breakpoints on [0, pi / 2]: graded geometrically towards both ends (the GGX peak at
// theta = 0, the narrow Charlie peak next to pi / 2), each panel no wider than `max_width`.
std::vector<double> Breakpoints(double scale, double max_width) {
  const double half_pi = kPi / 2;
  std::vector<double> b = {0.0, half_pi};
  for (double a = scale; a < half_pi / 2; a *= 2) {
    b.push_back(a);
    b.push_back(half_pi - a);
  }
  std::sort(b.begin(), b.end());
  std::vector<double> out = {0.0};
  for (size_t i = 1; i < b.size(); ++i) {
    const double w = b[i] - b[i - 1];
    if (w <= 0) continue;
    const int n = std::max(1, static_cast<int>(std::ceil(w / max_width)));
    for (int k = 1; k <= n; ++k) out.push_back(b[i - 1] + w * k / n);
  }
  return out;
}

// Rings of the equiangular grid the level is synthesized on before the cubic (4-point Lagrange)
// resampling onto the cube's texels. The synthesis's generic rule, 4 (F + 1), bounds the error of
// the top band; a level's spectrum g_l^2 E_l falls by orders of magnitude before F, so fewer
// rings do: the smallest grid (>= F + 1) whose error by the cubic interpolation's model
// (CubicGridRows, core/shrm/shrm_synthesis.h) stays within kInterpolationBudget x tolerance of
// the level's RMS. kInterpolationBudget = 10: the tolerance given here is the sphere RMS that
// keeps the truncation's per-direction error at the job's (the ringing of a sun reaches every
// dark direction: IblJob divides by 30), while the interpolation errs only where the radiance
// varies fast, i.e. next to bright features, where the relative error per direction is small.
// Measured on the four bundled maps (rgba32f, 300 directions per level): the chosen grids
// (1.3-1.7 F) give the same per-direction RMS as 4 F within 1e-4 (docs/results.md), and the
// bundled-map test holds them to 1e-3.
int GridRings(const std::vector<double>& g, const std::vector<double>& energy, int f,
              double tolerance) {
  constexpr double kInterpolationBudget = 10;
  std::vector<double> band(f + 1);
  for (int l = 0; l <= f; ++l) band[l] = g[l] * g[l] * energy[l];
  return CubicGridRows(band, 0, kInterpolationBudget * tolerance, f + 1, std::max(32, 4 * (f + 1)));
}

// The base level of a lat-long map without rotation, or turned about the vertical by a yaw:
// Radiance() at every texel centre, with the polar angle and azimuth from row tables instead of two
// atan2 and a hypot per texel. The four side faces share one polar-angle table (their
// unnormalized directions all have hypot(x, z) = hypot(1, sc) and y = -tc) and one azimuth per
// column; the caps have a table each. The angles equal Radiance()'s up to the rounding of the
// direction's normalization. A yaw (the lighting turned actively about +Y, a turntable) leaves
// the polar angle alone and adds `phi_offset` to the map's azimuth atan2(x, -z) of the texel's
// direction (the lookup R^-1 d; 0 without rotation).
void ResampleLatLongBase(const EnvMap& map, int s, int threads, double phi_offset,
                         RadianceCube& cube) {
  const auto coord = [s](int i) { return 2 * (i + 0.5) / s - 1; };
  // Mirror images are exact: coord(s - 1 - i) = -coord(i) bit for bit (s >= 2 a power of two), and
  // hypot ignores signs. The polar angles of the caps are computed on the columns x < s / 2 and
  // mirrored, and serve rows y and s - 1 - y alike; +Y's azimuth on the columns x < s / 2 and
  // mirrored with its sign changed (atan2 is odd in its first argument); -Y's azimuth
  // atan2(sc, tc) is +Y's atan2(sc, -tc) a row mirrored. So each task takes a pair of rows (y, s -
  // 1 - y) of every face, with the angles of those two rows in buffers of its own (a few KB, where
  // tables of every texel took 2.6 MB of fresh memory at S = 256).
  const int half = (s + 1) / 2;
  std::vector<double> side_phi(static_cast<size_t>(4) * s);
  for (int x = 0; x < s; ++x) {
    const double sc = coord(x);
    side_phi[0 * s + x] = std::atan2(1.0, sc);    // +X: (1, -tc, -sc)
    side_phi[1 * s + x] = std::atan2(-1.0, -sc);  // -X: (-1, -tc, sc)
    side_phi[2 * s + x] = std::atan2(sc, -1.0);   // +Z: (sc, -tc, 1)
    side_phi[3 * s + x] = std::atan2(-sc, 1.0);   // -Z: (-sc, -tc, -1)
  }
  // hypot(1, sc) of the side faces' columns; the atan2 calls of a row at once (VectorAtan2).
  std::vector<double> side_run(half);
  for (int x = 0; x < half; ++x) side_run[x] = std::hypot(1.0, coord(x));
  ParallelChunks(half, threads, [&](int begin, int end) {
    // [0]: row y, [1]: row s - 1 - y.
    std::vector<double> side_theta(2 * static_cast<size_t>(s)), up_phi(2 * static_cast<size_t>(s));
    std::vector<double> up_theta(s), down_theta(s), num(half), den(half);
    for (int y = begin; y < end; ++y) {
      const int rows[2] = {y, s - 1 - y};
      const int pair = rows[1] != y ? 2 : 1;  // s odd: the middle row alone
      for (int r = 0; r < pair; ++r) {
        const double tc = coord(rows[r]);
        double* st = side_theta.data() + static_cast<size_t>(r) * s;
        double* up = up_phi.data() + static_cast<size_t>(r) * s;
        std::fill(den.begin(), den.end(), -tc);
        internal::VectorAtan2(side_run.data(), den.data(), st, half);
        for (int x = 0; x < half; ++x) num[x] = coord(x);
        // +Y: (sc, 1, tc).
        internal::VectorAtan2(num.data(), den.data(), up, half);
        for (int x = half; x < s; ++x) {
          st[x] = st[s - 1 - x];
          up[x] = -up[s - 1 - x];  // atan2 is odd in its first argument
        }
      }
      const double tc = coord(y);
      for (int x = 0; x < half; ++x) num[x] = std::hypot(coord(x), tc);
      std::fill(den.begin(), den.end(), 1.0);
      internal::VectorAtan2(num.data(), den.data(), up_theta.data(), half);
      std::fill(den.begin(), den.end(), -1.0);
      internal::VectorAtan2(num.data(), den.data(), down_theta.data(), half);
      for (int x = half; x < s; ++x) {
        up_theta[x] = up_theta[s - 1 - x];
        down_theta[x] = down_theta[s - 1 - x];
      }
      for (int r = 0; r < pair; ++r) {
        const int row = rows[r];
        const double* st = side_theta.data() + static_cast<size_t>(r) * s;
        for (int face = 0; face < kCubeFaceCount; ++face) {
          float* out = cube.data.data() + cube.Index(face, 0, row, 0);
          if (face == kPosY) {
            map.LatLongRadianceAt(up_theta.data(), up_phi.data() + static_cast<size_t>(r) * s,
                                  phi_offset, s, out);
          } else if (face == kNegY) {
            // -Y's azimuth at row `row` is +Y's at the mirrored row: the pair's other one.
            map.LatLongRadianceAt(down_theta.data(),
                                  up_phi.data() + static_cast<size_t>(pair - 1 - r) * s, phi_offset,
                                  s, out);
          } else {
            const int side = face == kPosX ? 0 : face == kNegX ? 1 : face == kPosZ ? 2 : 3;
            map.LatLongRadianceAt(st, &side_phi[static_cast<size_t>(side) * s], phi_offset, s, out);
          }
        }
      }
    }
  });
}

}  // namespace

const char* SpecularLobeName(SpecularLobe lobe) {
  switch (lobe) {
    case SpecularLobe::kGgx:
      return "ggx";
    case SpecularLobe::kCharlie:
      return "charlie";
    default:
      return "lambert";
  }
}

absl::StatusOr<SpecularLobe> ParseSpecularLobe(std::string_view name) {
  const std::string n = absl::AsciiStrToLower(std::string(name));
  if (n == "ggx") return SpecularLobe::kGgx;
  if (n == "charlie" || n == "sheen") return SpecularLobe::kCharlie;
  if (n == "lambert") return SpecularLobe::kLambert;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown lobe '", std::string(name), "' (expected ggx, charlie or lambert)"));
}

const char* RoughnessPresetName(RoughnessPreset preset) {
  switch (preset) {
    case RoughnessPreset::kFilament:
      return "filament";
    case RoughnessPreset::kGltf:
      return "gltf";
    case RoughnessPreset::kBabylon:
      return "babylon";
    default:
      return "explicit";
  }
}

absl::StatusOr<RoughnessPreset> ParseRoughnessPreset(std::string_view name) {
  const std::string n = absl::AsciiStrToLower(std::string(name));
  if (n == "filament") return RoughnessPreset::kFilament;
  if (n == "gltf") return RoughnessPreset::kGltf;
  if (n == "explicit") return RoughnessPreset::kExplicit;
  if (n == "babylon") return RoughnessPreset::kBabylon;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown roughness preset '", std::string(name),
                   "' (expected filament, gltf, babylon or explicit)"));
}

absl::StatusOr<MipChain> MakeMipChain(RoughnessPreset preset, int face_size, int levels,
                                      std::span<const double> roughness) {
  if (!IsPowerOfTwo(face_size) || face_size > kMaxIblFaceSize) {
    return absl::InvalidArgumentError(absl::StrCat(
        "face size ", face_size, ": must be a power of two from 1 to ", kMaxIblFaceSize));
  }
  const int max_levels = Log2(face_size) + 1;
  if (preset == RoughnessPreset::kExplicit) {
    if (roughness.empty()) {
      return absl::InvalidArgumentError("explicit roughness list is empty");
    }
    if (levels != 0 && levels != static_cast<int>(roughness.size())) {
      return absl::InvalidArgumentError(absl::StrCat(levels, " levels requested but ",
                                                     roughness.size(), " roughness values given"));
    }
    levels = static_cast<int>(roughness.size());
  } else if (levels == 0) {
    levels = preset == RoughnessPreset::kFilament  ? std::max(1, max_levels - 4)
             : preset == RoughnessPreset::kBabylon ? max_levels
                                                   : std::max(1, max_levels - 1);
  }
  if (levels < 1 || levels > max_levels) {
    return absl::InvalidArgumentError(
        absl::StrCat(levels, " levels: a ", face_size, "-texel face allows 1 to ", max_levels));
  }
  MipChain chain;
  chain.preset = preset;
  for (int k = 0; k < levels; ++k) {
    chain.face_size.push_back(face_size >> k);
    const double t = levels == 1 ? 0.0 : static_cast<double>(k) / (levels - 1);
    double r = 0;
    switch (preset) {
      case RoughnessPreset::kFilament:
        r = 1 - std::sqrt(1 - t);
        break;
      case RoughnessPreset::kGltf:
        r = t;
        break;
      case RoughnessPreset::kBabylon:  // alpha = S^(t - 1) past the base level
        r = k == 0 ? 0.0 : std::sqrt(std::pow(static_cast<double>(face_size), t - 1));
        break;
      case RoughnessPreset::kExplicit:
        r = roughness[k];
        if (!(r >= 0 && r <= 1)) {
          return absl::InvalidArgumentError(
              absl::StrCat("roughness ", r, " of level ", k, " is outside [0, 1]"));
        }
        if (k > 0 && r < chain.roughness.back()) {
          return absl::InvalidArgumentError(
              absl::StrCat("roughness must not decrease along the chain: level ", k, " has ", r,
                           " after ", chain.roughness.back()));
        }
        break;
    }
    chain.roughness.push_back(r);
  }
  return chain;
}

double LobeNdf(SpecularLobe lobe, double alpha, double cos_h) {
  const double c2 = cos_h * cos_h;
  if (lobe == SpecularLobe::kLambert) return 1 / kPi;
  if (lobe == SpecularLobe::kGgx) {
    const double a2 = alpha * alpha;
    const double d = (a2 - 1) * c2 + 1;
    return a2 / (kPi * d * d);
  }
  const double inv = 1 / alpha;
  const double s2 = std::max(0.0, 1 - c2);
  return (2 + inv) * std::pow(s2, 0.5 * inv) / (2 * kPi);
}

double SplitSumKernel(SpecularLobe lobe, double alpha, double cos_theta) {
  if (cos_theta <= 0) return 0;
  if (lobe == SpecularLobe::kLambert) return cos_theta;
  // cos(theta / 2) = sqrt((1 + cos theta) / 2).
  return LobeNdf(lobe, alpha, std::sqrt(0.5 * (1 + std::min(1.0, cos_theta)))) * cos_theta;
}

namespace {

std::vector<double> ComputeSplitSumZonal(SpecularLobe lobe, double alpha, int lmax);
void KernelNodes(SpecularLobe lobe, double alpha, int lmax, std::vector<double>& x,
                 std::vector<double>& w);

}  // namespace

double SplitSumKernelIntegral(SpecularLobe lobe, double alpha) {
  std::vector<double> x, w;
  KernelNodes(lobe, alpha, 0, x, w);
  double sum = 0;
  for (double v : w) sum += v;
  return 2 * kPi * sum;
}

PeakKernel SplitSumPeakKernel(SpecularLobe lobe, double alpha) {
  PeakKernel k;
  const double integral = SplitSumKernelIntegral(lobe, alpha);
  switch (lobe) {
    case SpecularLobe::kGgx:
      // D = alpha^2 / (pi den^2), den = alpha^2 + (1 - alpha^2) e / 4 = alpha^2 (1 + slope e).
      k.form = PeakKernel::Form::kGgx;
      k.slope = (1 - alpha * alpha) / (4 * alpha * alpha);
      k.scale = 1 / (kPi * alpha * alpha * integral);
      break;
    case SpecularLobe::kLambert:
      k.form = PeakKernel::Form::kCosine;
      k.scale = 1 / integral;
      break;
    case SpecularLobe::kCharlie:
      // D = (2 + 1 / alpha) (sin^2 theta_h)^(1 / (2 alpha)) / (2 pi), sin^2 theta_h = e / 4.
      k.form = PeakKernel::Form::kPower;
      k.exponent = 0.5 / alpha;
      k.scale = (2 + 1 / alpha) / (2 * kPi * integral);
      break;
  }
  return k;
}

std::vector<double> SplitSumZonal(SpecularLobe lobe, double alpha, int lmax) {
  // Kept for the process (a job asks for each level's lobe twice: the light's degree, then the
  // level's; a live session for the same lobes every frame), the last kKept of them.
  constexpr size_t kKept = 32;
  struct Entry {
    SpecularLobe lobe;
    double alpha;
    int lmax;
    std::shared_ptr<const std::vector<double>> g;
  };
  static std::mutex mu;
  static std::vector<Entry> kept;
  {
    std::lock_guard<std::mutex> lock(mu);
    for (const Entry& e : kept) {
      if (e.lobe == lobe && e.alpha == alpha && e.lmax == lmax) return *e.g;
    }
  }
  auto g = std::make_shared<const std::vector<double>>(ComputeSplitSumZonal(lobe, alpha, lmax));
  std::lock_guard<std::mutex> lock(mu);
  if (kept.size() >= kKept) kept.erase(kept.begin());
  kept.push_back({lobe, alpha, lmax, g});
  return *g;
}

namespace {

// The quadrature nodes x = cos(theta) and weights w = K(x) sin(theta) dtheta of the kernel over
// theta in [0, pi / 2], for degrees up to lmax (nodes where K = 0 dropped).
void KernelNodes(SpecularLobe lobe, double alpha, int lmax, std::vector<double>& x,
                 std::vector<double>& w) {
  const double scale =
      lobe == SpecularLobe::kLambert ? 0.25 : std::max(1e-6, std::min(alpha, 1.0) / 4);
  // A 16-node Gauss-Legendre panel integrates P_l (cos theta) times the smooth kernel to
  // rounding while l x width stays below about 16 (half the rule's polynomial degree, 31, in
  // radians of oscillation); kPanelPhase = 8 keeps a factor of two in hand.
  constexpr double kPanelPhase = 8;
  const double max_width = std::min(0.1, kPanelPhase / (lmax + 1));
  const std::vector<double> b = Breakpoints(scale, max_width);
  const RingQuadrature gl = GaussLegendreRule(kPanelNodes);
  x.clear();
  w.clear();
  x.reserve((b.size() - 1) * kPanelNodes);
  w.reserve(x.capacity());
  for (size_t i = 1; i < b.size(); ++i) {
    const double mid = 0.5 * (b[i] + b[i - 1]), half = 0.5 * (b[i] - b[i - 1]);
    for (int k = 0; k < kPanelNodes; ++k) {
      // Gauss-Legendre nodes x_k = cos(theta_k) in [-1, 1], weights summing to 2.
      const double theta = mid + half * gl.cos_theta[k];
      const double c = std::cos(theta);
      const double weight = half * gl.weight[k] * std::sin(theta) * SplitSumKernel(lobe, alpha, c);
      if (weight == 0) continue;
      x.push_back(c);
      w.push_back(weight);
    }
  }
}

std::vector<double> ComputeSplitSumZonal(SpecularLobe lobe, double alpha, int lmax) {
  std::vector<double> g(lmax + 1, 0.0);
  std::vector<double> x, w;
  // The nodes first, then the Legendre recurrence over all of them at once per degree (the
  // inner loop runs over nodes: independent lanes, vectorized).
  KernelNodes(lobe, alpha, lmax, x, w);
  double norm = 0;
  for (double v : w) norm += v;
  if (x.empty() || norm == 0) return g;
  // Padded to whole blocks of kLanes with zero weights (their terms stay 0).
  constexpr size_t kLanes = 8;
  const size_t n = (x.size() + kLanes - 1) / kLanes * kLanes;
  x.resize(n, 0.0);
  w.resize(n, 0.0);
  // p0 = w P_{l-1}, p1 = w P_l, carried weighted so that each degree's sum is a plain sum;
  // kLanes partial sums so that the loop vectorizes without reassociating a single sum.
  std::vector<double> p0(w), p1(n);
  for (size_t j = 0; j < n; ++j) p1[j] = w[j] * x[j];
  auto lane_sum = [&](const std::vector<double>& p) {
    double s[kLanes] = {};
    for (size_t j = 0; j < n; j += kLanes)
      for (size_t k = 0; k < kLanes; ++k) s[k] += p[j + k];
    double t = 0;
    for (double v : s) t += v;
    return t;
  };
  g[0] = 1;
  if (lmax >= 1) g[1] = lane_sum(p1) / norm;
  for (int l = 2; l <= lmax; ++l) {
    const double a = (2.0 * l - 1) / l, c = (l - 1.0) / l;
    double s[kLanes] = {};
    for (size_t j = 0; j < n; j += kLanes) {
      for (size_t k = 0; k < kLanes; ++k) {
        const double p2 = a * x[j + k] * p1[j + k] - c * p0[j + k];
        p0[j + k] = p1[j + k];
        p1[j + k] = p2;
        s[k] += p2;
      }
    }
    double t = 0;
    for (double v : s) t += v;
    g[l] = t / norm;
  }
  return g;
}

}  // namespace

std::array<double, 3> SplitSumReference(const EnvMap& map, SpecularLobe lobe, double alpha,
                                        const Vec3& r) {
  if (alpha <= 0) {
    const std::array<float, 3> v = map.Radiance(r);
    return {v[0], v[1], v[2]};
  }
  double sum[3] = {0, 0, 0}, norm = 0;
  for (const EnvSample& s : map.samples()) {
    const double k = SplitSumKernel(lobe, alpha, r.Dot(s.dir)) * s.solid_angle;
    if (k == 0) continue;
    norm += k;
    for (int c = 0; c < 3; ++c) sum[c] += k * s.rgb[c];
  }
  if (norm == 0) return {0, 0, 0};
  return {sum[0] / norm, sum[1] / norm, sum[2] / norm};
}

namespace {

// The bounding cone of `n` unit directions (float-rounded members) with `sum` their sum.
template <typename Cone, typename DirAt>
Cone BoundingCone(const Vec3& sum, int n, DirAt dir_at) {
  Cone cone;
  const double len = sum.Norm();
  // A block spread over more than a hemisphere (len ~ 0) is never skipped.
  cone.axis = len > 1e-9 ? sum * (1 / len) : Vec3{0, 0, 1};
  double min_cos = len > 1e-9 ? 1.0 : -1.0;
  for (int k = 0; k < n; ++k) min_cos = std::min(min_cos, cone.axis.Dot(dir_at(k)));
  // The member directions are rounded to float (relative 6e-8, so the cosines above are off by
  // as much): widen the cone by more than that.
  min_cos = std::max(-1.0, min_cos - 1e-6);
  cone.sin_radius = min_cos <= 0 ? 2.0 : std::sqrt(1 - min_cos * min_cos);
  return cone;
}

}  // namespace

PixelSumTable::PixelSumTable(const EnvMap& map) {
  if (const Image* img = map.lat_long_image(); img != nullptr && img->channels >= 3) {
    // The directions and solid angles of EnvMap::ForEachSample, as tables.
    lat_long_.emplace(map);
    const int w = img->width, h = img->height;
    blocks_per_row_ = (w + kBlock - 1) / kBlock;
    blocks_ = blocks_per_row_ * h;
    cones_.resize(blocks_);
    // A block is one ring's run of columns: the sum of its directions is the ring's sine times
    // the sums of its columns' azimuth sines and cosines (the same for every ring), and its member
    // farthest from any axis in the run's middle meridian plane (the normalized sum is) is one of
    // its two ends, where the cosine to the axis, sin a sin t cos(phi - phi_mid) + cos a cos t, is
    // smallest. (The members are float-rounded, as in MakeLatLongBlock: BoundingCone's margin
    // covers that.) So each cone costs two members, not the block's 256.
    const LatLongSampler& ll = *lat_long_;
    std::vector<double> col_sin(blocks_per_row_, 0.0), col_cos(blocks_per_row_, 0.0);
    for (int c = 0; c < w; ++c) {
      col_sin[c / kBlock] += ll.ColSin(c);
      col_cos[c / kBlock] += ll.ColCos(c);
    }
    for (int blk = 0; blk < blocks_; ++blk) {
      const int j = blk / blocks_per_row_, b = blk % blocks_per_row_, c0 = b * kBlock;
      const int n = std::min(kBlock, w - c0);
      const double st = ll.RowSin(j), ct = ll.RowCos(j);
      const Vec3 sum{st * col_sin[b], n * ct, -st * col_cos[b]};
      const auto member = [&](int c) {
        return Vec3{static_cast<float>(st * ll.ColSin(c)), static_cast<float>(ct),
                    static_cast<float>(-st * ll.ColCos(c))};
      };
      cones_[blk] =
          BoundingCone<Cone>(sum, 2, [&](int k) { return member(k == 0 ? c0 : c0 + n - 1); });
    }
    return;
  }
  // Streamed from the map (not through map.samples(), which would keep 48 bytes per pixel
  // besides this table's 28).
  const size_t count = map.sample_count();
  blocks_ = static_cast<int>((count + kBlock - 1) / kBlock);
  const size_t n = static_cast<size_t>(blocks_) * kBlock;
  for (std::vector<float>* v : {&x_, &y_, &z_, &omega_, &r_, &g_, &b_}) v->assign(n, 0.0f);
  cones_.resize(blocks_);
  std::vector<Vec3> sums(blocks_, Vec3{0, 0, 0});
  size_t i = 0;
  map.ForEachSample([&](const EnvSample& s) {
    x_[i] = static_cast<float>(s.dir.x);
    y_[i] = static_cast<float>(s.dir.y);
    z_[i] = static_cast<float>(s.dir.z);
    omega_[i] = static_cast<float>(s.solid_angle);
    r_[i] = s.rgb[0];
    g_[i] = s.rgb[1];
    b_[i] = s.rgb[2];
    Vec3& sum = sums[i / kBlock];
    sum = sum + s.dir;
    ++i;
  });
  for (int b = 0; b < blocks_; ++b) {
    const size_t begin = static_cast<size_t>(b) * kBlock;
    const int members = static_cast<int>(std::min(count, begin + kBlock) - begin);
    cones_[b] = BoundingCone<Cone>(sums[b], members, [&](int k) {
      return Vec3{x_[begin + k], y_[begin + k], z_[begin + k]};
    });
  }
}

void PixelSumTable::MakeLatLongBlock(int blk, BlockData& out) const {
  const LatLongSampler& ll = *lat_long_;
  const int w = ll.width();
  const int j = blk / blocks_per_row_, c0 = (blk % blocks_per_row_) * kBlock;
  const int n = std::min(kBlock, w - c0);
  const double st = ll.RowSin(j), ct = ll.RowCos(j);
  const float omega = static_cast<float>(ll.RowSolidAngle(j));
  const float* px = ll.pixels() + (static_cast<size_t>(j) * w + c0) * 3;
  constexpr int ch = 3;
  for (int k = 0; k < n; ++k) {
    out.x[k] = static_cast<float>(st * ll.ColSin(c0 + k));
    out.y[k] = static_cast<float>(ct);
    out.z[k] = static_cast<float>(-st * ll.ColCos(c0 + k));
    out.omega[k] = omega;
    out.r[k] = px[k * ch];
    out.g[k] = px[k * ch + 1];
    out.b[k] = px[k * ch + 2];
  }
  for (int k = n; k < kBlock; ++k) {
    out.x[k] = out.z[k] = 0;
    out.y[k] = 1;
    out.omega[k] = out.r[k] = out.g[k] = out.b[k] = 0;
  }
}

namespace {

// The kernel of SplitSumKernel up to a constant factor, as a function of e = |r - d|^2. GGX and
// Lambert also in 16 lanes (AVX-512), GGX's division there by the reciprocal estimate and one
// Newton step (within an ulp or two of the quotient: the sums are single precision anyway).
struct GgxInE {
  float a2, b;  // alpha^2, (1 - alpha^2) / 4
  float operator()(float e) const {
    const float q = a2 + b * e;
    return std::max(0.0f, 1 - 0.5f * e) / (q * q);
  }
#if defined(__AVX512F__)
  static constexpr bool kVector = true;
  __m512 operator()(__m512 e) const {
    const __m512 q = _mm512_fmadd_ps(_mm512_set1_ps(b), e, _mm512_set1_ps(a2));
    const __m512 q2 = _mm512_mul_ps(q, q);
    __m512 r = _mm512_maskz_rcp14_ps(0xFFFF, q2);
    r = _mm512_fmadd_ps(r, _mm512_fnmadd_ps(q2, r, _mm512_set1_ps(1.0f)), r);
    const __m512 c = _mm512_fnmadd_ps(_mm512_set1_ps(0.5f), e, _mm512_set1_ps(1.0f));
    return _mm512_mul_ps(_mm512_maskz_max_ps(0xFFFF, c, _mm512_setzero_ps()), r);
  }
#endif
};
struct CharlieInE {
  float power;  // 1 / (2 alpha): D ~ (sin^2 theta_h)^power, sin^2 theta_h = e / 4
  float operator()(float e) const {
    const float c = 1 - 0.5f * e;
    return c > 0 ? std::pow(0.25f * e, power) * c : 0.0f;
  }
#if defined(__AVX512F__)
  static constexpr bool kVector = true;
  __m512 operator()(__m512 e) const {
    const __m512 c =
        _mm512_maskz_max_ps(0xFFFF, _mm512_fnmadd_ps(_mm512_set1_ps(0.5f), e, _mm512_set1_ps(1.0f)),
                            _mm512_setzero_ps());
    return _mm512_mul_ps(c, shrm::internal::QuarterPower(e, power));
  }
#endif
};
struct LambertInE {
  float operator()(float e) const { return std::max(0.0f, 1 - 0.5f * e); }
#if defined(__AVX512F__)
  static constexpr bool kVector = true;
  __m512 operator()(__m512 e) const {
    const __m512 c = _mm512_fnmadd_ps(_mm512_set1_ps(0.5f), e, _mm512_set1_ps(1.0f));
    return _mm512_maskz_max_ps(0xFFFF, c, _mm512_setzero_ps());
  }
#endif
};

#if defined(__AVX512F__)
// The wide lobes' kernels as functions of d = r.p = 1 - e / 2 (16 lanes): d takes three
// operations where e takes six, and the N.L factor max(d, 0) is d itself. Rounding moves d by
// about 1e-7 either way; in e = |r - p|^2 it is |r - p| times smaller, which only matters near a
// narrow peak, where GGX's q = alpha^2 + (1 - alpha^2) e / 4 is about alpha^2: from
// kDotFormMinAlpha2 on, d's rounding moves q by under 1e-5 of itself (tests/split_sum_test.cc
// PixelSumTableIsTheReferenceSum holds every lobe to 2e-6 of the double-precision sum).
constexpr float kDotFormMinAlpha2 = 0.01f;
struct GgxInD {
  float c0, c1;  // q = c0 + c1 d: (1 + alpha^2) / 2, -(1 - alpha^2) / 2
  static constexpr bool kVector = true, kDot = true;
  __m512 operator()(__m512 d) const {
    const __m512 q = _mm512_fmadd_ps(_mm512_set1_ps(c1), d, _mm512_set1_ps(c0));
    const __m512 q2 = _mm512_mul_ps(q, q);
    __m512 r = _mm512_maskz_rcp14_ps(0xFFFF, q2);
    r = _mm512_fmadd_ps(r, _mm512_fnmadd_ps(q2, r, _mm512_set1_ps(1.0f)), r);
    return _mm512_mul_ps(_mm512_maskz_max_ps(0xFFFF, d, _mm512_setzero_ps()), r);
  }
};
struct LambertInD {
  static constexpr bool kVector = true, kDot = true;
  __m512 operator()(__m512 d) const { return _mm512_maskz_max_ps(0xFFFF, d, _mm512_setzero_ps()); }
};
#endif

// A direction's sums over the blocks: weight, then the weighted r, g, b. With AVX-512 per lane
// (the 16 lanes of each single-precision block sum, in double), summed at the end.
struct LaneTotals {
#if defined(__AVX512F__)
  __m512d lanes[8] = {};  // [2 k], [2 k + 1]: lanes 0-7 and 8-15 of sum k
#endif
  std::array<double, 4> sums = {0, 0, 0, 0};
  std::array<double, 4> Sums() const {
    std::array<double, 4> t = sums;
#if defined(__AVX512F__)
    for (int k = 0; k < 4; ++k) {
      alignas(64) double f[16];
      _mm512_store_pd(f, lanes[2 * k]);
      _mm512_store_pd(f + 8, lanes[2 * k + 1]);
      for (double x : f) t[k] += x;
    }
#endif
    return t;
  }
};

// One block's sums for direction (rx, ry, rz): weight, then the weighted r, g, b, each over
// `n` members (a multiple of 16) in single precision.
template <typename Kernel>
void BlockSums(const Kernel& kernel, float rx, float ry, float rz, int n, const float* px,
               const float* py, const float* pz, const float* po, const float* pr, const float* pg,
               const float* pb, LaneTotals* acc) {
#if defined(__AVX512F__)
  if constexpr (requires { Kernel::kVector; }) {
    const __m512 vx = _mm512_set1_ps(rx), vy = _mm512_set1_ps(ry), vz = _mm512_set1_ps(rz);
    const __m512 zero = _mm512_setzero_ps(), two = _mm512_set1_ps(2.0f);
    __m512 sw = zero, sr = zero, sg = zero, sb = zero;
    for (int j = 0; j < n; j += 16) {
      // The kernel's argument, d = r.p (Kernel::kDot) or e = |r - p|^2 = 2 - 2 d. Every vector
      // kernel is 0 behind the normal (d <= 0, e >= 2): sixteen pixels there add zeros, skipped.
      // (Blocks are rows of 256 pixels, up to 90 degrees of azimuth: many straddle the horizon
      // that their bounding cone cannot cull.)
      __m512 t;
      __mmask16 front;
      const __m512 x = _mm512_loadu_ps(px + j), y = _mm512_loadu_ps(py + j),
                   z = _mm512_loadu_ps(pz + j);
      if constexpr (requires { Kernel::kDot; }) {
        t = _mm512_fmadd_ps(vx, x, _mm512_fmadd_ps(vy, y, _mm512_mul_ps(vz, z)));
        front = _mm512_cmp_ps_mask(t, zero, _CMP_GT_OQ);
      } else {
        const __m512 dx = _mm512_sub_ps(vx, x), dy = _mm512_sub_ps(vy, y),
                     dz = _mm512_sub_ps(vz, z);
        t = _mm512_fmadd_ps(dx, dx, _mm512_fmadd_ps(dy, dy, _mm512_mul_ps(dz, dz)));
        front = _mm512_cmp_ps_mask(t, two, _CMP_LT_OQ);
      }
      if (front == 0) continue;
      const __m512 w = _mm512_mul_ps(kernel(t), _mm512_loadu_ps(po + j));
      sw = _mm512_add_ps(sw, w);
      sr = _mm512_fmadd_ps(w, _mm512_loadu_ps(pr + j), sr);
      sg = _mm512_fmadd_ps(w, _mm512_loadu_ps(pg + j), sg);
      sb = _mm512_fmadd_ps(w, _mm512_loadu_ps(pb + j), sb);
    }
    // Each lane's block sum widened to double and added to the direction's lane sums: the lanes
    // are summed once, at the end (LaneTotals::Sums), not per block (16 dependent additions a
    // sum, a third of the work per block and direction).
    const __m512 s[4] = {sw, sr, sg, sb};
    for (int k = 0; k < 4; ++k) {
      // (Through memory: GCC 12 reports the extraction intrinsics' undefined vectors.)
      alignas(64) float f[16];
      _mm512_store_ps(f, s[k]);
      acc->lanes[2 * k] =
          _mm512_add_pd(acc->lanes[2 * k], _mm512_maskz_cvtps_pd(0xFF, _mm256_load_ps(f)));
      acc->lanes[2 * k + 1] =
          _mm512_add_pd(acc->lanes[2 * k + 1], _mm512_maskz_cvtps_pd(0xFF, _mm256_load_ps(f + 8)));
    }
    return;
  } else  // NOLINT(readability/braces): the portable sum below is the else branch
#endif
  {
    constexpr int kLanes = 8;
    float sw[kLanes] = {}, sr[kLanes] = {}, sg[kLanes] = {}, sb[kLanes] = {};
    for (int j = 0; j < n; j += kLanes) {
      for (int k = 0; k < kLanes; ++k) {
        const float dx = rx - px[j + k], dy = ry - py[j + k], dz = rz - pz[j + k];
        const float w = kernel(dx * dx + dy * dy + dz * dz) * po[j + k];
        sw[k] += w;
        sr[k] += w * pr[j + k];
        sg[k] += w * pg[j + k];
        sb[k] += w * pb[j + k];
      }
    }
    for (int k = 0; k < kLanes; ++k) {
      acc->sums[0] += sw[k];
      acc->sums[1] += sr[k];
      acc->sums[2] += sg[k];
      acc->sums[3] += sb[k];
    }
  }
}

}  // namespace

std::vector<std::array<double, 3>> PixelSumTable::Prefiltered(SpecularLobe lobe, double alpha,
                                                              std::span<const Vec3> dirs,
                                                              int threads) const {
  const Query query{lobe, alpha, dirs};
  return std::move(PrefilteredMany({&query, 1}, threads)[0]);
}

std::vector<std::vector<std::array<double, 3>>> PixelSumTable::PrefilteredMany(
    std::span<const Query> queries, int threads) const {
  // The queries' directions end to end; a worker takes a run of them, which may span queries.
  std::vector<size_t> first(queries.size() + 1, 0);
  for (size_t q = 0; q < queries.size(); ++q) first[q + 1] = first[q] + queries[q].dirs.size();
  std::vector<std::vector<std::array<double, 3>>> out(queries.size());
  for (size_t q = 0; q < queries.size(); ++q) out[q].assign(queries[q].dirs.size(), {0, 0, 0});
  const auto dir_at = [&](size_t q, size_t i) -> const Vec3& {
    return queries[q].dirs[i - first[q]];
  };
  ParallelChunks(static_cast<int>(first.back()), threads, [&](int begin, int end) {
    std::vector<LaneTotals> total(end - begin);
    std::unique_ptr<BlockData> made;
    if (lat_long_) made = std::make_unique<BlockData>();
    for (int blk = 0; blk < blocks_; ++blk) {
      const Cone& cone = cones_[blk];
      // Every member at least 90 degrees from dir: K = 0 for the whole block.
      const auto behind = [&cone](const Vec3& dir) {
        return cone.sin_radius <= 1 && dir.Dot(cone.axis) <= -cone.sin_radius;
      };
      const float *px, *py, *pz, *po, *pr, *pg, *pb;
      if (made) {
        bool any = false;
        for (size_t q = 0; q < queries.size() && !any; ++q) {
          for (size_t i = std::max<size_t>(begin, first[q]);
               i < std::min<size_t>(end, first[q + 1]) && !any; ++i)
            any = !behind(dir_at(q, i));
        }
        if (!any) continue;
        MakeLatLongBlock(blk, *made);
        px = made->x, py = made->y, pz = made->z, po = made->omega;
        pr = made->r, pg = made->g, pb = made->b;
      } else {
        const size_t base = static_cast<size_t>(blk) * kBlock;
        px = x_.data() + base, py = y_.data() + base, pz = z_.data() + base;
        po = omega_.data() + base;
        pr = r_.data() + base, pg = g_.data() + base, pb = b_.data() + base;
      }
      for (size_t q = 0; q < queries.size(); ++q) {
        const size_t i0 = std::max<size_t>(begin, first[q]),
                     i1 = std::min<size_t>(end, first[q + 1]);
        if (i0 >= i1) continue;
        auto sum = [&](const auto& kernel) {
          for (size_t i = i0; i < i1; ++i) {
            const Vec3& dir = dir_at(q, i);
            if (behind(dir)) continue;
            BlockSums(kernel, static_cast<float>(dir.x), static_cast<float>(dir.y),
                      static_cast<float>(dir.z), kBlock, px, py, pz, po, pr, pg, pb,
                      &total[i - begin]);
          }
        };
        const float a = static_cast<float>(queries[q].alpha);
        switch (queries[q].lobe) {
          case SpecularLobe::kGgx:
#if defined(__AVX512F__)
            if (a * a >= kDotFormMinAlpha2) {
              sum(GgxInD{(1 + a * a) / 2, -(1 - a * a) / 2});
              break;
            }
#endif
            sum(GgxInE{a * a, (1 - a * a) / 4});
            break;
          case SpecularLobe::kCharlie:
            sum(CharlieInE{0.5f / a});
            break;
          case SpecularLobe::kLambert:
#if defined(__AVX512F__)
            sum(LambertInD{});
#else
            sum(LambertInE{});
#endif
            break;
        }
      }
    }
    for (size_t q = 0; q < queries.size(); ++q) {
      const size_t i0 = std::max<size_t>(begin, first[q]), i1 = std::min<size_t>(end, first[q + 1]);
      for (size_t i = i0; i < i1; ++i) {
        const std::array<double, 4> t = total[i - begin].Sums();
        if (t[0] > 0) out[q][i - first[q]] = {t[1] / t[0], t[2] / t[0], t[3] / t[0]};
      }
    }
  });
  return out;
}

std::array<double, 3> ImportanceSampledGgx(const EnvMap& map, double alpha, const Vec3& n,
                                           int samples) {
  const Vec3 up = std::abs(n.y) < 0.999 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  const Vec3 t = up.Cross(n).Normalized(), b = n.Cross(t);
  const double a2 = alpha * alpha;
  double sum[3] = {0, 0, 0}, w = 0;
  for (int i = 0; i < samples; ++i) {
    // Hammersley point (i / N, radical inverse of i in base 2).
    uint32_t bits = static_cast<uint32_t>(i);
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    const double u1 = static_cast<double>(i) / samples, u2 = bits * 2.3283064365386963e-10;
    const double ch = std::sqrt((1 - u2) / (1 + (a2 - 1) * u2)), sh = std::sqrt(1 - ch * ch);
    const double phi = 2 * kPi * u1;
    const Vec3 h = t * (sh * std::cos(phi)) + b * (sh * std::sin(phi)) + n * ch;
    const Vec3 l = h * (2 * n.Dot(h)) - n;
    const double nl = n.Dot(l);
    if (nl <= 0) continue;
    const std::array<float, 3> v = map.Radiance(l);
    for (int c = 0; c < 3; ++c) sum[c] += v[c] * nl;
    w += nl;
  }
  if (w == 0) return {0, 0, 0};
  return {sum[0] / w, sum[1] / w, sum[2] / w};
}

int SpecularLightDegree(const EnvMap& map, const Mat3& rotation, int max_degree) {
  // The degree the map resolves: its own lat-long grid, or the grid LightingCoefficients
  // resamples other layouts to.
  int limit = map.lat_long_image() != nullptr
                  ? ShtMaxDegree(ShtGrid{map.width(), map.height(), ShtGridKind::kEquiangular})
                  : map.NativeLatLongWidth() / 2 - 1;
  if (!rotation.IsIdentity()) limit = std::min(limit, kMaxRotationLmax);
  if (max_degree > 0) limit = std::min(limit, max_degree);
  return std::max(limit, 0);
}

absl::StatusOr<SpecularLight> SpecularLightFromCoefficients(int degree, const Mat3& rotation,
                                                            std::vector<double> unrotated,
                                                            int map_degree, double total_energy) {
  if (degree < 0 || unrotated.size() != static_cast<size_t>(ShCount(degree)) * 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("IBL: ", unrotated.size(), " coefficients for degree ", degree));
  }
  SpecularLight light;
  light.degree = degree;
  light.map_degree = std::max(degree, map_degree);
  light.total_energy = total_energy;
  light.rotation = rotation;
  light.coeffs = std::move(unrotated);
  // As LightingCoefficients does after its transform.
  if (!rotation.IsIdentity()) SHRM_RETURN_IF_ERROR(RotateLighting(degree, rotation, light.coeffs));
  light.energy.assign(degree + 1, 0.0);
  for (int l = 0; l <= degree; ++l)
    for (int m = -l; m <= l; ++m) {
      double y = 0;
      for (int c = 0; c < 3; ++c)
        y += kLuma[c] * light.coeffs[static_cast<size_t>(ShIndex(l, m)) * 3 + c];
      light.energy[l] += y * y;
    }
  return light;
}

namespace {

// The map's coefficients to `degree` (at most SpecularLightDegree), with the map's degree and
// `total_energy` (LightMoments::total, 0 when not known). The pixels' own quadrature: the
// convolution is then the pixel sum with the degree-F kernel. (Rotated: LightingCoefficients'
// unrotated coefficients turned by SpecularLightFromCoefficients.)
absl::StatusOr<SpecularLight> LightToDegree(const EnvMap& map, const Mat3& rotation, int degree,
                                            int threads, double total_energy) {
  auto coeffs =
      LightingCoefficients(map, degree, Mat3::Identity(), threads, ShtQuadrature::kPixelSum);
  if (!coeffs.ok()) return coeffs.status();
  return SpecularLightFromCoefficients(degree, rotation, std::move(coeffs).value(),
                                       SpecularLightDegree(map, rotation, 0), total_energy);
}

}  // namespace

absl::StatusOr<SpecularLight> ComputeSpecularLight(const EnvMap& map, const Mat3& rotation,
                                                   int max_degree, int threads) {
  if (threads < 1) return absl::InvalidArgumentError(absl::StrCat("IBL: threads = ", threads));
  if (max_degree < 0) {
    return absl::InvalidArgumentError(absl::StrCat("IBL: negative degree cap ", max_degree));
  }
  const int limit = SpecularLightDegree(map, rotation, max_degree);
  const LightMoments moments =
      limit < SpecularLightDegree(map, rotation, 0) ? MapLightMoments(map) : LightMoments{};
  return LightToDegree(map, rotation, limit, threads, moments.total);
}

LightMoments MapLightMoments(const EnvMap& map) {
  LightMoments out;
  const Image* img = map.lat_long_image();
  if (img == nullptr || img->width < 1 || img->height < 1 || img->channels != 3) return out;
  const RingQuadrature rule = FejerFirstRule(img->height);
  const size_t w = static_cast<size_t>(img->width);
  double sum = 0, sum_sq = 0;
  for (int j = 0; j < img->height; ++j) {
    const LuminanceRow row = SumLuminanceRow(img->pixels.data() + j * w * 3, img->width);
    const double weight = 2 * kPi / static_cast<double>(w) * rule.weight[j];
    sum += weight * row.sum;
    sum_sq += weight * row.sum_sq;
  }
  out.known = true;
  out.e0 = sum * sum / (4 * kPi);
  out.total = sum_sq;
  return out;
}

LightMoments SplitLightMoments(const PeakSplit& split, const EnvMap& source) {
  if (!split.moments_known) return MapLightMoments(source);
  LightMoments out;
  out.known = true;
  out.e0 = split.sum_y * split.sum_y / (4 * kPi);
  out.total = split.sum_y2;
  return out;
}

int SplitSumLightDegree(const EnvMap& map, const Mat3& rotation, const SplitSumSetOptions& options,
                        const LightMoments& moments) {
  const int limit = SpecularLightDegree(map, rotation, 0);
  if (!moments.known || !(moments.e0 > 0) || !(options.tolerance > 0)) return limit;
  const double spread = std::max(0.0, moments.total - moments.e0);
  const double budget = kLightTailShare * options.tolerance * options.tolerance * moments.e0;
  int need = 0;
  const auto lobe_needs = [&](SpecularLobe lobe, double alpha) {
    if (!(alpha > 0) || need >= limit) return;
    const std::vector<double> g = SplitSumZonal(lobe, alpha, limit);
    // The smallest d with max_{d < j <= limit} g_j^2 spread <= budget: from the top down.
    double largest = 0;
    int d = limit;
    for (int j = limit; j > need; --j) {
      largest = std::max(largest, g[j] * g[j]);
      if (largest * spread > budget) break;
      d = j - 1;
    }
    need = std::max(need, d);
  };
  for (double r : options.chain.roughness) lobe_needs(SpecularLobe::kGgx, r * r);
  if (options.sheen) {
    for (double r : options.chain.roughness) lobe_needs(SpecularLobe::kCharlie, r * r);
  }
  lobe_needs(SpecularLobe::kLambert, 1.0);
  return std::min(need, limit);
}

namespace {

// A level's degree (PrefilterSpecular): the smallest F <= limit whose dropped energy, the bands
// F < l <= limit of g_l^2 E_l plus the bound of what lies above `limit` (the map's energy there,
// light.total_energy less what the light holds, times the largest g_j^2 it may meet), is within
// tolerance^2 of the level's total; F = limit when none is. `above` is that bound; g runs to the
// map's own degree when the light stops short of it.
struct LevelDegree {
  std::vector<double> g;
  int degree = 0;
  double estimate = 0;  // sqrt(dropped / total)
  double total = 0, above = 0;
};
LevelDegree ChooseLevelDegree(SpecularLobe lobe, double alpha, const SpecularLight& light,
                              int limit, double tolerance) {
  LevelDegree out;
  const int top = light.total_energy > 0 ? std::max(limit, light.map_degree) : limit;
  out.g = SplitSumZonal(lobe, alpha, top);
  const std::vector<double>& g = out.g;
  const std::vector<double>& energy = light.energy;
  double total = 0, kept = 0;
  for (int l = 0; l <= limit; ++l) {
    total += g[l] * g[l] * energy[l];
    kept += energy[l];
  }
  double above = 0;
  if (top > limit) {
    double largest = 0;
    for (int j = limit + 1; j <= top; ++j) largest = std::max(largest, g[j] * g[j]);
    above = largest * std::max(0.0, light.total_energy - kept);
  }
  double tail = total;
  int f = limit;
  for (int l = 0; l <= limit; ++l) {
    tail -= g[l] * g[l] * energy[l];
    if (tail + above <= tolerance * tolerance * total) {
      f = l;
      break;
    }
  }
  out.degree = f;
  out.estimate = total > 0 ? std::sqrt(std::max(0.0, tail) + above) / std::sqrt(total) : 0.0;
  out.total = total;
  out.above = above;
  return out;
}

}  // namespace

bool SplitSumLightSuffices(const SpecularLight& light, const SplitSumSetOptions& options) {
  const double share = kFirstTryShare * options.tolerance * options.tolerance;
  const auto meets = [&](SpecularLobe lobe, double alpha) {
    if (!(alpha > 0)) return true;
    const LevelDegree d = ChooseLevelDegree(lobe, alpha, light, light.degree, options.tolerance);
    return d.above <= share * d.total;
  };
  for (double r : options.chain.roughness) {
    if (!meets(SpecularLobe::kGgx, r * r)) return false;
    if (options.sheen && !meets(SpecularLobe::kCharlie, r * r)) return false;
  }
  return meets(SpecularLobe::kLambert, 1.0);
}

SplitSumLightTry SplitSumLightTries(const EnvMap& map, const Mat3& rotation,
                                    const SplitSumSetOptions& options, const LightMoments& moments,
                                    bool peaks_split) {
  SplitSumLightTry t;
  t.full = SplitSumLightDegree(map, rotation, options, moments);
  // (Not with the sheen lobes of a whole map: on the bundled maps their bands reach the map's
  // limit, and a first try would only add a transform. Without its peaks they fall fast.)
  if (moments.known && (!options.sheen || peaks_split) &&
      t.full - kFirstTryBelow >= kFirstTryBelow) {
    t.first = t.full - kFirstTryBelow;
  }
  return t;
}

absl::StatusOr<SpecularLight> ComputeSplitSumLight(const EnvMap& map, const Mat3& rotation,
                                                   const SplitSumSetOptions& options, int threads) {
  if (threads < 1) return absl::InvalidArgumentError(absl::StrCat("IBL: threads = ", threads));
  PeakSplit split = SplitLightPeaks(map);
  const EnvMap& source = split.rest ? *split.rest : map;
  const LightMoments moments = SplitLightMoments(split, source);
  // SplitSumLightDegree's bound counts all the map's spread as possibly above D; the light's own
  // energies show how much is: the first try is kept when every level leaves little above it.
  const SplitSumLightTry tries =
      SplitSumLightTries(source, rotation, options, moments, split.rest.has_value());
  absl::StatusOr<SpecularLight> light;
  if (tries.first > 0) {
    light = LightToDegree(source, rotation, tries.first, threads, moments.total);
    if (!light.ok()) return light.status();
  }
  if (tries.first <= 0 || !SplitSumLightSuffices(*light, options)) {
    light = LightToDegree(source, rotation, tries.full, threads, moments.total);
    if (!light.ok()) return light.status();
  }
  light->peaks = RotatedPeaks(split.peaks, rotation);
  return light;
}

absl::StatusOr<SpecularChain> PrefilterSpecular(const EnvMap& map, const SpecularOptions& options,
                                                const SpecularLight* given) {
  const MipChain& chain = options.chain;
  if (chain.levels() < 1 || chain.roughness.size() != chain.face_size.size()) {
    return absl::InvalidArgumentError("IBL: the mip chain has no levels");
  }
  if (!(options.tolerance > 0 && options.tolerance < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("IBL: tolerance ", options.tolerance, " must be in (0, 1)"));
  }
  if (options.threads < 1) {
    return absl::InvalidArgumentError(absl::StrCat("IBL: threads = ", options.threads));
  }
  bool any_convolved = false;
  for (double r : chain.roughness) any_convolved |= r > 0;
  SpecularChain out;
  out.lobe = options.lobe;
  SpecularLight computed;
  const SpecularLight* light = given;
  if (any_convolved && light == nullptr) {
    auto l = ComputeSpecularLight(map, options.rotation, options.max_degree, options.threads);
    if (!l.ok()) return l.status();
    computed = std::move(l).value();
    light = &computed;
  }
  int limit = 0;
  if (light != nullptr) {
    limit = light->degree;
    if (options.max_degree > 0) limit = std::min(limit, options.max_degree);
    out.light_degree = light->degree;
    out.peaks = static_cast<int>(light->peaks.size());
    out.peak_threshold = light->peaks.threshold;
  }
  const Mat3 inverse = options.rotation.Transposed();
  SynthesisScratch local;
  SynthesisScratch* scratch = options.scratch != nullptr ? options.scratch : &local;
  // The convolved levels first, the resampled ones (roughness 0) after, with the synthesis's
  // working storage released in between when it is this call's own: the base cube then takes
  // those freed blocks instead of fresh memory, each fresh huge page of which the kernel zeroes
  // on first touch (about 1.5 ms a 2 MiB page in a paravirtualized VM; docs/architecture.md
  // "Start-up"). The levels are independent: the order changes no value.
  std::vector<int> order;
  for (int pass = 0; pass < 2; ++pass) {
    for (int k = 0; k < chain.levels(); ++k) {
      if ((chain.roughness[k] > 0) == (pass == 0)) order.push_back(k);
    }
  }
  std::vector<SpecularLevel> levels(chain.levels());
  for (const int k : order) {
    if (chain.roughness[k] <= 0 && scratch == &local) local = SynthesisScratch();
    SpecularLevel level;
    level.face_size = chain.face_size[k];
    level.roughness = chain.roughness[k];
    level.alpha = level.roughness * level.roughness;
    RadianceCube& cube = level.cube;
    cube.face_size = level.face_size;
    cube.channels = 3;
    // (Convolved levels take the synthesis's buffer below: zeroing one here would only add the
    // first-touch page faults of another cube.)
    if (level.alpha <= 0) cube.data.assign(cube.size(), 0.0f);
    // (A 1 x 1 face's centre coordinate is 0, whose mirror image is +0 rather than -0: the
    // generic path.)
    const std::optional<Yaw> yaw = YawOf(options.rotation);
    if (level.alpha <= 0 && level.face_size >= 2 && map.lat_long_image() != nullptr && yaw) {
      // R = RotationY(psi) moves azimuth atan2(x, -z) by -psi; the lookup R^-1 d adds psi.
      const double psi = options.rotation.IsIdentity() ? 0.0 : std::atan2(yaw->sin, yaw->cos);
      ResampleLatLongBase(map, level.face_size, options.threads, psi, cube);
      levels[k] = std::move(level);
      continue;
    }
    if (level.alpha <= 0) {
      const int s = level.face_size;
      ParallelChunks(kCubeFaceCount * s, options.threads, [&](int begin, int end) {
        for (int row = begin; row < end; ++row) {
          const int face = row / s, y = row % s;
          for (int x = 0; x < s; ++x) {
            const std::array<float, 3> v =
                map.Radiance(inverse * CubeTexelDirection(face, x, y, s));
            for (int c = 0; c < 3; ++c) cube.data[cube.Index(face, x, y, c)] = v[c];
          }
        }
      });
      levels[k] = std::move(level);
      continue;
    }
    const LevelDegree choice =
        ChooseLevelDegree(options.lobe, level.alpha, *light, limit, options.tolerance);
    const std::vector<double>& g = choice.g;
    const int f = choice.degree;
    level.degree = f;
    level.truncation_estimate = choice.estimate;
    // The level's coefficients g_l L_lm, synthesized by the P = 0 SHRM path.
    std::vector<double> real(static_cast<size_t>(ShCount(f)) * 3);
    for (int l = 0; l <= f; ++l) {
      for (size_t i = static_cast<size_t>(l) * l * 3; i < static_cast<size_t>(l + 1) * (l + 1) * 3;
           ++i) {
        real[i] = g[l] * light->coeffs[i];
      }
    }
    ShrmGridOptions grid;
    grid.threads = options.threads;
    grid.alpha_samples = GridRings(g, light->energy, f, options.tolerance);
    grid.scratch = scratch;
    auto built = ShrmSynthesizer::RealZonalCube(f, 3, real, level.face_size, grid);
    if (!built.ok()) return built.status();
    cube.data = std::move(built->data);
    if (!light->peaks.empty()) {
      AddPeakSums(light->peaks, SplitSumPeakKernel(options.lobe, level.alpha), cube,
                  options.threads);
    }
    levels[k] = std::move(level);
  }
  out.levels = std::move(levels);
  return out;
}

LevelError MeasureLevelError(const EnvMap& map, SpecularLobe lobe, const SpecularLevel& level,
                             const Mat3& rotation, int count, uint64_t seed, int threads,
                             const PixelSumTable* table) {
  const LevelCheck check{lobe, &level, count, seed};
  return MeasureLevelErrors(map, {&check, 1}, rotation, threads, table)[0];
}

std::vector<LevelError> MeasureLevelErrors(const EnvMap& map, std::span<const LevelCheck> checks,
                                           const Mat3& rotation, int threads,
                                           const PixelSumTable* table) {
  // Each check's seeded texels and their world directions.
  struct Texels {
    std::vector<std::array<int, 3>> at;
    std::vector<Vec3> dirs;
  };
  std::vector<Texels> texels(checks.size());
  const Mat3 inverse = rotation.Transposed();
  for (size_t c = 0; c < checks.size(); ++c) {
    const int count = std::max(0, checks[c].count);
    const int s = checks[c].level->cube.face_size;
    std::mt19937_64 rng(checks[c].seed);
    const uint64_t n = static_cast<uint64_t>(kCubeFaceCount) * s * s;
    Texels& t = texels[c];
    t.at.resize(count);
    t.dirs.resize(count);
    for (int i = 0; i < count; ++i) {
      const uint64_t k = rng() % n;  // modulo bias < 2^-40 for these sizes
      t.at[i] = {static_cast<int>(k / (static_cast<uint64_t>(s) * s)), static_cast<int>(k % s),
                 static_cast<int>((k / s) % s)};
      t.dirs[i] = inverse * CubeTexelDirection(t.at[i][0], t.at[i][1], t.at[i][2], s);
    }
  }
  // The references: the map itself at alpha = 0, else the pixel sums, all in one pass.
  std::vector<std::vector<std::array<double, 3>>> want(checks.size());
  // One query per distinct (lobe, alpha, directions): checks of the same sums at the same
  // directions (the IBL job's irradiance cube and its SH9, both Lambert at one set of normals)
  // share it.
  std::vector<PixelSumTable::Query> queries;
  std::vector<int> query_of(checks.size(), -1);
  for (size_t c = 0; c < checks.size(); ++c) {
    const SpecularLevel& level = *checks[c].level;
    if (texels[c].dirs.empty()) continue;
    if (level.alpha <= 0) {
      for (const Vec3& d : texels[c].dirs)
        want[c].push_back(SplitSumReference(map, checks[c].lobe, 0.0, d));
      continue;
    }
    for (size_t q = 0; q < queries.size() && query_of[c] < 0; ++q) {
      const PixelSumTable::Query& other = queries[q];
      if (other.lobe == checks[c].lobe && other.alpha == level.alpha &&
          std::equal(other.dirs.begin(), other.dirs.end(), texels[c].dirs.begin(),
                     texels[c].dirs.end(), [](const Vec3& a, const Vec3& b) {
                       return a.x == b.x && a.y == b.y && a.z == b.z;
                     })) {
        query_of[c] = static_cast<int>(q);
      }
    }
    if (query_of[c] < 0) {
      query_of[c] = static_cast<int>(queries.size());
      queries.push_back({checks[c].lobe, level.alpha, texels[c].dirs});
    }
  }
  if (!queries.empty()) {
    std::optional<PixelSumTable> own;
    if (table == nullptr) table = &own.emplace(map);
    const std::vector<std::vector<std::array<double, 3>>> sums =
        table->PrefilteredMany(queries, threads);
    for (size_t c = 0; c < checks.size(); ++c)
      if (query_of[c] >= 0) want[c] = sums[query_of[c]];
  }
  std::vector<LevelError> errors(checks.size());
  for (size_t c = 0; c < checks.size(); ++c) {
    const int count = static_cast<int>(texels[c].dirs.size());
    if (count == 0) continue;
    const RadianceCube& cube = checks[c].level->cube;
    std::vector<double> got(count), ref(count);
    for (int i = 0; i < count; ++i) {
      const auto [face, x, y] = texels[c].at[i];
      double a = 0, b = 0;
      for (int ch = 0; ch < 3; ++ch) {
        a += kLuma[ch] * cube.data[cube.Index(face, x, y, ch)];
        b += kLuma[ch] * want[c][i][ch];
      }
      got[i] = a;
      ref[i] = b;
    }
    double mean = 0;
    for (double v : ref) mean += std::abs(v) / count;
    LevelError& e = errors[c];
    for (int i = 0; i < count; ++i) {
      // A black map has no scale (every reference 0): no error, as MeasureDirectionalError
      // counts it (0 / 0 made the RMS NaN, null in ibl.json).
      const double scale = std::max(std::abs(ref[i]), 0.01 * mean);
      const double d = scale > 0 ? std::abs(got[i] - ref[i]) / scale : 0.0;
      e.rms += d * d / count;
      e.max = std::max(e.max, d);
    }
    e.rms = std::sqrt(e.rms);
    e.count = count;
  }
  return errors;
}

absl::StatusOr<SplitSumSet> PrefilterSplitSumSet(const EnvMap& map, const SpecularLight& light,
                                                 const SplitSumSetOptions& options, int threads,
                                                 const PrefilterProgress& progress,
                                                 std::vector<StageTiming>* timings,
                                                 SynthesisScratch* scratch) {
  SplitSumSet set;
  SpecularOptions opt;
  // The caller's storage, or none: each call then has its own, released before its base level
  // (PrefilterSpecular).
  opt.scratch = scratch;
  opt.chain = options.chain;
  opt.tolerance = options.tolerance;
  opt.rotation = light.rotation;
  opt.threads = threads;
  auto t0 = std::chrono::steady_clock::now();
  auto stage = [&](const char* name) -> absl::Status {
    t0 = std::chrono::steady_clock::now();
    return progress ? progress(name) : absl::OkStatus();
  };
  auto done = [&](const char* name) {
    if (timings == nullptr) return;
    timings->push_back(
        {name,
         std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()});
  };
  SHRM_RETURN_IF_ERROR(stage("specular"));
  SHRM_ASSIGN_OR_RETURN(set.specular, PrefilterSpecular(map, opt, &light));
  done("specular");
  if (options.sheen) {
    SHRM_RETURN_IF_ERROR(stage("sheen"));
    opt.lobe = SpecularLobe::kCharlie;
    SHRM_ASSIGN_OR_RETURN(set.sheen, PrefilterSpecular(map, opt, &light));
    done("sheen");
  }
  SHRM_RETURN_IF_ERROR(stage("irradiance"));
  SpecularOptions diffuse = opt;
  diffuse.lobe = SpecularLobe::kLambert;
  const double one[] = {1.0};
  SHRM_ASSIGN_OR_RETURN(diffuse.chain,
                        MakeMipChain(RoughnessPreset::kExplicit, options.irradiance_size, 1, one));
  SHRM_ASSIGN_OR_RETURN(set.irradiance, PrefilterSpecular(map, diffuse, &light));
  set.radiance_sh9.assign(ShCount(2) * 3, 0.0);  // zeros above the degree of a tiny map
  std::copy_n(light.coeffs.begin(), std::min<size_t>(light.coeffs.size(), ShCount(2) * 3),
              set.radiance_sh9.begin());
  AddPeakCoefficients(light.peaks, 2, set.radiance_sh9);
  done("irradiance");
  return set;
}

}  // namespace shrm::ibl
