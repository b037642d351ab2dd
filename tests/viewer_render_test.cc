// The viewer's GPU modes against their CPU twins and against brute force (docs/viewer.md
// "Tests"). Needs an X display with OpenGL 3.3 core: CTest runs it under `xvfb-run -a`
// (tests/viewer_xvfb.sh) with Mesa's llvmpipe.
//
// A unit sphere (256 x 128 mesh) carrying a microfacet SHRM of the courtyard map (box-filtered to
// 128 x 64, tests/test_maps.h) is rendered headless into the viewer's HDR framebuffer (linear
// radiance, no background) from two views, and compared per pixel with
//  1. the CPU image of the SAME SHRM cube: the analytic sphere hit by each pixel-centre ray,
//     R = 2 (N.V) N - V, ShrmEvalAt (core) with V = the pixel's view (mode 2, local cube from
//     core's local synthesis) or the camera's central view (mode 1, global cube: eq. 5.35's one
//     view per frame);
//  2. the brute-force ReferenceRadiance (core) over the same 128 x 64 pixels with Fejer solid
//     angles computed by the test fixture (every other pixel) of what each mode shows:
//     B(N, V_pixel) for mode 2, B(R, V_central) for mode 1;
//  3. (background) core's EnvMap::Radiance along each pixel ray.
// A pixel fails when |gpu - ref| > tol * max(|ref|, floor) (RGB Euclidean norms); a view fails
// when more than the allowed fraction of the compared pixels fail, or one exceeds the hard limit.
// Nothing is stored: every reference is computed here (~6 s on 2 cores). With
// SHRM_VIEWER_TEST_OUTPUT=DIR the compared images are written there to look at.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/parallel.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_shader_params.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_reference.h"
#include "shrm/shaders.h"
#include "tests/test_maps.h"
#include "viewer/camera.h"
#include "viewer/cpu_images.h"
#include "viewer/gl_util.h"
#include "viewer/mesh.h"
#include "viewer/renderer.h"
#include "viewer/split_sum_shading.h"

namespace shrm::viewer {
namespace {

constexpr int kWidth = 96, kHeight = 96;
constexpr char kBrdf[] = "microfacet:sigma=0.25";
// Orders beyond the epsilon = 0.03 choice (11, 2), so that the brute-force comparison sees the
// viewer more than the order truncation; S_B = 64 keeps the texel interpolation at ~1e-3.
constexpr int kF = 20, kP = 4, kFaceSize = 64;

// GPU vs CPU evaluation of the same cube: float shader arithmetic vs double, the texture unit's
// reduced-precision bilinear weights, and GL's seamless cube filtering at face edges (mode 1
// and mode 2's filtered pass) vs core's adjacent-face texel rule.
constexpr double kSameCubeTol = 0.01;
// Pixels near the silhouette: the triangle mesh's interpolated normals and its coverage of the
// pixel centres differ slightly from the analytic sphere.
constexpr double kSameCubeFailFraction = 0.01;
// No pixel may be off by more than this (a wrong frame, face or orientation is off by O(1)).
constexpr double kSameCubeHardLimit = 0.1;
// The same with a Fresnel table (GGX f0 = 0.04): w(N.V) has slope ~4.8 at N.V -> 0, so there the
// mesh's normal error turns into tens of percent (measured 25% at one silhouette pixel); those
// comparisons skip N.V below this.
constexpr double kFresnelSilhouetteCos = 0.1;

// GPU vs brute force only where N.V >= kMinCosView: the SHRM's own truncation error at
// (F, P) = (20, 4) grows towards grazing views (the reflection-vector reparameterization of a
// horizon-clipped lobe needs more P there; CPU ShrmEval vs ReferenceRadiance on this sphere, rel.
// RMS: 0.27 for N.V < 0.2, 0.077 in [0.2, 0.4), 0.024 in [0.4, 0.6), 0.006 above 0.8). Near
// the silhouette the viewer is checked against the CPU evaluation of the same cube (above).
constexpr double kMinCosView = 0.4;
// Both modes against the brute force of what they show: truncation + cube interpolation
// (measured: 0.04-4.8 % of the pixels over 10 %, max 0.72, docs/results.md "Viewer").
constexpr double kTruthTol = 0.1;
constexpr double kTruthFailFraction = 0.1;
constexpr double kTruthHardLimit = 1.0;
// Relative errors are measured against max(|truth|, floor * mean |truth|): dark pixels.
constexpr double kFloorFraction = 0.25;

struct Comparison {
  int64_t pixels = 0, failed = 0;
  double max_rel = 0, rms_rel = 0;
};

// Compares the GPU's HDR readback (RGBA, rows from the top) with a CPU image on the pixels
// `mask` selects (covered by both).
Comparison Compare(const std::vector<float>& gpu, const Image& cpu, const std::vector<bool>& mask,
                   double tol) {
  double mean = 0;
  int64_t n = 0;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    mean += std::sqrt(cpu.pixels[3 * i] * cpu.pixels[3 * i] +
                      cpu.pixels[3 * i + 1] * cpu.pixels[3 * i + 1] +
                      cpu.pixels[3 * i + 2] * cpu.pixels[3 * i + 2]);
    ++n;
  }
  mean /= std::max<int64_t>(1, n);
  Comparison c;
  double sum2 = 0;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    double d2 = 0, r2 = 0;
    for (int ch = 0; ch < 3; ++ch) {
      const double d = gpu[4 * i + ch] - cpu.pixels[3 * i + ch];
      d2 += d * d;
      r2 += static_cast<double>(cpu.pixels[3 * i + ch]) * cpu.pixels[3 * i + ch];
    }
    const double rel = std::sqrt(d2) / std::max(std::sqrt(r2), kFloorFraction * mean);
    ++c.pixels;
    if (rel > tol) ++c.failed;
    c.max_rel = std::max(c.max_rel, rel);
    sum2 += rel * rel;
  }
  c.rms_rel = std::sqrt(sum2 / std::max<int64_t>(1, c.pixels));
  return c;
}

