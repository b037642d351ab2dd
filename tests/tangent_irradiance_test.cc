// Tests for core/sh/tangent_irradiance.h (H-basis paper, Habel & Wimmer 2010: tangent-space
// irradiance from world radiance SH, eqs. 5-7, T_h of eq. 14 / App. A). References are
// independent of the code under test:
//  - band-limited radiance: E(n) = integral over the hemisphere around n of L(w) (n . w) dw by a
//    product rule built in the frame of each world normal (exact for the polynomial integrand),
//    and its H-basis projection by a tangent-space hemisphere rule;
//  - the four bundled real maps: E(n) as pixel sums (Fejer solid angles) over the whole map,
//    compared with SH9 / H4 / H6 evaluations over the tangent-space upper hemisphere.
#include "core/sh/tangent_irradiance.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "core/sh/hbasis.h"
#include "core/sh/hsh.h"
#include "core/sh/sh.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Band-limited input: the library and the reference differ only by rounding (rotations of a
// degree-4 vector, exact product rules of a few hundred nodes), relative to max |E|.
constexpr double kExactTol = 1e-12;
// Real maps, degree-16 tangent SH vs pixel sums: the clamped-cosine tail beyond l = 16
// (|A_l| ~ l^-5/2, A_18 = 0.0053) times the maps' l > 16 energy (sun, sharp windows); relative
// RMS over the tangent hemisphere. Measured 3.8e-4 .. 5.3e-3; a frame or convention error gives
// O(1) (the band-limited test above pins the conventions to 1e-12).
constexpr double kHighOrderTol = 1e-2;
// Real maps, quadratic SH (9 coefficients) vs pixel sums, relative RMS over the hemisphere:
// Ramamoorthi & Hanrahan 2001 report a few per cent for order 2; the bundled maps measure
// 3.2 % .. 7.8 % (city, normal down: the bright sky enters only through the hemisphere's edge).
constexpr double kSh9Tol = 0.1;
// Ordering slack: H6 <= H4 and SH9 <= H6 are compared with this relative margin (rounding of
// the error integrals only).
constexpr double kOrderSlack = 1e-9;

Mat3 FrameFromColumns(const Vec3& t, const Vec3& b, const Vec3& n) {
  return Mat3{{{{t.x, b.x, n.x}, {t.y, b.y, n.y}, {t.z, b.z, n.z}}}};
}

Mat3 RandomRotation(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  return Quaternion{g(rng), g(rng), g(rng), g(rng)}.ToMatrix();
}

struct NamedFrame {
  std::string name;
  Mat3 m;
};

std::vector<NamedFrame> Frames() {
  // n = -Y (world down), t = +X, b = n x t = +Z.
  const Mat3 down = FrameFromColumns({1, 0, 0}, {0, 0, 1}, {0, -1, 0});
  return {{"identity", Mat3::Identity()}, {"random", RandomRotation(42)}, {"down", down}};
}

// World radiance L(w) from world-frame SH (sh.h's SH frame).
double Radiance(const std::vector<double>& sh, int lmax, const Vec3& world) {
  return EvalShSeries(lmax, sh, ShFrameFromWorld(world));
}

// E(n) = integral over the hemisphere around the world normal n of L(w) (n . w) dw, by a product
// rule in a frame with pole n (any tangent): exact for L of degree <= 4 (integrand degree 5).
double BruteIrradiance(const std::vector<double>& sh, int lmax, const Vec3& n,
                       const HemisphereRule& rule) {
  const Vec3 a = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t = (a - n * n.Dot(a)).Normalized();
  const Vec3 b = n.Cross(t);
  double e = 0;
  for (int j = 0; j < rule.num_theta(); ++j) {
    for (int k = 0; k < rule.num_phi(); ++k) {
      const Vec3 d = rule.Direction(j, k);
      const Vec3 w = t * d.x + b * d.y + n * d.z;
      e += rule.weight[j] * rule.dphi * Radiance(sh, lmax, w) * d.z;
    }
  }
  return e;
}

