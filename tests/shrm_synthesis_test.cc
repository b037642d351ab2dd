// SHRM synthesis (SHRM paper eqs. 5.7-5.14, 5.23-5.24) against the angular-domain reference on a
// real HDR map, as docs/shrm.md describes: L_lm by the transform of a 128 x 64 box-downsampled
// courtyard map, EnvSamples of the same pixels with Fejer-1 solid angles, and a view-dependent
// isotropic test BRDF built INSIDE the test from chosen coefficients,
//   rho-hat(w_i', w_o') = sum rho_lpq conj(Y_lq(w_i')) Y_pq(w_o')   (l <= 20, p <= 3),
// so it is band-limited by construction and the pixel sum of L rho-hat equals the frequency-space
// sum exactly (the transform's plain Fejer quadrature on H = 64 rings is the same pixel sum).
#include "core/shrm/shrm_synthesis.h"

#include <cmath>
#include <complex>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/io/image.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"
#include "core/shrm/shrm_reference.h"
#include "core/transform/sht.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Frequency path vs pixel sum for a band-limited BRDF: identical sums up to rounding of ~1e4
// terms spanning the sun's dynamic range (MATH.md saw 4.5e-8); the float map is shared.
constexpr double kDirectVsReferenceTol = 1e-9;  // measured 2e-15
// Global = RotateSh of the local coefficients: rounding only.
constexpr double kGlobalVsLocalTol = 1e-10;
// White furnace through float texels: float rounding of O(1) values.
constexpr double kFurnaceTol = 1e-5;
// Wigner columns by our recurrence vs the library's full tables (both double recurrences).
constexpr double kWignerTol = 1e-11;
// Grid (4x4 Lagrange) + float storage at texel centres, F = 20 on >= 128 alpha rows:
// (F h)^4 / 40 ~ 6e-5 for the top band, smaller for the energy-weighted error.
constexpr double kTexelCentreTol = 2e-4;
// A quadratic Fresnel table against its closed form: the table's nodes are floats (6e-8 of w).
constexpr double kFresnelQuadraticTol = 1e-6;
// The direct cube at its texel centres: float storage of O(1) values only.
constexpr double kDirectCubeTol = 1e-6;
// ShrmEval from N against ShrmEvalAt from R = 2 (N.V) N - V, whose argument (R + V)/|R + V| is N
// again up to the rounding of the reflection and the normalization.
constexpr double kSameArgumentTol = 1e-9;

constexpr int kF = 20;
constexpr int kP = 3;

struct Scene {
  ShtGrid grid{128, 64, ShtGridKind::kEquiangular};
  std::vector<float> map;
  std::vector<EnvSample> samples;
  std::vector<double> light;  // real L_lm, degree kF, 3 channels
};

const Scene& GetScene() {
  static const Scene* scene = [] {
    auto* s = new Scene;
    const Image img = testing::LoadBundledMap("courtyard.exr", s->grid.width);
    s->map = img.pixels;
    s->samples = testing::LatLongSamples(img);
    auto light = ForwardSht(s->grid, kF, 3, s->map);
    EXPECT_TRUE(light.ok()) << light.status();
    s->light = *light;
    return s;
  }();
  return *scene;
}

// Chosen coefficients of a smooth, view-dependent isotropic BRDF (grey).
BrdfCoefficients TestBrdf(int lmax = kF, int pmax = kP) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = pmax;
  b.channels = 1;
  b.values.assign(static_cast<size_t>(lmax + 1) * (pmax + 1) * (pmax + 1), 0.0);
  for (int l = 0; l <= lmax; ++l)
    for (int p = 0; p <= pmax; ++p)
      for (int q = 0; q <= std::min(l, p); ++q)
        b.values[b.Index(l, p, q, 0)] = std::exp(-l * (l + 1) / 120.0) * std::pow(0.45, p) *
                                        std::pow(-0.6, q) * (1.0 + 0.05 * l * p) *
                                        (p == 0 ? 1.0 : std::cos(0.3 * l + p));
  return b;
}

// rho-hat(w_i', w_o') of a coefficient set, in a world-frame local frame with pole R (the
// view's argument w_o' is V in that frame, or N for ViewVariable::kNormal).
class TestTransfer {
 public:
  explicit TestTransfer(const BrdfCoefficients& b) : b_(b) {}
  double operator()(const Vec3& n, const Vec3& v, const Vec3& w, int /*c*/) {
    if (n.x != n_.x || n.y != n_.y || n.z != n_.z || v.x != v_.x || v.y != v_.y || v.z != v_.z)
      Prepare(n, v);
    const Vec3 wl{w.Dot(e1_), w.Dot(e2_), w.Dot(r_)};
    double theta, phi;
    AnglesFromDirection(wl, &theta, &phi);
    EvalComplexSh(b_.lmax, theta, phi, yi_);
    double sum = 0;
    for (int l = 0; l <= b_.lmax; ++l)
      for (int q = -std::min(l, b_.pmax); q <= std::min(l, b_.pmax); ++q)
        sum += (std::conj(yi_[ShIndex(l, q)]) * g_[ShIndex(l, q)]).real();
    return sum * fresnel_;
  }
  // The coefficients' Fresnel table is `w` (a closed form) at N.V: the sum times w(n.v).
  void SetFresnel(std::function<double(double)> w) { w_ = std::move(w); }