// With SHRM_VIEWER_TEST_OUTPUT=DIR the compared images are written there as PNG previews
// (<name>_gpu.png, <name>_cpu.png, <name>_err.png: relative error x 10, clamped), to look at.
void Dump(const std::string& name, const std::vector<float>& gpu, const Image& cpu,
          const std::vector<bool>& mask) {
  const char* dir = std::getenv("SHRM_VIEWER_TEST_OUTPUT");
  if (dir == nullptr) return;
  Image g = cpu, e = cpu;
  for (size_t i = 0; i < mask.size(); ++i) {
    double d2 = 0, r2 = 0;
    for (int c = 0; c < 3; ++c) {
      g.pixels[3 * i + c] = gpu[4 * i + c];
      d2 += std::pow(gpu[4 * i + c] - cpu.pixels[3 * i + c], 2);
      r2 += std::pow(cpu.pixels[3 * i + c], 2);
    }
    const float rel = mask[i] ? static_cast<float>(std::sqrt(d2 / std::max(r2, 1e-30))) : 0.0f;
    for (int c = 0; c < 3; ++c) e.pixels[3 * i + c] = std::min(1.0f, 10 * rel);
  }
  const std::string base = std::string(dir) + "/" + name;
  EXPECT_TRUE(WritePreviewPng(base + "_gpu.png", g, 0).ok());
  EXPECT_TRUE(WritePreviewPng(base + "_cpu.png", cpu, 0).ok());
  EXPECT_TRUE(WriteImage8Bit(base + "_err.png", e).ok());
}

void Expect(const Comparison& c, double fail_fraction, double hard_limit, const char* what) {
  std::printf("[%s] %lld px, %lld over tolerance (%.2f%%), rel. RMS %.2e, max %.3f\n", what,
              static_cast<long long>(c.pixels), static_cast<long long>(c.failed),
              100.0 * c.failed / std::max<int64_t>(1, c.pixels), c.rms_rel, c.max_rel);
  EXPECT_GT(c.pixels, 500) << what;
  EXPECT_LE(c.failed, fail_fraction * c.pixels) << what;
  EXPECT_LE(c.max_rel, hard_limit) << what;
}

// Views: a generic one, and one looking down near the +Y pole, where the local frames of the
// texels turn fastest (mode 2 must not mix them).
const OrbitView kViews[] = {{30, 20, 3}, {-120, 75, 3}};

class ViewerRenderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    map_ = new Image(testing::LoadBundledMap("courtyard.exr", 128));
    const EnvMap env = EnvMap::FromLatLong(*map_);
    brdf_ = ParseBrdfSpec(kBrdf).value().release();
    brdf_shared_ = std::shared_ptr<const Brdf>(ParseBrdfSpec(kBrdf).value());
    PrefilterOptions opt;
    opt.f = kF;
    opt.p = kP;
    opt.face_size = kFaceSize;
    opt.threads = 2;
    auto data = std::make_shared<ShrmData>();
    opt.kind = ShrmKind::kGlobal;
    data->global = Prefilter(env, *brdf_, opt).value().cube;
    opt.kind = ShrmKind::kLocal;  // core's local synthesis, not the viewer's conversion
    data->local = Prefilter(env, *brdf_, opt).value().cube;
    data->f_b = kF;
    data->p_b = kP;
    shrm_ = data;
    absl::StatusOr<std::unique_ptr<GlContext>> ctx =
        GlContext::Create(kWidth, kHeight, /*visible=*/false, "viewer_render_test");
    ASSERT_TRUE(ctx.ok()) << ctx.status() << " (run under xvfb-run -a)";
    context_ = ctx->release();
    absl::StatusOr<std::unique_ptr<Renderer>> r = Renderer::Create(kWidth, kHeight, 2);
    ASSERT_TRUE(r.ok()) << r.status();
    renderer_ = r->release();
    renderer_->SetMesh(MakeSphere(256, 128));
    SceneData scene;
    scene.shrm = shrm_;
    ASSERT_TRUE(renderer_->SetScene(scene).ok());
  }
  static void TearDownTestSuite() {
    delete renderer_;
    delete context_;
    delete brdf_;
    delete map_;
    shrm_.reset();
    brdf_shared_.reset();
  }

  // HDR frame of `mode` without background.
  // Modes 1 and 2 at every view of kViews against the CPU's evaluation of the scene's SHRMs
  // (`data`): mode 1 by eq. 5.35 for the central view, mode 2 by eq. 5.10 per pixel.
  static void ExpectModesMatchCpu(const ShrmData& data, const std::string& label,
                                  double min_cos_view = -1, const Brdf* lights_brdf = nullptr) {
    for (const OrbitView& view : kViews) {
      const OrbitCamera camera(view);
      const GeometryBuffer g = SphereGeometry(camera, kWidth, kHeight);
      const std::vector<float> m1 = RenderMode(1, camera), m2 = RenderMode(2, camera);
      const Image c1 = ShadeImage(
          g, ShrmPixelShader(data.global, ViewModel::kCentral, camera.CentralView(), lights_brdf),
          2);
      const Image c2 =
          ShadeImage(g, ShrmPixelShader(data.local, ViewModel::kPerPixel, {}, lights_brdf), 2);
      std::printf("view %g,%g,%g\n", view.azimuth_deg, view.elevation_deg, view.distance);
      const std::string tag =
          absl::StrCat(label, "cpu_", view.azimuth_deg, "_", view.elevation_deg);
      Dump(tag + "_mode1", m1, c1, Mask(m1, g, min_cos_view));
      Dump(tag + "_mode2", m2, c2, Mask(m2, g, min_cos_view));
      Expect(Compare(m1, c1, Mask(m1, g, min_cos_view), kSameCubeTol), kSameCubeFailFraction,
             kSameCubeHardLimit,
             (label + "mode 1 vs CPU eq. 5.35 map (global, central V)").c_str());
      Expect(Compare(m2, c2, Mask(m2, g, min_cos_view), kSameCubeTol), kSameCubeFailFraction,
             kSameCubeHardLimit, (label + "mode 2 vs CPU ShrmEval (local, per-pixel V)").c_str());
    }
  }

  static std::vector<float> RenderMode(int mode, const OrbitCamera& camera) {
    RenderSettings s;
    s.mode = mode;
    s.background = false;
    EXPECT_TRUE(renderer_->Render(camera, s).ok());
    return renderer_->ReadHdr();
  }

  // Covered by the GPU frame and by the analytic sphere, with N.V >= min_cos_view.
  static std::vector<bool> Mask(const std::vector<float>& gpu, const GeometryBuffer& g,
                                double min_cos_view = -1) {
    std::vector<bool> m(g.pixels.size());
    for (size_t i = 0; i < m.size(); ++i) {
      const PixelGeometry& p = g.pixels[i];
      m[i] = p.hit && gpu[4 * i + 3] > 0 && p.normal.Dot(p.view) >= min_cos_view;
    }
    return m;
  }

  static Image* map_;
  static Brdf* brdf_;
  static std::shared_ptr<const Brdf> brdf_shared_;
  static std::shared_ptr<const ShrmData> shrm_;
  static GlContext* context_;
  static Renderer* renderer_;
};

