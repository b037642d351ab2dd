// The live session (core/live/live_session.h, docs/live.md): each frame equals the offline
// Prefilter() of the same lighting, rotation, BRDF and options, bit for bit where the path is
// the same (a map, a rotation, a BRDF change and back) and within a named float tolerance where
// it differs (coefficients given directly); latest-wins, by the order of events (a gate holds the
// worker while updates arrive), not by timing; errors are frames, and the next update recovers.
// On courtyard.exr box-downsampled to 256 x 128 (it resolves degree 127, above every F_rho here).
// A session with split-sum options also hands out the split-sum set of each lighting state: equal,
// bit for bit, to the offline PrefilterSplitSumSet of ComputeSplitSumLight (what `shrm ibl`
// computes, tested against the brute-force pixel sum in tests/split_sum_test.cc), recomputed when
// the lighting changes and reused when only the material does.
#include "core/live/live_session.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/envmap/lighting.h"
#include "core/ibl/split_sum.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_explicit.h"
#include "tests/stage_gate.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Lat-long width of the map (256 x 128).
constexpr int kMapWidth = 256;
constexpr int kFaceSize = 32;
// A frame is waited for at most this long: a safety net far beyond a frame's ~10-100 ms on a
// loaded machine (a broken session fails the test instead of hanging it), not a timing claim.
constexpr absl::Duration kFrameWait = absl::Seconds(120);
// Coefficients given directly: transformed to degree kCoefficientsLmax, below H / 2 = 64 so the
// transform takes the direct path Prefilter()'s transform to F_rho takes (from 64 up it resamples
// theta onto virtual rings, which for a map that is not band-limited differs by ~4e-7 relative).
// Truncated to F_rho they agree to the order of sums (kCoefficientTol of the largest; measured:
// equal), and the cube is then Prefilter()'s bit for bit.
constexpr int kCoefficientsLmax = 63;
constexpr double kCoefficientTol = 1e-12;
// Rotations the session applies (the world rotation of the lighting).
const Mat3 kRotationA = RotationZ(0.7) * RotationY(-0.3);
const Mat3 kRotationB = RotationX(1.1);

std::shared_ptr<const EnvMap> Courtyard() {
  static const std::shared_ptr<const EnvMap> map = std::make_shared<const EnvMap>(
      EnvMap::FromLatLong(testing::LoadBundledMap("courtyard.exr", kMapWidth)));
  return map;
}

std::shared_ptr<const Brdf> ParsedBrdf(const std::string& spec) {
  absl::StatusOr<std::unique_ptr<Brdf>> b = ParseBrdfSpec(spec);
  EXPECT_TRUE(b.ok()) << b.status();
  return b.ok() ? std::shared_ptr<const Brdf>(*std::move(b)) : nullptr;
}

PrefilterOptions SessionOptions() {
  PrefilterOptions o;
  o.epsilon = 0.03;
  o.face_size = kFaceSize;
  o.threads = 2;
  return o;
}

// The offline pipeline's cube for the same inputs.
ShrmCube Offline(const Brdf& brdf, const Mat3& rotation) {
  PrefilterOptions o = SessionOptions();
  o.rotation = rotation;
  absl::StatusOr<PrefilterResult> r = Prefilter(*Courtyard(), brdf, o);
  EXPECT_TRUE(r.ok()) << r.status();
  return r.ok() ? r->cube : ShrmCube{};
}

std::shared_ptr<const LiveFrame> Frame(const LiveSession& s, uint64_t update) {
  absl::StatusOr<std::shared_ptr<const LiveFrame>> f = s.WaitFor(update, kFrameWait);
  EXPECT_TRUE(f.ok()) << f.status();
  if (!f.ok()) return nullptr;
  EXPECT_GE((*f)->update, update);
  EXPECT_TRUE((*f)->status.ok()) << (*f)->status;
  return *f;
}

void ExpectSameCube(const ShrmCube& got, const ShrmCube& want) {
  EXPECT_EQ(got.face_size, want.face_size);
  EXPECT_EQ(got.pmax, want.pmax);
  EXPECT_EQ(got.kind, want.kind);
  EXPECT_TRUE(got.data == want.data) << "the frame's cube differs from Prefilter()'s";
}

