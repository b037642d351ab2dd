// Tests of the split-sum prefiltered radiance (core/ibl/split_sum.h) against independent
// references: the lobes' normalization (integral of D (n.h) over the hemisphere = 1), the zonal
// factors against a plain midpoint rule with std::legendre, the white furnace, the presets'
// published roughness formulas, and every level of the chain on the four bundled real maps
// against the brute-force pixel sum of the same integral (and a 1024-sample importance-sampled
// estimate, the way cmgen and glTF-IBL-Sampler compute it).
#include "core/ibl/split_sum.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/base/cubemap.h"
#include "core/envmap/lighting.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm::ibl {
namespace {

// data/envmaps/<name>, loaded with the default options.
absl::StatusOr<EnvMap> LoadBundled(const std::string& name) {
  EnvMapOptions options;
  options.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name};
  return EnvMap::Load(options);
}

constexpr const char* kMaps[] = {"courtyard.exr", "interior.exr", "city.exr", "forest.exr"};

TEST(SplitSumTest, LobesAreNormalizedOverTheHemisphere) {
  // integral D(cos h) cos h dw_h = 1 over the hemisphere, by a midpoint rule in cos h
  // substituted to resolve the peak (u = cos h).
  constexpr double kNormTol = 1e-6;  // midpoint rule with 2e6 nodes on a smooth integrand
  for (SpecularLobe lobe : {SpecularLobe::kGgx, SpecularLobe::kCharlie}) {
    for (double alpha : {0.05, 0.2, 0.5, 1.0}) {
      const int n = 2000000;
      double sum = 0;
      for (int i = 0; i < n; ++i) {
        // theta_h in [0, pi/2], midpoint.
        const double t = (i + 0.5) / n * kPi / 2;
        sum += LobeNdf(lobe, alpha, std::cos(t)) * std::cos(t) * std::sin(t);
      }
      sum *= 2 * kPi * (kPi / 2) / n;
      EXPECT_NEAR(sum, 1.0, kNormTol) << SpecularLobeName(lobe) << " alpha " << alpha;
    }
  }
}

TEST(SplitSumTest, ZonalFactorsMatchAMidpointRuleWithStdLegendre) {
  constexpr double kZonalTol = 2e-5;  // midpoint rule, 1e5 nodes, on kernels resolved by them
  for (SpecularLobe lobe : {SpecularLobe::kGgx, SpecularLobe::kCharlie}) {
    for (double alpha : {0.1, 0.3, 0.8}) {
      const int lmax = 40;
      const std::vector<double> g = SplitSumZonal(lobe, alpha, lmax);
      const int n = 100000;
      std::vector<double> want(lmax + 1, 0.0);
      double norm = 0;
      for (int i = 0; i < n; ++i) {
        const double t = (i + 0.5) / n * kPi / 2;
        const double w = SplitSumKernel(lobe, alpha, std::cos(t)) * std::sin(t);
        norm += w;
        for (int l = 0; l <= lmax; ++l) want[l] += w * std::legendre(l, std::cos(t));
      }
      for (int l = 0; l <= lmax; ++l) {
        EXPECT_NEAR(g[l], want[l] / norm, kZonalTol)
            << SpecularLobeName(lobe) << " alpha " << alpha << " l " << l;
      }
    }
  }
}

