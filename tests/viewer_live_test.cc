// The viewer's live mode without GL (viewer/live_source.h, docs/viewer.md "Live"): each frame the
// driver shows equals core's offline Prefilter() of the same map, rotation and BRDF bit for bit
// (the rotation being `shrm prefilter --rotate yaw,0,0`'s), for a rotation, a sequence map and a
// material change; the clock -> lighting conventions; the map producer (latest request first, the
// next sequence frame prefetched) by the order of events, never by timing; the sequence folder;
// the overlay's stage lines; the rate meter on given times.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_join.h"
#include "core/envmap/lighting.h"
#include "core/io/image.h"
#include "jobs/environment.h"
#include "tests/test_maps.h"
#include "viewer/live_source.h"
#include "viewer/split_sum_shading.h"

namespace shrm::viewer {
namespace {

constexpr int kMapWidth = 256;  // the bundled maps box-filtered to 256 x 128
constexpr int kFaceSize = 32;
// Waits are a safety net (a broken worker fails the test instead of hanging it), not timing.
constexpr absl::Duration kWait = absl::Seconds(120);

// A temporary folder with the bundled maps at 256 x 128 as EXR files 0.exr, 1.exr, ...
class ViewerLiveFiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::filesystem::path(std::filesystem::temp_directory_path() /
                                     ("shrm_viewer_live_test_" + std::to_string(::getpid())));
    std::filesystem::create_directories(*dir_);
    const char* names[] = {"courtyard.exr", "city.exr", "forest.exr"};
    for (int k = 0; k < 3; ++k) {
      ASSERT_TRUE(WriteExr(Path(k), testing::LoadBundledMap(names[k], kMapWidth)).ok());
    }
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    std::filesystem::remove_all(*dir_, ec);
    delete dir_;
  }
  static std::string Path(int k) { return (*dir_ / (std::to_string(k) + ".exr")).string(); }
  static std::filesystem::path* dir_;
};
std::filesystem::path* ViewerLiveFiles::dir_ = nullptr;

jobs::PrefilterJob Job(const std::string& brdf) {
  ComputeRequest req;
  req.brdf_spec = brdf;
  req.verify = 0;
  req.face_size = kFaceSize;
  return PrefilterJobFor(req, "unused.exr");
}

// The map as `shrm prefilter --env PATH` decodes it (the job layer's options).
EnvMap OfflineMap(const std::string& path) {
  jobs::EnvironmentSpec env;
  env.files = {path};
  absl::StatusOr<EnvMap> map = EnvMap::Load(jobs::EnvMapOptionsFor(env));
  EXPECT_TRUE(map.ok()) << map.status();
  return map.ok() ? *std::move(map) : EnvMap::FromLatLong(Image{});
}

// Prefilter() as `shrm prefilter --epsilon 0.03 --verify 0 --size 32 [--rotate yaw,0,0]` runs it.
ShrmCube Offline(const EnvMap& map, const std::string& brdf_spec, std::optional<double> yaw) {
  jobs::PrefilterJob job = Job(brdf_spec);
  if (yaw) job.env.rotate_ypr_deg = std::array<double, 3>{*yaw, 0, 0};
  auto brdf = ParseBrdfSpec(brdf_spec);
  EXPECT_TRUE(brdf.ok());
  const PrefilterOptions options = jobs::CorePrefilterOptions(job, 2);
  absl::StatusOr<PrefilterResult> r = Prefilter(map, **brdf, options);
  EXPECT_TRUE(r.ok()) << r.status();
  return r.ok() ? r->cube : ShrmCube{};
}

void ExpectSameCube(const ShrmCube& live, const ShrmCube& offline) {
  ASSERT_EQ(live.face_size, offline.face_size);
  ASSERT_EQ(live.pmax, offline.pmax);
  ASSERT_EQ(live.data.size(), offline.data.size());
  size_t differ = 0;
  for (size_t i = 0; i < live.data.size(); ++i) differ += live.data[i] != offline.data[i];
  EXPECT_EQ(differ, 0u) << "values differ of " << live.data.size();
}

