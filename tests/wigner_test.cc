// Tests of core/sh/wigner.h: the small-d recurrence against Wigner's factorial sum, its
// stability at l = 256 (orthogonality, composition), special values, and the D convention
// checked against complex SH evaluated at rotated directions.
#include "core/sh/wigner.h"

#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "core/base/geometry.h"
#include "core/sh/sh.h"
#include "gtest/gtest.h"

namespace shrm {
namespace {

constexpr double kSlowTwinTol = 1e-12;    // long double factorial sum vs double recurrence, l <= 14
constexpr double kExactTol = 1e-14;       // closed forms of a few ulps
constexpr double kRecurrenceTol = 1e-13;  // rounding of up to 40 steps of the l-recurrence
constexpr double kOrthoTolL256 = 1e-11;   // 513-term dot products of O(1/sqrt l) entries at l = 256
constexpr double kComposeTolL256 = 1e-11;  // d(a) d(b) vs d(a + b), 513-term sums, l = 256
constexpr double kConventionTol = 1e-12;   // complex SH at rotated directions, l <= 8

const double kAngles[] = {0.0, 1e-6, 0.3, 1.0, kPi / 2, 2.0, 3.0, kPi - 1e-6, kPi, -0.7, 4.0};

TEST(WignerSmallDTest, MatchesFactorialSumTwin) {
  constexpr int kLmax = 14;
  const WignerSmallD w = *WignerSmallD::Create(kLmax);
  std::vector<double> d(WignerTableSize(kLmax));
  for (double beta : kAngles) {
    w.Compute(beta, d);
    for (int l = 0; l <= kLmax; ++l)
      for (int m = -l; m <= l; ++m)
        for (int mp = -l; mp <= l; ++mp)
          ASSERT_NEAR(d[WignerBandOffset(l) + WignerBlockIndex(l, m, mp)],
                      WignerSmallDSlow(l, m, mp, beta), kSlowTwinTol)
              << "l=" << l << " m=" << m << " m'=" << mp << " beta=" << beta;
  }
}

TEST(WignerSmallDTest, BandOneMatchesStatedConvention) {
  for (double b : kAngles) {
    const std::vector<double> d = WignerSmallDTable(1, b);
    const long o = WignerBandOffset(1);
    EXPECT_NEAR(d[o + WignerBlockIndex(1, -1, 0)], std::sin(b) / std::sqrt(2.0), kExactTol);
    EXPECT_NEAR(d[o + WignerBlockIndex(1, 0, 0)], std::cos(b), kExactTol);
    EXPECT_NEAR(d[o + WignerBlockIndex(1, 1, 0)], -std::sin(b) / std::sqrt(2.0), kExactTol);
    EXPECT_NEAR(d[o + WignerBlockIndex(1, 1, 1)], (1 + std::cos(b)) / 2, kExactTol);
    EXPECT_NEAR(d[o + WignerBlockIndex(1, 1, -1)], (1 - std::cos(b)) / 2, kExactTol);
  }
}

TEST(WignerSmallDTest, SpecialAngles) {
  constexpr int kLmax = 40;
  const std::vector<double> d0 = WignerSmallDTable(kLmax, 0.0);
  const std::vector<double> dpi = WignerSmallDTable(kLmax, kPi);
  for (int l = 0; l <= kLmax; ++l)
    for (int m = -l; m <= l; ++m)
      for (int mp = -l; mp <= l; ++mp) {
        const long i = WignerBandOffset(l) + WignerBlockIndex(l, m, mp);
        EXPECT_NEAR(d0[i], m == mp ? 1.0 : 0.0, kRecurrenceTol);
        // d^l_{mm'}(pi) = (-1)^{l+m} delta_{m,-m'}.
        EXPECT_NEAR(dpi[i], m == -mp ? (((l + m) & 1) ? -1.0 : 1.0) : 0.0, kRecurrenceTol);
      }
}

TEST(WignerSmallDTest, ColumnZeroIsSphericalHarmonic) {
  // Standard identity d^l_{m0}(b) = sqrt(4pi / (2l+1)) Y_lm(b, 0) (complex SH, Condon-Shortley).
  constexpr int kLmax = 30;
  constexpr double kTol = 1e-12;  // two independent recurrences, l <= 30
  const double b = 0.83;
  const std::vector<double> d = WignerSmallDTable(kLmax, b);
  for (int l = 0; l <= kLmax; ++l)
    for (int m = -l; m <= l; ++m)
      EXPECT_NEAR(d[WignerBandOffset(l) + WignerBlockIndex(l, m, 0)],
                  std::sqrt(4 * kPi / (2 * l + 1)) * EvalComplexSh(l, m, b, 0.0).real(), kTol)
          << "l=" << l << " m=" << m;
}

// Orthogonality of the rows and the composition law at l = 256 (the stability requirement).
TEST(WignerSmallDTest, StableAtL256) {
  constexpr int kL = 256;
  constexpr int kW = 2 * kL + 1;
  const WignerSmallD w = *WignerSmallD::Create(kL);
  std::vector<double> d(kW * kW), da(kW * kW), db(kW * kW);
  for (double beta : {1e-3, 0.4, kPi / 2, 2.5, kPi - 1e-3}) {
    w.ComputeBand(kL, beta, d);
    double worst = 0, worst_norm = 0;
    for (int i = 0; i < kW; ++i) {
      for (int j = i; j < kW; ++j) {
        double s = 0;
        for (int k = 0; k < kW; ++k) s += d[i * kW + k] * d[j * kW + k];
        worst = std::max(worst, std::abs(s - (i == j ? 1.0 : 0.0)));
        if (i == j) worst_norm = std::max(worst_norm, std::abs(s - 1));
      }
    }
    EXPECT_LT(worst, kOrthoTolL256) << "beta=" << beta;
    EXPECT_LT(worst_norm, kOrthoTolL256) << "sum_m' d^2 = 1 fails, beta=" << beta;
  }
  const double a = 0.9, b = 1.7;
  w.ComputeBand(kL, a, da);
  w.ComputeBand(kL, b, db);
  w.ComputeBand(kL, a + b, d);
  double worst = 0;
  for (int i = 0; i < kW; ++i)
    for (int j = 0; j < kW; ++j) {
      double s = 0;
      for (int k = 0; k < kW; ++k) s += da[i * kW + k] * db[k * kW + j];
      worst = std::max(worst, std::abs(s - d[i * kW + j]));
    }
  EXPECT_LT(worst, kComposeTolL256);
}

TEST(WignerSmallDTest, BandMatchesTable) {
  constexpr int kLmax = 20;
  const WignerSmallD w = *WignerSmallD::Create(kLmax);
  std::vector<double> table(WignerTableSize(kLmax));
  w.Compute(1.234, table);
  for (int l = 0; l <= kLmax; ++l) {
    std::vector<double> band((2 * l + 1) * (2 * l + 1));
    w.ComputeBand(l, 1.234, band);
    for (size_t i = 0; i < band.size(); ++i)
      ASSERT_EQ(band[i], table[WignerBandOffset(l) + i]) << "l=" << l;
  }
}

TEST(WignerDTest, ComplexMatchesSlowTwin) {
  constexpr int kLmax = 8;
  const double a = 0.4, b = 1.1, g = -2.3;
  const std::vector<std::complex<double>> d = WignerDTable(kLmax, a, b, g);
  for (int l = 0; l <= kLmax; ++l)
    for (int m = -l; m <= l; ++m)
      for (int mp = -l; mp <= l; ++mp)
        EXPECT_LT(std::abs(d[WignerBandOffset(l) + WignerBlockIndex(l, m, mp)] -
                           WignerDSlow(l, m, mp, a, b, g)),
                  kSlowTwinTol);
}

// The defining relation Y_lq(Rot^-1 w) = sum_m D^l_mq(Rot) Y_lm(w), Rot = Rz(a) Ry(b) Rz(g),
// with the complex SH of core/sh/sh.h evaluated at plain and rotated directions.
TEST(WignerDTest, DefinitionAgainstRotatedComplexSh) {
  constexpr int kLmax = 8;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-kPi, kPi);
  for (int trial = 0; trial < 4; ++trial) {
    const double a = u(rng), b = std::abs(u(rng)), g = u(rng);
    const Mat3 rot = RotationZ(a) * RotationY(b) * RotationZ(g);
    const std::vector<std::complex<double>> d = WignerDTable(kLmax, a, b, g);
    for (int k = 0; k < 5; ++k) {
      const Vec3 wdir = DirectionFromAngles(std::abs(u(rng)), u(rng));
      double th, ph, th_r, ph_r;
      AnglesFromDirection(wdir, &th, &ph);
      AnglesFromDirection(rot.Transposed() * wdir, &th_r, &ph_r);
      for (int l = 0; l <= kLmax; ++l)
        for (int q = -l; q <= l; ++q) {
          std::complex<double> sum = 0;
          for (int m = -l; m <= l; ++m)
            sum += d[WignerBandOffset(l) + WignerBlockIndex(l, m, q)] * EvalComplexSh(l, m, th, ph);
          EXPECT_LT(std::abs(sum - EvalComplexSh(l, q, th_r, ph_r)), kConventionTol)
              << "l=" << l << " q=" << q;
        }
    }
  }
}

TEST(WignerDTest, RealShUnitaryIsUnitaryAndMatchesRealSh) {
  for (int l = 0; l <= 6; ++l) {
    const int w = 2 * l + 1;
    const std::vector<std::complex<double>> u = RealShUnitary(l);
    for (int a = 0; a < w; ++a)
      for (int b = 0; b < w; ++b) {
        std::complex<double> s = 0;
        for (int k = 0; k < w; ++k) s += u[a * w + k] * std::conj(u[b * w + k]);
        EXPECT_LT(std::abs(s - (a == b ? 1.0 : 0.0)), kExactTol);
      }
    // Y^real_a = sum_m U_am Y_m at one direction.
    const double th = 0.7, ph = -2.1;
    const std::vector<double> real = EvalSh(l, DirectionFromAngles(th, ph));
    for (int a = -l; a <= l; ++a) {
      std::complex<double> s = 0;
      for (int m = -l; m <= l; ++m) s += u[(a + l) * w + (m + l)] * EvalComplexSh(l, m, th, ph);
      EXPECT_NEAR(s.real(), real[ShIndex(l, a)], kConventionTol);
      EXPECT_NEAR(s.imag(), 0.0, kConventionTol);
    }
  }
}

TEST(WignerSmallDTest, RejectsBadLmax) {
  EXPECT_FALSE(WignerSmallD::Create(-1).ok());
  EXPECT_FALSE(WignerSmallD::Create(kMaxWignerLmax + 1).ok());
  EXPECT_TRUE(WignerSmallD::Create(0).ok());
}

}  // namespace
}  // namespace shrm
