// Per-outgoing-direction BRDF tables: for each view direction w_o of a parabolic map of the upper
// hemisphere, the coefficients over incoming directions w_i of the cosine-weighted BRDF, in real
// SH over the sphere or in hemispherical harmonics (HSH) over the upper hemisphere.
//
// Paper: Gautron, Krivanek, Pattanaik, Bouatouch, "A Novel Hemispherical Basis for Accurate and
// Efficient Rendering" (EGSR 2004):
//  - sec. 5, eqs. 16-17: the BRDF (times the cosine) is tabulated per outgoing direction and
//    projected over the incoming hemisphere, f(w_o, w_i) ~ sum_k c_k(w_o) H_k(w_i);
//  - sec. 6.1: shading = dot product of the lighting coefficients (HSH, or SH converted by C of
//    eq. 18, core/sh/hsh.h) with the BRDF coefficients at the view direction;
//  - Figs. 4-5: HSH against SH at equal coefficient counts (bench/outgoing_brdf_bench.cc,
//    docs/results.md).
// Parabolic map: Heidrich & Seidel 1998 (the upper paraboloid's projection).
//
// Conventions (docs/conventions.md, "Parabolic map and local shading frame"): everything is in
// the local frame with the normal n = +z; the SH are those of core/sh/sh.h evaluated at local
// directions (pole +z, Condon-Shortley phase, index k = l (l + 1) + m), the HSH those of
// core/sh/hsh.h. Integrals are over solid angle.
#ifndef SHRM_CORE_BRDF_OUTGOING_TABLE_H_
#define SHRM_CORE_BRDF_OUTGOING_TABLE_H_

#include <span>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"

namespace shrm {

// The basis over incoming directions: real SH over the whole sphere (g = 0 below the horizon)
// or HSH over the upper hemisphere.
enum class HemisphereBasis { kSh, kHsh };
// "sh" / "hsh".
std::string_view HemisphereBasisName(HemisphereBasis basis);

// Parabolic map of the upper hemisphere (local frame: z = normal): (u, v) in [-1,1]^2 <->
// w = normalize(u, v, (1 - u^2 - v^2) / 2), valid for u^2 + v^2 <= 1 (u^2 + v^2 = 1 is the
// horizon, (0, 0) the normal). Outside the disc the formula is applied as written (z < 0).
// Inverse: (u, v) = (x, y) / (1 + z) for unit w with z > -1; directions below the horizon map
// outside the unit disc (the caller clamps if needed).
Vec3 ParabolicToDirection(double u, double v);
void DirectionToParabolic(const Vec3& w, double* u, double* v);

// Texel (x, y) of a resolution^2 map: its centre (u, v) = (-1 + (x + 0.5) 2 / resolution,
// -1 + (y + 0.5) 2 / resolution); the radius to which centres are clamped before evaluation,
// 1 - 1 / resolution; and the outgoing direction a texel's coefficients are computed for.
void OutgoingTexelCentre(int resolution, int x, int y, double* u, double* v);
double OutgoingTexelRadius(int resolution);
Vec3 OutgoingTexelDirection(int resolution, int x, int y);

struct OutgoingBrdfTableOptions {
  HemisphereBasis basis = HemisphereBasis::kSh;
  // (lmax + 1)^2 coefficients per outgoing direction.
  int lmax = 3;
  // Texels per side of the parabolic map (texel centres at u = -1 + (x + 0.5) * 2 / resolution).
  int resolution = 32;
  // Incoming quadrature (0: chosen from lmax and the BRDF's bandwidth; see below).
  int quad_theta = 0, quad_phi = 0;
  // Worker threads (rows of texels are split between them), >= 1.
  int threads = 1;
};

// Largest accepted lmax and resolution (a table is resolution^2 * channels * (lmax + 1)^2 floats).
inline constexpr int kMaxOutgoingTableLmax = 32;
inline constexpr int kMaxOutgoingTableResolution = 1024;

// For each texel's outgoing direction w_o: the coefficients over incoming directions w_i of
// g(w_i) = brdf.Transfer(n = +z, v = w_o, w = w_i, c) (= f_r cos(theta_i) for ordinary models):
// real SH over the sphere (g = 0 below the horizon) or HSH over the upper hemisphere.
// Texel centres farther than OutgoingTexelRadius = 1 - 1/resolution from the centre of the map
// (the corners outside the disc, and centres within half a texel of the horizon) are evaluated at
// the nearest point of that circle, so bilinear lookups near the horizon neither blend in the
// zeros that models return at N.V = 0 nor sample the grazing singularity of models with a
// 1/sqrt(cos theta_o) or 1/cos theta_o factor (Ward, GGX).
struct OutgoingBrdfTable {
  OutgoingBrdfTableOptions options;  // as given, with quad_theta / quad_phi resolved
  int channels = 1;
  int count = 0;  // (lmax + 1)^2
  // Index ((y * resolution + x) * channels + c) * count + k, k = l(l+1)+m.
  std::vector<float> coeffs;

