// The glTF 2.0 output of the split-sum IBL set (docs/ibl.md "glTF"): ONE self-contained binary
// glTF (`ibl.glb`) carrying an image-based light in the vendor extension EXT_lights_image_based
// (KhronosGroup/glTF extensions/2.0/Vendor/EXT_lights_image_based/README.md) and a small scene
// that shows it at once: a row of spheres, one per level of the radiance chain (metallic 1, base
// colour white, the level's roughness up to kMaxSphereRoughness), then a white dielectric sphere
// (roughness kMaxSphereRoughness) for the
// diffuse term, and an orthographic camera looking down -Z at them.
//
// Container: binary glTF (glTF 2.0 spec, "Binary glTF Layout": 12-byte header, a JSON chunk
// padded with spaces, a BIN chunk padded with zeros, both to 4 bytes). The sphere geometry and
// the specular images are bufferViews of the one buffer, the images with mimeType image/png.
// Babylon.js's loader reads the extension's images through its generic `loadImageAsync`
// (EXT_lights_image_based.ts), which takes bufferView images as well as URIs, and the glTF spec
// allows bufferView images everywhere; gltf-validator accepts them (tests/engines_test.sh), so
// no .gltf with base64 data URIs (a third larger) is needed.
//
// The extension's fields (README "Image-Based Light Properties"):
//   - specularImages: N x 6 images, one array of 6 faces per mip (README "Prefiltered Specular
//     Radiance Cubemaps": faces +X, -X, +Y, -Y, +Z, -Z, square, power of two, each level half
//     the previous); every level of the chain is written (N = the chain's levels).
//   - specularImageSize: the face size of level 0.
//   - Images (README "HDR Images"): 4-channel PNGs "assumed to be HDR images packed in RGBD
//     format". The README only says "RGB divided by alpha"; the packing used is Babylon.js's
//     (the extension's authors' engine; helperFunctions.fx toRGBD / fromRGBD, which its loader
//     decodes with): D = floor(min(255 / max(r, g, b), 255)) / 255 (at least 1 / 255),
//     rgb' = (rgb D)^(1/2.2) clamped to [0, 1], each 8-bit; decoded rgb = rgb'^2.2 / D. The
//     per-channel rounding is at most 0.5 / 255 in rgb' (kRgbdRounding); radiance above 255
//     cannot be stored and is clamped (GltfIblFile::clamped counts the texels).
//   - Orientation: the README shows the usual cube-map face figure and adds that "each saved
//     image must be flipped"; what matters is what its consumer samples. Babylon.js (default
//     left-handed scene) places the glTF scene under a root node that maps glTF (x, y, z) to its
//     world (-x, y, z), samples the cube at its world direction, and decodes each PNG through a
//     texture uploaded with flipY, so the image's BOTTOM row becomes the GL face's row t = 0.
//     Hence face f, image row j (0 = top), column i holds the radiance in the glTF direction
//     GltfDirectionOfTexel(f, i, j, size) = Mirror_x(CubeTexelDirection(f, i, size - 1 - j,
//     size)): the GL cube of core/base/cubemap.h in the frame (-x, y, z), stored bottom-up. Both
//     are permutations of texel centres (no resampling). The engine test
//     (tests/engines/babylon_*.mjs) checks this against Babylon with a mirrored negative control.
//   - irradianceCoefficients: 9 x 3, in the same frame as the images (Babylon evaluates them at
//     the same direction it samples the cube with). GltfIrradianceCoefficients makes them from
//     shrm's radiance SH as the literal irradiance E_lm = A_l L_lm in Babylon's Condon-Shortley
//     basis (`gltf` of docs/ibl_sh9.md). Babylon 9.35's loader divides by pi and its default
//     shader path (harmonics, PBRBRDFConfiguration.DEFAULT_USE_SPHERICAL_HARMONICS) evaluates
//     sum (c_i / pi) s_i k_i P_i, which is then E / pi, the physically right diffuse (measured:
//     its harmonics are its polynomial's with band 1 x 1.5 and band 2 x 4, i.e. without the
//     A_l / pi that its legacy polynomial path applies, for which `gltf-babylon` = pi L_lm would
//     be right; with those, the default path went negative on courtyard).
//   - intensity and rotation (unit quaternion x, y, z, w) as given (defaults 1 and identity).
// The glTF frame is right-handed, +Y up, like shrm's world frame (docs/conventions.md); glTF
// directions are shrm world directions.
#ifndef SHRM_CORE_EXPORT_GLTF_IBL_H_
#define SHRM_CORE_EXPORT_GLTF_IBL_H_