TEST(SplitSumTest, ZonalFactorsAtHighDegreeMatchAFineMidpointRule) {
  // The degrees of a 1024 x 512 map (up to 511) for the sharpest lobes of the presets, against
  // a midpoint rule in theta fine enough for both the lobe's peak (width ~ 2 alpha) and
  // P_511's oscillation (period ~ 0.012): 2e5 nodes, spacing 7.9e-6, relative error of the rule
  // ~ (h / width)^2 / 24 < 1e-8 on the peak and ~(511 h)^2 / 24 ~ 7e-7 on the top degrees.
  constexpr double kHighDegreeTol = 1e-6;
  constexpr int kLmax = 511;
  constexpr int kNodes = 200000;
  const std::pair<SpecularLobe, double> cases[] = {
      {SpecularLobe::kGgx, 0.134}, {SpecularLobe::kGgx, 0.3}, {SpecularLobe::kCharlie, 0.3}};
  for (const auto& [lobe, roughness] : cases) {
    {
      const double alpha = roughness * roughness;
      const std::vector<double> g = SplitSumZonal(lobe, alpha, kLmax);
      std::vector<double> want(kLmax + 1, 0.0);
      double norm = 0;
      for (int i = 0; i < kNodes; ++i) {
        const double t = (i + 0.5) / kNodes * kPi / 2, x = std::cos(t);
        const double w = SplitSumKernel(lobe, alpha, x) * std::sin(t);
        norm += w;
        double p0 = 1, p1 = x;
        want[0] += w;
        want[1] += w * x;
        for (int l = 2; l <= kLmax; ++l) {
          const double p2 = ((2 * l - 1) * x * p1 - (l - 1) * p0) / l;
          want[l] += w * p2;
          p0 = p1;
          p1 = p2;
        }
      }
      for (int l = 0; l <= kLmax; ++l) {
        ASSERT_NEAR(g[l], want[l] / norm, kHighDegreeTol)
            << SpecularLobeName(lobe) << " roughness " << roughness << " l " << l;
      }
    }
  }
}

TEST(SplitSumTest, ChecksAtTheSameNormalsShareTheirSumsAndKeepTheirOwnErrors) {
  // Two Lambert levels of the same face size checked with the same seed (the IBL job's irradiance
  // cube and its SH9): one pixel sum per normal for both, and each level's errors those it gets
  // alone; a third with another seed has its own normals.
  auto map = LoadBundled("city.exr");
  ASSERT_TRUE(map.ok()) << map.status();
  constexpr int kFace = 8, kCount = 12;
  SpecularLevel levels[3];
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.5f, 2.0f);
  for (SpecularLevel& level : levels) {
    level.face_size = kFace;
    level.roughness = level.alpha = 1;
    level.cube.face_size = kFace;
    level.cube.channels = 3;
    level.cube.data.resize(level.cube.size());
    for (float& v : level.cube.data) v = u(rng);
  }
  const LevelCheck checks[] = {{SpecularLobe::kLambert, &levels[0], kCount, 41},
                               {SpecularLobe::kLambert, &levels[1], kCount, 41},
                               {SpecularLobe::kLambert, &levels[2], kCount, 42}};
  const std::vector<LevelError> together = MeasureLevelErrors(*map, checks, Mat3::Identity(), 1);
  ASSERT_EQ(together.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    const LevelError alone = MeasureLevelError(*map, SpecularLobe::kLambert, levels[k],
                                               Mat3::Identity(), kCount, checks[k].seed, 1);
    EXPECT_EQ(together[k].count, kCount);
    EXPECT_EQ(together[k].rms, alone.rms) << k;
    EXPECT_EQ(together[k].max, alone.max) << k;
  }
  // Different cubes: different errors (the sharing did not hand one level's result to another).
  EXPECT_NE(together[0].rms, together[1].rms);
}

