#include "core/export/gltf_ibl.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/io/image.h"

namespace shrm::gltf {
namespace {

using nlohmann::json;

constexpr uint32_t kGlbMagic = 0x46546C67;   // "glTF"
constexpr uint32_t kJsonChunk = 0x4E4F534A;  // "JSON"
constexpr uint32_t kBinChunk = 0x004E4942;   // "BIN\0"
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;
constexpr int kFloat = 5126;
constexpr int kUnsignedShort = 5123;
constexpr char kExtension[] = "EXT_lights_image_based";
// |q| = 1 within float rounding of a quaternion read from text.
constexpr double kUnitQuaternionTol = 1e-6;

// The buffer under construction: bufferViews appended 4-byte aligned.
class BinBuilder {
 public:
  int Add(const void* data, size_t bytes, int target) {
    while (bin_.size() % 4) bin_.push_back('\0');
    json view = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", bytes}};
    if (target) view["target"] = target;
    bin_.append(static_cast<const char*>(data), bytes);
    views_.push_back(view);
    return static_cast<int>(views_.size()) - 1;
  }
  std::string& bin() { return bin_; }
  json& views() { return views_; }

 private:
  std::string bin_;
  json views_ = json::array();
};

void AppendU32(std::string* out, uint32_t v) {
  for (int b = 0; b < 4; ++b) out->push_back(static_cast<char>((v >> (8 * b)) & 0xFF));
}

absl::Status ValidateChain(const ibl::SpecularChain& chain) {
  if (chain.levels.empty()) return absl::InvalidArgumentError("glTF IBL: empty radiance chain");
  for (size_t k = 0; k < chain.levels.size(); ++k) {
    const ibl::SpecularLevel& l = chain.levels[k];
    const int n = l.face_size;
    if (n <= 0 || (n & (n - 1)) != 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("glTF IBL: level ", k, " face size ", n,
                       " is not a power of two (the extension's rule)"));
    }
    if (k > 0 && n != chain.levels[k - 1].face_size / 2) {
      return absl::InvalidArgumentError(absl::StrCat("glTF IBL: level ", k, " face size ", n,
                                                     " is not half of level ", k - 1, "'s ",
                                                     chain.levels[k - 1].face_size));
    }
    if (l.cube.face_size != n || l.cube.channels != 3 || l.cube.data.size() != l.cube.size()) {
      return absl::InvalidArgumentError(absl::StrCat(
          "glTF IBL: level ", k, " does not hold 6 square RGB faces of ", n, " x ", n,
          " (cube face size ", l.cube.face_size, ", ", l.cube.data.size(), " values)"));
    }
    if (!std::isfinite(l.roughness) || l.roughness < 0 || l.roughness > 1) {
      return absl::InvalidArgumentError(
          absl::StrCat("glTF IBL: level ", k, " roughness ", l.roughness, " is not in [0, 1]"));
    }
    for (size_t i = 0; i < l.cube.data.size(); ++i) {
      const float v = l.cube.data[i];
      if (!std::isfinite(v) || v < 0) {
        return absl::InvalidArgumentError(
            absl::StrCat("glTF IBL: level ", k, " value ", i, " is ", v,
                         " (radiance must be finite and non-negative)"));
      }
    }
  }
  return absl::OkStatus();
}

absl::Status ValidateOptions(const ibl::Sh9Rgb& coeff, const GltfIblOptions& o) {
  for (const auto& c : coeff)
    for (double v : c)
      if (!std::isfinite(v))
        return absl::InvalidArgumentError(
            "glTF IBL: irradiance coefficients must be finite (got NaN/Inf)");
  if (!std::isfinite(o.intensity) || o.intensity < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("glTF IBL: intensity ", o.intensity, " must be finite and >= 0"));
  }
  double n2 = 0;
  for (double q : o.rotation) n2 += q * q;
  if (!std::isfinite(n2) || std::abs(std::sqrt(n2) - 1) > kUnitQuaternionTol) {
    return absl::InvalidArgumentError(absl::StrCat("glTF IBL: rotation [", o.rotation[0], ", ",
                                                   o.rotation[1], ", ", o.rotation[2], ", ",
                                                   o.rotation[3], "] is not a unit quaternion"));
  }
  return absl::OkStatus();
}

// One face of one level as an RGBD PNG (rows from the top, in the orientation of
// GltfDirectionOfTexel).
absl::StatusOr<std::string> FacePng(const ibl::SpecularLevel& level, int face, int64_t* clamped) {
  const int n = level.face_size;
  Image img;
  img.width = img.height = n;
  img.channels = 4;
  img.pixels.resize(static_cast<size_t>(n) * n * 4);
  for (int row = 0; row < n; ++row)
    for (int col = 0; col < n; ++col) {
      // The mirror x -> -x swaps +X and -X and reverses the columns of every face; the row order
      // is bottom-up (GltfDirectionOfTexel).
      const int src_face = face == kPosX ? kNegX : face == kNegX ? kPosX : face;
      const size_t at = level.cube.Index(src_face, n - 1 - col, n - 1 - row, 0);
      const std::array<float, 3> rgb = {level.cube.data[at], level.cube.data[at + 1],
                                        level.cube.data[at + 2]};
      if (std::max({rgb[0], rgb[1], rgb[2]}) > kRgbdMaxValue) ++*clamped;
      const std::array<uint8_t, 4> q = EncodeRgbd(rgb);
      // EncodeImage rounds v * 255: exact for v = q / 255.
      for (int c = 0; c < 4; ++c)
        img.pixels[(static_cast<size_t>(row) * n + col) * 4 + c] = q[c] / 255.0f;
    }
  return EncodeImage(img, ImageEncoding::kPng8);
}