 private:
  void Prepare(const Vec3& n, const Vec3& v) {
    n_ = n;
    v_ = v;
    fresnel_ = w_ ? w_(n.Dot(v)) : 1.0;
    r_ = (n * (2 * n.Dot(v)) - v).Normalized();
    const Vec3 a = std::abs(r_.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    e1_ = a.Cross(r_).Normalized();
    e2_ = r_.Cross(e1_);
    const Vec3 arg = b_.view == ViewVariable::kNormal ? n : v;
    const Vec3 vl{arg.Dot(e1_), arg.Dot(e2_), arg.Dot(r_)};
    double theta, phi;
    AnglesFromDirection(vl, &theta, &phi);
    std::vector<std::complex<double>> yo(ShCount(b_.pmax));
    EvalComplexSh(b_.pmax, theta, phi, yo);
    g_.assign(ShCount(b_.lmax), 0.0);
    yi_.assign(ShCount(b_.lmax), 0.0);
    for (int l = 0; l <= b_.lmax; ++l)
      for (int q = -std::min(l, b_.pmax); q <= std::min(l, b_.pmax); ++q)
        for (int p = std::abs(q); p <= b_.pmax; ++p)
          g_[ShIndex(l, q)] += b_.at(l, p, q) * yo[ShIndex(p, q)];
  }
  BrdfCoefficients b_;
  std::function<double(double)> w_;
  double fresnel_ = 1.0;
  Vec3 n_{2, 2, 2}, v_, r_, e1_, e2_;
  std::vector<std::complex<double>> g_, yi_;
};

Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3{g(rng), g(rng), g(rng)}.Normalized();
}

// Random front-facing (N, V): V uniform, N uniform in the hemisphere around V.
void RandomNormalView(std::mt19937& rng, Vec3* n, Vec3* v) {
  *v = RandomUnit(rng);
  do {
    *n = RandomUnit(rng);
  } while (n->Dot(*v) < 0.05);
}

ShrmSynthesizer MakeSynth(const BrdfCoefficients& b) {
  auto s = ShrmSynthesizer::Create(kF, 3, GetScene().light, b);
  EXPECT_TRUE(s.ok()) << s.status();
  return *std::move(s);
}

TEST(WignerColumnsTest, MatchLibraryTablesIncludingOutsideZeroPi) {
  constexpr int kL = 30, kQ = 4;
  std::vector<double> cols(WignerColumnCount(kL, kQ));
  for (double alpha : {-0.07, 0.0, 1e-3, 0.9, 2.4, kPi, kPi + 0.05}) {
    WignerColumns(kL, kQ, alpha, cols);
    const std::vector<double> d = WignerSmallDTable(kL, alpha);
    double worst = 0;
    for (int l = 0; l <= kL; ++l)
      for (int m = -l; m <= l; ++m)
        for (int q = -std::min(l, kQ); q <= std::min(l, kQ); ++q)
          worst = std::max(worst, std::abs(cols[WignerColumnIndex(kL, kQ, l, m, q)] -
                                           d[WignerBandOffset(l) + WignerBlockIndex(l, m, q)]));
    EXPECT_LT(worst, kWignerTol) << "alpha " << alpha;
  }
}

double RelRms(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (a[i] - b[i]) * (a[i] - b[i]);
    den += b[i] * b[i];
  }
  return std::sqrt(num / den);
}

// The direct evaluation of `synth` (local and global) and the pixel sum of the world-frame BRDF
// `brdf` defines (TestTransfer), at 24 random front-facing (N, V): {local, global, reference}.
struct DirectAndReference {
  std::vector<double> local, global, ref;
};
DirectAndReference DirectVsBruteForce(const ShrmSynthesizer& synth, const BrdfCoefficients& brdf,
                                      uint32_t seed,
                                      const std::function<double(double)>& fresnel = nullptr) {
  DirectAndReference out;
  auto integ = ReferenceIntegrator::Create(GetScene().samples);
  EXPECT_TRUE(integ.ok());
  if (!integ.ok()) return out;
  TestTransfer transfer(brdf);
  if (fresnel) transfer.SetFresnel(fresnel);
  TransferFunction fn = [&transfer](const Vec3& n, const Vec3& v, const Vec3& w, int c) {
    return transfer(n, v, w, c);
  };
  ReferenceOptions opt;
  opt.grey = true;
  std::mt19937 rng(seed);
  for (int i = 0; i < 24; ++i) {
    Vec3 n, v;
    RandomNormalView(rng, &n, &v);
    const Vec3 r = n * (2 * n.Dot(v)) - v;
    const auto b_ref = integ->Radiance(fn, n, v, opt);
    const auto b_loc = synth.RadianceAt(ShrmKind::kLocal, r, v);
    const auto b_glo = synth.RadianceAt(ShrmKind::kGlobal, r, v);
    for (int c = 0; c < 3; ++c) {
      out.ref.push_back(b_ref[c]);
      out.local.push_back(b_loc[c]);
      out.global.push_back(b_glo[c]);
    }
  }
  return out;
}

