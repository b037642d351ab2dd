// Irradiance spherical harmonics (l <= 2, 9 coefficients x RGB) in the conventions of the engines
// that consume them, from shrm's radiance SH L_lm; Sloan-style windowing against ringing.
//
// Input: the project's real radiance SH (core/sh/sh.h, Condon-Shortley phase, SH frame x_s = +X,
// y_s = -Z, z_s = +Y of docs/conventions.md), rgb[ShIndex(l, m) * 3 + c] of a degree lmax >= 2
// expansion, e.g. LightingCoefficients(map, 2). Irradiance is E(n) = integral L(w) max(n.w, 0) dw
// (Ramamoorthi & Hanrahan 2001: E_lm = A_l L_lm, A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4).
//
// Every consumer evaluates a quadratic polynomial in its own frame's normal n = (x, y, z). All of
// them order the nine terms alike,
//   P = {1, y, z, x, xy, yz, 3z^2 - 1, xz, x^2 - y^2}            (index i = 0..8),
// i.e. real SH with z as the pole; they differ in the constants baked into the coefficients, in
// the sign of the basis (Condon-Shortley phase or not) and in the frame. Below, k_i are the
// positive SH constants (0.282095, 0.488603 x 3, 1.092548, 1.092548, 0.315392, 1.092548,
// 0.546274), s_i = (+, -, +, -, +, -, +, -, +) the Condon-Shortley signs, A_(l(i)) the band
// factors, L_i / E_i the radiance / irradiance SH coefficient of term i in the consumer's frame
// and basis. docs/ibl_sh9.md has the derivations and how each is tested (tests/sh9_test.cc).
//
// FRAME MAPS. Each consumer frame is the one in which that engine shows OUR lat-long image when
// it imports it the engine's own usual way, so the SH agree with the engine's own background of
// the same file. n_consumer = M d_world, d_world in the project's world frame (right-handed, +Y up,
// lat-long centre at -Z, u = 0.75 at +X):
//  - kFilament: cmgen's default import, which mirrors (cmgen.cpp: "we mirror by default";
//    CubemapUtils::equirectangularToCubemap puts u = 0.5 at +Z, u = 0.75 at +X, then
//    mirrorCubemap flips x): n = (-x, y, -z), a 180 degree turn about +Y (proper).
//  - kGltf, kGltfBabylon: glTF's frame is right-handed +Y up like ours; the EXT_lights_image_based
//    cube faces are written in it: n = (x, y, z) (identity).
//  - kThreeJs: three.js's equirectangular mapping (common.glsl equirectUv: u = atan(z, x) / 2pi +
//    0.5, so u = 0.5 at +X, u = 0.75 at +Z): n = (-z, y, x), a -90 degree turn about +Y. (A
//    CubeTexture of GL faces written in a frame F is shown mirrored, at (-x, y, z) of F.)
//  - kUnity: Unity is left-handed (+Y up, +Z forward); its Skybox/Panoramic shader's lat-long
//    lookup (ToRadialCoords: u = 0.5 - atan2(z, x) / 2pi, so u = 0.5 at +X, u = 0.25 at +Z):
//    n = (-z, y, -x) (improper: the handedness flip). UnityGLTF's mesh convention would be
//    (-x, y, z) instead: pre-rotate the lighting by yaw 90 degrees to get that placement.
//
// CONVENTIONS (coefficient c_i, and what the consumer's shader formula returns):
//  - kFilament: cmgen --sh-shader / sh.txt / IndirectLight::Builder::irradiance(3, sh).
//    c_i = s_i k_i A_l L_i / pi (CubemapSH::computeSH(irradiance) then preprocessSHForShader:
//    "pre-multiply by the A[i] factors ... include the lambertian diffuse BRDF 1/pi").
//    Shader (surface_light_indirect.fs Irradiance_SphericalHarmonics): max(sum c_i P_i(n), 0)
//    = E(n) / pi (multiplied by diffuseColor directly).
//  - kGltf: EXT_lights_image_based "irradianceCoefficients" (9 x 3, [i][rgb]); the extension only
//    says "spherical harmonic coefficients for irradiance up to l=2". We write c_i = E_i, the
//    irradiance SH coefficients (E_lm = A_l L_lm) in the Condon-Shortley basis s_i k_i P_i that
//    Babylon.js's SphericalHarmonics uses (sphericalPolynomial.ts SH3ylmBasisConstants). Babylon's
//    loader (EXT_lights_image_based.ts) then computes h = c * intensity / pi
//    (convertIrradianceToLambertianRadiance) and SphericalPolynomial.FromHarmonics(h), which
//    applies A_l k_i s_i / pi AGAIN: its shader returns sum_i (A_l / pi)^2 L_i s_i k_i P_i —
//    exactly what Babylon computes itself from a cube map (CubeMapToSphericalPolynomialTools
//    applies convertIncidentRadianceToIrradiance, /pi, then FromHarmonics), not E / pi for l >= 1.
//  - kGltfBabylon: the same container with c_i = pi L_i (radiance SH times pi), so that Babylon's
//    loader returns exactly E(n) / pi (the Lambertian outgoing radiance Babylon's PBR expects).
//  - kThreeJs: LightProbe.sh / SphericalHarmonics3 (toArray: [i * 3 + c]). c_i = L_i, radiance SH
//    in three's basis k_i P_i WITHOUT the Condon-Shortley signs (SphericalHarmonics3.getBasisAt;
//    LightProbeGenerator.fromCubeTexture projects radiance with it, normalized to 4 pi).
//    Shader (lights_pars_begin shGetIrradianceAt = SphericalHarmonics3.getIrradianceAt):
//    sum_i A_l k_i c_i P_i = E(n); then RE_IndirectDiffuse multiplies by BRDF_Lambert = albedo/pi.
//  - kUnity: UnityEngine.Rendering.SphericalHarmonicsL2, sh[rgb, i] (Manual "Light Probes:
//    technical information": order L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22; reconstruction
//    of Sloan's "Stupid SH tricks" App. A10 in UnityCG.cginc). c_i = s_i k_i A_l L_i / pi with
//    L_i in the Condon-Shortley basis (the engine's SphericalHarmonicsL2::kNormalizationConstants
//    {1/2 sqrt(1/pi), -1/3 sqrt(3/pi), ..., 1/16 sqrt(15/pi)} as inverted by HDRP's
//    SphericalHarmonicMath.UndoCosineRescaling, "see SetSHEMapConstants() in Stupid SH Tricks";
//    pema99's SHTools says the same: raw coefficients times basis constant / pi) — numerically
//    kFilament's c_i in Unity's frame. SphericalHarmonicMath.PackCoefficients copies it to
//    unity_SHA*/SHB*/SHC as (c3, c1, c2, c0 - c6), (c4, c5, 3 c6, c7), c8 and ShadeSH9 returns
//    dot(SHA, (n, 1)) + dot(SHB, n.xyzz * n.yzzx) + SHC (x^2 - y^2) = E(n) / pi (Unity's
//    Standard shader multiplies it by the diffuse colour).
//
// WINDOWING (Sloan, "Stupid Spherical Harmonics (SH) Tricks", 2008, sec. on windowing; Sloan,
// "Deringing Spherical Harmonics", 2017): the l <= 2 irradiance of a map with a sun rings negative
// on the far side. Multiplying band l by a window h_l (h_0 = 1) trades ringing for blur:
//   Hanning  h_l = (1 + cos(pi l / w)) / 2 for l < w, else 0;
//   Lanczos  h_l = sin(pi l / w) / (pi l / w) for l < w, else 0;
//   Sinc4    h_l = (Lanczos h_l)^4 (cmgen's CubemapSH::sincWindow, --sh-window).
// Larger w blurs less (w -> infinity: no window). `automatic` picks, per map (the three channels
// together), the weakest window of its family — the largest w to 1e-3 by bisection, as cmgen
// does — whose irradiance is non-negative at a dense set of directions (MinIrradianceOnSphere).
#ifndef SHRM_CORE_IBL_SH9_H_
#define SHRM_CORE_IBL_SH9_H_

