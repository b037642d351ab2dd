// The viewer's CPU parts (viewer/, library shrm_viewer_core; no GL): the orbit camera, the meshes,
// the per-view global SHRM sum of mode 1 against core's ReflectionMapForView, the SHRM kind
// conversion against core's local synthesis, the progressive ground truth against
// ReferenceRadiance, and the BRDF edits.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <thread>
#include <vector>

#include "core/base/cubemap.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/shrm_synthesis.h"
#include "jobs/prefilter_job.h"
#include "tests/test_maps.h"
#include "tests/test_paths.h"
#include "viewer/brdf_edit.h"
#include "viewer/camera.h"
#include "viewer/cpu_images.h"
#include "viewer/cube_convert.h"
#include "viewer/mesh.h"
#include "viewer/progressive_reference.h"
#include "viewer/reflection_sum.h"
#include "viewer/scene_source.h"

namespace shrm::viewer {
namespace {

Vec3 V3(const std::vector<float>& v, size_t i) { return {v[3 * i], v[3 * i + 1], v[3 * i + 2]}; }

// Column-major 4x4 times (x, y, z, 1).
std::array<double, 4> Apply(const Mat4f& m, const Vec3& p) {
  std::array<double, 4> r{};
  for (int row = 0; row < 4; ++row)
    r[row] = m[row] * p.x + m[4 + row] * p.y + m[8 + row] * p.z + m[12 + row];
  return r;
}

TEST(ViewerCamera, EyeAndFrameFollowTheDocumentedAngles) {
  constexpr double kTol = 1e-12;  // closed forms in double
  const OrbitCamera front({0, 0, 3});
  EXPECT_NEAR(front.Eye().z, 3, kTol);
  EXPECT_NEAR(front.Forward().z, -1, kTol);
  EXPECT_NEAR(front.Right().x, 1, kTol);
  EXPECT_NEAR(front.Up().y, 1, kTol);
  const OrbitCamera side({90, 0, 2});  // positive azimuth moves the eye towards +X
  EXPECT_NEAR(side.Eye().x, 2, kTol);
  const OrbitCamera above({0, 60, 1});
  EXPECT_NEAR(above.Eye().y, std::sin(kPi / 3), kTol);
}

TEST(ViewerCamera, PixelRaysProjectBackToTheirPixels) {
  // The ray of pixel (x, y) (row 0 at the top) lands, through ProjectionMatrix * ViewMatrix, at
  // that pixel centre with GL's bottom-up window rows.
  constexpr double kTol = 1e-4;  // float matrices
  const OrbitCamera cam({37, -25, 4});
  const int w = 200, h = 100;
  const Mat4f vp = Multiply(cam.ProjectionMatrix(2.0), cam.ViewMatrix());
  for (auto [x, y] : {std::pair{0, 0}, {199, 99}, {57, 13}, {100, 50}}) {
    const Vec3 p = cam.Eye() + cam.PixelRay(x, y, w, h) * 2.5;
    const std::array<double, 4> c = Apply(vp, p);
    EXPECT_NEAR((c[0] / c[3] + 1) / 2 * w, x + 0.5, kTol * w);
    EXPECT_NEAR((c[1] / c[3] + 1) / 2 * h, (h - 1 - y) + 0.5, kTol * h);
    EXPECT_GT(c[2] / c[3], -1);
    EXPECT_LT(c[2] / c[3], 1);
  }
}

TEST(ViewerCamera, ParseRejectsBadViews) {
  EXPECT_TRUE(ParseOrbitView("30,20", "--view").ok());
  EXPECT_NEAR(ParseOrbitView("30,20,5", "--view")->distance, 5, 0);
  for (const char* bad : {"", "30", "a,b", "30,95", "30,20,0.5", "30,20,1e9", "1,2,3,4", "nan,0"})
    EXPECT_FALSE(ParseOrbitView(bad, "--view").ok()) << bad;
}

void ExpectMeshSane(const Mesh& m) {
  constexpr double kUnitTol = 1e-5;  // float storage
  ASSERT_GT(m.triangle_count(), 0u);
  ASSERT_EQ(m.normals.size(), m.positions.size());
  ASSERT_EQ(m.tangents.size(), 4 * m.vertex_count());
  ASSERT_EQ(m.uvs.size(), 2 * m.vertex_count());
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    const Vec3 n = V3(m.normals, v);
    const Vec3 t{m.tangents[4 * v], m.tangents[4 * v + 1], m.tangents[4 * v + 2]};
    EXPECT_NEAR(n.Norm(), 1, kUnitTol);
    EXPECT_NEAR(t.Norm(), 1, kUnitTol);
    EXPECT_NEAR(n.Dot(t), 0, kUnitTol);
    EXPECT_LE(V3(m.positions, v).Norm(), 1 + kUnitTol);
  }
  // Counter-clockwise seen from outside: the face normal agrees with the vertex normals.
  int agree = 0;
  for (size_t f = 0; f < m.triangle_count(); ++f) {
    const uint32_t* i = &m.indices[3 * f];
    const Vec3 a = V3(m.positions, i[0]), b = V3(m.positions, i[1]), c = V3(m.positions, i[2]);
    const Vec3 fn = (b - a).Cross(c - a);
    if (fn.Norm() < 1e-12) continue;
    agree += fn.Dot(V3(m.normals, i[0]) + V3(m.normals, i[1]) + V3(m.normals, i[2])) > 0 ? 1 : -1;
  }
  EXPECT_GT(agree, 0.9 * m.triangle_count());
}

TEST(ViewerMesh, SphereAndTorusAreConsistent) {
  const Mesh s = MakeSphere(32, 16);
  ExpectMeshSane(s);
  for (size_t v = 0; v < s.vertex_count(); ++v)
    EXPECT_NEAR((V3(s.positions, v) - V3(s.normals, v)).Norm(), 0, 1e-6);
  ExpectMeshSane(MakeTorus(0.7, 0.3, 32, 16));
}

TEST(ViewerMesh, ObjFileLoadsAndBadFilesAreErrors) {
  const std::string dir = ::testing::TempDir();
  const std::string good = dir + "/viewer_quad.obj";
  {
    FILE* f = std::fopen(good.c_str(), "w");
    std::fputs(
        "v 0 0 0\nv 2 0 0\nv 2 2 0\nv 0 2 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "f 1/1 2/2 3/3 4/4\n",
        f);
    std::fclose(f);
  }
  absl::StatusOr<Mesh> m = LoadObjMesh(good);
#ifdef SHRM_VIEWER_HAVE_TINYOBJLOADER
  ASSERT_TRUE(m.ok()) << m.status();
  EXPECT_EQ(m->triangle_count(), 2u);
  ExpectMeshSane(*m);
  EXPECT_NEAR(V3(m->normals, 0).z, 1, 1e-6);  // smooth normals of the +z-facing quad
  EXPECT_NEAR(m->tangents[0], 1, 1e-6);       // +u is +x
#endif
  EXPECT_FALSE(LoadObjMesh(dir + "/does_not_exist.obj").ok());
}

class ViewerShrmTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    map_ = new Image(testing::LoadBundledMap("courtyard.exr", 64));
    const EnvMap env = EnvMap::FromLatLong(*map_);
    brdf_ = ParseBrdfSpec("microfacet:sigma=0.3").value().release();
    PrefilterOptions opt;
    opt.f = 10;
    opt.p = 3;
    opt.face_size = 16;
    opt.kind = ShrmKind::kGlobal;
    global_ = new ShrmCube(Prefilter(env, *brdf_, opt).value().cube);
    opt.kind = ShrmKind::kLocal;
    local_ = new ShrmCube(Prefilter(env, *brdf_, opt).value().cube);
  }
  static void TearDownTestSuite() {
    delete global_;
    delete local_;
    delete brdf_;
    delete map_;
  }
  static Image* map_;
  static Brdf* brdf_;
  static ShrmCube *global_, *local_;
};
Image* ViewerShrmTest::map_ = nullptr;
Brdf* ViewerShrmTest::brdf_ = nullptr;
ShrmCube* ViewerShrmTest::global_ = nullptr;
ShrmCube* ViewerShrmTest::local_ = nullptr;

