#include "core/shrm/shrm_file.h"

#include <cmath>
#include <string_view>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"
#include "core/io/cube_exr.h"

namespace shrm {
namespace {

// A light's direction is stored to 9 digits: unit within ~1e-8; 1e-5 admits any writer's
// single-precision rounding and refuses what is not a direction.
constexpr double kLightUnitTolerance = 1e-5;

const std::map<std::string, std::string>& ConventionAttributes() {
  static const auto* attrs = new std::map<std::string, std::string>{
      {"shrm:format", kShrmFormatTag},
      {"shrm:basis",
       "real orthonormal SH with Condon-Shortley phase; channel Y_p_q holds coefficient (p,q); "
       "Y_p_q = sqrt2 K P_p^q(cos t) cos(q f) (q>0), sqrt2 K P_p^|q|(cos t) sin(|q| f) (q<0)"},
      {"shrm:frame",
       "world right-handed, +Y up; SH frame x_s=+X, y_s=-Z, z_s=+Y; (t, f) SH angles"},
      {"shrm:face_order",
       "OpenGL cube map: parts px nx py ny pz nz, GL major-axis table, row 0 = t 0"},
      {"shrm:eval",
       "R = 2(N.V)N - V (index reflection) or T (index tangent) picks the texel; global: "
       "B = sum c_pq Y_pq(V_s); local: B = sum c_pq Y_pq(Rot^T V_s), Rot = Rz(beta) Ry(alpha), "
       "(alpha, beta) the SH angles of R; V_s = V in the SH frame"},
  };
  return *attrs;
}

// shrm:lights' text: the count, then per light its unit direction and its three weights.
absl::StatusOr<std::vector<ShrmLight>> ParseShrmLights(const std::string& label,
                                                       const std::string& text) {
  const std::vector<std::string> words = absl::StrSplit(text, ' ', absl::SkipEmpty());
  size_t count = 0;
  if (words.empty() || !absl::SimpleAtoi(words[0], &count) || count > kMaxShrmLights ||
      words.size() != 1 + 6 * count) {
    return absl::InvalidArgumentError(absl::StrCat(
        label, ": bad shrm:lights (expected 'K' and K x 6 numbers, K <= ", kMaxShrmLights, ")"));
  }
  std::vector<ShrmLight> lights(count);
  for (size_t k = 0; k < count; ++k) {
    float v[6];
    for (int i = 0; i < 6; ++i) {
      const std::string& word = words[1 + 6 * k + i];
      if (!absl::SimpleAtof(word, &v[i]) || !std::isfinite(v[i])) {
        return absl::InvalidArgumentError(
            absl::StrCat(label, ": bad shrm:lights value '", word, "' (light ", k, ")"));
      }
    }
    const double norm = std::sqrt(double{v[0]} * v[0] + double{v[1]} * v[1] + double{v[2]} * v[2]);
    if (!(std::abs(norm - 1) <= kLightUnitTolerance)) {
      return absl::InvalidArgumentError(absl::StrCat(label, ": bad shrm:lights direction of light ",
                                                     k, " (norm ", norm, ", not unit)"));
    }
    lights[k].dir = {v[0], v[1], v[2]};
    lights[k].weight = {v[3], v[4], v[5]};
  }
  return lights;
}

}  // namespace

std::map<std::string, std::string> ShrmConventionAttributes(const ShrmCube& cube) {
  std::map<std::string, std::string> attrs = ConventionAttributes();
  attrs["shrm:kind"] = cube.kind == ShrmKind::kLocal ? "local" : "global";
  attrs["shrm:index"] = cube.index == ReparamKind::kTangent ? "tangent" : "reflection";
  attrs["shrm:pmax"] = absl::StrCat(cube.pmax);
  attrs["shrm:view_variable"] = ViewVariableName(cube.view);
  if (cube.view == ViewVariable::kNormal) {
    attrs["shrm:eval"] =
        "R = 2(N.V)N - V picks the texel; global: B = sum c_pq Y_pq(N_s); local: B = sum c_pq "
        "Y_pq(Rot^T N_s), Rot = Rz(beta) Ry(alpha), (alpha, beta) the SH angles of R; N_s = the "
        "normal N = (R + V)/|R + V| in the SH frame (N.R >= 0 only)";
  }
  if (!cube.fresnel.empty() && cube.index == ReparamKind::kReflection) {
    const int ch = FresnelChannels(cube.fresnel.size());
    absl::StrAppend(&attrs["shrm:eval"],
                    "; times w(N.V) of shrm:fresnel: 'K C v_0 .. v_K' (C channels per node, "
                    "node k at N.V = 1 - k / K; Catmull-Rom in N.V, ghost nodes "
                    "v_-1 = 3 (v_0 - v_1) + v_2, v_K+1 = 3 (v_K - v_K-1) + v_K-2); N.V = N.R ",
                    cube.view == ViewVariable::kNormal ? "(normal)" : "= |R + V| / 2 (view)");
    std::string table = absl::StrCat(kFresnelIntervals, " ", ch);
    for (float v : cube.fresnel) absl::StrAppend(&table, " ", absl::StrFormat("%.9g", v));
    attrs["shrm:fresnel"] = table;
  }
  if (!cube.lights.empty()) {
    absl::StrAppend(&attrs["shrm:eval"],
                    "; plus the directional lights of shrm:lights: 'K x_1 y_1 z_1 r_1 g_1 b_1 .. "
                    "b_K' (world unit directions, radiance x solid angle), B += sum_k w_k "
                    "f_r(N, V, d_k) max(N.d_k, 0) with the BRDF of shrm:brdf (docs/formats.md)");
    std::string list = absl::StrCat(cube.lights.size());
    for (const ShrmLight& light : cube.lights) {
      for (float v : light.dir) absl::StrAppend(&list, " ", absl::StrFormat("%.9g", v));
      for (float v : light.weight) absl::StrAppend(&list, " ", absl::StrFormat("%.9g", v));
    }
    attrs["shrm:lights"] = list;
  }
  return attrs;
}

absl::Status ParseShrmConventionAttributes(const std::string& label,
                                           const std::map<std::string, std::string>& attributes,
                                           ShrmCube* cube) {
  auto attr = [&](const std::string& k) -> absl::StatusOr<std::string> {
    auto it = attributes.find(k);
    if (it == attributes.end()) {
      return absl::InvalidArgumentError(
          absl::StrCat(label, ": not an SHRM file (header attribute ", k, " missing)"));
    }
    return it->second;
  };
  SHRM_ASSIGN_OR_RETURN(const std::string format, attr("shrm:format"));
  if (format != kShrmFormatTag) {
    return absl::InvalidArgumentError(absl::StrCat(label, ": unsupported SHRM format '", format,
                                                   "' (expected ", kShrmFormatTag, ")"));
  }
  SHRM_ASSIGN_OR_RETURN(const std::string kind, attr("shrm:kind"));
  SHRM_ASSIGN_OR_RETURN(const std::string index, attr("shrm:index"));
  SHRM_ASSIGN_OR_RETURN(const std::string pmax, attr("shrm:pmax"));
  if (kind != "local" && kind != "global") {
    return absl::InvalidArgumentError(absl::StrCat(label, ": bad shrm:kind '", kind, "'"));
  }
  if (index != "reflection" && index != "tangent") {
    return absl::InvalidArgumentError(absl::StrCat(label, ": bad shrm:index '", index, "'"));
  }
  // P <= 255 keeps (P + 1)^2 and every size computed from it far from overflow.
  constexpr int kMaxPmax = 255;
  if (!absl::SimpleAtoi(pmax, &cube->pmax) || cube->pmax < 0 || cube->pmax > kMaxPmax) {
    return absl::InvalidArgumentError(absl::StrCat(label, ": bad shrm:pmax '", pmax, "'"));
  }
  // shrm:view_variable: absent in files written before the normal variable existed (they are
  // "view").
  cube->view = ViewVariable::kView;
  if (auto it = attributes.find("shrm:view_variable"); it != attributes.end()) {
    if (it->second == "normal" && index == "reflection") {
      cube->view = ViewVariable::kNormal;
    } else if (it->second != "view") {
      return absl::InvalidArgumentError(absl::StrCat(label, ": bad shrm:view_variable '",
                                                     it->second,
                                                     "' (view, or normal with index reflection)"));
    }
  }
  // shrm:fresnel: absent for models without a Fresnel factor and files written before the
  // normalization (w = 1); reflection-indexed SHRMs only (conventions 3: the normal variable only).
  cube->fresnel.clear();
  if (auto it = attributes.find("shrm:fresnel"); it != attributes.end()) {
    const std::vector<std::string> words = absl::StrSplit(it->second, ' ', absl::SkipEmpty());
    int k = 0, ch = 0;
    const bool header = words.size() >= 2 && absl::SimpleAtoi(words[0], &k) &&
                        absl::SimpleAtoi(words[1], &ch) && k == kFresnelIntervals &&
                        (ch == 1 || ch == 3) && words.size() == 2 + static_cast<size_t>(k + 1) * ch;
    if (!header || index == "tangent") {
      return absl::InvalidArgumentError(absl::StrCat(label, ": bad shrm:fresnel (expected '",
                                                     kFresnelIntervals, " C' and (",
                                                     kFresnelIntervals,
                                                     " + 1) x C positive values, C = 1 or 3, with "
                                                     "shrm:index reflection)"));
    }
    for (size_t i = 2; i < words.size(); ++i) {
      float v = 0;
      if (!absl::SimpleAtof(words[i], &v) || !(v > 0) || !std::isfinite(v)) {
        return absl::InvalidArgumentError(
            absl::StrCat(label, ": bad shrm:fresnel value '", words[i], "' (must be positive)"));
      }
      cube->fresnel.push_back(v);
    }
  }
  // shrm:lights: absent when the expansion is the whole reflection (and in files written before
  // lights existed).
  cube->lights.clear();
  if (auto it = attributes.find("shrm:lights"); it != attributes.end()) {
    SHRM_ASSIGN_OR_RETURN(cube->lights, ParseShrmLights(label, it->second));
  }
  cube->kind = kind == "local" ? ShrmKind::kLocal : ShrmKind::kGlobal;
  cube->index = index == "tangent" ? ReparamKind::kTangent : ReparamKind::kReflection;
  return absl::OkStatus();
}

std::string BrdfAttribute(const ShrmFile& file) {
  auto it = file.attributes.find("shrm:brdf");
  return it == file.attributes.end() ? std::string() : it->second;
}

absl::StatusOr<std::unique_ptr<Brdf>> ShrmFileBrdf(const ShrmFile& file, const std::string& label) {
  absl::StatusOr<std::unique_ptr<Brdf>> brdf = ParseBrdfSpec(BrdfAttribute(file));
  if (!brdf.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        label, ": its peak lights need the BRDF of shrm:brdf: ", brdf.status().message()));
  }
  return brdf;
}

