// Round trip of the engine containers' writers (core/export): random valid parameters ->
// EncodeKtx2 / EncodeKtx1Cube -> bytes -> parsed back by the small, independent readers below
// (written from the KTX 2.0 and KTX 1.1 specifications, not from the writers) -> every header
// field, index entry, padding, key/value pair and texel checked against what went in.
//
// Input (FuzzedDataProvider): byte 0 bit 0 chooses KTX2 or KTX1; then the format, sizes, level
// count, layers, keys and the texel values.
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "core/export/ktx1.h"
#include "core/export/ktx2.h"
#include "fuzz/fuzz_util.h"

namespace {

using shrm::fuzz::Check;

// Little-endian reads with bounds checks (a read past the end is a finding).
struct Reader {
  const std::string& bytes;
  uint32_t U32(size_t at) const {
    Check(at + 4 <= bytes.size(), "u32 inside the file");
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(bytes[at + i]);
    return v;
  }
  uint64_t U64(size_t at) const { return U32(at) | (uint64_t{U32(at + 4)} << 32); }
  uint16_t U16(size_t at) const {
    Check(at + 2 <= bytes.size(), "u16 inside the file");
    return static_cast<uint16_t>(static_cast<uint8_t>(bytes[at]) |
                                 (static_cast<uint8_t>(bytes[at + 1]) << 8));
  }
};

// IEEE half -> float (independent of ktx2::HalfToFloat).
float DecodeHalf(uint16_t h) {
  const int sign = h >> 15, exp = (h >> 10) & 31, man = h & 1023;
  float v = exp == 0 ? std::ldexp(static_cast<float>(man), -24)
                     : std::ldexp(static_cast<float>(man | 1024), exp - 25);
  Check(exp != 31, "no half infinity or NaN is written");
  return sign ? -v : v;
}

// Small unsigned float with `mbits` mantissa bits and a 5-bit exponent (B10G11R11).
float DecodeUfloat(uint32_t bits, int mbits) {
  const uint32_t exp = bits >> mbits, man = bits & ((1u << mbits) - 1);
  Check(exp != 31, "no packed infinity or NaN is written");
  return exp == 0 ? std::ldexp(static_cast<float>(man), -14 - mbits)
                  : std::ldexp(static_cast<float>(man | (1u << mbits)),
                               static_cast<int>(exp) - 15 - mbits);
}

// The stored value of texel channel `c` against the input `x` (already clamped as the format
// must): 32-bit floats exactly, the others within their rounding (relative to `scale`, the
// largest channel for the shared exponent).
void CheckValue(float stored, float x, double rel, float scale) {
  const double tol = rel * std::max(std::abs(static_cast<double>(scale)), 6.2e-5) + 1e-30;
  Check(std::abs(static_cast<double>(stored) - x) <= tol, "a texel reads back within rounding");
}

// A half float against its input (saturating at 65504, rounded to 11 significant bits).
void CheckHalf(uint16_t stored, float x) {
  const float clamped = std::clamp(x, -65504.0f, 65504.0f);
  CheckValue(DecodeHalf(stored), clamped, 1.0 / 2048, clamped);
}

// A B10G11R11 texel against its (non-negative) inputs: 6/6/5 mantissa bits, clamped.
void CheckB10G11R11(uint32_t w, const float* x) {
  const float rgb[3] = {DecodeUfloat(w & 0x7FF, 6), DecodeUfloat((w >> 11) & 0x7FF, 6),
                        DecodeUfloat(w >> 22, 5)};
  const float maxv[3] = {65024, 65024, 64512};
  for (int c = 0; c < 3; ++c) {
    const float clamped = std::min(x[c], maxv[c]);
    CheckValue(rgb[c], clamped, c < 2 ? 1.0 / 64 : 1.0 / 32, clamped);
  }
}

struct FormatInfo {
  shrm::ktx2::Format format;
  int channels, block, type_size;
  bool ufloat;
};
constexpr FormatInfo kKtx2Formats[] = {
    {shrm::ktx2::Format::kR16G16Sfloat, 2, 4, 2, false},
    {shrm::ktx2::Format::kR16G16B16Sfloat, 3, 6, 2, false},
    {shrm::ktx2::Format::kR16G16B16A16Sfloat, 4, 8, 2, false},
    {shrm::ktx2::Format::kR32G32Sfloat, 2, 8, 4, false},
    {shrm::ktx2::Format::kR32G32B32Sfloat, 3, 12, 4, false},
    {shrm::ktx2::Format::kR32G32B32A32Sfloat, 4, 16, 4, false},
    {shrm::ktx2::Format::kB10G11R11UfloatPack32, 3, 4, 4, true},
    {shrm::ktx2::Format::kE5B9G9R9UfloatPack32, 3, 4, 4, true},
};

float Value(FuzzedDataProvider* fdp, bool non_negative) {
  float v;
  switch (fdp->ConsumeIntegralInRange(0, 3)) {
    case 0:
      v = fdp->ConsumeFloatingPointInRange(-2.0f, 2.0f);
      break;
    case 1:
      v = fdp->ConsumeFloatingPointInRange(-1e5f, 1e5f);
      break;
    case 2:
      v = std::ldexp(1.0f, fdp->ConsumeIntegralInRange(-30, 20));
      break;
    default:
      v = fdp->ConsumeFloatingPoint<float>();
      if (!std::isfinite(v)) v = 0;
  }
  return non_negative ? std::abs(v) : v;
}

std::map<std::string, std::string> Keys(FuzzedDataProvider* fdp, const char* prefix) {
  std::map<std::string, std::string> kv;
  const int n = fdp->ConsumeIntegralInRange(0, 3);
  for (int i = 0; i < n; ++i) {
    std::string key = prefix + std::to_string(fdp->ConsumeIntegralInRange(0, 99));
    std::string value;
    const int len = fdp->ConsumeIntegralInRange(0, 40);
    for (int j = 0; j < len; ++j) value += static_cast<char>(fdp->ConsumeIntegralInRange(32, 126));
    kv[key] = value;
  }
  return kv;
}

// Key/Value Data: keyAndValueByteLength, key NUL value NUL, padding to 4. KTX2 entries are
// sorted by key bytes.
std::map<std::string, std::string> ParseKeyValues(const std::string& f, size_t at, size_t length,
                                                  bool sorted) {
  const Reader r{f};
  std::map<std::string, std::string> kv;
  std::string last;
  const size_t end = at + length;
  while (at < end) {
    const uint32_t n = r.U32(at);
    Check(n >= 2 && at + 4 + n <= end, "a key/value entry inside the data");
    const std::string entry = f.substr(at + 4, n);
    const size_t nul = entry.find('\0');
    Check(nul != std::string::npos && entry.back() == '\0', "key NUL value NUL");
    const std::string key = entry.substr(0, nul);
    Check(!sorted || last.empty() || key > last, "keys sorted and unique");
    last = key;
    kv[key] = entry.substr(nul + 1, n - nul - 2);
    const size_t padded = (4 + n + 3) / 4 * 4;
    for (size_t i = at + 4 + n; i < at + padded; ++i) Check(f[i] == '\0', "valuePadding is 0");
    at += padded;
  }
  Check(at == end, "the key/value data ends with its last entry");
  return kv;
}

void FuzzKtx2(FuzzedDataProvider* fdp) {
  const FormatInfo& info = fdp->PickValueInArray(kKtx2Formats);
  shrm::ktx2::Ktx2Image im;
  im.format = info.format;
  const bool cube = fdp->ConsumeBool();
  im.faces = cube ? 6 : 1;
  im.width = fdp->ConsumeIntegralInRange(1, cube ? 9 : 17);
  im.height = cube ? im.width : fdp->ConsumeIntegralInRange(1, 17);
  im.layers = fdp->ConsumeIntegralInRange(0, 2);
  const int levels = fdp->ConsumeIntegralInRange(1, shrm::ktx2::MaxLevelCount(im.width, im.height));
  shrm::ktx2::EncodeOptions options;
  const bool clamp = info.ufloat && fdp->ConsumeBool();
  options.negatives = clamp ? shrm::ktx2::Negatives::kClampToZero : shrm::ktx2::Negatives::kReject;
  options.writer = "shrm fuzz " + std::to_string(fdp->ConsumeIntegral<uint8_t>());
  const int images = std::max(1, im.layers) * im.faces;
  for (int p = 0; p < levels; ++p) {
    shrm::ktx2::Level level;
    level.width = std::max(1, im.width >> p);
    level.height = std::max(1, im.height >> p);
    const size_t n = static_cast<size_t>(images) * level.width * level.height * info.channels;
    level.pixels.resize(n);
    for (float& v : level.pixels) v = Value(fdp, info.ufloat && !clamp);
    im.levels.push_back(std::move(level));
  }
  im.key_values = Keys(fdp, "shrm:k");
  absl::StatusOr<std::string> bytes = shrm::ktx2::EncodeKtx2(im, options);
  Check(bytes.ok(), "valid parameters encode");
  const std::string& f = *bytes;
  const Reader r{f};

  static const uint8_t kId[12] = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, '\r', '\n', 0x1A, '\n'};
  Check(f.size() >= 80 && std::memcmp(f.data(), kId, 12) == 0, "KTX2 identifier");
  Check(r.U32(12) == static_cast<uint32_t>(info.format), "vkFormat");
  Check(r.U32(16) == static_cast<uint32_t>(info.type_size), "typeSize");
  Check(
      r.U32(20) == static_cast<uint32_t>(im.width) && r.U32(24) == static_cast<uint32_t>(im.height),
      "pixelWidth, pixelHeight");
  Check(r.U32(28) == 0 && r.U32(32) == static_cast<uint32_t>(im.layers) &&
            r.U32(36) == static_cast<uint32_t>(im.faces),
        "pixelDepth, layerCount, faceCount");
  Check(r.U32(40) == static_cast<uint32_t>(levels) && r.U32(44) == 0,
        "levelCount, supercompressionScheme");
  const uint32_t dfd_off = r.U32(48), dfd_len = r.U32(52), kvd_off = r.U32(56), kvd_len = r.U32(60);
  Check(r.U64(64) == 0 && r.U64(72) == 0, "no supercompression global data");
  Check(dfd_off == 80 + 24u * levels && dfd_len >= 28 && r.U32(dfd_off) == dfd_len,
        "the DFD follows the level index; dfdTotalSize");
  Check((r.U32(dfd_off + 4 + 16) & 0xFF) == static_cast<uint32_t>(info.block),
        "bytesPlane0 = the texel block size");
  Check(kvd_off == dfd_off + dfd_len && kvd_off + kvd_len <= f.size(), "the KVD follows the DFD");
  std::map<std::string, std::string> kv = ParseKeyValues(f, kvd_off, kvd_len, true);
  Check(kv["KTXorientation"] == "rd" && kv["KTXwriter"] == options.writer, "orientation, writer");
  for (const auto& [k, v] : im.key_values) Check(kv[k] == v, "caller keys kept");
  Check(kv.size() == im.key_values.size() + 2, "no other keys");

