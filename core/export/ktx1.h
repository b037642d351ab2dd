// KTX 1.1 cube-map writer (Khronos "KTX File Format Specification" 1.1), for the files Filament
// loads: cmgen's IBL (`<name>_ibl.ktx`: the prefiltered radiance, one roughness per level, and
// the irradiance SH as the "sh" key) and its skybox (`<name>_skybox.ktx`: one level), read by
// Filament's `Ktx1Bundle` / `Ktx1Reader` (`Engine::createIblFromKtx1`, `createSkyFromKtx1`).
// See docs/ibl.md "KTX1 for Filament".
//
// What is written (section names of the KTX 1.1 specification):
//   - "identifier" (0xAB 'K' 'T' 'X' ' ' '1' '1' 0xBB \r \n 0x1A \n), "endianness" 0x04030201
//     (little endian, the writer's), then the header fields below, all uint32.
//   - glFormat GL_RGB, glBaseInternalFormat GL_RGB and, per format:
//       kRgb16f       glType GL_HALF_FLOAT (0x140B), glTypeSize 2, glInternalFormat GL_RGB16F
//       kRgb32f       glType GL_FLOAT (0x1406), glTypeSize 4, glInternalFormat GL_RGB32F
//       kR11fG11fB10f glType GL_R11F_G11F_B10F (0x8C3A), glTypeSize 4, glInternalFormat
//                     GL_R11F_G11F_B10F (0x8C3A)
//     The packed format's glType is the one deviation from the specification (which would name
//     GL_UNSIGNED_INT_10F_11F_11F_REV, 0x8C3B): it is what cmgen writes and the only value
//     Filament's `Ktx1Reader::toPixelDataType` maps to UINT_10F_11F_11F_REV (any other glType
//     makes Filament upload garbage).
//   - pixelWidth = pixelHeight = the base face size, pixelDepth 0, numberOfArrayElements 0 (not
//     an array), numberOfFaces 6, numberOfMipmapLevels = the levels given (level k is
//     max(1, size >> k)).
//   - "bytesOfKeyValueData" then each pair as keyAndValueByteSize, key, NUL, value, NUL,
//     valuePadding to 4 bytes; pairs in the order of the map (sorted by key). Always written:
//     "KTXorientation" = "S=r,T=d" (row 0 of a face is t = 0, as glTexImage2D uploads it: the
//     OpenGL cube-map convention, core/base/cubemap.h) and "KTXwriter".
//   - per level: imageSize = the bytes of ONE face (the specification's rule for non-array cube
//     maps), then the six faces +X, -X, +Y, -Y, +Z, -Z, rows tightly packed, each face followed
//     by cubePadding to 4 bytes and the level by mipPadding to 4 bytes. (Filament's reader
//     assumes both paddings are 0; they are, except for a 1 x 1 RGB16F face: 6 bytes + 2.)
//
// Values (checked before any byte is produced; a failure returns an error and no bytes): NaN,
// infinities and negatives (other than -0.0) are rejected; half floats saturate at 65504 and the
// packed floats at their largest finite values (core/export/ktx2.h's encoders, the same rules).
#ifndef SHRM_CORE_EXPORT_KTX1_H_
#define SHRM_CORE_EXPORT_KTX1_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm::ktx1 {

enum class Format { kRgb16f, kRgb32f, kR11fG11fB10f };

// The OpenGL enumerants written to the header.
inline constexpr uint32_t kGlHalfFloat = 0x140B;
inline constexpr uint32_t kGlFloat = 0x1406;
inline constexpr uint32_t kGlRgb = 0x1907;
inline constexpr uint32_t kGlRgb16f = 0x881B;
inline constexpr uint32_t kGlRgb32f = 0x8815;
inline constexpr uint32_t kGlR11fG11fB10f = 0x8C3A;

// Bytes per texel: 6, 12, 4.
int TexelBytes(Format format);
// "RGB16F", "RGB32F", "R11F_G11F_B10F".
const char* FormatName(Format format);

struct CubeLevel {
  int size = 0;  // face size, max(1, base size >> level)
  // pixels[((face * size + y) * size + x) * 3 + c], faces +X, -X, +Y, -Y, +Z, -Z; row y = 0 is
  // t = 0 (core/base/cubemap.h).
  std::vector<float> pixels;
};

struct Ktx1Cube {
  Format format = Format::kR11fG11fB10f;
  std::vector<CubeLevel> levels;  // level 0 (the base, the largest) first
  // Extra key/value pairs (UTF-8 strings), e.g. Filament's "sh"; keys must not start with "KTX".
  std::map<std::string, std::string> key_values;
};

// The file's bytes; InvalidArgument naming the level, face, texel or key on any broken rule.
absl::StatusOr<std::string> EncodeKtx1Cube(const Ktx1Cube& cube, const std::string& writer);

}  // namespace shrm::ktx1

#endif  // SHRM_CORE_EXPORT_KTX1_H_
