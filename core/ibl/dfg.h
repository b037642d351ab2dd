// The split-sum DFG ("environment BRDF") lookup table, by deterministic quadrature
// (docs/ibl_dfg.md).
//
// Split sum (Karis 2013, "Real Shading in Unreal Engine 4", eq. 4-5): the specular image-based
// light is approximated by (prefiltered radiance) x (directional albedo of the BRDF), and with
// Schlick's Fresnel F = f0 (1 - Fc) + f90 Fc, Fc = (1 - v.h)^5, the albedo splits into two
// tables of (N.V, roughness):
//   A = integral (1 - Fc) D V (n.l) dl        (Karis' "scale", multiplies f0)
//   B = integral Fc D V (n.l) dl              (Karis' "bias", multiplies f90)
//   E = A + B = integral D V (n.l) dl         (the single-scattering albedo with F = 1)
// with D the GGX (Trowbridge-Reitz) distribution of parameter alpha,
//   D(h) = alpha^2 / (pi ((n.h)^2 (alpha^2 - 1) + 1)^2),
// and V the height-correlated Smith visibility (Heitz 2014; Filament documentation "Physically
// Based Rendering in Filament", sec. 4.4.2, V_SmithGGXCorrelated),
//   V = 0.5 / (n.v sqrt((n.l)^2 (1 - alpha^2) + alpha^2) + n.l sqrt((n.v)^2 (1 - alpha^2) +
//   alpha^2)),
// so that D V = D G / (4 n.v n.l) and A f0 + B f90 is the specular albedo.
//
// Filament's multiscatter form (Filament documentation sec. 5.3.4.3 "the DFG term" and sec. 4.7.2
// "energy loss in specular reflectance"; cmgen --ibl-dfg-multiscatter, libs/ibl CubemapIBL.cpp
// DFV_Multiscatter) stores x = B and y = E; the shader forms specular = mix(dfg.xxx, dfg.yyy, f0)
// = (1 - f0) B + f0 E = f0 A + B (f90 = 1), and the multiple-scattering energy compensation
// 1 + f0 (1 / dfg.y - 1) = 1 + f0 (1 / E - 1) (Kulla & Conty 2017; Turquin 2019).
//
// Sheen (Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF"): the "Charlie"
// distribution D_c(h) = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi), integrated as
//   C = integral D_c V_N (n.l) dl,  V_N = 1 / (4 (n.l + n.v - n.l n.v))
// with the Neubelt visibility (Neubelt & Pettineo 2013, "Crafting a Next-Gen Material Pipeline
// for The Order: 1886"; Filament's VisibilityAshikhmin; KHR_materials_sheen's "simpler
// visibility"), which is Filament's DFG blue channel, glTF-IBL-Sampler's / the Khronos sample
// viewer's lut_charlie blue channel and Babylon's environment-BRDF blue channel; and
//   S = integral D_c V_C (n.l) dl,  V_C = 1 / ((1 + L(n.v) + L(n.l)) 4 n.v n.l), clamped to [0, 1]
// with Estevez & Kulla's fitted lambda L (KHR_materials_sheen "Sheen visibility"), the sheen
// albedo E(n.v) of the Khronos sample viewer's lut_sheen_E (albedo scaling).
//
// Axes: column i samples n.v = (i + 0.5) / n; row j samples the roughness coordinate
// y = (j + 0.5 + offset) / n (clamped to 1) in the consumer's row order; with the perceptual axis
// alpha = y^2 (Filament, glTF, Babylon all index by perceptual roughness), with the alpha axis
// alpha = y. Quadrature (deterministic, no random sampling): over the half vector, panels of equal
// width in the log of the lobe's own CDF (GGX: log(1 - u), u = tan^2 / (tan^2 + alpha^2);
// Charlie: log(u), u = sin^(2 + 1/alpha)), so nodes follow the lobe at every roughness; split
// where the horizon (n.l = 0) starts and stops cutting the azimuth circle, graded into those
// ends; Gauss-Legendre in each panel, the periodic midpoint rule (full circle, mapped towards
// phi = pi) or Gauss-Legendre (cut circle) in the azimuth. Accuracy and time: docs/ibl_dfg.md.
#ifndef SHRM_CORE_IBL_DFG_H_
#define SHRM_CORE_IBL_DFG_H_

#include <vector>

#include "absl/status/statusor.h"

