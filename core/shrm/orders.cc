#include "core/shrm/orders.h"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"

namespace shrm {

std::vector<double> BandEnergies(int lmax, int channels, std::span<const double> coeffs) {
  std::vector<double> e(static_cast<size_t>(lmax + 1) * channels, 0.0);
  for (int l = 0; l <= lmax; ++l)
    for (int m = -l; m <= l; ++m)
      for (int c = 0; c < channels; ++c) {
        const double v = coeffs[static_cast<size_t>(ShIndex(l, m)) * channels + c];
        e[static_cast<size_t>(l) * channels + c] += v * v;
      }
  return e;
}

absl::StatusOr<std::vector<double>> MapEnergy(const ShtGrid& grid, int channels,
                                              std::span<const float> map) {
  if (grid.width < 1 || grid.height < 1 || channels < 1) {
    return absl::InvalidArgumentError(absl::StrCat("MapEnergy: empty grid ", grid.width, " x ",
                                                   grid.height, " or channels ", channels));
  }
  if (map.size() != static_cast<size_t>(grid.width) * grid.height * channels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "MapEnergy: map has ", map.size(),
        " values, expected W * H * channels = ", size_t{1} * grid.width * grid.height * channels));
  }
  const RingQuadrature q = grid.kind == ShtGridKind::kGaussLegendre ? GaussLegendreRule(grid.height)
                                                                    : FejerFirstRule(grid.height);
  std::vector<double> total(channels, 0.0);
  for (int j = 0; j < grid.height; ++j) {
    std::vector<double> ring(channels, 0.0);
    for (int i = 0; i < grid.width; ++i)
      for (int c = 0; c < channels; ++c) {
        const double v = map[(static_cast<size_t>(j) * grid.width + i) * channels + c];
        ring[c] += v * v;
      }
    for (int c = 0; c < channels; ++c) total[c] += q.weight[j] * (2 * kPi / grid.width) * ring[c];
  }
  return total;
}

int OrderForTolerance(std::span<const double> band_energy, double total, double epsilon) {
  double sum = 0;
  for (size_t l = 0; l < band_energy.size(); ++l) {
    sum += band_energy[l];
    if (sum >= (1.0 - epsilon) * total) return static_cast<int>(l);
  }
  return -1;
}

double CapturedFraction(std::span<const double> band_energy, double total, int order) {
  double sum = 0;
  for (int l = 0; l <= order && l < static_cast<int>(band_energy.size()); ++l)
    sum += band_energy[l];
  return total > 0 ? sum / total : 1.0;
}

}  // namespace shrm
