// Tests of an SHRM's peak lights (PrefilterOptions::peak_lights, ShrmCube::lights; docs/shrm.md
// "Peak lights") against independent references: the lights are the split pixels of the map (the
// brute-force pixel sum of the whole map equals that of the rest plus the lights' sum, rotated
// too); they survive the file (and a damaged shrm:lights is refused); and on the bundled map whose
// lamps defeat the expansion, the default job with them meets the per-direction targets at pairs
// it did not choose or check with, against the pixel sum of the whole map.
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "core/base/cubemap.h"
#include "core/brdf/brdf.h"
#include "core/envmap/light_split.h"
#include "core/envmap/lighting.h"
#include "core/shrm/fast_reference.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/tolerance.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

absl::StatusOr<EnvMap> LoadBundled(const std::string& name) {
  EnvMapOptions options;
  options.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name};
  return EnvMap::Load(options);
}

Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3{g(rng), g(rng), g(rng)}.Normalized();
}

TEST(PeakLightsTest, LightsAreTheSplitPixelsOfTheMapRotated) {
  // The rest's pixel sum plus the lights' equals the whole map's: both are sums of the same
  // pixels' L dOmega rho-hat in double precision, but the lights' weights are stored in single
  // precision (2^-24 relative of each) and the sums of ~32k pixels round at ~1e-12 relative.
  constexpr double kSumTol = 1e-6;
  const Image img = testing::LoadBundledMap("interior.exr", 256);
  const EnvMap map = EnvMap::FromLatLong(img);
  const PeakSplit split = SplitLightPeaks(map);
  ASSERT_TRUE(split.rest.has_value()) << "interior's lamps are split";
  const std::vector<EnvSample> whole = testing::LatLongSamples(img);
  const std::vector<EnvSample> rest = testing::LatLongSamples(*split.rest->lat_long_image());
  auto brdf = ParseBrdfSpec("ggx:alpha=0.1,f0=0.04");
  ASSERT_TRUE(brdf.ok()) << brdf.status();
  PrefilterOptions options;
  options.f = 6;  // the expansion is not under test: small orders keep the job quick
  options.p = 2;
  options.face_size = 8;
  options.peak_lights = PeakLights::kOn;
  options.rotation = RotationFromYawPitchRoll(25, -20, 60);
  absl::StatusOr<PrefilterResult> r = Prefilter(map, **brdf, options);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->cube.lights.size(), split.peaks.size());
  EXPECT_EQ(r->peak_threshold, split.peaks.threshold);
  std::mt19937 rng(7);
  int lit = 0;
  for (int k = 0; k < 64; ++k) {
    const Vec3 n = RandomUnit(rng);
    Vec3 v = RandomUnit(rng);
    if (v.Dot(n) < 0) v = v * -1.0;
    const auto all = BrdfReferenceRadiance(whole, **brdf, options.rotation, n, v);
    const auto part = BrdfReferenceRadiance(rest, **brdf, options.rotation, n, v);
    const auto lights = ShrmLightsRadiance(r->cube, **brdf, n, v);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(part[c] + lights[c], all[c], kSumTol * std::abs(all[c]) + 1e-12)
          << "pair " << k << " channel " << c;
    }
    if (lights[1] > 0.01 * all[1]) ++lit;
  }
  EXPECT_GT(lit, 4) << "some pairs see the lamps (else the check would be empty)";
  // `shrm render`'s per-view map holds the lights too: at a texel centre R, the map is the
  // evaluation at the normal that reflects V into R (the texel itself, no interpolation). The
  // map is single precision.
  constexpr double kMapTol = 1e-5;
  const Vec3 view = Vec3{0.3, 0.5, 0.8}.Normalized();
  absl::StatusOr<RadianceCube> map_for_view = ReflectionMapForView(r->cube, view, 2);
  ASSERT_TRUE(map_for_view.ok()) << map_for_view.status();
  AddLightsToViewMap(r->cube, **brdf, view, *map_for_view, 2);
  const int s = map_for_view->face_size;
  for (int face = 0; face < 6; ++face)
    for (int y = 1; y < s; y += 3)
      for (int x = 0; x < s; x += 3) {
        const Vec3 texel = CubeTexelDirection(face, x, y, s);
        const Vec3 n = (texel + view).Normalized();
        if (!(n.Dot(view) > 0.05)) continue;  // (V near -R: the normal is ill-defined)
        const auto want = ShrmEvalWithLights(r->cube, **brdf, n, view);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(map_for_view->data[map_for_view->Index(face, x, y, c)], want[c],
                      kMapTol * (std::abs(want[c]) + 1e-3))
              << "face " << face << " texel " << x << "," << y;
      }
  // Without the split asked, no lights.
  options.peak_lights = PeakLights::kOff;
  absl::StatusOr<PrefilterResult> plain = Prefilter(map, **brdf, options);
  ASSERT_TRUE(plain.ok()) << plain.status();
  EXPECT_TRUE(plain->cube.lights.empty());
  EXPECT_EQ(plain->peak_threshold, 0);
}

