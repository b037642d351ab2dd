// KTX 2.0 container writer (Khronos KTX File Format Specification 2.0, document revision 4+),
// for uncompressed floating-point textures: 2D images, cube maps and cube-map arrays, each with
// an optional mip chain. See docs/ktx2.md.
//
// What is written (section names of the KTX 2.0 specification):
//   - "File Structure": identifier, header, Index, Level Index, Data Format Descriptor,
//     Key/Value Data, no Supercompression Global Data (supercompressionScheme 0, "None"), then
//     the Mip Level Array.
//   - "typeSize": 2 for the 16-bit formats, 4 for the 32-bit ones and for the _PACK32 formats
//     (xx / 8 with xx = 32).
//   - "pixelWidth, pixelHeight, pixelDepth", "layerCount", "faceCount": pixelDepth is always 0;
//     layerCount 0 is "not an array"; cube maps (faceCount 6) must be square.
//   - "levelCount": the number of levels given (>= 1, never 0, at most
//     floor(log2(max(width, height))) + 1); level p is max(1, width >> p) x max(1, height >> p).
//   - "Level Index": levels[0] is the largest level; byteLength == uncompressedByteLength == the
//     level's exact size. "Mip Level Array": levels are stored in the file from the SMALLEST
//     (level levelCount - 1) to the largest, each preceded by "mipPadding" (zeros) so its
//     offset is a multiple of lcm(texel block size, 4). "levelImages": within a level, layers,
//     then faces (+X, -X, +Y, -Y, +Z, -Z, as core/base/cubemap.h), then rows, tightly packed.
//   - "Data Format Descriptor": one Khronos Basic Data Format Descriptor Block (Khronos Data
//     Format Specification 1.4, chapter "The Khronos Data Format Descriptor Block"),
//     versionNumber 2 (1.3+), colorModel KHR_DF_MODEL_RGBSDA, colorPrimaries BT709,
//     transferFunction LINEAR, flags ALPHA_STRAIGHT, texelBlockDimension 0 (1x1x1x1),
//     bytesPlane0 = texel block size, one sample per channel (channel ids R 0, G 1, B 2, A 15).
//     SFLOAT samples: qualifiers FLOAT | SIGNED, sampleLower -1.0f (0xBF800000), sampleUpper 1.0f
//     (0x3F800000). B10G11R11_UFLOAT: qualifier FLOAT, sampleLower 0.0f, sampleUpper 1.0f, R in
//     bits 0..10, G 11..21, B 22..31. E5B9G9R9_UFLOAT (DF spec "Non-standard floating point
//     formats" and the R9G9B9E5 example descriptor): six samples, for each of R, G, B a 9-bit
//     mantissa sample (no qualifier) followed by the shared exponent (bits 27..31, qualifier
//     EXPONENT). The DF spec's prose says the exponent's sampleLower is the bias and its
//     sampleUpper the largest legal exponent, while its example table shows 0 / 15; the values
//     written are those of the Khronos reference implementation (libktx's vk2dfd, which
//     `ktx validate` compares against and libktx's loader requires): mantissa 0 / 8448,
//     exponent 15 / 31.
//   - "Key/Value Data": entries sorted by the bytes of their keys (= Unicode code points for
//     UTF-8), each keyAndValueByteLength, key, NUL, value, NUL, then valuePadding to 4 bytes.
//     Always written: "KTXorientation" = "rd" (row y = 0 is the top row, stored first; the
//     "Cubemap Orientation" appendix requires "rd" for cube maps) and "KTXwriter". Caller keys
//     must not start with "KTX" or "ktx" (reserved by the specification); "shrm:..." keys are
//     the intended use.
//
// Value conversion (every value is checked before any byte is produced; a failure returns an
// error and no bytes):
//   - NaN and +-infinity are rejected in every format.
//   - 16-bit half (SFLOAT): IEEE round to nearest, ties to even, subnormals kept; magnitudes that
//     would round past the largest finite half (65504) are clamped to +-65504 (what engines
//     want for HDR radiance: never an infinity).
//   - B10G11R11_UFLOAT (Vulkan "Unsigned 11-Bit / 10-Bit Floating-Point Numbers", DF spec
//     "Floating-point formats"): round to nearest even, clamped to the largest finite value
//     (65024 for the 11-bit R and G, 64512 for the 10-bit B).
//   - E5B9G9R9_UFLOAT: the Vulkan specification's shared-exponent conversion ("Shared Exponent"
//     in "Fundamentals"): channels clamped to (511/512) * 2^16 = 65408, round half up.
//   - Unsigned formats cannot hold negative values: by default a negative input (other than
//     -0.0, which becomes +0) is an error; EncodeOptions::negatives = kClampToZero clamps them to
//     0 instead (e.g. SH ringing in a radiance cube).
#ifndef SHRM_CORE_EXPORT_KTX2_H_
#define SHRM_CORE_EXPORT_KTX2_H_

#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm::ktx2 {

