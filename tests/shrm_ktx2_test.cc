// The SHRM in KTX2 (core/export/shrm_ktx2.h, docs/formats.md "SHRM in KTX2"): the bytes read
// back by a parser written here from the KTX 2.0 specification (header fields, level index, the
// level's layer/face/row order), the half-float variant against OpenEXR's own half conversion (the
// EXR container of the same cube), and clear errors for every damaged or foreign file, never a
// crash. The shaders that consume these files are tested in tests/viewer_render_test.cc (GLSL)
// and tests/engines (WGSL in Chromium's WebGPU).
#include "core/export/shrm_ktx2.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_shader_params.h"
#include "core/io/atomic_file.h"
#include "core/shrm/shrm_file.h"
#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

std::string Temp(const std::string& name) { return testing::UniqueTempPath("shrm_ktx2_" + name); }

ShrmCube MakeCube(int pmax, int size, ShrmKind kind) {
  ShrmCube c;
  c.kind = kind;
  c.face_size = size;
  c.pmax = pmax;
  c.data.resize(c.size());
  for (size_t i = 0; i < c.data.size(); ++i) c.data[i] = std::cos(0.37 * i) * (i % 7 + 1) - 2.0f;
  return c;
}

uint32_t U32(const std::string& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
uint64_t U64(const std::string& b, size_t at) {
  uint64_t v;
  std::memcpy(&v, b.data() + at, 8);
  return v;
}

// The KTX 2.0 header ("File Structure"): identifier (12 bytes), then nine uint32 fields, the
// index (dfd offset/length, kvd offset/length: uint32; sgd offset/length: uint64) and the level
// index (byteOffset, byteLength, uncompressedByteLength: uint64 per level).
struct Header {
  uint32_t vk_format, type_size, width, height, depth, layers, faces, levels, scheme;
  uint32_t kvd_offset, kvd_length;
  uint64_t level_offset, level_length;
};
Header ParseHeader(const std::string& b) {
  Header h;
  h.vk_format = U32(b, 12);
  h.type_size = U32(b, 16);
  h.width = U32(b, 20);
  h.height = U32(b, 24);
  h.depth = U32(b, 28);
  h.layers = U32(b, 32);
  h.faces = U32(b, 36);
  h.levels = U32(b, 40);
  h.scheme = U32(b, 44);
  h.kvd_offset = U32(b, 56);
  h.kvd_length = U32(b, 60);
  h.level_offset = U64(b, 80);
  h.level_length = U64(b, 88);
  return h;
}

// The value of key `key` in the Key/Value Data ("" when absent).
std::string KeyValue(const std::string& b, const Header& h, const std::string& key) {
  for (size_t at = h.kvd_offset; at + 4 <= h.kvd_offset + h.kvd_length;) {
    const uint32_t len = U32(b, at);
    const std::string entry = b.substr(at + 4, len);
    const size_t nul = entry.find('\0');
    if (entry.substr(0, nul) == key) return entry.substr(nul + 1, entry.size() - nul - 2);
    at += 4 + (len + 3) / 4 * 4;
  }
  return "";
}

TEST(ShrmKtx2Test, LayerKIsCoefficientKOfEveryFaceRowMajor) {
  const ShrmCube c = MakeCube(2, 3, ShrmKind::kGlobal);
  absl::StatusOr<std::string> bytes =
      EncodeShrmKtx2("t.ktx2", c, {{"shrm:brdf", "phong:s=8"}}, false);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  const std::string& b = *bytes;
  const Header h = ParseHeader(b);
  EXPECT_EQ(h.vk_format, 109u);  // VK_FORMAT_R32G32B32A32_SFLOAT
  EXPECT_EQ(h.type_size, 4u);
  EXPECT_EQ(h.width, 3u);
  EXPECT_EQ(h.height, 3u);
  EXPECT_EQ(h.depth, 0u);
  EXPECT_EQ(h.layers, 9u);  // (P + 1)^2
  EXPECT_EQ(h.faces, 6u);
  EXPECT_EQ(h.levels, 1u);
  EXPECT_EQ(h.scheme, 0u);
  ASSERT_EQ(h.level_length, uint64_t{9} * 6 * 3 * 3 * 16);
  ASSERT_LE(h.level_offset + h.level_length, b.size());
  for (int k = 0; k < 9; ++k)
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 3; ++x) {
          const size_t texel = h.level_offset + (((k * 6 + f) * 3 + y) * 3 + x) * 16;
          float rgba[4];
          std::memcpy(rgba, b.data() + texel, 16);
          for (int ch = 0; ch < 3; ++ch)
            ASSERT_EQ(rgba[ch], c.data[c.Index(f, x, y, k, ch)])
                << "k " << k << " face " << f << " (" << x << ", " << y << ") channel " << ch;
          ASSERT_EQ(rgba[3], 0.0f);
        }
  EXPECT_EQ(KeyValue(b, h, "shrm:format"), kShrmFormatTag);
  EXPECT_EQ(KeyValue(b, h, "shrm:kind"), "global");
  EXPECT_EQ(KeyValue(b, h, "shrm:index"), "reflection");
  EXPECT_EQ(KeyValue(b, h, "shrm:pmax"), "2");
  EXPECT_EQ(KeyValue(b, h, "shrm:brdf"), "phong:s=8");
  EXPECT_NE(KeyValue(b, h, "shrm:layout").find("layer k = SH coefficient k"), std::string::npos);
  EXPECT_EQ(KeyValue(b, h, "KTXorientation"), "rd");

  absl::StatusOr<ShrmFile> back = DecodeShrmKtx2("t.ktx2", b);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->cube.kind, ShrmKind::kGlobal);
  EXPECT_EQ(back->cube.pmax, 2);
  EXPECT_EQ(back->cube.face_size, 3);
  EXPECT_EQ(back->cube.data, c.data);
  EXPECT_EQ(back->attributes.at("shrm:brdf"), "phong:s=8");
}