TEST(LiveSession, FramesEqualOfflinePrefilterAndOnlyWhatChangedIsRecomputed) {
  absl::StatusOr<std::unique_ptr<LiveSession>> s = LiveSession::Create(SessionOptions());
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;
  const auto microfacet = ParsedBrdf("microfacet:sigma=0.3");
  const auto phong = ParsedBrdf("phong:s=32");

  live.SetMap(Courtyard());
  auto f = Frame(live, live.SetBrdf(microfacet));
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->brdf_reused);
  EXPECT_FALSE(f->lighting_reused);
  ExpectSameCube(f->result.cube, Offline(*microfacet, Mat3::Identity()));

  // A rotation: rho_lpq and the transform reused, the cube that of the rotated lighting.
  f = Frame(live, live.SetRotation(kRotationA));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->brdf_reused);
  EXPECT_TRUE(f->lighting_reused);
  ExpectSameCube(f->result.cube, Offline(*microfacet, kRotationA));

  // A material change (another F_rho: the transform is redone), then back (from the cache).
  f = Frame(live, live.SetBrdf(phong));
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->brdf_reused);
  EXPECT_FALSE(f->lighting_reused);
  ExpectSameCube(f->result.cube, Offline(*phong, kRotationA));
  f = Frame(live, live.SetBrdf(ParsedBrdf("microfacet:sigma=0.3")));  // another object, same spec
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->brdf_reused);
  EXPECT_TRUE(f->lighting_reused);  // L_lm at this F_rho is still cached for this map
  ExpectSameCube(f->result.cube, Offline(*microfacet, kRotationA));

  // Coefficients given directly (a content tool's own L_lm), to a higher degree than F_rho.
  auto coefficients = std::make_shared<const std::vector<double>>(
      *LightingCoefficients(*Courtyard(), kCoefficientsLmax, Mat3::Identity(), 1));
  const int f_rho = f->result.light_lmax;
  const std::vector<double> direct =
      *LightingCoefficients(*Courtyard(), f_rho, Mat3::Identity(), 1);
  double coeff_largest = 0, coeff_diff = 0;
  for (size_t i = 0; i < direct.size(); ++i) {
    coeff_largest = std::max(coeff_largest, std::abs(direct[i]));
    coeff_diff = std::max(coeff_diff, std::abs(direct[i] - (*coefficients)[i]));
  }
  EXPECT_LE(coeff_diff, kCoefficientTol * coeff_largest) << "F_rho " << f_rho;
  f = Frame(live,
            live.SetCoefficients(coefficients, kCoefficientsLmax, LightingEnergy(*Courtyard())));
  ASSERT_NE(f, nullptr);
  ExpectSameCube(f->result.cube, Offline(*microfacet, kRotationA));

  const LiveStats stats = live.Stats();
  EXPECT_EQ(stats.updates, 6u);
  EXPECT_EQ(stats.frames + stats.dropped, 6u);
}

// A released frame's cube storage becomes a later frame's (no fresh, zero-filled buffer per
// frame), and that frame still equals Prefilter()'s cube exactly: every value is written again.
TEST(LiveSession, ReleasedCubeStorageIsReusedAndEveryValueWrittenAgain) {
  absl::StatusOr<std::unique_ptr<LiveSession>> s = LiveSession::Create(SessionOptions());
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;
  const auto microfacet = ParsedBrdf("microfacet:sigma=0.3");
  live.SetMap(Courtyard());
  auto first = Frame(live, live.SetBrdf(microfacet));
  ASSERT_NE(first, nullptr);
  const float* storage = first->result.cube.data.data();
  auto second = Frame(live, live.SetRotation(kRotationA));  // the first is still held
  ASSERT_NE(second, nullptr);
  EXPECT_NE(second->result.cube.data.data(), storage);
  first.reset();  // its last holder: the storage goes to the session's pool
  auto third = Frame(live, live.SetRotation(kRotationB));
  ASSERT_NE(third, nullptr);
  EXPECT_EQ(third->result.cube.data.data(), storage);
  ExpectSameCube(third->result.cube, Offline(*microfacet, kRotationB));
  // A frame outliving its session lets go of its storage safely.
  s->reset();
  third.reset();
}

