#include "core/export/ktx1.h"

#include <cmath>
#include <cstring>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/export/ktx2.h"

namespace shrm::ktx1 {
namespace {

constexpr unsigned char kIdentifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x31,
                                           0x31, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
constexpr uint32_t kEndianness = 0x04030201;
constexpr int kMaxSize = 1 << 15;

struct GlInfo {
  uint32_t type;
  uint32_t type_size;
  uint32_t internal_format;
};

GlInfo Gl(Format f) {
  switch (f) {
    case Format::kRgb16f:
      return {kGlHalfFloat, 2, kGlRgb16f};
    case Format::kRgb32f:
      return {kGlFloat, 4, kGlRgb32f};
    default:
      return {kGlR11fG11fB10f, 4, kGlR11fG11fB10f};
  }
}

void PutU32(std::string* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void PadTo4(std::string* out) {
  while (out->size() % 4 != 0) out->push_back('\0');
}

absl::Status Validate(const Ktx1Cube& cube) {
  if (cube.levels.empty()) return absl::InvalidArgumentError("KTX1: no levels");
  const int base = cube.levels.front().size;
  if (base < 1 || base > kMaxSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("KTX1: face size must be in [1, ", kMaxSize, "], got ", base));
  }
  const int max_levels = static_cast<int>(std::floor(std::log2(base))) + 1;
  if (static_cast<int>(cube.levels.size()) > max_levels) {
    return absl::InvalidArgumentError(absl::StrCat(
        "KTX1: ", cube.levels.size(), " levels, at most ", max_levels, " for ", base, " x ", base));
  }
  for (size_t k = 0; k < cube.levels.size(); ++k) {
    const CubeLevel& l = cube.levels[k];
    const int want = std::max(1, base >> k);
    if (l.size != want) {
      return absl::InvalidArgumentError(
          absl::StrCat("KTX1: level ", k, " has face size ", l.size, ", expected ", want));
    }
    const size_t values = static_cast<size_t>(kCubeFaceCount) * l.size * l.size * 3;
    if (l.pixels.size() != values) {
      return absl::InvalidArgumentError(
          absl::StrCat("KTX1: level ", k, " has ", l.pixels.size(), " values, expected ", values));
    }
    for (size_t i = 0; i < values; ++i) {
      const float v = l.pixels[i];
      if (!std::isfinite(v) || (v < 0 && v != 0)) {
        const size_t texel = i / 3, face_texels = static_cast<size_t>(l.size) * l.size;
        const size_t face = texel / face_texels, in_face = texel % face_texels;
        return absl::InvalidArgumentError(
            absl::StrCat("KTX1: level ", k, " face ", kCubeFaceNames[face], " texel (",
                         in_face % l.size, ", ", in_face / l.size, ") channel ", i % 3, " is ", v,
                         " (unsigned radiance must be finite and >= 0)"));
      }
    }
  }
  for (const auto& [key, value] : cube.key_values) {
    if (key.empty() || absl::StartsWithIgnoreCase(key, "ktx")) {
      return absl::InvalidArgumentError(
          absl::StrCat("KTX1: key \"", key, "\" is empty or reserved (KTX...)"));
    }
    if (key.find('\0') != std::string::npos || value.find('\0') != std::string::npos) {
      return absl::InvalidArgumentError(absl::StrCat("KTX1: key \"", key, "\" holds a NUL"));
    }
  }
  return absl::OkStatus();
}

void PutKeyValue(std::string* out, const std::string& key, const std::string& value) {
  PutU32(out, static_cast<uint32_t>(key.size() + 1 + value.size() + 1));
  out->append(key);
  out->push_back('\0');
  out->append(value);
  out->push_back('\0');
  PadTo4(out);  // the key/value data starts at byte 64, so this is the valuePadding
}

void PutTexel(std::string* out, Format f, const float* rgb) {
  switch (f) {
    case Format::kRgb16f:
      for (int c = 0; c < 3; ++c) {
        const uint16_t h = ktx2::FloatToHalf(rgb[c] == 0 ? 0.0f : rgb[c]);  // -0 -> +0
        out->push_back(static_cast<char>(h & 0xFF));
        out->push_back(static_cast<char>(h >> 8));
      }
      break;
    case Format::kRgb32f:
      for (int c = 0; c < 3; ++c) {
        const float v = rgb[c] == 0 ? 0.0f : rgb[c];
        uint32_t bits;
        std::memcpy(&bits, &v, 4);
        PutU32(out, bits);
      }
      break;
    default:
      PutU32(out, ktx2::PackB10G11R11(rgb[0], rgb[1], rgb[2]));
  }
}

}  // namespace

int TexelBytes(Format format) {
  return format == Format::kRgb16f ? 6 : format == Format::kRgb32f ? 12 : 4;
}

const char* FormatName(Format format) {
  return format == Format::kRgb16f   ? "RGB16F"
         : format == Format::kRgb32f ? "RGB32F"
                                     : "R11F_G11F_B10F";
}

absl::StatusOr<std::string> EncodeKtx1Cube(const Ktx1Cube& cube, const std::string& writer) {
  if (absl::Status s = Validate(cube); !s.ok()) return s;
  std::map<std::string, std::string> kv = cube.key_values;
  kv["KTXorientation"] = "S=r,T=d";
  kv["KTXwriter"] = writer;
  std::string kvd;
  for (const auto& [key, value] : kv) PutKeyValue(&kvd, key, value);

  const GlInfo gl = Gl(cube.format);
  const int base = cube.levels.front().size;
  std::string out(reinterpret_cast<const char*>(kIdentifier), sizeof(kIdentifier));
  PutU32(&out, kEndianness);
  PutU32(&out, gl.type);
  PutU32(&out, gl.type_size);
  PutU32(&out, kGlRgb);  // glFormat
  PutU32(&out, gl.internal_format);
  PutU32(&out, kGlRgb);  // glBaseInternalFormat
  PutU32(&out, static_cast<uint32_t>(base));
  PutU32(&out, static_cast<uint32_t>(base));
  PutU32(&out, 0);  // pixelDepth
  PutU32(&out, 0);  // numberOfArrayElements
  PutU32(&out, kCubeFaceCount);
  PutU32(&out, static_cast<uint32_t>(cube.levels.size()));
  PutU32(&out, static_cast<uint32_t>(kvd.size()));
  out += kvd;
  const int texel_bytes = TexelBytes(cube.format);
  for (const CubeLevel& l : cube.levels) {
    const size_t face_texels = static_cast<size_t>(l.size) * l.size;
    PutU32(&out, static_cast<uint32_t>(face_texels * texel_bytes));  // imageSize: one face
    for (int face = 0; face < kCubeFaceCount; ++face) {
      for (size_t t = 0; t < face_texels; ++t)
        PutTexel(&out, cube.format, &l.pixels[(face * face_texels + t) * 3]);
      PadTo4(&out);  // cubePadding
    }
    PadTo4(&out);  // mipPadding (already aligned by the faces' padding)
  }
  return out;
}

}  // namespace shrm::ktx1