TEST(ShrmKtx2Test, HalfFloatsEqualOpenExrsHalvesOfTheSameCube) {
  // Two independent half conversions (ours, OpenEXR's) of the same cube, each read back.
  ShrmCube c = MakeCube(3, 4, ShrmKind::kLocal);
  c.index = ReparamKind::kTangent;
  c.data[5] = 1e-6f;     // a half subnormal
  c.data[6] = 60000.0f;  // near the largest half (65504)
  const std::string exr = Temp("half.shrm.exr"), ktx = Temp("half.shrm.ktx2");
  ASSERT_TRUE(WriteShrmFile(exr, c, {}, /*half=*/true).ok());
  absl::StatusOr<std::string> bytes = EncodeShrmKtx2(ktx, c, {}, /*half=*/true);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  EXPECT_EQ(ParseHeader(*bytes).vk_format, 97u);  // VK_FORMAT_R16G16B16A16_SFLOAT
  ASSERT_TRUE(WriteFileAtomically(ktx, *bytes).ok());
  absl::StatusOr<ShrmFile> from_exr = ReadShrm(exr), from_ktx = ReadShrm(ktx);
  ASSERT_TRUE(from_exr.ok()) << from_exr.status();
  ASSERT_TRUE(from_ktx.ok()) << from_ktx.status();
  EXPECT_EQ(from_ktx->cube.kind, ShrmKind::kLocal);
  EXPECT_EQ(from_ktx->cube.index, ReparamKind::kTangent);
  EXPECT_EQ(from_ktx->cube.data, from_exr->cube.data);
  std::filesystem::remove(exr);
  std::filesystem::remove(ktx);
}