TEST_F(ViewerShrmTest, PerViewSumEqualsCoreReflectionMapForView) {
  // Same float products as core's blocked sum, different order: float rounding only.
  constexpr double kTol = 1e-5;
  absl::StatusOr<GlobalReflectionSum> sum = GlobalReflectionSum::Create(*global_);
  ASSERT_TRUE(sum.ok()) << sum.status();
  RadianceCube fast;
  for (const Vec3 v : {Vec3{0, 0, 1}, Vec3{0.3, 0.8, -0.2}.Normalized(), Vec3{0, -1, 0}}) {
    for (int threads : {1, 2}) {
      sum->Compute(v, &fast, threads);
      const RadianceCube slow = ReflectionMapForView(*global_, v).value();
      ASSERT_EQ(fast.data.size(), slow.data.size());
      double max_abs = 0, max_err = 0;
      for (size_t i = 0; i < slow.data.size(); ++i) {
        max_abs = std::max(max_abs, std::abs(static_cast<double>(slow.data[i])));
        max_err = std::max(max_err, std::abs(static_cast<double>(fast.data[i]) - slow.data[i]));
      }
      EXPECT_LE(max_err, kTol * max_abs);
    }
  }
  EXPECT_FALSE(GlobalReflectionSum::Create(*local_).ok());
}

