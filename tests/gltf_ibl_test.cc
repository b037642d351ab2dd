// The glTF IBL encoder (core/export/gltf_ibl.h) against an independent reader (tests/glb_reader.h,
// from the glTF 2.0 and PNG specifications, zlib only), the accessors' ranges and min/max checked
// here ("Accessors"); RGBD decoded with the extension's rule (rgb / D) and Babylon's gamma 2.2,
// written out here.
#include "core/export/gltf_ibl.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/base/cubemap.h"
#include "gtest/gtest.h"
#include "tests/glb_reader.h"

namespace shrm::gltf {
namespace {

using nlohmann::json;

// Decoded radiance against the input: the stored gamma value is within half an 8-bit step of
// the exact one (plus float rounding of the input's conversion).
constexpr double kGammaStepTol = 0.5 / 255 + 1e-6;
// Sphere vertices are floats: unit length and radius to float rounding.
constexpr double kFloatTol = 1e-6;
// The coefficients pass through JSON text with 17 digits (nlohmann round-trips doubles).
constexpr double kJsonTol = 0.0;

using testing::Glb;
using testing::Rgba8;

// The reader of tests/glb_reader.h, its errors as test failures.
Glb ParseGlb(const std::string& b) {
  absl::StatusOr<Glb> g = testing::ReadGlb(b);
  EXPECT_TRUE(g.ok()) << g.status();
  return g.ok() ? *std::move(g) : Glb{};
}
std::string ViewBytes(const Glb& g, int v) {
  absl::StatusOr<std::string> bytes = testing::GlbViewBytes(g, v);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  return bytes.ok() ? *std::move(bytes) : std::string();
}
Rgba8 DecodePng(const std::string& b) {
  absl::StatusOr<Rgba8> img = testing::ReadPngRgba8(b);
  EXPECT_TRUE(img.ok()) << img.status();
  return img.ok() ? *std::move(img) : Rgba8{};
}

// A chain of `levels` levels from `size` whose radiance is a smooth function of the direction
// with a wide range (1e-3 .. 400, beyond RGBD's 255 around +X).
ibl::SpecularChain MakeChain(int size, int levels) {
  ibl::SpecularChain chain;
  for (int k = 0; k < levels; ++k) {
    ibl::SpecularLevel l;
    l.face_size = size >> k;
    l.roughness = levels > 1 ? static_cast<double>(k) / (levels - 1) : 0;
    l.cube.face_size = l.face_size;
    l.cube.data.resize(l.cube.size());
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < l.face_size; ++y)
        for (int x = 0; x < l.face_size; ++x) {
          const Vec3 d = CubeTexelDirection(f, x, y, l.face_size);
          const double peak = std::pow(std::max(0.0, d.x), 64);  // bright towards +X
          l.cube.data[l.cube.Index(f, x, y, 0)] = static_cast<float>(400 * peak + 0.5 + 0.4 * d.y);
          l.cube.data[l.cube.Index(f, x, y, 1)] = static_cast<float>(1e-3 + 0.2 * (1 + d.z));
          l.cube.data[l.cube.Index(f, x, y, 2)] = static_cast<float>(2 + d.x + d.y * d.z);
        }
    chain.levels.push_back(std::move(l));
  }
  return chain;
}

// The radiance of MakeChain at a direction (the same formula, evaluated at the file's direction).
std::array<double, 3> ChainRadiance(const Vec3& d) {
  return {400 * std::pow(std::max(0.0, d.x), 64) + 0.5 + 0.4 * d.y, 1e-3 + 0.2 * (1 + d.z),
          2 + d.x + d.y * d.z};
}

ibl::Sh9Rgb SomeCoefficients() {
  ibl::Sh9Rgb c;
  for (int i = 0; i < 9; ++i)
    for (int ch = 0; ch < 3; ++ch) c[i][ch] = 0.1 * (i + 1) - 0.05 * ch;
  return c;
}

TEST(GltfIblTest, GlbStructureAndExtension) {
  const ibl::SpecularChain chain = MakeChain(16, 3);
  GltfIblOptions opt;
  opt.intensity = 1.5;
  opt.rotation = {0, std::sqrt(0.5), 0, std::sqrt(0.5)};
  const auto file = EncodeGltfIbl(chain, SomeCoefficients(), opt);
  ASSERT_TRUE(file.ok()) << file.status();
  const Glb g = ParseGlb(file->glb);
  const json& d = g.doc;
  EXPECT_EQ(d["asset"]["version"], "2.0");
  EXPECT_EQ(d["extensionsUsed"], json({"EXT_lights_image_based"}));
  EXPECT_FALSE(d.contains("extensionsRequired"));
  EXPECT_EQ(d["buffers"].size(), 1u);
  EXPECT_EQ(d["buffers"][0]["byteLength"], g.bin.size());
  EXPECT_FALSE(d["buffers"][0].contains("uri"));  // the GLB's own BIN chunk
  ASSERT_EQ(d["scenes"].size(), 1u);
  EXPECT_EQ(d["scenes"][0]["extensions"]["EXT_lights_image_based"]["light"], 0);
  const json& light = d["extensions"]["EXT_lights_image_based"]["lights"].at(0);
  EXPECT_EQ(light["intensity"], 1.5);
  EXPECT_EQ(light["rotation"], json(opt.rotation));
  EXPECT_EQ(light["specularImageSize"], 16);
  ASSERT_EQ(light["irradianceCoefficients"].size(), 9u);
  const ibl::Sh9Rgb c = SomeCoefficients();
  for (int i = 0; i < 9; ++i)
    for (int ch = 0; ch < 3; ++ch)
      EXPECT_NEAR(light["irradianceCoefficients"][i][ch].get<double>(), c[i][ch], kJsonTol);
  ASSERT_EQ(light["specularImages"].size(), 3u);
  for (const json& faces : light["specularImages"]) {
    ASSERT_EQ(faces.size(), 6u);
    for (const json& im : faces) {
      const json& image = d["images"].at(im.get<int>());
      EXPECT_EQ(image["mimeType"], "image/png");
      EXPECT_TRUE(image.contains("bufferView"));
    }
  }
  // Accessors in range of their views; POSITION min/max equal to the data's.
  for (const json& a : d["accessors"]) {
    const std::string view = ViewBytes(g, a["bufferView"]);
    const int comps = a["type"] == "VEC3" ? 3 : 1;
    const int bytes = a["componentType"] == 5126 ? 4 : 2;
    EXPECT_LE(static_cast<size_t>(a["count"]) * comps * bytes, view.size());
  }
  // One metallic sphere per level with the level's roughness, then a dielectric one.
  ASSERT_EQ(d["materials"].size(), 4u);
  for (int k = 0; k < 4; ++k) {
    const json& m = d["materials"][k]["pbrMetallicRoughness"];
    EXPECT_EQ(m["metallicFactor"], k < 3 ? 1 : 0);
    EXPECT_DOUBLE_EQ(m["roughnessFactor"].get<double>(),
                     std::min(kMaxSphereRoughness, k < 3 ? chain.levels[k].roughness : 1.0));
    EXPECT_EQ(m["baseColorFactor"], json({1, 1, 1, 1}));
  }
  int sphere_nodes = 0;
  for (const json& n : d["nodes"]) sphere_nodes += n.contains("mesh");
  EXPECT_EQ(sphere_nodes, 4);
}

TEST(GltfIblTest, SphereGeometry) {
  const auto file = EncodeGltfIbl(MakeChain(8, 1), SomeCoefficients());
  ASSERT_TRUE(file.ok()) << file.status();
  const Glb g = ParseGlb(file->glb);
  const json& prim = g.doc["meshes"][0]["primitives"][0];
  const json& pa = g.doc["accessors"][prim["attributes"]["POSITION"].get<int>()];
  const json& na = g.doc["accessors"][prim["attributes"]["NORMAL"].get<int>()];
  const json& ia = g.doc["accessors"][prim["indices"].get<int>()];
  const size_t n = pa["count"];
  std::vector<float> pos(n * 3), nrm(n * 3);
  std::memcpy(pos.data(), ViewBytes(g, pa["bufferView"]).data(), n * 12);
  std::memcpy(nrm.data(), ViewBytes(g, na["bufferView"]).data(), n * 12);
  std::array<float, 3> lo = {1e9f, 1e9f, 1e9f}, hi = {-1e9f, -1e9f, -1e9f};
  for (size_t v = 0; v < n; ++v) {
    const double r = std::hypot(pos[v * 3], pos[v * 3 + 1], pos[v * 3 + 2]);
    const double u = std::hypot(nrm[v * 3], nrm[v * 3 + 1], nrm[v * 3 + 2]);
    EXPECT_NEAR(r, kSphereRadius, kFloatTol);
    EXPECT_NEAR(u, 1.0, kFloatTol);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(nrm[v * 3 + a], pos[v * 3 + a] / kSphereRadius, kFloatTol);
      lo[a] = std::min(lo[a], pos[v * 3 + a]);
      hi[a] = std::max(hi[a], pos[v * 3 + a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(pa["min"][a].get<float>(), lo[a]);
    EXPECT_EQ(pa["max"][a].get<float>(), hi[a]);
  }
  // Indices in range; every triangle counter-clockwise seen from outside (glTF front faces).
  const size_t m = ia["count"];
  std::vector<uint16_t> idx(m);
  std::memcpy(idx.data(), ViewBytes(g, ia["bufferView"]).data(), m * 2);
  int outward = 0, degenerate = 0;
  for (size_t t = 0; t < m; t += 3) {
    for (int k = 0; k < 3; ++k) ASSERT_LT(idx[t + k], n);
    const float* a = &pos[idx[t] * 3];
    const float* b = &pos[idx[t + 1] * 3];
    const float* c = &pos[idx[t + 2] * 3];
    const Vec3 e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const Vec3 cr{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
    const double dot =
        cr.x * (a[0] + b[0] + c[0]) + cr.y * (a[1] + b[1] + c[1]) + cr.z * (a[2] + b[2] + c[2]);
    if (std::sqrt(cr.x * cr.x + cr.y * cr.y + cr.z * cr.z) < 1e-9) {
      ++degenerate;  // the pole rows of a UV sphere
    } else {
      outward += dot > 0;
    }
  }
  EXPECT_EQ(outward + degenerate, static_cast<int>(m / 3));
  // Sphere centres: kSphereSpacing apart along x.
  const json& nodes = g.doc["nodes"];
  EXPECT_DOUBLE_EQ(
      nodes[1]["translation"][0].get<double>() - nodes[0]["translation"][0].get<double>(),
      kSphereSpacing);
}

// Every texel of every face of every level decodes (RGBD, gamma 2.2) to the input radiance at the
// direction the header assigns to it, within half an 8-bit step of the gamma-encoded value.
TEST(GltfIblTest, RgbdFacesReproduceTheRadiance) {
  const ibl::SpecularChain chain = MakeChain(16, 3);
  const auto file = EncodeGltfIbl(chain, SomeCoefficients());
  ASSERT_TRUE(file.ok()) << file.status();
  const Glb g = ParseGlb(file->glb);
  const json& light = g.doc["extensions"]["EXT_lights_image_based"]["lights"][0];
  int64_t clamped = 0;
  double worst = 0;
  for (int k = 0; k < 3; ++k) {
    const int n = 16 >> k;
    for (int f = 0; f < 6; ++f) {
      const json& image = g.doc["images"][light["specularImages"][k][f].get<int>()];
      const Rgba8 img = DecodePng(ViewBytes(g, image["bufferView"]));
      ASSERT_EQ(img.width, n);
      ASSERT_EQ(img.height, n);
      for (int row = 0; row < n; ++row)
        for (int col = 0; col < n; ++col) {
          const uint8_t* p = &img.px[(row * n + col) * 4];
          const std::array<double, 3> want = ChainRadiance(GltfDirectionOfTexel(f, col, row, n));
          const double mx = std::max({want[0], want[1], want[2], 1e-6});
          // The extension's D: the largest integer multiple of 1/255 with max * D <= 1 (>= 1/255).
          const int d = static_cast<int>(std::clamp(std::floor(255 / mx), 1.0, 255.0));
          ASSERT_EQ(p[3], d) << "level " << k << " face " << f << " (" << col << ", " << row << ")";
          if (mx > kRgbdMaxValue) ++clamped;
          for (int c = 0; c < 3; ++c) {
            const double exact = std::pow(std::min(1.0, want[c] * d / 255), 1 / 2.2);
            const double err = std::abs(p[c] / 255.0 - exact);
            worst = std::max(worst, err);
            ASSERT_LE(err, kGammaStepTol)
                << "level " << k << " face " << f << " channel " << c << " (" << col << ", " << row
                << ") want " << want[c] << " D " << d << " stored " << int{p[c]};
            // Decoded as Babylon does: (rgb / 255)^2.2 / (D / 255).
            if (mx <= kRgbdMaxValue && want[c] > 0.05 * mx) {
              const double decoded = std::pow(p[c] / 255.0, 2.2) * 255 / d;
              EXPECT_NEAR(decoded, want[c], want[c] * 2.2 * kGammaStepTol / exact * 1.01);
            }
          }
        }
    }
  }
  EXPECT_EQ(file->clamped, clamped);
  EXPECT_GT(clamped, 0);  // the 400 peak
  std::printf("worst gamma-space difference %.3g (bound %.3g), %lld clamped texels\n", worst,
              kGammaStepTol, static_cast<long long>(clamped));
}

// The direction map is a mirror in x of the GL cube, stored bottom-up: written out per face.
TEST(GltfIblTest, DirectionOfTexelKnownAnswers) {
  // Image (top-left texel, 2 x 2) of face +X: the GL texel (0, 1) of +X, s = 0.25, t = 0.75,
  // direction (1, -0.5, 0.5), mirrored to (-1, -0.5, 0.5): Babylon's +X face shows glTF -X.
  const Vec3 d = GltfDirectionOfTexel(kPosX, 0, 0, 2);
  const double s = 1 / std::sqrt(1.5);
  EXPECT_NEAR(d.x, -s, 1e-12);
  EXPECT_NEAR(d.y, -0.5 * s, 1e-12);
  EXPECT_NEAR(d.z, 0.5 * s, 1e-12);
  // Face +Y's image centre looks up, -Z's looks along -Z.
  const Vec3 up = GltfDirectionOfTexel(kPosY, 4, 4, 9);
  EXPECT_NEAR(up.y, 1, 1e-12);
  const Vec3 back = GltfDirectionOfTexel(kNegZ, 4, 4, 9);
  EXPECT_NEAR(back.z, -1, 1e-12);
}

TEST(GltfIblTest, RgbdKnownAnswers) {
  EXPECT_EQ(EncodeRgbd({1, 1, 1}), (std::array<uint8_t, 4>{255, 255, 255, 255}));
  EXPECT_EQ(EncodeRgbd({0, 0, 0}), (std::array<uint8_t, 4>{0, 0, 0, 255}));
  // max 2: D = floor(127.5) = 127; 2 * 127 / 255 = 0.99608, ^(1/2.2) = 0.99822 -> 255.
  const auto q = EncodeRgbd({2, 0, 0});
  EXPECT_EQ(q[3], 127);
  EXPECT_EQ(q[0], 255);
  EXPECT_NEAR(DecodeRgbd(q)[0], 255.0 / 127, 1e-12);
  // Above 255: D = 1/255, clamped.
  EXPECT_EQ(EncodeRgbd({1000, 0, 0})[3], 1);
  EXPECT_NEAR(DecodeRgbd(EncodeRgbd({1000, 0, 0}))[0], 255, 1e-9);
}

// Babylon 9.35's default diffuse from irradianceCoefficients c (its loader's 1 / pi, then its
// harmonics shader path, harmonicsFunctions.fx with preScaleForRendering's basis constants):
// sum_i (c_i / pi) s_i k_i P_i(n), P = {1, y, z, x, yx, yz, 3z^2 - 1, zx, x^2 - y^2}.
double BabylonDefaultDiffuse(const ibl::Sh9Rgb& c, int ch, const Vec3& n) {
  constexpr double k[9] = {0.282095, 0.488603, 0.488603, 0.488603, 1.092548,
                           1.092548, 0.315392, 1.092548, 0.546274};
  constexpr double s[9] = {1, -1, 1, -1, 1, -1, 1, -1, 1};
  const double p[9] = {
      1, n.y, n.z, n.x, n.y * n.x, n.y * n.z, 3 * n.z * n.z - 1, n.z * n.x, n.x * n.x - n.y * n.y};
  double e = 0;
  for (int i = 0; i < 9; ++i) e += c[i][ch] / kPi * s[i] * k[i] * p[i];
  return e;
}

TEST(GltfIblTest, IrradianceCoefficientsMirrorAndScale) {
  // L = 1 (red) and L = -x (green; Y_11 = -sqrt(3 / 4pi) x with the Condon-Shortley phase). In the
  // images' frame (x negated) the green field is +n_x, so Babylon must show E / pi = 1 (red) and
  // (2/3) n_x (green: A_1 / pi).
  std::vector<double> sh(27, 0.0);
  const double y00 = 0.5 / std::sqrt(kPi), y1 = std::sqrt(3 / (4 * kPi));
  sh[0] = 1 / y00;
  sh[3 * 3 + 1] = 1 / y1;
  const auto c = GltfIrradianceCoefficients(sh);
  ASSERT_TRUE(c.ok()) << c.status();
  for (const Vec3 n : {Vec3{1, 0, 0}, Vec3{0, 1, 0}, Vec3{-0.6, 0, 0.8}}) {
    EXPECT_NEAR(BabylonDefaultDiffuse(*c, 0, n), 1.0, 1e-5);  // 6-digit constants
    EXPECT_NEAR(BabylonDefaultDiffuse(*c, 1, n), 2.0 / 3 * n.x, 1e-5);
  }
  EXPECT_FALSE(GltfIrradianceCoefficients(std::vector<double>(26, 0.0)).ok());
}

TEST(GltfIblTest, BadInput) {
  const ibl::Sh9Rgb c = SomeCoefficients();
  auto expect_error = [&](const ibl::SpecularChain& chain, const GltfIblOptions& opt,
                          const std::string& words) {
    const auto r = EncodeGltfIbl(chain, c, opt);
    ASSERT_FALSE(r.ok()) << words;
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find(words), std::string::npos) << r.status();
  };
  expect_error({}, {}, "empty radiance chain");
  ibl::SpecularChain odd = MakeChain(16, 2);
  odd.levels[0].face_size = 12;
  odd.levels[0].cube.face_size = 12;
  expect_error(odd, {}, "not a power of two");
  ibl::SpecularChain gap = MakeChain(16, 3);
  gap.levels.erase(gap.levels.begin() + 1);
  expect_error(gap, {}, "is not half of level 0");
  ibl::SpecularChain short_data = MakeChain(16, 2);
  short_data.levels[1].cube.data.pop_back();
  expect_error(short_data, {}, "does not hold 6 square RGB faces");
  ibl::SpecularChain nan = MakeChain(8, 1);
  nan.levels[0].cube.data[5] = std::nanf("");
  expect_error(nan, {}, "value 5 is nan");
  ibl::SpecularChain neg = MakeChain(8, 1);
  neg.levels[0].cube.data[7] = -1;
  expect_error(neg, {}, "must be finite and non-negative");
  GltfIblOptions bad;
  bad.intensity = -1;
  expect_error(MakeChain(8, 1), bad, "intensity -1");
  bad = {};
  bad.rotation = {0, 0, 0, 2};
  expect_error(MakeChain(8, 1), bad, "not a unit quaternion");
  ibl::Sh9Rgb cn = c;
  cn[4][1] = INFINITY;
  const auto r = EncodeGltfIbl(MakeChain(8, 1), cn);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("irradiance coefficients must be finite"), std::string::npos);
}

}  // namespace
}  // namespace shrm::gltf