std::string ShrmChannelGroup(int p, int q) { return absl::StrCat("Y_", p, "_", q); }

namespace {

// The cube file's layout and attributes (the values stay in `cube`).
absl::StatusOr<CubeExr> ShrmCubeExr(const std::string& path, const ShrmCube& cube,
                                    const std::map<std::string, std::string>& extra, bool half) {
  if (cube.face_size < 1 || cube.pmax < 0 || cube.channels != 3 ||
      cube.data.size() != cube.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": inconsistent SHRM cube (face size ", cube.face_size, ", P ",
                     cube.pmax, ", channels ", cube.channels, ", ", cube.data.size(), " values)"));
  }
  CubeExr exr;
  exr.face_size = cube.face_size;
  exr.half = half;
  for (int p = 0; p <= cube.pmax; ++p)
    for (int q = -p; q <= p; ++q) exr.group_names.push_back(ShrmChannelGroup(p, q));
  for (const auto& [k, v] : extra) {
    if (!absl::StartsWith(k, "shrm:")) {
      return absl::InvalidArgumentError(absl::StrCat("SHRM attribute ", k, " lacks shrm: prefix"));
    }
    exr.attributes[k] = v;
  }
  for (auto& [k, v] : ShrmConventionAttributes(cube)) exr.attributes[k] = std::move(v);
  return exr;
}

}  // namespace

