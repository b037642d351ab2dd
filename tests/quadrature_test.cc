// The theta quadrature rules (core/sh/quadrature.h) against closed forms: the integrals of
// x^k = cos^k(theta) over [-1, 1] (2 / (k + 1) for even k, 0 for odd k) up to each rule's degree
// of exactness, the Gauss-Legendre nodes against P_n's roots refined in long double, and the
// Fejer weights against their defining sum evaluated term by term in long double.
#include "core/sh/quadrature.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace shrm {
namespace {

// The sums of a few hundred weighted terms of size <= 1 round at ~1e-16 each.
constexpr double kMomentTolerance = 2e-14;
// A node in double is its long-double value rounded: within one ulp of 1, and the Newton
// iteration stops within an ulp of the root (quadratic convergence, then rounding).
constexpr double kNodeTolerance = 4.5e-16;
// The Chebyshev recurrence of the Fejer weights' cosines rounds like k eps per term, divided by
// 4 k^2 - 1: far below 1e-15 in each weight (the weights themselves are ~2 / n).
constexpr double kFejerWeightTolerance = 1e-15;

double Moment(int k) { return k % 2 == 1 ? 0.0 : 2.0 / (k + 1); }

void ExpectExactUpTo(const RingQuadrature& q, int degree, const char* rule) {
  for (int k = 0; k <= degree; ++k) {
    double sum = 0;
    for (size_t j = 0; j < q.weight.size(); ++j) sum += q.weight[j] * std::pow(q.cos_theta[j], k);
    EXPECT_NEAR(sum, Moment(k), kMomentTolerance)
        << rule << " n = " << q.weight.size() << ", x^" << k;
  }
}

// P_n(x) and P_n'(x) in long double (Bonnet's recurrence).
void Legendre(int n, long double x, long double* p, long double* dp) {
  long double p0 = 1, p1 = x;
  if (n == 0) {
    *p = 1;
    *dp = 0;
    return;
  }
  for (int k = 2; k <= n; ++k) {
    const long double p2 = ((2 * k - 1) * x * p1 - (k - 1) * p0) / k;
    p0 = p1;
    p1 = p2;
  }
  *p = p1;
  *dp = n * (x * p1 - p0) / (x * x - 1);
}

TEST(Quadrature, GaussLegendreIsExactToDegreeTwoNMinusOne) {
  for (int n : {1, 2, 3, 5, 16, 40, 57, 128}) {
    const RingQuadrature q = GaussLegendreRule(n);
    ASSERT_EQ(q.weight.size(), static_cast<size_t>(n));
    ExpectExactUpTo(q, 2 * n - 1, "Gauss-Legendre");
  }
}

TEST(Quadrature, GaussLegendreNodesAreTheRootsOfPn) {
  for (int n : {2, 7, 16, 40, 64, 200, 512}) {
    const RingQuadrature q = GaussLegendreRule(n);
    for (int j = 0; j < n; ++j) {
      long double x = q.cos_theta[j], p, dp;
      for (int it = 0; it < 3; ++it) {
        Legendre(n, x, &p, &dp);
        x -= p / dp;
      }
      EXPECT_NEAR(q.cos_theta[j], static_cast<double>(x), kNodeTolerance)
          << "n = " << n << ", j = " << j;
      EXPECT_NEAR(std::cos(q.theta[j]), q.cos_theta[j], kNodeTolerance);
      if (j > 0) EXPECT_LT(q.theta[j - 1], q.theta[j]) << "n = " << n;
      EXPECT_EQ(q.weight[j], q.weight[n - 1 - j]);  // mirrored nodes
    }
  }
}

TEST(Quadrature, FejerIsExactToDegreeNMinusOne) {
  for (int n : {1, 2, 3, 8, 64, 255, 512}) {
    const RingQuadrature q = FejerFirstRule(n);
    ASSERT_EQ(q.weight.size(), static_cast<size_t>(n));
    ExpectExactUpTo(q, n - 1, "Fejer");
  }
}

TEST(Quadrature, FejerWeightsEqualTheirDefiningSum) {
  for (int n : {1, 2, 5, 64, 512, 1024, 2048}) {
    const RingQuadrature q = FejerFirstRule(n);
    for (int j = 0; j < n; ++j) {
      const long double pi = 3.141592653589793238462643383279502884L;
      const long double t = pi * (j + 0.5L) / n;
      long double sum = 0;
      for (int k = 1; k <= n / 2; ++k) sum += std::cos(2.0L * k * t) / (4.0L * k * k - 1.0L);
      const long double w = 2.0L / n * (1.0L - 2.0L * sum);
      EXPECT_NEAR(q.weight[j], static_cast<double>(w), kFejerWeightTolerance)
          << "n = " << n << ", j = " << j;
      EXPECT_NEAR(q.theta[j], static_cast<double>(t), 1e-15);
    }
  }
}

}  // namespace
}  // namespace shrm