TEST(PeakLightsTest, LightsSurviveTheFileAndDamagedListsAreRefused) {
  ShrmCube cube;
  cube.face_size = 2;
  cube.pmax = 1;
  cube.data.assign(cube.size(), 0.5f);
  cube.lights = {{{0.6f, 0.8f, 0.0f}, {1.5f, 2.25f, 3.0f}},
                 {{0.0f, -1.0f, 0.0f}, {1e-3f, 0.0f, 7.0f}}};
  const std::string path = ::testing::TempDir() + "/lights.shrm.exr";
  ASSERT_TRUE(WriteShrmFile(path, cube, {{"shrm:brdf", "phong:s=8"}}).ok());
  absl::StatusOr<ShrmFile> back = ReadShrmFile(path);
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->cube.lights.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back->cube.lights[k].dir, cube.lights[k].dir);  // %.9g round-trips a float
    EXPECT_EQ(back->cube.lights[k].weight, cube.lights[k].weight);
  }
  EXPECT_EQ(BrdfAttribute(*back), "phong:s=8");
  // A file without lights reads back without them.
  cube.lights.clear();
  ASSERT_TRUE(WriteShrmFile(path, cube, {}).ok());
  back = ReadShrmFile(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(back->cube.lights.empty());
  // Damaged lists: each refused with the attribute named.
  std::map<std::string, std::string> attrs = ShrmConventionAttributes(cube);
  for (const char* bad : {"", "x", "2 0 1 0 1 1 1", "1 0 1 0 1 1", "1 0 2 0 1 1 1",
                          "1 0 1 0 nan 1 1", "1 0 1 0 inf 1 1", "99999 0 1 0 1 1 1"}) {
    attrs["shrm:lights"] = bad;
    ShrmCube parsed;
    const absl::Status s = ParseShrmConventionAttributes("f.exr", attrs, &parsed);
    EXPECT_FALSE(s.ok()) << "'" << bad << "'";
    EXPECT_NE(s.message().find("shrm:lights"), std::string::npos) << s.message();
  }
}

// The default job (jobs/prefilter_job.cc CorePrefilterOptions, peak lights auto) of `brdf` on a
// bundled map, measured at kPairs pairs the job neither chose nor checked with, against the pixel
// sum of the whole map (FastReference, within 2e-3 of it per direction: fast_reference_test).
constexpr double kDefaultTolerance = 0.01;          // the default job's
constexpr uint64_t kTestSeed = 0x5045414b4c495431;  // "PEAKLIT1": neither job seed
void MeasureDefaultJob(const char* map_name, const char* brdf_spec, PrefilterResult* result,
                       DirectionalError* error, int pairs_count = 512, uint64_t seed = kTestSeed) {
  auto map = LoadBundled(map_name);
  ASSERT_TRUE(map.ok()) << map.status();
  auto brdf = ParseBrdfSpec(brdf_spec);
  ASSERT_TRUE(brdf.ok()) << brdf.status();
  PrefilterOptions options;
  options.tolerance = kDefaultTolerance;
  options.window = RingingWindow::kAuto;
  options.view = ViewVariable::kNormal;
  options.try_other_view = true;
  options.size_budget_values = 256e6 / 4;
  options.threads = 2;
  options.peak_lights = PeakLights::kAuto;
  absl::StatusOr<PrefilterResult> r = Prefilter(*map, **brdf, options);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_FALSE(r->cube.lights.empty()) << map_name << ": " << r->peak_lights_note;
  const std::vector<DirectionPair> pairs =
      StratifiedDirectionPairs(seed, pairs_count, ReparamKind::kReflection);
  absl::StatusOr<FastReference> reference = FastReference::Create(*map);
  ASSERT_TRUE(reference.ok()) << reference.status();
  std::vector<Rgb> got, ref;
  for (const DirectionPair& p : pairs) {
    got.push_back(ShrmEvalWithLights(r->cube, **brdf, p.index, p.view));
    ref.push_back(reference->Radiance(**brdf, Mat3::Identity(), p.index, p.view));
  }
  *error = MeasureDirectionalError(pairs, got, ref);
  std::printf(
      "%s %s with %zu lights, (%d, %d) S %d: front RMS %.4f, largest %.4f; grazing RMS %.4f\n",
      map_name, brdf_spec, r->cube.lights.size(), r->analysis.f_b, r->analysis.p_b,
      r->cube.face_size, error->front.rms, error->front.max, error->grazing.rms);
  *result = *std::move(r);
}