TEST_F(ViewerShrmTest, KindConversionMatchesCoreSynthesis) {
  // Both cubes are exact at the texel centres (resampled from the same grid); rotation in double,
  // float storage, and the grid interpolation of each kind.
  constexpr double kTol = 2e-3;
  const ShrmCube to_local = ConvertShrmKind(*global_, ShrmKind::kLocal).value();
  const ShrmCube to_global = ConvertShrmKind(*local_, ShrmKind::kGlobal, 2).value();
  double max_abs = 0, err_l = 0, err_g = 0;
  for (size_t i = 0; i < local_->data.size(); ++i) {
    max_abs = std::max(max_abs, std::abs(static_cast<double>(local_->data[i])));
    err_l = std::max(err_l, std::abs(static_cast<double>(to_local.data[i]) - local_->data[i]));
    err_g = std::max(err_g, std::abs(static_cast<double>(to_global.data[i]) - global_->data[i]));
  }
  EXPECT_LE(err_l, kTol * max_abs);
  EXPECT_LE(err_g, kTol * max_abs);
  EXPECT_EQ(to_local.kind, ShrmKind::kLocal);
  EXPECT_EQ(to_global.kind, ShrmKind::kGlobal);
}

TEST_F(ViewerShrmTest, ProgressiveReferenceEqualsReferenceRadiance) {
  const OrbitCamera cam({20, 30, 3});
  const int w = 24, h = 18;
  GeometryBuffer g = SphereGeometry(cam, w, h);
  const EnvMap env = EnvMap::FromLatLong(*map_);
  auto integrator = std::make_shared<const ReferenceIntegrator>(
      ReferenceIntegrator::Create(env.samples()).value());
  std::shared_ptr<const Brdf> brdf(ParseBrdfSpec("microfacet:sigma=0.3").value().release());
  ProgressiveReference ref(2);
  ref.Start(g, integrator, brdf);
  ref.Wait();
  EXPECT_TRUE(ref.finished());
  EXPECT_DOUBLE_EQ(ref.progress(), 1.0);
  std::vector<float> rgba;
  ASSERT_TRUE(ref.Poll(&rgba));
  EXPECT_FALSE(ref.Poll(&rgba));  // nothing new
  const Brdf& b = *brdf;
  const TransferFunction transfer = [&b](const Vec3& n, const Vec3& v, const Vec3& wi, int) {
    return b.Transfer(n, v, wi, 0);
  };
  constexpr double kTol = 1e-5;  // the same double sums, float image
  int covered = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const PixelGeometry& p = g.at(x, y);
      const float* px = &rgba[(static_cast<size_t>(y) * w + x) * 4];
      if (!p.hit) {
        EXPECT_EQ(px[3], 0.0f);
        continue;
      }
      ++covered;
      EXPECT_EQ(px[3], 1.0f);
      const std::array<double, 3> r = ReferenceRadiance(env.samples(), transfer, p.normal, p.view);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(px[c], r[c], kTol * std::abs(r[c]) + 1e-7);
    }
  EXPECT_GT(covered, 100);
}

