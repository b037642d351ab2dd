#include "core/sh/quadrature.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>

#include "core/base/geometry.h"

namespace shrm {

namespace {

RingQuadrature ComputeFejerFirstRule(int n) {
  RingQuadrature q;
  q.theta.resize(n);
  q.cos_theta.resize(n);
  q.sin_theta.resize(n);
  q.weight.resize(n);
  // Eight rings side by side (each ring's sum its own lane, with the same operations in the same
  // order as one ring alone): the recurrence is a chain of dependent multiply-adds per ring, eight
  // of which now run at once.
  constexpr int kRings = 8;
  for (int j0 = 0; j0 < n; j0 += kRings) {
    const int rings = std::min(kRings, n - j0);
    double t[kRings], c1[kRings], c_prev[kRings], c[kRings], sum[kRings];
    for (int r = 0; r < kRings; ++r) {
      // (Lanes past the last ring repeat it.)
      t[r] = kPi * (j0 + std::min(r, rings - 1) + 0.5) / n;
      c1[r] = std::cos(2.0 * t[r]);
      c_prev[r] = 1.0;
      c[r] = c1[r];
      sum[r] = 0;
    }
    // w_j = (2/n) (1 - 2 sum_{k=1}^{n/2} cos(2 k t) / (4 k^2 - 1))   (Fejer 1933), the cosines
    // by the Chebyshev recurrence cos((k+1) u) = 2 cos(u) cos(k u) - cos((k-1) u), u = 2t: no
    // trigonometric call per term (the rule of a 1024 x 512 map took ~4 ms with them); the
    // recurrence's rounding grows like k eps, under 1e-15 in the weights once divided by 4k^2 - 1
    // (tests/quadrature_test.cc checks them against the direct sum).
    for (int k = 1; k <= n / 2; ++k) {
      const double d = 4.0 * k * k - 1.0;
      for (int r = 0; r < kRings; ++r) {
        sum[r] += c[r] / d;
        // (Where there is a fused multiply-add, the form the compiler gives one ring's loop,
        // spelled out for the lanes: the same weights bit for bit.)
#if defined(__FMA__)
        const double next = std::fma(2.0 * c1[r], c[r], -c_prev[r]);
#else
        const double next = 2.0 * c1[r] * c[r] - c_prev[r];
#endif
        c_prev[r] = c[r];
        c[r] = next;
      }
    }
    for (int r = 0; r < rings; ++r) {
      const int j = j0 + r;
      q.theta[j] = t[r];
      q.cos_theta[j] = std::cos(t[r]);
      q.sin_theta[j] = std::sin(t[r]);
      q.weight[j] = 2.0 / n * (1.0 - 2.0 * sum[r]);
    }
  }
  return q;
}

}  // namespace

RingQuadrature FejerFirstRule(int n) {
  // Each rule computed once per process (O(n^2): 0.3 ms at n = 512, and a job asks for its map's
  // several times: the transform's plan, the light's moments, the check's pixel weights). A few
  // dozen sizes at most in a process; the cache forgets them all past kSizes.
  constexpr size_t kSizes = 64;
  static std::mutex mu;
  static std::map<int, std::shared_ptr<const RingQuadrature>> cache;
  std::shared_ptr<const RingQuadrature> rule;
  {
    std::lock_guard<std::mutex> lock(mu);
    if (auto it = cache.find(n); it != cache.end()) rule = it->second;
  }
  if (rule == nullptr) {
    rule = std::make_shared<const RingQuadrature>(ComputeFejerFirstRule(n));
    std::lock_guard<std::mutex> lock(mu);
    if (cache.size() >= kSizes) cache.clear();
    cache.emplace(n, rule);
  }
  return *rule;
}

namespace {

// P_n(x) and P_{n-1}(x) by Bonnet's recurrence.
void LegendrePair(int n, double x, double* pn, double* pn1) {
  double p0 = 1.0, p1 = x;
  for (int k = 2; k <= n; ++k) {
    const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
    p0 = p1;
    p1 = p2;
  }
  *pn = n == 0 ? 1.0 : p1;
  *pn1 = n <= 1 ? 1.0 : p0;
}

}  // namespace

RingQuadrature GaussLegendreRule(int n) {
  RingQuadrature q;
  q.theta.resize(n);
  q.cos_theta.resize(n);
  q.sin_theta.resize(n);
  q.weight.resize(n);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    // Newton iteration in theta on P_n(cos theta), from Tricomi's estimate. With
    // (1 - x^2) P_n'(x) = n (P_{n-1} - x P_n): dP_n/dtheta = -n (P_{n-1} - x P_n) / sin(theta).
    // Converged when the step stops shrinking: at the rounding level it no longer does, and
    // iterating on (as a fixed threshold of 1e-16 did, to 100 steps for most nodes) only moves
    // the node by an ulp either way. Quadratic convergence takes 3-5 steps.
    double t = kPi * (i + 0.75) / (n + 0.5);
    double last_step = HUGE_VAL;
    for (int iter = 0; iter < 100; ++iter) {
      double pn, pn1;
      LegendrePair(n, std::cos(t), &pn, &pn1);
      const double dt = pn / (-n * (pn1 - std::cos(t) * pn) / std::sin(t));
      if (std::abs(dt) >= last_step) break;
      t -= dt;
      last_step = std::abs(dt);
      if (last_step < 1e-16) break;
    }
    const double x = std::cos(t), s = std::sin(t);
    double pn, pn1;
    LegendrePair(n, x, &pn, &pn1);
    const double dp = n * (pn1 - x * pn) / (s * s);  // P_n'(x)
    const double w = 2.0 / (s * s * dp * dp);        // 2 / ((1 - x^2) P_n'(x)^2)
    const int j = n - 1 - i;                         // mirror node
    q.theta[i] = t;
    q.cos_theta[i] = x;
    q.sin_theta[i] = s;
    q.weight[i] = w;
    q.theta[j] = kPi - t;
    q.cos_theta[j] = -x;
    q.sin_theta[j] = s;
    q.weight[j] = w;
  }
  return q;
}

}  // namespace shrm
