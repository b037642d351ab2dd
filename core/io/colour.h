// Colour-space conversion of input pixels to a linear working space through OpenColorIO 2.1, and
// an 8-bit image writer (for sRGB-encoded test inputs and previews).
//
// shrm ships its own small OCIO v2 config (data/ocio/config.ocio; OCIO 2.1 has no built-in
// configs). It uses only matrix, exponent-with-linear-segment and OCIO built-in transforms, so it
// needs no LUT files. Scene reference: ACES2065-1. Colour spaces (docs/envmap.md):
//   lin_rec709    scene-linear, Rec.709/sRGB primaries, D65 (the default working space)
//   lin_ap1       ACEScg: scene-linear, ACES AP1 primaries
//   lin_ap0       ACES2065-1: scene-linear, ACES AP0 primaries
//   lin_p3d65     scene-linear, P3 primaries, D65
//   cie_xyz_d65   CIE XYZ, D65
//   srgb_texture  sRGB-encoded (IEC 61966-2-1 curve), Rec.709 primaries (8-bit inputs)
//   raw           data: values pass through unchanged
// Aliases (e.g. "acescg", "srgb") are accepted wherever a colour-space name is.
//
// Which config is used (`config_path` arguments):
//   1. a non-empty `config_path`: that file;
//   2. otherwise the $OCIO environment variable, if set and non-empty;
//   3. otherwise the config text compiled into colour.cc (kept identical to data/ocio/config.ocio;
//      tests/colour_test.cc checks it), so the binary does not need the source tree at run time.
// Configs are parsed once per path and cached for the life of the process.
//
// Every OpenColorIO exception is caught here and returned as an absl::Status; none crosses the
// module boundary. All functions are thread-safe.
#ifndef SHRM_CORE_IO_COLOUR_H_
#define SHRM_CORE_IO_COLOUR_H_

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/image.h"

namespace shrm {

// Names in the shipped config.
inline constexpr char kLinRec709[] = "lin_rec709";
inline constexpr char kSrgbTexture[] = "srgb_texture";
inline constexpr char kRawColourSpace[] = "raw";
// The default working space: scene-linear Rec.709.
inline constexpr char kDefaultWorkingColourSpace[] = "lin_rec709";

// The config text compiled into the library (identical to data/ocio/config.ocio).
std::string_view BuiltinColourConfig();

// Where a config would be read from for `config_path`: the path itself, "$OCIO=<path>", or
// "<built-in>" (for messages and logs).
std::string ColourConfigSource(const std::string& config_path = "");

// Names of all colour spaces of the config (aliases not included), in config order.
// Errors: NotFound / InvalidArgument when the config cannot be read or parsed (message names the
// file and OpenColorIO's reason).
absl::StatusOr<std::vector<std::string>> ListColourSpaces(const std::string& config_path = "");

// Converts interleaved RGB triples in place from colour space `from` to `to`. Identity when both
// name the same space (or either is a data space). Errors: InvalidArgument for a size that is not
// a multiple of 3, or an unknown colour space (the message lists the valid names); config errors
// as ListColourSpaces.
absl::Status ConvertColourSpace(std::span<float> rgb_interleaved, const std::string& from,
                                const std::string& to, const std::string& config_path = "");

// Default input colour space of an image file from its pixel type (the header only, reader chosen
// by magic bytes as in image.h): integer pixel types (8- and 16-bit PNG/TIFF) are sRGB-encoded
// ("srgb_texture"); float and half types (EXR, HDR, PFM, float TIFF) are scene-linear Rec.709
// ("lin_rec709"). Errors: those of ProbeImage().
absl::StatusOr<std::string> DefaultInputColourSpace(const std::string& path,
                                                    const ImageLimits& limits = {});

}  // namespace shrm

#endif  // SHRM_CORE_IO_COLOUR_H_