TEST_F(ViewerShrmTest, CpuSphereImageFollowsTheCamera) {
  // The pixel at the image centre sees the sphere point facing the eye; N = V there, so R = V.
  const OrbitCamera cam({45, 10, 3});
  const GeometryBuffer g = SphereGeometry(cam, 33, 33);
  const PixelGeometry& c = g.at(16, 16);
  ASSERT_TRUE(c.hit);
  EXPECT_NEAR((c.normal - cam.Eye().Normalized()).Norm(), 0, 1e-9);
  EXPECT_FALSE(g.at(0, 0).hit);
  const Image img = ShadeImage(g, ShrmPixelShader(*global_, ViewModel::kPerPixel, {}), 2);
  const std::array<double, 3> direct = ShrmEval(*global_, c.normal, c.view);
  for (int ch = 0; ch < 3; ++ch)
    EXPECT_NEAR(img.pixels[(16 * 33 + 16) * 3 + ch], direct[ch], 1e-5 * std::abs(direct[ch]));
}

TEST_F(ViewerShrmTest, ShrmFileSourceHasBothKinds) {
  const std::string path = ::testing::TempDir() + "/viewer_core_test.shrm.exr";
  ASSERT_TRUE(WriteShrmFile(path, *local_,
                            {{"shrm:brdf", "microfacet:sigma=0.3"},
                             {"shrm:orders", "10,3"},
                             {"shrm:epsilon", "explicit orders"}})
                  .ok());
  absl::StatusOr<ShrmData> d = LoadShrmData(path, 2);
  ASSERT_TRUE(d.ok()) << d.status();
  EXPECT_EQ(d->global.kind, ShrmKind::kGlobal);
  EXPECT_EQ(d->local.kind, ShrmKind::kLocal);
  EXPECT_EQ(d->local.data, local_->data);  // the file's kind is kept as stored
  EXPECT_EQ(d->brdf_spec, "microfacet:sigma=0.3");
  EXPECT_EQ(d->f_b, 10);
  EXPECT_EQ(d->p_b, 3);
  EXPECT_FALSE(LoadShrmData(path + ".missing", 1).ok());
}

// The viewer checks each SHRM it computes (issue 16: the overlay shows the measured error, not
// the eq. 5.19 bound) against a reference built once per map; the figures must be those of the
// job's own check as `shrm prefilter --verify` makes it (which builds its reference per job).
TEST_F(ViewerShrmTest, EmbeddedComputeMeasuresItsCubeAsThePrefilterJobDoes) {
  const std::string path = testing::UniqueTempPath("viewer_verify_map.exr");
  ASSERT_TRUE(WriteExr(path, *map_).ok());
  absl::StatusOr<std::shared_ptr<const EnvironmentData>> env = LoadEnvironment(path, 32, 2);
  ASSERT_TRUE(env.ok()) << env.status();
  ComputeRequest req;
  req.brdf_spec = "microfacet:sigma=0.3";
  req.f = 8;
  req.p = 3;
  req.face_size = 16;
  req.verify = 32;
  req.threads = 2;
  absl::StatusOr<ShrmData> d = EmbeddedCompute(*env)(req, nullptr);
  ASSERT_TRUE(d.ok()) << d.status();
  absl::StatusOr<jobs::PrefilterRun> cli = jobs::RunPrefilterJob(PrefilterJobFor(req, path), 1);
  ASSERT_TRUE(cli.ok()) << cli.status();
  ASSERT_TRUE(cli->attributes.count("shrm:measured_error"));
  EXPECT_EQ(d->attributes.at("shrm:measured_error"), cli->attributes.at("shrm:measured_error"));
  EXPECT_EQ(d->measured.pairs, 32);
  // The attribute holds 6 significant digits (absl::StrCat).
  constexpr double kAttributeDigits = 1e-5;
  EXPECT_NEAR(d->measured.front_rms, cli->result.measured.front.rms,
              kAttributeDigits * cli->result.measured.front.rms);
  EXPECT_NEAR(d->measured.front_max, cli->result.measured.front.max,
              kAttributeDigits * cli->result.measured.front.max);
  const std::string line = ShrmSummaryLine(*d);
  EXPECT_NE(line.find("measured RMS"), std::string::npos) << line;
  EXPECT_EQ(line.find("bound"), std::string::npos) << line;

  // Without a check (a file written without --verify) the line says so and names the bound.
  ShrmData unmeasured = *d;
  unmeasured.measured = {};
  unmeasured.eps_bound = 0.5;
  EXPECT_NE(ShrmSummaryLine(unmeasured).find("not measured (eq. 5.19 energy bound 0.5)"),
            std::string::npos)
      << ShrmSummaryLine(unmeasured);
  std::filesystem::remove(path);
}