Image* ViewerRenderTest::map_ = nullptr;
Brdf* ViewerRenderTest::brdf_ = nullptr;
std::shared_ptr<const Brdf> ViewerRenderTest::brdf_shared_;
std::shared_ptr<const ShrmData> ViewerRenderTest::shrm_;
GlContext* ViewerRenderTest::context_ = nullptr;
Renderer* ViewerRenderTest::renderer_ = nullptr;

TEST_F(ViewerRenderTest, ModesMatchCpuEvaluationOfTheSameShrm) {
  ASSERT_NE(renderer_, nullptr);
  ExpectModesMatchCpu(*shrm_, "");
}

// SHRMs in the normal variable (shrm:view_variable "normal", docs/shaders.md): the global pass
// with SHRM_VIEW_NORMAL (each texel at its own normal) and the local form with the argument
// ShrmViewNormal(R, V), against the CPU's evaluation of the same cubes. GGX with f0 = 0.04: the
// cubes carry the Fresnel table (shrm_common.glsl ShrmFresnel), which both sides multiply by; in
// the view variable too (conventions 4: N.V = |R + V| / 2 there, ShrmFresnelCos).
TEST_F(ViewerRenderTest, NormalVariableModesMatchCpuEvaluation) {
  ASSERT_NE(renderer_, nullptr);
  const EnvMap env = EnvMap::FromLatLong(*map_);
  const std::unique_ptr<Brdf> ggx = ParseBrdfSpec("ggx:alpha=0.3,f0=0.04").value();
  for (const ViewVariable view : {ViewVariable::kNormal, ViewVariable::kView}) {
    PrefilterOptions opt;
    opt.f = kF;
    opt.p = kP;
    opt.face_size = kFaceSize;
    opt.threads = 2;
    opt.view = view;
    auto data = std::make_shared<ShrmData>(*shrm_);
    opt.kind = ShrmKind::kGlobal;
    data->global = Prefilter(env, *ggx, opt).value().cube;
    opt.kind = ShrmKind::kLocal;
    data->local = Prefilter(env, *ggx, opt).value().cube;
    ASSERT_EQ(data->global.view, view);
    ASSERT_EQ(data->global.fresnel.size(), static_cast<size_t>(kFresnelIntervals + 1));
    ASSERT_EQ(data->local.fresnel.size(), static_cast<size_t>(kFresnelIntervals + 1));
    SceneData scene;
    scene.shrm = data;
    ASSERT_TRUE(renderer_->SetScene(scene).ok());
    ExpectModesMatchCpu(*data, absl::StrCat(ViewVariableName(view), " variable: "),
                        kFresnelSilhouetteCos);
  }
  SceneData back;
  back.shrm = shrm_;
  ASSERT_TRUE(renderer_->SetScene(back).ok());
}