TEST(ShrmSynthesisTest, DirectLocalAndGlobalMatchBruteForceOnRealMap) {
  const BrdfCoefficients brdf = TestBrdf();
  const ShrmSynthesizer synth = MakeSynth(brdf);
  const auto [local, global, ref] = DirectVsBruteForce(synth, brdf, 7);
  const double err_local = RelRms(local, ref), err_global = RelRms(global, ref);
  std::printf("direct local vs brute force: rel RMS %.3g; global %.3g\n", err_local, err_global);
  EXPECT_LT(err_local, kDirectVsReferenceTol);
  EXPECT_LT(err_global, kDirectVsReferenceTol);
  EXPECT_LT(RelRms(global, local), kGlobalVsLocalTol);
}

// Normalized Phong-like lobe (s + 1)/(2 pi) max(cos theta_i', 0)^s: rho_l00 = sqrt(4 pi) *
// integral rho-hat Y_l0 dw_i', by Gauss-Legendre in cos theta_i' on [0, 1] (exact: polynomial).
BrdfCoefficients PhongLobe(double s, int lmax, int pmax) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = pmax;
  b.channels = 1;
  b.values.assign(static_cast<size_t>(lmax + 1) * (pmax + 1) * (pmax + 1), 0.0);
  const RingQuadrature gl = GaussLegendreRule(64);  // x in [-1, 1]
  std::vector<double> lambda(LegendreCount(lmax));
  for (int j = 0; j < 64; ++j) {
    const double x = 0.5 * (gl.cos_theta[j] + 1), w = 0.5 * gl.weight[j];
    NormalizedLegendre(lmax, x, lambda);
    const double rho = (s + 1) / (2 * kPi) * std::pow(x, s);
    for (int l = 0; l <= lmax; ++l)
      b.values[b.Index(l, 0, 0, 0)] +=
          std::sqrt(4 * kPi) * 2 * kPi * w * rho * lambda[LegendreIndex(l, 0)];
  }
  return b;
}

TEST(ShrmSynthesisTest, WhiteFurnaceDirectAndThroughCubes) {
  constexpr double kC = 2.5;
  std::vector<double> light(ShCount(8) * 3, 0.0);
  for (int c = 0; c < 3; ++c) light[c] = kC * std::sqrt(4 * kPi);
  for (int pmax : {0, 2}) {
    auto synth = ShrmSynthesizer::Create(8, 3, light, PhongLobe(16, 8, pmax));
    ASSERT_TRUE(synth.ok()) << synth.status();
    std::mt19937 rng(3);
    for (ShrmKind kind : {ShrmKind::kLocal, ShrmKind::kGlobal}) {
      auto cube = synth->BuildCube(kind, 9);
      ASSERT_TRUE(cube.ok()) << cube.status();
      for (int i = 0; i < 50; ++i) {
        Vec3 n, v;
        RandomNormalView(rng, &n, &v);
        const auto direct = synth->RadianceAt(kind, n * (2 * n.Dot(v)) - v, v);
        const auto cubed = ShrmEval(*cube, n, v);
        for (int c = 0; c < 3; ++c) {
          EXPECT_NEAR(direct[c], kC, kFurnaceTol * kC);
          EXPECT_NEAR(cubed[c], kC, kFurnaceTol * kC);
        }
      }
      // Every texel of every face, including the pole texel of the odd-sized face.
      for (int f = 0; f < 6; ++f)
        for (int y = 0; y < 9; ++y)
          for (int x = 0; x < 9; ++x)
            EXPECT_NEAR(ShrmTexelRadiance(*cube, f, x, y, RandomUnit(rng))[1], kC,
                        kFurnaceTol * kC);
    }
  }
}

// Error of the cube path against direct evaluation at random (R, V), relative RMS.
double CubeError(const ShrmSynthesizer& synth, const ShrmCube& cube, int count) {
  std::mt19937 rng(11);
  std::vector<double> a, b;
  for (int i = 0; i < count; ++i) {
    const Vec3 r = RandomUnit(rng), v = RandomUnit(rng);
    const auto direct = synth.RadianceAt(cube.kind, r, v);
    const auto cubed = ShrmEvalAt(cube, r, v);
    for (int c = 0; c < 3; ++c) {
      a.push_back(cubed[c]);
      b.push_back(direct[c]);
    }
  }
  return RelRms(a, b);
}

