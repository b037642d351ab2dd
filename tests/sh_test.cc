// Real and complex SH: closed forms, the textbook twin, orthonormality to l = 256 by
// Gauss-Legendre quadrature, the addition theorem to l = 512 (also near the poles), and the
// real <-> complex coefficient conversion.
#include "core/sh/sh.h"

#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "core/sh/quadrature.h"
#include "gtest/gtest.h"

namespace shrm {
namespace {

constexpr double kClosedFormTol = 1e-14;  // a few ulps of O(1) values
constexpr double kSlowTwinTol = 1e-11;    // long-double factorial sums lose ~4 digits by l = 15
constexpr double kGramTol = 1e-10;        // issue acceptance bound for max |G - I|
constexpr double kAdditionTol = 1e-9;  // relative; sums of 1025 terms of size up to ~6 at l = 512

std::vector<Vec3> RandomDirections(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<Vec3> d(n);
  for (auto& v : d) v = Vec3{g(rng), g(rng), g(rng)}.Normalized();
  // Directions at and near both poles and on the equator.
  d.push_back({0, 0, 1});
  d.push_back({0, 0, -1});
  d.push_back(DirectionFromAngles(1e-9, 0.3));
  d.push_back(DirectionFromAngles(kPi - 1e-7, -2.0));
  d.push_back({1, 0, 0});
  return d;
}

TEST(ShTest, IndexLayout) {
  EXPECT_EQ(ShIndex(0, 0), 0);
  EXPECT_EQ(ShIndex(1, -1), 1);
  EXPECT_EQ(ShIndex(1, 1), 3);
  EXPECT_EQ(ShIndex(2, -2), 4);
  EXPECT_EQ(ShCount(2), 9);
  EXPECT_EQ(LegendreCount(3), 10);
}

TEST(ShTest, LowBandsMatchClosedForms) {
  // Real SH with the Condon-Shortley phase (docs/conventions.md).
  const double c0 = 0.5 / std::sqrt(kPi), c1 = std::sqrt(3 / (4 * kPi)),
               c2 = std::sqrt(15 / (4 * kPi)), c20 = std::sqrt(5 / (16 * kPi));
  for (const Vec3& d : RandomDirections(20, 1)) {
    const std::vector<double> y = EvalSh(2, d);
    const double x = d.x, yy = d.y, z = d.z;
    EXPECT_NEAR(y[0], c0, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(1, -1)], -c1 * yy, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(1, 0)], c1 * z, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(1, 1)], -c1 * x, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(2, -2)], c2 * x * yy, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(2, -1)], -c2 * yy * z, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(2, 0)], c20 * (3 * z * z - 1), kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(2, 1)], -c2 * x * z, kClosedFormTol);
    EXPECT_NEAR(y[ShIndex(2, 2)], 0.5 * c2 * (x * x - yy * yy), kClosedFormTol);
  }
}

TEST(ShTest, FastEvaluatorsMatchTextbookTwin) {
  constexpr int kLmax = 15;
  const std::vector<Vec3> dirs = RandomDirections(40, 2);
  std::vector<double> batch(ShCount(kLmax) * dirs.size());
  EvalShBatch(kLmax, dirs, batch);
  for (size_t k = 0; k < dirs.size(); ++k) {
    double theta, phi;
    AnglesFromDirection(dirs[k], &theta, &phi);
    const std::vector<double> y = EvalSh(kLmax, dirs[k]);
    for (int l = 0; l <= kLmax; ++l) {
      for (int m = -l; m <= l; ++m) {
        const double slow = EvalShSlow(l, m, theta, phi);
        EXPECT_NEAR(y[ShIndex(l, m)], slow, kSlowTwinTol) << l << " " << m;
        EXPECT_NEAR(batch[ShIndex(l, m) * dirs.size() + k], slow, kSlowTwinTol) << l << " " << m;
        const std::complex<double> c = EvalComplexSh(l, m, theta, phi);
        const std::complex<double> cs = EvalComplexShSlow(l, m, theta, phi);
        EXPECT_NEAR(std::abs(c - cs), 0.0, kSlowTwinTol) << l << " " << m;
      }
    }
  }
}