// Peak lights (shaders/glsl/shrm_lights.glsl, SHRM_LIGHTS): mode 1's pass adds them at each
// texel's own normal, mode 2 at the pixel's N and V; against the CPU's evaluation of the same
// cubes plus core's exact light sum (ShrmLightsRadiance with the core BRDF). Three lights of
// about a sun pixel's L dOmega, on the microfacet cubes (view variable) and on GGX cubes in the
// normal variable with the Fresnel table.
TEST_F(ViewerRenderTest, PeakLightsModesMatchCpuEvaluation) {
  ASSERT_NE(renderer_, nullptr);
  const std::vector<ShrmLight> lights = {{{0.3f, 0.8f, 0.5f}, {0.5f, 0.45f, 0.4f}},
                                         {{-0.7f, 0.2f, 0.6f}, {0.2f, 0.3f, 0.1f}},
                                         {{0.1f, -0.4f, -0.9f}, {0.3f, 0.3f, 0.35f}}};
  auto with_lights = [&](ShrmCube cube) {
    cube.lights = lights;
    for (ShrmLight& l : cube.lights) {
      const Vec3 d = Vec3{l.dir[0], l.dir[1], l.dir[2]}.Normalized();
      l.dir = {static_cast<float>(d.x), static_cast<float>(d.y), static_cast<float>(d.z)};
    }
    return cube;
  };
  const EnvMap env = EnvMap::FromLatLong(*map_);
  const std::unique_ptr<Brdf> ggx = ParseBrdfSpec("ggx:alpha=0.3,f0=0.04").value();
  for (const Brdf* brdf : {static_cast<const Brdf*>(brdf_), static_cast<const Brdf*>(ggx.get())}) {
    auto data = std::make_shared<ShrmData>(*shrm_);
    if (brdf == ggx.get()) {
      PrefilterOptions opt;
      opt.f = kF;
      opt.p = kP;
      opt.face_size = kFaceSize;
      opt.threads = 2;
      opt.view = ViewVariable::kNormal;
      opt.kind = ShrmKind::kGlobal;
      data->global = Prefilter(env, *ggx, opt).value().cube;
      opt.kind = ShrmKind::kLocal;
      data->local = Prefilter(env, *ggx, opt).value().cube;
    }
    data->global = with_lights(data->global);
    data->local = with_lights(data->local);
    data->light_brdf = BrdfShaderParamsFor(*brdf).value();
    SceneData scene;
    scene.shrm = data;
    ASSERT_TRUE(renderer_->SetScene(scene).ok());
    EXPECT_NE(renderer_->ModeStatus(1).find("3 peak lights"), std::string::npos)
        << renderer_->ModeStatus(1);
    ExpectModesMatchCpu(*data, absl::StrCat(brdf->spec(), " + 3 peak lights: "),
                        kFresnelSilhouetteCos, brdf);
  }
  SceneData back;
  back.shrm = shrm_;
  ASSERT_TRUE(renderer_->SetScene(back).ok());
}