TEST(ShrmSynthesisTest, CubeInterpolationErrorShrinksWithFaceSize) {
  const ShrmSynthesizer synth = MakeSynth(TestBrdf());
  for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
    ShrmGridOptions opt;
    opt.threads = 2;
    auto small = synth.BuildCube(kind, 32, opt);
    auto large = synth.BuildCube(kind, 128, opt);
    ASSERT_TRUE(small.ok() && large.ok());
    const double e_small = CubeError(synth, *small, 150), e_large = CubeError(synth, *large, 150);
    std::printf("%s cube vs direct: S_B = 32: %.3g, S_B = 128: %.3g\n",
                kind == ShrmKind::kGlobal ? "global" : "local", e_small, e_large);
    // Bilinear texel interpolation: error ~ h^2, so 4x the size gives ~16x less (allow 6x).
    EXPECT_LT(e_large, e_small / 6);
    EXPECT_LT(e_large, 1e-2);
  }
}

// Relative RMS of the cube at every third texel centre (random views) against RadianceAt.
double TexelCentreError(const ShrmSynthesizer& synth, const ShrmCube& cube, std::mt19937& rng) {
  const int s = cube.face_size;
  std::vector<double> a, b;
  for (int f = 0; f < 6; ++f)
    for (int y = 0; y < s; y += 3)
      for (int x = 0; x < s; x += 3) {
        const Vec3 v = RandomUnit(rng);
        const auto t = ShrmTexelRadiance(cube, f, x, y, v);
        const auto d = synth.RadianceAt(cube.kind, CubeTexelDirection(f, x, y, s), v);
        for (int c = 0; c < 3; ++c) {
          a.push_back(t[c]);
          b.push_back(d[c]);
        }
      }
  return RelRms(a, b);
}

TEST(ShrmSynthesisTest, TexelCentresEqualDirectEvaluation) {
  const ShrmSynthesizer synth = MakeSynth(TestBrdf());
  std::mt19937 rng(5);
  for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
    auto cube = synth.BuildCube(kind, 16);
    ASSERT_TRUE(cube.ok());
    const double err = TexelCentreError(synth, *cube, rng);
    std::printf("%s texel centres vs direct: %.3g\n",
                kind == ShrmKind::kGlobal ? "global" : "local", err);
    EXPECT_LT(err, kTexelCentreTol);
  }
}

// Every resampling kernel: the fixed strides of P = 1, 2 (packed), 4, 5 (nodes padded to 64-byte
// lines) and the runtime stride of P = 6, each against the direct evaluation, whole and in slabs.
TEST(ShrmSynthesisTest, TexelCentresEqualDirectEvaluationForEveryKernel) {
  std::mt19937 rng(21);
  for (const int pmax : {1, 2, 4, 5, 6}) {
    const ShrmSynthesizer synth = MakeSynth(TestBrdf(12, pmax));
    for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
      for (const size_t bytes : {size_t{0}, size_t{1}}) {
        ShrmGridOptions options;
        options.max_grid_bytes = bytes;
        auto cube = synth.BuildCube(kind, 12, options);
        ASSERT_TRUE(cube.ok()) << cube.status();
        EXPECT_LT(TexelCentreError(synth, *cube, rng), kTexelCentreTol)
            << "P " << pmax << (kind == ShrmKind::kGlobal ? " global" : " local") << ", "
            << (bytes == 0 ? "whole grid" : "slabs");
      }
    }
  }
}

// The direct cube (ShrmGridOptions::CubePath::kDirect: each texel centre by eq. 5.23, the l-sums
// of eight texels per Wigner pass) against the one-point direct evaluation at the texel centres
// (float storage only) and against the grid path (its interpolation error): global and local,
// both view variables, the tangent reparameterization (q = 0 only), face sizes whose texel count
// is not a multiple of the block; and a large-P configuration for which kAuto takes it.
TEST(ShrmSynthesisTest, DirectCubeEqualsTheDirectEvaluationAtTexelCentres) {
  std::mt19937 rng(31);
  struct Case {
    int pmax;
    ReparamKind reparam;
    ViewVariable view;
    int face_size;
  };
  for (const Case& cs : {Case{4, ReparamKind::kReflection, ViewVariable::kView, 12},
                         Case{6, ReparamKind::kReflection, ViewVariable::kNormal, 7},
                         Case{5, ReparamKind::kTangent, ViewVariable::kView, 9}}) {
    BrdfCoefficients brdf = TestBrdf(12, cs.pmax);
    brdf.reparam = cs.reparam;
    brdf.view = cs.view;
    const ShrmSynthesizer synth = MakeSynth(brdf);
    for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
      ShrmGridOptions direct, grid;
      direct.path = ShrmGridOptions::CubePath::kDirect;
      grid.path = ShrmGridOptions::CubePath::kGrid;
      direct.threads = 2;
      auto a = synth.BuildCube(kind, cs.face_size, direct);
      auto b = synth.BuildCube(kind, cs.face_size, grid);
      ASSERT_TRUE(a.ok() && b.ok());
      const std::string what = absl::StrCat(
          "P ", cs.pmax, kind == ShrmKind::kGlobal ? " global" : " local", " S ", cs.face_size);
      EXPECT_LT(TexelCentreError(synth, *a, rng), kDirectCubeTol) << what;
      std::vector<double> va(a->data.begin(), a->data.end()), vb(b->data.begin(), b->data.end());
      EXPECT_LT(RelRms(va, vb), kTexelCentreTol) << what;
      EXPECT_EQ(a->view, cs.view);
      EXPECT_EQ(a->index, cs.reparam);
    }
  }
  // (20, 14) on 16 x 16 faces: the grid has 4 (F + P + 1) = 140 rows (144 x 288 nodes), the cube
  // 1,536 texels: kAuto's cost model takes the direct path (equal to kDirect's cube bit for bit).
  const ShrmSynthesizer synth = MakeSynth(TestBrdf(20, 14));
  ShrmGridOptions direct;
  direct.path = ShrmGridOptions::CubePath::kDirect;
  auto a = synth.BuildCube(ShrmKind::kGlobal, 16);
  auto b = synth.BuildCube(ShrmKind::kGlobal, 16, direct);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->data, b->data);
}

