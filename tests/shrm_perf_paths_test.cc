// Fast paths of the SHRM synthesis and explicit forms (docs/shrm.md, "Performance paths") against
// the general path and direct evaluation (SHRM paper eqs. 5.23-5.24, 5.35):
//  - P = 0 cubes by the inverse SHT of sqrt(4 pi/(2l+1)) rho_l L_lm (ShrmGridOptions::p0_sht_path)
//    vs the Wigner / FFT grid path and vs ShrmSynthesizer::RadianceAt at texel centres;
//  - the grid rows (computed in alpha <-> pi - alpha pairs) vs CoefficientsAt at grid nodes,
//    padding rows included;
//  - the AVX-512 interpolation kernels (strides 3, 12, 27, 48 and the generic one) vs direct
//    evaluation at texel centres;
//  - the register-blocked eq. 5.35 product (ViewGridMapsInto, reused output maps, view counts
//    that are not multiples of the 4-view block, rows not a multiple of 16 floats) vs
//    ShrmTexelRadiance.
#include <cmath>
#include <random>
#include <vector>

#include "core/base/cubemap.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/transform/sht.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Same tolerance as shrm_synthesis_test's texel-centre check (grid + 4x4 Lagrange + float).
constexpr double kTexelCentreTol = 2e-4;
// Two cubic interpolations of the same band-limited field on differently placed grids.
constexpr double kPathVsPathTol = 2e-4;
// Grid nodes vs direct evaluation: float storage only.
constexpr double kGridNodeTol = 1e-6;
// Explicit maps vs ShrmTexelRadiance: float products of <= 16 terms.
constexpr double kExplicitTol = 1e-5;

std::vector<double> Light(int lmax) {
  static const std::vector<float> map = [] {
    return testing::LoadBundledMap("courtyard.exr", 128).pixels;
  }();
  auto light = ForwardSht(ShtGrid{128, 64, ShtGridKind::kEquiangular}, lmax, 3, map);
  EXPECT_TRUE(light.ok()) << light.status();
  return *light;
}

BrdfCoefficients Brdf(int lmax, int pmax, int channels = 1) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = pmax;
  b.channels = channels;
  b.values.assign(static_cast<size_t>(lmax + 1) * (pmax + 1) * (pmax + 1) * channels, 0.0);
  for (int l = 0; l <= lmax; ++l)
    for (int p = 0; p <= pmax; ++p)
      for (int q = 0; q <= std::min(l, p); ++q)
        for (int c = 0; c < channels; ++c)
          b.values[b.Index(l, p, q, c)] =
              std::exp(-l * (l + 1) / (6.0 * lmax)) * std::pow(0.45, p) * std::pow(-0.6, q) *
              (1.0 + 0.05 * l * p + 0.1 * c) * (p == 0 ? 1.0 : std::cos(0.3 * l + p));
  return b;
}

double RelRms(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    num += (a[i] - b[i]) * (a[i] - b[i]);
    den += b[i] * b[i];
  }
  return std::sqrt(num / den);
}

Vec3 RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3{g(rng), g(rng), g(rng)}.Normalized();
}

// Texel-centre values of `cube` vs direct evaluation, every `step`-th texel, random views.
double TexelError(const ShrmSynthesizer& synth, const ShrmCube& cube, int step) {
  std::mt19937 rng(7);
  std::vector<double> a, b;
  const int s = cube.face_size;
  for (int f = 0; f < 6; ++f)
    for (int y = 0; y < s; y += step)
      for (int x = 0; x < s; x += step) {
        const Vec3 v = RandomUnit(rng);
        const auto t = ShrmTexelRadiance(cube, f, x, y, v);
        const auto d = synth.RadianceAt(cube.kind, CubeTexelDirection(f, x, y, s), v);
        for (int c = 0; c < std::min(cube.channels, 3); ++c) {
          a.push_back(t[c]);
          b.push_back(d[c]);
        }
      }
  return RelRms(a, b);
}