TEST(ShTest, RealShAreScaledRealAndImaginaryPartsOfComplexSh) {
  const double theta = 1.1, phi = -2.3;
  for (int l = 0; l <= 10; ++l) {
    for (int m = 1; m <= l; ++m) {
      const std::complex<double> c = EvalComplexSh(l, m, theta, phi);
      std::vector<double> y(ShCount(l));
      EvalSh(l, theta, phi, y);
      EXPECT_NEAR(y[ShIndex(l, m)], std::sqrt(2.0) * c.real(), kClosedFormTol);
      EXPECT_NEAR(y[ShIndex(l, -m)], std::sqrt(2.0) * c.imag(), kClosedFormTol);
      const std::complex<double> cm = EvalComplexSh(l, -m, theta, phi);
      EXPECT_NEAR(std::abs(cm - (m % 2 ? -1.0 : 1.0) * std::conj(c)), 0.0, kClosedFormTol);
    }
  }
}

// The real-SH Gram matrix factorizes: for (l, m) and (l', m') the azimuthal integral of the
// trigonometric factors is exactly 0 unless m = m' (uniform-phi rule with > 2 lmax samples), so
// max |G - I| is the max over m of the Legendre Gram 2 pi sum_j w_j lambda_l^m lambda_l'^m
// (doubled for m != 0 by the sqrt2 factors and halved by the cos^2/sin^2 average). This checks
// every entry of G up to l = 256 with Gauss-Legendre quadrature of 257 nodes (exact degree 513).
TEST(ShTest, OrthonormalToDegree256ByGaussLegendre) {
  constexpr int kLmax = 256;
  const RingQuadrature q = GaussLegendreRule(kLmax + 1);
  std::vector<std::vector<double>> table(q.weight.size());
  for (size_t j = 0; j < q.weight.size(); ++j) {
    table[j].resize(LegendreCount(kLmax));
    NormalizedLegendre(kLmax, q.cos_theta[j], q.sin_theta[j], table[j]);
  }
  double worst = 0;
  for (int m = 0; m <= kLmax; m += 1) {
    for (int l = m; l <= kLmax; ++l) {
      for (int lp = l; lp <= kLmax; ++lp) {
        double g = 0;
        for (size_t j = 0; j < q.weight.size(); ++j)
          g += q.weight[j] * table[j][LegendreIndex(l, m)] * table[j][LegendreIndex(lp, m)];
        g *= 2 * kPi;
        worst = std::max(worst, std::abs(g - (l == lp ? 1.0 : 0.0)));
      }
    }
  }
  EXPECT_LT(worst, kGramTol);
}

// The same identity computed with the full real-SH evaluator on a product grid (all m, m').
TEST(ShTest, FullGramMatrixOnProductGrid) {
  constexpr int kLmax = 20;
  const RingQuadrature q = GaussLegendreRule(kLmax + 1);
  const int num_phi = 2 * kLmax + 1;
  std::vector<Vec3> dirs;
  std::vector<double> w;
  for (size_t j = 0; j < q.weight.size(); ++j) {
    for (int k = 0; k < num_phi; ++k) {
      dirs.push_back(DirectionFromAngles(q.theta[j], 2 * kPi * (k + 0.25) / num_phi));
      w.push_back(q.weight[j] * 2 * kPi / num_phi);
    }
  }
  const int n = ShCount(kLmax);
  std::vector<double> y(n * dirs.size());
  EvalShBatch(kLmax, dirs, y);
  double worst = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = a; b < n; ++b) {
      double g = 0;
      for (size_t k = 0; k < dirs.size(); ++k)
        g += w[k] * y[a * dirs.size() + k] * y[b * dirs.size() + k];
      worst = std::max(worst, std::abs(g - (a == b ? 1.0 : 0.0)));
    }
  }
  EXPECT_LT(worst, kGramTol);
}