// The tangent reparameterization (Kajiya-Kay): rho_lpq only for q = 0, whose l-sums alone the
// synthesis forms (the others are zero); the texel centres still equal the direct evaluation,
// which sums every q. The global cube takes the zonal path (BuildZonalGlobalCube: the local
// B_p0 by a P = 0 synthesis, then the addition theorem per texel); it also equals the general
// grid path's cube.
TEST(ShrmSynthesisTest, TangentCoefficientsOnlyQZeroTexelCentresEqualDirectEvaluation) {
  std::mt19937 rng(23);
  for (const int pmax : {2, 5, 8}) {
    BrdfCoefficients brdf = TestBrdf(10, pmax);
    brdf.reparam = ReparamKind::kTangent;
    const ShrmSynthesizer synth = MakeSynth(brdf);
    ASSERT_EQ(synth.RhoQmax(), 0);
    for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
      auto cube = synth.BuildCube(kind, 12);
      ASSERT_TRUE(cube.ok()) << cube.status();
      const double err = TexelCentreError(synth, *cube, rng);
      std::printf("tangent P %d %s: texel centres vs direct %.3g\n", pmax,
                  kind == ShrmKind::kGlobal ? "global (zonal path)" : "local", err);
      EXPECT_LT(err, kTexelCentreTol)
          << "P " << pmax << (kind == ShrmKind::kGlobal ? " global" : " local");
      if (kind != ShrmKind::kGlobal) continue;
      ShrmGridOptions grid;
      grid.path = ShrmGridOptions::CubePath::kGrid;
      auto general = synth.BuildCube(kind, 12, grid);
      ASSERT_TRUE(general.ok());
      std::vector<double> a(cube->data.begin(), cube->data.end()),
          b(general->data.begin(), general->data.end());
      EXPECT_LT(RelRms(a, b), kTexelCentreTol) << "P " << pmax << " zonal vs grid path";
    }
  }
}

// The zonal path with the caller's storage (a live session's SynthesisScratch): the texels' Y_ps
// table is made by the first cube of a face size and P and reused by the next, and a released
// cube's buffer is written again. Every cube equals the one made without storage bit for bit,
// including after the face size or P changes (the table is remade) and back.
// The P = 0 path from real coefficients given directly (a split-sum level's g_l L_lm): at the
// texel centres, the SH series of the same coefficients evaluated by EvalSh (the grid's cubic
// interpolation and float storage, kTexelCentreTol); and the cube of a synthesizer whose
// rho_l00 = k_l sqrt((2l + 1) / (4 pi)) up to that synthesizer's complex round trip (float
// storage of the same values: kDirectCubeTol). Bad sizes are refused.
// InterpolationRows: the grid it picks for an error budget keeps the texel centres within that
// budget of the direct evaluation (eq. 5.23, RadianceAt: no grid) for both kinds, with fewer rows
// than the automatic rule; a smaller budget never takes fewer rows; none gives the automatic
// rule's count.
TEST(ShrmSynthesisTest, InterpolationRowsKeepTheTexelCentresWithinTheBudget) {
  const ShrmSynthesizer synth = MakeSynth(TestBrdf());
  const int automatic = FftFriendlyRings(std::max(32, 4 * (kF + kP + 1)));
  std::mt19937 rng(11);
  for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
    EXPECT_EQ(synth.InterpolationRows(kind, 0), automatic);
    int previous = 0;
    for (const double budget : {3e-2, 1e-2, 3e-3, 1e-3}) {
      const int rows = synth.InterpolationRows(kind, budget);
      EXPECT_GE(rows, previous);
      EXPECT_GE(rows, kF + kP + 1);
      EXPECT_LE(rows, automatic);
      previous = rows;
      ShrmGridOptions options;
      options.alpha_samples = rows;
      options.path = ShrmGridOptions::CubePath::kGrid;
      auto cube = synth.BuildCube(kind, 48, options);
      ASSERT_TRUE(cube.ok()) << cube.status();
      const double err = TexelCentreError(synth, *cube, rng);
      std::printf("%s budget %.0e: %d rows (automatic %d), texel centres vs direct %.3g\n",
                  kind == ShrmKind::kGlobal ? "global" : "local", budget, rows, automatic, err);
      EXPECT_LE(err, budget) << (kind == ShrmKind::kGlobal ? "global" : "local");
    }
    EXPECT_LT(synth.InterpolationRows(kind, 1e-2), automatic);
  }
}

