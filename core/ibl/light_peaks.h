// The brightest pixels of a map (a sun, lamps), split off so that the frequency-space path
// needs far fewer degrees, and summed directly instead (docs/ibl.md "Peaks summed directly").
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
#ifndef SHRM_CORE_IBL_LIGHT_PEAKS_H_
#define SHRM_CORE_IBL_LIGHT_PEAKS_H_

#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "core/base/geometry.h"
#include "core/envmap/envmap.h"
#include "core/envmap/light_split.h"
#include "core/shrm/radiance_cube.h"

namespace shrm::ibl {

using shrm::LightPeaks;
using shrm::LuminanceRow;
using shrm::PeakSplit;
using shrm::RotatedPeaks;
using shrm::SplitLightPeaks;
using shrm::SumLuminanceRow;

// Adds the peaks' projection, sum_k Y_lm(d_k) (w_k L_k), l <= lmax, to RGB coefficients
// coeffs[ShIndex(l, m) * 3 + c] ((lmax + 1)^2 * 3 values): with the rest's coefficients, the
// whole map's.
void AddPeakCoefficients(const LightPeaks& peaks, int lmax, std::span<double> coeffs);

// A zonal kernel K(r . d) for the direct sums, in e = |r - d|^2 = 2 (1 - r . d) (the form of
// PixelSumTable, which keeps a sharp peak exact in single precision), times `scale` (the caller's
// 1 / integral K dw):
//  - kGgx: (1 - e / 2)+ / (1 + slope e)^2, slope = (1 - alpha^2) / (4 alpha^2): D(cos(theta / 2))
//    cos theta up to the factor 1 / (pi alpha^2), which `scale` carries (the form stays within
//    [0, 1] however sharp the lobe);
//  - kCosine: (1 - e / 2)+ (the Lambert lobe);
//  - kPower: (e / 4)^exponent (1 - e / 2)+ (the Charlie lobe: sin^2(theta_h) = e / 4);
struct PeakKernel {
  enum class Form { kGgx, kCosine, kPower };
  Form form = Form::kCosine;
  double slope = 0;     // kGgx
  double exponent = 0;  // kPower
  double scale = 1;
};
// Adds sum_k kernel(r . d_k) (w_k L_k) to every texel of `cube` (3 channels), r the texel
// centre's direction (CubeTexelDirection); rows of faces split over `threads`. 16 texels of a
// row at a time in single precision (the reciprocal by the AVX-512 estimate, within 2^-14), the
// peaks in groups of nearby directions whose bounding cones skip the runs of texels 90 degrees or
// more away (about half of all pairs; every kernel is 0 there).
void AddPeakSums(const LightPeaks& peaks, const PeakKernel& kernel, RadianceCube& cube,
                 int threads);

}  // namespace shrm::ibl

#endif  // SHRM_CORE_IBL_LIGHT_PEAKS_H_