  // Texel (x, y), channel c: `count` coefficients. Preconditions: 0 <= x, y < resolution,
  // 0 <= c < channels.
  std::span<const float> Texel(int x, int y, int c) const;
  // Bilinear in the parabolic map; w_o in the local frame (z < 0 clamped to the horizon).
  // out.size() must be >= channels * count (checked by assert), out[c * count + k].
  void Lookup(const Vec3& wo, std::span<double> out /* channels * count */) const;
};

// Errors (InvalidArgument, naming the problem): lmax outside [0, kMaxOutgoingTableLmax],
// resolution outside [1, kMaxOutgoingTableResolution], quadrature sizes outside [0, 4096],
// threads < 1, and models reparameterized by the tangent (Kajiya-Kay: Transfer's first argument
// is a tangent, not a normal, so "n = +z" has no meaning).
//
// Incoming quadrature (per texel; the lower hemisphere contributes nothing since g = 0 there, so
// SH and HSH use the same rule), h = brdf.bandwidth_hint().lmax:
//  - quad_theta rings (default max(lmax + 8, h, 24)): Gauss-Legendre in t = sqrt(cos theta_i)
//    on [0, 1], which makes the sqrt(cos theta_i) behaviour of Ward's f_r cos(theta_i) and of the
//    odd-m HSH at the horizon smooth;
//  - azimuths (quad_phi, default max(2 lmax + 2, h, 32)): a trapezoid rule after the Moebius map
//    phi = phi_o + pi + 2 atan(k tan(s / 2)), which grades the nodes towards the mirror azimuth
//    phi_o + pi, where the specular lobes lie and, at grazing views, are narrow in azimuth
//    (width ~ 2 sigma cos(theta_o)). k = clamp(sqrt(2 sigma cos(theta_o) quad_phi / (6 pi)),
//    1/32, 1) with sigma = 3.5 / max(h - 8, 3.5), and quad_phi / k nodes: ~3 nodes across the
//    lobe, never sparser than a uniform quad_phi-node rule elsewhere. (A strong feature away from
//    the mirror azimuth, e.g. a retro-reflective lobe, gets only the uniform resolution.)
// Accuracy with the defaults: ~1e-6 of the texel's largest coefficient (the level of the dense
// midpoint references), also at the most grazing texels (tests/outgoing_table_test.cc,
// docs/brdf.md).
absl::StatusOr<OutgoingBrdfTable> ComputeOutgoingBrdfTable(const Brdf& brdf,
                                                           const OutgoingBrdfTableOptions& options);

// The incoming rule ComputeOutgoingBrdfTable integrates with for outgoing direction wo (local
// frame, unit, z > 0): upper-hemisphere nodes and solid-angle weights (summing to 2 pi). For
// error measurements (bench/outgoing_brdf_bench.cc). Errors: as above, and wo not a unit vector
// above the horizon.
struct IncomingQuadrature {
  std::vector<Vec3> dirs;
  std::vector<double> weights;
};
absl::StatusOr<IncomingQuadrature> OutgoingIncomingQuadrature(
    const Brdf& brdf, const OutgoingBrdfTableOptions& options, const Vec3& wo);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_OUTGOING_TABLE_H_