// Every damaged file is refused with a message naming the problem.
TEST(ShrmKtx2Test, DamagedFilesAreRefusedWithTheField) {
  const ShrmCube c = MakeCube(1, 2, ShrmKind::kGlobal);
  const std::string good = *EncodeShrmKtx2("g", c, {}, false);
  auto expect_error = [](const std::string& bytes, const std::string& needle) {
    absl::StatusOr<ShrmFile> r = DecodeShrmKtx2("f.ktx2", bytes);
    ASSERT_FALSE(r.ok()) << "accepted: " << needle;
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find(needle), std::string::npos) << r.status().message();
  };
  // Every truncation: an error, never a read past the end.
  for (size_t n = 0; n < good.size(); n += (n < 200 ? 1 : 61)) {
    absl::StatusOr<ShrmFile> r = DecodeShrmKtx2("f.ktx2", good.substr(0, n));
    EXPECT_FALSE(r.ok()) << "truncated to " << n << " bytes";
  }
  auto patched = [&](size_t at, uint32_t value) {
    std::string b = good;
    std::memcpy(b.data() + at, &value, 4);
    return b;
  };
  expect_error("not a ktx2 file at all, but long enough to have a header ...", "identifier");
  expect_error(patched(12, 100), "vkFormat 100");  // a format an SHRM never has
  expect_error(patched(16, 2), "typeSize 2");
  expect_error(patched(36, 1), "faceCount 1");
  expect_error(patched(24, 3), "square");
  expect_error(patched(32, 5), "layerCount 5 does not match shrm:pmax 1");
  expect_error(patched(40, 2), "levelCount 2");
  expect_error(patched(44, 1), "supercompressionScheme 1");
  expect_error(patched(56, static_cast<uint32_t>(good.size())), "Key/Value Data");
  {
    std::string b = good;
    const uint64_t far = uint64_t{1} << 40;
    std::memcpy(b.data() + 80, &far, 8);
    expect_error(b, "level 0 lies outside the file");
  }
  {
    // A foreign KTX2 key set: the SHRM attributes renamed away.
    std::string b = good;
    for (size_t at = b.find("shrm:format"); at != std::string::npos; at = b.find("shrm:format"))
      b[at] = 'x';
    expect_error(b, "shrm:format missing");
  }
  {
    std::string b = good;
    const size_t at = b.find("shrm:pmax");
    b[at + 10] = '7';  // "shrm:pmax\0" + "1" -> "7"
    expect_error(b, "layerCount 4 does not match shrm:pmax 7");
  }
  {
    // A value that is not UTF-8 (found by fuzz/shrm_ktx2_fuzzer.cc: read, it could not be written
    // again).
    std::string b = good;
    const size_t at = b.find("shrm-cube/1");
    b[at + 5] = static_cast<char>(0xFF);
    expect_error(b, "is not NUL-free UTF-8");
  }
  {
    ImageLimits small;
    small.max_width = 1;
    absl::StatusOr<ShrmFile> r = DecodeShrmKtx2("f.ktx2", good, small);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.status().message().find("exceeds the limits"), std::string::npos);
  }
  {
    std::string b = good;
    const float nan = std::nanf("");
    std::memcpy(b.data() + ParseHeader(good).level_offset, &nan, 4);
    expect_error(b, "not finite");
  }
}

TEST(ShrmKtx2Test, EncoderRefusesInconsistentCubesAndForeignAttributes) {
  ShrmCube c = MakeCube(1, 2, ShrmKind::kGlobal);
  EXPECT_FALSE(EncodeShrmKtx2("x", c, {{"brdf", "x"}}, false).ok());
  c.data.pop_back();
  EXPECT_FALSE(EncodeShrmKtx2("x", c, {}, false).ok());
  ShrmCube inf = MakeCube(1, 2, ShrmKind::kGlobal);
  inf.data[3] = INFINITY;
  EXPECT_FALSE(EncodeShrmKtx2("x", inf, {}, false).ok());
}