namespace shrm::ibl {

// The GGX integrals at one point (alpha = GGX parameter, "linear roughness" in Filament).
struct GgxDfg {
  double scale = 0;                               // A = integral (1 - Fc) D V n.l
  double bias = 0;                                // B = integral Fc D V n.l
  double Energy() const { return scale + bias; }  // E = A + B (F = 1)
};

// n_dot_v in (0, 1], alpha in (0, 1] (alpha below kDfgMinAlpha is raised to it).
GgxDfg IntegrateGgxDfg(double n_dot_v, double alpha);
// C = integral D_charlie V_neubelt n.l.
double IntegrateCharlieNeubelt(double n_dot_v, double alpha);
// S = integral D_charlie V_charlie n.l (V_charlie clamped to [0, 1], as the sample viewer).
double IntegrateSheenAlbedo(double n_dot_v, double alpha);

// Below this alpha the integrals are evaluated at it (the GGX lobe is then narrower than the
// double-precision resolution of the quadrature variable near the mirror direction).
inline constexpr double kDfgMinAlpha = 1e-7;

// Known limits (used by the tests, docs/ibl_dfg.md):
//  - alpha -> 0, n.v not grazing: G -> 1 so A -> 1 - (1 - n.v)^5, B -> (1 - n.v)^5, E -> 1.
double GgxSmoothLimitBias(double n_dot_v);
//  - alpha = 1: D = 1/pi and the height-correlated Smith G2 = 1 / (1 + L(v) + L(l)) with
//    L(w) = (1 - w)/(2 w), so E = 1 - n.v ln(1 + 1/n.v) (= 1 - ln 2 at n.v = 1).
double GgxEnergyAtAlphaOne(double n_dot_v);
//  - n.v = 1: C = (2 + 1/alpha) / (4 2^p (p + 1)(p + 2)), p = 1/(2 alpha) (1/(5 sqrt 2) at 1).
double CharlieNeubeltAtNormalIncidence(double alpha);

// What a LUT channel holds.
enum class DfgChannel {
  kGgxScale,        // A
  kGgxBias,         // B (Filament multiscatter x, Babylon r)
  kGgxEnergy,       // A + B (Filament multiscatter y, Babylon g)
  kCharlieNeubelt,  // C (Filament z, lut_charlie b, Babylon b)
  kSheenAlbedo,     // S (lut_sheen_E r)
  kZero,            // padding
};

// Meaning of the row coordinate y.
enum class RoughnessAxis {
  kPerceptual,  // y = perceptual roughness r, alpha = r^2
  kAlpha,       // y = alpha
};

// Row order of the data as stored (row 0 first in memory).
enum class RowOrder {
  kSmoothFirst,  // row 0 = smallest roughness: GL/Vulkan t = 0 first, PNG top row = roughness 0
  kRoughFirst,   // row 0 = roughness 1
};

struct DfgLutLayout {
  std::vector<DfgChannel> channels;  // 1..4
  RoughnessAxis roughness_axis = RoughnessAxis::kPerceptual;
  RowOrder row_order = RowOrder::kSmoothFirst;
  // Row j (counted from the smooth end) samples y = min(1, (j + 0.5 + offset) / n). 0 = texel
  // centres, what a bilinear lookup at y expects; 1 reproduces cmgen's generator, which samples
  // (j + 1.5) / n (its row coordinate is (h - y + 0.5) / h before the flip to GL order).
  double roughness_texel_offset = 0;
};

// The consumers' layouts (docs/ibl_dfg.md lists the sources read).
enum class DfgConsumer {
  kFilament,               // dfg.inc / cmgen --ibl-dfg-multiscatter --ibl-dfg-cloth: (B, E, C)
  kFilamentCmgenExact,     // as kFilament with cmgen's one-texel roughness shift
  kFilamentSingleScatter,  // cmgen --ibl-dfg without -multiscatter: (A, B, C)
  kGltfLutGgx,             // glTF-IBL-Sampler / sample viewer lut_ggx: (A, B, C), reads .rg
  kGltfLutCharlie,         // lut_charlie: the viewer reads .b = C
  kGltfLutSheenE,          // lut_sheen_E: .r = S
  kBabylon,                // environment BRDF (height-correlated, MS): (B, E, C), RGBD by writers
  kKaris,                  // UE4-style scale/bias: (A, B)
};

DfgLutLayout LayoutFor(DfgConsumer consumer);
const char* DfgConsumerName(DfgConsumer consumer);

// Largest accepted size (a 4096^2 four-channel float table is 256 MB).
inline constexpr int kMaxDfgLutSize = 4096;

struct DfgLut {
  int size = 0;
  int channels = 0;
  DfgLutLayout layout;
  std::vector<float> data;  // [row][col][channel], rows in layout.row_order

  float At(int row, int col, int channel) const {
    return data[(static_cast<size_t>(row) * size + col) * channels + channel];
  }
  // The sample coordinates of a stored row / column.
  double NDotVOfColumn(int col) const { return (col + 0.5) / size; }
  double RoughnessCoordinateOfRow(int row) const;  // y (perceptual or alpha, per the layout)
  double AlphaOfRow(int row) const;
};

// n x n table. InvalidArgument for n < 1 or n > kMaxDfgLutSize, no channels or more than 4, or a
// negative / non-finite offset. threads >= 1 (rows split between threads).
// At n = kPrecomputedDfgSize with the perceptual axis and a roughness texel offset of 0 or 1
// (every consumer's default table), the values come from a table the build computed with this
// same quadrature (core/ibl/tools/dfg_table_gen.cc): bit for bit what the quadrature gives, in
// microseconds instead of a quarter of a second. Other tables are integrated here.
absl::StatusOr<DfgLut> ComputeDfgLut(int size, const DfgLutLayout& layout, int threads = 1);
absl::StatusOr<DfgLut> ComputeDfgLut(int size, DfgConsumer consumer, int threads = 1);
// The quadrature itself, never the precomputed table (the build's generator, the tests).
absl::StatusOr<DfgLut> ComputeDfgLutByQuadrature(int size, const DfgLutLayout& layout,
                                                 int threads = 1);
// The arguments' checks of ComputeDfgLut.
absl::Status ValidateDfgLut(int size, const DfgLutLayout& layout, int threads);

// The precomputed table: size, rows and the quantities stored per (row, column).
inline constexpr int kPrecomputedDfgSize = 128;
// Rows 0..size-1 sample y = (j + 0.5) / size, row `size` samples y = 1 (perceptual axis), so that
// offsets 0 and 1 are both rows of it.
inline constexpr int kPrecomputedDfgRows = kPrecomputedDfgSize + 1;
// Per (row, column), as floats: A, B, E, C, S (DfgChannel kGgxScale .. kSheenAlbedo).
inline constexpr int kPrecomputedDfgValues = 5;

}  // namespace shrm::ibl

#endif  // SHRM_CORE_IBL_DFG_H_