TEST(SplitSumTest, PixelSumTableIsTheReferenceSum) {
  // The jobs' batched single-precision sum against SplitSumReference (double, one sample at a
  // time) on a real map with a sun (courtyard, full size): single-precision directions and
  // block sums of 256 terms (measured: 1.5e-7 at most).
  constexpr double kTableTol = 2e-6;
  auto map = LoadBundled("courtyard.exr");
  ASSERT_TRUE(map.ok()) << map.status();
  const PixelSumTable table(*map);
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  std::vector<Vec3> dirs;
  for (int i = 0; i < 12; ++i)
    dirs.push_back(Vec3{gauss(rng), gauss(rng), gauss(rng)}.Normalized());
  // The brightest pixel's own direction: the sharpest peak the sum meets.
  const EnvSample* sun = &map->samples()[0];
  for (const EnvSample& s : map->samples())
    if (s.rgb[1] > sun->rgb[1]) sun = &s;
  dirs.push_back(sun->dir);
  const std::pair<SpecularLobe, double> lobes[] = {{SpecularLobe::kGgx, 0.018},
                                                   {SpecularLobe::kGgx, 0.25},
                                                   {SpecularLobe::kGgx, 1.0},
                                                   {SpecularLobe::kCharlie, 0.09},
                                                   {SpecularLobe::kLambert, 1.0}};
  // Each lobe alone, then all of them in one pass (PrefilteredMany, as the jobs' checks call
  // it), on 1 to 3 threads (whose runs of directions then span queries).
  std::vector<PixelSumTable::Query> queries;
  for (const auto& [lobe, alpha] : lobes) queries.push_back({lobe, alpha, dirs});
  std::vector<std::vector<std::vector<std::array<double, 3>>>> runs;
  for (const auto& q : queries) runs.push_back({table.Prefiltered(q.lobe, q.alpha, dirs, 2)});
  for (int threads = 1; threads <= 3; ++threads) {
    std::vector<std::vector<std::array<double, 3>>> many = table.PrefilteredMany(queries, threads);
    ASSERT_EQ(many.size(), queries.size());
    for (size_t q = 0; q < queries.size(); ++q) runs[q].push_back(std::move(many[q]));
  }
  double worst = 0;
  for (size_t q = 0; q < queries.size(); ++q) {
    const auto [lobe, alpha] = lobes[q];
    for (size_t i = 0; i < dirs.size(); ++i) {
      const std::array<double, 3> want = SplitSumReference(*map, lobe, alpha, dirs[i]);
      for (const auto& got : runs[q]) {
        ASSERT_EQ(got.size(), dirs.size());
        for (int c = 0; c < 3; ++c) {
          const double rel = std::abs(got[i][c] - want[c]) / std::abs(want[c]);
          worst = std::max(worst, rel);
          EXPECT_LE(rel, kTableTol) << SpecularLobeName(lobe) << " alpha " << alpha << " dir " << i;
        }
      }
    }
  }
  std::printf("PixelSumTable: largest relative difference %.1e\n", worst);
}

TEST(SplitSumTest, LambertFactorsAreTheClampedCosineClosedForm) {
  // Ramamoorthi & Hanrahan 2001, eq. 8: A_0 = pi, A_1 = 2 pi / 3, odd l > 1: 0, even l:
  // A_l = 2 pi (-1)^(l/2 - 1) / ((l + 2)(l - 1)) l! / (2^l ((l/2)!)^2); g_l = A_l / pi.
  constexpr double kClosedFormTol = 1e-12;  // graded Gauss-Legendre on a polynomial kernel
  const int lmax = 30;
  const std::vector<double> g = SplitSumZonal(SpecularLobe::kLambert, 1.0, lmax);
  for (int l = 0; l <= lmax; ++l) {
    double a;
    if (l == 0) {
      a = kPi;
    } else if (l == 1) {
      a = 2 * kPi / 3;
    } else if (l % 2 == 1) {
      a = 0;
    } else {
      const double lf = std::tgamma(l + 1.0), hf = std::tgamma(l / 2 + 1.0);
      a = 2 * kPi * ((l / 2 - 1) % 2 == 0 ? 1 : -1) / ((l + 2.0) * (l - 1.0)) * lf /
          (std::pow(2.0, l) * hf * hf);
    }
    EXPECT_NEAR(g[l], a / kPi, kClosedFormTol) << "l " << l;
  }
}