// Peak lights: the list round-trips exactly (%.9g of floats), and "shrm:light_model" holds the
// shaders' copy of the BRDF: the model number of docs/shaders.md and its parameters in the
// documented slots (GGX: v_0 alpha, v_1 f0; Lafortune: v_0 rho_d, v_1 the lobe count, lobe k at
// v_4+4k). Models the shaders cannot evaluate are refused, with nothing encoded.
TEST(ShrmKtx2Test, PeakLightsCarryTheirListAndTheShadersBrdf) {
  ShrmCube c = MakeCube(1, 2, ShrmKind::kGlobal);
  c.lights = {{{0.6f, 0.8f, 0.0f}, {1.5f, 0.25f, 3e-7f}}, {{0.0f, -1.0f, 0.0f}, {2, 2, 2}}};
  absl::StatusOr<std::string> bytes =
      EncodeShrmKtx2("lit", c, {{"shrm:brdf", "ggx:alpha=0.2,f0=0.04"}}, false);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  absl::StatusOr<ShrmFile> back = DecodeShrmKtx2("lit", *bytes, ImageLimits{});
  ASSERT_TRUE(back.ok()) << back.status();
  ASSERT_EQ(back->cube.lights.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back->cube.lights[k].dir, c.lights[k].dir);
    EXPECT_EQ(back->cube.lights[k].weight, c.lights[k].weight);
  }
  ASSERT_TRUE(back->attributes.count("shrm:light_model"));
  const std::string& model = back->attributes.at("shrm:light_model");
  EXPECT_EQ(model.substr(0, model.find(' ')), "6");
  absl::StatusOr<BrdfShaderParams> p = ParseBrdfShaderParams(model);
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->model, BrdfShaderModel::kGgx);
  EXPECT_FLOAT_EQ(p->values[0], 0.2f);
  EXPECT_FLOAT_EQ(p->values[1], 0.04f);
  for (int i = 2; i < kBrdfShaderValues; ++i) EXPECT_EQ(p->values[i], 0.0f) << i;

  const absl::StatusOr<BrdfShaderParams> laf = BrdfShaderParamsFor(
      *ParseBrdfSpec("lafortune:rho_d=0.1;cx=-0.9,cz=0.8,n=15,rho=1.5;cx=-1,cz=1,n=40,rho=0.5")
           .value());
  ASSERT_TRUE(laf.ok()) << laf.status();
  EXPECT_EQ(laf->model, BrdfShaderModel::kLafortune);
  const float want[] = {0.1f, 2, 0, 0, -0.9f, 0.8f, 15, 1.5f, -1, 1, 40, 0.5f};
  for (int i = 0; i < 12; ++i) EXPECT_FLOAT_EQ(laf->values[i], want[i]) << i;

  // No BRDF, or one without a shader copy: refused.
  EXPECT_FALSE(EncodeShrmKtx2("lit", c, {}, false).ok());
  const absl::StatusOr<std::string> five_lobes =
      EncodeShrmKtx2("lit", c,
                     {{"shrm:brdf",
                       "lafortune:cx=-1,cz=1,n=2,rho=1;cx=-1,cz=1,n=3,rho=1;cx=-1,cz=1,n=4,rho=1;"
                       "cx=-1,cz=1,n=5,rho=1;cx=-1,cz=1,n=6,rho=1"}},
                     false);
  ASSERT_FALSE(five_lobes.ok());
  EXPECT_NE(five_lobes.status().message().find("at most 4 lobes"), std::string::npos)
      << five_lobes.status();
  // The key's text is validated when read back.
  EXPECT_FALSE(ParseBrdfShaderParams("6 0.2").ok());
  EXPECT_FALSE(ParseBrdfShaderParams("9 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0").ok());
  EXPECT_FALSE(ParseBrdfShaderParams("6 nan 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0").ok());
  EXPECT_TRUE(ParseBrdfShaderParams(FormatBrdfShaderParams(*laf)).ok());
}

TEST(ShrmKtx2Test, ReadShrmNamesAMissingFile) {
  absl::StatusOr<ShrmFile> r = ReadShrm(Temp("missing.ktx2"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace shrm
