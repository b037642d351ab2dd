// Tests for core/sh/hbasis.h (Habel & Wimmer 2010: eqs. 4-16, T_h eq. 14, App. A).
// References: the paper's closed forms (eqs. 8-14), exact values computed with sympy for the
// l = 4 block (App. A, not printed in our copy), quadrature rules from
// core/sh/quadrature.h, and brute-force hemispherical integration of eq. 4.
#include "core/sh/hbasis.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "core/sh/hsh.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

constexpr double kSqrt2 = std::numbers::sqrt2;
// Exact quadrature of low-degree polynomials, a few hundred O(1) terms.
constexpr double kExactTol = 1e-13;
// Closed-form evaluation in different but equivalent forms (angles vs coordinates).
constexpr double kEvalTol = 1e-14;

std::vector<double> RandomVector(int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> v(n);
  for (double& x : v) x = g(rng);
  return v;
}

// Integral over the upper hemisphere (z >= 0) of g(dir) by Fejer's first rule (quadrature.h),
// mapped to x = cos theta in [0, 1], times num_phi equispaced azimuths: exact for polynomials
// in (x, y, z) of degree < num_rings when num_phi exceeds the degree.
double FejerHemisphere(int num_rings, int num_phi, const std::function<double(const Vec3&)>& g) {
  const RingQuadrature q = FejerFirstRule(num_rings);
  double sum = 0;
  for (int j = 0; j < num_rings; ++j) {
    const double x = 0.5 * (1.0 + q.cos_theta[j]);
    const double s = std::sqrt((1.0 - x) * (1.0 + x));
    for (int k = 0; k < num_phi; ++k) {
      const double p = 2.0 * kPi * (k + 0.25) / num_phi;  // offset: not the code's azimuths
      sum += 0.5 * q.weight[j] * (2.0 * kPi / num_phi) * g({s * std::cos(p), s * std::sin(p), x});
    }
  }
  return sum;
}

TEST(HBasis, MatchesClosedFormsInAngles) {
  // Eqs. 8-13, the (theta, phi) forms, against the code's (x, y, z) forms.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> ut(0.0, kPi / 2), up(-kPi, kPi);
  const double c3 = std::sqrt(3 / (2 * kPi)), c15 = std::sqrt(15 / (2 * kPi));
  for (int trial = 0; trial < 50; ++trial) {
    const double t = ut(rng), p = up(rng);
    const auto h = EvalHBasis(DirectionFromAngles(t, p));
    EXPECT_NEAR(h[0], 1 / std::sqrt(2 * kPi), kEvalTol);
    EXPECT_NEAR(h[1], -c3 * std::sin(p) * std::sin(t), kEvalTol);
    EXPECT_NEAR(h[2], c3 * (2 * std::cos(t) - 1), kEvalTol);
    EXPECT_NEAR(h[3], -c3 * std::cos(p) * std::sin(t), kEvalTol);
    EXPECT_NEAR(h[4], 0.5 * c15 * std::sin(2 * p) * std::sin(t) * std::sin(t), kEvalTol);
    EXPECT_NEAR(h[5], 0.5 * c15 * std::cos(2 * p) * std::sin(t) * std::sin(t), kEvalTol);
    // Relations to the SH (CS phase, sh.h) and the HSH: H = sqrt2 Y, and H3 = H_1^0.
    const double yv[] = {EvalShSlow(0, 0, t, p), EvalShSlow(1, -1, t, p), EvalShSlow(1, 1, t, p),
                         EvalShSlow(2, -2, t, p), EvalShSlow(2, 2, t, p)};
    const int idx[] = {0, 1, 3, 4, 5};
    for (int i = 0; i < 5; ++i) EXPECT_NEAR(h[idx[i]], kSqrt2 * yv[i], kEvalTol);
    EXPECT_NEAR(h[2], EvalHshSlow(1, 0, t, p), kEvalTol);
  }
}

TEST(HBasis, GramIsIdentityOnHemisphere) {
  // Products are polynomials of degree <= 4: Fejer with 8 rings x 9 azimuths is exact.
  for (int a = 0; a < kHBasisCount; ++a) {
    for (int b = 0; b < kHBasisCount; ++b) {
      const double g = FejerHemisphere(8, 9, [&](const Vec3& n) {
        const auto h = EvalHBasis(n);
        return h[a] * h[b];
      });
      EXPECT_NEAR(g, a == b ? 1.0 : 0.0, kExactTol) << a << " " << b;
    }
  }
}