TEST(SplitSumTest, PresetsFollowTheConsumersFormulas) {
  auto f = MakeMipChain(RoughnessPreset::kFilament, 256, 0);
  ASSERT_TRUE(f.ok()) << f.status();
  ASSERT_EQ(f->levels(), 5);  // cmgen: 256 down to its 16 x 16 smallest level
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(f->face_size[k], 256 >> k);
    const double r = f->roughness[k];
    // Filament's shader: lod = (levels - 1) r (2 - r).
    EXPECT_NEAR(4 * r * (2 - r), k, 1e-12);
  }
  auto g = MakeMipChain(RoughnessPreset::kGltf, 256, 0);
  ASSERT_TRUE(g.ok()) << g.status();
  ASSERT_EQ(g->levels(), 8);  // glTF-IBL-Sampler: floor(log2(256)) mips
  for (int k = 0; k < 8; ++k) EXPECT_NEAR(g->roughness[k], k / 7.0, 1e-15);
  // Babylon.js: its glTF loader sets lodGenerationScale = (levels - 1) / log2(size) and its PBR
  // shader reads lod = log2(size alphaG) x lodGenerationScale; level k must hold that alpha.
  for (int levels : {0, 5}) {
    auto b = MakeMipChain(RoughnessPreset::kBabylon, 256, levels);
    ASSERT_TRUE(b.ok()) << b.status();
    const int n = levels == 0 ? 9 : levels;  // default: the full chain, 256 down to 1 x 1
    ASSERT_EQ(b->levels(), n);
    EXPECT_EQ(b->roughness[0], 0.0);
    EXPECT_EQ(b->face_size[n - 1], 256 >> (n - 1));
    for (int k = 1; k < n; ++k) {
      const double alpha = b->roughness[k] * b->roughness[k];
      EXPECT_NEAR(std::log2(256 * alpha) * (n - 1) / std::log2(256.0), k, 1e-12) << k;
    }
    EXPECT_NEAR(b->roughness[n - 1], 1.0, 1e-15);
  }
  const double list[] = {0, 0.5, 1};
  auto e = MakeMipChain(RoughnessPreset::kExplicit, 64, 0, list);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->levels(), 3);
  EXPECT_EQ(e->face_size[2], 16);

  EXPECT_FALSE(MakeMipChain(RoughnessPreset::kGltf, 100, 0).ok());   // not a power of two
  EXPECT_FALSE(MakeMipChain(RoughnessPreset::kGltf, 8192, 0).ok());  // too large
  EXPECT_FALSE(MakeMipChain(RoughnessPreset::kGltf, 16, 6).ok());    // 16 -> 1 is 5 levels
  EXPECT_FALSE(MakeMipChain(RoughnessPreset::kExplicit, 16, 0).ok());
  const double bad[] = {0, 0.7, 0.5};
  EXPECT_FALSE(MakeMipChain(RoughnessPreset::kExplicit, 16, 0, bad).ok());
  const double out_of_range[] = {0, 1.5};
  EXPECT_FALSE(MakeMipChain(RoughnessPreset::kExplicit, 16, 0, out_of_range).ok());
}

TEST(SplitSumTest, WhiteFurnaceIsConstantOnEveryLevel) {
  constexpr double kFurnaceTol = 1e-5;  // float storage of a unit radiance
  Image img;
  img.width = 128;
  img.height = 64;
  img.channels = 3;
  img.pixels.assign(128 * 64 * 3, 1.0f);
  const EnvMap map = EnvMap::FromLatLong(img);
  for (SpecularLobe lobe : {SpecularLobe::kGgx, SpecularLobe::kCharlie, SpecularLobe::kLambert}) {
    SpecularOptions opt;
    opt.lobe = lobe;
    opt.chain = *MakeMipChain(RoughnessPreset::kGltf, 16, 0);
    auto chain = PrefilterSpecular(map, opt);
    ASSERT_TRUE(chain.ok()) << chain.status();
    for (const SpecularLevel& level : chain->levels)
      for (float v : level.cube.data) ASSERT_NEAR(v, 1.0, kFurnaceTol);
  }
}

// Relative error per direction as the accuracy issue defines it: |got - ref| / max(|ref|,
// 0.01 mean |ref|) on luminance, RMS and largest over the directions.
struct RelativeError {
  double rms = 0, max = 0;
};