// The supported formats; the values are the VkFormat enumerants written to the header.
enum class Format : uint32_t {
  kR16G16Sfloat = 83,
  kR16G16B16Sfloat = 90,
  kR16G16B16A16Sfloat = 97,
  kR32G32Sfloat = 103,
  kR32G32B32Sfloat = 106,
  kR32G32B32A32Sfloat = 109,
  kB10G11R11UfloatPack32 = 122,
  kE5B9G9R9UfloatPack32 = 123,
};

// Input channels per texel (R, G[, B[, A]] in that order): 2, 3 or 4. The packed formats take
// 3 (R, G, B).
int ChannelCount(Format format);
// Bytes per texel (the Vulkan texel block size): 4, 6, 8, 12 or 16.
int TexelBlockBytes(Format format);
// The header's typeSize: 2 (16-bit), 4 (32-bit and _PACK32).
int TypeSize(Format format);
// "R16G16B16A16_SFLOAT" etc. (the VkFormat name without VK_FORMAT_), for messages.
std::string_view FormatName(Format format);
// floor(log2(max(width, height))) + 1: the length of a full mip chain (0 for an empty size).
int MaxLevelCount(int width, int height);

struct Level {
  int width = 0;   // must be max(1, image width >> level)
  int height = 0;  // must be max(1, image height >> level)
  // pixels[((((layer * faces + face) * height + y) * width + x) * channels + c], with
  // max(1, layers) layers, `faces` faces, channels = ChannelCount(format); row y = 0 is the
  // first row stored (the top row: KTXorientation "rd").
  std::vector<float> pixels;
  // Instead of `pixels` (left empty): the level's values as RGB triples in the same texel order,
  // read in place (the caller keeps them alive until EncodeKtx2 returns), for a format of three
  // channels or four, whose alpha is then 1. A job's cubes are encoded from their own storage
  // without an RGBA copy of every level.
  std::span<const float> rgb = {};
};

struct Ktx2Image {
  Format format = Format::kR16G16B16A16Sfloat;
  int width = 0;              // level 0
  int height = 0;             // level 0 (a cube map's faces are square: height == width)
  int faces = 1;              // 1, or 6 for a cube map / cube-map array
  int layers = 0;             // 0: not an array; n >= 1: an array of n images (or n cube maps)
  std::vector<Level> levels;  // level 0 (the largest) first
  // Extra Key/Value Data, written as NUL-terminated UTF-8 strings (e.g. "shrm:roughness").
  std::map<std::string, std::string> key_values;
};

enum class Negatives { kReject, kClampToZero };

struct EncodeOptions {
  std::string writer = "shrm";               // the KTXwriter value, e.g. "shrm 0.1.0"
  Negatives negatives = Negatives::kReject;  // for the unsigned (UFLOAT) formats only
};

// The KTX2 file's bytes. InvalidArgument (naming the offending field, level, texel or key) if
// the image or the options break any rule above; nothing is returned then. Callers write the
// bytes with core/io's WriteFileAtomically.
absl::StatusOr<std::string> EncodeKtx2(const Ktx2Image& image, const EncodeOptions& options = {});

// True when `s` is valid UTF-8 (the rule EncodeKtx2 applies to keys and values; readers apply it
// to what they accept, so that what they read can be written again).
bool IsValidUtf8(std::string_view s);

// The value conversions used by EncodeKtx2 (inputs must be finite; see the rules above).
uint16_t FloatToHalf(float value);                  // saturating at +-65504
uint32_t PackB10G11R11(float r, float g, float b);  // negatives become 0
uint32_t PackE5B9G9R9(float r, float g, float b);   // negatives become 0

// Their inverses (Vulkan specification, "Unsigned 11-Bit / 10-Bit Floating-Point Numbers" and
// "Shared Exponent"), and the value a texel reads back as after storage in `format`: what a
// job measures its stored outputs with. `rgb` holds ChannelCount(format) values (up to 4).
float HalfToFloat(uint16_t bits);
void UnpackB10G11R11(uint32_t packed, float rgb[3]);
void UnpackE5B9G9R9(uint32_t packed, float rgb[3]);
void RoundTrip(Format format, float* values);
// RoundTrip of every RGB triple of `rgb` (3 values per texel, the alpha of the RGBA formats being
// 1), the format decided once for the whole span.
void RoundTripRgb(Format format, std::span<float> rgb);
// FloatToHalf and HalfToFloat of whole arrays (out.size() >= in.size()): equal value by value,
// 8 at a time by the processor's F16C conversions where the build has them (round to nearest
// even, as FloatToHalf; a vector holding a value that is not finite or beyond the half range
// takes the scalar path, whose saturation F16C does not do).
void FloatsToHalves(std::span<const float> in, std::span<uint16_t> out);
void HalvesToFloats(std::span<const uint16_t> in, std::span<float> out);

}  // namespace shrm::ktx2

#endif  // SHRM_CORE_EXPORT_KTX2_H_
