// Quadrature rules: exactness on polynomials in cos(theta) against closed-form integrals.
#include "core/sh/quadrature.h"

#include <cmath>

#include "gtest/gtest.h"

namespace shrm {
namespace {

constexpr double kExactTol = 1e-13;  // exact rules; only rounding of O(n) terms remains

// integral_0^pi cos^k(theta) sin(theta) dtheta = integral_-1^1 x^k dx.
double MonomialIntegral(int k) { return k % 2 ? 0.0 : 2.0 / (k + 1); }

double Apply(const RingQuadrature& q, int k) {
  double s = 0;
  for (size_t j = 0; j < q.weight.size(); ++j) s += q.weight[j] * std::pow(q.cos_theta[j], k);
  return s;
}

TEST(QuadratureTest, FejerIsExactBelowDegreeN) {
  for (int n : {1, 2, 7, 32, 65}) {
    const RingQuadrature q = FejerFirstRule(n);
    for (int k = 0; k < n; ++k)
      EXPECT_NEAR(Apply(q, k), MonomialIntegral(k), kExactTol) << n << " " << k;
  }
}

TEST(QuadratureTest, GaussLegendreIsExactBelowDegree2N) {
  for (int n : {1, 2, 5, 16, 33}) {
    const RingQuadrature q = GaussLegendreRule(n);
    for (int k = 0; k < 2 * n; ++k)
      EXPECT_NEAR(Apply(q, k), MonomialIntegral(k), kExactTol) << n << " " << k;
  }
}

TEST(QuadratureTest, NodesAreSortedFromNorthPole) {
  const RingQuadrature g = GaussLegendreRule(300);
  for (size_t j = 1; j < g.theta.size(); ++j) EXPECT_LT(g.theta[j - 1], g.theta[j]);
  double sum = 0;
  for (double w : g.weight) sum += w;
  EXPECT_NEAR(sum, 2.0, kExactTol);
}

}  // namespace
}  // namespace shrm
