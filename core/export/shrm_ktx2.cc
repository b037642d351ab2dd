#include "core/export/shrm_ktx2.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_shader_params.h"
#include "core/export/ktx2.h"
#include "core/sh/sh.h"
#include "shrm/version.h"

namespace shrm {
namespace {

constexpr unsigned char kIdentifier[12] = {0xAB, 'K',  'T',  'X',  ' ',  '2',
                                           '0',  0xBB, '\r', '\n', 0x1A, '\n'};
constexpr int kChannels = 4;  // RGBA: A unused (0)

// The KTX2-specific statements (they replace the EXR container's face order).
const std::map<std::string, std::string>& Ktx2LayoutAttributes() {
  static const auto* attrs = new std::map<std::string, std::string>{
      {"shrm:face_order",
       "KTX2 cube-map array: faces +X -X +Y -Y +Z -Z, GL major-axis table, row 0 = t 0 "
       "(KTXorientation rd)"},
      {"shrm:layout",
       "layer k = SH coefficient k = p(p+1)+q, k < (pmax+1)^2; RGB = the channel's coefficient, "
       "A unused (0); as a 2D array texture, layer 6k+face"},
  };
  return *attrs;
}

// Little-endian reads inside `bytes`, every access bounds-checked by the caller's Need().
uint32_t U32(std::string_view b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
uint64_t U64(std::string_view b, size_t at) {
  uint64_t v;
  std::memcpy(&v, b.data() + at, 8);
  return v;
}

}  // namespace

bool IsKtx2(std::string_view bytes) {
  return bytes.size() >= sizeof(kIdentifier) &&
         std::memcmp(bytes.data(), kIdentifier, sizeof(kIdentifier)) == 0;
}

std::vector<float> ShrmCoefficientLayers(const ShrmCube& cube) {
  const int s = cube.face_size, n = cube.coeff_count(), ch = cube.channels;
  std::vector<float> out(static_cast<size_t>(6) * s * s * n * kChannels, 0.0f);
  for (int k = 0; k < n; ++k)
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < s; ++y)
        for (int x = 0; x < s; ++x)
          for (int c = 0; c < std::min(ch, 3); ++c)
            out[(((static_cast<size_t>(k) * 6 + f) * s + y) * s + x) * kChannels + c] =
                cube.data[cube.Index(f, x, y, k, c)];
  return out;
}

absl::StatusOr<std::string> EncodeShrmKtx2(const std::string& label, const ShrmCube& cube,
                                           const std::map<std::string, std::string>& extra,
                                           bool half) {
  if (cube.face_size < 1 || cube.pmax < 0 || cube.channels != 3 ||
      cube.data.size() != cube.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat(label, ": inconsistent SHRM cube (face size ", cube.face_size, ", P ",
                     cube.pmax, ", channels ", cube.channels, ", ", cube.data.size(), " values)"));
  }
  std::string light_model;
  if (!cube.lights.empty()) {
    // The shipped shaders sum the lights with their own copy of the BRDF (shrm_lights.glsl): the
    // key "shrm:light_model" holds its model and parameters. A BRDF they cannot evaluate is
    // refused rather than written as a file they would render without its lights.
    auto it = extra.find("shrm:brdf");
    SHRM_ASSIGN_OR_RETURN(
        const BrdfShaderParams params,
        PeakLightShaderParams(label, it == extra.end() ? std::string() : it->second,
                              cube.lights.size(), "write the KTX2 of a job without --peak-lights"));
    light_model = FormatBrdfShaderParams(params);
  }
  ktx2::Ktx2Image image;
  image.format = half ? ktx2::Format::kR16G16B16A16Sfloat : ktx2::Format::kR32G32B32A32Sfloat;
  image.width = image.height = cube.face_size;
  image.faces = 6;
  image.layers = cube.coeff_count();
  image.levels.push_back({cube.face_size, cube.face_size, ShrmCoefficientLayers(cube)});
  for (const auto& [k, v] : extra) {
    if (!absl::StartsWith(k, "shrm:")) {
      return absl::InvalidArgumentError(absl::StrCat("SHRM attribute ", k, " lacks shrm: prefix"));
    }
    image.key_values[k] = v;
  }
  for (auto& [k, v] : ShrmConventionAttributes(cube)) image.key_values[k] = std::move(v);
  for (const auto& [k, v] : Ktx2LayoutAttributes()) image.key_values[k] = v;
  if (!light_model.empty()) image.key_values["shrm:light_model"] = light_model;
  absl::StatusOr<std::string> bytes =
      ktx2::EncodeKtx2(image, {.writer = absl::StrCat("shrm ", kVersion)});
  if (!bytes.ok())
    return absl::InvalidArgumentError(absl::StrCat(label, ": ", bytes.status().message()));
  return bytes;
}

