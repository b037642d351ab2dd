#include "jobs/ibl_outputs.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/export/gltf_ibl.h"
#include "core/export/ktx1.h"
#include "core/export/ktx2.h"
#include "core/ibl/sh9.h"
#include "core/io/image.h"
#include "shrm/version.h"

namespace shrm::jobs {
namespace {

// The cube convention every cube file states (docs/ibl.md "Orientation").
constexpr char kCubeConvention[] =
    "faces +X,-X,+Y,-Y,+Z,-Z in the OpenGL/Vulkan cube-map convention (row 0 = t 0); world frame "
    "right-handed, +Y up (shrm docs/conventions.md)";

absl::StatusOr<std::string> EncodeCube(const IblJob& job, const IblRun& run, const IblCube& cube) {
  const ktx2::Format format = IblKtx2Format(job.format);
  ktx2::Ktx2Image image;
  image.format = format;
  image.faces = 6;
  image.width = image.height = cube.chain.levels.front().face_size;
  std::vector<std::string> roughness, degree, measured;
  for (size_t k = 0; k < cube.chain.levels.size(); ++k) {
    const ibl::SpecularLevel& l = cube.chain.levels[k];
    ktx2::Level level;
    level.width = level.height = l.face_size;
    level.rgb = l.cube.data;  // read in place: the cube's RGB (alpha 1 for a four-channel format)
    image.levels.push_back(std::move(level));
    roughness.push_back(absl::StrFormat("%.17g", l.roughness));  // round-trips the double
    degree.push_back(absl::StrCat(l.degree));
    if (k < cube.measured.size() && cube.measured[k].count > 0) {
      measured.push_back(absl::StrCat(cube.measured[k].rms, "/", cube.measured[k].max));
    }
  }
  std::map<std::string, std::string>& kv = image.key_values;
  kv["shrm:version"] = kVersion;
  kv["shrm:content"] =
      cube.name == "irradiance"
          ? "irradiance / pi (cosine-weighted mean radiance) by normal"
          : absl::StrCat("split-sum prefiltered radiance (N = V = R), lobe ",
                         ibl::SpecularLobeName(cube.chain.lobe), ", one roughness per level");
  kv["shrm:units"] = absl::StrCat("linear radiance, working space ", job.env.working_colour_space);
  kv["shrm:cube"] = kCubeConvention;
  if (cube.name != "irradiance") {
    kv["shrm:preset"] = ibl::RoughnessPresetName(job.preset);
    kv["shrm:roughness"] = absl::StrJoin(roughness, ",");
    kv["shrm:alpha"] = "roughness^2";
  }
  kv["shrm:degree"] = absl::StrJoin(degree, ",");
  if (!measured.empty()) kv["shrm:measured_error"] = absl::StrJoin(measured, ",");
  kv["shrm:source"] = run.source.names;
  kv["shrm:source_sha256"] = run.source.sha256;
  if (job.env.rotate_ypr_deg) kv["shrm:rotate_ypr_deg"] = RotationAttribute(job.env);
  ktx2::EncodeOptions opt;
  opt.writer = absl::StrCat("shrm ", kVersion);
  opt.negatives = ktx2::Negatives::kClampToZero;  // already clamped (StoreAs); -0.0 stays 0
  return ktx2::EncodeKtx2(image, opt);
}

// The DFG table as a 2D KTX2 (half floats: 1-2 channels R16G16, 3 R16G16B16, 4 R16G16B16A16),
// and as 3-channel float EXR and 8-bit PNG images (missing channels 0; the PNG clamps to
// [0, 1] like the glTF sample viewer's LUT files, so the Charlie channel's values above 1 at
// grazing views are only in the KTX2 and EXR); rows as the consumer stores them (row 0 first:
// GL t = 0, the PNG's top row).
absl::Status EncodeDfg(const IblJob& job, const IblRun& run, std::vector<IblFile>* files) {
  const ibl::DfgLut& lut = *run.dfg;
  const std::string consumer = ibl::DfgConsumerName(*ResolvedDfg(job));
  const int ch = lut.channels;
  const ktx2::Format format = ch <= 2   ? ktx2::Format::kR16G16Sfloat
                              : ch == 3 ? ktx2::Format::kR16G16B16Sfloat
                                        : ktx2::Format::kR16G16B16A16Sfloat;
  const int kch = ktx2::ChannelCount(format);
  const size_t texels = static_cast<size_t>(lut.size) * lut.size;
  ktx2::Ktx2Image image;
  image.format = format;
  image.width = image.height = lut.size;
  ktx2::Level level;
  level.width = level.height = lut.size;
  level.pixels.assign(texels * kch, 0.0f);
  Image rgb;
  rgb.width = rgb.height = lut.size;
  rgb.channels = 3;
  rgb.pixels.assign(texels * 3, 0.0f);
  for (size_t t = 0; t < texels; ++t)
    for (int c = 0; c < ch; ++c) {
      level.pixels[t * kch + c] = lut.data[t * ch + c];
      if (c < 3) rgb.pixels[t * 3 + c] = lut.data[t * ch + c];
    }
  image.levels.push_back(std::move(level));
  image.key_values["shrm:version"] = kVersion;
  image.key_values["shrm:content"] = absl::StrCat(
      "split-sum DFG lookup table for ", consumer,
      ": column i at N.V = (i + 0.5) / n, row j at roughness (j + 0.5) / n (docs/ibl_dfg.md)");
  ktx2::EncodeOptions opt;
  opt.writer = absl::StrCat("shrm ", kVersion);
  // Uncompressed: zip shrinks this smooth table by 3% and took 5 ms of a 110 ms `shrm ibl`.
  SHRM_ASSIGN_OR_RETURN(std::string exr, EncodeImage(rgb, ImageEncoding::kExrFloatUncompressed));
  SHRM_ASSIGN_OR_RETURN(std::string png, EncodeImage(rgb, ImageEncoding::kPng8));
  const std::string what = absl::StrCat("DFG table (", consumer, "), ", lut.size, " x ", lut.size);
  if (HasContainer(job, IblContainer::kKtx2)) {
    SHRM_ASSIGN_OR_RETURN(std::string ktx, ktx2::EncodeKtx2(image, opt));
    files->push_back({"dfg.ktx2", std::move(ktx), what, "table"});
  }
  files->push_back({"dfg.exr", std::move(exr), what + ", float", "table"});
  files->push_back({"dfg.png", std::move(png), what + ", 8-bit", "table"});
  return absl::OkStatus();
}

// KTX1 for Filament (docs/ibl.md "KTX1 for Filament"): cmgen --deploy's ibl.ktx (the specular
// chain, the irradiance SH as the "sh" key), skybox.ktx (level 0) and sh.txt, with the faces in
// Filament's frame (the cube a cmgen import of the same lat-long map gives: core/ibl/sh9.h
// ConsumerFrameMatrix(kFilament), an exact permutation of our texels).
ktx1::Format Ktx1Format(IblFormat format) {
  switch (format) {
    case IblFormat::kRgba32f:
      return ktx1::Format::kRgb32f;
    case IblFormat::kB10g11r11:
      return ktx1::Format::kR11fG11fB10f;
    default:
      return ktx1::Format::kRgb16f;  // rgba16f (rgb9e5 is refused by ValidateIblJob)
  }
}

absl::Status EncodeKtx1(const IblJob& job, const IblRun& run, std::vector<IblFile>* files) {
  const Mat3 frame = ibl::ConsumerFrameMatrix(ibl::Sh9Convention::kFilament);
  SHRM_ASSIGN_OR_RETURN(
      const ibl::Sh9Rgb sh,
      ibl::ConvertRadianceSh9(run.radiance_sh9, 2, ibl::Sh9Convention::kFilament));
  std::string sh_key, sh_txt;
  for (int l = 0, i = 0; l <= 2; ++l)
    for (int m = -l; m <= l; ++m, ++i) {
      absl::StrAppendFormat(&sh_key, "%.9g %.9g %.9g\n", sh[i][0], sh[i][1], sh[i][2]);
      // cmgen's outputSh lines.
      absl::StrAppendFormat(&sh_txt,
                            "(%18.15f, %18.15f, %18.15f); // L%d%d, irradiance, pre-scaled base\n",
                            sh[i][0], sh[i][1], sh[i][2], l, m);
    }
  ktx1::Ktx1Cube ibl_cube;
  ibl_cube.format = Ktx1Format(job.format);
  std::vector<std::string> roughness;
  for (const ibl::SpecularLevel& l : run.specular.chain.levels) {
    ktx1::CubeLevel level;
    level.size = l.face_size;
    level.pixels.resize(l.cube.data.size());
    if (!CubeInFrame(frame, l.face_size, 3, l.cube.data.data(), level.pixels.data())) {
      return absl::InternalError("Filament's frame is not an axis permutation");
    }
    ibl_cube.levels.push_back(std::move(level));
    roughness.push_back(absl::StrFormat("%.17g", l.roughness));
  }
  ktx1::Ktx1Cube sky;
  sky.format = ibl_cube.format;
  sky.levels.push_back(ibl_cube.levels.front());
  const std::string frame_text =
      "Filament's frame as cmgen places a lat-long map: n = (-x, y, -z) of the world direction "
      "(shrm docs/ibl.md); faces +X,-X,+Y,-Y,+Z,-Z in the OpenGL cube-map convention";
  for (ktx1::Ktx1Cube* c : {&ibl_cube, &sky}) {
    c->key_values["shrm:version"] = kVersion;
    c->key_values["shrm:units"] =
        absl::StrCat("linear radiance, working space ", job.env.working_colour_space);
    c->key_values["shrm:cube"] = frame_text;
    c->key_values["shrm:source"] = run.source.names;
    c->key_values["shrm:source_sha256"] = run.source.sha256;
  }
  ibl_cube.key_values["sh"] = sh_key;
  ibl_cube.key_values["shrm:content"] =
      "split-sum prefiltered radiance (N = V = R), lobe GGX, one roughness per level; \"sh\": "
      "Filament's pre-scaled irradiance SH (E / pi)";
  ibl_cube.key_values["shrm:preset"] = ibl::RoughnessPresetName(job.preset);
  ibl_cube.key_values["shrm:roughness"] = absl::StrJoin(roughness, ",");
  sky.key_values["shrm:content"] = "the environment map resampled (the IBL's level 0)";
  const std::string writer = absl::StrCat("shrm ", kVersion);
  SHRM_ASSIGN_OR_RETURN(std::string ibl_bytes, ktx1::EncodeKtx1Cube(ibl_cube, writer));
  SHRM_ASSIGN_OR_RETURN(std::string sky_bytes, ktx1::EncodeKtx1Cube(sky, writer));
  const std::string fmt = ktx1::FormatName(ibl_cube.format);
  files->push_back({"ibl.ktx", std::move(ibl_bytes),
                    absl::StrCat("Filament IBL (KTX1, ", fmt, ", ", ibl_cube.levels.size(),
                                 " levels, SH in the \"sh\" key)"),
                    "ktx1"});
  files->push_back({"skybox.ktx", std::move(sky_bytes),
                    absl::StrCat("Filament skybox (KTX1, ", fmt, ")"), "ktx1"});
  files->push_back(
      {"sh.txt", std::move(sh_txt), "Filament's irradiance SH as cmgen writes sh.txt", "text"});
  return absl::OkStatus();
}

// preview.png (docs/ibl.md "Preview"): one row per level of the specular chain, then one for the
// irradiance cube; in a row the faces +X, -X, +Y, -Y, +Z, -Z (kPreviewTile texels each, nearest
// texel, row 0 = t 0 as stored) and a mirror sphere seen from +Z (+Y up, +X to the right; the
// level at the reflected direction). Exposure: level 0's median luminance at 0.18, then
// TonemapPreview (Reinhard, sRGB). Background and gaps: 0.
Image PreviewSheet(const IblRun& run) {
  const int t = kPreviewTile, g = kPreviewGap;
  std::vector<const ibl::SpecularLevel*> rows;
  for (const ibl::SpecularLevel& l : run.specular.chain.levels) rows.push_back(&l);
  for (const ibl::SpecularLevel& l : run.irradiance.chain.levels) rows.push_back(&l);
  Image sheet;
  sheet.width = 7 * t + 8 * g;
  sheet.height = static_cast<int>(rows.size()) * (t + g) + g;
  sheet.channels = 3;
  sheet.pixels.assign(static_cast<size_t>(sheet.width) * sheet.height * 3, 0.0f);
  auto put = [&](int x, int y, const float* rgb) {
    for (int c = 0; c < 3; ++c)
      sheet.pixels[(static_cast<size_t>(y) * sheet.width + x) * 3 + c] = rgb[c];
  };
  auto texel = [](const ibl::SpecularLevel& l, const Vec3& d) {
    int face = 0;
    double s = 0, tt = 0;
    CubeFaceCoordinates(d, &face, &s, &tt);
    const int n = l.face_size;
    const int x = std::min(n - 1, static_cast<int>(s * n));
    const int y = std::min(n - 1, static_cast<int>(tt * n));
    return &l.cube.data[l.cube.Index(face, x, y, 0)];
  };
  for (size_t r = 0; r < rows.size(); ++r) {
    const ibl::SpecularLevel& l = *rows[r];
    const int y0 = g + static_cast<int>(r) * (t + g);
    for (int face = 0; face < kCubeFaceCount; ++face)
      for (int v = 0; v < t; ++v)
        for (int u = 0; u < t; ++u)
          put(g + face * (t + g) + u, y0 + v, texel(l, CubeTexelDirection(face, u, v, t)));
    for (int j = 0; j < t; ++j)
      for (int i = 0; i < t; ++i) {
        const double x = 2 * (i + 0.5) / t - 1, y = 1 - 2 * (j + 0.5) / t, r2 = x * x + y * y;
        if (r2 >= 1) continue;
        const double z = std::sqrt(1 - r2);  // normal (x, y, z), view +Z: R = 2 z N - V
        put(g + 6 * (t + g) + i, y0 + j, texel(l, Vec3{2 * z * x, 2 * z * y, 2 * z * z - 1}));
      }
  }
  std::vector<double> lum;
  const std::vector<float>& d0 = run.specular.chain.levels.front().cube.data;
  for (size_t i = 0; i < d0.size(); i += 3)
    lum.push_back(0.2126 * d0[i] + 0.7152 * d0[i + 1] + 0.0722 * d0[i + 2]);
  std::nth_element(lum.begin(), lum.begin() + lum.size() / 2, lum.end());
  const double median = lum[lum.size() / 2];
  return TonemapPreview(sheet, median > 0 ? std::log2(0.18 / median) : 0.0);
}

// The SH9 in every consumer's convention (core/ibl/sh9.h) with its frame and what its formula
// returns.
absl::StatusOr<nlohmann::json> Sh9Json(const IblRun& run) {
  nlohmann::json out;
  for (ibl::Sh9Convention conv :
       {ibl::Sh9Convention::kFilament, ibl::Sh9Convention::kGltf, ibl::Sh9Convention::kGltfBabylon,
        ibl::Sh9Convention::kThreeJs, ibl::Sh9Convention::kUnity}) {
    SHRM_ASSIGN_OR_RETURN(const ibl::Sh9Rgb c, ibl::ConvertRadianceSh9(run.radiance_sh9, 2, conv));
    nlohmann::json j;
    if (conv == ibl::Sh9Convention::kUnity) {
      j["coefficients"] = ibl::UnityLayout(c);  // SphericalHarmonicsL2 [channel * 9 + i]
    } else {
      j["coefficients"] = c;  // [i][r, g, b]
    }
    const Mat3 m = ibl::ConsumerFrameMatrix(conv);
    j["frame_from_world"] = {m.m[0], m.m[1], m.m[2]};
    switch (ibl::ConsumerOutput(conv)) {
      case ibl::Sh9Output::kIrradiance:
        j["evaluates_to"] = "irradiance E";
        break;
      case ibl::Sh9Output::kIrradianceOverPi:
        j["evaluates_to"] = "irradiance / pi";
        break;
      default:
        j["evaluates_to"] =
            "Babylon's doubly convolved irradiance (the literal E_lm of the glTF "
            "extension)";
    }
    out[ibl::Sh9ConventionName(conv)] = j;
  }
  return out;
}

// ibl.glb (core/export/gltf_ibl.h): the stored (rounded) GGX chain as RGBD PNG faces and the SH9
// in the extension's frame as the literal E_lm (docs/ibl.md "glTF").
absl::Status EncodeGltf(const IblRun& run, std::vector<IblFile>* files) {
  SHRM_ASSIGN_OR_RETURN(const ibl::Sh9Rgb coeff,
                        gltf::GltfIrradianceCoefficients(run.radiance_sh9));
  gltf::GltfIblOptions opt;
  opt.generator = absl::StrCat("shrm ", kVersion);
  SHRM_ASSIGN_OR_RETURN(gltf::GltfIblFile glb, gltf::EncodeGltfIbl(run.specular.chain, coeff, opt));
  files->push_back(
      {"ibl.glb", std::move(glb.glb),
       absl::StrCat("glTF 2.0 (EXT_lights_image_based: ", run.specular.chain.levels.size(),
                    " RGBD PNG levels, SH9), a sphere per roughness",
                    glb.clamped ? absl::StrCat(", ", glb.clamped, " texels clamped to 255") : ""),
       "gltf"});
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::vector<IblFile>> EncodeIblOutputs(const IblJob& job, const IblRun& run) {
  std::vector<IblFile> files;
  const std::string fmt = IblFormatName(job.format);
  if (HasContainer(job, IblContainer::kKtx2)) {
    SHRM_ASSIGN_OR_RETURN(std::string specular, EncodeCube(job, run, run.specular));
    files.push_back(
        {"specular.ktx2", std::move(specular),
         absl::StrCat("GGX radiance cube, ", run.specular.chain.levels.size(), " levels, ", fmt),
         "cube"});
    if (job.sheen) {
      SHRM_ASSIGN_OR_RETURN(std::string sheen, EncodeCube(job, run, run.sheen));
      files.push_back({"sheen.ktx2", std::move(sheen),
                       absl::StrCat("Charlie sheen radiance cube, ", run.sheen.chain.levels.size(),
                                    " levels, ", fmt),
                       "cube"});
    }
    SHRM_ASSIGN_OR_RETURN(std::string irradiance, EncodeCube(job, run, run.irradiance));
    files.push_back({"irradiance.ktx2", std::move(irradiance),
                     absl::StrCat("irradiance / pi cube, ", fmt), "cube"});
  }
  if (HasContainer(job, IblContainer::kKtx1)) SHRM_RETURN_IF_ERROR(EncodeKtx1(job, run, &files));
  if (HasContainer(job, IblContainer::kGltf)) SHRM_RETURN_IF_ERROR(EncodeGltf(run, &files));
  if (run.dfg) SHRM_RETURN_IF_ERROR(EncodeDfg(job, run, &files));
  if (job.preview) {
    SHRM_ASSIGN_OR_RETURN(std::string png, EncodeImage(PreviewSheet(run), ImageEncoding::kPng8));
    files.push_back({"preview.png", std::move(png),
                     absl::StrCat("contact sheet: ", run.specular.chain.levels.size(),
                                  " specular levels and the irradiance, faces and a mirror sphere"),
                     "image"});
  }
  SHRM_ASSIGN_OR_RETURN(nlohmann::json sh9, Sh9Json(run));
  nlohmann::json sh9_file = {{"radiance_sh9", run.report["radiance_sh9"]},
                             {"sh_window", run.report["sh_window"]},
                             {"conventions", sh9}};
  files.push_back({"sh9.json", sh9_file.dump(2) + "\n",
                   "irradiance SH9 for Filament, glTF, three.js and Unity", "json"});
  nlohmann::json sidecar = run.report;
  nlohmann::json list = nlohmann::json::array();
  for (const IblFile& f : files)
    list.push_back({{"name", f.name}, {"what", f.what}, {"type", f.type}});
  sidecar["files"] = list;
  sidecar["cube_convention"] = kCubeConvention;
  files.push_back({"ibl.json", sidecar.dump(2) + "\n", "the set's description and report", "json"});
  return files;
}

}  // namespace shrm::jobs
