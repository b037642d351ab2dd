// SHRM explicit forms (paper eqs. 5.25, 5.35), Lambertian irradiance, the angular reference's
// truncation cone and the sec. 5.5 error analysis, on a 128 x 64 box-downsampled courtyard map
// with BRDF coefficients computed inside the test (independent of core/brdf).
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/base/cubemap.h"
#include "core/io/image.h"
#include "core/sh/hbasis.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/shrm/orders.h"
#include "core/shrm/shrm_analysis.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/transform/sht.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Explicit maps vs ShrmEval at texel centres: same texel values, float accumulation of <= 16
// terms (global blocked path) against double.
constexpr double kExplicitTol = 2e-6;
// Quadrature of the clamped-cosine kink on 128 x 64 pixels, O(h^2) with h = pi / 64, on top of
// the computed l > 2 truncation bound (real_map_sht_test measured 4.9e-4 at h = pi / 128).
constexpr double kIrradianceQuadratureTol = 4e-3;

constexpr int kLmax = 31;  // plain Fejer quadrature on 64 rings is exact for degree <= 31

struct Scene {
  ShtGrid grid{128, 64, ShtGridKind::kEquiangular};
  std::vector<float> map;
  std::vector<EnvSample> samples;
  std::vector<double> light;  // degree kLmax
};

const Scene& GetScene() {
  static const Scene* scene = [] {
    auto* s = new Scene;
    const Image img = testing::LoadBundledMap("courtyard.exr", s->grid.width);
    s->map = img.pixels;
    s->samples = testing::LatLongSamples(img);
    s->light = *ForwardSht(s->grid, kLmax, 3, s->map);
    return s;
  }();
  return *scene;
}

// Normalized Phong lobe (s + 1)/(2 pi) max(cos theta_i', 0)^s; rho_l00 = sqrt(4 pi) * integral
// rho-hat Y_l0 dw_i' by Gauss-Legendre in cos theta_i' on [0, 1] (exact for integer s <= 100).
BrdfCoefficients PhongLobe(double s, int lmax) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = 0;
  b.channels = 1;
  b.values.assign(lmax + 1, 0.0);
  const RingQuadrature gl = GaussLegendreRule(96);
  std::vector<double> lambda(LegendreCount(lmax));
  double total = 0;
  for (int j = 0; j < 96; ++j) {
    const double x = 0.5 * (gl.cos_theta[j] + 1), w = 0.5 * gl.weight[j];
    NormalizedLegendre(lmax, x, lambda);
    const double rho = (s + 1) / (2 * kPi) * std::pow(x, s);
    for (int l = 0; l <= lmax; ++l)
      b.values[l] += std::sqrt(4 * kPi) * 2 * kPi * w * rho * lambda[LegendreIndex(l, 0)];
    total += 2 * kPi * w * rho * rho;
  }
  // Eq. 5.18's right side: integral over w_i' of rho-hat^2 times integral over w_o' of |Y_00|^2
  // expansion... the view-independent lobe has energy 4 pi * integral rho-hat^2 dw_i' in the
  // (w_i', w_o') double integral, and rho_l00 = sqrt(4 pi) rho_l, so the totals match.
  b.total_energy = {4 * kPi * total};
  return b;
}

// A view-dependent, band-limited test BRDF (chosen coefficients).
BrdfCoefficients ViewDependent(int lmax, int pmax) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = pmax;
  b.channels = 1;
  b.values.assign(static_cast<size_t>(lmax + 1) * (pmax + 1) * (pmax + 1), 0.0);
  for (int l = 0; l <= lmax; ++l)
    for (int p = 0; p <= pmax; ++p)
      for (int q = 0; q <= std::min(l, p); ++q)
        b.values[b.Index(l, p, q, 0)] = std::exp(-l * (l + 1) / 100.0) * std::pow(0.4, p) *
                                        std::pow(-0.5, q) * std::cos(0.2 * l + p);
  return b;
}

Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3{g(rng), g(rng), g(rng)}.Normalized();
}