std::vector<double> RandomRadiance(int lmax, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> sh(ShCount(lmax));
  for (double& c : sh) c = u(rng);
  sh[0] = 5.0;
  return sh;
}

// ------------------------------------------------------------------------------------------

TEST(TangentIrradianceTest, ConstantRadianceKnownValues) {
  // L = 1 everywhere: L_00 = sqrt(4 pi); E = pi for every normal, so the tangent SH are
  // (pi sqrt(4 pi), 0, ...) and the H-basis coefficients (pi sqrt(2 pi), 0, ...): the integral of
  // pi H1 = pi / sqrt(2 pi) over the hemisphere (2 pi) is pi sqrt(2 pi).
  std::vector<double> sh(9, 0.0);
  sh[0] = std::sqrt(4 * kPi);
  for (const NamedFrame& f : Frames()) {
    std::vector<double> e(9), h6(6), h4(4);
    ASSERT_TRUE(TangentIrradianceSh(sh, f.m, 2, e).ok());
    ASSERT_TRUE(TangentIrradianceH(sh, f.m, 6, h6).ok());
    ASSERT_TRUE(TangentIrradianceH(sh, f.m, 4, h4).ok());
    EXPECT_NEAR(e[0], kPi * std::sqrt(4 * kPi), kExactTol * 10);
    EXPECT_NEAR(h6[0], kPi * std::sqrt(2 * kPi), kExactTol * 10);
    EXPECT_NEAR(h4[0], kPi * std::sqrt(2 * kPi), kExactTol * 10);
    for (int k = 1; k < 9; ++k) EXPECT_NEAR(e[k], 0.0, kExactTol * 10) << f.name;
    for (int k = 1; k < 6; ++k) EXPECT_NEAR(h6[k], 0.0, kExactTol * 10) << f.name;
  }
}

// Band-limited radiance (degree 4): the tangent SH of degree 4 are exact, at every tangent
// direction (both hemispheres: E is defined on the whole sphere of normals), for proper and
// mirrored frames; and the H-basis coefficients equal the projection of E over the tangent
// hemisphere (exact: E is a degree-4 polynomial).
TEST(TangentIrradianceTest, BandLimitedRadianceMatchesBruteForce) {
  constexpr int kL = 4;
  const std::vector<double> sh = RandomRadiance(kL, 7);
  const HemisphereRule world_rule = *MakeHemisphereRule(8, 12);    // exact for degree 5
  const HemisphereRule tangent_rule = *MakeHemisphereRule(8, 16);  // E H: degree <= 6
  std::vector<NamedFrame> frames = Frames();
  {
    const Mat3 r = RandomRotation(99);
    // Mirrored (left-handed) frame: columns (t, -b, n).
    frames.push_back({"mirrored", FrameFromColumns({r.m[0][0], r.m[1][0], r.m[2][0]},
                                                   {-r.m[0][1], -r.m[1][1], -r.m[2][1]},
                                                   {r.m[0][2], r.m[1][2], r.m[2][2]})});
  }
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g;
  for (const NamedFrame& f : frames) {
    std::vector<double> e(ShCount(kL));
    ASSERT_TRUE(TangentIrradianceSh(sh, f.m, kL, e).ok()) << f.name;
    double scale = 0;
    std::vector<std::pair<double, double>> pairs;
    for (int i = 0; i < 200; ++i) {
      const Vec3 d = Vec3{g(rng), g(rng), g(rng)}.Normalized();  // tangent space
      const double want = BruteIrradiance(sh, kL, f.m * d, world_rule);
      pairs.push_back({EvalShSeries(kL, e, d), want});
      scale = std::max(scale, std::abs(want));
    }
    for (const auto& [got, want] : pairs) EXPECT_NEAR(got, want, kExactTol * scale) << f.name;
    // Lower degrees are the truncation (band-wise rotation and scaling).
    std::vector<double> e2(9);
    ASSERT_TRUE(TangentIrradianceSh(sh, f.m, 2, e2).ok());
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(e2[k], e[k], kExactTol * scale);
    // H-basis: projection of the brute-force E over the tangent hemisphere.
    std::array<double, 6> want_h{};
    for (int j = 0; j < tangent_rule.num_theta(); ++j) {
      for (int k = 0; k < tangent_rule.num_phi(); ++k) {
        const Vec3 d = tangent_rule.Direction(j, k);
        const double ev = BruteIrradiance(sh, kL, f.m * d, world_rule);
        const auto h = EvalHBasis(d);
        for (int i = 0; i < 6; ++i)
          want_h[i] += tangent_rule.weight[j] * tangent_rule.dphi * ev * h[i];
      }
    }
    std::vector<double> h6(6), h4(4);
    ASSERT_TRUE(TangentIrradianceH(sh, f.m, 6, h6).ok());
    ASSERT_TRUE(TangentIrradianceH(sh, f.m, 4, h4).ok());
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(h6[i], want_h[i], kExactTol * scale * 10) << f.name;
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(h4[i], want_h[i], kExactTol * scale * 10) << f.name;
  }
}