double Luma(const std::array<double, 3>& v) {
  return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

RelativeError Compare(const std::vector<double>& got, const std::vector<double>& ref) {
  double mean = 0;
  for (double v : ref) mean += std::abs(v) / ref.size();
  RelativeError e;
  for (size_t i = 0; i < ref.size(); ++i) {
    const double d = std::abs(got[i] - ref[i]) / std::max(std::abs(ref[i]), 0.01 * mean);
    e.rms += d * d / ref.size();
    e.max = std::max(e.max, d);
  }
  e.rms = std::sqrt(e.rms);
  return e;
}

// Bilinear lookup of a lat-long image, written from docs/conventions.md (pixel (i, j) at
// p = 2 pi ((i + 0.5) / W - 0.5), theta = pi (j + 0.5) / H, d = (sin t sin p, cos t,
// -sin t cos p)); wraps in azimuth, clamps at the poles.
std::array<double, 3> LatLongBilinear(const Image& img, const Vec3& d) {
  const double p = std::atan2(d.x, -d.z), theta = std::acos(std::clamp(d.y, -1.0, 1.0));
  const double x = (p / (2 * kPi) + 0.5) * img.width - 0.5;
  const double y = std::clamp(theta / kPi * img.height - 0.5, 0.0, img.height - 1.0);
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  std::array<double, 3> out{};
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      const int xi = ((x0 + dx) % img.width + img.width) % img.width;
      const int yi = std::min(y0 + dy, img.height - 1);
      const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      for (int c = 0; c < 3; ++c) out[c] += w * img.at(xi, yi, c);
    }
  return out;
}

TEST(SplitSumTest, EveryLevelMatchesThePixelSumOnTheBundledMaps) {
  // RGBA32F storage: the bound for float levels against the brute-force pixel sum.
  constexpr double kLevelRmsTol = 1e-3;
  // Largest relative error at a texel centre (the engine-outputs issue allows 5%; measured
  // <= 3e-3 at the default tolerance).
  constexpr double kLevelMaxTol = 1e-2;
  // Float storage of bilinear values.
  constexpr double kBaseTol = 1e-5;
  constexpr int kDirections = 48;
  constexpr int kImportanceSamples = 1024;
  for (const char* name : kMaps) {
    auto map = LoadBundled(name);
    ASSERT_TRUE(map.ok()) << map.status();
    SpecularOptions opt;
    opt.chain = *MakeMipChain(RoughnessPreset::kFilament, 128, 0);
    opt.threads = 2;
    auto chain = PrefilterSpecular(*map, opt);
    ASSERT_TRUE(chain.ok()) << chain.status();
    ASSERT_EQ(chain->levels.size(), 4u);
    std::mt19937 rng(7);
    for (const SpecularLevel& level : chain->levels) {
      const int s = level.face_size;
      std::uniform_int_distribution<int> pick(0, 6 * s * s - 1);
      std::vector<double> got, ref, sampled;
      for (int i = 0; i < kDirections; ++i) {
        const int t = pick(rng), face = t / (s * s), y = (t / s) % s, x = t % s;
        const Vec3 r = CubeTexelDirection(face, x, y, s);
        std::array<double, 3> v;
        for (int c = 0; c < 3; ++c) v[c] = level.cube.data[level.cube.Index(face, x, y, c)];
        if (level.alpha == 0) {
          const std::array<double, 3> want = LatLongBilinear(*map->lat_long_image(), r);
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(v[c], want[c], kBaseTol * std::max(1.0, want[c])) << name;
          continue;
        }
        got.push_back(Luma(v));
        ref.push_back(Luma(SplitSumReference(*map, SpecularLobe::kGgx, level.alpha, r)));
        sampled.push_back(Luma(ImportanceSampledGgx(*map, level.alpha, r, kImportanceSamples)));
      }
      if (level.alpha == 0) continue;
      const RelativeError e = Compare(got, ref), is = Compare(sampled, ref);
      std::printf(
          "%-14s S %3d r %.3f F %3d est %.1e: rms %.1e max %.1e (1024 samples: %.1e %.1e)\n", name,
          s, level.roughness, level.degree, level.truncation_estimate, e.rms, e.max, is.rms,
          is.max);
      EXPECT_LE(e.rms, kLevelRmsTol) << name << " level " << s;
      EXPECT_LE(e.max, kLevelMaxTol) << name << " level " << s;
      EXPECT_LT(e.rms, is.rms) << name << " level " << s << ": not better than sampling";
      EXPECT_LT(e.max, is.max) << name << " level " << s << ": not better than sampling";
    }
  }
}