TEST(ShrmExplicitTest, OneViewMapsEqualShrmEvalAtTexelCentres) {
  auto synth = ShrmSynthesizer::Create(kLmax, 3, GetScene().light, ViewDependent(16, 2), 16, 2);
  ASSERT_TRUE(synth.ok()) << synth.status();
  std::mt19937 rng(1);
  // Both kinds, without and with a Fresnel table (conventions 4: the view variable's sum times
  // w(|R + V| / 2); ShrmEvalAt applies it per point, the maps per texel).
  for (const bool table : {false, true})
    for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
      auto cube = synth->BuildCube(kind, 12);
      ASSERT_TRUE(cube.ok());
      if (table)
        for (int k = 0; k <= kFresnelIntervals; ++k)
          cube->fresnel.push_back(static_cast<float>(0.04 + 0.96 * std::pow(k / 128.0, 5)));
      const Vec3 view = RandomUnit(rng);
      auto map = ReflectionMapForView(*cube, view, 2);
      auto cabral = CabralMaps(*cube);
      ASSERT_TRUE(map.ok() && cabral.ok());
      ASSERT_EQ(cabral->size(), 12u);
      const auto ico = IcosahedronVertices();
      double worst = 0, scale = 0;
      for (int f = 0; f < 6; ++f)
        for (int y = 0; y < 12; ++y)
          for (int x = 0; x < 12; ++x) {
            const Vec3 r = CubeTexelDirection(f, x, y, 12);
            const auto e = ShrmEvalAt(*cube, r, view);
            const auto e5 = ShrmEvalAt(*cube, r, ico[5]);
            for (int c = 0; c < 3; ++c) {
              worst = std::max(worst, std::abs(map->data[map->Index(f, x, y, c)] - e[c]));
              worst = std::max(worst, std::abs((*cabral)[5].data[map->Index(f, x, y, c)] - e5[c]));
              scale = std::max(scale, std::abs(e[c]));
            }
          }
      EXPECT_LT(worst, kExplicitTol * scale) << (table ? "with a Fresnel table" : "");
    }
  for (const Vec3& v : IcosahedronVertices()) EXPECT_NEAR(v.Norm(), 1.0, 1e-15);
}

