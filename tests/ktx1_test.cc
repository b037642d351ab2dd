// KTX 1.1 cube writer (core/export/ktx1.h) against an independent reader written here from the
// KTX File Format Specification 1.1 ("File Structure": identifier, endianness, the header
// fields, keyAndValueByteSize / valuePadding, imageSize, cubePadding, mipPadding; "Cubemap"
// rules: imageSize is the size of one face for a non-array cube map), the OpenGL enumerant
// values of the OpenGL 4.6 / ES 3.0 headers, and texel decoders from the specifications; plus
// CubeInFrame (core/base/cubemap.h) against directions computed here.
#include "core/export/ktx1.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "core/base/cubemap.h"
#include "gtest/gtest.h"
#include "tests/float_decoders.h"

namespace shrm::ktx1 {
namespace {

using ::shrm::testing::DecodeB10G11R11;
using ::shrm::testing::ImathHalfToFloat;

// Tolerances of the decoded values, relative (and absolute near 0).
constexpr double kHalfRel = 0x1p-11;   // half: round to 10 mantissa bits, half an ulp
constexpr double kUfloatRel = 0x1p-6;  // 10/11-bit ufloat: 5 (blue) mantissa bits, half an ulp
constexpr double kAbsFloor = 0x1p-20;  // subnormal quanta of the packed formats
constexpr double kExactFloat = 0.0;    // RGB32F stores the float itself

// The OpenGL enumerants (glcorearb.h / gl3.h).
constexpr uint32_t GL_HALF_FLOAT = 0x140B, GL_FLOAT = 0x1406, GL_RGB = 0x1907, GL_RGB16F = 0x881B,
                   GL_RGB32F = 0x8815, GL_R11F_G11F_B10F = 0x8C3A;

// --- an independent KTX 1.1 reader (little endian, bounds checked) ------------------------------
struct Parsed {
  uint32_t header[13] = {};                             // endianness .. bytesOfKeyValueData
  std::vector<std::pair<std::string, std::string>> kv;  // in file order; value without its NUL
  std::vector<bool> value_nul_terminated;
  // faces[level][face] = the face's bytes.
  std::vector<std::vector<std::string>> faces;
  std::vector<uint32_t> image_size;
};

uint32_t U32(const std::string& b, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(uint8_t(b.at(at + i))) << (8 * i);
  return v;
}

Parsed Parse(const std::string& b) {
  Parsed p;
  const unsigned char id[12] = {0xAB, 'K', 'T', 'X', ' ', '1', '1', 0xBB, '\r', '\n', 0x1A, '\n'};
  EXPECT_EQ(std::memcmp(b.data(), id, 12), 0) << "identifier";
  for (int i = 0; i < 13; ++i) p.header[i] = U32(b, 12 + 4 * i);
  size_t at = 64;
  const size_t kv_end = at + p.header[12];
  while (at < kv_end) {
    const uint32_t size = U32(b, at);
    at += 4;
    const std::string entry = b.substr(at, size);
    const size_t nul = entry.find('\0');
    EXPECT_NE(nul, std::string::npos) << "key without NUL";
    std::string value = entry.substr(nul + 1);
    const bool terminated = !value.empty() && value.back() == '\0';
    if (terminated) value.pop_back();
    p.kv.emplace_back(entry.substr(0, nul), value);
    p.value_nul_terminated.push_back(terminated);
    at += size;
    const size_t padding = 3 - ((size + 3) % 4);  // valuePadding
    for (size_t i = 0; i < padding; ++i) EXPECT_EQ(b.at(at + i), '\0') << "valuePadding";
    at += padding;
  }
  EXPECT_EQ(at, kv_end) << "key/value data length";
  const uint32_t faces = p.header[10], levels = std::max(1u, p.header[11]);
  for (uint32_t level = 0; level < levels; ++level) {
    const uint32_t image_size = U32(b, at);
    p.image_size.push_back(image_size);
    at += 4;
    std::vector<std::string> level_faces;
    for (uint32_t f = 0; f < faces; ++f) {
      level_faces.push_back(b.substr(at, image_size));
      at += image_size;
      const size_t cube_padding = 3 - ((image_size + 3) % 4);
      for (size_t i = 0; i < cube_padding; ++i) EXPECT_EQ(b.at(at + i), '\0') << "cubePadding";
      at += cube_padding;
    }
    EXPECT_EQ(at % 4, 0u) << "mipPadding";
    p.faces.push_back(level_faces);
  }
  EXPECT_EQ(at, b.size()) << "bytes after the last level";
  return p;
}

std::string ValueOf(const Parsed& p, const std::string& key) {
  for (const auto& [k, v] : p.kv)
    if (k == key) return v;
  ADD_FAILURE() << "no key " << key;
  return "";
}

// Texel t of a face's bytes, decoded as the header's glType says.
std::array<double, 3> Texel(const Parsed& p, const std::string& face, size_t t) {
  std::array<double, 3> v{};
  switch (p.header[1]) {  // glType
    case GL_HALF_FLOAT:
      for (int c = 0; c < 3; ++c) {
        uint16_t bits = uint16_t(uint8_t(face[t * 6 + 2 * c])) |
                        uint16_t(uint8_t(face[t * 6 + 2 * c + 1])) << 8;
        v[c] = ImathHalfToFloat(bits);
      }
      return v;
    case GL_FLOAT:
      for (int c = 0; c < 3; ++c) {
        float f;
        std::memcpy(&f, face.data() + t * 12 + 4 * c, 4);
        v[c] = f;
      }
      return v;
    default:
      return DecodeB10G11R11(U32(face, t * 4));
  }
}

// A deterministic cube: non-negative values over [0, 2e3], a few exact zeros and -0.0.
Ktx1Cube MakeCube(Format f, int size, int levels) {
  Ktx1Cube cube;
  cube.format = f;
  uint32_t state = 12345;
  for (int k = 0; k < levels; ++k) {
    CubeLevel l;
    l.size = std::max(1, size >> k);
    l.pixels.resize(size_t(6) * l.size * l.size * 3);
    for (size_t i = 0; i < l.pixels.size(); ++i) {
      state = state * 1664525u + 1013904223u;
      const double u = (state >> 8) / double(1 << 24);
      l.pixels[i] = i % 97 == 0 ? 0.0f : i % 89 == 0 ? -0.0f : float(std::pow(10.0, 6 * u - 3) * 2);
    }
    cube.levels.push_back(std::move(l));
  }
  cube.key_values["sh"] = "0.5 0.25 0.125\n";
  cube.key_values["shrm:content"] = "test";
  return cube;
}

void CheckRoundTrip(Format f, int size, int levels, uint32_t gl_type, uint32_t type_size,
                    uint32_t internal, int texel_bytes, double rel) {
  SCOPED_TRACE(FormatName(f));
  const Ktx1Cube cube = MakeCube(f, size, levels);
  absl::StatusOr<std::string> bytes = EncodeKtx1Cube(cube, "shrm test");
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  const Parsed p = Parse(*bytes);
  EXPECT_EQ(p.header[0], 0x04030201u) << "endianness";
  EXPECT_EQ(p.header[1], gl_type) << "glType";
  EXPECT_EQ(p.header[2], type_size) << "glTypeSize";
  EXPECT_EQ(p.header[3], GL_RGB) << "glFormat";
  EXPECT_EQ(p.header[4], internal) << "glInternalFormat";
  EXPECT_EQ(p.header[5], GL_RGB) << "glBaseInternalFormat";
  EXPECT_EQ(p.header[6], uint32_t(size)) << "pixelWidth";
  EXPECT_EQ(p.header[7], uint32_t(size)) << "pixelHeight";
  EXPECT_EQ(p.header[8], 0u) << "pixelDepth";
  EXPECT_EQ(p.header[9], 0u) << "numberOfArrayElements";
  EXPECT_EQ(p.header[10], 6u) << "numberOfFaces";
  EXPECT_EQ(p.header[11], uint32_t(levels)) << "numberOfMipmapLevels";
  // Keys sorted, every value NUL-terminated; the orientation of a GL cube map's faces.
  for (size_t i = 1; i < p.kv.size(); ++i) EXPECT_LT(p.kv[i - 1].first, p.kv[i].first);
  for (bool t : p.value_nul_terminated) EXPECT_TRUE(t);
  EXPECT_EQ(ValueOf(p, "KTXorientation"), "S=r,T=d");
  EXPECT_EQ(ValueOf(p, "KTXwriter"), "shrm test");
  EXPECT_EQ(ValueOf(p, "sh"), "0.5 0.25 0.125\n");
  ASSERT_EQ(p.faces.size(), size_t(levels));
  for (int k = 0; k < levels; ++k) {
    const int n = std::max(1, size >> k);
    EXPECT_EQ(p.image_size[k], uint32_t(n * n * texel_bytes))
        << "imageSize = one face, level " << k;
    for (int face = 0; face < 6; ++face) {
      for (int t = 0; t < n * n; ++t) {
        const std::array<double, 3> got = Texel(p, p.faces[k][face], t);
        for (int c = 0; c < 3; ++c) {
          const double want = cube.levels[k].pixels[(size_t(face) * n * n + t) * 3 + c];
          ASSERT_LE(std::abs(got[c] - want), rel * std::abs(want) + (rel > 0 ? kAbsFloor : 0))
              << "level " << k << " face " << face << " texel " << t << " channel " << c;
          ASSERT_FALSE(std::signbit(got[c])) << "-0.0 must be stored as +0";
        }
      }
    }
  }
}

TEST(Ktx1Test, R11fG11fB10fAsCmgenWritesIt) {
  // glType is GL_R11F_G11F_B10F, the value Filament's Ktx1Reader requires (ktx1.h).
  CheckRoundTrip(Format::kR11fG11fB10f, 16, 5, GL_R11F_G11F_B10F, 4, GL_R11F_G11F_B10F, 4,
                 kUfloatRel);
}

TEST(Ktx1Test, Rgb16f) {
  CheckRoundTrip(Format::kRgb16f, 8, 4, GL_HALF_FLOAT, 2, GL_RGB16F, 6, kHalfRel);
}

TEST(Ktx1Test, Rgb32fIsExact) {
  CheckRoundTrip(Format::kRgb32f, 4, 3, GL_FLOAT, 4, GL_RGB32F, 12, kExactFloat);
}

TEST(Ktx1Test, OneTexelHalfFacesArePaddedToFourBytes) {
  // A 1 x 1 RGB16F face is 6 bytes: cubePadding 2 (the parser checks the zeros and the length).
  const Ktx1Cube cube = MakeCube(Format::kRgb16f, 1, 1);
  absl::StatusOr<std::string> bytes = EncodeKtx1Cube(cube, "w");
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  const Parsed p = Parse(*bytes);
  EXPECT_EQ(p.image_size[0], 6u);
  EXPECT_EQ(bytes->size() % 4, 0u);
}

TEST(Ktx1Test, BadInputIsRefusedWithItsPlaceNamed) {
  auto error = [](const Ktx1Cube& c) {
    absl::StatusOr<std::string> b = EncodeKtx1Cube(c, "w");
    EXPECT_FALSE(b.ok());
    return b.ok() ? std::string() : std::string(b.status().message());
  };
  Ktx1Cube none;
  EXPECT_NE(error(none).find("no levels"), std::string::npos);
  Ktx1Cube c = MakeCube(Format::kRgb16f, 4, 2);
  c.levels[1].size = 4;
  EXPECT_NE(error(c).find("level 1 has face size 4, expected 2"), std::string::npos);
  c = MakeCube(Format::kRgb16f, 4, 2);
  c.levels[1].pixels.pop_back();
  EXPECT_NE(error(c).find("level 1 has"), std::string::npos);
  c = MakeCube(Format::kRgb16f, 4, 1);
  c.levels[0].pixels[(size_t(2) * 16 + 4 * 1 + 3) * 3 + 1] = NAN;  // +Y, texel (3, 1), green
  EXPECT_NE(error(c).find("level 0 face py texel (3, 1) channel 1"), std::string::npos);
  c.levels[0].pixels[(size_t(2) * 16 + 4 * 1 + 3) * 3 + 1] = -1e-3f;
  EXPECT_NE(error(c).find(">= 0"), std::string::npos);
  c = MakeCube(Format::kRgb16f, 4, 4);
  EXPECT_NE(error(c).find("at most 3"), std::string::npos);
  c = MakeCube(Format::kRgb16f, 4, 1);
  c.key_values["KTXorientation"] = "S=l,T=u";
  EXPECT_NE(error(c).find("reserved"), std::string::npos);
}

// --- CubeInFrame -----------------------------------------------------------------------------

// A cube whose texels hold their own direction.
std::vector<float> DirectionCube(int size) {
  std::vector<float> c(size_t(6) * size * size * 3);
  for (int f = 0; f < 6; ++f)
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const Vec3 d = CubeTexelDirection(f, x, y, size);
        const size_t i = ((size_t(f) * size + y) * size + x) * 3;
        c[i] = float(d.x), c[i + 1] = float(d.y), c[i + 2] = float(d.z);
      }
  return c;
}

TEST(CubeInFrameTest, EveryTexelHoldsTheWorldDirectionOfItsFrameDirection) {
  constexpr double kTol = 1e-6;  // float storage of unit vectors
  const int n = 8;
  const std::vector<float> src = DirectionCube(n);
  // Filament's frame (core/ibl/sh9.h): n = (-x, y, -z); and a 90 degree turn about +Y with a
  // mirror (an improper signed permutation): n = (z, y, x).
  const Mat3 frames[] = {Mat3{{{{-1, 0, 0}, {0, 1, 0}, {0, 0, -1}}}},
                         Mat3{{{{0, 0, 1}, {0, 1, 0}, {1, 0, 0}}}}, Mat3::Identity()};
  for (const Mat3& m : frames) {
    std::vector<float> dst(src.size(), -9);
    ASSERT_TRUE(CubeInFrame(m, n, 3, src.data(), dst.data()));
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const Vec3 frame_dir = CubeTexelDirection(f, x, y, n);
          // world d with M d = frame_dir, written out: d_j = sum_i M_ij frame_dir_i.
          const double fd[3] = {frame_dir.x, frame_dir.y, frame_dir.z};
          double d[3] = {0, 0, 0};
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) d[j] += m.m[i][j] * fd[i];
          const size_t i = ((size_t(f) * n + y) * n + x) * 3;
          for (int c = 0; c < 3; ++c)
            ASSERT_NEAR(dst[i + c], d[c], kTol) << f << " " << x << " " << y;
        }
  }
  const Mat3 not_axes{{{{0.6, 0.8, 0}, {-0.8, 0.6, 0}, {0, 0, 1}}}};
  std::vector<float> dst(src.size(), 7);
  EXPECT_FALSE(CubeInFrame(not_axes, n, 3, src.data(), dst.data()));
  EXPECT_EQ(dst.front(), 7);
}

}  // namespace
}  // namespace shrm::ktx1