TEST(ShrmSynthesisTest, RealZonalCubeIsTheSeriesAtTexelCentres) {
  const Scene& sc = GetScene();
  std::vector<double> k(kF + 1), real(sc.light.size());
  BrdfCoefficients zonal;
  zonal.lmax = kF;
  zonal.pmax = 0;
  zonal.channels = 1;
  zonal.values.resize(kF + 1);
  for (int l = 0; l <= kF; ++l) {
    k[l] = std::exp(-l * l / 120.0);
    zonal.values[l] = k[l] * std::sqrt((2 * l + 1) / (4 * kPi));
    for (int m = -l; m <= l; ++m)
      for (int c = 0; c < 3; ++c) {
        const size_t i = static_cast<size_t>(ShIndex(l, m)) * 3 + c;
        real[i] = k[l] * sc.light[i];
      }
  }
  constexpr int kS = 16;
  auto cube = ShrmSynthesizer::RealZonalCube(kF, 3, real, kS, ShrmGridOptions{});
  ASSERT_TRUE(cube.ok()) << cube.status();
  ASSERT_EQ(cube->data.size(), static_cast<size_t>(6) * kS * kS * 3);
  std::vector<double> got, want, y(ShCount(kF));
  for (int f = 0; f < 6; ++f)
    for (int t = 0; t < kS; ++t)
      for (int x = 0; x < kS; ++x) {
        EvalSh(kF, ShFrameFromWorld(CubeTexelDirection(f, x, t, kS)), y);
        for (int c = 0; c < 3; ++c) {
          double v = 0;
          for (int i = 0; i < ShCount(kF); ++i) v += real[static_cast<size_t>(i) * 3 + c] * y[i];
          want.push_back(v);
          got.push_back(cube->data[((static_cast<size_t>(f) * kS + t) * kS + x) * 3 + c]);
        }
      }
  const double err = RelRms(got, want);
  std::printf("real zonal cube vs the series at texel centres: %.3g\n", err);
  EXPECT_LT(err, kTexelCentreTol);
  auto synth = ShrmSynthesizer::Create(kF, 3, sc.light, zonal, kF, 0);
  ASSERT_TRUE(synth.ok()) << synth.status();
  auto through = synth->BuildCube(ShrmKind::kGlobal, kS);
  ASSERT_TRUE(through.ok()) << through.status();
  std::vector<double> a(cube->data.begin(), cube->data.end()),
      b(through->data.begin(), through->data.end());
  EXPECT_LT(RelRms(a, b), kDirectCubeTol);
  EXPECT_FALSE(ShrmSynthesizer::RealZonalCube(kF, 3, std::span(real).first(10), kS, {}).ok());
  EXPECT_FALSE(ShrmSynthesizer::RealZonalCube(-1, 3, {}, kS, {}).ok());
  EXPECT_FALSE(ShrmSynthesizer::RealZonalCube(kF, 3, real, 0, {}).ok());
  ShrmGridOptions few;
  few.alpha_samples = kF;  // fewer rows than degree + 1
  EXPECT_FALSE(ShrmSynthesizer::RealZonalCube(kF, 3, real, kS, few).ok());
}

TEST(ShrmSynthesisTest, ZonalCubeWithReusedStorageEqualsFreshCube) {
  SynthesisScratch scratch;
  ShrmGridOptions reuse;
  reuse.scratch = &scratch;
  for (const auto& [pmax, size] :
       std::vector<std::pair<int, int>>{{8, 12}, {8, 12}, {8, 10}, {5, 10}, {8, 12}}) {
    BrdfCoefficients brdf = TestBrdf(10, pmax);
    brdf.reparam = ReparamKind::kTangent;
    const ShrmSynthesizer synth = MakeSynth(brdf);
    auto fresh = synth.BuildCube(ShrmKind::kGlobal, size);
    auto reused = synth.BuildCube(ShrmKind::kGlobal, size, reuse);
    ASSERT_TRUE(fresh.ok() && reused.ok());
    EXPECT_EQ(fresh->data, reused->data) << "P " << pmax << " S " << size;
    EXPECT_EQ(scratch.zonal_w_face_size, size);
    EXPECT_EQ(scratch.zonal_w_pmax, pmax);
    scratch.cube = std::move(reused->data);  // released, as a live frame's
  }
}