absl::StatusOr<std::string> EncodeShrmFile(const std::string& path, const ShrmCube& cube,
                                           const std::map<std::string, std::string>& extra,
                                           bool half) {
  SHRM_ASSIGN_OR_RETURN(const CubeExr exr, ShrmCubeExr(path, cube, extra, half));
  // cube.data has the file's layout (texel-major, then coefficient, then channel): encoded in
  // place rather than copied (a large SHRM is hundreds of MB).
  return EncodeCubeExr(exr, path, cube.data);
}

absl::Status WriteShrmFile(const std::string& path, const ShrmCube& cube,
                           const std::map<std::string, std::string>& extra, bool half) {
  SHRM_ASSIGN_OR_RETURN(const CubeExr exr, ShrmCubeExr(path, cube, extra, half));
  // Streamed: the encoded file is never held whole (a default job's 233 MB file cost as much
  // again in fresh memory, zeroed by the kernel page by page).
  return WriteCubeExr(path, exr, cube.data);
}

absl::StatusOr<ShrmFile> ReadShrmFile(const std::string& path, const ImageLimits& limits) {
  SHRM_ASSIGN_OR_RETURN(CubeExr exr, ReadCubeExr(path, limits));
  ShrmFile file;
  ShrmCube& cube = file.cube;
  SHRM_RETURN_IF_ERROR(ParseShrmConventionAttributes(path, exr.attributes, &cube));
  if (ShCount(cube.pmax) != exr.groups()) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": shrm:pmax '", cube.pmax, "' does not match ", exr.groups(), " channel triples"));
  }
  // OpenEXR stores channels sorted by name, so map each coefficient's triple by its name.
  std::map<std::string, int> group_of;
  for (int g = 0; g < exr.groups(); ++g) group_of[exr.group_names[g]] = g;
  std::vector<int> source(exr.groups());
  for (int p = 0; p <= cube.pmax; ++p)
    for (int q = -p; q <= p; ++q) {
      auto it = group_of.find(ShrmChannelGroup(p, q));
      if (it == group_of.end()) {
        return absl::InvalidArgumentError(
            absl::StrCat(path, ": channel triple ", ShrmChannelGroup(p, q), " missing"));
      }
      source[ShIndex(p, q)] = it->second;
    }
  cube.face_size = exr.face_size;
  cube.channels = 3;
  cube.data.resize(cube.size());
  const int groups = exr.groups();
  const size_t texels = size_t{6} * cube.face_size * cube.face_size;
  for (size_t t = 0; t < texels; ++t)
    for (int k = 0; k < groups; ++k)
      for (int c = 0; c < 3; ++c)
        cube.data[(t * groups + k) * 3 + c] = exr.data[(t * groups + source[k]) * 3 + c];
  file.attributes = std::move(exr.attributes);
  return file;
}

}  // namespace shrm