#include <array>
#include <span>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace shrm::ibl {

inline constexpr int kSh9Terms = 9;
inline constexpr int kSh9Values = 27;

enum class Sh9Convention { kFilament, kGltf, kGltfBabylon, kThreeJs, kUnity };

// "filament", "gltf", "gltf-babylon", "three", "unity"; Parse is case-insensitive and lists the
// valid names in its InvalidArgument error.
const char* Sh9ConventionName(Sh9Convention convention);
absl::StatusOr<Sh9Convention> ParseSh9Convention(std::string_view name);

// Nine RGB coefficients in a consumer's own order P (see the header comment): coeff[i][c].
// glTF irradianceCoefficients, Filament's float3 sh[9] and three's coefficients[i] are this
// layout; Unity's sh[c, i] is its transpose (UnityLayout).
using Sh9Rgb = std::array<std::array<double, 3>, kSh9Terms>;

// The frame map n_consumer = M d_world of the header comment (M orthogonal, det -1 for Unity).
Mat3 ConsumerFrameMatrix(Sh9Convention convention);
Vec3 ConsumerFromWorld(Sh9Convention convention, const Vec3& world_dir);
Vec3 WorldFromConsumer(Sh9Convention convention, const Vec3& consumer_dir);

// The consumer's coefficients from radiance SH `radiance` (rgb[ShIndex(l, m) * 3 + c], size
// ShCount(lmax) * 3, lmax >= 2; bands above 2 are ignored). InvalidArgument for lmax < 2, a wrong
// size or non-finite values.
absl::StatusOr<Sh9Rgb> ConvertRadianceSh9(std::span<const double> radiance, int lmax,
                                          Sh9Convention convention);

