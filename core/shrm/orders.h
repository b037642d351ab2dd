// Error analysis of SH expansions: energy captured per band and the order needed for a tolerance.
//
// SHRM paper (Ramamoorthi & Hanrahan, sec. 5.5.1):
//   eq. 5.15: the total energy of L is integral L^2 dw = sum_lm |L_lm|^2;
//   eq. 5.16: an order-F_L expansion has accuracy 1 - epsilon when
//             sum_{l <= F_L} sum_m |L_lm|^2 >= (1 - epsilon) integral L^2 dw,
//   and F_L(epsilon) is the smallest such F. The total energy is integrated on the map's own grid
//   (the quadrature rule of its rings), not summed from a truncated expansion.
#ifndef SHRM_CORE_SHRM_ORDERS_H_
#define SHRM_CORE_SHRM_ORDERS_H_

#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/transform/sht.h"

namespace shrm {

// Energy per band and channel of coefficients laid out as coeff[ShIndex(l, m) * channels + c]:
// result[l * channels + c] = sum_m coeff_lm^2.
std::vector<double> BandEnergies(int lmax, int channels, std::span<const double> coeffs);

// integral L_c^2 dw per channel (eq. 5.15, left side) of a map on `grid`, by the grid's ring
// quadrature (Fejer's first rule or Gauss-Legendre) and the uniform rule in phi.
absl::StatusOr<std::vector<double>> MapEnergy(const ShtGrid& grid, int channels,
                                              std::span<const float> map);

// Eq. 5.16 for one channel: the smallest F <= lmax whose cumulative band energy reaches
// (1 - epsilon) * total, or -1 when even degree lmax does not. epsilon must be in (0, 1).
int OrderForTolerance(std::span<const double> band_energy, double total, double epsilon);

// Accuracy 1 - epsilon of the order-F expansion: cumulative band energy up to F over the total.
double CapturedFraction(std::span<const double> band_energy, double total, int order);

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_ORDERS_H_