  const uint64_t align = std::lcm(uint64_t(info.block), uint64_t{4});
  uint64_t expected_end = kvd_off + kvd_len;
  for (int p = levels - 1; p >= 0; --p) {  // stored smallest first
    const shrm::ktx2::Level& level = im.levels[p];
    const uint64_t off = r.U64(80 + 24 * p), len = r.U64(88 + 24 * p), ulen = r.U64(96 + 24 * p);
    const uint64_t texels = uint64_t(images) * level.width * level.height;
    Check(len == texels * info.block && ulen == len, "byteLength = the level's exact size");
    Check(off % align == 0 && off >= expected_end && off - expected_end < align,
          "level offset after mipPadding");
    for (uint64_t i = expected_end; i < off; ++i) Check(f[i] == '\0', "mipPadding is 0");
    Check(off + len <= f.size(), "the level inside the file");
    for (uint64_t t = 0; t < texels; ++t) {
      const size_t at = off + t * info.block;
      const float* in = &level.pixels[t * info.channels];
      float x[4];
      for (int c = 0; c < info.channels; ++c) {
        x[c] = clamp ? std::max(in[c], 0.0f) : in[c];
        if (x[c] == 0) x[c] = 0;  // -0 -> +0
      }
      if (info.type_size == 2) {
        for (int c = 0; c < info.channels; ++c) CheckHalf(r.U16(at + 2 * c), x[c]);
      } else if (!info.ufloat) {
        for (int c = 0; c < info.channels; ++c) {
          float v;
          const uint32_t bits = r.U32(at + 4 * c);
          std::memcpy(&v, &bits, 4);
          Check(std::memcmp(&v, &x[c], 4) == 0, "32-bit floats stored exactly");
        }
      } else if (info.format == shrm::ktx2::Format::kB10G11R11UfloatPack32) {
        CheckB10G11R11(r.U32(at), x);
      } else {
        const uint32_t w = r.U32(at);
        const int e = static_cast<int>(w >> 27);
        float m = 0;
        for (int c = 0; c < 3; ++c) m = std::max(m, std::min(x[c], 65408.0f));
        for (int c = 0; c < 3; ++c) {
          const float v = std::ldexp(static_cast<float>((w >> (9 * c)) & 511), e - 15 - 9);
          CheckValue(v, std::min(x[c], 65408.0f), 1.0 / 256, m);
        }
      }
    }
    expected_end = off + len;
  }
  Check(expected_end == f.size(), "the file ends with level 0");
}

