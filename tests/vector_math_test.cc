// The elementwise vector math (core/brdf/vector_math.h) against libm's scalar functions: within
// libmvec's documented accuracy where it runs, at every length (the masked last vector), in
// every quadrant and at the signed zeros and axes for atan2, and in place.
#include "core/brdf/vector_math.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace shrm::internal {
namespace {

// libmvec's documented bound: 4 ulp of the exact value; libm's own result is within ~1 ulp of
// it, so 5 ulp of libm's. (The scalar fallback is libm itself: 0.)
constexpr double kUlps = 5;

double Ulp(double v) {
  const double a = std::abs(v);
  return std::nextafter(a, INFINITY) - a;
}

void ExpectClose(double got, double want, const char* what, int i) {
  if (want == 0) {
    EXPECT_LE(std::abs(got), 1e-300) << what << " at " << i;
    return;
  }
  EXPECT_LE(std::abs(got - want), kUlps * Ulp(want))
      << what << " at " << i << ": " << got << " vs " << want;
}

TEST(VectorMathTest, Atan2IsLibmsInEveryQuadrantAndAtTheAxes) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<double> y, x;
  const double specials[] = {0.0, -0.0, 1.0, -1.0, 1e-300, -1e-300, 3.5, -3.5};
  for (double a : specials)
    for (double b : specials) {
      y.push_back(a);
      x.push_back(b);
    }
  for (int i = 0; i < 4000; ++i) {
    y.push_back(u(rng));
    x.push_back(u(rng));
  }
  // Every length up to 20 (the masked tail), then the whole set.
  for (int n = 1; n <= 20; ++n) {
    std::vector<double> out(n);
    VectorAtan2(y.data() + 64, x.data() + 64, out.data(), n);
    for (int i = 0; i < n; ++i) ExpectClose(out[i], std::atan2(y[64 + i], x[64 + i]), "atan2", i);
  }
  std::vector<double> out(y.size());
  VectorAtan2(y.data(), x.data(), out.data(), static_cast<int>(y.size()));
  for (size_t i = 0; i < y.size(); ++i) {
    const double want = std::atan2(y[i], x[i]);
    if (want == 0) {
      // atan2(+-0, +x) = +-0 and atan2(+-0, -x) = +-pi: the sign of a zero result matters.
      EXPECT_EQ(out[i], want) << i;
      EXPECT_EQ(std::signbit(out[i]), std::signbit(want)) << i;
    } else {
      ExpectClose(out[i], want, "atan2", static_cast<int>(i));
    }
  }
  // In place.
  std::vector<double> in_place = y;
  VectorAtan2(in_place.data(), x.data(), in_place.data(), static_cast<int>(y.size()));
  EXPECT_EQ(in_place, out);
}

TEST(VectorMathTest, ExpAsinPowSinCosAreLibms) {
  std::mt19937_64 rng(12);
  std::uniform_real_distribution<double> u(-1, 1);
  constexpr int kN = 1003;
  std::vector<double> x(kN), y(kN), s(kN), c(kN);
  for (double& v : x) v = u(rng);
  VectorExp(x.data(), y.data(), kN);
  for (int i = 0; i < kN; ++i) ExpectClose(y[i], std::exp(x[i]), "exp", i);
  VectorAsin(x.data(), y.data(), kN);
  for (int i = 0; i < kN; ++i) ExpectClose(y[i], std::asin(x[i]), "asin", i);
  VectorSinCos(x.data(), s.data(), c.data(), kN);
  for (int i = 0; i < kN; ++i) {
    ExpectClose(s[i], std::sin(x[i]), "sin", i);
    ExpectClose(c[i], std::cos(x[i]), "cos", i);
  }
  for (double& v : x) v = std::abs(v) * 3;
  VectorPow(x.data(), 2.7, y.data(), kN);
  for (int i = 0; i < kN; ++i) ExpectClose(y[i], std::pow(x[i], 2.7), "pow", i);
}

}  // namespace
}  // namespace shrm::internal