#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/ibl/sh9.h"
#include "core/ibl/split_sum.h"

namespace shrm::gltf {

// Largest rounding of one stored RGBD channel in the gamma-encoded value rgb' (8-bit rounding).
inline constexpr double kRgbdRounding = 0.5 / 255;
// The gamma of Babylon's RGBD packing (toGammaSpace / toLinearSpace, LinearEncodePowerApprox).
inline constexpr double kRgbdGamma = 2.2;
// Largest radiance an RGBD texel can hold (rgbdMaxRange: D >= 1 / 255).
inline constexpr double kRgbdMaxValue = 255;

// Sphere geometry of the scene: radius 1 (normals = positions), centres kSphereSpacing apart
// along +X at y = z = 0, the row centred on x = 0; kSphereSegments around, kSphereRings from
// pole to pole (UV sphere with duplicated seam vertices).
inline constexpr double kSphereRadius = 1;
inline constexpr double kSphereSpacing = 2.5;
inline constexpr int kSphereSegments = 48;
inline constexpr int kSphereRings = 24;
// Largest roughnessFactor of the spheres: Babylon.js 9.35 (the extension's main consumer) renders
// a PBR material of roughness exactly 1 black under this light, and near 1 its environment factor
// for a white metal falls to 0.015 at 0.99 (measured in the engine test, SwiftShader): at 0.9 the
// roughest sphere still shows the last level (Babylon's lod 3.6 of 4 for 5 levels of 32).
inline constexpr double kMaxSphereRoughness = 0.9;

struct GltfIblOptions {
  double intensity = 1;
  std::array<double, 4> rotation = {0, 0, 0, 1};  // unit quaternion x, y, z, w
  std::string generator = "shrm";                 // asset.generator
  std::string light_name = "shrm ibl";
};

struct GltfIblFile {
  std::string glb;      // the bytes of ibl.glb
  int64_t clamped = 0;  // texels above kRgbdMaxValue, stored as kRgbdMaxValue
};

// The glTF (= shrm world) direction whose radiance face `face`, image row `row` (0 = top),
// column `column` of a size x size specular image holds (see the orientation note above).
Vec3 GltfDirectionOfTexel(int face, int column, int row, int size);

// irradianceCoefficients (coeff[i][rgb]) from shrm's radiance SH `radiance_sh9` (rgb[ShIndex(l,
// m) * 3 + c], l <= 2, SH frame of docs/conventions.md): the literal E_lm (`gltf`), in the
// images' frame. InvalidArgument for a wrong size or non-finite values.
absl::StatusOr<ibl::Sh9Rgb> GltfIrradianceCoefficients(std::span<const double> radiance_sh9);

// Babylon's RGBD packing of one linear RGB texel (values >= 0; above kRgbdMaxValue clamped) and
// its decoding. `rgbd` are the 4 bytes r', g', b', D.
std::array<uint8_t, 4> EncodeRgbd(const std::array<float, 3>& rgb);
std::array<double, 3> DecodeRgbd(const std::array<uint8_t, 4>& rgbd);

// ibl.glb from the radiance chain (levels with face sizes S, S/2, ..., S a power of two, RGB
// float faces +X, -X, +Y, -Y, +Z, -Z in core/base/cubemap.h's layout, values finite and >= 0) and
// the irradiance coefficients (GltfIrradianceCoefficients). InvalidArgument naming the problem:
// an empty chain, a face size that is not a power of two or not half the previous level's, a
// level whose data is not 6 square faces of that size, NaN/Inf or negative radiance, non-finite
// coefficients, a negative or non-finite intensity, a rotation that is not a unit quaternion.
absl::StatusOr<GltfIblFile> EncodeGltfIbl(const ibl::SpecularChain& chain,
                                          const ibl::Sh9Rgb& irradiance_coefficients,
                                          const GltfIblOptions& options = {});

}  // namespace shrm::gltf

#endif  // SHRM_CORE_EXPORT_GLTF_IBL_H_