TEST(LiveSession, LatestWinsAndTheStatesInBetweenAreDroppedAndCounted) {
  testing::StageGate gate;  // closed: the worker waits before its first frame
  auto hook = gate.Hook();
  absl::StatusOr<std::unique_ptr<LiveSession>> s =
      LiveSession::Create(SessionOptions(), [hook](uint64_t) { hook("frame"); });
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;
  const auto brdf = ParsedBrdf("microfacet:sigma=0.3");
  live.SetMap(Courtyard());
  live.SetBrdf(brdf);
  // Ten rotations while the worker is held: a producer far faster than the computation.
  uint64_t last = 0;
  Mat3 rotation = Mat3::Identity();
  for (int k = 1; k <= 10; ++k) {
    rotation = RotationZ(0.1 * k) * RotationY(0.05 * k);
    last = live.SetRotation(rotation, std::make_shared<const int>(k));  // the state's tag
  }
  ASSERT_TRUE(gate.WaitHeld(1, kFrameWait)) << "the worker never started a frame";
  EXPECT_EQ(live.Latest(), nullptr);
  gate.Open();
  auto f = Frame(live, last);
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->update, last);
  ASSERT_NE(f->tag, nullptr);
  EXPECT_EQ(*std::static_pointer_cast<const int>(f->tag), 10);  // the tag of the state computed
  ExpectSameCube(f->result.cube, Offline(*brdf, rotation));
  const LiveStats stats = live.Stats();
  EXPECT_EQ(stats.updates, 12u);
  EXPECT_EQ(stats.frames, 1u);  // one computation for all twelve updates
  EXPECT_EQ(stats.dropped, 11u);
  // And it goes on with the next update.
  f = Frame(live, live.SetRotation(kRotationB));
  ASSERT_NE(f, nullptr);
  ExpectSameCube(f->result.cube, Offline(*brdf, kRotationB));
  EXPECT_EQ(live.Stats().frames, 2u);
}

// Where asked (SetView), a frame also holds the reflection map of that view (eq. 5.35), the one
// ReflectionMapForView makes from Prefilter()'s cube; a change of the view alone reuses the cube.
TEST(LiveSession, ViewMapIsEq535OfTheFramesCubeAndAViewChangeReusesTheCube) {
  absl::StatusOr<std::unique_ptr<LiveSession>> s = LiveSession::Create(SessionOptions());
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;
  const auto brdf = ParsedBrdf("microfacet:sigma=0.3");
  live.SetMap(Courtyard());
  live.SetBrdf(brdf);
  const Vec3 v1{0.3, 0.5, 0.8}, v2{-0.6, 0.2, 0.1};
  auto f = Frame(live, live.SetView(v1 * 2.0));  // normalized by the session
  ASSERT_NE(f, nullptr);
  const ShrmCube cube = Offline(*brdf, Mat3::Identity());
  ExpectSameCube(f->result.cube, cube);
  absl::StatusOr<RadianceCube> want = ReflectionMapForView(cube, v1.Normalized(), 1);
  ASSERT_TRUE(want.ok()) << want.status();
  EXPECT_TRUE(f->view_map.data == want->data);
  // (Whether this frame reused a cube depends on whether the worker had computed the state
  // without a view first; the next one follows a frame of the same state.)

  f = Frame(live, live.SetView(v2));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->shrm_reused);
  ASSERT_EQ(f->result.timings.size(), 1u);
  EXPECT_EQ(f->result.timings[0].stage, "view");
  ExpectSameCube(f->result.cube, cube);
  want = ReflectionMapForView(cube, v2.Normalized(), 1);
  ASSERT_TRUE(want.ok()) << want.status();
  EXPECT_TRUE(f->view_map.data == want->data);

  // No view: no map; a zero view: the frame's error.
  f = Frame(live, live.SetView(std::nullopt));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->view_map.data.empty());
  absl::StatusOr<std::shared_ptr<const LiveFrame>> bad =
      live.WaitFor(live.SetView(Vec3{0, 0, 0}), kFrameWait);
  ASSERT_TRUE(bad.ok()) << bad.status();
  EXPECT_EQ((*bad)->status.code(), absl::StatusCode::kInvalidArgument);
}

