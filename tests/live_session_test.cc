// The live session (core/shrm/live_session.h, docs/live.md): each frame equals the offline
// Prefilter() of the same lighting, rotation, BRDF and options, bit for bit where the path is
// the same (a map, a rotation, a BRDF change and back) and within a named float tolerance where
// it differs (coefficients given directly); latest-wins, by the order of events (a gate holds the
// worker while updates arrive), not by timing; errors are frames, and the next update recovers.
// On courtyard.exr box-downsampled to 256 x 128 (it resolves degree 127, above every F_rho here).
#include "core/shrm/live_session.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/envmap/lighting.h"
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

}  // namespace
}  // namespace shrm