absl::StatusOr<ShrmFile> DecodeShrmKtx2(const std::string& label, std::string_view b,
                                        const ImageLimits& limits) {
  auto bad = [&](auto&&... what) {
    return absl::InvalidArgumentError(absl::StrCat(label, ": ", what...));
  };
  auto need = [&](uint64_t offset, uint64_t length) {
    return offset <= b.size() && length <= b.size() - offset;
  };
  if (!IsKtx2(b)) return bad("not a KTX 2.0 file (identifier missing)");
  constexpr size_t kHeader = 12 + 9 * 4, kIndex = kHeader + 4 * 4 + 2 * 8, kLevelIndex = 24;
  if (!need(0, kIndex + kLevelIndex)) return bad("truncated KTX2 header (", b.size(), " bytes)");
  const uint32_t vk_format = U32(b, 12), type_size = U32(b, 16), width = U32(b, 20),
                 height = U32(b, 24), depth = U32(b, 28), layers = U32(b, 32), faces = U32(b, 36),
                 levels = U32(b, 40), scheme = U32(b, 44);
  ktx2::Format format;
  if (vk_format == static_cast<uint32_t>(ktx2::Format::kR32G32B32A32Sfloat)) {
    format = ktx2::Format::kR32G32B32A32Sfloat;
  } else if (vk_format == static_cast<uint32_t>(ktx2::Format::kR16G16B16A16Sfloat)) {
    format = ktx2::Format::kR16G16B16A16Sfloat;
  } else {
    return bad("vkFormat ", vk_format,
               " is not an SHRM format (R32G32B32A32_SFLOAT 109 or R16G16B16A16_SFLOAT 97)");
  }
  if (type_size != static_cast<uint32_t>(ktx2::TypeSize(format)))
    return bad("typeSize ", type_size, " does not match vkFormat ", vk_format);
  if (faces != 6) return bad("faceCount ", faces, ": an SHRM is a cube-map array (6)");
  if (width < 1 || width != height || depth != 0)
    return bad("an SHRM's faces are square 2D images, got ", width, " x ", height, " x ", depth);
  if (static_cast<int64_t>(width) > limits.max_width ||
      int64_t{6} * width * width > limits.max_pixels)
    return bad("face size ", width, " exceeds the limits (", limits.max_width, " per side, ",
               limits.max_pixels, " texels)");
  if (levels != 1) return bad("levelCount ", levels, ": an SHRM has exactly one level");
  if (scheme != 0) return bad("supercompressionScheme ", scheme, " (only 0, none, is read)");
  const uint32_t kvd_offset = U32(b, kHeader + 8), kvd_length = U32(b, kHeader + 12);
  const uint64_t level_offset = U64(b, kIndex), level_length = U64(b, kIndex + 8),
                 level_uncompressed = U64(b, kIndex + 16);
  if (!need(kvd_offset, kvd_length)) return bad("Key/Value Data lies outside the file");

  // Key/Value Data: keyAndValueByteLength, key NUL value, padding to 4.
  std::map<std::string, std::string> attributes;
  for (uint64_t at = kvd_offset; at + 4 <= uint64_t{kvd_offset} + kvd_length;) {
    const uint32_t len = U32(b, at);
    if (len > uint64_t{kvd_offset} + kvd_length - at - 4)
      return bad("Key/Value entry at byte ", at, " runs past the Key/Value Data");
    const std::string_view entry = b.substr(at + 4, len);
    const size_t nul = entry.find('\0');
    if (nul == std::string_view::npos) return bad("Key/Value entry at byte ", at, " has no NUL");
    std::string_view value = entry.substr(nul + 1);
    if (!value.empty() && value.back() == '\0') value.remove_suffix(1);
    const std::string key(entry.substr(0, nul));
    if (absl::StartsWith(key, "shrm:")) {
      // The KTX 2.0 rule for Key/Value Data (UTF-8, NUL-terminated): what is read can be written.
      if (value.find('\0') != std::string_view::npos || !ktx2::IsValidUtf8(key) ||
          !ktx2::IsValidUtf8(value))
        return bad("Key/Value entry ", key, " at byte ", at, " is not NUL-free UTF-8");
      attributes[key] = std::string(value);
    }
    at += 4 + (uint64_t{len} + 3) / 4 * 4;
  }
  ShrmFile file;
  ShrmCube& cube = file.cube;
  SHRM_RETURN_IF_ERROR(ParseShrmConventionAttributes(label, attributes, &cube));
  if (layers != static_cast<uint32_t>(cube.coeff_count()))
    return bad("layerCount ", layers, " does not match shrm:pmax ", cube.pmax, " (",
               cube.coeff_count(), " coefficient layers)");
  cube.face_size = static_cast<int>(width);
  cube.channels = 3;
  const int texel_bytes = ktx2::TexelBlockBytes(format);
  const uint64_t expected = uint64_t{layers} * 6 * width * width * texel_bytes;
  if (level_length != expected || level_uncompressed != expected)
    return bad("level 0 holds ", level_length, " bytes, expected ", expected);
  if (!need(level_offset, level_length)) return bad("level 0 lies outside the file");
  if (level_offset % 16 != 0 && level_offset % static_cast<uint64_t>(texel_bytes) != 0)
    return bad("level 0 offset ", level_offset, " is not aligned to its texel size");

  cube.data.resize(cube.size());
  const int n = cube.coeff_count(), s = cube.face_size;
  const char* level = b.data() + level_offset;
  for (int k = 0; k < n; ++k)
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < s; ++y)
        for (int x = 0; x < s; ++x) {
          const size_t texel = ((static_cast<size_t>(k) * 6 + f) * s + y) * s + x;
          for (int c = 0; c < 3; ++c) {
            float v;
            if (format == ktx2::Format::kR32G32B32A32Sfloat) {
              std::memcpy(&v, level + texel * 16 + c * 4, 4);
            } else {
              uint16_t h;
              std::memcpy(&h, level + texel * 8 + c * 2, 2);
              v = ktx2::HalfToFloat(h);
            }
            if (!std::isfinite(v))
              return bad("coefficient ", k, " of face ", f, " texel (", x, ", ", y,
                         ") is not finite");
            cube.data[cube.Index(f, x, y, k, c)] = v;
          }
        }
  file.attributes = std::move(attributes);
  return file;
}

absl::StatusOr<ShrmFile> ReadShrm(const std::string& path, const ImageLimits& limits) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open file"));
  char head[sizeof(kIdentifier)] = {};
  in.read(head, sizeof(head));
  if (!IsKtx2(std::string_view(head, static_cast<size_t>(in.gcount()))))
    return ReadShrmFile(path, limits);
  std::error_code ec;
  const uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return absl::NotFoundError(absl::StrCat(path, ": ", ec.message()));
  if (size > static_cast<uintmax_t>(limits.max_file_bytes))
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": ", size, " bytes exceed the limit of ", limits.max_file_bytes));
  std::string bytes(size, '\0');
  in.seekg(0);
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<uintmax_t>(in.gcount()) != size)
    return absl::DataLossError(absl::StrCat(path, ": short read"));
  return DecodeShrmKtx2(path, bytes, limits);
}

}  // namespace shrm