// Unnormalized Legendre polynomial by Bonnet's recurrence: an independent reference.
double LegendreP(int l, double x) {
  double p0 = 1, p1 = x;
  if (l == 0) return 1;
  for (int k = 2; k <= l; ++k) {
    const double p2 = ((2.0 * k - 1) * x * p1 - (k - 1.0) * p0) / k;
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

// Addition theorem: sum_m Y_lm(a) Y_lm(b) = (2l+1)/(4 pi) P_l(a.b); with a = b the sum is
// (2l+1)/(4 pi). Checked at l = 512, including directions 1e-9 rad from the poles.
TEST(ShTest, AdditionTheoremAtDegree512) {
  constexpr int kLmax = 512;
  const std::vector<Vec3> dirs = RandomDirections(6, 3);
  std::vector<std::vector<double>> ys;
  for (const Vec3& d : dirs) ys.push_back(EvalSh(kLmax, d));
  for (size_t a = 0; a < dirs.size(); ++a) {
    for (size_t b = a; b < dirs.size(); ++b) {
      for (int l : {0, 1, 7, 100, 255, 511, 512}) {
        double s = 0;
        for (int m = -l; m <= l; ++m) s += ys[a][ShIndex(l, m)] * ys[b][ShIndex(l, m)];
        const double norm = (2 * l + 1) / (4 * kPi);
        const double expected = norm * LegendreP(l, std::clamp(dirs[a].Dot(dirs[b]), -1.0, 1.0));
        EXPECT_NEAR(s, expected, kAdditionTol * norm) << a << " " << b << " l=" << l;
      }
    }
  }
}

TEST(ShTest, LegendreAtThePoleIsExact) {
  constexpr int kLmax = 512;
  std::vector<double> p(LegendreCount(kLmax));
  NormalizedLegendre(kLmax, 1.0, 0.0, p);
  for (int l = 0; l <= kLmax; ++l) {
    EXPECT_NEAR(p[LegendreIndex(l, 0)], std::sqrt((2 * l + 1) / (4 * kPi)),
                1e-12 * std::sqrt(l + 1.0));
    for (int m = 1; m <= l; ++m) EXPECT_EQ(p[LegendreIndex(l, m)], 0.0);
  }
}

// A real function's coefficients in both bases, each computed by quadrature on its own basis,
// are related by ComplexToReal / RealToComplex.
TEST(ShTest, RealComplexConversionMatchesProjection) {
  constexpr int kLmax = 6;
  const RingQuadrature q = GaussLegendreRule(kLmax + 4);
  const int num_phi = 2 * kLmax + 3;
  auto f = [](const Vec3& d) { return std::exp(d.x - 0.5 * d.y + 0.3 * d.z * d.x); };
  std::vector<double> real(ShCount(kLmax), 0.0);
  std::vector<std::complex<double>> cplx(ShCount(kLmax), 0.0);
  std::vector<std::complex<double>> yc(ShCount(kLmax));
  std::vector<double> yr(ShCount(kLmax));
  // Not band-limited, so both projections share the same aliasing; the relation is linear and
  // holds exactly for the discrete sums.
  for (size_t j = 0; j < q.weight.size(); ++j) {
    for (int k = 0; k < num_phi; ++k) {
      const double phi = 2 * kPi * k / num_phi;
      const double w = q.weight[j] * 2 * kPi / num_phi;
      const Vec3 d = DirectionFromAngles(q.theta[j], phi);
      EvalSh(kLmax, d, yr);
      EvalComplexSh(kLmax, q.theta[j], phi, yc);
      for (int i = 0; i < ShCount(kLmax); ++i) {
        real[i] += w * f(d) * yr[i];
        cplx[i] += w * f(d) * std::conj(yc[i]);
      }
    }
  }
  std::vector<double> r2(ShCount(kLmax));
  ComplexToReal(kLmax, cplx, r2);
  std::vector<std::complex<double>> c2(ShCount(kLmax));
  RealToComplex(kLmax, real, c2);
  for (int i = 0; i < ShCount(kLmax); ++i) {
    EXPECT_NEAR(r2[i], real[i], 1e-13);
    EXPECT_NEAR(std::abs(c2[i] - cplx[i]), 0.0, 1e-13);
  }
}

TEST(ShTest, WorldAndShFramesAreRightHandedWithYUp) {
  const Vec3 up = ShFrameFromWorld({0, 1, 0});
  EXPECT_EQ(up.z, 1.0);
  const Vec3 xs = ShFrameFromWorld({1, 0, 0}), ys = ShFrameFromWorld({0, 0, -1});
  EXPECT_EQ(xs.x, 1.0);
  EXPECT_EQ(ys.y, 1.0);
  const Vec3 c = xs.Cross(ys);  // x_s cross y_s = z_s
  EXPECT_EQ(c.z, 1.0);
  const Vec3 w{0.3, -0.2, 0.9};
  const Vec3 back = WorldFromShFrame(ShFrameFromWorld(w));
  EXPECT_EQ(back.x, w.x);
  EXPECT_EQ(back.y, w.y);
  EXPECT_EQ(back.z, w.z);
}

}  // namespace
}  // namespace shrm
