// The brightest pixels of a map (a sun, lamps), split off so that the frequency-space path
// needs far fewer degrees, and summed directly instead (docs/ibl.md "Peaks summed directly";
// for SHRMs, shipped as directional lights beside the cube: docs/shrm.md "Peak lights").
//
// A sun of 30,000 against a mean of 1 puts almost all of a map's non-constant energy into a few
// pixels, and that energy reaches every SH degree: a sharp lobe then needs a high degree to keep
// its ringing below the tolerance in dark directions, and the roughest lobes (whose horizon kink
// makes g_l decay slowly) need one too. Split as L = rest + peaks, where a pixel of luminance Y
// above the threshold T keeps T / Y of its radiance in `rest` and gives the remainder to the
// peaks, the rest's energy spectrum falls fast (the threshold caps its dynamic range), and the
// peaks' part of a zonal convolution is a short sum per texel,
//   sum_k K(r . d_k) w_k L_k / integral K dw,
// the same sum the pixel-sum reference makes over those pixels, with the normalization the SH
// path uses (g_0 = 1). Nothing is approximated: rest + peaks is the map, pixel for pixel.
#ifndef SHRM_CORE_ENVMAP_LIGHT_SPLIT_H_
#define SHRM_CORE_ENVMAP_LIGHT_SPLIT_H_

#include <cstddef>
#include <optional>
#include <vector>

#include "core/base/geometry.h"
#include "core/envmap/envmap.h"

namespace shrm {

// The split-off parts of a map's brightest pixels: world directions (after the light's
// rotation), and their radiance times the pixel's weight under the forward transform's own
// quadrature (the Fejer-1 rule, (2 pi / W) w_j for ring j: what the pixel would have added to
// each L_lm), in single precision (x, y, z, r, g, b each of size()).
struct LightPeaks {
  std::vector<float> x, y, z, r, g, b;
  double threshold = 0;  // the luminance T above which pixels were split (0: none)
  size_t size() const { return x.size(); }
  bool empty() const { return x.empty(); }
};

// A row of RGB pixels' luminance (Rec. 709) summed, squared and summed, and its largest value,
// by four partial sums (independent chains of additions): the pass over a map's pixels that
// SplitLightPeaks and MapLightMoments (split_sum.h) make.
struct LuminanceRow {
  double sum = 0, sum_sq = 0, max = 0;
};
LuminanceRow SumLuminanceRow(const float* rgb, int width);

// The split's rules. A pixel is split when its luminance exceeds kPeakRatio times the map's
// mean luminance (over the sphere), at most kMaxPeaks pixels (the threshold rises to the
// (kMaxPeaks + 1)-th largest luminance when more exceed it): the direct sums cost texels x
// peaks. And only when it pays: when the split leaves the rest at most kPeakSpreadShare of the
// map's non-constant luminance energy (sum Y^2 w - E_0), the energy that drives the degrees.
// Measured (1% tolerance, Filament chain from 256, the sharpest level's degree): city 278 -> 158
// (29 pixels above 32 x its mean, keeping 0.02% of the energy), interior 278 -> 203 (128 pixels,
// 0.05%), forest 225 -> 199 (128 pixels, 11%); courtyard (no sun, its brightest pixels 98 x the
// mean) would keep 99% and is not split.
inline constexpr double kPeakRatio = 32;
inline constexpr int kMaxPeaks = 128;
inline constexpr double kPeakSpreadShare = 0.5;

struct PeakSplit {
  // The map without its peaks (a lat-long map of the same size); empty when nothing is split,
  // the map itself then stands for it.
  std::optional<EnvMap> rest;
  LightPeaks peaks;  // unrotated (world directions of the map's own frame)
  // The luminance moments of what the light is computed from (the rest, else the map) under the
  // transform's Fejer-1 quadrature, sum Y w and sum Y^2 w, found on the way (the rest's as the
  // map's less the split parts): what MapLightMoments (split_sum.h) sums, one pass over the
  // pixels fewer. Known for lat-long maps.
  bool moments_known = false;
  double sum_y = 0, sum_y2 = 0;
  // The share of the map's non-constant luminance energy the candidate split leaves in the rest
  // (whether or not it was made; 1 when no pixel is a candidate, or the map is not lat-long).
  double rest_share = 1;
};
// Splits a lat-long map by the rules above (other layouts, and maps whose split would not pay,
// give no split). `max_rest_share` replaces kPeakSpreadShare: the split is made only when the
// rest keeps at most this share of the map's non-constant luminance energy.
PeakSplit SplitLightPeaks(const EnvMap& map, double max_rest_share = kPeakSpreadShare);

// The peaks of the lighting rotated actively by `rotation` (directions d -> R d, as
// RotateLighting turns the coefficients).
LightPeaks RotatedPeaks(const LightPeaks& peaks, const Mat3& rotation);

}  // namespace shrm

#endif  // SHRM_CORE_ENVMAP_LIGHT_SPLIT_H_