TEST(ShrmPerfPathsTest, P0ShtPathMatchesGeneralPathAndDirect) {
  for (int lmax : {7, 20, 40}) {
    auto synth = ShrmSynthesizer::Create(lmax, 3, Light(lmax), Brdf(lmax, 0));
    ASSERT_TRUE(synth.ok()) << synth.status();
    for (ShrmKind kind : {ShrmKind::kLocal, ShrmKind::kGlobal}) {
      ShrmGridOptions fast, slow;
      slow.p0_sht_path = false;
      auto a = synth->BuildCube(kind, 32, fast);
      auto b = synth->BuildCube(kind, 32, slow);
      ASSERT_TRUE(a.ok() && b.ok());
      ASSERT_EQ(a->data.size(), b->data.size());
      EXPECT_EQ(a->kind, kind);
      EXPECT_EQ(a->pmax, 0);
      std::vector<double> va(a->data.begin(), a->data.end()), vb(b->data.begin(), b->data.end());
      const double e_path = RelRms(va, vb);
      const double e_fast = TexelError(*synth, *a, 1), e_slow = TexelError(*synth, *b, 1);
      std::printf("P=0 F=%d %s: sht path vs grid path %.3g, vs direct %.3g (grid path %.3g)\n",
                  lmax, kind == ShrmKind::kLocal ? "local" : "global", e_path, e_fast, e_slow);
      EXPECT_LT(e_path, kPathVsPathTol);
      EXPECT_LT(e_fast, kTexelCentreTol);
      EXPECT_LT(e_fast, 2 * e_slow + 1e-6);
    }
  }
}

TEST(ShrmPerfPathsTest, P0ShtPathKeepsTheWhiteFurnace) {
  // L = c, normalized lobe (rho_l00 = sqrt(4 pi) delta_l0 ... any l > 0 terms vanish with a
  // constant light): B_00 = c sqrt(4 pi) at every texel.
  constexpr int kL = 9;
  std::vector<double> light(static_cast<size_t>(ShCount(kL)) * 3, 0.0);
  for (int c = 0; c < 3; ++c) light[c] = 2.0 * std::sqrt(4 * kPi);  // L = 2: L_00 = 2 sqrt(4 pi)
  BrdfCoefficients b = Brdf(kL, 0);
  b.values[b.Index(0, 0, 0, 0)] = 1.0 / std::sqrt(4 * kPi) * std::sqrt(4 * kPi);
  auto synth = ShrmSynthesizer::Create(kL, 3, light, b);
  ASSERT_TRUE(synth.ok());
  auto cube = synth->BuildCube(ShrmKind::kLocal, 8);
  ASSERT_TRUE(cube.ok());
  const auto direct = synth->RadianceAt(ShrmKind::kLocal, {0.3, 0.4, 0.5}, {0, 0, 1});
  for (float v : cube->data) EXPECT_NEAR(v, cube->data[0], 1e-6 * std::abs(cube->data[0]));
  const auto t = ShrmTexelRadiance(*cube, 2, 3, 4, {0, 1, 0});
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(t[c], direct[c], 1e-6 * std::abs(direct[c]));
}

TEST(ShrmPerfPathsTest, GridRowsIncludingPaddingMatchDirect) {
  constexpr int kL = 16;
  for (int pmax : {0, 2, 3}) {
    auto synth = ShrmSynthesizer::Create(kL, 3, Light(kL), Brdf(kL, pmax));
    ASSERT_TRUE(synth.ok());
    for (ShrmKind kind : {ShrmKind::kLocal, ShrmKind::kGlobal}) {
      for (int na : {kL + pmax + 1, 40, 41}) {  // odd na: a middle row without a mirror partner
        auto g = synth->BuildGrid(kind, na);
        ASSERT_TRUE(g.ok()) << g.status();
        std::vector<double> a, b, d(static_cast<size_t>(g->stride));
        for (int j = -2; j <= na + 1; ++j)
          for (int k = 0; k < g->nb; k += 5) {
            const double alpha = kPi * (j + 0.5) / na, beta = 2 * kPi * k / g->nb;
            synth->CoefficientsAt(kind, alpha, beta, d);
            for (int i = 0; i < g->stride; ++i) {
              a.push_back(g->values[(static_cast<size_t>(j + 2) * g->nb + k) * g->stride + i]);
              b.push_back(d[i]);
            }
          }
        EXPECT_LT(RelRms(a, b), kGridNodeTol) << "P " << pmax << " na " << na;
      }
    }
  }
}

