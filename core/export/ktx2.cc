#include "core/export/ktx2.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

#if defined(__F16C__) && defined(__AVX__)
#include <immintrin.h>
#define SHRM_KTX2_F16C 1
#endif

#include "absl/strings/str_cat.h"

namespace shrm::ktx2 {
namespace {

constexpr unsigned char kIdentifier[12] = {0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32,
                                           0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A};
constexpr uint32_t kHeaderBytes = 80;      // identifier + 9 UInt32 + Index
constexpr uint32_t kLevelIndexEntry = 24;  // 3 UInt64 per level
constexpr int kMaxDimension = 1 << 16;
constexpr int kMaxLayers = 1 << 16;
// The largest E5B9G9R9 value: (2^N - 1) / 2^N * 2^(Emax - B) with N = 9, Emax = 31, B = 15.
constexpr double kE5Max = 511.0 / 512.0 * 65536.0;

// Khronos Data Format Specification enumerants.
constexpr uint32_t kDfVersion13 = 2;
constexpr uint32_t kDfModelRgbsda = 1;
constexpr uint32_t kDfPrimariesBt709 = 1;
constexpr uint32_t kDfTransferLinear = 1;
constexpr uint8_t kChannelR = 0, kChannelG = 1, kChannelB = 2, kChannelA = 15;
constexpr uint8_t kQualifierExponent = 0x20, kQualifierSigned = 0x40, kQualifierFloat = 0x80;
constexpr uint32_t kFloatMinusOne = 0xBF800000u, kFloatOne = 0x3F800000u;

struct Sample {
  uint16_t bit_offset;
  uint8_t bits;  // stored as bits - 1
  uint8_t channel_and_qualifiers;
  uint32_t lower;
  uint32_t upper;
};

struct FormatInfo {
  const char* name;
  int channels;
  int block_bytes;
  int type_size;
  bool is_unsigned;
};

FormatInfo Info(Format f) {
  switch (f) {
    case Format::kR16G16Sfloat:
      return {"R16G16_SFLOAT", 2, 4, 2, false};
    case Format::kR16G16B16Sfloat:
      return {"R16G16B16_SFLOAT", 3, 6, 2, false};
    case Format::kR16G16B16A16Sfloat:
      return {"R16G16B16A16_SFLOAT", 4, 8, 2, false};
    case Format::kR32G32Sfloat:
      return {"R32G32_SFLOAT", 2, 8, 4, false};
    case Format::kR32G32B32Sfloat:
      return {"R32G32B32_SFLOAT", 3, 12, 4, false};
    case Format::kR32G32B32A32Sfloat:
      return {"R32G32B32A32_SFLOAT", 4, 16, 4, false};
    case Format::kB10G11R11UfloatPack32:
      return {"B10G11R11_UFLOAT_PACK32", 3, 4, 4, true};
    case Format::kE5B9G9R9UfloatPack32:
      return {"E5B9G9R9_UFLOAT_PACK32", 3, 4, 4, true};
  }
  return {"", 0, 0, 0, false};  // not a supported format
}

// The basic block's samples for `f` (see the header comment).
std::vector<Sample> Samples(Format f) {
  constexpr uint8_t kIds[4] = {kChannelR, kChannelG, kChannelB, kChannelA};
  const FormatInfo info = Info(f);
  std::vector<Sample> s;
  if (f == Format::kB10G11R11UfloatPack32) {
    s.push_back({0, 11, uint8_t(kChannelR | kQualifierFloat), 0, kFloatOne});
    s.push_back({11, 11, uint8_t(kChannelG | kQualifierFloat), 0, kFloatOne});
    s.push_back({22, 10, uint8_t(kChannelB | kQualifierFloat), 0, kFloatOne});
  } else if (f == Format::kE5B9G9R9UfloatPack32) {
    for (int c = 0; c < 3; ++c) {
      s.push_back({uint16_t(9 * c), 9, kIds[c], 0, 8448});
      s.push_back({27, 5, uint8_t(kIds[c] | kQualifierExponent), 15, 31});
    }
  } else {
    const int bits = 8 * info.type_size;
    for (int c = 0; c < info.channels; ++c) {
      s.push_back({uint16_t(bits * c), uint8_t(bits),
                   uint8_t(kIds[c] | kQualifierFloat | kQualifierSigned), kFloatMinusOne,
                   kFloatOne});
    }
  }
  return s;
}

void PutU16(std::string* out, uint16_t v) {
  out->push_back(static_cast<char>(v & 0xFF));
  out->push_back(static_cast<char>(v >> 8));
}
void PutU32(std::string* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void PutU64(std::string* out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}
void PadTo(std::string* out, uint64_t alignment) {
  while (out->size() % alignment != 0) out->push_back('\0');
}

// x / 2^s rounded to the nearest integer, ties to even (s >= 0).
uint32_t ShiftRoundHalfEven(uint32_t x, int s) {
  if (s == 0) return x;
  if (s > 31) return 0;  // x < 2^24 <= 2^(s - 1) for every caller: below one half
  const uint32_t q = x >> s, r = x & ((1u << s) - 1), half = 1u << (s - 1);
  return q + ((r > half || (r == half && (q & 1u))) ? 1u : 0u);
}

// v (finite) as an unsigned float with a 5-bit exponent (bias 15) and `m` mantissa bits: round
// to nearest even, subnormals kept, saturating at the largest finite value. v <= 0 gives 0.
// Integer arithmetic on the float's own bits (exact, independent of the FPU rounding mode).
uint32_t EncodeUnsignedSmallFloat(float v, int m) {
  if (!(v > 0)) return 0;
  const uint32_t one = 1u << m;
  const uint32_t largest = (30u << m) | (one - 1);
  const uint32_t bits = std::bit_cast<uint32_t>(v);
  const int biased_f = static_cast<int>(bits >> 23);  // sign is 0 here
  if (biased_f == 255) return largest;                // +infinity saturates
  // v = x 2^(e - 23), x < 2^24 an integer (with the implicit bit for normal floats).
  const uint32_t x = biased_f == 0 ? (bits & 0x7FFFFFu) : ((bits & 0x7FFFFFu) | 0x800000u);
  int e = biased_f == 0 ? -126 : biased_f - 127;
  if (e < -14) {
    // Subnormal: units of 2^(-14 - m), v / unit = x 2^(e - 23 + 14 + m); a result of 2^m is
    // exactly the smallest normal's bits.
    return ShiftRoundHalfEven(x, 9 - m - e);
  }
  uint32_t n = ShiftRoundHalfEven(x, 23 - m);  // in [2^m, 2^(m+1)]
  if (n == 2 * one) {
    ++e;
    n = one;
  }
  const int biased = e + 15;
  if (biased > 30) return largest;
  return (static_cast<uint32_t>(biased) << m) | (n - one);
}

bool ValidUtf8(std::string_view s) {
  size_t i = 0;
  while (i < s.size()) {
    const auto b = static_cast<unsigned char>(s[i]);
    int extra;
    uint32_t cp;
    if (b < 0x80) {
      ++i;
      continue;
    } else if ((b & 0xE0) == 0xC0) {
      extra = 1;
      cp = b & 0x1F;
    } else if ((b & 0xF0) == 0xE0) {
      extra = 2;
      cp = b & 0x0F;
    } else if ((b & 0xF8) == 0xF0) {
      extra = 3;
      cp = b & 0x07;
    } else {
      return false;
    }
    if (i + extra >= s.size()) return false;  // truncated sequence
    for (int k = 1; k <= extra; ++k) {
      const auto c = static_cast<unsigned char>(s[i + k]);
      if ((c & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (c & 0x3F);
    }
    constexpr uint32_t kMinForLength[4] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMinForLength[extra] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) {
      return false;
    }
    i += extra + 1;
  }
  return true;
}

absl::Status Invalid(std::string message) {
  return absl::InvalidArgumentError(absl::StrCat("KTX2: ", message));
}

absl::Status CheckText(const std::string& what, std::string_view s) {
  if (s.find('\0') != std::string_view::npos) return Invalid(absl::StrCat(what, " contains NUL"));
  if (!ValidUtf8(s)) return Invalid(absl::StrCat(what, " is not valid UTF-8"));
  return absl::OkStatus();
}

// A level's values as given (Level::pixels, or Level::rgb) and the values per texel in them.
std::span<const float> LevelValues(const Level& lv) {
  return lv.rgb.empty() ? std::span<const float>(lv.pixels) : lv.rgb;
}
int ValueStride(const Level& lv, const FormatInfo& info) {
  return lv.rgb.empty() ? info.channels : 3;
}

absl::Status ValidateLayout(const Ktx2Image& im) {
  const FormatInfo info = Info(im.format);
  if (info.channels == 0) {
    return Invalid(absl::StrCat("unsupported format (VkFormat ", uint32_t(im.format), ")"));
  }
  if (im.width < 1 || im.height < 1 || im.width > kMaxDimension || im.height > kMaxDimension) {
    return Invalid(absl::StrCat("image size ", im.width, "x", im.height, " must be within 1..",
                                kMaxDimension));
  }
  if (im.faces != 1 && im.faces != 6) {
    return Invalid(absl::StrCat("faces is ", im.faces, ", must be 1 or 6 (a cube map)"));
  }
  if (im.faces == 6 && im.width != im.height) {
    return Invalid(absl::StrCat("cube map faces must be square, got ", im.width, "x", im.height));
  }
  if (im.layers < 0 || im.layers > kMaxLayers) {
    return Invalid(
        absl::StrCat("layers is ", im.layers, ", must be 0 (not an array) or 1..", kMaxLayers));
  }
  const int max_levels = MaxLevelCount(im.width, im.height);
  if (im.levels.empty()) return Invalid("no levels (level 0 is required)");
  if (static_cast<int>(im.levels.size()) > max_levels) {
    return Invalid(absl::StrCat(im.levels.size(), " levels given, a ", im.width, "x", im.height,
                                " image has at most ", max_levels));
  }
  for (size_t p = 0; p < im.levels.size(); ++p) {
    const Level& lv = im.levels[p];
    const int w = std::max(1, im.width >> p), h = std::max(1, im.height >> p);
    if (lv.width != w || lv.height != h) {
      return Invalid(absl::StrCat("level ", p, " is ", lv.width, "x", lv.height, ", level ", p,
                                  " of a ", im.width, "x", im.height, " image must be ", w, "x",
                                  h));
    }
    if (!lv.rgb.empty() && !lv.pixels.empty()) {
      return Invalid(absl::StrCat("level ", p, " has both pixels and rgb values"));
    }
    if (!lv.rgb.empty() && info.channels < 3) {
      return Invalid(absl::StrCat("level ", p, " has rgb values, but ", info.name, " has ",
                                  info.channels, " channel(s)"));
    }
    const int stride = ValueStride(lv, info);
    const uint64_t expected = uint64_t(std::max(1, im.layers)) * im.faces * w * h * stride;
    if (LevelValues(lv).size() != expected) {
      return Invalid(absl::StrCat(
          "level ", p, " has ", LevelValues(lv).size(), " values, expected ", expected, " (",
          std::max(1, im.layers), " layer(s) x ", im.faces, " face(s) x ", w, "x", h, " x ", stride,
          lv.rgb.empty() ? " channels of " : " rgb values for ", info.name, ")"));
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateKeys(const Ktx2Image& im, const EncodeOptions& options) {
  if (options.writer.empty()) return Invalid("the writer (KTXwriter) is empty");
  if (absl::Status s = CheckText("the writer (KTXwriter)", options.writer); !s.ok()) return s;
  for (const auto& [key, value] : im.key_values) {
    if (key.empty()) return Invalid("an empty key in key_values");
    const std::string_view prefix = std::string_view(key).substr(0, 3);
    if (prefix == "KTX" || prefix == "ktx") {
      return Invalid(absl::StrCat("key '", key, "' is reserved (keys starting KTX/ktx)"));
    }
    if (absl::Status s = CheckText(absl::StrCat("key '", key, "'"), key); !s.ok()) return s;
    if (absl::Status s = CheckText(absl::StrCat("the value of key '", key, "'"), value); !s.ok()) {
      return s;
    }
  }
  return absl::OkStatus();
}

// Names the texel of value index `i` in level `p` for error messages.
std::string Where(const Ktx2Image& im, size_t p, size_t i) {
  const Level& lv = im.levels[p];
  const size_t channels = ValueStride(lv, Info(im.format));
  const size_t t = i / channels, w = lv.width, h = lv.height;
  return absl::StrCat("level ", p, ", layer ", t / (w * h * im.faces), ", face ",
                      (t / (w * h)) % im.faces, ", x ", t % w, ", y ", (t / w) % h, ", channel ",
                      i % channels);
}

// Level p's values against the format's rules (finite; unsigned formats: negatives as
// `negatives` says).
absl::Status CheckLevelValues(const Ktx2Image& im, size_t p, Negatives negatives) {
  const FormatInfo info = Info(im.format);
  const std::span<const float> v = LevelValues(im.levels[p]);
  // First a branch-free pass the compiler vectorizes (an exponent of all ones: NaN or infinity;
  // a set sign bit below zero where negatives are refused); the value-by-value loop that names
  // the first offender runs only when it found one (the early exits kept it scalar: ~0.5 ms of
  // an ibl run).
  const bool refuse_negatives = info.is_unsigned && negatives == Negatives::kReject;
  uint32_t offending = 0;
  for (const float x : v) {
    uint32_t bits;
    std::memcpy(&bits, &x, sizeof(bits));
    offending |= static_cast<uint32_t>((bits & 0x7F800000u) == 0x7F800000u) |
                 static_cast<uint32_t>(refuse_negatives & (x < 0));
  }
  if (offending == 0) return absl::OkStatus();
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) {
      return Invalid(absl::StrCat(std::isnan(v[i]) ? "NaN" : "infinity", " at ", Where(im, p, i),
                                  " (", info.name, " stores finite values only)"));
    }
    if (info.is_unsigned && v[i] < 0 && negatives == Negatives::kReject) {
      return Invalid(absl::StrCat("negative value ", v[i], " at ", Where(im, p, i), " (", info.name,
                                  " is unsigned; EncodeOptions::negatives can clamp to 0)"));
    }
  }
  return absl::OkStatus();
}

// The size of level p's bytes (the levelImages of "Mip Level Array").
size_t LevelBytes(const Ktx2Image& im, size_t p) {
  const FormatInfo info = Info(im.format);
  const Level& lv = im.levels[p];
  return LevelValues(lv).size() / ValueStride(lv, info) * info.block_bytes;
}
// Values of `format` (ChannelCount(format) per texel) appended to `out`.
void AppendValues(Format format, std::span<const float> v, std::string* out_ptr) {
  std::string& out = *out_ptr;
  const size_t texels = v.size() / Info(format).channels;
  switch (format) {
    case Format::kR16G16Sfloat:
    case Format::kR16G16B16Sfloat:
    case Format::kR16G16B16A16Sfloat: {
      // Little-endian 16-bit codes, a block of values at a time.
      std::array<uint16_t, 1024> halves;
      for (size_t i = 0; i < v.size(); i += halves.size()) {
        const std::span<const float> part =
            std::span<const float>(v).subspan(i, std::min(halves.size(), v.size() - i));
        FloatsToHalves(part, halves);
        if constexpr (std::endian::native == std::endian::little) {
          out.append(reinterpret_cast<const char*>(halves.data()), part.size() * sizeof(uint16_t));
        } else {
          for (size_t k = 0; k < part.size(); ++k) PutU16(&out, halves[k]);
        }
      }
      break;
    }
    case Format::kR32G32Sfloat:
    case Format::kR32G32B32Sfloat:
    case Format::kR32G32B32A32Sfloat:
      for (float x : v) {
        uint32_t bits;
        std::memcpy(&bits, &x, sizeof(bits));
        PutU32(&out, bits);
      }
      break;
    case Format::kB10G11R11UfloatPack32:
      for (size_t t = 0; t < texels; ++t) {
        PutU32(&out, PackB10G11R11(v[3 * t], v[3 * t + 1], v[3 * t + 2]));
      }
      break;
    case Format::kE5B9G9R9UfloatPack32:
      for (size_t t = 0; t < texels; ++t) {
        PutU32(&out, PackE5B9G9R9(v[3 * t], v[3 * t + 1], v[3 * t + 2]));
      }
      break;
  }
}

// Level p's bytes appended to `out`, whose capacity the caller has reserved: the file is made in
// one buffer, without a buffer and a copy per level. Its values must have passed
// CheckLevelValues.
void AppendLevel(const Ktx2Image& im, size_t p, std::string* out_ptr) {
  const Level& lv = im.levels[p];
  if (lv.rgb.empty() || Info(im.format).channels == 3) {
    AppendValues(im.format, LevelValues(lv), out_ptr);
    return;
  }
  // RGB triples of a four-channel format: each run of texels widened (alpha 1) and appended.
  constexpr size_t kRun = 256;
  std::array<float, 4 * kRun> run;
  const size_t texels = lv.rgb.size() / 3;
  for (size_t first = 0; first < texels; first += kRun) {
    const size_t n = std::min(kRun, texels - first);
    const float* in = lv.rgb.data() + 3 * first;
    for (size_t t = 0; t < n; ++t) {
      run[4 * t] = in[3 * t];
      run[4 * t + 1] = in[3 * t + 1];
      run[4 * t + 2] = in[3 * t + 2];
      run[4 * t + 3] = 1.0f;
    }
    AppendValues(im.format, std::span<const float>(run).first(4 * n), out_ptr);
  }
}

// One Key/Value Data entry: keyAndValueByteLength, key NUL value NUL, valuePadding.
void PutKeyValue(std::string* out, std::string_view key, std::string_view value) {
  PutU32(out, static_cast<uint32_t>(key.size() + 1 + value.size() + 1));
  out->append(key);
  out->push_back('\0');
  out->append(value);
  out->push_back('\0');
  PadTo(out, 4);  // the KVD starts 4-aligned, so this aligns the file offset
}

}  // namespace

int ChannelCount(Format format) { return Info(format).channels; }
int TexelBlockBytes(Format format) { return Info(format).block_bytes; }
int TypeSize(Format format) { return Info(format).type_size; }
std::string_view FormatName(Format format) { return Info(format).name; }

int MaxLevelCount(int width, int height) {
  int m = std::max(width, height), n = 0;
  while (m > 0) {
    ++n;
    m >>= 1;
  }
  return n;
}

bool IsValidUtf8(std::string_view s) { return ValidUtf8(s); }

uint16_t FloatToHalf(float value) {
  // EncodeUnsignedSmallFloat(|value|, 10) with the sign, by integer arithmetic on the float's
  // bits (the chain's storage rounding converts millions of values per job).
  const uint32_t bits = std::bit_cast<uint32_t>(value);
  const auto sign = static_cast<uint16_t>((bits >> 16) & 0x8000u);
  const uint32_t a = bits & 0x7FFFFFFFu;
  if (a >= 0x477FF000u) {  // |value| >= 65520 (rounds past 65504), infinity or NaN
    return a > 0x7F800000u ? sign : static_cast<uint16_t>(sign | 0x7BFFu);  // NaN: 0; else clamp
  }
  if (a < 0x38800000u) {  // below 2^-14: a subnormal half (or 0)
    // 0.5 has a float ulp of 2^-24, the half subnormal's unit: the addition rounds |value| to a
    // multiple of it, half to even, and the difference of the bits counts the units (1024 is the
    // smallest normal's encoding, where a value rounds up to it).
    const float t = std::bit_cast<float>(a) + 0.5f;
    return static_cast<uint16_t>(sign | (std::bit_cast<uint32_t>(t) - 0x3F000000u));
  }
  // Normal: rebias the exponent (127 -> 15) and drop 13 mantissa bits, half to even (adding
  // 0xFFF plus the kept bits' lowest bit); a carry out of the mantissa increments the exponent.
  const uint32_t r = a - (112u << 23) + 0xFFFu + ((a >> 13) & 1u);
  return static_cast<uint16_t>(sign | (r >> 13));
}

uint32_t PackB10G11R11(float r, float g, float b) {
  return EncodeUnsignedSmallFloat(r, 6) | (EncodeUnsignedSmallFloat(g, 6) << 11) |
         (EncodeUnsignedSmallFloat(b, 5) << 22);
}

uint32_t PackE5B9G9R9(float r, float g, float b) {
  // Vulkan specification, "Shared Exponent": N = 9 mantissa bits, B = 15, Emax = 31.
  constexpr int kN = 9, kB = 15;
  auto clamp = [](float x) { return x > 0 ? std::min(static_cast<double>(x), kE5Max) : 0.0; };
  const double rc = clamp(r), gc = clamp(g), bc = clamp(b);
  const double max_c = std::max({rc, gc, bc});
  int floor_log2 = -kB - 1;  // max(-B - 1, floor(log2(max_c))), log2(0) = -infinity
  if (max_c > 0) {
    int e2 = 0;
    std::frexp(max_c, &e2);
    floor_log2 = std::max(floor_log2, e2 - 1);
  }
  int exp_shared = floor_log2 + 1 + kB;
  const auto max_s =
      static_cast<int>(std::floor(max_c / std::ldexp(1.0, exp_shared - kB - kN) + 0.5));
  if (max_s == (1 << kN)) ++exp_shared;
  const double scale = std::ldexp(1.0, exp_shared - kB - kN);
  auto mantissa = [&](double x) { return static_cast<uint32_t>(std::floor(x / scale + 0.5)); };
  return (static_cast<uint32_t>(exp_shared) << 27) | (mantissa(bc) << 18) | (mantissa(gc) << 9) |
         mantissa(rc);
}

namespace {

// An unsigned float with 5 exponent bits (bias 15) and `mantissa_bits` bits.
float DecodeUnsignedSmallFloat(uint32_t bits, int mantissa_bits) {
  const uint32_t e = bits >> mantissa_bits, m = bits & ((1u << mantissa_bits) - 1);
  if (e == 0) {  // m 2^(-14 - mantissa_bits): exact in float (m < 2^11, the scale a power of 2)
    return static_cast<float>(m) *
           std::bit_cast<float>(static_cast<uint32_t>(127 - 14 - mantissa_bits) << 23);
  }
  if (e == 31)
    return m == 0 ? std::numeric_limits<float>::infinity()
                  : std::numeric_limits<float>::quiet_NaN();
  // A normal float with the same exponent and the mantissa's bits at the top of its 23.
  return std::bit_cast<float>(((e - 15 + 127) << 23) | (m << (23 - mantissa_bits)));
}

}  // namespace

float HalfToFloat(uint16_t bits) {
  const float v = DecodeUnsignedSmallFloat(bits & 0x7FFFu, 10);
  return (bits & 0x8000u) ? -v : v;
}

void UnpackB10G11R11(uint32_t packed, float rgb[3]) {
  rgb[0] = DecodeUnsignedSmallFloat(packed & 0x7FFu, 6);
  rgb[1] = DecodeUnsignedSmallFloat((packed >> 11) & 0x7FFu, 6);
  rgb[2] = DecodeUnsignedSmallFloat(packed >> 22, 5);
}

void UnpackE5B9G9R9(uint32_t packed, float rgb[3]) {
  const double scale = std::ldexp(1.0, static_cast<int>(packed >> 27) - 15 - 9);
  rgb[0] = static_cast<float>((packed & 0x1FFu) * scale);
  rgb[1] = static_cast<float>(((packed >> 9) & 0x1FFu) * scale);
  rgb[2] = static_cast<float>(((packed >> 18) & 0x1FFu) * scale);
}

void FloatsToHalves(std::span<const float> in, std::span<uint16_t> out) {
  size_t i = 0;
#ifdef SHRM_KTX2_F16C
  const __m256 limit = _mm256_set1_ps(65504.0f);
  const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7FFFFFFF));
  for (; i + 8 <= in.size(); i += 8) {
    const __m256 v = _mm256_loadu_ps(in.data() + i);
    // |v| <= 65504 is false for NaN and infinities too: those vectors go the scalar way below.
    const __m256 ok = _mm256_cmp_ps(_mm256_and_ps(v, abs_mask), limit, _CMP_LE_OQ);
    if (_mm256_movemask_ps(ok) != 0xFF) {
      for (size_t k = i; k < i + 8; ++k) out[k] = FloatToHalf(in[k]);
      continue;
    }
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out.data() + i),
                     _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
  }
#endif
  for (; i < in.size(); ++i) out[i] = FloatToHalf(in[i]);
}

void HalvesToFloats(std::span<const uint16_t> in, std::span<float> out) {
  size_t i = 0;
#ifdef SHRM_KTX2_F16C
  for (; i + 8 <= in.size(); i += 8) {
    _mm256_storeu_ps(
        out.data() + i,
        _mm256_cvtph_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(in.data() + i))));
  }