TEST(ViewerAsyncShrmJob, NewerRequestSupersedesTheRunningOne) {
  // A fake computation: walks the stages slowly, returns a cube whose face size is the request's.
  ShrmComputeFn compute = [](const ComputeRequest& req,
                             const PrefilterProgress& progress) -> absl::StatusOr<ShrmData> {
    for (const char* stage : {"brdf", "lighting", "analysis", "synthesis"}) {
      absl::Status s = progress(stage);
      if (!s.ok()) return s;
      std::this_thread::sleep_for(std::chrono::milliseconds(req.face_size == 1 ? 50 : 1));
    }
    ShrmData d;
    d.global.face_size = req.face_size;
    d.brdf_spec = req.brdf_spec;
    return d;
  };
  AsyncShrmJob job(compute);
  ComputeRequest slow, fast;
  slow.face_size = 1;
  slow.brdf_spec = "slow";
  fast.face_size = 2;
  fast.brdf_spec = "fast";
  job.Start(slow);
  EXPECT_TRUE(job.busy());
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  job.Start(fast);
  std::optional<absl::StatusOr<ShrmData>> r = job.Wait();
  ASSERT_TRUE(r.has_value());
  ASSERT_TRUE(r->ok()) << r->status();
  EXPECT_EQ((*r)->brdf_spec, "fast");
  EXPECT_FALSE(job.busy());
  EXPECT_DOUBLE_EQ(job.fraction(), 1.0);
  std::this_thread::sleep_for(std::chrono::milliseconds(250));  // the slow one has stopped
  EXPECT_FALSE(job.Poll().has_value());                         // and its result was dropped
  // Errors are results too.
  AsyncShrmJob failing(
      [](const ComputeRequest&, const PrefilterProgress&) -> absl::StatusOr<ShrmData> {
        return absl::InvalidArgumentError("no");
      });
  failing.Start({});
  r = failing.Wait();
  ASSERT_TRUE(r.has_value());
  EXPECT_FALSE(r->ok());
}

TEST(ViewerBrdfEdit, ScalesTheLobeParameterAndKeepsRanges) {
  EXPECT_EQ(ScaleBrdfLobe("microfacet:sigma=0.2", 2).value(), "microfacet:sigma=0.4");
  EXPECT_EQ(ScaleBrdfLobe("phong:s=32", 0.5).value(), "phong:s=16");
  EXPECT_EQ(ScaleBrdfLobe("ggx:alpha=0.3,f0=0.04", 2).value(), "ggx:alpha=0.6,f0=0.04");
  EXPECT_FALSE(ScaleBrdfLobe("ggx:alpha=0.8", 2).ok());  // alpha in (0, 1]
  EXPECT_FALSE(ScaleBrdfLobe("lambert", 2).ok());
  EXPECT_FALSE(ScaleBrdfLobe("nonsense:x=1", 2).ok());
  for (const std::string& spec : BrdfPresets()) EXPECT_TRUE(ParseBrdfSpec(spec).ok()) << spec;
}

}  // namespace
}  // namespace shrm::viewer