TEST(ViewerLiveTest, ClockToLighting) {
  EXPECT_DOUBLE_EQ(RotateYawAt(3, 30), 90);
  EXPECT_DOUBLE_EQ(RotateYawAt(13, 30), 30);   // wrapped
  EXPECT_DOUBLE_EQ(RotateYawAt(1, -30), 330);  // negative speeds turn the other way
  EXPECT_EQ(SequenceIndexAt(0, 24, 5), 0);
  // t = k / fps from steps of 1 / fps lands on k (the slack), looping over 5 maps.
  for (int k = 0; k < 50; ++k) EXPECT_EQ(SequenceIndexAt(k * (1.0 / 24), 24, 5), k % 5) << k;
  EXPECT_EQ(SequenceIndexAt(0.49, 2, 3), 0);
  EXPECT_EQ(SequenceIndexAt(0.5, 2, 3), 1);
}

TEST(ViewerLiveTest, RateMeterOverTheLastWindow) {
  RateMeter m(1.0);
  EXPECT_EQ(m.rate(), 0);
  m.Add(0, 0);
  EXPECT_EQ(m.rate(), 0);
  for (int k = 1; k <= 40; ++k) m.Add(k * 0.1, 3 * k);  // 30 per second
  EXPECT_NEAR(m.rate(), 30, 1e-9);
  for (int k = 41; k <= 60; ++k) m.Add(k * 0.1, 120 + (k - 40));  // then 10 per second
  EXPECT_NEAR(m.rate(), 10, 1e-9);                                // only the last second counts
}

TEST_F(ViewerLiveFiles, SequenceFolderIsSortedExrFiles) {
  std::ofstream(*dir_ / "notes.txt") << "not a map";
  auto files = ExpandSequence({dir_->string()});
  ASSERT_TRUE(files.ok()) << files.status();
  EXPECT_EQ(*files, (std::vector<std::string>{Path(0), Path(1), Path(2)}));
  // Files as given stay as given (order included).
  auto given = ExpandSequence({Path(2), Path(0)});
  ASSERT_TRUE(given.ok());
  EXPECT_EQ(*given, (std::vector<std::string>{Path(2), Path(0)}));
  const std::filesystem::path empty = *dir_ / "empty";
  std::filesystem::create_directories(empty);
  auto none = ExpandSequence({empty.string()});
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("has no .exr files"), std::string::npos);
  EXPECT_NE(none.status().message().find(empty.string()), std::string::npos);
}

TEST_F(ViewerLiveFiles, MissingSequenceFileIsNamedBeforeAnyFrame) {
  LiveSpec spec;
  spec.kind = LiveKind::kSequence;
  spec.sequence = {Path(0), (*dir_ / "missing.exr").string()};
  auto l = LiveLighting::Create(spec, 1);
  ASSERT_FALSE(l.ok());
  EXPECT_NE(l.status().message().find("missing.exr"), std::string::npos) << l.status();
}

// The producer by the order of events: the next frame is prefetched after a request; a request
// waiting beats a prefetch; results are kept up to `keep`.
TEST(ViewerLiveTest, MapProducerPrefetchesTheNextFrame) {
  std::vector<int64_t> made;
  std::mutex mu;
  MapProducer p(
      [&](int64_t key) -> absl::StatusOr<std::shared_ptr<const LiveMap>> {
        std::lock_guard<std::mutex> lock(mu);
        made.push_back(key);
        auto m = std::make_shared<LiveMap>();
        m->label = std::to_string(key);
        return std::shared_ptr<const LiveMap>(m);
      },
      [](int64_t key) -> std::optional<int64_t> { return (key + 1) % 4; }, 3);
  auto m0 = p.Wait(0, kWait);
  ASSERT_TRUE(m0.ok());
  EXPECT_EQ((*m0)->label, "0");
  auto m1 = p.Wait(1, kWait);  // prefetched after 0, or made now: made once either way
  ASSERT_TRUE(m1.ok());
  EXPECT_EQ((*m1)->label, "1");
  auto m2 = p.Wait(2, kWait);
  ASSERT_TRUE(m2.ok());
  // One map ahead of the requests only: 2's prefetch of 3, never 3's of 0 (a loop would decode
  // round and round). Waiting for 3 (made by the prefetch or now) makes it the last.
  auto m3 = p.Wait(3, kWait);
  ASSERT_TRUE(m3.ok());
  std::lock_guard<std::mutex> lock(mu);
  // Each key at most once, in order.
  EXPECT_LE(made.size(), 5u);  // 0..3, and 3's prefetch of 0 (0 was dropped: keep 3)
  for (size_t k = 0; k < std::min<size_t>(made.size(), 4); ++k) {
    EXPECT_EQ(made[k], static_cast<int64_t>(k));
  }
}