// The light `shrm ibl` uses stops at the degree its lobes need (SplitSumLightDegree), not at the
// map's 511. Checked against the transform to the map's full degree on the bundled maps: the
// moments are that transform's E_0 and bound its energy (Parseval), what the chosen degree leaves
// out of every level is within its share of the tolerance and below the bound the chain counts,
// and each level's degree drops no more than its tolerance of the full spectrum.
TEST(SplitSumTest, SplitSumLightDegreeBoundsWhatItLeavesOut) {
  // E_0 from the pixels against the transform's constant band: the same sum in another order.
  constexpr double kMomentTol = 1e-9;
  // The chain's tail, total - (running sum), carries the rounding of ~F additions of terms up
  // to the total: 1e-13 of the total covers F <= 511 (511 x 2^-53 = 5.7e-14).
  constexpr double kTailRounding = 1e-13;
  for (const char* name : kMaps) {
    for (const bool sheen : {false, true}) {
      auto map = LoadBundled(name);
      ASSERT_TRUE(map.ok()) << map.status();
      SplitSumSetOptions options;
      options.chain = *MakeMipChain(RoughnessPreset::kFilament, 256, 0);
      options.tolerance = 1e-3 / 30;  // the job's default (jobs/ibl_job.h)
      options.sheen = sheen;
      // The light is that of the map less its peaks (SplitLightPeaks) where they are split:
      // everything below is about what is transformed.
      const PeakSplit split = SplitLightPeaks(*map);
      const EnvMap& source = split.rest ? *split.rest : *map;
      // The maps with a sun are split; courtyard is not.
      EXPECT_EQ(split.rest.has_value(), std::string(name) != "courtyard.exr") << name;
      auto full = ComputeSpecularLight(source, Mat3::Identity(), 0, 1);
      ASSERT_TRUE(full.ok()) << full.status();
      const LightMoments moments = SplitLightMoments(split, source);
      ASSERT_TRUE(moments.known);
      // The split's own sums are the rest's (or the map's) moments.
      const LightMoments summed = MapLightMoments(source);
      EXPECT_NEAR(moments.e0, summed.e0, kMomentTol * summed.e0) << name;
      EXPECT_NEAR(moments.total, summed.total, kMomentTol * summed.total) << name;
      EXPECT_NEAR(moments.e0, full->energy[0], kMomentTol * full->energy[0]) << name;
      double sum_all = 0;
      for (double e : full->energy) sum_all += e;
      EXPECT_GE(moments.total, sum_all) << name << ": Parseval";
      const int d = SplitSumLightDegree(source, Mat3::Identity(), options, moments);
      ASSERT_GE(d, 0);
      ASSERT_LE(d, full->degree);
      // ComputeSplitSumLight transforms to the first try when it suffices, else to d; the share
      // of each level's tolerance left above is the one granted to the degree it kept.
      const SplitSumLightTry tries =
          SplitSumLightTries(source, Mat3::Identity(), options, moments, split.rest.has_value());
      ASSERT_EQ(tries.full, d);
      auto light = ComputeSplitSumLight(*map, Mat3::Identity(), options, 1);
      ASSERT_TRUE(light.ok()) << light.status();
      EXPECT_EQ(light->peaks.size(), split.peaks.size()) << name;
      const bool first_kept = tries.first > 0 && light->degree == tries.first;
      ASSERT_TRUE(first_kept || light->degree == d) << name << " degree " << light->degree;
      const double share = first_kept ? kFirstTryShare : kLightTailShare;
      const int used = light->degree;
      for (int l = 0; l <= used; ++l) {
        ASSERT_NEAR(light->energy[l], full->energy[l], 1e-9 * full->energy[l] + 1e-300)
            << name << " l " << l;
      }
      std::printf("%-14s sheen %d: light degree %d (bound %d) of %d\n", name, sheen, used, d,
                  full->degree);
      // Courtyard's spectrum falls fast enough for the GGX and Lambert lobes to stop well short,
      // and its energies let the first try stand.
      if (std::string(name) == "courtyard.exr" && !sheen) {
        EXPECT_LT(d, full->degree - 64);
        EXPECT_TRUE(first_kept);
      }
      const auto check = [&](SpecularLobe lobe, const MipChain& chain) {
        SpecularOptions opt;
        opt.lobe = lobe;
        opt.chain = chain;
        opt.tolerance = options.tolerance;
        auto got = PrefilterSpecular(*map, opt, &*light);
        ASSERT_TRUE(got.ok()) << got.status();
        for (const SpecularLevel& level : got->levels) {
          if (level.alpha == 0) continue;
          const std::vector<double> g = SplitSumZonal(lobe, level.alpha, full->degree);
          double total = 0, above_d = 0, above_f = 0;
          for (int l = 0; l <= full->degree; ++l) {
            const double t = g[l] * g[l] * full->energy[l];
            total += t;
            if (l > used) above_d += t;
            if (l > level.degree) above_f += t;
          }
          const double tol2 = options.tolerance * options.tolerance;
          EXPECT_LE(above_d, share * tol2 * total)
              << name << " " << SpecularLobeName(lobe) << " r " << level.roughness;
          EXPECT_LE(above_f, tol2 * total)
              << name << " " << SpecularLobeName(lobe) << " r " << level.roughness;
          // The reported estimate counts the bound, so it is not below the true tail.
          EXPECT_GE(level.truncation_estimate * level.truncation_estimate + kTailRounding,
                    above_f / total)
              << name << " " << SpecularLobeName(lobe) << " r " << level.roughness;
        }
      };
      check(SpecularLobe::kGgx, options.chain);
      if (sheen) check(SpecularLobe::kCharlie, options.chain);
      const double one[] = {1.0};
      check(SpecularLobe::kLambert, *MakeMipChain(RoughnessPreset::kExplicit, 32, 1, one));
    }
  }
}