#endif
  for (; i < in.size(); ++i) out[i] = HalfToFloat(in[i]);
}

void RoundTrip(Format format, float* values) {
  switch (format) {
    case Format::kR16G16Sfloat:
    case Format::kR16G16B16Sfloat:
    case Format::kR16G16B16A16Sfloat:
      for (int c = 0; c < ChannelCount(format); ++c)
        values[c] = HalfToFloat(FloatToHalf(values[c]));
      break;
    case Format::kB10G11R11UfloatPack32:
      UnpackB10G11R11(PackB10G11R11(values[0], values[1], values[2]), values);
      break;
    case Format::kE5B9G9R9UfloatPack32:
      UnpackE5B9G9R9(PackE5B9G9R9(values[0], values[1], values[2]), values);
      break;
    default:
      break;  // 32-bit floats are stored as they are
  }
}

void RoundTripRgb(Format format, std::span<float> rgb) {
  switch (format) {
    case Format::kR16G16B16Sfloat:
    case Format::kR16G16B16A16Sfloat: {
      std::array<uint16_t, 1024> halves;
      for (size_t i = 0; i < rgb.size(); i += halves.size()) {
        const std::span<float> part = rgb.subspan(i, std::min(halves.size(), rgb.size() - i));
        FloatsToHalves(part, halves);
        HalvesToFloats(std::span(halves).first(part.size()), part);
      }
      break;
    }
    case Format::kB10G11R11UfloatPack32:
    case Format::kE5B9G9R9UfloatPack32:
    case Format::kR16G16Sfloat:  // (R and G stored; B as it is)
      for (size_t i = 0; i + 3 <= rgb.size(); i += 3) RoundTrip(format, &rgb[i]);
      break;
    default:  // 32-bit floats are stored as they are
      break;
  }
}