TEST(ViewerLiveTest, MapProducerKeepsErrorsAsResults) {
  MapProducer p(
      [](int64_t) -> absl::StatusOr<std::shared_ptr<const LiveMap>> {
        return absl::DataLossError("frame 7.exr: truncated");
      },
      nullptr, 2);
  auto r = p.Wait(7, kWait);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kDataLoss);
  ASSERT_TRUE(p.Find(7).has_value());
  EXPECT_FALSE(p.Find(7)->ok());
  EXPECT_FALSE(p.Find(8).has_value());
}

// Rotate: the frame of yaw 90 is Prefilter() of the map with --rotate 90,0,0, bit for bit; a
// material change and back; the overlay names every stage the session ran.
// --live rotate of map 0 at 30 deg/s.
LiveSpec RotateSpec(const std::string& map) {
  LiveSpec spec;
  spec.kind = LiveKind::kRotate;
  spec.env = map;
  spec.speed = 30;
  return spec;
}

TEST_F(ViewerLiveFiles, RotateFramesEqualOfflinePrefilter) {
  const LiveSpec spec = RotateSpec(Path(0));
  auto lighting = LiveLighting::Create(spec, 2);
  ASSERT_TRUE(lighting.ok()) << lighting.status();
  auto driver = LiveDriver::Create(Job("microfacet:sigma=0.2"), 2);
  ASSERT_TRUE(driver.ok()) << driver.status();
  const EnvMap map = OfflineMap(Path(0));

  auto at = (*lighting)->At(3, false);  // 3 s at 30 deg/s
  ASSERT_TRUE(at.ok());
  EXPECT_EQ(at->text, "yaw 90.0 deg");
  jobs::EnvironmentSpec env;
  env.rotate_ypr_deg = std::array<double, 3>{90, 0, 0};
  EXPECT_EQ(at->rotation.m, jobs::EnvironmentRotation(env).m);
  auto update = (*driver)->Push(*at, "microfacet:sigma=0.2");
  ASSERT_TRUE(update.ok());
  auto shown = (*driver)->WaitFor(*update, kWait);
  ASSERT_TRUE(shown.ok()) << shown.status();
  ASSERT_TRUE((*shown)->status.ok()) << (*shown)->status;
  ExpectSameCube((*shown)->shrm->global, Offline(map, "microfacet:sigma=0.2", 90));
  EXPECT_EQ((*shown)->shrm->global.kind, ShrmKind::kGlobal);
  EXPECT_EQ((*shown)->shrm->local.kind, ShrmKind::kLocal);
  EXPECT_EQ((*shown)->lighting, "yaw 90.0 deg");
  EXPECT_EQ((*shown)->rotation.m, at->rotation.m);

  // Nothing changed: no update.
  auto same = (*driver)->Push(*at, "microfacet:sigma=0.2");
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(*same, *update);

  // Another material, then back (the session's BRDF cache), each equal to the offline cube.
  for (const char* spec_text : {"phong:s=32", "microfacet:sigma=0.2"}) {
    auto u = (*driver)->Push(*at, spec_text);
    ASSERT_TRUE(u.ok());
    auto s = (*driver)->WaitFor(*u, kWait);
    ASSERT_TRUE(s.ok());
    ASSERT_TRUE((*s)->status.ok()) << (*s)->status;
    EXPECT_EQ((*s)->brdf_spec, spec_text);
    ExpectSameCube((*s)->shrm->global, Offline(map, spec_text, 90));
    const std::vector<std::string> lines =
        LiveOverlayLines(spec, **s, (*driver)->Stats(), 12.5, 60);
    const std::string all = absl::StrJoin(lines, "\n");
    for (const char* stage : {"brdf", "lighting", "analysis", "synthesis", "compute", "convert"}) {
      EXPECT_NE(all.find(stage), std::string::npos) << stage << " missing in\n" << all;
    }
    EXPECT_NE(all.find("live 12.5 frames/s, render 60.0 frames/s"), std::string::npos) << all;
    EXPECT_NE(all.find("(F_B, P_B) = ("), std::string::npos) << all;
  }
  // A bad spec is refused before anything is sent.
  EXPECT_FALSE((*driver)->Push(*at, "microfacet:sigma=-1").ok());
}