TEST(LiveSession, ErrorsAreFramesAndTheNextUpdateRecovers) {
  PrefilterOptions tolerance = SessionOptions();
  tolerance.tolerance = 0.01;
  EXPECT_EQ(LiveSession::Create(tolerance).status().code(), absl::StatusCode::kInvalidArgument);
  PrefilterOptions verify = SessionOptions();
  verify.verify = 16;
  EXPECT_EQ(LiveSession::Create(verify).status().code(), absl::StatusCode::kInvalidArgument);

  absl::StatusOr<std::unique_ptr<LiveSession>> s = LiveSession::Create(SessionOptions());
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;
  absl::StatusOr<std::shared_ptr<const LiveFrame>> f =
      live.WaitFor(live.SetMap(Courtyard()), kFrameWait);
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ((*f)->status.code(), absl::StatusCode::kFailedPrecondition) << (*f)->status;
  // Coefficients of a lower degree than the BRDF's F_rho: named in the frame's error.
  auto low = std::make_shared<const std::vector<double>>(ShCount(2) * 3, 0.5);
  live.SetBrdf(ParsedBrdf("phong:s=32"));
  f = live.WaitFor(live.SetCoefficients(low, 2, {1, 1, 1}), kFrameWait);
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ((*f)->status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE((*f)->status.message().find("degree 2"), std::string::npos) << (*f)->status;
  // The map again: a good frame.
  auto good = Frame(live, live.SetMap(Courtyard()));
  ASSERT_NE(good, nullptr);
  ExpectSameCube(good->result.cube, Offline(*ParsedBrdf("phong:s=32"), Mat3::Identity()));
  // An update that was never made is refused at once.
  EXPECT_EQ(live.WaitFor(1000, kFrameWait).status().code(), absl::StatusCode::kInvalidArgument);
}

// The split-sum chain of these tests: Filament's preset from a 64 x 64 base (3 levels down to
// 16 x 16), the core tolerance of `shrm ibl`'s default (1e-3 / 30).
ibl::SplitSumSetOptions SplitSumOptions() {
  ibl::SplitSumSetOptions o;
  o.chain = *ibl::MakeMipChain(ibl::RoughnessPreset::kFilament, 64, 0);
  o.tolerance = 1e-3 / 30;
  o.irradiance_size = 8;
  return o;
}

ibl::SplitSumSet OfflineSplitSum(const Mat3& rotation) {
  const int threads = SessionOptions().threads;
  absl::StatusOr<ibl::SpecularLight> light =
      ibl::ComputeSplitSumLight(*Courtyard(), rotation, SplitSumOptions(), threads);
  EXPECT_TRUE(light.ok()) << light.status();
  if (!light.ok()) return {};
  absl::StatusOr<ibl::SplitSumSet> set =
      ibl::PrefilterSplitSumSet(*Courtyard(), *light, SplitSumOptions(), threads);
  EXPECT_TRUE(set.ok()) << set.status();
  return set.ok() ? *std::move(set) : ibl::SplitSumSet{};
}

void ExpectSameChain(const ibl::SpecularChain& got, const ibl::SpecularChain& want) {
  EXPECT_EQ(got.light_degree, want.light_degree);
  ASSERT_EQ(got.levels.size(), want.levels.size());
  for (size_t k = 0; k < got.levels.size(); ++k) {
    EXPECT_EQ(got.levels[k].degree, want.levels[k].degree) << "level " << k;
    EXPECT_EQ(got.levels[k].face_size, want.levels[k].face_size) << "level " << k;
    EXPECT_TRUE(got.levels[k].cube.data == want.levels[k].cube.data)
        << "level " << k << ": the frame's radiance differs from the offline chain's";
  }
}

void ExpectSameSet(const ibl::SplitSumSet& got, const ibl::SplitSumSet& want) {
  ExpectSameChain(got.specular, want.specular);
  ExpectSameChain(got.irradiance, want.irradiance);
  EXPECT_TRUE(got.sheen.levels.empty());
  EXPECT_EQ(got.radiance_sh9, want.radiance_sh9);
}

bool HasStage(const LiveFrame& f, const std::string& stage) {
  for (const StageTiming& t : f.result.timings)
    if (t.stage == stage) return true;
  return false;
}

TEST(LiveSession, SplitSumSetEqualsTheOfflineChainAndIsReusedWhenOnlyTheMaterialChanges) {
  absl::StatusOr<std::unique_ptr<LiveSession>> s =
      LiveSession::Create(SessionOptions(), nullptr, SplitSumOptions());
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;

  // No BRDF: the frames hold the set alone.
  auto f = Frame(live, live.SetMap(Courtyard()));
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->incomplete);
  EXPECT_FALSE(f->has_shrm);
  ASSERT_NE(f->split_sum, nullptr);
  EXPECT_FALSE(f->split_sum_reused);
  EXPECT_TRUE(HasStage(*f, "specular"));
  ExpectSameSet(*f->split_sum, OfflineSplitSum(Mat3::Identity()));

  // A rotation: the cached coefficients turned (degree capped at kMaxRotationLmax; this map's
  // 127 is below it), the chain recomputed.
  f = Frame(live, live.SetRotation(kRotationA));
  ASSERT_NE(f, nullptr);
  ASSERT_NE(f->split_sum, nullptr);
  EXPECT_FALSE(f->split_sum_reused);
  ExpectSameSet(*f->split_sum, OfflineSplitSum(kRotationA));

  // A material: the SHRM computed, the set reused (the same object).
  const auto microfacet = ParsedBrdf("microfacet:sigma=0.3");
  const std::shared_ptr<const ibl::SplitSumSet> before = f->split_sum;
  f = Frame(live, live.SetBrdf(microfacet));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->has_shrm);
  EXPECT_TRUE(f->split_sum_reused);
  EXPECT_EQ(f->split_sum, before);
  EXPECT_FALSE(HasStage(*f, "specular"));
  ExpectSameCube(f->result.cube, Offline(*microfacet, kRotationA));

  // Coefficients have no map for the base level: the frame's error names it; a map recovers.
  auto coefficients = std::make_shared<const std::vector<double>>(
      *LightingCoefficients(*Courtyard(), kCoefficientsLmax, Mat3::Identity(), 1));
  absl::StatusOr<std::shared_ptr<const LiveFrame>> bad = live.WaitFor(
      live.SetCoefficients(coefficients, kCoefficientsLmax, LightingEnergy(*Courtyard())),
      kFrameWait);
  ASSERT_TRUE(bad.ok()) << bad.status();
  EXPECT_EQ((*bad)->status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE((*bad)->status.message().find("needs a map"), std::string::npos) << (*bad)->status;
  EXPECT_FALSE((*bad)->has_shrm);
  f = Frame(live, live.SetMap(Courtyard(), kRotationB));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->has_shrm);
  ASSERT_NE(f->split_sum, nullptr);
  ExpectSameSet(*f->split_sum, OfflineSplitSum(kRotationB));
  ExpectSameCube(f->result.cube, Offline(*microfacet, kRotationB));

  // Bad split-sum options are refused when the session is created.
  ibl::SplitSumSetOptions no_levels = SplitSumOptions();
  no_levels.chain = {};
  EXPECT_EQ(LiveSession::Create(SessionOptions(), nullptr, no_levels).status().code(),
            absl::StatusCode::kInvalidArgument);
  ibl::SplitSumSetOptions bad_tolerance = SplitSumOptions();
  bad_tolerance.tolerance = 0;
  EXPECT_EQ(LiveSession::Create(SessionOptions(), nullptr, bad_tolerance).status().code(),
            absl::StatusCode::kInvalidArgument);
  ibl::SplitSumSetOptions bad_irradiance = SplitSumOptions();
  bad_irradiance.irradiance_size = 3;
  EXPECT_EQ(LiveSession::Create(SessionOptions(), nullptr, bad_irradiance).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// SetSplitSum: a session made with split-sum options computes the set only while it is on (a
// viewer showing the SHRM turns it off); turned on with nothing else changed, the next frame keeps
// the SHRM and computes the set, equal to the offline chain.
TEST(LiveSession, SplitSumIsComputedOnlyWhileAsked) {
  absl::StatusOr<std::unique_ptr<LiveSession>> s =
      LiveSession::Create(SessionOptions(), nullptr, SplitSumOptions());
  ASSERT_TRUE(s.ok()) << s.status();
  LiveSession& live = **s;
  const auto microfacet = ParsedBrdf("microfacet:sigma=0.3");
  live.SetSplitSum(false);
  // Off and no BRDF: nothing to compute.
  absl::StatusOr<std::shared_ptr<const LiveFrame>> none =
      live.WaitFor(live.SetMap(Courtyard(), kRotationA), kFrameWait);
  ASSERT_TRUE(none.ok()) << none.status();
  EXPECT_TRUE((*none)->incomplete);
  EXPECT_EQ((*none)->status.code(), absl::StatusCode::kFailedPrecondition) << (*none)->status;
  auto f = Frame(live, live.SetBrdf(microfacet));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->has_shrm);
  EXPECT_EQ(f->split_sum, nullptr);
  EXPECT_FALSE(HasStage(*f, "specular"));
  f = Frame(live, live.SetSplitSum(true));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->shrm_reused);
  ExpectSameCube(f->result.cube, Offline(*microfacet, kRotationA));
  ASSERT_NE(f->split_sum, nullptr);
  ExpectSameSet(*f->split_sum, OfflineSplitSum(kRotationA));
  f = Frame(live, live.SetSplitSum(false));
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->shrm_reused);
  EXPECT_EQ(f->split_sum, nullptr);
}

}  // namespace
}  // namespace shrm