TEST(SplitSumTest, BaseLevelIsTheMapAtEveryTexelCentre) {
  // The base level's table-driven lookups against the test's own bilinear lookup at every texel
  // of every face (the angles agree to the rounding of the direction's normalization), without
  // rotation, turned by yaws (the same tables, the azimuth offset) and by a general rotation
  // (the per-texel path); the rotated lighting is looked up at R^-1 d.
  constexpr double kBaseTol = 1e-5;
  auto map = LoadBundled("city.exr");
  ASSERT_TRUE(map.ok()) << map.status();
  const Mat3 rotations[] = {Mat3::Identity(), RotationFromYawPitchRoll(37, 0, 0),
                            RotationFromYawPitchRoll(-150, 0, 0),
                            RotationFromYawPitchRoll(20, 30, -10)};
  // (Not S = 1: its texels look exactly at the poles, where the azimuth, and so the lat-long
  // row's pixel, depends on the sign of a zero.)
  for (const Mat3& rotation : rotations) {
    for (int s : {2, 4, 64}) {
      SpecularOptions opt;
      const double zero[] = {0.0};
      opt.chain = *MakeMipChain(RoughnessPreset::kExplicit, s, 1, zero);
      opt.rotation = rotation;
      auto chain = PrefilterSpecular(*map, opt);
      ASSERT_TRUE(chain.ok()) << chain.status();
      const RadianceCube& cube = chain->levels[0].cube;
      for (int face = 0; face < kCubeFaceCount; ++face)
        for (int y = 0; y < s; ++y)
          for (int x = 0; x < s; ++x) {
            const std::array<double, 3> want = LatLongBilinear(
                *map->lat_long_image(), rotation.Transposed() * CubeTexelDirection(face, x, y, s));
            for (int c = 0; c < 3; ++c) {
              ASSERT_NEAR(cube.data[cube.Index(face, x, y, c)], want[c],
                          kBaseTol * std::max(1.0, want[c]))
                  << "S " << s << " face " << face << " texel " << x << "," << y << " rotation "
                  << rotation.m[0][0] << "," << rotation.m[0][2];
            }
          }
    }
  }
}