// Mode 6 live: with the split-sum needed, each shown frame carries the session's split-sum set of
// its lighting, whose chain is SplitSumShading::Create's for the map turned the same way (what
// mode 6 shows for a fixed map) bit for bit; without the need, frames carry none.
TEST_F(ViewerLiveFiles, SplitSumFramesEqualTheChainOfTheTurnedMap) {
  auto lighting = LiveLighting::Create(RotateSpec(Path(0)), 2);
  ASSERT_TRUE(lighting.ok()) << lighting.status();
  const std::string ggx = "ggx:alpha=0.3";
  auto driver = LiveDriver::Create(Job(ggx), 2);
  ASSERT_TRUE(driver.ok()) << driver.status();
  const EnvMap map = OfflineMap(Path(0));
  auto brdf = ParseBrdfSpec(ggx);
  ASSERT_TRUE(brdf.ok());

  auto at = (*lighting)->At(3, false);  // yaw 90
  ASSERT_TRUE(at.ok());
  auto update = (*driver)->Push(*at, ggx);
  ASSERT_TRUE(update.ok());
  auto shown = (*driver)->WaitFor(*update, kWait);
  ASSERT_TRUE(shown.ok()) << shown.status();
  ASSERT_TRUE((*shown)->status.ok()) << (*shown)->status;
  EXPECT_EQ((*shown)->split_sum, nullptr) << "computed while mode 6 is not shown";

  (*driver)->SetNeedSplitSum(true);
  update = (*driver)->Push(*at, ggx);  // nothing else changed: the split-sum update
  ASSERT_TRUE(update.ok());
  shown = (*driver)->WaitFor(*update, kWait);
  ASSERT_TRUE(shown.ok()) << shown.status();
  ASSERT_TRUE((*shown)->status.ok()) << (*shown)->status;
  ASSERT_NE((*shown)->split_sum, nullptr);
  ASSERT_NE((*shown)->brdf, nullptr);
  absl::StatusOr<SplitSumShading> want = SplitSumShading::Create(map, **brdf, 2, at->rotation);
  ASSERT_TRUE(want.ok()) << want.status();
  const ibl::SpecularChain& got = (*shown)->split_sum->specular;
  ASSERT_EQ(got.levels.size(), want->chain().levels.size());
  for (size_t k = 0; k < got.levels.size(); ++k) {
    EXPECT_EQ(got.levels[k].degree, want->chain().levels[k].degree) << "level " << k;
    EXPECT_TRUE(got.levels[k].cube.data == want->chain().levels[k].cube.data)
        << "level " << k << ": the live chain differs from the turned map's";
  }
  // The shading mode 6 draws with, from the live chain: the same lod and f0.
  absl::StatusOr<SplitSumShading> live =
      SplitSumShading::FromChain((*shown)->split_sum->specular, *(*shown)->brdf);
  ASSERT_TRUE(live.ok()) << live.status();
  EXPECT_EQ(live->lod(), want->lod());
  EXPECT_EQ(live->f0(), want->f0());
  const Vec3 n = Vec3{0.3, 0.8, -0.5}.Normalized(), v = Vec3{0.1, 0.2, 1}.Normalized();
  EXPECT_EQ(live->Eval(n, v), want->Eval(n, v));
}

// Sequence: frame floor(t fps) of the folder, each shown frame Prefilter() of that file.
TEST_F(ViewerLiveFiles, SequenceFramesEqualOfflinePrefilter) {
  LiveSpec spec;
  spec.kind = LiveKind::kSequence;
  spec.sequence = {dir_->string()};
  spec.fps = 2;
  auto lighting = LiveLighting::Create(spec, 2);
  ASSERT_TRUE(lighting.ok()) << lighting.status();
  auto driver = LiveDriver::Create(Job("phong:s=32"), 2);
  ASSERT_TRUE(driver.ok());
  for (double t : {0.0, 0.5, 1.0, 1.5}) {  // frames 0, 1, 2, 0
    auto at = (*lighting)->At(t, true);
    ASSERT_TRUE(at.ok()) << at.status();
    const int k = SequenceIndexAt(t, 2, 3);
    EXPECT_EQ(at->map->env->path, Path(k));
    auto u = (*driver)->Push(*at, "phong:s=32");
    ASSERT_TRUE(u.ok());
    auto s = (*driver)->WaitFor(*u, kWait);
    ASSERT_TRUE(s.ok());
    ASSERT_TRUE((*s)->status.ok()) << (*s)->status;
    EXPECT_EQ((*s)->map->env->path, Path(k));
    ExpectSameCube((*s)->shrm->global, Offline(OfflineMap(Path(k)), "phong:s=32", std::nullopt));
  }
}

}  // namespace
}  // namespace shrm::viewer