// The shaders' copy of each analytic BRDF (ShrmLightTransfer, shaders/glsl/shrm_lights.glsl)
// against core's Brdf::Transfer (double) at 4096 seeded (N, V, w) triples per model, half of them
// with w near the mirror direction where the lobes are large. Triples within kHorizonMargin of a
// cut (N.w, N.V, R.w or Kajiya-Kay's cos(theta_i' - theta_o') = 0) are skipped: float and double
// may fall on either side there.
TEST_F(ViewerRenderTest, LightTransferMatchesCoreModels) {
  ASSERT_NE(renderer_, nullptr);
  constexpr int kSide = 64, kTriples = kSide * kSide;
  constexpr double kHorizonMargin = 0.02;
  // Float shader arithmetic against double. The Gaussian of microfacet amplifies the error of
  // llvmpipe's asin (theta_h, ~2e-5 rad) by 2 theta_h / sigma^2: measured 6e-4 at sigma 0.15;
  // the other models measured below 7e-5 (pow of exponents up to 64, exp, sqrt).
  constexpr double kTransferTol = 2e-3;
  // Values below this fraction of the model's largest are judged by that absolute floor.
  constexpr double kTransferFloor = 1e-3;
  const char* kSpecs[] = {"lambert:albedo=0.8",
                          "phong:s=64",
                          "microfacet:sigma=0.15",
                          "lafortune:rho_d=0.1;cx=-0.9,cz=0.8,n=15,rho=1.5;cx=-1,cz=1,n=40,rho=0.5",
                          "ward:alpha=0.2,rho_s=0.1,rho_d=0.05",
                          "ward:alpha_x=0.15,alpha_y=0.4,rho_s=0.2,rho_d=0",
                          "ggx:alpha=0.1,f0=0.04",
                          "ggx:alpha=0.4,f0=1",
                          "kajiya-kay:s=32"};
  const std::string fragment =
      absl::StrCat("#version 330 core\n#define PMAX 0\n#define SHRM_LIGHTS\n", shaders::kCommonGlsl,
                   shaders::kLightsGlsl, R"(
uniform sampler2D u_triples;  // 64 x 192: N, V, w in rows y, y + 64, y + 128
out vec4 o_color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 n = texelFetch(u_triples, p, 0).xyz;
  vec3 v = texelFetch(u_triples, p + ivec2(0, 64), 0).xyz;
  vec3 w = texelFetch(u_triples, p + ivec2(0, 128), 0).xyz;
  o_color = vec4(ShrmLightTransfer(n, v, w), 0.0, 0.0, 1.0);
}
)");
  absl::StatusOr<GlProgram> program =
      BuildProgram(kFullscreenVertexShader, fragment, "ShrmLightTransfer test");
  ASSERT_TRUE(program.ok()) << program.status();
  absl::StatusOr<std::unique_ptr<Framebuffer>> fb = Framebuffer::Create(kSide, kSide, {GL_RGBA32F});
  ASSERT_TRUE(fb.ok()) << fb.status();
  GlTexture input = GlTexture::Generate();
  GlVertexArray vao = GlVertexArray::Generate();
  std::mt19937_64 rng(20261206);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> unit(0, 1);
  auto random_dir = [&] { return Vec3{gauss(rng), gauss(rng), gauss(rng)}.Normalized(); };
  for (const char* spec : kSpecs) {
    const std::unique_ptr<Brdf> brdf = ParseBrdfSpec(spec).value();
    const BrdfShaderParams params = BrdfShaderParamsFor(*brdf).value();
    const bool tangent = brdf->reparam() == ReparamKind::kTangent;
    std::vector<Vec3> n(kTriples), v(kTriples), w(kTriples);
    std::vector<float> texels(static_cast<size_t>(kTriples) * 3 * 4, 0.0f);
    std::vector<bool> skip(kTriples, false);
    for (int i = 0; i < kTriples; ++i) {
      n[i] = random_dir();
      v[i] = random_dir();
      if (!tangent && v[i].Dot(n[i]) < 0) v[i] = v[i] * -1.0;
      const Vec3 mirror = tangent ? v[i] * -1.0 : n[i] * (2 * n[i].Dot(v[i])) - v[i];
      w[i] = i % 2 ? random_dir() : (mirror + random_dir() * (0.4 * unit(rng))).Normalized();
      const double nw = n[i].Dot(w[i]), nv = n[i].Dot(v[i]), rw = mirror.Dot(w[i]);
      const double si = std::sqrt(std::max(0.0, 1 - nw * nw)),
                   so = std::sqrt(std::max(0.0, 1 - nv * nv));
      skip[i] = std::abs(nw) < kHorizonMargin || std::abs(nv) < kHorizonMargin ||
                std::abs(rw) < kHorizonMargin || std::abs(nw * nv + si * so) < kHorizonMargin;
      Vec3* rows[3] = {&n[i], &v[i], &w[i]};
      for (int r = 0; r < 3; ++r) {
        const size_t t = (static_cast<size_t>(r) * kTriples + i) * 4;
        texels[t] = static_cast<float>(rows[r]->x);
        texels[t + 1] = static_cast<float>(rows[r]->y);
        texels[t + 2] = static_cast<float>(rows[r]->z);
        // The shader sees the float vectors: so does the reference.
        *rows[r] = {texels[t], texels[t + 1], texels[t + 2]};
      }
    }
    glBindTexture(GL_TEXTURE_2D, input.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, kSide, 3 * kSide, 0, GL_RGBA, GL_FLOAT,
                 texels.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glBindFramebuffer(GL_FRAMEBUFFER, (*fb)->id());
    glViewport(0, 0, kSide, kSide);
    glDisable(GL_DEPTH_TEST);
    glUseProgram(program->get());
    SetUniform(program->get(), "u_triples", 0);
    SetUniform(program->get(), "shrm_light_model", static_cast<int>(params.model));
    glUniform4fv(glGetUniformLocation(program->get(), "shrm_light_brdf"), kBrdfShaderValues / 4,
                 params.values.data());
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, input.get());
    glBindVertexArray(vao.get());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glUseProgram(0);
    const std::vector<float> gpu = (*fb)->ReadRgba(0);  // rows from the top
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    std::vector<double> cpu(kTriples);
    double largest = 0;
    for (int i = 0; i < kTriples; ++i) {
      cpu[i] = brdf->Transfer(n[i], v[i], w[i], 0);
      largest = std::max(largest, std::abs(cpu[i]));
    }
    ASSERT_GT(largest, 0) << spec;
    int compared = 0, nonzero = 0;
    double worst = 0;
    for (int i = 0; i < kTriples; ++i) {
      if (skip[i]) continue;
      const int x = i % kSide, y = i / kSide;
      const double g = gpu[(static_cast<size_t>(kSide - 1 - y) * kSide + x) * 4];
      const double rel =
          std::abs(g - cpu[i]) / std::max(std::abs(cpu[i]), kTransferFloor * largest);
      worst = std::max(worst, rel);
      ++compared;
      if (cpu[i] > kTransferFloor * largest) ++nonzero;
      EXPECT_LE(rel, kTransferTol)
          << spec << " triple " << i << ": shader " << g << ", core " << cpu[i];
      if (rel > kTransferTol) break;
    }
    std::printf("[%s] %d triples (%d lit), largest relative difference %.2e\n", spec, compared,
                nonzero, worst);
    EXPECT_GT(compared, kTriples / 2) << spec;
    EXPECT_GT(nonzero, kTriples / 8) << spec;
  }
}

