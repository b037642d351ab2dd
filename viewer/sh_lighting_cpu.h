// Mode 3 without GL: low-frequency SH lighting with per-outgoing-direction BRDF coefficients and
// normal mapping, evaluated at one pixel in double precision. The CPU twin of
// viewer/mode_sh_lighting.cc (which takes its tables from here) and the reference of the tests.
//
// Papers:
//  - Krivanek et al., "Fast Approximation to Spherical Harmonic Rotation" (2006), sec. 5.1
//    (Kautz et al. 2002): the lighting L_lm rotated into the local frame of a surface point, BRDF
//    coefficients per outgoing direction looked up by the local view direction, a dot product;
//    sec. 5.2: normal mapping by a per-pixel "1.5th order" Taylor rotation of the lighting between
//    the interpolated frame and the frame of the normal-map normal, and the "simplified" normal
//    mapping that skips that rotation (the normal map only moves the view of the BRDF lookup);
//  - Gautron et al., "A Novel Hemispherical Basis..." (2004), sec. 6.1: with HSH BRDF
//    coefficients the rotated SH lighting is converted by C (eq. 18, core/sh/hsh.h) first.
//
// Per pixel, in the local frame (t, b, n) of the surface point (docs/conventions.md "Local
// shading frames"; the tangent-space normal-map normal m = (sin th cos ph, sin th sin ph, cos th)
// in that frame):
//   L_loc   = D(Q^T) L,  Q = S (t b n)       (exact rotation; S = world -> SH frame)
//   R_p     = Rz(ph) Ry(th) Rz(-ph)           (takes +z to m, no twist about the normal)
//   L_p     = D(R_p^T) L_loc = Zr(ph) Yr(-th) Zr(-ph) L_loc, with Yr(-th) exact (kExact), its
//             1.5th-order Taylor expansion I - th A + th^2/2 diag(A^2) (kTaylor,
//             core/sh/taylor_rotation.h), or L_p = L_loc (kSimplified)
//   v_p     = R_p^T v_loc                     (the view in the perturbed frame)
//   B       = sum_k L_p,k c_k(v_p)            (SH table), or sum_k (C L_p)_k c_k(v_p) (HSH)
// where c_k(v_p) is the bilinear lookup of core's OutgoingBrdfTable (parabolic map). Without a
// normal map m = +z and every variant is the plain algorithm of sec. 5.1.
//
// What B approximates: the integral over the upper hemisphere of the perturbed normal of
// L(w) rho-hat(m, v, w) dw, i.e. brute-force integration with rho-hat cut at the horizon (the
// tables are hemispherical: models without a horizon cut, Phong's eq. 5.26, lose the part of the
// lobe below it). With the SH table the dot product is exact for the lighting truncated to
// degree lmax; what remains is the lighting's truncation and the table's interpolation.
#ifndef SHRM_VIEWER_SH_LIGHTING_CPU_H_
#define SHRM_VIEWER_SH_LIGHTING_CPU_H_

#include <array>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/brdf/outgoing_table.h"
#include "core/sh/hsh.h"
#include "core/sh/taylor_rotation.h"

namespace shrm::viewer {

// Degree of the per-vertex lighting and of the BRDF tables: order n = 5, 25 coefficients, as in
// the rotation paper's sec. 5.3; 25 RGB coefficients (75 floats) fit the 128 vertex-output
// components of Mesa's llvmpipe with room for the other attributes.
inline constexpr int kShLightingLmax = 4;
// Texels per side of the parabolic map of outgoing directions.
inline constexpr int kShLightingTableResolution = 32;

enum class NormalMapping {
  kTaylor,      // per-pixel 1.5th-order Taylor rotation (rotation paper sec. 5.2)
  kSimplified,  // no rotation of the lighting, only the BRDF lookup moves (sec. 5.2, end)
  kExact,       // exact per-pixel rotation (CPU only: the reference of the Taylor variant)
};
std::string_view NormalMappingName(NormalMapping m);  // "taylor", "simplified", "exact"
[[nodiscard]] absl::StatusOr<NormalMapping> ParseNormalMapping(
    std::string_view name);  // taylor | simplified

struct ShLightingOptions {
  HemisphereBasis basis = HemisphereBasis::kSh;
  int light_lmax = kShLightingLmax;  // degree of the lighting in the local frame
  int brdf_lmax = kShLightingLmax;   // degree of the BRDF table (<= light_lmax)
  int resolution = kShLightingTableResolution;
  int threads = 1;  // for the table
};

class ShLightingCpu {
 public:
  // world_sh_rgb: RGB lighting L_lm in the SH frame, layout [ShIndex(l, m) * 3 + c]
  // (core/envmap/lighting.h), any complete degree L (missing bands up to light_lmax count as 0).
  // Errors (InvalidArgument): an incomplete coefficient vector, degrees outside [0, 32] or
  // brdf_lmax > light_lmax, and the table's own errors (e.g. tangent-indexed Kajiya-Kay).
  [[nodiscard]] static absl::StatusOr<ShLightingCpu> Create(std::span<const double> world_sh_rgb,
                                                            const Brdf& brdf,
                                                            const ShLightingOptions& options);

  const ShLightingOptions& options() const { return options_; }
  int light_count() const { return (options_.light_lmax + 1) * (options_.light_lmax + 1); }
  int brdf_count() const { return table_.count; }
  const OutgoingBrdfTable& table() const { return table_; }
  // C of eq. 18 (brdf_lmax x light_lmax), HSH only.
  const std::optional<ShHshConversion>& conversion() const { return conversion_; }
  const TaylorYRotation& taylor() const { return taylor_; }
  // World lighting truncated / padded to light_lmax, [k * 3 + c].
  std::span<const double> world_lighting() const { return world_; }

  // The lighting in the local frame whose columns are (t, b, n) in world coordinates (a
  // mirrored frame, t x b = -n, is the proper (t, -b, n) followed by y -> -y), [k * 3 + c].
  void LocalLighting(const Mat3& world_from_tangent, std::span<double> out) const;
  // B of the header for lighting already in the local frame (light_count() * 3 values), the
  // view in that frame (unit) and the tangent-space normal m (need not be normalized).
  std::array<double, 3> ShadeLocal(std::span<const double> local_rgb, const Vec3& view_local,
                                   const Vec3& tangent_normal, NormalMapping mapping) const;
  // Both steps: world frame (t, b, n) columns, world view direction (unit, towards the viewer).
  std::array<double, 3> Shade(const Mat3& world_from_tangent, const Vec3& view_world,
                              const Vec3& tangent_normal, NormalMapping mapping) const;

 private:
  ShLightingCpu(ShLightingOptions options, OutgoingBrdfTable table, TaylorYRotation taylor)
      : options_(options), table_(std::move(table)), taylor_(std::move(taylor)) {}
  ShLightingOptions options_;
  OutgoingBrdfTable table_;
  TaylorYRotation taylor_;
  std::optional<ShHshConversion> conversion_;
  std::vector<double> world_;
};

// The local frame of a vertex or pixel as the shaders build it from the mesh attributes:
// n = normalize(normal), t = the tangent made orthogonal to n and normalized,
// b = handedness * n x t; columns (t, b, n).
Mat3 TangentFrame(const Vec3& normal, const Vec3& tangent, double handedness);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_SH_LIGHTING_CPU_H_
