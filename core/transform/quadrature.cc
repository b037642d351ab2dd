#include "core/transform/quadrature.h"

#include <cmath>

#include "core/base/geometry.h"

namespace shrm {

RingQuadrature FejerFirstRule(int n) {
  RingQuadrature q;
  q.theta.resize(n);
  q.cos_theta.resize(n);
  q.sin_theta.resize(n);
  q.weight.resize(n);
  for (int j = 0; j < n; ++j) {
    const double t = kPi * (j + 0.5) / n;
    // w_j = (2/n) (1 - 2 sum_{k=1}^{n/2} cos(2 k t) / (4 k^2 - 1))   (Fejer 1933)
    double sum = 0;
    for (int k = 1; k <= n / 2; ++k) sum += std::cos(2.0 * k * t) / (4.0 * k * k - 1.0);
    q.theta[j] = t;
    q.cos_theta[j] = std::cos(t);
    q.sin_theta[j] = std::sin(t);
    q.weight[j] = 2.0 / n * (1.0 - 2.0 * sum);
  }
  return q;
}

RingQuadrature GaussLegendreRule(int n) {
  RingQuadrature q;
  q.theta.resize(n);
  q.cos_theta.resize(n);
  q.sin_theta.resize(n);
  q.weight.resize(n);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    // Newton iteration in theta on P_n(cos theta), starting from Tricomi's estimate.
    double t = kPi * (i + 0.75) / (n + 0.5);
    double dp = 0;
    for (int iter = 0; iter < 100; ++iter) {
      const double x = std::cos(t);
      double p0 = 1.0, p1 = x;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) p0 = 1.0;
      // dP_n/dtheta = -sin(t) P_n'(x) = n (x P_n - P_{n-1}) / sin(t) * (-1) ... :
      // (1 - x^2) P_n'(x) = n (P_{n-1} - x P_n)  =>  dP_n/dt = -n (P_{n-1} - x P_n) / sin t.
      const double s = std::sin(t);
      const double dpdt = -n * (p0 - x * p1) / s;
      dp = n * (p0 - x * p1) / (s * s);  // P_n'(x)
      const double dt = p1 / dpdt;
      t -= dt;
      if (std::abs(dt) < 1e-16) break;
    }
    const double x = std::cos(t), s = std::sin(t);
    // Recompute P_n'(x) at the converged node for the weight 2 / ((1 - x^2) P_n'(x)^2).
    double p0 = 1.0, p1 = x;
    for (int k = 2; k <= n; ++k) {
      const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
      p0 = p1;
      p1 = p2;
    }
    if (n == 1) p0 = 1.0;
    dp = n * (p0 - x * p1) / (s * s);
    const double w = 2.0 / (s * s * dp * dp);
    const int j = n - 1 - i;  // mirror node
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
