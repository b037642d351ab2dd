#include "core/io/colour.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"

namespace shrm {
namespace {

namespace OCIO = OCIO_NAMESPACE;

// Identical to data/ocio/config.ocio (tests/colour_test.cc compares the two byte for byte).
constexpr char kBuiltinConfig[] = R"ocio(ocio_profile_version: 2

# shrm colour configuration (OpenColorIO 2.1; no LUT files). Scene reference: ACES2065-1 (AP0).
# Keep identical to kBuiltinConfig in core/io/colour.cc (tests/colour_test.cc checks it).
description: shrm environment-map colour spaces (scene-linear working spaces and sRGB texture input)
search_path: ""
strictparsing: true
luma: [0.2126, 0.7152, 0.0722]

roles:
  default: lin_rec709
  scene_linear: lin_rec709
  rendering: lin_rec709
  data: raw
  color_picking: srgb_texture
  texture_paint: srgb_texture
  aces_interchange: lin_ap0
  cie_xyz_d65_interchange: cie_xyz_d65

file_rules:
  - !<Rule> {name: Default, colorspace: default}

displays:
  sRGB:
    - !<View> {name: Raw, colorspace: raw}
    - !<View> {name: Texture, colorspace: srgb_texture}

active_displays: []
active_views: []

colorspaces:
  - !<ColorSpace>
    name: lin_rec709
    aliases: [linear_rec709, lin_srgb, scene_linear_rec709]
    family: scene-linear
    equalitygroup: ""
    bitdepth: 32f
    description: Scene-linear, Rec.709 / sRGB primaries, D65 white (shrm's default working space)
    isdata: false
    encoding: scene-linear
    allocation: uniform
    to_scene_reference: !<GroupTransform>
      children:
        - !<BuiltinTransform> {style: "UTILITY - ACES-AP1_to_LINEAR-REC709_BFD", direction: inverse}
        - !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}

  - !<ColorSpace>
    name: lin_ap1
    aliases: [acescg, ACEScg]
    family: scene-linear
    equalitygroup: ""
    bitdepth: 32f
    description: ACEScg, scene-linear, ACES AP1 primaries, ACES (~D60) white
    isdata: false
    encoding: scene-linear
    allocation: uniform
    to_scene_reference: !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}

  - !<ColorSpace>
    name: lin_ap0
    aliases: [aces2065_1, ACES2065-1]
    family: scene-linear
    equalitygroup: ""
    bitdepth: 32f
    description: ACES2065-1, scene-linear, ACES AP0 primaries (the scene reference of this config)
    isdata: false
    encoding: scene-linear
    allocation: uniform

  - !<ColorSpace>
    name: lin_p3d65
    aliases: [linear_p3d65]
    family: scene-linear
    equalitygroup: ""
    bitdepth: 32f
    description: Scene-linear, P3 primaries, D65 white
    isdata: false
    encoding: scene-linear
    allocation: uniform
    to_scene_reference: !<GroupTransform>
      children:
        - !<MatrixTransform> {matrix: [0.486570948648216, 0.265667693169093, 0.198217285234363, 0, 0.228974564069749, 0.691738521836506, 0.079286914093745, 0, 0, 0.045113381858903, 1.043944368900976, 0, 0, 0, 0, 1]}
        - !<BuiltinTransform> {style: "UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD", direction: inverse}

  - !<ColorSpace>
    name: cie_xyz_d65
    family: scene-linear
    equalitygroup: ""
    bitdepth: 32f
    description: CIE 1931 XYZ, D65 white (interchange space)
    isdata: false
    encoding: scene-linear
    allocation: uniform
    to_scene_reference: !<BuiltinTransform> {style: "UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD", direction: inverse}

  - !<ColorSpace>
    name: srgb_texture
    aliases: [srgb, sRGB, srgb_tx]
    family: texture
    equalitygroup: ""
    bitdepth: 32f
    description: sRGB-encoded (IEC 61966-2-1 piecewise curve), Rec.709 primaries, D65 white; 8-bit inputs
    isdata: false
    encoding: sdr-video
    allocation: uniform
    to_scene_reference: !<GroupTransform>
      children:
        - !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055}
        - !<BuiltinTransform> {style: "UTILITY - ACES-AP1_to_LINEAR-REC709_BFD", direction: inverse}
        - !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}

  - !<ColorSpace>
    name: raw
    aliases: [none]
    family: data
    equalitygroup: ""
    bitdepth: 32f
    description: Not colour, values pass through unchanged
    isdata: true
    allocation: uniform
)ocio";

constexpr char kBuiltinSourceName[] = "<built-in>";

// The file to read for `config_path`, or "" for the built-in text.
std::string ResolveConfigPath(const std::string& config_path) {
  if (!config_path.empty()) return config_path;
  const char* env = std::getenv("OCIO");
  if (env != nullptr && env[0] != '\0') return env;
  return "";
}