// With only bands 0..2 given, the H-basis coefficients are the projection of the degree-2
// irradiance (band 4 absent).
TEST(TangentIrradianceTest, HBasisFromNineCoefficientsProjectsDegreeTwoIrradiance) {
  const std::vector<double> sh = RandomRadiance(2, 11);
  const HemisphereRule world_rule = *MakeHemisphereRule(8, 12);
  const HemisphereRule tangent_rule = *MakeHemisphereRule(8, 16);
  const Mat3 m = RandomRotation(5);
  std::array<double, 6> want{};
  for (int j = 0; j < tangent_rule.num_theta(); ++j) {
    for (int k = 0; k < tangent_rule.num_phi(); ++k) {
      const Vec3 d = tangent_rule.Direction(j, k);
      const double ev = BruteIrradiance(sh, 2, m * d, world_rule);
      const auto h = EvalHBasis(d);
      for (int i = 0; i < 6; ++i) want[i] += tangent_rule.weight[j] * tangent_rule.dphi * ev * h[i];
    }
  }
  std::vector<double> h6(6);
  ASSERT_TRUE(TangentIrradianceH(sh, m, 6, h6).ok());
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(h6[i], want[i], kExactTol * 100);
}

// Real maps: irradiance by pixel sums vs the tangent-space SH / H-basis, over the tangent
// hemisphere, for the four bundled maps and three frames.
TEST(TangentIrradianceTest, RealMapsAgainstPixelSums) {
  // Maps box-downsampled to 256 x 128; tangent SH of degree 16 as a convention check; a
  // 16 x 32 rule of tangent-space normals.
  constexpr int kWidth = 256;
  constexpr int kHighL = 16;
  const HemisphereRule rule = *MakeHemisphereRule(16, 32);
  std::printf("relative RMS error of E over the tangent hemisphere (luminance)\n");
  std::printf("%-15s %-9s %9s %9s %9s %9s\n", "map", "frame", "SH(l<=16)", "SH9", "H6", "H4");
  for (const std::string name : {"courtyard.exr", "city.exr", "forest.exr", "interior.exr"}) {
    const Image img = testing::LoadBundledMap(name, kWidth);
    const std::vector<EnvSample> samples = testing::LatLongSamples(img);
    // Luminance samples and their world-frame SH by pixel sums (no transform code involved).
    std::vector<double> lum(samples.size());
    std::vector<double> sh(ShCount(kHighL), 0.0), y(ShCount(kHighL));
    for (size_t p = 0; p < samples.size(); ++p) {
      const auto& c = samples[p].rgb;
      lum[p] = 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
      EvalSh(kHighL, ShFrameFromWorld(samples[p].dir), y);
      for (size_t k = 0; k < y.size(); ++k) sh[k] += lum[p] * samples[p].solid_angle * y[k];
    }
    const std::vector<double> sh4(sh.begin(), sh.begin() + ShCount(4));
    for (const NamedFrame& f : Frames()) {
      std::vector<double> e16(ShCount(kHighL)), e9(9), h6(6), h4(4);
      ASSERT_TRUE(TangentIrradianceSh(sh, f.m, kHighL, e16).ok());
      ASSERT_TRUE(TangentIrradianceSh(sh4, f.m, 2, e9).ok());
      ASSERT_TRUE(TangentIrradianceH(sh4, f.m, 6, h6).ok());
      ASSERT_TRUE(TangentIrradianceH(sh4, f.m, 4, h4).ok());
      double err16 = 0, err9 = 0, errh6 = 0, errh4 = 0, norm = 0;
      for (int j = 0; j < rule.num_theta(); ++j) {
        for (int k = 0; k < rule.num_phi(); ++k) {
          const Vec3 d = rule.Direction(j, k);
          const Vec3 n = f.m * d;
          double truth = 0;
          for (size_t p = 0; p < samples.size(); ++p) {
            const double c = n.Dot(samples[p].dir);
            if (c > 0) truth += lum[p] * c * samples[p].solid_angle;
          }
          const double w = rule.weight[j] * rule.dphi;
          const auto sq = [&](double a) { return w * (a - truth) * (a - truth); };
          err16 += sq(EvalShSeries(kHighL, e16, d));
          err9 += sq(EvalShSeries(2, e9, d));
          errh6 += sq(*EvalHBasisSeries(h6, d));
          errh4 += sq(*EvalHBasisSeries(h4, d));
          norm += w * truth * truth;
        }
      }
      const double r16 = std::sqrt(err16 / norm), r9 = std::sqrt(err9 / norm);
      const double rh6 = std::sqrt(errh6 / norm), rh4 = std::sqrt(errh4 / norm);
      std::printf("%-15s %-9s %9.2e %9.4f %9.4f %9.4f\n", name.c_str(), f.name.c_str(), r16, r9,
                  rh6, rh4);
      EXPECT_LT(r16, kHighOrderTol) << name << " " << f.name;
      EXPECT_LT(r9, kSh9Tol) << name << " " << f.name;
      EXPECT_LE(rh6, rh4 * (1 + kOrderSlack)) << name << " " << f.name;
      EXPECT_LE(r9, rh6 * (1 + kOrderSlack)) << name << " " << f.name;
    }
  }
}