TEST_F(ViewerRenderTest, ModesMatchBruteForce) {
  ASSERT_NE(renderer_, nullptr);
  const std::vector<EnvSample> samples = testing::LatLongSamples(*map_);
  const Brdf& b = *brdf_;
  const TransferFunction transfer = [&b](const Vec3& n, const Vec3& v, const Vec3& w, int) {
    return b.Transfer(n, v, w, 0);
  };
  const PixelShader brute_force = [&](const PixelGeometry& p) {
    return ReferenceRadiance(samples, transfer, p.normal, p.view);
  };
  for (const OrbitView& view : kViews) {
    const OrbitCamera camera(view);
    // Mode 2 shows B(N, V_pixel). Every other pixel (checkerboard) keeps the brute force short.
    GeometryBuffer g2 = SphereGeometry(camera, kWidth, kHeight);
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        if ((x + y) % 2) g2.pixels[static_cast<size_t>(y) * kWidth + x].hit = false;
    // Mode 1 shows eq. 5.35's B(R, V_c): the pixel's reflection vector R = 2 (N.V) N - V with
    // the central view V_c, i.e. the normal N' = normalize(R + V_c) seen from V_c.
    GeometryBuffer g1 = g2;
    const Vec3 vc = camera.CentralView();
    for (PixelGeometry& p : g1.pixels) {
      if (!p.hit) continue;
      const Vec3 r = p.normal * (2 * p.normal.Dot(p.view)) - p.view;
      if ((r + vc).Norm() < 1e-6) {
        p.hit = false;
        continue;
      }
      p.normal = (r + vc).Normalized();
      p.view = vc;
    }
    const Image truth2 = ShadeImage(g2, brute_force, 2), truth1 = ShadeImage(g1, brute_force, 2);
    const std::vector<float> m1 = RenderMode(1, camera), m2 = RenderMode(2, camera);
    std::printf("view %g,%g,%g\n", view.azimuth_deg, view.elevation_deg, view.distance);
    const std::string tag = absl::StrCat("truth_", view.azimuth_deg, "_", view.elevation_deg);
    Dump(tag + "_mode2", m2, truth2, Mask(m2, g2, kMinCosView));
    Dump(tag + "_mode1", m1, truth1, Mask(m1, g1, kMinCosView));
    Expect(Compare(m2, truth2, Mask(m2, g2, kMinCosView), kTruthTol), kTruthFailFraction,
           kTruthHardLimit, "mode 2 vs brute force B(N, V_pixel)");
    Expect(Compare(m1, truth1, Mask(m1, g1, kMinCosView), kTruthTol), kTruthFailFraction,
           kTruthHardLimit, "mode 1 vs brute force B(R, V_central)");
  }
}

