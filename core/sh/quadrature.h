// Quadrature rules in theta for SH transforms on latitude-longitude grids.
//
// A ring grid samples theta at H nodes; integral_0^pi f(theta) sin(theta) dtheta is replaced by
// sum_j w_j f(theta_j). Fejer's first rule is exact for every f that is a polynomial of degree
// < H in cos(theta), Gauss-Legendre for degree < 2H. The integrand of an SH coefficient of a
// degree-F band-limited signal, f Y_lm, is a polynomial of degree <= 2F in cos(theta) (after the
// azimuthal integral; odd-m factors of sin(theta) pair up), so plain quadrature is exact on
// Gauss-Legendre rings for F <= H - 1 and on Fejer rings only for F <= (H - 1) / 2; the
// transform (sht.h) resamples pixel-centre rings exactly to reach F <= H - 1 there too.
//  - Fejer's first rule: pixel-centre rings theta_j = pi (j + 1/2) / H, the natural nodes of an
//    equiangular lat-long image. Weights in closed form (Waldvogel 2006; Fejer 1933).
//  - Gauss-Legendre: x_j = cos(theta_j) the roots of P_H, weights 2 / ((1 - x^2) P_H'(x)^2).
#ifndef SHRM_CORE_SH_QUADRATURE_H_
#define SHRM_CORE_SH_QUADRATURE_H_

#include <vector>

namespace shrm {

struct RingQuadrature {
  std::vector<double> theta;      // ring polar angles, increasing (north pole first)
  std::vector<double> cos_theta;  // cos(theta_j)
  std::vector<double> sin_theta;  // sin(theta_j), computed directly (accurate near poles)
  std::vector<double> weight;     // w_j, with sum_j w_j = 2 (the integral of sin over [0, pi])
};

// Fejer's first rule on H pixel-centre rings (H >= 1).
RingQuadrature FejerFirstRule(int num_rings);
// Gauss-Legendre rule with H rings (H >= 1), nodes by Newton iteration on P_H (no tables).
RingQuadrature GaussLegendreRule(int num_rings);

}  // namespace shrm

#endif  // SHRM_CORE_SH_QUADRATURE_H_