struct SphereMesh {
  std::vector<float> positions, normals;
  std::vector<uint16_t> indices;
};

SphereMesh MakeSphere() {
  SphereMesh m;
  for (int r = 0; r <= kSphereRings; ++r) {
    const double theta = kPi * r / kSphereRings;
    for (int s = 0; s <= kSphereSegments; ++s) {
      const double phi = 2 * kPi * s / kSphereSegments;
      const double n[3] = {std::sin(theta) * std::cos(phi), std::cos(theta),
                           -std::sin(theta) * std::sin(phi)};
      for (int a = 0; a < 3; ++a) {
        m.normals.push_back(static_cast<float>(n[a]));
        m.positions.push_back(static_cast<float>(kSphereRadius * n[a]));
      }
    }
  }
  const int row = kSphereSegments + 1;
  for (int r = 0; r < kSphereRings; ++r)
    for (int s = 0; s < kSphereSegments; ++s) {
      const int a = r * row + s, b = a + row;  // b is below a; counter-clockwise from outside
      for (int i : {a, b, a + 1, a + 1, b, b + 1}) m.indices.push_back(static_cast<uint16_t>(i));
    }
  return m;
}

json Vec3Json(const float* v) { return {v[0], v[1], v[2]}; }

}  // namespace

Vec3 GltfDirectionOfTexel(int face, int column, int row, int size) {
  const Vec3 d = CubeTexelDirection(face, column, size - 1 - row, size);
  return {-d.x, d.y, d.z};
}

absl::StatusOr<ibl::Sh9Rgb> GltfIrradianceCoefficients(std::span<const double> radiance_sh9) {
  if (radiance_sh9.size() != static_cast<size_t>(ibl::kSh9Values)) {
    return absl::InvalidArgumentError(
        absl::StrCat("glTF IBL: radiance SH9 has ", radiance_sh9.size(), " values, want 27"));
  }
  // The images' frame is the world mirrored in x; in the SH frame (x_s = +X) the mirror
  // x_s -> -x_s negates the real SH odd in x_s: Y_1,1 (x), Y_2,-2 (xy), Y_2,1 (xz).
  std::vector<double> mirrored(radiance_sh9.begin(), radiance_sh9.end());
  for (int index : {3, 4, 7})
    for (int c = 0; c < 3; ++c) mirrored[index * 3 + c] = -mirrored[index * 3 + c];
  return ibl::ConvertRadianceSh9(mirrored, 2, ibl::Sh9Convention::kGltf);
}

std::array<uint8_t, 4> EncodeRgbd(const std::array<float, 3>& rgb) {
  const double max_rgb = std::max({1e-6, double{rgb[0]}, double{rgb[1]}, double{rgb[2]}});
  const double d = std::clamp(std::floor(std::max(kRgbdMaxValue / max_rgb, 1.0)), 1.0, 255.0);
  std::array<uint8_t, 4> q;
  for (int c = 0; c < 3; ++c) {
    const double g = std::pow(std::clamp(rgb[c] * d / 255, 0.0, 1.0), 1 / kRgbdGamma);
    q[c] = static_cast<uint8_t>(std::lround(g * 255));
  }
  q[3] = static_cast<uint8_t>(d);
  return q;
}

std::array<double, 3> DecodeRgbd(const std::array<uint8_t, 4>& rgbd) {
  std::array<double, 3> out;
  for (int c = 0; c < 3; ++c) out[c] = std::pow(rgbd[c] / 255.0, kRgbdGamma) / (rgbd[3] / 255.0);
  return out;
}