TEST(HBasis, ThMatchesEq14) {
  auto conv = HBasisConversion::Create(2);
  ASSERT_TRUE(conv.ok());
  ASSERT_EQ(conv->cols(), 9);
  // Eq. 14 as printed (rows H1..H6, columns SH index 0..8).
  const double a = 1 / kSqrt2, b = 0.5 * std::sqrt(1.5), c = 3.0 / 8.0 * std::sqrt(2.5),
               d = 1 / (2 * kSqrt2), e = 0.25 * std::sqrt(7.5);
  const double th[6][9] = {{a, 0, b, 0, 0, 0, 0, 0, 0}, {0, a, 0, 0, 0, c, 0, 0, 0},
                           {0, 0, d, 0, 0, 0, e, 0, 0}, {0, 0, 0, a, 0, 0, 0, c, 0},
                           {0, 0, 0, 0, a, 0, 0, 0, 0}, {0, 0, 0, 0, 0, 0, 0, 0, a}};
  for (int r = 0; r < 6; ++r)
    for (int col = 0; col < 9; ++col)
      EXPECT_NEAR((*conv)(r, col), th[r][col], kExactTol) << r << col;
}

TEST(HBasis, ThHigherBandsMatchExactProjection) {
  // App. A (l = 4) and the l = 3 block, exact values by sympy from eqs. 8-13 and sh.h's SH.
  auto conv = HBasisConversion::Create(4);
  ASSERT_TRUE(conv.ok());
  std::vector<double> expected(6 * 25, 0.0);
  auto set = [&](int row, int l, int m, double v) { expected[row * 25 + ShIndex(l, m)] = v; };
  set(0, 3, 0, -std::sqrt(14.0) / 16);
  set(2, 3, 0, std::sqrt(42.0) / 16);
  set(4, 3, -2, 5 * std::sqrt(14.0) / 32);
  set(5, 3, 2, 5 * std::sqrt(14.0) / 32);
  set(1, 4, -1, -std::sqrt(15.0) / 16);
  set(2, 4, 0, -std::sqrt(6.0) / 16);
  set(3, 4, 1, -std::sqrt(15.0) / 16);
  for (int r = 0; r < 6; ++r)
    for (int col = 9; col < 25; ++col)
      EXPECT_NEAR((*conv)(r, col), expected[r * 25 + col], kExactTol) << r << " " << col;
}

TEST(HBasis, ThIsProjectionByIndependentQuadrature) {
  // T_h applied to a random degree-4 SH expansion equals its brute-force H projection.
  constexpr int kLmax = 4;
  auto conv = HBasisConversion::Create(kLmax);
  ASSERT_TRUE(conv.ok());
  const std::vector<double> s = RandomVector(ShCount(kLmax), 5);
  std::array<double, 6> h{};
  ASSERT_TRUE(conv->Apply(s, h).ok());
  for (int i = 0; i < 6; ++i) {
    const double ref = FejerHemisphere(
        10, 9, [&](const Vec3& n) { return EvalHBasis(n)[i] * EvalShSeries(kLmax, s, n); });
    EXPECT_NEAR(h[i], ref, kExactTol * 10) << i;
  }
  std::array<double, 4> h4{};
  ASSERT_TRUE(conv->Apply(s, h4).ok());
  for (int i = 0; i < 4; ++i) EXPECT_EQ(h4[i], h[i]);
  // ProjectHBasis by the code's own rule agrees too.
  auto rule = MakeHemisphereRule(5, 8);
  ASSERT_TRUE(rule.ok());
  const auto p = ProjectHBasis(*rule, [&](const Vec3& n) { return EvalShSeries(kLmax, s, n); });
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(p[i], h[i], kExactTol * 10);
}

TEST(HBasis, RejectsBadInput) {
  EXPECT_EQ(HBasisConversion::Create(-1).status().code(), absl::StatusCode::kInvalidArgument);
  auto conv = HBasisConversion::Create(2);
  ASSERT_TRUE(conv.ok());
  std::vector<double> s(9), wrong(8), h5(5), h6(6);
  EXPECT_FALSE(conv->Apply(wrong, h6).ok());
  EXPECT_FALSE(conv->Apply(s, h5).ok());
  EXPECT_FALSE(EvalHBasisSeries(h5, {0, 0, 1}).ok());
  EXPECT_FALSE(IrradianceShFromRadianceSh(-1, s, s).ok());
  EXPECT_FALSE(IrradianceShFromRadianceSh(2, wrong, s).ok());
}

TEST(Irradiance, BandFactorsMatchEq6) {
  const double a[] = {1.0, 2.0 / 3.0, 0.25, 0.0, -1.0 / 24.0};
  for (int l = 0; l <= 4; ++l) {
    EXPECT_NEAR(HabelBandFactor(l), a[l], kEvalTol) << l;
    EXPECT_NEAR(LambertianBandFactor(l), kPi * a[l], kEvalTol) << l;
  }
  // A_6 = pi / 64 (Ramamoorthi & Hanrahan 2001), odd bands above 1 vanish.
  EXPECT_NEAR(LambertianBandFactor(6), kPi / 64.0, kEvalTol);
  EXPECT_EQ(LambertianBandFactor(5), 0.0);
  EXPECT_EQ(LambertianBandFactor(-1), 0.0);
}

