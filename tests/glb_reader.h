// A reader of binary glTF and of the PNG images in it, written from the glTF 2.0 specification
// ("Binary glTF Layout": header, chunks, 4-byte alignment; "Buffers and Buffer Views") and the
// PNG specification (chunks, IHDR, zlib IDAT, the five row filters), decoding with zlib only:
// independent of core/export's writers, for tests/gltf_ibl_test.cc and the glTF round-trip fuzz
// harness (fuzz/gltf_roundtrip_fuzzer.cc). Every rule the files must follow is an error here.
#ifndef SHRM_TESTS_GLB_READER_H_
#define SHRM_TESTS_GLB_READER_H_

#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"

namespace shrm::testing {

inline uint32_t GlbU32(const std::string& b, size_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
  return v;
}
inline uint32_t PngU32(const std::string& b, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
  return v;
}

struct Glb {
  nlohmann::json doc;
  std::string bin;
};

// glTF 2.0 "Binary glTF Layout": a 12-byte header (magic, version 2, length), a JSON chunk
// padded to 4 bytes, a BIN chunk padded to 4 bytes, nothing after it.
inline absl::StatusOr<Glb> ReadGlb(const std::string& b) {
  auto bad = [](const std::string& what) { return absl::DataLossError("glb: " + what); };
  if (b.size() < 28) return bad("shorter than a header and two chunk headers");
  if (GlbU32(b, 0) != 0x46546C67u) return bad("magic is not glTF");
  if (GlbU32(b, 4) != 2u) return bad("version is not 2");
  if (GlbU32(b, 8) != b.size()) return bad("length is not the file's size");
  const uint32_t json_len = GlbU32(b, 12);
  if (GlbU32(b, 16) != 0x4E4F534Au) return bad("first chunk is not JSON");
  if (json_len % 4 != 0) return bad("JSON chunk not padded to 4 bytes");
  if (20u + json_len + 8 > b.size()) return bad("JSON chunk runs past the file");
  Glb g;
  g.doc = nlohmann::json::parse(b.substr(20, json_len), nullptr, false);
  if (g.doc.is_discarded() || !g.doc.is_object()) return bad("JSON chunk is not a JSON object");
  const size_t bin_at = 20 + json_len;
  const uint32_t bin_len = GlbU32(b, bin_at);
  if (GlbU32(b, bin_at + 4) != 0x004E4942u) return bad("second chunk is not BIN");
  if (bin_len % 4 != 0) return bad("BIN chunk not padded to 4 bytes");
  if (bin_at + 8 + bin_len != b.size()) return bad("BIN chunk does not end the file");
  g.bin = b.substr(bin_at + 8, bin_len);
  return g;
}

// The bytes of bufferView v: buffer 0, 4-byte aligned, inside the BIN chunk.
inline absl::StatusOr<std::string> GlbViewBytes(const Glb& g, int v) {
  if (!g.doc.contains("bufferViews") || !g.doc["bufferViews"].is_array() || v < 0 ||
      static_cast<size_t>(v) >= g.doc["bufferViews"].size())
    return absl::DataLossError(absl::StrCat("glb: no bufferView ", v));
  const nlohmann::json& view = g.doc["bufferViews"][v];
  if (view.value("buffer", -1) != 0)
    return absl::DataLossError(absl::StrCat("glb: bufferView ", v, " not in buffer 0"));
  const size_t off = view.value("byteOffset", size_t{0}), len = view.value("byteLength", size_t{0});
  if (off % 4 != 0 || off + len > g.bin.size())
    return absl::DataLossError(absl::StrCat("glb: bufferView ", v, " misaligned or outside BIN"));
  return g.bin.substr(off, len);
}

struct Rgba8 {
  int width = 0, height = 0;
  std::vector<uint8_t> px;  // rows from the top, RGBA
};

inline int PngPaeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
}

// PNG: signature, IHDR (8-bit RGBA, not interlaced), IDAT zlib stream, filters 0..4, IEND.
inline absl::StatusOr<Rgba8> ReadPngRgba8(const std::string& b) {
  auto bad = [](const std::string& what) { return absl::DataLossError("png: " + what); };
  if (b.size() < 8 || b.compare(0, 8, std::string("\x89PNG\r\n\x1a\n", 8)) != 0)
    return bad("no PNG signature");
  Rgba8 img;
  std::string idat;
  bool end = false;
  for (size_t at = 8; !end;) {
    if (at + 12 > b.size()) return bad("a chunk runs past the file (no IEND)");
    const uint32_t len = PngU32(b, at);
    if (len > b.size() - at - 12) return bad("a chunk runs past the file");
    const std::string type = b.substr(at + 4, 4);
    const uint32_t crc = PngU32(b, at + 8 + len);
    if (crc != crc32(0, reinterpret_cast<const Bytef*>(b.data() + at + 4), len + 4))
      return bad("chunk " + type + " has a wrong CRC");
    if (type == "IHDR") {
      if (len != 13) return bad("IHDR is not 13 bytes");
      img.width = static_cast<int>(PngU32(b, at + 8));
      img.height = static_cast<int>(PngU32(b, at + 12));
      if (b[at + 16] != 8 || b[at + 17] != 6 || b[at + 20] != 0)
        return bad("not 8-bit RGBA without interlace");
      if (img.width < 1 || img.height < 1 || img.width > 1 << 14 || img.height > 1 << 14)
        return bad("size out of range");
    } else if (type == "IDAT") {
      idat += b.substr(at + 8, len);
    } else if (type == "IEND") {
      end = true;
    }
    at += 12 + len;
    if (end && at != b.size()) return bad("bytes after IEND");
  }
  if (img.width == 0) return bad("no IHDR");
  const size_t stride = static_cast<size_t>(img.width) * 4;
  std::vector<uint8_t> raw((stride + 1) * img.height);
  uLongf raw_len = raw.size();
  if (uncompress(raw.data(), &raw_len, reinterpret_cast<const Bytef*>(idat.data()), idat.size()) !=
          Z_OK ||
      raw_len != raw.size())
    return bad("IDAT does not inflate to the image's size");
  img.px.assign(stride * img.height, 0);
  for (int y = 0; y < img.height; ++y) {
    const int filter = raw[y * (stride + 1)];
    if (filter > 4) return bad("unknown row filter");
    for (size_t x = 0; x < stride; ++x) {
      const int v = raw[y * (stride + 1) + 1 + x];
      const int a = x >= 4 ? img.px[y * stride + x - 4] : 0;
      const int up = y > 0 ? img.px[(y - 1) * stride + x] : 0;
      const int c = x >= 4 && y > 0 ? img.px[(y - 1) * stride + x - 4] : 0;
      const int pred = filter == 0   ? 0
                       : filter == 1 ? a
                       : filter == 2 ? up
                       : filter == 3 ? (a + up) / 2
                                     : PngPaeth(a, up, c);
      img.px[y * stride + x] = static_cast<uint8_t>(v + pred);
    }
  }
  return img;
}

}  // namespace shrm::testing

#endif  // SHRM_TESTS_GLB_READER_H_
