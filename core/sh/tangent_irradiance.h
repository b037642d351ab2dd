// Irradiance in a tangent frame, as SH and in the H-basis (irradiance normal mapping).
//
// Paper: Habel & Wimmer, "Efficient Irradiance Normal Mapping" (I3D 2010):
//  - sec. 3: the radiance SH are rotated into the tangent frame of a surface point;
//  - eqs. 5-7: irradiance SH by the clamped-cosine band factors (we use A_l = pi a^l, so the
//    result is the irradiance E itself, not the paper's E / pi: core/sh/hbasis.h);
//  - eq. 14 / App. A: T_h projects tangent-space SH onto the H-basis over the upper hemisphere.
//
// Conventions (docs/conventions.md, "Tangent frames"):
//  - Input radiance SH are world-frame coefficients as everywhere in shrm: real SH evaluated in the
//    SH frame of the world (x_s = +X, y_s = -Z, z_s = +Y, core/sh/sh.h), index k = l (l + 1) + m.
//  - world_from_tangent has columns (t, b, n) in world coordinates: the tangent-space direction
//    d = (x, y, z) is the world direction x t + y b + z n. The output SH / H-basis functions are
//    evaluated at tangent-space directions with the hemisphere pole z = n (core/sh/hsh.h frame).
//  - The frame must be orthonormal (|M^T M - I| <= 1e-6 entrywise). A left-handed frame
//    (t x b = -n, mirrored UVs) is allowed: it is handled exactly as a reflection y -> -y.
#ifndef SHRM_CORE_SH_TANGENT_IRRADIANCE_H_
#define SHRM_CORE_SH_TANGENT_IRRADIANCE_H_

#include <span>

#include "absl/status/status.h"
#include "core/base/geometry.h"

namespace shrm {

// Irradiance in a tangent frame (H-basis paper): world-frame radiance SH (real SH, k = l(l+1)+m,
// at least bands 0..2; bands 0..4 are used for H6 when present) rotated into the frame whose
// columns are (t, b, n) in world coordinates (world_from_tangent), times the clamped-cosine band
// factors (eq. 6; A_l = pi a^l, so the result is E itself, not the paper's E / pi), i.e.
// irradiance E(n_local) as SH in tangent space; then T_h to the H-basis.

// out[ShIndex(l, m)] = A_l * (radiance rotated into tangent space)_lm for l <= lmax, so that
// E(d) = sum_k out[k] Y_k(d) for tangent-space directions d (exact up to the band cut).
// Errors (InvalidArgument): world_radiance_sh.size() not a complete ShCount(L) or L < lmax,
// lmax outside [0, kMaxRotationLmax = 256] (core/sh/rotation.h), out.size() != ShCount(lmax),
// world_from_tangent not orthonormal.
absl::Status TangentIrradianceSh(std::span<const double> world_radiance_sh,
                                 const Mat3& world_from_tangent, int lmax,
                                 std::span<double> out /* (lmax+1)^2 */);

// out[i] = coefficient of H^{i+1}: T_h applied to the tangent-space irradiance SH of bands
// 0..min(L, 4) (band 3 vanishes, A_3 = 0; band 4 has nonzero H2..H4 rows, App. A). This is the
// exact projection onto H_4 / H_6 over the upper hemisphere of the irradiance band-limited to
// degree min(L, 4), for num_h = 4 as well as 6 (H_4 is the first four H_6 functions).
// Errors (InvalidArgument): world_radiance_sh.size() not a complete ShCount(L) with L >= 2,
// num_h not 4 or 6, out.size() != num_h, world_from_tangent not orthonormal.
absl::Status TangentIrradianceH(std::span<const double> world_radiance_sh,
                                const Mat3& world_from_tangent, int num_h /* 4 or 6 */,
                                std::span<double> out /* num_h */);

}  // namespace shrm

#endif  // SHRM_CORE_SH_TANGENT_IRRADIANCE_H_
