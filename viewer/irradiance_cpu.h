// Mode 4 without GL: irradiance normal mapping (Habel & Wimmer, "Efficient Irradiance Normal
// Mapping", I3D 2010), evaluated at one pixel in double precision. The CPU twin of
// viewer/mode_irradiance.cc and the reference of its tests.
//
// Per vertex (sec. 3, sec. 5): the world lighting L_lm rotated into the tangent frame (t, b, n),
// irradiance E_lm = A_l L_lm (eqs. 5-7 with A_l = pi a^l: E itself, not E / pi), then
//  - H4 / H6: the H-basis coefficients h = T_h E (eq. 14, App. A; bands 0..4),
//    core/sh/tangent_irradiance.h TangentIrradianceH;
//  - SH9: the SH coefficients of bands 0..2 (the quadratic SH of the paper's comparison),
//    TangentIrradianceSh(lmax 2).
// The coefficients are interpolated over the triangle and evaluated per pixel at the
// normal-map normal m (tangent space): E(m) = sum_i h_i H^i(m) (eq. 15) or sum_k E_k Y_k(m).
// Output radiance of a Lambertian surface: albedo / pi * E(m), with the albedo of a `lambert`
// BRDF (per channel) and 1 for every other model (mode 4 shows irradiance, not the BRDF).
#ifndef SHRM_VIEWER_IRRADIANCE_CPU_H_
#define SHRM_VIEWER_IRRADIANCE_CPU_H_

#include <array>
#include <span>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"

namespace shrm::viewer {

enum class IrradianceBasis { kH4, kH6, kSh9 };
std::string_view IrradianceBasisName(IrradianceBasis b);  // "h4", "h6", "sh9"
[[nodiscard]] absl::StatusOr<IrradianceBasis> ParseIrradianceBasis(std::string_view name);
// 4, 6, 9.
int IrradianceCoefficientCount(IrradianceBasis b);
// The SH degree of the lighting the basis uses: 4 for H4 / H6 (T_h's l = 4 block), 2 for SH9.
int IrradianceLightLmax(IrradianceBasis b);

// Tangent-space irradiance coefficients, RGB, out[i * 3 + c], IrradianceCoefficientCount(b) of
// them, from world lighting [ShIndex(l, m) * 3 + c] of any complete degree >= 2 (bands above
// IrradianceLightLmax are ignored). world_from_tangent: columns (t, b, n), orthonormal, either
// handedness. Errors: those of core/sh/tangent_irradiance.h.
[[nodiscard]] absl::Status TangentIrradianceRgb(std::span<const double> world_sh_rgb,
                                                const Mat3& world_from_tangent, IrradianceBasis b,
                                                std::span<double> out);

// E at the tangent-space normal m (normalized here) from the coefficients above.
std::array<double, 3> EvalTangentIrradiance(IrradianceBasis b, std::span<const double> coeffs_rgb,
                                            const Vec3& tangent_normal);

// Mode 4's albedo: a `lambert` BRDF's albedo per channel (pi rho-hat at normal incidence), 1
// for every other model or none.
std::array<double, 3> IrradianceAlbedo(const Brdf* brdf);

// One pixel: albedo / pi * E(m) with the coefficients of the frame (t, b, n).
[[nodiscard]] absl::StatusOr<std::array<double, 3>> IrradiancePixel(
    std::span<const double> world_sh_rgb, const Mat3& world_from_tangent, IrradianceBasis b,
    const Vec3& tangent_normal, const std::array<double, 3>& albedo);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_IRRADIANCE_CPU_H_
