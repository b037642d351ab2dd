// SH lighting coefficients of an environment map and their exact rotation.
//
// SHRM paper (Ramamoorthi & Hanrahan, "Frequency Space Environment Map Rendering") eqs. 5.20-5.21:
// the lighting L(w) is expanded as L(w) = sum_lm L_lm Y_lm(w) with L_lm = integral L(w) Y_lm(w) dw
// (here in the real SH of core/sh/sh.h, evaluated in the SH frame of docs/conventions.md), one
// coefficient vector per RGB channel, layout coeff[ShIndex(l, m) * 3 + c] (core/transform/sht.h).
//
// How L_lm is computed (docs/envmap.md):
//  - lat-long maps go straight through ForwardSht on their own grid (no resampling), which needs
//    lmax <= ShtMaxDegree(grid) = min(H - 1, (W - 1) / 2);
//  - the other layouts are resampled (bilinear, EnvMap::ToLatLong) to a lat-long grid of width
//    W = max(EnvMap::NativeLatLongWidth(), 2 lmax + 2) rounded up to even (4 S for a cube of face
//    size S, 2 D for a D x D angular map), then ForwardSht;
//  - LightingCoefficientsDirect sums over the native samples instead,
//    L_lm = sum_k L_k Y_lm(d_k) Omega_k: exact for the samples' own quadrature (the brute-force
//    reference), O(N (lmax + 1)^2) for N pixels.
//
// Rotation (`--rotate`): the lighting is rotated ACTIVELY by a world rotation R, i.e. the rotated
// lighting is L_R(w) = L(R^-1 w) (a feature seen in direction d moves to R d). This is exact in
// SH space: R is converted to the SH frame, R_s = M R M^T with M the world -> SH-frame change of
// basis (x_s = X, y_s = -Z, z_s = Y), and every channel is rotated with RotateSh(lmax, R_s).
#ifndef SHRM_CORE_ENVMAP_LIGHTING_H_
#define SHRM_CORE_ENVMAP_LIGHTING_H_

#include <array>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/envmap/envmap.h"
#include "core/transform/sht.h"

namespace shrm {

// World rotation from yaw, pitch, roll in DEGREES: R = Ry(yaw) Rx(pitch) Rz(roll), i.e. roll about
// +Z is applied first, then pitch about +X, then yaw about +Y; active, right-handed (a positive
// angle turns counter-clockwise seen from the tip of the axis). E.g. yaw = 90 moves the +X
// direction to -Z: the lat-long image content shifts left by W/4 (towards smaller u); pitch = 90
// moves +Y (the zenith) to +Z.
Mat3 RotationFromYawPitchRoll(double yaw_deg, double pitch_deg, double roll_deg);

// A world rotation that turns about +Y alone (a yaw: RotationFromYawPitchRoll(y, 0, 0), a
// turntable), as (cos a, sin a) of R = RotationY(a), i.e. (R_00, R_02); nullopt otherwise. The
// test is exact: the vertical row and column must be exactly (0, 1, 0), as RotationY's products
// with exact identities give them. Such a turn is diagonal per m in SH space (RotateLighting) and
// a shift of the lat-long azimuth (core/ibl's base level).
struct Yaw {
  double cos = 1, sin = 0;
};
std::optional<Yaw> YawOf(const Mat3& world_rotation);

// The world -> SH-frame change of basis M (rows x_s = X, y_s = -Z, z_s = Y) and the conversion of
// a world rotation to the SH frame, M R M^T (the rotation RotateSh expects).
Mat3 WorldToShFrameMatrix();
Mat3 ShFrameRotationFromWorld(const Mat3& world_rotation);

// Rotates RGB lighting coefficients (layout coeff[ShIndex(l, m) * 3 + c], (lmax + 1)^2 * 3 values)
// in place so that they describe L(R^-1 w). Errors: InvalidArgument for lmax outside
// [0, kMaxRotationLmax], a wrong size, or a matrix that is not a rotation (core/sh/rotation.h).
absl::Status RotateLighting(int lmax, const Mat3& world_rotation, std::span<double> rgb_coeffs);

// Width of the lat-long grid that LightingCoefficients resamples a non-lat-long map to.
int LightingResampleWidth(const EnvMap& map, int lmax);

// RGB lighting coefficients L_lm up to degree lmax of `map` rotated by `world_rotation` (identity:
// unrotated), (lmax + 1)^2 * 3 values, coeff[ShIndex(l, m) * 3 + c]. Errors: InvalidArgument for
// lmax < 0, num_threads < 1, a lat-long map too small for lmax (ShtMaxDegree), a non-rotation, or
// lmax > kMaxRotationLmax with a non-identity rotation.
// `quadrature` (core/transform/sht.h): kPixelSum gives the projection of the (lat-long or
// resampled) pixels themselves, as LightingCoefficientsDirect does for a lat-long map.
absl::StatusOr<std::vector<double>> LightingCoefficients(
    const EnvMap& map, int lmax, const Mat3& world_rotation = Mat3::Identity(), int num_threads = 1,
    ShtQuadrature quadrature = ShtQuadrature::kExact);

// The same by direct summation over map.samples() (see the header comment), split over
// num_threads threads (the partial sums, and so the last bits, depend on num_threads). Same
// errors, except that any lmax >= 0 is accepted.
absl::StatusOr<std::vector<double>> LightingCoefficientsDirect(
    const EnvMap& map, int lmax, const Mat3& world_rotation = Mat3::Identity(),
    int num_threads = 1);

// Eq. 5.15's integral of L_c^2 over the sphere, per channel, by the map's own sample quadrature
// (its pixels' solid angles): the total the captured fraction of eq. 5.16 is measured against.
// Lat-long maps are summed ring by ring from the image (equal to the sum over samples() up to
// rounding; tests/envmap_test.cc), the other layouts over samples().
std::array<double, 3> LightingEnergy(const EnvMap& map);

}  // namespace shrm

#endif  // SHRM_CORE_ENVMAP_LIGHTING_H_
