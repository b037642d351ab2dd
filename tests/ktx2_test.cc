// KTX 2.0 writer (core/export/ktx2.h) against an independent reader written here from the KTX 2.0
// specification ("File Structure", "Index", "Level Index", "Data Format Descriptor",
// "Key/Value Data", "Mip Level Array") and the Khronos Data Format Specification's basic
// descriptor block; texel values decoded with Imath's half and the Vulkan specification's
// decode formulas for the packed unsigned floats.
#include "core/export/ktx2.h"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "tests/float_decoders.h"

namespace shrm::ktx2 {
namespace {

using ::shrm::testing::DecodeUfloat;
using ::shrm::testing::ImathHalfToFloat;

// Tolerances of the decoded values (relative to the value, or absolute near zero).
constexpr double kHalfRel = 0x1p-11;     // half: RNE to 10 mantissa bits, half an ulp
constexpr double kHalfAbs = 0x1p-25;     // half subnormals: half of the 2^-24 quantum
constexpr double kUfloat11Rel = 0x1p-7;  // 11-bit ufloat: 6 mantissa bits, half an ulp
constexpr double kUfloat10Rel = 0x1p-6;  // 10-bit ufloat: 5 mantissa bits, half an ulp
constexpr double kUfloatAbs = 0x1p-21;   // 10/11-bit subnormals: half of a 2^-19/2^-20 quantum
constexpr double kE5Rel = 0x1p-9;        // shared exponent: half a quantum <= max channel/512
constexpr double kE5Abs = 0x1p-25;       // shared exponent at the smallest exponent: 2^-24 / 2

// ---------------------------------------------------------------------------------------------
// An independent KTX2 reader (little endian, bounds checked).

struct Reader {
  const std::string& b;
  bool ok = true;
  uint64_t Get(uint64_t offset, int bytes) {
    if (offset + bytes > b.size()) {
      ok = false;
      return 0;
    }
    uint64_t v = 0;
    for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[offset + i]);
    return v;
  }
  uint32_t U32(uint64_t offset) { return static_cast<uint32_t>(Get(offset, 4)); }
  uint64_t U64(uint64_t offset) { return Get(offset, 8); }
};

struct ParsedSample {
  uint32_t bit_offset, bit_length, channel, qualifiers, positions, lower, upper;
};
struct ParsedLevel {
  uint64_t offset, length, uncompressed;
};
struct KeyValue {
  uint32_t byte_length;  // keyAndValueByteLength
  std::string key;
  std::string value;  // with its terminating NUL, as stored
  std::string padding;
};

struct Parsed {
  std::string identifier;
  uint32_t vk_format, type_size, width, height, depth, layers, faces, level_count, scheme;
  uint32_t dfd_offset, dfd_length, kvd_offset, kvd_length;
  uint64_t sgd_offset, sgd_length;
  std::vector<ParsedLevel> levels;
  // DFD
  uint32_t dfd_total, vendor_id, descriptor_type, version, block_size;
  uint32_t model, primaries, transfer, flags;
  std::array<uint32_t, 4> block_dimension;
  std::array<uint32_t, 8> bytes_plane;
  std::vector<ParsedSample> samples;
  std::vector<KeyValue> kv;
};

Parsed Parse(const std::string& b) {
  Reader r{b};
  Parsed p{};
  p.identifier = b.substr(0, 12);
  p.vk_format = r.U32(12);
  p.type_size = r.U32(16);
  p.width = r.U32(20);
  p.height = r.U32(24);
  p.depth = r.U32(28);
  p.layers = r.U32(32);
  p.faces = r.U32(36);
  p.level_count = r.U32(40);
  p.scheme = r.U32(44);
  p.dfd_offset = r.U32(48);
  p.dfd_length = r.U32(52);
  p.kvd_offset = r.U32(56);
  p.kvd_length = r.U32(60);
  p.sgd_offset = r.U64(64);
  p.sgd_length = r.U64(72);
  for (uint32_t i = 0; i < std::max<uint32_t>(1, p.level_count) && i < 64; ++i) {
    const uint64_t o = 80 + 24 * uint64_t{i};
    p.levels.push_back({r.U64(o), r.U64(o + 8), r.U64(o + 16)});
  }
  // Data Format Descriptor: dfdTotalSize, then the basic block (DF spec word layout).
  const uint64_t d = p.dfd_offset;
  p.dfd_total = r.U32(d);
  const uint32_t w0 = r.U32(d + 4), w1 = r.U32(d + 8), w2 = r.U32(d + 12);
  const uint32_t w3 = r.U32(d + 16), w4 = r.U32(d + 20), w5 = r.U32(d + 24);
  p.vendor_id = w0 & 0x1FFFF;
  p.descriptor_type = w0 >> 17;
  p.version = w1 & 0xFFFF;
  p.block_size = w1 >> 16;
  p.model = w2 & 0xFF;
  p.primaries = (w2 >> 8) & 0xFF;
  p.transfer = (w2 >> 16) & 0xFF;
  p.flags = w2 >> 24;
  for (int i = 0; i < 4; ++i) {
    p.block_dimension[i] = (w3 >> (8 * i)) & 0xFF;
    p.bytes_plane[i] = (w4 >> (8 * i)) & 0xFF;
    p.bytes_plane[4 + i] = (w5 >> (8 * i)) & 0xFF;
  }
  const uint32_t num_samples = p.block_size >= 24 ? (p.block_size - 24) / 16 : 0;
  for (uint32_t s = 0; s < num_samples && s < 64; ++s) {
    const uint64_t o = d + 4 + 24 + 16 * uint64_t{s};
    const uint32_t sw0 = r.U32(o);
    p.samples.push_back({sw0 & 0xFFFF, ((sw0 >> 16) & 0xFF) + 1, (sw0 >> 24) & 0x0F,
                         (sw0 >> 24) & 0xF0, r.U32(o + 4), r.U32(o + 8), r.U32(o + 12)});
  }
  // Key/Value Data.
  uint64_t o = p.kvd_offset;
  const uint64_t kvd_end = uint64_t{p.kvd_offset} + p.kvd_length;
  while (r.ok && o + 4 <= kvd_end) {
    KeyValue e;
    e.byte_length = r.U32(o);
    const uint64_t start = o + 4, stop = start + e.byte_length;
    if (stop > b.size() || e.byte_length < 2) {
      r.ok = false;
      break;
    }
    const std::string kv = b.substr(start, e.byte_length);
    const size_t nul = kv.find('\0');
    e.key = kv.substr(0, nul);
    e.value = nul == std::string::npos ? "" : kv.substr(nul + 1);
    const uint64_t next = (stop + 3) / 4 * 4;
    e.padding = b.substr(stop, next - stop);
    p.kv.push_back(e);
    o = next;
  }
  EXPECT_TRUE(r.ok) << "the file is truncated or an entry runs past its end";
  return p;
}

// ---------------------------------------------------------------------------------------------
// The expected format properties, from the Vulkan format tables and the KTX2 "typeSize" rule.

struct ExpectedFormat {
  uint32_t vk;
  uint32_t type_size;
  uint32_t block_bytes;
  int channels;
};

ExpectedFormat Expected(Format f) {
  switch (f) {
    case Format::kR16G16Sfloat:
      return {83, 2, 4, 2};
    case Format::kR16G16B16Sfloat:
      return {90, 2, 6, 3};
    case Format::kR16G16B16A16Sfloat:
      return {97, 2, 8, 4};
    case Format::kR32G32Sfloat:
      return {103, 4, 8, 2};
    case Format::kR32G32B32Sfloat:
      return {106, 4, 12, 3};
    case Format::kR32G32B32A32Sfloat:
      return {109, 4, 16, 4};
    case Format::kB10G11R11UfloatPack32:
      return {122, 4, 4, 3};
    case Format::kE5B9G9R9UfloatPack32:
      return {123, 4, 4, 3};
  }
  return {};
}

// The basic block's samples as the DF spec and libktx define them for each format.
std::vector<ParsedSample> ExpectedSamples(Format f) {
  constexpr uint32_t kFloat = 0x80, kSigned = 0x40, kExponent = 0x20;
  constexpr uint32_t kMinusOne = 0xBF800000u, kOne = 0x3F800000u;
  constexpr uint32_t kIds[4] = {0, 1, 2, 15};  // R, G, B, A in KHR_DF_MODEL_RGBSDA
  if (f == Format::kB10G11R11UfloatPack32) {
    return {{0, 11, 0, kFloat, 0, 0, kOne},
            {11, 11, 1, kFloat, 0, 0, kOne},
            {22, 10, 2, kFloat, 0, 0, kOne}};
  }
  if (f == Format::kE5B9G9R9UfloatPack32) {
    std::vector<ParsedSample> s;
    for (uint32_t c = 0; c < 3; ++c) {
      s.push_back({9 * c, 9, c, 0, 0, 0, 8448});      // mantissa
      s.push_back({27, 5, c, kExponent, 0, 15, 31});  // shared exponent: bias, max exponent
    }
    return s;
  }
  const ExpectedFormat e = Expected(f);
  std::vector<ParsedSample> s;
  for (int c = 0; c < e.channels; ++c) {
    const uint32_t bits = 8 * e.type_size;
    s.push_back({bits * c, bits, kIds[c], kFloat | kSigned, 0, kMinusOne, kOne});
  }
  return s;
}

uint64_t Align(uint64_t x, uint64_t a) { return (x + a - 1) / a * a; }

// Every container rule of the KTX 2.0 specification that applies to these files.
void CheckContainer(const std::string& bytes, const Parsed& p, Format f, int width, int height,
                    int faces, int layers, int levels) {
  const ExpectedFormat e = Expected(f);
  const std::string kId = {'\xAB', 'K', 'T', 'X', ' ', '2', '0', '\xBB', '\r', '\n', '\x1A', '\n'};
  EXPECT_EQ(p.identifier, kId);
  EXPECT_EQ(p.vk_format, e.vk);
  EXPECT_EQ(p.type_size, e.type_size);
  EXPECT_EQ(p.width, uint32_t(width));
  EXPECT_EQ(p.height, uint32_t(height));
  EXPECT_EQ(p.depth, 0u);
  EXPECT_EQ(p.layers, uint32_t(layers));
  EXPECT_EQ(p.faces, uint32_t(faces));
  EXPECT_EQ(p.level_count, uint32_t(levels));
  EXPECT_EQ(p.scheme, 0u);
  EXPECT_EQ(p.sgd_offset, 0u);
  EXPECT_EQ(p.sgd_length, 0u);

  // Index and DFD placement: the DFD follows the level index; dfdByteLength == dfdTotalSize ==
  // kvdByteOffset - dfdByteOffset.
  EXPECT_EQ(p.dfd_offset, 80u + 24u * levels);
  EXPECT_EQ(p.dfd_length, p.dfd_total);
  EXPECT_EQ(p.dfd_total, p.kvd_offset - p.dfd_offset);
  EXPECT_EQ(p.dfd_total, 4 + p.block_size);
  EXPECT_EQ(p.kvd_offset % 4, 0u);

  // Basic descriptor block.
  EXPECT_EQ(p.vendor_id, 0u);
  EXPECT_EQ(p.descriptor_type, 0u);
  EXPECT_EQ(p.version, 2u);  // KHR_DF_VERSIONNUMBER_1_3
  EXPECT_EQ(p.model, 1u);    // KHR_DF_MODEL_RGBSDA
  EXPECT_EQ(p.primaries, 1u);
  EXPECT_EQ(p.transfer, 1u);  // KHR_DF_TRANSFER_LINEAR
  EXPECT_EQ(p.flags, 0u);     // KHR_DF_FLAG_ALPHA_STRAIGHT
  EXPECT_EQ(p.block_dimension, (std::array<uint32_t, 4>{0, 0, 0, 0}));
  EXPECT_EQ(p.bytes_plane, (std::array<uint32_t, 8>{e.block_bytes, 0, 0, 0, 0, 0, 0, 0}));
  const std::vector<ParsedSample> want = ExpectedSamples(f);
  EXPECT_EQ(p.block_size, 24u + 16u * want.size());
  ASSERT_EQ(p.samples.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    SCOPED_TRACE("sample " + std::to_string(i));
    EXPECT_EQ(p.samples[i].bit_offset, want[i].bit_offset);
    EXPECT_EQ(p.samples[i].bit_length, want[i].bit_length);
    EXPECT_EQ(p.samples[i].channel, want[i].channel);
    EXPECT_EQ(p.samples[i].qualifiers, want[i].qualifiers);
    EXPECT_EQ(p.samples[i].positions, 0u);
    EXPECT_EQ(p.samples[i].lower, want[i].lower);
    EXPECT_EQ(p.samples[i].upper, want[i].upper);
  }

  // Key/Value Data: sum of padded entries + 4 per entry == kvdByteLength; keys sorted by code
  // point, unique, NUL-terminated, not empty; padding zero; string values NUL-terminated.
  uint64_t kv_sum = 0;
  for (size_t i = 0; i < p.kv.size(); ++i) {
    const KeyValue& kv = p.kv[i];
    SCOPED_TRACE("key " + kv.key);
    kv_sum += Align(kv.byte_length, 4) + 4;
    EXPECT_GE(kv.byte_length, 2u);
    EXPECT_FALSE(kv.key.empty());
    EXPECT_EQ(kv.byte_length, kv.key.size() + 1 + kv.value.size());
    ASSERT_FALSE(kv.value.empty());
    EXPECT_EQ(kv.value.back(), '\0');
    EXPECT_EQ(kv.value.find('\0'), kv.value.size() - 1);
    EXPECT_EQ(kv.padding, std::string(kv.padding.size(), '\0'));
    EXPECT_LT(kv.padding.size(), 4u);
    if (i > 0) {
      const std::string& a = p.kv[i - 1].key;
      EXPECT_TRUE(std::lexicographical_compare(
          a.begin(), a.end(), kv.key.begin(), kv.key.end(),
          [](char x, char y) { return (unsigned char)x < (unsigned char)y; }))
          << a << " !< " << kv.key;
    }
  }
  EXPECT_EQ(kv_sum, p.kvd_length);

  // Level index and Mip Level Array: levels[0] largest; stored smallest first, each offset the
  // first multiple of lcm(texel block size, 4) after the previous data, zero padding between,
  // exact byte lengths, the last (level 0) ending the file.
  ASSERT_EQ(p.levels.size(), size_t(levels));
  const uint64_t alignment = std::lcm(uint64_t{e.block_bytes}, uint64_t{4});
  uint64_t end = uint64_t{p.kvd_offset} + p.kvd_length;
  for (int lv = levels - 1; lv >= 0; --lv) {
    SCOPED_TRACE("level " + std::to_string(lv));
    const ParsedLevel& l = p.levels[lv];
    const uint64_t w = std::max(1, width >> lv), h = std::max(1, height >> lv);
    const uint64_t size = uint64_t(std::max(1, layers)) * faces * w * h * e.block_bytes;
    EXPECT_EQ(l.offset, Align(end, alignment));
    EXPECT_EQ(l.offset % alignment, 0u);
    EXPECT_EQ(l.length, size);
    EXPECT_EQ(l.uncompressed, size);
    EXPECT_EQ(l.uncompressed % (uint64_t(faces) * std::max(1, layers)), 0u);
    ASSERT_LE(l.offset, bytes.size());
    const std::string padding = bytes.substr(end, l.offset - end);
    EXPECT_EQ(padding, std::string(padding.size(), '\0'));
    end = l.offset + l.length;
  }
  EXPECT_EQ(end, bytes.size());
}

std::string KeyValueOf(const Parsed& p, const std::string& key) {
  for (const KeyValue& kv : p.kv) {
    if (kv.key == key) return kv.value.substr(0, kv.value.size() - 1);
  }
  return "<missing>";
}

// ---------------------------------------------------------------------------------------------
// Decoders from the specifications (not the encoder's code).

// E5B9G9R9: Vulkan "Shared Exponent": channel = mantissa * 2^(exp - B - N), B = 15, N = 9.
std::array<double, 3> DecodeE5(uint32_t w) {
  const int e = int(w >> 27);
  return {std::ldexp(double(w & 0x1FF), e - 24), std::ldexp(double((w >> 9) & 0x1FF), e - 24),
          std::ldexp(double((w >> 18) & 0x1FF), e - 24)};
}

// Level `lv`'s values back from the file, in the input layout.
std::vector<double> DecodeLevel(const std::string& bytes, const Parsed& p, Format f, int lv) {
  Reader r{bytes};
  const ParsedLevel& l = p.levels[lv];
  std::vector<double> out;
  switch (f) {
    case Format::kR16G16Sfloat:
    case Format::kR16G16B16Sfloat:
    case Format::kR16G16B16A16Sfloat:
      for (uint64_t o = 0; o < l.length; o += 2) {
        out.push_back(ImathHalfToFloat(static_cast<uint16_t>(r.Get(l.offset + o, 2))));
      }
      break;
    case Format::kR32G32Sfloat:
    case Format::kR32G32B32Sfloat:
    case Format::kR32G32B32A32Sfloat:
      for (uint64_t o = 0; o < l.length; o += 4) {
        const uint32_t u = r.U32(l.offset + o);
        float v;
        std::memcpy(&v, &u, 4);
        out.push_back(v);
      }
      break;
    case Format::kB10G11R11UfloatPack32:
      for (uint64_t o = 0; o < l.length; o += 4) {
        const uint32_t w = r.U32(l.offset + o);
        out.push_back(DecodeUfloat(w & 0x7FF, 6));
        out.push_back(DecodeUfloat((w >> 11) & 0x7FF, 6));
        out.push_back(DecodeUfloat(w >> 22, 5));
      }
      break;
    case Format::kE5B9G9R9UfloatPack32:
      for (uint64_t o = 0; o < l.length; o += 4) {
        for (double v : DecodeE5(r.U32(l.offset + o))) out.push_back(v);
      }
      break;
  }
  return out;
}

// Whether decoded `got` represents input `want` within the format's rounding; `texel` holds the
// input texel's channels (the shared exponent depends on the largest).
bool WithinRounding(Format f, double want, double got, int channel, const float* texel) {
  const double err = std::abs(got - want);
  switch (f) {
    case Format::kR32G32Sfloat:
    case Format::kR32G32B32Sfloat:
    case Format::kR32G32B32A32Sfloat:
      return got == want;
    case Format::kR16G16Sfloat:
    case Format::kR16G16B16Sfloat:
    case Format::kR16G16B16A16Sfloat:
      return err <= std::max(kHalfRel * std::abs(want), kHalfAbs);
    case Format::kB10G11R11UfloatPack32:
      return err <= std::max((channel == 2 ? kUfloat10Rel : kUfloat11Rel) * want, kUfloatAbs);
    case Format::kE5B9G9R9UfloatPack32: {
      const double max_c = std::max({double(texel[0]), double(texel[1]), double(texel[2])});
      return err <= std::max(kE5Rel * max_c, kE5Abs);
    }
  }
  return false;
}

// A deterministic test image: values spread over [1e-3, 1e3] in magnitude, signed for the SFLOAT
// formats.
Ktx2Image MakeImage(Format f, int width, int height, int faces, int layers, int levels,
                    uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> log_mag(-3, 3);
  std::bernoulli_distribution negative(0.3);
  const bool is_unsigned =
      f == Format::kB10G11R11UfloatPack32 || f == Format::kE5B9G9R9UfloatPack32;
  Ktx2Image im;
  im.format = f;
  im.width = width;
  im.height = height;
  im.faces = faces;
  im.layers = layers;
  for (int lv = 0; lv < levels; ++lv) {
    Level l;
    l.width = std::max(1, width >> lv);
    l.height = std::max(1, height >> lv);
    l.pixels.resize(size_t(std::max(1, layers)) * faces * l.width * l.height * ChannelCount(f));
    for (float& v : l.pixels) {
      v = float(std::pow(10.0, log_mag(rng)));
      if (!is_unsigned && negative(rng)) v = -v;
    }
    im.levels.push_back(std::move(l));
  }
  return im;
}

// Encodes `im`, checks the container rules and every decoded value.
void CheckRoundTrip(const Ktx2Image& im) {
  SCOPED_TRACE(std::string(FormatName(im.format)));
  absl::StatusOr<std::string> bytes = EncodeKtx2(im, {.writer = "shrm test"});
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  const Parsed p = Parse(*bytes);
  CheckContainer(*bytes, p, im.format, im.width, im.height, im.faces, im.layers,
                 int(im.levels.size()));
  EXPECT_EQ(KeyValueOf(p, "KTXorientation"), "rd");
  EXPECT_EQ(KeyValueOf(p, "KTXwriter"), "shrm test");
  const int channels = Expected(im.format).channels;
  for (size_t lv = 0; lv < im.levels.size(); ++lv) {
    const std::vector<float>& want = im.levels[lv].pixels;
    const std::vector<double> got = DecodeLevel(*bytes, p, im.format, int(lv));
    ASSERT_EQ(got.size(), want.size()) << "level " << lv;
    int failures = 0;
    for (size_t i = 0; i < want.size() && failures < 5; ++i) {
      const float* texel = &want[i - i % channels];
      if (!WithinRounding(im.format, want[i], got[i], int(i % channels), texel)) {
        ADD_FAILURE() << "level " << lv << " value " << i << ": wrote " << want[i] << ", read "
                      << got[i];
        ++failures;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------

TEST(Ktx2Test, Rgba16fMipChain2d) {
  CheckRoundTrip(MakeImage(Format::kR16G16B16A16Sfloat, 8, 4, 1, 0, 4));
}

TEST(Ktx2Test, EveryFormatSingleLevel) {
  for (Format f : {Format::kR16G16Sfloat, Format::kR16G16B16Sfloat, Format::kR16G16B16A16Sfloat,
                   Format::kR32G32Sfloat, Format::kR32G32B32Sfloat, Format::kR32G32B32A32Sfloat,
                   Format::kB10G11R11UfloatPack32, Format::kE5B9G9R9UfloatPack32}) {
    CheckRoundTrip(MakeImage(f, 5, 3, 1, 0, 1));
  }
}

TEST(Ktx2Test, CubeMapWithFullMipChain) {
  // The radiance cube: one roughness per level, down to 1x1.
  CheckRoundTrip(MakeImage(Format::kR16G16B16A16Sfloat, 16, 16, 6, 0, 5));
  CheckRoundTrip(MakeImage(Format::kE5B9G9R9UfloatPack32, 8, 8, 6, 0, 4));
  CheckRoundTrip(MakeImage(Format::kB10G11R11UfloatPack32, 4, 4, 6, 0, 3));
}

TEST(Ktx2Test, CubeMapArray) {
  // SH coefficient planes: one layer per coefficient.
  CheckRoundTrip(MakeImage(Format::kR32G32B32A32Sfloat, 4, 4, 6, 9, 1));
  CheckRoundTrip(MakeImage(Format::kR16G16B16A16Sfloat, 8, 8, 6, 3, 2));
}

TEST(Ktx2Test, TwoDimensionalArray) {
  CheckRoundTrip(MakeImage(Format::kR32G32Sfloat, 4, 2, 1, 2, 3));
}

TEST(Ktx2Test, MipPaddingForSixByteTexels) {
  // R16G16B16: texel block 6, alignment lcm(6, 4) = 12, so levels 1x1 (6 bytes) and 2x1 need
  // padding; CheckContainer checks offsets and zero padding.
  const Ktx2Image im = MakeImage(Format::kR16G16B16Sfloat, 4, 2, 1, 0, 3);
  CheckRoundTrip(im);
  const std::string bytes = *EncodeKtx2(im);
  const Parsed p = Parse(bytes);
  EXPECT_EQ(p.levels[2].offset % 12, 0u);
  EXPECT_EQ(p.levels[1].offset, Align(p.levels[2].offset + 6, 12));
  EXPECT_GT(p.levels[1].offset, p.levels[2].offset + 6);  // really padded
}

TEST(Ktx2Test, LayoutIsLayerFaceRowTexel) {
  // Each value encodes its own index: decoding position (layer, face, y, x, c) of the file must
  // give the value written there.
  Ktx2Image im;
  im.format = Format::kR32G32B32A32Sfloat;
  im.width = im.height = 2;
  im.faces = 6;
  im.layers = 2;
  Level l{2, 2, {}};
  for (int i = 0; i < 2 * 6 * 2 * 2 * 4; ++i) l.pixels.push_back(float(i));
  im.levels.push_back(l);
  const std::string bytes = *EncodeKtx2(im);
  const Parsed p = Parse(bytes);
  Reader r{bytes};
  for (int layer = 0; layer < 2; ++layer) {
    for (int face = 0; face < 6; ++face) {
      for (int y = 0; y < 2; ++y) {
        for (int x = 0; x < 2; ++x) {
          for (int c = 0; c < 4; ++c) {
            const uint64_t byte = ((((layer * 6 + face) * 2 + y) * 2 + x) * 4 + c) * 4;
            const uint32_t u = r.U32(p.levels[0].offset + byte);
            float v;
            std::memcpy(&v, &u, 4);
            EXPECT_EQ(v, float((((layer * 6 + face) * 2 + y) * 2 + x) * 4 + c));
          }
        }
      }
    }
  }
}

TEST(Ktx2Test, KeyValueDataSortedAndTerminated) {
  Ktx2Image im = MakeImage(Format::kR16G16Sfloat, 4, 4, 1, 0, 1);
  im.key_values = {{"shrm:roughness", "0.25 0.5"},
                   {"shrm:a", ""},
                   {"Zebra", "1"},
                   {"shrm:\xC3\xA9t\xC3\xA9", "caf\xC3\xA9"},
                   {"abc", "xyz!"}};
  absl::StatusOr<std::string> bytes = EncodeKtx2(im, {.writer = "shrm 0.1.0"});
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  const Parsed p = Parse(*bytes);
  CheckContainer(*bytes, p, im.format, 4, 4, 1, 0, 1);
  std::vector<std::string> keys;
  for (const KeyValue& kv : p.kv) keys.push_back(kv.key);
  // Code point order: uppercase before lowercase, U+00E9 after ASCII.
  EXPECT_EQ(keys, (std::vector<std::string>{"KTXorientation", "KTXwriter", "Zebra", "abc", "shrm:a",
                                            "shrm:roughness", "shrm:\xC3\xA9t\xC3\xA9"}));
  EXPECT_EQ(KeyValueOf(p, "KTXwriter"), "shrm 0.1.0");
  EXPECT_EQ(KeyValueOf(p, "shrm:roughness"), "0.25 0.5");
  EXPECT_EQ(KeyValueOf(p, "shrm:a"), "");
  // The first entry byte for byte: length 18 ("KTXorientation\0rd\0"), 2 bytes of padding.
  EXPECT_EQ(p.kv[0].byte_length, 18u);
  EXPECT_EQ(p.kv[0].padding, std::string(2, '\0'));
}

TEST(Ktx2Test, KnownBitPatterns) {
  // Vulkan / DF spec encodings of 1.0.
  EXPECT_EQ(FloatToHalf(1.0f), 0x3C00);
  EXPECT_EQ(FloatToHalf(-2.0f), 0xC000);
  EXPECT_EQ(PackB10G11R11(1, 1, 1), 0x781E03C0u);  // R 0x3C0, G 0x3C0 << 11, B 0x1E0 << 22
  EXPECT_EQ(PackE5B9G9R9(1, 1, 1), 0x84020100u);   // exponent 16, mantissas 256
  EXPECT_EQ(PackE5B9G9R9(0, 0, 0), 0u);
  // Through a file: a 1x1 E5B9G9R9 texel (1, 0.5, 0.25).
  Ktx2Image im;
  im.format = Format::kE5B9G9R9UfloatPack32;
  im.width = im.height = 1;
  im.levels.push_back({1, 1, {1.0f, 0.5f, 0.25f}});
  const std::string bytes = *EncodeKtx2(im);
  const Parsed p = Parse(bytes);
  EXPECT_EQ(Reader{bytes}.U32(p.levels[0].offset), (16u << 27) | (64u << 18) | (128u << 9) | 256u);
}

TEST(Ktx2Test, HalfRoundingAndSaturation) {
  EXPECT_EQ(FloatToHalf(65504.0f), 0x7BFF);                    // max finite half
  EXPECT_EQ(FloatToHalf(65519.0f), 0x7BFF);                    // rounds down to it
  EXPECT_EQ(FloatToHalf(65520.0f), 0x7BFF);                    // would round to inf: clamped
  EXPECT_EQ(FloatToHalf(1e30f), 0x7BFF);                       // HDR overflow: clamped
  EXPECT_EQ(FloatToHalf(-1e30f), 0xFBFF);                      // -65504
  EXPECT_EQ(FloatToHalf(1.0f + 0x1p-11f), 0x3C00);             // tie: to even (mantissa 0)
  EXPECT_EQ(FloatToHalf(1.0f + 3 * 0x1p-11f), 0x3C02);         // tie: to even (mantissa 2)
  EXPECT_EQ(FloatToHalf(1.0f + 0x1p-11f + 0x1p-20f), 0x3C01);  // above the tie: up
  EXPECT_EQ(FloatToHalf(0x1p-24f), 0x0001);                    // smallest subnormal
  EXPECT_EQ(FloatToHalf(0x1p-25f), 0x0000);                    // tie between 0 and 2^-24: even
  EXPECT_EQ(FloatToHalf(3 * 0x1p-25f), 0x0002);                // tie between 1 and 2: even
  EXPECT_EQ(FloatToHalf(0x1p-14f), 0x0400);                    // smallest normal
  EXPECT_EQ(FloatToHalf(0x1p-14f - 0x1p-25f), 0x0400);         // subnormal rounding up to normal
  EXPECT_EQ(FloatToHalf(-0.0f), 0x8000);
  EXPECT_EQ(FloatToHalf(std::numeric_limits<float>::infinity()), 0x7BFF);  // clamped
  EXPECT_EQ(FloatToHalf(std::numeric_limits<float>::quiet_NaN()), 0x0000);
  EXPECT_EQ(FloatToHalf(std::nextafter(0x1p-14f, 0.0f)), 0x0400);  // largest float below normal
  // Against Imath's round-to-nearest-even conversion over the finite range.
  std::mt19937 rng(3);
  std::uniform_int_distribution<uint32_t> bits;
  int checked = 0;
  while (checked < 1000000) {
    const uint32_t u = bits(rng);
    float v;
    std::memcpy(&v, &u, 4);
    if (!std::isfinite(v) || std::abs(v) >= 65504.0f) continue;
    ASSERT_EQ(FloatToHalf(v), Imath::half(v).bits()) << v;
    ++checked;
  }
}

TEST(Ktx2Test, PackedUfloatLimits) {
  // 11-bit max finite 65024 (E 30, M 63), 10-bit 64512 (E 30, M 31); larger values clamp.
  EXPECT_EQ(PackB10G11R11(1e9f, 0, 0) & 0x7FF, (30u << 6) | 63u);
  EXPECT_EQ(PackB10G11R11(0, 0, 1e9f) >> 22, (30u << 5) | 31u);
  EXPECT_EQ(DecodeUfloat(PackB10G11R11(65024, 0, 0) & 0x7FF, 6), 65024.0);
  EXPECT_EQ(DecodeUfloat(PackB10G11R11(0, 0, 64512) >> 22, 5), 64512.0);
  // 11-bit ties to even: 1 + 2^-7 is halfway between 1 and 1 + 2^-6.
  EXPECT_EQ(PackB10G11R11(1 + 0x1p-7f, 0, 0) & 0x7FF, 15u << 6);
  EXPECT_EQ(PackB10G11R11(1 + 3 * 0x1p-7f, 0, 0) & 0x7FF, (15u << 6) | 2u);
  // E5B9G9R9 max (511/512) * 2^16 = 65408; larger clamps to it.
  const std::array<double, 3> big = DecodeE5(PackE5B9G9R9(1e9f, 65408, 0));
  EXPECT_EQ(big[0], 65408.0);
  EXPECT_EQ(big[1], 65408.0);
  EXPECT_EQ(big[2], 0.0);
  // The mantissa overflow case: 511.75 / 512 rounds to 512 and bumps the shared exponent.
  const std::array<double, 3> bump = DecodeE5(PackE5B9G9R9(511.75f / 512, 0, 0));
  EXPECT_EQ(bump[0], 1.0);
}

TEST(Ktx2Test, NegativeUfloatRejectedOrClamped) {
  for (Format f : {Format::kB10G11R11UfloatPack32, Format::kE5B9G9R9UfloatPack32}) {
    Ktx2Image im;
    im.format = f;
    im.width = 2;
    im.height = 1;
    im.levels.push_back({2, 1, {1, 2, 3, 4, -0.5f, 6}});
    const absl::StatusOr<std::string> rejected = EncodeKtx2(im);
    ASSERT_FALSE(rejected.ok());
    EXPECT_EQ(rejected.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(rejected.status().message().find("negative"), std::string::npos) << rejected.status();
    EXPECT_NE(rejected.status().message().find("x 1, y 0, channel 1"), std::string::npos)
        << rejected.status();
    const absl::StatusOr<std::string> clamped =
        EncodeKtx2(im, {.negatives = Negatives::kClampToZero});
    ASSERT_TRUE(clamped.ok()) << clamped.status();
    const Parsed p = Parse(*clamped);
    const std::vector<double> got = DecodeLevel(*clamped, p, f, 0);
    EXPECT_EQ(got[4], 0.0);
    // -0.0 is zero, not negative.
    im.levels[0].pixels[4] = -0.0f;
    EXPECT_TRUE(EncodeKtx2(im).ok());
  }
  // Negative values are fine in the signed formats.
  Ktx2Image im = MakeImage(Format::kR16G16B16A16Sfloat, 2, 2, 1, 0, 1);
  im.levels[0].pixels[0] = -3.0f;
  EXPECT_TRUE(EncodeKtx2(im).ok());
}

TEST(Ktx2Test, NonFiniteRejected) {
  for (float bad : {NAN, INFINITY, -INFINITY}) {
    for (Format f : {Format::kR16G16B16A16Sfloat, Format::kR32G32B32A32Sfloat,
                     Format::kE5B9G9R9UfloatPack32}) {
      Ktx2Image im = MakeImage(f, 4, 4, 6, 0, 2);
      im.levels[1].pixels.back() = bad;
      const absl::StatusOr<std::string> r = EncodeKtx2(im);
      ASSERT_FALSE(r.ok());
      EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
      EXPECT_NE(r.status().message().find("level 1, layer 0, face 5"), std::string::npos)
          << r.status();
    }
  }
}

// A level given as RGB triples (Level::rgb, read in place) is the level given as pixels with
// alpha 1 (for a four-channel format) or the same triples (three channels): the same bytes, whose
// values the round trip above checks against the formats' decoders.
TEST(Ktx2Test, RgbViewEncodesAsItsPixels) {
  for (Format f :
       {Format::kR16G16B16A16Sfloat, Format::kR32G32B32A32Sfloat, Format::kR16G16B16Sfloat,
        Format::kR32G32B32Sfloat, Format::kB10G11R11UfloatPack32, Format::kE5B9G9R9UfloatPack32}) {
    SCOPED_TRACE(std::string(FormatName(f)));
    const int channels = ChannelCount(f);
    // 6 faces of 40 x 40 at level 0: 9600 texels, several of the encoder's runs and a partial one.
    Ktx2Image with_pixels = MakeImage(f, 40, 40, 6, 0, 3);
    Ktx2Image with_rgb = with_pixels;
    std::vector<std::vector<float>> triples;
    for (Level& l : with_pixels.levels) {
      std::vector<float>& rgb = triples.emplace_back();
      for (size_t t = 0; t < l.pixels.size() / channels; ++t) {
        for (int c = 0; c < 3; ++c) rgb.push_back(l.pixels[t * channels + c]);
        if (channels == 4) l.pixels[t * channels + 3] = 1.0f;
      }
    }
    for (size_t k = 0; k < with_rgb.levels.size(); ++k) {
      with_rgb.levels[k].pixels.clear();
      with_rgb.levels[k].rgb = triples[k];
    }
    const absl::StatusOr<std::string> a = EncodeKtx2(with_pixels), b = EncodeKtx2(with_rgb);
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_TRUE(b.ok()) << b.status();
    EXPECT_EQ(*a, *b);
    // Its values are checked as pixels are, and named by texel.
    triples[1][3 * 7 + 2] = NAN;
    const absl::StatusOr<std::string> bad = EncodeKtx2(with_rgb);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.status().message().find("NaN at level 1, layer 0, face 0, x 7, y 0, channel 2"),
              std::string::npos)
        << bad.status();
  }
}

// Expects EncodeKtx2 to fail with InvalidArgument mentioning `needle`.
void ExpectInvalid(const Ktx2Image& im, const std::string& needle, const EncodeOptions& o = {}) {
  const absl::StatusOr<std::string> r = EncodeKtx2(im, o);
  ASSERT_FALSE(r.ok()) << "expected an error mentioning: " << needle;
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find(needle), std::string::npos) << r.status();
}

TEST(Ktx2Test, BadLayoutRejected) {
  const Ktx2Image good = MakeImage(Format::kR16G16B16A16Sfloat, 8, 8, 6, 0, 4);
  ASSERT_TRUE(EncodeKtx2(good).ok());

  Ktx2Image im = good;
  im.levels.clear();
  ExpectInvalid(im, "no levels");

  im = MakeImage(Format::kR16G16B16A16Sfloat, 8, 8, 6, 0, 4);
  Level extra{1, 1, std::vector<float>(6 * 4)};
  im.levels.push_back(extra);  // a 5th level: 8x8 has 4 (8, 4, 2, 1)
  ExpectInvalid(im, "at most 4");

  im = good;
  im.levels[2].width = 3;
  ExpectInvalid(im, "level 2 is 3x2");

  im = good;
  im.levels[1].pixels.pop_back();  // one value short
  ExpectInvalid(im, "level 1 has");

  im = good;
  im.format = Format::kE5B9G9R9UfloatPack32;  // 3 channels, data has 4
  ExpectInvalid(im, "3 channels");

  // RGB triples in place of pixels: not both, not for a two-channel format, the right count.
  const std::vector<float> triples(6 * 8 * 8 * 3, 0.5f);
  im = good;
  im.levels.resize(1);
  im.levels[0].rgb = triples;
  ExpectInvalid(im, "both pixels and rgb");
  im.levels[0].pixels.clear();
  ASSERT_TRUE(EncodeKtx2(im).ok());
  im.levels[0].rgb = std::span<const float>(triples).first(triples.size() - 3);
  ExpectInvalid(im, "rgb values for");
  im.levels[0].rgb = triples;
  im.format = Format::kR16G16Sfloat;
  ExpectInvalid(im, "has rgb values, but");

  im = MakeImage(Format::kR16G16B16A16Sfloat, 8, 4, 1, 0, 1);
  im.faces = 6;
  ExpectInvalid(im, "square");

  im = good;
  im.faces = 2;
  ExpectInvalid(im, "faces is 2");

  im = good;
  im.layers = -1;
  ExpectInvalid(im, "layers is -1");

  im = good;
  im.width = 0;
  ExpectInvalid(im, "image size 0x8");

  im = good;
  im.format = static_cast<Format>(44);
  ExpectInvalid(im, "unsupported format");
}

TEST(Ktx2Test, BadKeysRejected) {
  const Ktx2Image good = MakeImage(Format::kR16G16Sfloat, 2, 2, 1, 0, 1);
  Ktx2Image im = good;
  im.key_values["KTXorientation"] = "ru";
  ExpectInvalid(im, "reserved");
  im = good;
  im.key_values["ktxfoo"] = "1";
  ExpectInvalid(im, "reserved");
  im = good;
  im.key_values[""] = "1";
  ExpectInvalid(im, "empty key");
  im = good;
  im.key_values[std::string("a\0b", 3)] = "1";
  ExpectInvalid(im, "NUL");
  im = good;
  im.key_values["shrm:x"] = std::string("1\0002", 3);
  ExpectInvalid(im, "NUL");
  im = good;
  im.key_values["shrm:\xFF"] = "1";
  ExpectInvalid(im, "UTF-8");
  ExpectInvalid(good, "writer", {.writer = ""});
  ExpectInvalid(good, "UTF-8", {.writer = "shrm \xC0\x80"});  // overlong NUL
}

// The module's decoders (used by jobs to measure stored outputs) against the test's own decoders
// written from the specifications, on random values of every magnitude.
TEST(Ktx2Test, DecodersMatchTheSpecificationFormulas) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> expo(-20, 16);
  for (int i = 0; i < 20000; ++i) {
    const float v[3] = {static_cast<float>(std::exp2(expo(rng))),
                        static_cast<float>(std::exp2(expo(rng))),
                        static_cast<float>(std::exp2(expo(rng)))};
    const uint16_t h = FloatToHalf(v[0]);
    EXPECT_EQ(HalfToFloat(h), ImathHalfToFloat(h));
    float got[3];
    const uint32_t b = PackB10G11R11(v[0], v[1], v[2]);
    UnpackB10G11R11(b, got);
    EXPECT_EQ(got[0], static_cast<float>(DecodeUfloat(b & 0x7FF, 6)));
    EXPECT_EQ(got[1], static_cast<float>(DecodeUfloat((b >> 11) & 0x7FF, 6)));
    EXPECT_EQ(got[2], static_cast<float>(DecodeUfloat(b >> 22, 5)));
    const uint32_t e = PackE5B9G9R9(v[0], v[1], v[2]);
    UnpackE5B9G9R9(e, got);
    const std::array<double, 3> want = DecodeE5(e);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(got[c], static_cast<float>(want[c]));
    float rt[4] = {v[0], v[1], v[2], 1.0f};
    RoundTrip(Format::kE5B9G9R9UfloatPack32, rt);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(rt[c], got[c]);
  }
}

// The whole-span storage rounding a job applies to its RGB cubes, texel by texel, against Imath's
// half and the specification's decoders of the packed codes.
TEST(Ktx2Test, RoundTripRgbRoundsEveryTexelAsItsFormatStoresIt) {
  std::mt19937 rng(6);
  // Below the half's saturation (65504), where Imath rounds to infinity and the encoder clamps.
  std::uniform_real_distribution<double> expo(-20, 15.9);
  std::vector<float> rgb(3 * 3000);
  for (float& v : rgb) v = static_cast<float>(std::exp2(expo(rng)));
  for (size_t i = 0; i < rgb.size(); i += 7) rgb[i] = -rgb[i];  // signed formats keep the sign
  for (Format f : {Format::kR16G16Sfloat, Format::kR16G16B16Sfloat, Format::kR16G16B16A16Sfloat,
                   Format::kR32G32B32A32Sfloat, Format::kB10G11R11UfloatPack32,
                   Format::kE5B9G9R9UfloatPack32}) {
    std::vector<float> got = rgb;
    RoundTripRgb(f, got);
    for (size_t i = 0; i < rgb.size(); i += 3) {
      std::array<float, 3> want = {rgb[i], rgb[i + 1], rgb[i + 2]};
      if (f == Format::kB10G11R11UfloatPack32) {
        const uint32_t b = PackB10G11R11(want[0], want[1], want[2]);
        want = {static_cast<float>(DecodeUfloat(b & 0x7FF, 6)),
                static_cast<float>(DecodeUfloat((b >> 11) & 0x7FF, 6)),
                static_cast<float>(DecodeUfloat(b >> 22, 5))};
      } else if (f == Format::kE5B9G9R9UfloatPack32) {
        const std::array<double, 3> e = DecodeE5(PackE5B9G9R9(want[0], want[1], want[2]));
        want = {static_cast<float>(e[0]), static_cast<float>(e[1]), static_cast<float>(e[2])};
      } else if (f != Format::kR32G32B32A32Sfloat) {
        for (int c = 0; c < (f == Format::kR16G16Sfloat ? 2 : 3); ++c) {
          want[c] = static_cast<float>(Imath::half(want[c]));
        }
      }
      for (int c = 0; c < 3; ++c) {
        ASSERT_EQ(got[i + c], want[c]) << FormatName(f) << " texel " << i / 3 << " channel " << c;
      }
    }
  }
}

// The encoders against their definition: the code (5-bit exponent, m mantissa bits) whose value,
// by the specification's formula (DecodeUfloat), is nearest to v, ties to the even code, and the
// largest finite code above it. Found by bisection over the codes (their values increase).
uint32_t NearestCode(double v, int m) {
  const uint32_t largest = (30u << m) | ((1u << m) - 1);
  if (!(v > 0)) return 0;
  if (v >= testing::DecodeUfloat(largest, m)) return largest;
  uint32_t lo = 0, hi = largest;  // value(lo) <= v < value(hi)
  while (hi - lo > 1) {
    const uint32_t mid = lo + (hi - lo) / 2;
    (testing::DecodeUfloat(mid, m) <= v ? lo : hi) = mid;
  }
  const double dl = v - testing::DecodeUfloat(lo, m), dh = testing::DecodeUfloat(hi, m) - v;
  if (dl < dh) return lo;
  if (dh < dl) return hi;
  return (lo & 1u) ? hi : lo;
}

// Every code's value, the midpoints between neighbours (the ties) and the floats next to them,
// plus a stride through all positive floats; for half, 10-bit and 11-bit ufloat, and half's sign.
TEST(Ktx2Test, EncodersRoundToTheNearestCodeTiesToEven) {
  auto check = [](float v) {
    ASSERT_EQ(FloatToHalf(v), NearestCode(v, 10)) << v;
    ASSERT_EQ(FloatToHalf(-v), v > 0 ? (0x8000u | NearestCode(v, 10)) : 0x8000u) << v;
    const uint32_t packed = PackB10G11R11(v, v, v);
    ASSERT_EQ(packed & 0x7FFu, NearestCode(v, 6)) << v;
    ASSERT_EQ(packed >> 22, NearestCode(v, 5)) << v;
  };
  for (int m : {5, 6, 10}) {
    const uint32_t largest = (30u << m) | ((1u << m) - 1);
    for (uint32_t c = 0; c < largest; ++c) {
      const double a = testing::DecodeUfloat(c, m), b = testing::DecodeUfloat(c + 1, m);
      const float mid = static_cast<float>(0.5 * (a + b));  // exact: 12 significant bits at most
      for (float v :
           {static_cast<float>(a), mid, std::nextafter(mid, 0.0f), std::nextafter(mid, 1e30f)})
        check(v);
    }
  }
  for (uint64_t bits = 1; bits < 0x7F800000u; bits += 4099)
    check(std::bit_cast<float>(static_cast<uint32_t>(bits)));
  check(std::numeric_limits<float>::max());
  check(std::numeric_limits<float>::denorm_min());
}

// The array conversions (F16C where the build has it) give FloatToHalf's and HalfToFloat's codes
// and values: every half code; each code's value, the midpoints (ties) between neighbouring codes
// and a float ulp either side, of both signs; values past the half range, infinities and NaN (the
// scalar path's saturation, in vectors that are otherwise convertible); a sweep of float bits.
TEST(Ktx2Test, ArrayConversionsEqualTheScalarOnes) {
  std::vector<uint16_t> codes(65536);
  std::iota(codes.begin(), codes.end(), 0);
  std::vector<float> back(codes.size());
  HalvesToFloats(codes, back);
  for (size_t c = 0; c < codes.size(); ++c) {
    const float want = HalfToFloat(static_cast<uint16_t>(c));
    if (std::isnan(want)) {
      ASSERT_TRUE(std::isnan(back[c])) << c;
    } else {
      ASSERT_EQ(std::bit_cast<uint32_t>(back[c]), std::bit_cast<uint32_t>(want)) << c;
    }
  }
  std::vector<float> values;
  for (uint32_t c = 0; c < 0x7BFF; ++c) {
    const float a = HalfToFloat(static_cast<uint16_t>(c));
    const float b = HalfToFloat(static_cast<uint16_t>(c + 1));
    const float mid = static_cast<float>(0.5 * (static_cast<double>(a) + b));
    for (float v : {a, mid, std::nextafter(mid, 0.0f), std::nextafter(mid, 1e30f)}) {
      values.push_back(v);
      values.push_back(-v);
    }
  }
  const float inf = std::numeric_limits<float>::infinity();
  for (float v : {65504.0f, 65519.0f, 65520.0f, 65536.0f, 1e30f, inf,
                  std::numeric_limits<float>::quiet_NaN()}) {
    values.push_back(v);
    values.push_back(-v);
  }
  for (uint64_t bits = 1; bits < 0xFFFFFFFFu; bits += 65521) {
    values.push_back(std::bit_cast<float>(static_cast<uint32_t>(bits)));
  }
  for (size_t offset : {size_t{0}, size_t{3}}) {  // the saturated values in various lanes
    const std::span<const float> in = std::span<const float>(values).subspan(offset);
    std::vector<uint16_t> got(in.size());
    FloatsToHalves(in, got);
    for (size_t i = 0; i < in.size(); ++i) ASSERT_EQ(got[i], FloatToHalf(in[i])) << in[i];
  }
}

}  // namespace
}  // namespace shrm::ktx2