// Eq. 4 by brute force: E(n) = integral over the hemisphere around n of L(w) (n . w) dw, in a
// frame (t1, t2, n), with Gauss-Legendre in cos (quadrature.h) x equispaced azimuths. L of
// degree D makes the integrand a polynomial of degree D + 1 in w: exact with 8 x 12 nodes.
double BruteIrradiance(int lmax, const std::vector<double>& radiance, const Vec3& n) {
  const Vec3 helper = std::abs(n.z) < 0.9 ? Vec3{0, 0, 1} : Vec3{1, 0, 0};
  const Vec3 t1 = helper.Cross(n).Normalized();
  const Vec3 t2 = n.Cross(t1);
  const RingQuadrature q = GaussLegendreRule(8);
  constexpr int kPhi = 12;
  double sum = 0;
  for (int j = 0; j < 8; ++j) {
    const double c = 0.5 * (1.0 + q.cos_theta[j]);  // cos of the angle to n, in [0, 1]
    const double s = std::sqrt((1.0 - c) * (1.0 + c));
    for (int k = 0; k < kPhi; ++k) {
      const double p = 2.0 * kPi * k / kPhi;
      const Vec3 w = t1 * (s * std::cos(p)) + t2 * (s * std::sin(p)) + n * c;
      sum += 0.5 * q.weight[j] * (2.0 * kPi / kPhi) * EvalShSeries(lmax, radiance, w) * c;
    }
  }
  return sum;
}

TEST(Irradiance, BandFactorsEqualBruteForceEq4) {
  constexpr double kIrrTol = 1e-12;  // exact quadrature vs exact Funk-Hecke, O(10) values
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> ut(0.0, kPi), up(-kPi, kPi);
  for (int lmax : {2, 4}) {
    for (bool zero_band3 : {true, false}) {
      std::vector<double> radiance = RandomVector(ShCount(lmax), 100 + lmax);
      if (lmax == 4 && zero_band3)
        for (int m = -3; m <= 3; ++m) radiance[ShIndex(3, m)] = 0.0;
      std::vector<double> irr(ShCount(lmax));
      ASSERT_TRUE(IrradianceShFromRadianceSh(lmax, radiance, irr).ok());
      for (int trial = 0; trial < 20; ++trial) {
        const Vec3 n = DirectionFromAngles(ut(rng), up(rng));
        const double brute = BruteIrradiance(lmax, radiance, n);
        EXPECT_NEAR(EvalShSeries(lmax, irr, n), brute, kIrrTol) << lmax << zero_band3;
        // The paper's eq. 6-7 (a^l) give E / pi.
        double e_over_pi = 0;
        std::vector<double> y(ShCount(lmax));
        EvalSh(lmax, n, y);
        for (int l = 0; l <= lmax; ++l)
          for (int m = -l; m <= l; ++m)
            e_over_pi += HabelBandFactor(l) * radiance[ShIndex(l, m)] * y[ShIndex(l, m)];
        EXPECT_NEAR(e_over_pi * kPi, brute, kIrrTol);
      }
    }
  }
}

TEST(Imse, ZeroInSpanAndKnownValue) {
  auto rule = MakeHemisphereRule(6, 12);
  ASSERT_TRUE(rule.ok());
  // Constant 1 vs 0: IMSE = area of the hemisphere.
  EXPECT_NEAR(HemisphereImse(
                  *rule, [](const Vec3&) { return 0.0; }, [](const Vec3&) { return 1.0; }),
              2 * kPi, kExactTol);
  // An irradiance of band-limited radiance (l <= 2) projected onto H_6 vs SH9: SH9 is exact,
  // H_6 is not (yz, xz, z^2 are missing), H_6 of its own span is exact.
  const std::vector<double> radiance = RandomVector(9, 77);
  std::vector<double> irr(9);
  ASSERT_TRUE(IrradianceShFromRadianceSh(2, radiance, irr).ok());
  auto truth = [&](const Vec3& n) { return EvalShSeries(2, irr, n); };
  EXPECT_NEAR(HemisphereImse(*rule, truth, truth), 0.0, kExactTol);
  auto conv = HBasisConversion::Create(2);
  ASSERT_TRUE(conv.ok());
  std::array<double, 6> h{};
  ASSERT_TRUE(conv->Apply(irr, h).ok());
  auto h6 = [&](const Vec3& n) { return *EvalHBasisSeries(h, n); };
  const double imse_h6 = HemisphereImse(*rule, h6, truth);
  EXPECT_GT(imse_h6, 0.0);
  // Orthonormal projection: IMSE = |E|^2 - |h|^2 on the hemisphere (Pythagoras).
  double h2 = 0;
  for (double x : h) h2 += x * x;
  const double e2 = HemisphereImse(
      *rule, [](const Vec3&) { return 0.0; }, truth);
  EXPECT_NEAR(imse_h6, e2 - h2, kExactTol * 10 * e2);
  EXPECT_NEAR(HemisphereImse(*rule, h6, h6), 0.0, kExactTol);
}

}  // namespace
}  // namespace shrm
