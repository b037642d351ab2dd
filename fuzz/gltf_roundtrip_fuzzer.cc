// Round trip of the glTF writer (core/export/gltf_ibl.h, `shrm ibl --containers gltf`): random
// valid chains (face sizes 1..32, any level count, texels from 0 to beyond RGBD's range, with the
// boundary values), irradiance coefficients and light options -> EncodeGltfIbl -> ibl.glb ->
// parsed back by the reader of tests/glb_reader.h (from the glTF 2.0 and PNG specifications, not
// from the writer) -> the extension's fields, every image's size, and every texel's RGBD value
// against the input at the direction the orientation rule gives. An input with one invalid value
// (NaN, negative radiance, a bad intensity or rotation) must get InvalidArgument instead.
#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include "core/base/cubemap.h"
#include "core/export/gltf_ibl.h"
#include "fuzz/fuzz_util.h"
#include "tests/glb_reader.h"

namespace {

using shrm::fuzz::Check;

// Boundary values of the RGBD packing besides random ones: zero, subnormal, the smallest step,
// around 1, around the largest storable 255, and far beyond it (clamped).
constexpr float kSpecial[] = {0.0f,   1e-40f,  1.0f / 255, 0.5f,  1.0f,  254.99f,
                              255.0f, 255.01f, 1e6f,       3e38f, 1e-3f, 100.0f};

float Texel(FuzzedDataProvider& fdp) {
  if (fdp.ConsumeBool())
    return kSpecial[fdp.ConsumeIntegralInRange<size_t>(0, std::size(kSpecial) - 1)];
  return fdp.ConsumeFloatingPointInRange<float>(0.0f, 300.0f);
}

// Babylon's RGBD decoding (the extension's rule rgb / D with its gamma), written out here.
double DecodeRgbdChannel(uint8_t c, uint8_t d) {
  return std::pow(c / 255.0, shrm::gltf::kRgbdGamma) / (d / 255.0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  FuzzedDataProvider fdp(data, size);
  const int log_size = fdp.ConsumeIntegralInRange(0, 5);
  const int face = 1 << log_size;
  const int levels = fdp.ConsumeIntegralInRange(1, log_size + 1);
  // 0: valid; 1: a NaN texel; 2: a negative texel; 3: a bad intensity; 4: a bad rotation.
  const int broken = fdp.ConsumeIntegralInRange(0, 15) < 11 ? 0 : fdp.ConsumeIntegralInRange(1, 4);

  shrm::ibl::SpecularChain chain;
  for (int k = 0; k < levels; ++k) {
    shrm::ibl::SpecularLevel l;
    l.face_size = face >> k;
    l.roughness = levels > 1 ? static_cast<double>(k) / (levels - 1) : 0;
    l.cube.face_size = l.face_size;
    l.cube.data.resize(l.cube.size());
    for (float& v : l.cube.data) v = Texel(fdp);
    chain.levels.push_back(std::move(l));
  }
  if (broken == 1 || broken == 2) {
    std::vector<float>& d = chain.levels.back().cube.data;
    d[fdp.ConsumeIntegralInRange<size_t>(0, d.size() - 1)] =
        broken == 1 ? std::numeric_limits<float>::quiet_NaN() : -1.0f;
  }
  shrm::ibl::Sh9Rgb coefficients;
  for (auto& c : coefficients)
    for (double& v : c) v = fdp.ConsumeFloatingPointInRange<double>(-1e3, 1e3);
  shrm::gltf::GltfIblOptions options;
  options.intensity = broken == 3 ? -1.0 : fdp.ConsumeFloatingPointInRange<double>(0, 100);
  std::array<double, 4> q;
  double n2 = 0;
  for (double& v : q) {
    v = fdp.ConsumeFloatingPointInRange<double>(-1, 1);
    n2 += v * v;
  }
  if (n2 > 1e-6) {
    for (double& v : q) v /= std::sqrt(n2);
    options.rotation = q;
  }
  if (broken == 4) options.rotation = {0, 0, 0, 2};

  const absl::StatusOr<shrm::gltf::GltfIblFile> file =
      shrm::gltf::EncodeGltfIbl(chain, coefficients, options);
  if (broken != 0) {
    Check(!file.ok() && file.status().code() == absl::StatusCode::kInvalidArgument,
          "an invalid input is InvalidArgument");
    return 0;
  }
  Check(file.ok(), "a valid input is encoded");

  const absl::StatusOr<shrm::testing::Glb> glb = shrm::testing::ReadGlb(file->glb);
  Check(glb.ok(), "ibl.glb follows the Binary glTF Layout");
  const nlohmann::json& doc = glb->doc;
  Check(doc.value("asset", nlohmann::json::object()).value("version", "") == "2.0",
        "asset.version 2.0");
  bool used = false;
  for (const auto& e : doc.value("extensionsUsed", nlohmann::json::array()))
    used |= e == "EXT_lights_image_based";
  Check(used, "EXT_lights_image_based in extensionsUsed");
  const nlohmann::json& light = doc["extensions"]["EXT_lights_image_based"]["lights"].at(0);
  Check(light["specularImageSize"] == face, "specularImageSize is level 0's face size");
  Check(light["intensity"].get<double>() == options.intensity, "intensity as given");
  for (int i = 0; i < 4; ++i)
    Check(light["rotation"][i].get<double>() == options.rotation[i], "rotation as given");
  for (int i = 0; i < 9; ++i)
    for (int c = 0; c < 3; ++c)
      Check(light["irradianceCoefficients"][i][c].get<double>() == coefficients[i][c],
            "irradiance coefficients as given (17-digit JSON)");
  const nlohmann::json& specular = light["specularImages"];
  Check(specular.size() == static_cast<size_t>(levels), "one image array per level");

  int64_t clamped = 0;
  for (int k = 0; k < levels; ++k) {
    const shrm::ibl::SpecularLevel& level = chain.levels[k];
    const int s = level.face_size;
    Check(specular[k].size() == 6, "six faces per level");
    for (int f = 0; f < 6; ++f) {
      const nlohmann::json& image = doc["images"].at(specular[k][f].get<size_t>());
      Check(image.value("mimeType", "") == "image/png", "images are PNG");
      const absl::StatusOr<std::string> bytes =
          shrm::testing::GlbViewBytes(*glb, image["bufferView"].get<int>());
      Check(bytes.ok(), "the image's bufferView is inside the BIN chunk");
      const absl::StatusOr<shrm::testing::Rgba8> png = shrm::testing::ReadPngRgba8(*bytes);
      Check(png.ok(), "the image is a valid 8-bit RGBA PNG");
      Check(png->width == s && png->height == s, "the image has the level's face size");
      for (int row = 0; row < s; ++row)
        for (int col = 0; col < s; ++col) {
          // The input texel at the direction this image texel holds.
          const shrm::Vec3 d = shrm::gltf::GltfDirectionOfTexel(f, col, row, s);
          int in_face = 0;
          double u = 0, v = 0;
          shrm::CubeFaceCoordinates(d, &in_face, &u, &v);
          const int x = std::min(s - 1, static_cast<int>(u * s));
          const int y = std::min(s - 1, static_cast<int>(v * s));
          const uint8_t* p = &png->px[(static_cast<size_t>(row) * s + col) * 4];
          Check(p[3] >= 1, "D is at least 1/255");
          bool over = false;
          for (int c = 0; c < 3; ++c)
            over |= level.cube.data[level.cube.Index(in_face, x, y, c)] > shrm::gltf::kRgbdMaxValue;
          clamped += over;
          for (int c = 0; c < 3; ++c) {
            const double want = std::min<double>(
                level.cube.data[level.cube.Index(in_face, x, y, c)], shrm::gltf::kRgbdMaxValue);
            const double got = DecodeRgbdChannel(p[c], p[3]);
            // Half an 8-bit step in the gamma value rgb' = (rgb D)^(1/2.2), mapped back.
            const double dd = p[3] / 255.0;
            const double g = std::pow(want * dd, 1 / shrm::gltf::kRgbdGamma);
            const double lo = std::pow(std::max(0.0, g - shrm::gltf::kRgbdRounding - 1e-6),
                                       shrm::gltf::kRgbdGamma) /
                              dd;
            const double hi = std::pow(std::min(1.0, g + shrm::gltf::kRgbdRounding + 1e-6),
                                       shrm::gltf::kRgbdGamma) /
                              dd;
            Check(got >= lo && got <= hi, "the texel decodes to its radiance within RGBD rounding");
          }
        }
    }
  }
  Check(clamped <= file->clamped, "clamped texels are counted");
  return 0;
}