// The normal variable (brdf_coefficients.h ViewVariable::kNormal): coefficients (p + q even) read
// as an expansion in n' = Rot(R)^T N. The direct evaluation, local and global, against the
// pixel sum of the world-frame BRDF they define; the cubes' texel centres against the direct
// evaluation; ShrmEval from (N, V) against ShrmEvalAt from (R, V).
// ShrmEval from (N, V) against ShrmEvalAt from (R, V) at 16 random front-facing pairs.
void ExpectEvalFromNormalIsEvalAtReflection(const ShrmCube& cube, std::mt19937& rng) {
  for (int i = 0; i < 16; ++i) {
    Vec3 n, v;
    RandomNormalView(rng, &n, &v);
    const Vec3 r = n * (2 * n.Dot(v)) - v;
    const auto a = ShrmEval(cube, n, v), b = ShrmEvalAt(cube, r, v);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], kSameArgumentTol * (1 + std::abs(b[c])));
  }
}

TEST(ShrmSynthesisTest, NormalVariableMatchesBruteForceAndTexelCentres) {
  BrdfCoefficients brdf = TestBrdf();
  brdf.view = ViewVariable::kNormal;
  for (int l = 0; l <= brdf.lmax; ++l)
    for (int p = 0; p <= brdf.pmax; ++p)
      for (int q = 0; q <= std::min(l, p); ++q)
        if ((p + q) % 2 != 0) brdf.values[brdf.Index(l, p, q, 0)] = 0;
  const ShrmSynthesizer synth = MakeSynth(brdf);
  EXPECT_EQ(synth.view(), ViewVariable::kNormal);
  const auto [local, global, ref] = DirectVsBruteForce(synth, brdf, 9);
  std::mt19937 rng(9);
  std::printf("normal variable, direct vs brute force: local %.3g, global %.3g\n",
              RelRms(local, ref), RelRms(global, ref));
  EXPECT_LT(RelRms(local, ref), kDirectVsReferenceTol);
  EXPECT_LT(RelRms(global, ref), kDirectVsReferenceTol);
  for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
    auto cube = synth.BuildCube(kind, 16);
    ASSERT_TRUE(cube.ok());
    EXPECT_EQ(cube->view, ViewVariable::kNormal);
    EXPECT_LT(TexelCentreError(synth, *cube, rng), kTexelCentreTol);
    ExpectEvalFromNormalIsEvalAtReflection(*cube, rng);
  }
}

// The Fresnel table in either view variable (conventions 4; brdf_coefficients.h): the value is
// the sum times w(N.V). The table holds w(x) = 0.2 + 0.8 (1 - x)^2, which the Catmull-Rom cubic
// with its quadratic ghost nodes reproduces exactly (up to the nodes' float rounding); the pixel
// sum multiplies the test's own world-frame BRDF by the closed form at n.v. The direct
// evaluation (local, global), the cubes' texel centres and ShrmEval from (N, V); negative
// control: the same coefficients without the table are far from the reference.
TEST(ShrmSynthesisTest, ViewVariableFresnelMatchesBruteForce) {
  const auto w = [](double x) { return 0.2 + 0.8 * (1 - x) * (1 - x); };
  for (const ViewVariable view : {ViewVariable::kView, ViewVariable::kNormal}) {
    BrdfCoefficients brdf = TestBrdf();
    brdf.view = view;
    for (int k = 0; k <= kFresnelIntervals; ++k)
      brdf.fresnel.push_back(
          static_cast<float>(w(1.0 - static_cast<double>(k) / kFresnelIntervals)));
    const ShrmSynthesizer synth = MakeSynth(brdf);
    const auto [local, global, ref] = DirectVsBruteForce(synth, brdf, 13, w);
    BrdfCoefficients bare = brdf;
    bare.fresnel.clear();
    const auto plain = DirectVsBruteForce(MakeSynth(bare), bare, 13, w);
    std::printf(
        "%s variable with a Fresnel table, direct vs brute force: local %.3g, global %.3g "
        "(without the table %.3g)\n",
        ViewVariableName(view), RelRms(local, ref), RelRms(global, ref), RelRms(plain.local, ref));
    EXPECT_LT(RelRms(local, ref), kFresnelQuadraticTol);
    EXPECT_LT(RelRms(global, ref), kFresnelQuadraticTol);
    EXPECT_GT(RelRms(plain.local, ref), 0.05);
    std::mt19937 rng(13);
    for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
      auto cube = synth.BuildCube(kind, 16);
      ASSERT_TRUE(cube.ok());
      EXPECT_EQ(cube->fresnel.size(), brdf.fresnel.size());
      EXPECT_LT(TexelCentreError(synth, *cube, rng), kTexelCentreTol);
      ExpectEvalFromNormalIsEvalAtReflection(*cube, rng);
    }
  }
}