TEST(ShrmExplicitTest, KautzMcCoolSlicesAreTheQZeroPart) {
  auto synth = ShrmSynthesizer::Create(kLmax, 3, GetScene().light, ViewDependent(16, 3), 16, 3);
  ASSERT_TRUE(synth.ok());
  auto cube = synth->BuildCube(ShrmKind::kLocal, 8);
  ASSERT_TRUE(cube.ok());
  constexpr int kT = 5;
  auto slices = KautzMcCoolSlices(*cube, kT);
  ASSERT_TRUE(slices.ok());
  EXPECT_FALSE(KautzMcCoolSlices(*synth->BuildCube(ShrmKind::kGlobal, 4), kT).ok());
  // T_B beyond the limit is refused before any map is allocated (a grid of 1e5 x 1e5 views was
  // std::bad_alloc).
  for (int t_b : {0, kMaxExplicitTb + 1, 100000}) {
    EXPECT_EQ(KautzMcCoolSlices(*cube, t_b).status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(ViewGridMaps(*cube, t_b).status().code(), absl::StatusCode::kInvalidArgument);
  }
  // Independent q = 0 part: direct complex B_p0 at the texel centre times Y_p0(theta_o).
  std::vector<std::complex<double>> b(ShCount(3) * 3);
  double worst = 0, scale = 0;
  for (int f = 0; f < 6; f += 2) {
    double alpha, beta;
    ShrmAnglesFromWorld(CubeTexelDirection(f, 3, 5, 8), &alpha, &beta);
    synth->LocalComplexAt(alpha, beta, b);
    for (int k = 0; k < kT; ++k) {
      const double theta = KautzMcCoolTheta(k, kT);
      for (int c = 0; c < 3; ++c) {
        double want = 0;
        for (int p = 0; p <= 3; ++p)
          want += b[ShIndex(p, 0) * 3 + c].real() * EvalShSlow(p, 0, theta, 0);
        worst = std::max(worst, std::abs((*slices)[k].data[(*slices)[k].Index(f, 3, 5, c)] - want));
        scale = std::max(scale, std::abs(want));
      }
    }
  }
  EXPECT_LT(worst, 2e-4 * scale);  // grid interpolation at texel centres (see synthesis test)
}

TEST(ShrmIrradianceTest, NineCoefficientsMatchBruteForceWithinTruncationBound) {
  const Scene& s = GetScene();
  auto e9 = IrradianceCoefficients(kLmax, 3, s.light);
  ASSERT_TRUE(e9.ok());
  // Bound of the l > 2 terms at any normal (Cauchy-Schwarz with the addition theorem
  // sum_m Y_lm^2 = (2l + 1)/(4 pi)): sum_{l=3}^{31} |A_l| sqrt((2l+1)/(4pi) sum_m L_lm^2).
  std::vector<double> bound(3, 0.0);
  for (int l = 3; l <= kLmax; ++l)
    for (int c = 0; c < 3; ++c) {
      double e = 0;
      for (int m = -l; m <= l; ++m)
        e += s.light[ShIndex(l, m) * 3 + c] * s.light[ShIndex(l, m) * 3 + c];
      bound[c] += std::abs(LambertianBandFactor(l)) * std::sqrt((2 * l + 1) / (4 * kPi) * e);
    }
  auto cube = IrradianceCube(*e9, 3, 8);
  ASSERT_TRUE(cube.ok());
  std::mt19937 rng(4);
  for (int i = 0; i < 8; ++i) {
    const Vec3 n = i < 2 ? Vec3{0, i ? -1.0 : 1.0, 0} : RandomUnit(rng);
    std::array<double, 3> bf{0, 0, 0};
    for (const EnvSample& e : s.samples)
      for (int c = 0; c < 3; ++c) bf[c] += e.rgb[c] * e.solid_angle * std::max(0.0, n.Dot(e.dir));
    const std::vector<double> y = EvalSh(2, ShFrameFromWorld(n));
    for (int c = 0; c < 3; ++c) {
      double sh = 0;
      for (int k = 0; k < 9; ++k) sh += (*e9)[k * 3 + c] * y[k];
      const double err = std::abs(sh - bf[c]);
      if (c == 1)
        std::printf("N=(%.2f,%.2f,%.2f) E=%.4g err %.3g%% bound %.3g%%\n", n.x, n.y, n.z, bf[c],
                    100 * err / bf[c], 100 * bound[c] / bf[c]);
      EXPECT_LE(err, bound[c] + kIrradianceQuadratureTol * bf[c]);
    }
  }
  // The cube's texels are the same expansion.
  const Vec3 d = CubeTexelDirection(2, 3, 4, 8);
  const std::vector<double> y = EvalSh(2, ShFrameFromWorld(d));
  double want = 0;
  for (int k = 0; k < 9; ++k) want += (*e9)[k * 3] * y[k];
  EXPECT_NEAR(cube->data[cube->Index(2, 3, 4, 0)], want, 1e-6 * std::abs(want));
}

TEST(ShrmReferenceTest, PhongConeTruncationStaysWithinItsEnergyBound) {
  const Scene& s = GetScene();
  auto integ = ReferenceIntegrator::Create(s.samples);
  ASSERT_TRUE(integ.ok());
  constexpr double kS = 64, kEps = 0.01;
  TransferFunction phong = [](const Vec3& n, const Vec3& v, const Vec3& w, int) {
    const Vec3 r = n * (2 * n.Dot(v)) - v;
    const double c = r.Dot(w);
    return c > 0 ? (kS + 1) / (2 * kPi) * std::pow(c, kS) : 0.0;
  };
  ReferenceOptions cone;
  cone.cone_angle = PhongConeAngle(kS, kEps);
  cone.grey = true;
  std::mt19937 rng(2);
  double lmax = 0;
  for (const EnvSample& e : s.samples) lmax = std::max<double>(lmax, e.rgb[1]);
  for (int i = 0; i < 10; ++i) {
    const Vec3 n = RandomUnit(rng), v = RandomUnit(rng);
    const auto full = ReferenceRadiance(s.samples, phong, n, v);
    const auto cut = integ->Radiance(phong, n, v, cone);
    // Omitted: <= eps of the lobe's integral (eq. 5.30) times the brightest pixel.
    EXPECT_LE(full[1] - cut[1], kEps * lmax * 1.05 + 1e-9);
    EXPECT_GE(full[1] - cut[1], -1e-9 * full[1]);
  }
  const Vec3 axis{0, 0, -1};
  EXPECT_LT(integ->VisitedSamples(axis, cone.cone_angle), s.samples.size() / 20);
}

TEST(ShrmAnalysisTest, PhongOrdersMinimumRuleAndConservativeBound) {
  const Scene& s = GetScene();
  constexpr double kS = 32, kEps = 0.03;
  const BrdfCoefficients phong = PhongLobe(kS, kLmax);
  auto total = MapEnergy(s.grid, 3, s.map);
  ASSERT_TRUE(total.ok());
  ShrmAnalysisOptions opt;
  opt.epsilon = kEps;
  auto a = AnalyzeShrm(kLmax, 3, s.light, *total, phong, opt);
  ASSERT_TRUE(a.ok()) << a.status();
  std::printf("F_L %d F_rho %d P_rho %d F_B %d P_B %d eps_L %.3g eps_rho %.3g eps_bound %.3g\n",
              a->f_light, a->f_brdf, a->p_brdf, a->f_b, a->p_b, a->eps_light, a->eps_brdf,
              a->eps_bound);
  EXPECT_EQ(a->p_brdf, 0);
  // Eq. 5.28: F ~ sqrt(-s log eps) = 10.6 for the Gaussian approximation of the Phong lobe.
  EXPECT_NEAR(a->f_brdf, std::sqrt(-kS * std::log(kEps)), 2.0);
  EXPECT_LE(a->eps_brdf, kEps);
  EXPECT_GT(BrdfCapturedFraction(phong, a->f_brdf - 1, 0), 1 - kEps - 0.05);
  EXPECT_LT(BrdfCapturedFraction(phong, a->f_brdf - 1, 0), 1 - kEps);
  const int f_l = a->f_light < 0 ? kLmax : a->f_light;
  EXPECT_EQ(a->f_b, std::min(f_l, a->f_brdf));
  EXPECT_EQ(a->p_b, 0);
  EXPECT_DOUBLE_EQ(a->eps_estimate, std::min(a->eps_light, a->eps_brdf));
  EXPECT_EQ(a->suggested_face_size, 10 * a->f_b);
  ASSERT_EQ(static_cast<int>(a->curves.size()), a->reference_f + 1);
  for (size_t i = 0; i < a->curves.size(); ++i) {
    const auto& pt = a->curves[i];
    EXPECT_LE(pt.bound, pt.b + 1e-12) << "F = " << pt.f;  // eq. 5.19 is conservative
    if (i) {
      EXPECT_GE(pt.b, a->curves[i - 1].b);
    }
  }
  EXPECT_DOUBLE_EQ(a->curves.back().b, 1.0);
  // The minimum-rule estimate tracks the true accuracy of B within a few percent at F_B.
  EXPECT_NEAR(a->curves[a->f_b].b, 1 - a->eps_estimate, 0.05);
  opt.epsilon = 0;
  EXPECT_FALSE(AnalyzeShrm(kLmax, 3, s.light, *total, phong, opt).ok());
  opt.epsilon = 0.03;
  opt.f_brdf = kLmax + 1;
  opt.p_brdf = 0;
  EXPECT_FALSE(AnalyzeShrm(kLmax, 3, s.light, *total, phong, opt).ok());
  EXPECT_FALSE(AnalyzeShrm(kLmax, 2, s.light, *total, phong, {}).ok());
}

}  // namespace
}  // namespace shrm