absl::StatusOr<std::string> EncodeKtx2(const Ktx2Image& image, const EncodeOptions& options) {
  if (absl::Status s = ValidateLayout(image); !s.ok()) return s;
  if (absl::Status s = ValidateKeys(image, options); !s.ok()) return s;
  const FormatInfo info = Info(image.format);
  const size_t num_levels = image.levels.size();

  std::vector<size_t> level_bytes(num_levels);
  for (size_t p = 0; p < num_levels; ++p) {
    if (absl::Status s = CheckLevelValues(image, p, options.negatives); !s.ok()) return s;
    level_bytes[p] = LevelBytes(image, p);
  }

  // Data Format Descriptor: dfdTotalSize, then one basic descriptor block.
  const std::vector<Sample> samples = Samples(image.format);
  std::string dfd;
  const auto block_size = static_cast<uint32_t>(24 + 16 * samples.size());
  PutU32(&dfd, 4 + block_size);
  PutU32(&dfd, 0);  // vendorId KHRONOS (0), descriptorType BASICFORMAT (0)
  PutU32(&dfd, kDfVersion13 | (block_size << 16));
  PutU32(&dfd, kDfModelRgbsda | (kDfPrimariesBt709 << 8) | (kDfTransferLinear << 16));  // flags 0
  PutU32(&dfd, 0);                                        // texelBlockDimension0..3: 1x1x1x1
  PutU32(&dfd, static_cast<uint32_t>(info.block_bytes));  // bytesPlane0; planes 1..3 = 0
  PutU32(&dfd, 0);                                        // bytesPlane4..7
  for (const Sample& s : samples) {
    PutU32(&dfd, s.bit_offset | (uint32_t(s.bits - 1) << 16) |
                     (uint32_t(s.channel_and_qualifiers) << 24));
    PutU32(&dfd, 0);  // samplePosition0..3
    PutU32(&dfd, s.lower);
    PutU32(&dfd, s.upper);
  }

  // Key/Value Data, sorted by key bytes (unsigned: the UTF-8 order of code points).
  std::vector<std::pair<std::string_view, std::string_view>> kv = {{"KTXorientation", "rd"},
                                                                   {"KTXwriter", options.writer}};
  for (const auto& [key, value] : image.key_values) kv.emplace_back(key, value);
  std::sort(kv.begin(), kv.end(), [](const auto& a, const auto& b) {
    return std::lexicographical_compare(
        a.first.begin(), a.first.end(), b.first.begin(), b.first.end(), [](char x, char y) {
          return static_cast<unsigned char>(x) < static_cast<unsigned char>(y);
        });
  });
  std::string kvd;
  for (const auto& [key, value] : kv) PutKeyValue(&kvd, key, value);

  const uint64_t dfd_offset = kHeaderBytes + kLevelIndexEntry * num_levels;
  const uint64_t kvd_offset = dfd_offset + dfd.size();
  const uint64_t alignment = std::lcm(uint64_t(info.block_bytes), uint64_t{4});
  // Level offsets: smallest level first, each after mipPadding to `alignment`.
  std::vector<uint64_t> offsets(num_levels);
  uint64_t end = kvd_offset + kvd.size();
  for (size_t p = num_levels; p-- > 0;) {
    end = (end + alignment - 1) / alignment * alignment;
    offsets[p] = end;
    end += level_bytes[p];
  }

  std::string out;
  out.reserve(end);
  out.append(reinterpret_cast<const char*>(kIdentifier), sizeof(kIdentifier));
  PutU32(&out, static_cast<uint32_t>(image.format));
  PutU32(&out, static_cast<uint32_t>(info.type_size));
  PutU32(&out, static_cast<uint32_t>(image.width));
  PutU32(&out, static_cast<uint32_t>(image.height));
  PutU32(&out, 0);  // pixelDepth
  PutU32(&out, static_cast<uint32_t>(image.layers));
  PutU32(&out, static_cast<uint32_t>(image.faces));
  PutU32(&out, static_cast<uint32_t>(num_levels));
  PutU32(&out, 0);  // supercompressionScheme: none
  PutU32(&out, static_cast<uint32_t>(dfd_offset));
  PutU32(&out, static_cast<uint32_t>(dfd.size()));
  PutU32(&out, static_cast<uint32_t>(kvd_offset));
  PutU32(&out, static_cast<uint32_t>(kvd.size()));
  PutU64(&out, 0);  // sgdByteOffset
  PutU64(&out, 0);  // sgdByteLength
  for (size_t p = 0; p < num_levels; ++p) {
    PutU64(&out, offsets[p]);
    PutU64(&out, level_bytes[p]);  // byteLength
    PutU64(&out, level_bytes[p]);  // uncompressedByteLength
  }
  out += dfd;
  out += kvd;
  for (size_t p = num_levels; p-- > 0;) {
    out.resize(offsets[p], '\0');  // mipPadding
    AppendLevel(image, p, &out);
  }
  return out;
}

}  // namespace shrm::ktx2