absl::StatusOr<OCIO::ConstConfigRcPtr> GetConfig(const std::string& config_path) {
  static std::mutex mu;
  static auto* cache = new std::map<std::string, OCIO::ConstConfigRcPtr>();
  const std::string file = ResolveConfigPath(config_path);
  std::lock_guard<std::mutex> lock(mu);
  auto it = cache->find(file);
  if (it != cache->end()) return it->second;
  const std::string source = file.empty() ? std::string(kBuiltinSourceName) : file;
  OCIO::ConstConfigRcPtr config;
  try {
    if (file.empty()) {
      std::istringstream in{std::string(kBuiltinConfig)};
      config = OCIO::Config::CreateFromStream(in);
    } else {
      if (!std::filesystem::exists(file)) {
        return absl::NotFoundError(absl::StrCat(file, ": OpenColorIO config not found"));
      }
      config = OCIO::Config::CreateFromFile(file.c_str());
    }
    config->validate();
  } catch (const OCIO::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": invalid OpenColorIO config: ", e.what()));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": cannot load OpenColorIO config: ", e.what()));
  }
  (*cache)[file] = config;
  return config;
}

std::vector<std::string> SpaceNames(const OCIO::ConstConfigRcPtr& config) {
  std::vector<std::string> names;
  const int n = config->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL);
  for (int i = 0; i < n; ++i) {
    names.emplace_back(config->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                                        OCIO::COLORSPACE_ALL, i));
  }
  return names;
}

absl::StatusOr<OCIO::ConstColorSpaceRcPtr> FindSpace(const OCIO::ConstConfigRcPtr& config,
                                                     const std::string& name,
                                                     const std::string& config_path) {
  OCIO::ConstColorSpaceRcPtr space;
  try {
    space = config->getColorSpace(name.c_str());
  } catch (const OCIO::Exception&) {
    space = nullptr;
  }
  if (!space) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown colour space '", name, "' (config ", ColourConfigSource(config_path),
                     "); valid names: ", absl::StrJoin(SpaceNames(config), ", ")));
  }
  return space;
}

}  // namespace

std::string_view BuiltinColourConfig() { return kBuiltinConfig; }

std::string ColourConfigSource(const std::string& config_path) {
  if (!config_path.empty()) return config_path;
  const std::string file = ResolveConfigPath(config_path);
  if (!file.empty()) return absl::StrCat("$OCIO=", file);
  return kBuiltinSourceName;
}

absl::StatusOr<std::vector<std::string>> ListColourSpaces(const std::string& config_path) {
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstConfigRcPtr config, GetConfig(config_path));
  try {
    return SpaceNames(config);
  } catch (const OCIO::Exception& e) {
    return absl::InternalError(absl::StrCat("OpenColorIO: ", e.what()));
  }
}

absl::Status ConvertColourSpace(std::span<float> rgb_interleaved, const std::string& from,
                                const std::string& to, const std::string& config_path) {
  if (rgb_interleaved.size() % 3 != 0) {
    return absl::InvalidArgumentError(absl::StrCat("colour conversion needs RGB triples, got ",
                                                   rgb_interleaved.size(), " values"));
  }
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstConfigRcPtr config, GetConfig(config_path));
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstColorSpaceRcPtr src, FindSpace(config, from, config_path));
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstColorSpaceRcPtr dst, FindSpace(config, to, config_path));
  if (std::string(src->getName()) == dst->getName() || rgb_interleaved.empty()) {
    return absl::OkStatus();
  }
  try {
    OCIO::ConstProcessorRcPtr processor = config->getProcessor(src, dst);
    if (processor->isNoOp()) return absl::OkStatus();
    OCIO::ConstCPUProcessorRcPtr cpu = processor->getDefaultCPUProcessor();
    // Rows of at most 2^20 pixels keep the image description's sizes small.
    constexpr size_t kRow = size_t{1} << 20;
    const size_t pixels = rgb_interleaved.size() / 3;
    for (size_t start = 0; start < pixels; start += kRow) {
      const size_t n = std::min(kRow, pixels - start);
      OCIO::PackedImageDesc desc(rgb_interleaved.data() + start * 3, static_cast<long>(n), 1, 3);
      cpu->apply(desc);
    }
  } catch (const OCIO::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("cannot convert from '", from, "' to '", to,
                                                   "' (config ", ColourConfigSource(config_path),
                                                   "): ", e.what()));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::string> DefaultInputColourSpace(const std::string& path,
                                                    const ImageLimits& limits) {
  SHRM_ASSIGN_OR_RETURN(ImageHeader header, ProbeImage(path, limits));  // also sets OIIO options
  auto in = OIIO::ImageInput::create(header.format);
  if (!in) {
    return absl::InternalError(
        absl::StrCat(path, ": no OpenImageIO reader for format ", header.format));
  }
  OIIO::ImageSpec spec;
  if (!in->open(path, spec)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": cannot read ", header.format, " header: ", in->geterror()));
  }
  in->close();
  const auto base = static_cast<OIIO::TypeDesc::BASETYPE>(spec.format.basetype);
  const bool is_float = base == OIIO::TypeDesc::HALF || base == OIIO::TypeDesc::FLOAT ||
                        base == OIIO::TypeDesc::DOUBLE;
  return std::string(is_float ? kLinRec709 : kSrgbTexture);
}

}  // namespace shrm