TEST(SplitSumTest, SheenAndLambertLevelsMatchThePixelSum) {
  constexpr double kLevelRmsTol = 1e-3;  // as for GGX: float storage, the bound
  constexpr double kLevelMaxTol = 1e-2;
  auto map = LoadBundled("city.exr");
  ASSERT_TRUE(map.ok()) << map.status();
  const double list[] = {0.3, 0.6, 1.0};
  for (SpecularLobe lobe : {SpecularLobe::kCharlie, SpecularLobe::kLambert}) {
    SpecularOptions opt;
    opt.lobe = lobe;
    opt.chain = *MakeMipChain(RoughnessPreset::kExplicit, 32, 0, list);
    opt.threads = 2;
    auto chain = PrefilterSpecular(*map, opt);
    ASSERT_TRUE(chain.ok()) << chain.status();
    std::mt19937 rng(11);
    for (const SpecularLevel& level : chain->levels) {
      const int s = level.face_size;
      std::uniform_int_distribution<int> pick(0, 6 * s * s - 1);
      std::vector<double> got, ref;
      for (int i = 0; i < 32; ++i) {
        const int t = pick(rng), face = t / (s * s), y = (t / s) % s, x = t % s;
        std::array<double, 3> v;
        for (int c = 0; c < 3; ++c) v[c] = level.cube.data[level.cube.Index(face, x, y, c)];
        got.push_back(Luma(v));
        ref.push_back(
            Luma(SplitSumReference(*map, lobe, level.alpha, CubeTexelDirection(face, x, y, s))));
      }
      const RelativeError e = Compare(got, ref);
      EXPECT_LE(e.rms, kLevelRmsTol) << SpecularLobeName(lobe) << " r " << level.roughness;
      EXPECT_LE(e.max, kLevelMaxTol) << SpecularLobeName(lobe) << " r " << level.roughness;
    }
  }
}

TEST(SplitSumTest, MeasuredLevelErrorSeesAKnownPerturbation) {
  // A level filled with the reference itself measures ~0; scaled by 1.01 it measures 0.01.
  constexpr double kExactTol = 1e-6;  // float storage of the reference values
  constexpr double kScaleTol = 1e-5;
  Image img = testing::LoadBundledMap("forest.exr", 128);
  const EnvMap map = EnvMap::FromLatLong(img);
  SpecularLevel level;
  level.face_size = 8;
  level.roughness = 0.5;
  level.alpha = 0.25;
  level.cube.face_size = 8;
  level.cube.data.resize(level.cube.size());
  for (int f = 0; f < 6; ++f)
    for (int y = 0; y < 8; ++y)
      for (int x = 0; x < 8; ++x) {
        const auto v =
            SplitSumReference(map, SpecularLobe::kGgx, 0.25, CubeTexelDirection(f, x, y, 8));
        for (int c = 0; c < 3; ++c) level.cube.data[level.cube.Index(f, x, y, c)] = v[c];
      }
  const LevelError exact =
      MeasureLevelError(map, SpecularLobe::kGgx, level, Mat3::Identity(), 40, 3, 2);
  EXPECT_EQ(exact.count, 40);
  EXPECT_LE(exact.max, kExactTol);
  for (float& v : level.cube.data) v *= 1.01f;
  const LevelError scaled =
      MeasureLevelError(map, SpecularLobe::kGgx, level, Mat3::Identity(), 40, 3, 1);
  EXPECT_NEAR(scaled.rms, 0.01, kScaleTol);
  EXPECT_NEAR(scaled.max, 0.01, kScaleTol);
}

}  // namespace
}  // namespace shrm::ibl