void FuzzKtx1(FuzzedDataProvider* fdp) {
  using shrm::ktx1::Format;
  const Format format =
      fdp->PickValueInArray({Format::kRgb16f, Format::kRgb32f, Format::kR11fG11fB10f});
  shrm::ktx1::Ktx1Cube cube;
  cube.format = format;
  const int size = fdp->ConsumeIntegralInRange(1, 9);
  const int levels = fdp->ConsumeIntegralInRange(1, shrm::ktx2::MaxLevelCount(size, size));
  for (int p = 0; p < levels; ++p) {
    shrm::ktx1::CubeLevel level;
    level.size = std::max(1, size >> p);
    level.pixels.resize(size_t{6} * level.size * level.size * 3);
    for (float& v : level.pixels) v = Value(fdp, true);
    cube.levels.push_back(std::move(level));
  }
  cube.key_values = Keys(fdp, "sh");
  const std::string writer = "shrm fuzz";
  absl::StatusOr<std::string> bytes = shrm::ktx1::EncodeKtx1Cube(cube, writer);
  Check(bytes.ok(), "valid parameters encode");
  const std::string& f = *bytes;
  const Reader r{f};
  static const uint8_t kId[12] = {0xAB, 'K', 'T', 'X', ' ', '1', '1', 0xBB, '\r', '\n', 0x1A, '\n'};
  Check(f.size() >= 64 && std::memcmp(f.data(), kId, 12) == 0, "KTX1 identifier");
  Check(r.U32(12) == 0x04030201, "endianness");
  const int texel = shrm::ktx1::TexelBytes(format);
  const uint32_t gl_type = format == Format::kRgb16f   ? 0x140B
                           : format == Format::kRgb32f ? 0x1406
                                                       : 0x8C3A;
  const uint32_t internal = format == Format::kRgb16f   ? 0x881B
                            : format == Format::kRgb32f ? 0x8815
                                                        : 0x8C3A;
  Check(r.U32(16) == gl_type && r.U32(20) == (format == Format::kRgb16f ? 2u : 4u),
        "glType, glTypeSize");
  Check(r.U32(24) == 0x1907 && r.U32(28) == internal && r.U32(32) == 0x1907,
        "glFormat, glInternalFormat, glBaseInternalFormat");
  Check(r.U32(36) == static_cast<uint32_t>(size) && r.U32(40) == static_cast<uint32_t>(size) &&
            r.U32(44) == 0 && r.U32(48) == 0 && r.U32(52) == 6 &&
            r.U32(56) == static_cast<uint32_t>(levels),
        "sizes, array elements, faces, levels");
  const uint32_t kv_len = r.U32(60);
  std::map<std::string, std::string> kv = ParseKeyValues(f, 64, kv_len, false);
  Check(kv["KTXorientation"] == "S=r,T=d" && kv["KTXwriter"] == writer, "orientation, writer");
  for (const auto& [k, v] : cube.key_values) Check(kv[k] == v, "caller keys kept");
  size_t at = 64 + kv_len;
  for (int p = 0; p < levels; ++p) {
    const shrm::ktx1::CubeLevel& level = cube.levels[p];
    const uint32_t face_bytes = static_cast<uint32_t>(level.size * level.size * texel);
    Check(r.U32(at) == face_bytes, "imageSize = one face's bytes");
    at += 4;
    for (int face = 0; face < 6; ++face) {
      for (int t = 0; t < level.size * level.size; ++t) {
        const float* in = &level.pixels[(size_t(face) * level.size * level.size + t) * 3];
        const size_t texel_at = at + size_t(t) * texel;
        if (format == Format::kRgb32f) {
          for (int c = 0; c < 3; ++c) {
            const uint32_t bits = r.U32(texel_at + 4 * c);
            float v;
            std::memcpy(&v, &bits, 4);
            Check(v == in[c], "32-bit floats stored exactly");
          }
        } else if (format == Format::kRgb16f) {
          for (int c = 0; c < 3; ++c) CheckHalf(r.U16(texel_at + 2 * c), in[c]);
        } else {
          CheckB10G11R11(r.U32(texel_at), in);
        }
      }
      at += face_bytes;
      while (at % 4 != 0) Check(f[at++] == '\0', "cubePadding is 0");
    }
    while (at % 4 != 0) Check(f[at++] == '\0', "mipPadding is 0");
  }
  Check(at == f.size(), "the file ends with the last level");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  FuzzedDataProvider fdp(data + 1, size - 1);
  if (data[0] & 1) {
    FuzzKtx1(&fdp);
  } else {
    FuzzKtx2(&fdp);
  }
  return 0;
}