// The background is the environment seen along each pixel ray (orientation of the lat-long
// lookup and of the camera), compared with core's EnvMap::Radiance.
TEST_F(ViewerRenderTest, BackgroundIsTheEnvironmentAlongThePixelRays) {
  ASSERT_NE(renderer_, nullptr);
  auto env = std::make_shared<EnvironmentData>(EnvMap::FromLatLong(*map_));
  env->latlong = *map_;
  SceneData scene = renderer_->scene();
  scene.env = env;
  ASSERT_TRUE(renderer_->SetScene(scene).ok());
  const OrbitCamera camera(kViews[0]);
  RenderSettings s;
  s.mode = 1;
  ASSERT_TRUE(renderer_->Render(camera, s).ok());
  const std::vector<float> gpu = renderer_->ReadHdr();
  GeometryBuffer g = SphereGeometry(camera, kWidth, kHeight);
  Image cpu;
  cpu.width = kWidth;
  cpu.height = kHeight;
  cpu.channels = 3;
  cpu.pixels.resize(static_cast<size_t>(kWidth) * kHeight * 3);
  std::vector<bool> mask(g.pixels.size());
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const size_t i = static_cast<size_t>(y) * kWidth + x;
      const std::array<float, 3> rgb = env->map.Radiance(camera.PixelRay(x, y, kWidth, kHeight));
      for (int c = 0; c < 3; ++c) cpu.pixels[3 * i + c] = rgb[c];
      mask[i] = gpu[4 * i + 3] == 0;
    }
  // Both bilinear on the same texels: float weights and the u seam.
  constexpr double kBackgroundTol = 0.01;
  constexpr double kBackgroundFailFraction = 0.01;
  constexpr double kBackgroundHardLimit = 0.2;
  Expect(Compare(gpu, cpu, mask, kBackgroundTol), kBackgroundFailFraction, kBackgroundHardLimit,
         "background vs EnvMap::Radiance");
}

// Mode 6 (the split-sum of a GGX BRDF) against its CPU twin on the same chain and DFG table
// (viewer/split_sum_shading.h): trilinear cube lookup at Filament's lod, the table by N.V. The
// split-sum's own error against the truth is measured by bench/split_sum_vs_shrm (docs/results.md
// "Split-sum vs SHRM"), not here: it is the approximation, not the viewer.
TEST_F(ViewerRenderTest, SplitSumModeMatchesItsCpuTwin) {
  ASSERT_NE(renderer_, nullptr);
  const SceneData saved = renderer_->scene();
  auto env = std::make_shared<EnvironmentData>(EnvMap::FromLatLong(*map_));
  env->latlong = *map_;
  SceneData scene = saved;
  scene.env = env;
  scene.brdf = std::shared_ptr<const Brdf>(ParseBrdfSpec("ggx:alpha=0.2,f0=0.5").value());
  ASSERT_TRUE(renderer_->SetScene(scene).ok());
  ASSERT_TRUE(renderer_->ModeReady(6));
  absl::StatusOr<SplitSumShading> twin = SplitSumShading::Create(env->map, *scene.brdf, 2);
  ASSERT_TRUE(twin.ok()) << twin.status();
  for (const OrbitView& view : kViews) {
    const OrbitCamera camera(view);
    const GeometryBuffer g = SphereGeometry(camera, kWidth, kHeight);
    const std::vector<float> gpu = RenderMode(6, camera);
    const Image cpu = ShadeImage(
        g, [&](const PixelGeometry& p) { return twin->Eval(p.normal, p.view); }, 2);
    Dump(absl::StrCat("split_sum_", view.azimuth_deg, "_", view.elevation_deg), gpu, cpu,
         Mask(gpu, g));
    // The same lookups as modes 1 and 2 (float weights, seamless edges) plus GL's trilinear
    // mix of two levels and the table's linear filter in 8-bit subtexel precision.
    Expect(Compare(gpu, cpu, Mask(gpu, g), kSameCubeTol), kSameCubeFailFraction, kSameCubeHardLimit,
           "mode 6 vs its CPU twin (split-sum)");
  }
  // A BRDF that is not GGX: mode 6 has nothing to draw, and says so without an error.
  scene.brdf = brdf_shared_;
  ASSERT_TRUE(renderer_->SetScene(scene).ok());
  EXPECT_FALSE(renderer_->ModeReady(6));
  ASSERT_TRUE(renderer_->SetScene(saved).ok());
}

}  // namespace
}  // namespace shrm::viewer