// Unity's SphericalHarmonicsL2 order: out[c * 9 + i] = coeff[i][c].
std::array<double, kSh9Values> UnityLayout(const Sh9Rgb& coeff);

// THE CONSUMER'S OWN FORMULA (transcribed from its shader / loader, see the header comment) at a
// unit normal n in the consumer's frame, per channel:
//  kFilament: max(sum c_i P_i(n), 0) (Irradiance_SphericalHarmonics, with its clamp);
//  kGltf, kGltfBabylon: Babylon's EXT_lights_image_based loader (intensity 1) + FromHarmonics
//    with its printed constants (including 0.886277, a typo of pi * 0.282095 = 0.886227) + the
//    polynomial computeEnvironmentIrradiance (no clamp);
//  kThreeJs: shGetIrradianceAt with three's 6-digit constants (no clamp);
//  kUnity: the unity_SH* packing and ShadeSH9's SHEvalLinearL0L1 + SHEvalLinearL2 (no clamp;
//    Unity's ShadeSHPerPixel clamps the sum with the ambient later).
std::array<double, 3> EvalConsumerSh9(Sh9Convention convention, const Sh9Rgb& coeff, const Vec3& n);

// What EvalConsumerSh9 returns in terms of the irradiance E of the input radiance: kThreeJs: E;
// kFilament, kUnity, kGltfBabylon: E / pi; kGltf: Babylon's doubly convolved value (see above).
enum class Sh9Output { kIrradiance, kIrradianceOverPi, kBabylonDoubleConvolution };
Sh9Output ConsumerOutput(Sh9Convention convention);

// ---- Windowing --------------------------------------------------------------------------------

enum class ShWindow { kNone, kHanning, kLanczos, kSinc4 };

// h_l of the header comment for band l >= 0 and width w > 0 (kNone: 1).
double ShWindowFactor(ShWindow window, int l, double width);

// Minimum over the sphere of the l <= 2 irradiance E(n) = sum A_l L_lm Y_lm(n) of `radiance`
// (27 values: rgb[ShIndex(l, m) * 3 + c], l <= 2), per channel: E at `num_directions` Fibonacci
// directions, then a local refinement (shrinking pattern search) around each channel's lowest
// sample. InvalidArgument for a wrong size or num_directions < 16.
absl::StatusOr<std::array<double, 3>> MinIrradianceOnSphere(std::span<const double> radiance,
                                                            int num_directions = 16384);

struct Sh9WindowOptions {
  ShWindow window = ShWindow::kNone;
  // Width w in bands (> 0) for a fixed window; ignored when `automatic`.
  double width = 0;
  // Choose the largest w of `window`'s family (kNone means kHanning) that keeps the irradiance
  // non-negative; no window at all if it already is.
  bool automatic = false;
  // With `automatic`: reproduce cmgen's default --sh-window=auto instead (CubemapSH::windowSH):
  // family kSinc4 whatever `window` says; per channel, bisection on w in [3, 13] while
  // lo + 0.1 < hi (at most 16 steps), lo = 3 taken as valid without a check; the smallest of the
  // three widths is applied, EVEN IF the unwindowed irradiance is already non-negative (then
  // w ~ 12.9: bands 1 and 2 scaled by ~0.96 and ~0.84). Like cmgen, w = 3 itself is not checked
  // (min_after reports the outcome).
  bool cmgen_compatible = false;
  int num_directions = 16384;
};

struct Sh9WindowReport {
  ShWindow window = ShWindow::kNone;
  double width = 0;  // the w applied; 0 when no window was applied
  std::array<double, 3> min_before{}, min_after{};
  // RMS over the sphere of the change of E the window made, relative to the mean of E (per
  // channel; Parseval: sqrt(sum_{l>=1} (1 - h_l)^2 sum_m E_lm^2 / 4pi) / (E_00 Y_00)).
  std::array<double, 3> rms_change_relative{};
};

// Windows the l <= 2 bands of `radiance` (size ShCount(lmax) * 3, lmax >= 2) in place: band l is
// multiplied by h_l; bands above 2 are zeroed when a window is applied (they carry no
// irradiance). kNone and no `automatic` leave `radiance` untouched. Errors: InvalidArgument for
// bad sizes, a non-positive fixed width, or (automatic) a map whose mean irradiance is negative
// in some channel (no window can make it non-negative).
absl::StatusOr<Sh9WindowReport> WindowSh9(std::span<double> radiance, int lmax,
                                          const Sh9WindowOptions& options);

}  // namespace shrm::ibl

#endif  // SHRM_CORE_IBL_SH9_H_