absl::StatusOr<GltfIblFile> EncodeGltfIbl(const ibl::SpecularChain& chain,
                                          const ibl::Sh9Rgb& irradiance_coefficients,
                                          const GltfIblOptions& options) {
  SHRM_RETURN_IF_ERROR(ValidateChain(chain));
  SHRM_RETURN_IF_ERROR(ValidateOptions(irradiance_coefficients, options));
  GltfIblFile out;
  BinBuilder bin;
  json doc;
  doc["asset"] = {{"version", "2.0"}, {"generator", options.generator}};
  doc["extensionsUsed"] = {kExtension};

  // Geometry shared by every sphere.
  const SphereMesh sphere = MakeSphere();
  const size_t vertices = sphere.positions.size() / 3;
  float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
  for (size_t v = 0; v < vertices; ++v)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], sphere.positions[v * 3 + a]);
      hi[a] = std::max(hi[a], sphere.positions[v * 3 + a]);
    }
  const int pos_view =
      bin.Add(sphere.positions.data(), sphere.positions.size() * sizeof(float), kArrayBuffer);
  const int nrm_view =
      bin.Add(sphere.normals.data(), sphere.normals.size() * sizeof(float), kArrayBuffer);
  const int idx_view =
      bin.Add(sphere.indices.data(), sphere.indices.size() * sizeof(uint16_t), kElementArrayBuffer);
  doc["accessors"] = {
      {{"bufferView", pos_view},
       {"componentType", kFloat},
       {"count", vertices},
       {"type", "VEC3"},
       {"min", Vec3Json(lo)},
       {"max", Vec3Json(hi)}},
      {{"bufferView", nrm_view}, {"componentType", kFloat}, {"count", vertices}, {"type", "VEC3"}},
      {{"bufferView", idx_view},
       {"componentType", kUnsignedShort},
       {"count", sphere.indices.size()},
       {"type", "SCALAR"}}};

  // Materials, meshes and nodes: one metallic sphere per level, then the dielectric one.
  const int count = static_cast<int>(chain.levels.size()) + 1;
  json materials = json::array(), meshes = json::array(), nodes = json::array();
  json scene_nodes = json::array();
  for (int k = 0; k < count; ++k) {
    const bool diffuse = k + 1 == count;
    const double roughness =
        std::min(kMaxSphereRoughness, diffuse ? 1.0 : chain.levels[k].roughness);
    const std::string name =
        diffuse ? absl::StrCat("white dielectric, roughness ", roughness)
                : absl::StrCat("level ", k, ": metallic, roughness ", chain.levels[k].roughness);
    materials.push_back({{"name", name},
                         {"pbrMetallicRoughness",
                          {{"baseColorFactor", {1, 1, 1, 1}},
                           {"metallicFactor", diffuse ? 0 : 1},
                           {"roughnessFactor", roughness}}}});
    meshes.push_back(
        {{"name", name},
         {"primitives",
          {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"material", k}}}}});
    const double x = kSphereSpacing * (k - (count - 1) / 2.0);
    nodes.push_back({{"name", name}, {"mesh", k}, {"translation", {x, 0, 0}}});
    scene_nodes.push_back(k);
  }
  // The camera: orthographic, at +Z looking down -Z, framing the row.
  const double half_width = kSphereSpacing * (count - 1) / 2.0 + 1.5 * kSphereRadius;
  doc["cameras"] = {
      {{"type", "orthographic"},
       {"orthographic",
        {{"xmag", half_width}, {"ymag", half_width * 0.25}, {"znear", 0.1}, {"zfar", 20}}}}};
  nodes.push_back({{"name", "camera"}, {"camera", 0}, {"translation", {0, 0, 10}}});
  scene_nodes.push_back(count);
  doc["materials"] = materials;
  doc["meshes"] = meshes;
  doc["nodes"] = nodes;
  doc["scenes"] = {{{"nodes", scene_nodes}, {"extensions", {{kExtension, {{"light", 0}}}}}}};
  doc["scene"] = 0;

  // The light: images per level and face.
  json images = json::array(), specular = json::array();
  for (const ibl::SpecularLevel& level : chain.levels) {
    json faces = json::array();
    for (int f = 0; f < kCubeFaceCount; ++f) {
      SHRM_ASSIGN_OR_RETURN(const std::string png, FacePng(level, f, &out.clamped));
      const int view = bin.Add(png.data(), png.size(), 0);
      faces.push_back(images.size());
      images.push_back({{"bufferView", view}, {"mimeType", "image/png"}});
    }
    specular.push_back(faces);
  }
  doc["images"] = images;
  json coefficients = json::array();
  for (const auto& c : irradiance_coefficients) coefficients.push_back({c[0], c[1], c[2]});
  json light = {{"name", options.light_name},
                {"intensity", options.intensity},
                {"rotation", options.rotation},
                {"irradianceCoefficients", coefficients},
                {"specularImageSize", chain.levels.front().face_size},
                {"specularImages", specular}};
  doc["extensions"] = {{kExtension, {{"lights", {light}}}}};

  while (bin.bin().size() % 4) bin.bin().push_back('\0');
  doc["bufferViews"] = bin.views();
  doc["buffers"] = {{{"byteLength", bin.bin().size()}}};
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');

  std::string& glb = out.glb;
  AppendU32(&glb, kGlbMagic);
  AppendU32(&glb, 2);
  AppendU32(&glb, static_cast<uint32_t>(12 + 8 + text.size() + 8 + bin.bin().size()));
  AppendU32(&glb, static_cast<uint32_t>(text.size()));
  AppendU32(&glb, kJsonChunk);
  glb += text;
  AppendU32(&glb, static_cast<uint32_t>(bin.bin().size()));
  AppendU32(&glb, kBinChunk);
  glb += bin.bin();
  return out;
}

}  // namespace shrm::gltf