// Both RMS targets and no negative value, at the default job's tolerance.
void ExpectRmsTargetsMet(const PrefilterResult& r, const DirectionalError& e) {
  const ToleranceTargets targets = TargetsForTolerance(kDefaultTolerance, r.cube.view);
  EXPECT_LE(e.front.rms, targets.rms);
  ASSERT_TRUE(targets.grazing);  // the normal variable's grazing RMS is a target
  EXPECT_LE(e.grazing.rms, targets.grazing_rms);
  EXPECT_EQ(e.negative, 0);
}

TEST(PeakLightsTest, InteriorsLampsNoLongerDefeatTheDefaultJob) {
  // interior.exr's lamps sit near the horizon of many normals: the default job without lights is
  // budget-limited at (97, 31), a 231 MB file, and measures 5.7% front RMS, 144% largest and 46%
  // grazing RMS at 1024 pairs (docs/results.md, "Accuracy, session 35"). With them (and the
  // rest's orders chosen at 1024 stratified pairs, kLightsSelectionFactor) the file is (36, 24)
  // at S 56 (141 MB) and meets both RMS targets: 0.41% front, 1.9% grazing. The largest front
  // error, 8.7% at this seed (4.0% at the job's own 1024 pairs), is printed, not asserted: its 5%
  // target is not met at every seed yet (docs/results.md, "Peak lights, session 36" and
  // "Stratified selection, session 37").
  PrefilterResult r;
  DirectionalError e;
  MeasureDefaultJob("interior.exr", "microfacet:sigma=0.2", &r, &e);
  if (HasFatalFailure()) return;
  ExpectRmsTargetsMet(r, e);
}

TEST(PeakLightsTest, ForestsBrightSkyIsSplitByDefault) {
  // forest.exr's 128 brightest pixels (a bright sky, not a sun) leave 11% of its non-constant
  // energy in the rest. Until session 45 the default split only a sun (at most 1% left), and
  // forest's microfacet sigma 0.3 default, (25, 22) at S 32, measured 1.01% front RMS, 12.7%
  // largest and 4.2% grazing RMS at this test's pairs (0.53%, 9.8%, 8.1% at the job's 1024):
  // an RMS target missed at either. Split, (27, 25) at S 40: 0.40%, 7.6%, 1.6% here (0.27%,
  // 5.4%, 2.7% at the job's); docs/results.md "Session 45". The largest error is printed only,
  // as above.
  PrefilterResult r;
  DirectionalError e;
  MeasureDefaultJob("forest.exr", "microfacet:sigma=0.3", &r, &e);
  if (HasFatalFailure()) return;
  ExpectRmsTargetsMet(r, e);
}