TEST(ShrmPerfPathsTest, InterpolationKernelsMatchDirect) {
  constexpr int kL = 12;
  struct Case {
    int pmax, channels;
  };
  // strides 12, 27, 48 (AVX-512 kernels with 1, 2, 3 vectors), 4 and 9 (generic kernel).
  for (const Case cs : {Case{1, 3}, Case{2, 3}, Case{3, 3}, Case{1, 1}, Case{2, 1}}) {
    std::vector<double> light = Light(kL);
    if (cs.channels == 1) {
      std::vector<double> grey(ShCount(kL));
      for (int k = 0; k < ShCount(kL); ++k) grey[k] = light[k * 3 + 1];
      light = grey;
    }
    auto synth = ShrmSynthesizer::Create(kL, cs.channels, light, Brdf(kL, cs.pmax));
    ASSERT_TRUE(synth.ok()) << synth.status();
    for (ShrmKind kind : {ShrmKind::kLocal, ShrmKind::kGlobal}) {
      auto cube = synth->BuildCube(kind, 24);
      ASSERT_TRUE(cube.ok());
      const double e = TexelError(*synth, *cube, 1);
      EXPECT_LT(e, kTexelCentreTol) << "P " << cs.pmax << " channels " << cs.channels;
    }
  }
}

TEST(ShrmPerfPathsTest, BlockedExplicitMapsMatchTexelRadianceAndReuseStorage) {
  constexpr int kL = 12;
  for (int pmax : {0, 2, 3}) {
    auto synth = ShrmSynthesizer::Create(kL, 3, Light(kL), Brdf(kL, pmax));
    ASSERT_TRUE(synth.ok());
    for (int size : {12, 16}) {  // rows of 36 and 48 floats: masked tails and none
      auto cube = synth->BuildCube(ShrmKind::kGlobal, size);
      ASSERT_TRUE(cube.ok());
      std::vector<RadianceCube> maps;
      for (int t_b : {3, 2}) {  // 9 views (4 + 4 + 1), then 4 into the reused vector
        ASSERT_TRUE(ViewGridMapsInto(*cube, t_b, maps).ok());
        ASSERT_EQ(maps.size(), static_cast<size_t>(t_b * t_b));
        const std::vector<Vec3> views = ViewGrid(t_b);
        double worst = 0, scale = 0;
        for (size_t v = 0; v < views.size(); ++v)
          for (int f = 0; f < 6; ++f)
            for (int y = 0; y < size; ++y)
              for (int x = 0; x < size; ++x) {
                const auto e = ShrmTexelRadiance(*cube, f, x, y, views[v]);
                for (int c = 0; c < 3; ++c) {
                  worst = std::max(worst, std::abs(maps[v].data[maps[v].Index(f, x, y, c)] - e[c]));
                  scale = std::max(scale, std::abs(e[c]));
                }
              }
        EXPECT_LT(worst, kExplicitTol * scale) << "P " << pmax << " size " << size;
        auto fresh = ViewGridMaps(*cube, t_b, 2);
        ASSERT_TRUE(fresh.ok());
        for (size_t v = 0; v < views.size(); ++v) EXPECT_EQ((*fresh)[v].data, maps[v].data);
      }
    }
  }
}

}  // namespace
}  // namespace shrm