TEST(TangentIrradianceTest, BadArgumentsAreRejected) {
  const std::vector<double> sh9(9, 1.0), sh8(8, 1.0), sh4(4, 1.0);
  std::vector<double> out9(9), out6(6), out5(5);
  const auto expect = [](const absl::Status& s, const std::string& needle) {
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << needle;
    EXPECT_NE(s.message().find(needle), std::string::npos) << s;
  };
  const Mat3 id = Mat3::Identity();
  expect(TangentIrradianceSh(sh8, id, 1, std::span<double>(out9).first(4)), "8 coefficients");
  expect(TangentIrradianceSh(sh4, id, 2, out9), "L >= lmax = 2");
  expect(TangentIrradianceSh(sh9, id, -1, out9), "lmax = -1");
  expect(TangentIrradianceSh(sh9, id, 2, out6), "out has 6 entries");
  expect(TangentIrradianceH(sh4, id, 6, out6), "L >= 2");
  expect(TangentIrradianceH(sh9, id, 5, out5), "num_h = 5");
  expect(TangentIrradianceH(sh9, id, 6, out5), "out has 5 entries");
  Mat3 skew = id;
  skew.m[0][1] = 0.1;
  expect(TangentIrradianceH(sh9, skew, 6, out6), "orthonormal");
  Mat3 scaled = id;
  scaled.m[2][2] = 2.0;
  expect(TangentIrradianceSh(sh9, scaled, 2, out9), "orthonormal");
}

}  // namespace
}  // namespace shrm