// A grid too large for ShrmGridOptions::max_grid_bytes is made in slabs of rows, each resampled
// before the next: the texel centres still equal the direct evaluation (RadianceAt, eq. 5.23 with
// the library's Wigner tables), and the slabs' cube is the whole grid's value for value (the
// same sums in the same order), for slabs of one Wigner block and of a few, and any thread count.
TEST(ShrmSynthesisTest, CubeFromSlabsOfTheGridEqualsTheWholeGrid) {
  const ShrmSynthesizer synth = MakeSynth(TestBrdf());
  ASSERT_GT(synth.pmax(), 0);
  std::mt19937 rng(9);
  for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
    ShrmGridOptions whole;
    whole.max_grid_bytes = 0;
    auto reference = synth.BuildCube(kind, 20, whole);
    ASSERT_TRUE(reference.ok()) << reference.status();
    for (const size_t bytes : {size_t{1}, size_t{200000}, size_t{1000000}})
      for (const int threads : {1, 3}) {
        ShrmGridOptions slabs;
        slabs.max_grid_bytes = bytes;
        slabs.threads = threads;
        auto cube = synth.BuildCube(kind, 20, slabs);
        ASSERT_TRUE(cube.ok()) << cube.status();
        ASSERT_EQ(cube->data.size(), reference->data.size());
        size_t differing = 0;
        for (size_t i = 0; i < cube->data.size(); ++i)
          differing += cube->data[i] != reference->data[i];
        EXPECT_EQ(differing, 0u) << "max_grid_bytes " << bytes << ", threads " << threads;
        EXPECT_LT(TexelCentreError(synth, *cube, rng), kTexelCentreTol)
            << "max_grid_bytes " << bytes;
      }
  }
}

TEST(ShrmSynthesisTest, GlobalAndLocalCubesAgree) {
  const ShrmSynthesizer synth = MakeSynth(TestBrdf());
  auto local = synth.BuildCube(ShrmKind::kLocal, 24);
  auto global = synth.BuildCube(ShrmKind::kGlobal, 24);
  ASSERT_TRUE(local.ok() && global.ok());
  std::mt19937 rng(9);
  std::vector<double> a, b;
  for (int i = 0; i < 200; ++i) {
    const Vec3 r = RandomUnit(rng), v = RandomUnit(rng);
    const auto x = ShrmEvalAt(*local, r, v), y = ShrmEvalAt(*global, r, v);
    for (int c = 0; c < 3; ++c) {
      a.push_back(x[c]);
      b.push_back(y[c]);
    }
  }
  // Both interpolate the same texel values (the local texels in their own frames); they differ
  // only by the grid interpolation of two different coefficient fields and float storage.
  EXPECT_LT(RelRms(a, b), kTexelCentreTol);
}

TEST(ShrmSynthesisTest, BadArguments) {
  const BrdfCoefficients brdf = TestBrdf(4, 1);
  std::vector<double> light(ShCount(4) * 3, 1.0);
  EXPECT_FALSE(ShrmSynthesizer::Create(-1, 3, light, brdf).ok());
  EXPECT_FALSE(ShrmSynthesizer::Create(4, 3, light, brdf, -2).ok());
  EXPECT_FALSE(ShrmSynthesizer::Create(4, 3, light, brdf, 4, -3).ok());
  EXPECT_FALSE(ShrmSynthesizer::Create(4, 3, light, brdf, 5).ok());     // F > inputs
  EXPECT_FALSE(ShrmSynthesizer::Create(4, 3, light, brdf, 4, 2).ok());  // P > BRDF's
  EXPECT_FALSE(ShrmSynthesizer::Create(4, 2, light, brdf).ok());        // size mismatch
  BrdfCoefficients two = brdf;
  two.channels = 2;
  two.values.resize(two.values.size() * 2);
  const auto status = ShrmSynthesizer::Create(4, 3, light, two).status();
  EXPECT_FALSE(status.ok());
  EXPECT_NE(std::string(status.message()).find("mismatched channels"), std::string::npos);
  auto synth = ShrmSynthesizer::Create(4, 3, light, brdf);
  ASSERT_TRUE(synth.ok());
  EXPECT_FALSE(synth->BuildCube(ShrmKind::kLocal, 0).ok());
  EXPECT_FALSE(synth->BuildCube(ShrmKind::kLocal, -4).ok());
  ShrmGridOptions bad;
  bad.alpha_samples = 3;  // cannot resolve F = 4
  EXPECT_FALSE(synth->BuildCube(ShrmKind::kGlobal, 8, bad).ok());
  bad.alpha_samples = 0;
  bad.threads = 0;
  EXPECT_FALSE(synth->BuildCube(ShrmKind::kGlobal, 8, bad).ok());
}

}  // namespace
}  // namespace shrm
