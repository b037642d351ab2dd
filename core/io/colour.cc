#include "core/io/colour.h"

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
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "core/base/status_macros.h"
#include "core/io/image_module.h"

namespace shrm {
namespace {

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

// A colour space of the built-in config: its name, aliases and whether it is data.
struct BuiltinSpace {
  std::string name;
  std::vector<std::string> aliases;
  bool is_data = false;
};

// The built-in config's colour spaces, read from its text (the "- !<ColorSpace>" entries' name,
// aliases and isdata lines), so that the identity conversion of every default job needs no
// OpenColorIO (tests/colour_test.cc checks the table against OpenColorIO's own parse).
const std::vector<BuiltinSpace>& BuiltinSpaces() {
  static const auto* const spaces = [] {
    auto* out = new std::vector<BuiltinSpace>();
    std::istringstream in{std::string(kBuiltinConfig)};
    std::string line;
    bool in_space = false;
    while (std::getline(in, line)) {
      const std::string t(absl::StripAsciiWhitespace(line));
      if (t == "- !<ColorSpace>") {
        out->emplace_back();
        in_space = true;
      } else if (!in_space || t.empty()) {
        continue;
      } else if (absl::StartsWith(t, "name: ")) {
        out->back().name = t.substr(6);
      } else if (absl::StartsWith(t, "aliases: [") && absl::EndsWith(t, "]")) {
        for (absl::string_view a : absl::StrSplit(t.substr(10, t.size() - 11), ',')) {
          out->back().aliases.emplace_back(absl::StripAsciiWhitespace(a));
        }
      } else if (t == "isdata: true") {
        out->back().is_data = true;
      }
    }
    return out;
  }();
  return *spaces;
}

// The built-in space that `name` names (OpenColorIO compares names and aliases case-blind).
const BuiltinSpace* FindBuiltinSpace(const std::string& name) {
  for (const BuiltinSpace& s : BuiltinSpaces()) {
    if (absl::EqualsIgnoreCase(s.name, name)) return &s;
    for (const std::string& a : s.aliases)
      if (absl::EqualsIgnoreCase(a, name)) return &s;
  }
  return nullptr;
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
  SHRM_ASSIGN_OR_RETURN(const image_module::Api* module, image_module::Get());
  return module->list_colour_spaces(ResolveConfigPath(config_path), ColourConfigSource(config_path),
                                    kBuiltinConfig);
}

absl::Status ConvertColourSpace(std::span<float> rgb_interleaved, const std::string& from,
                                const std::string& to, const std::string& config_path) {
  if (rgb_interleaved.size() % 3 != 0) {
    return absl::InvalidArgumentError(absl::StrCat("colour conversion needs RGB triples, got ",
                                                   rgb_interleaved.size(), " values"));
  }
  // The identity within the built-in config (both names of one space, or a data space): what
  // OpenColorIO would do, without loading it.
  if (ResolveConfigPath(config_path).empty()) {
    const BuiltinSpace* src = FindBuiltinSpace(from);
    const BuiltinSpace* dst = FindBuiltinSpace(to);
    if (src != nullptr && dst != nullptr && (src == dst || src->is_data || dst->is_data)) {
      return absl::OkStatus();
    }
  }
  SHRM_ASSIGN_OR_RETURN(const image_module::Api* module, image_module::Get());
  return module->convert_colour_space(rgb_interleaved, from, to, ResolveConfigPath(config_path),
                                      ColourConfigSource(config_path), kBuiltinConfig);
}

absl::StatusOr<std::string> DefaultInputColourSpace(const std::string& path,
                                                    const ImageLimits& limits) {
  SHRM_ASSIGN_OR_RETURN(ImageHeader header, ProbeImage(path, limits));
  // EXR, Radiance HDR and PFM hold only half or float pixels, PNG only integers; TIFF either.
  bool is_float = header.format != "png";
  if (header.format == "tiff") {
    SHRM_ASSIGN_OR_RETURN(const image_module::Api* module, image_module::Get());
    SHRM_ASSIGN_OR_RETURN(is_float, module->is_float(path, limits, header.format));
  }
  return std::string(is_float ? kLinRec709 : kSrgbTexture);
}

}  // namespace shrm