// The largest error rests on single pairs: where the surface's horizon cuts a lobe through bright
// light (N.V just above 0.3) the series in p converges like 1/P, at pairs the selection's own
// seldom hold. Before the selection asked half the largest-error target of a view-dependent
// BRDF's truncation (kViewLargestShare, session 46), forest's microfacet sigma 0.3 default,
// (27, 25) at S 40, measured 5.4% largest at the job's own 1024 check pairs (one pair at N.V
// 0.36), and city's GGX alpha 0.3 f0 0.04 default, (20, 12) at S 32, 9.9% at 1024 pairs of seed
// 777; now (29, 29) at S 40 and (23, 17) at S 32: 3.2% and 2.5% (docs/results.md "Session 46").
// Both the largest and the RMS targets are asserted here, at 1024 pairs neither job drew.
TEST(PeakLightsTest, LargestErrorHoldsAtPairsTheSelectionNeverSaw) {
  struct Case {
    const char* map;
    const char* brdf;
    uint64_t seed;
  };
  for (const Case& c : {Case{"forest.exr", "microfacet:sigma=0.3", kVerifySeed},
                        Case{"city.exr", "ggx:alpha=0.3,f0=0.04", 777}}) {
    SCOPED_TRACE(std::string(c.map) + " " + c.brdf);
    PrefilterResult r;
    DirectionalError e;
    MeasureDefaultJob(c.map, c.brdf, &r, &e, 1024, c.seed);
    if (HasFatalFailure()) return;
    ExpectRmsTargetsMet(r, e);
    EXPECT_LE(e.front.max, kMaxErrorFactor * kDefaultTolerance);
  }
}

// The default, auto, splits where the split pays (the rest keeps at most kPeakSpreadShare of the
// map's non-constant luminance energy), as on does. The split's rest share on the four bundled
// maps against values computed independently from their pixels (a script over `oiiotool
// --dumpdata`: Rec. 709 luminance, sin(theta) pixel weights; the transform's Fejer weights
// differ in the third digit): city 0.0002, interior 0.0005, forest 0.112 (128 pixels: its bright
// sky, split since session 45); courtyard's brightest pixels (98 x its mean) would leave 99.7%.
// Auto leaves the whole map to the expansion for a radially symmetric BRDF, a tabulated one, and
// the epsilon rule, saying why.
TEST(PeakLightsTest, AutoSplitsWhereItPaysAndSaysWhyNot) {
  struct Expected {
    const char* map;
    double share_min, share_max;
    bool auto_splits;
  };
  const Expected kMaps[] = {{"city.exr", 0, 0.001, true},
                            {"interior.exr", 0, 0.002, true},
                            {"forest.exr", 0.09, 0.14, true},
                            {"courtyard.exr", 0.5, 1.0, false}};
  for (const Expected& e : kMaps) {
    auto map = LoadBundled(e.map);
    ASSERT_TRUE(map.ok()) << map.status();
    const PeakSplit split = SplitLightPeaks(*map, kPeakSpreadShare);
    std::printf("%s: rest share %.5f\n", e.map, split.rest_share);
    EXPECT_GE(split.rest_share, e.share_min) << e.map;
    EXPECT_LE(split.rest_share, e.share_max) << e.map;
    EXPECT_EQ(split.rest.has_value(), e.auto_splits) << e.map;
  }
  // The decision inside Prefilter, on a small city (its sun still splits at 128 x 64) and a job
  // kept small by a loose tolerance and a tiny cube.
  const EnvMap city = EnvMap::FromLatLong(testing::LoadBundledMap("city.exr", 128));
  PrefilterOptions options;
  options.tolerance = 0.2;
  options.view = ViewVariable::kNormal;
  options.face_size = 8;
  options.threads = 2;
  options.peak_lights = PeakLights::kAuto;
  struct Case {
    const char* brdf;
    bool epsilon;
    bool lights;
    const char* note;
  };
  const Case kCases[] = {{"ggx:alpha=0.3,f0=0.04", false, true, ""},
                         {"phong:s=32", false, false, "radially symmetric"},
                         {"ggx:alpha=0.3,f0=0.04", true, false, "tolerance rule only"}};
  for (const Case& c : kCases) {
    auto brdf = ParseBrdfSpec(c.brdf);
    ASSERT_TRUE(brdf.ok()) << brdf.status();
    PrefilterOptions o = options;
    if (c.epsilon) {
      o.tolerance = 0;
      o.epsilon = 0.1;
    }
    absl::StatusOr<PrefilterResult> r = Prefilter(city, **brdf, o);
    ASSERT_TRUE(r.ok()) << r.status();
    EXPECT_EQ(!r->cube.lights.empty(), c.lights) << c.brdf << " " << r->peak_lights_note;
    EXPECT_NE(r->peak_lights_note.find(c.note), std::string::npos)
        << c.brdf << ": '" << r->peak_lights_note << "'";
  }
}

}  // namespace
}  // namespace shrm
