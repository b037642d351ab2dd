// The SHRM file: an SHRM cube (shrm_map.h) in a six-part OpenEXR (core/io/cube_exr.h), one part
// per cube face, one RGB channel triple per SH coefficient, self-describing in its header.
// docs/formats.md is the specification another program reads it by; in short:
//   parts "px" "nx" "py" "ny" "pz" "nz" (GL order), S x S float32 (or half) texels;
//   channels "Y_<p>_<q>.R/.G/.B" for the real SH coefficient (p, q), q in [-p, p];
//   string attributes (every part):
//     shrm:format      "shrm-cube/1"
//     shrm:kind        "local" | "global"
//     shrm:index       "reflection" | "tangent" (what addresses the texels)
//     shrm:pmax        P_B
//     shrm:basis       real SH statement (Condon-Shortley phase, index l(l+1)+m)
//     shrm:frame       world/SH frame statement
//     shrm:face_order  GL face order and orientation statement
//     shrm:eval        how to evaluate B(N, V) from a texel (local / global formula)
//     shrm:lights      (optional) directional lights summed beside the expansion (shrm_map.h)
//   plus whatever the producer adds (shrm:brdf, shrm:epsilon, shrm:orders, shrm:eps_light,
//   shrm:eps_brdf, shrm:eps_bound, shrm:source_sha256, shrm:working_space, ...).
#ifndef SHRM_CORE_SHRM_SHRM_FILE_H_
#define SHRM_CORE_SHRM_SHRM_FILE_H_

#include <cstddef>
#include <map>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"
#include "core/io/image.h"
#include "core/shrm/shrm_map.h"

namespace shrm {

inline constexpr char kShrmFormatTag[] = "shrm-cube/1";
// Most lights a file may list (shrm:lights; a prefilter ships at most kMaxPeaks = 128): bounds
// what a reader allocates for a header.
inline constexpr size_t kMaxShrmLights = 4096;

struct ShrmFile {
  ShrmCube cube;
  std::map<std::string, std::string> attributes;  // every shrm:* attribute of the header
};

// The bytes of the SHRM file WriteShrmFile writes (encoded in memory; `path` only labels errors).
absl::StatusOr<std::string> EncodeShrmFile(const std::string& path, const ShrmCube& cube,
                                           const std::map<std::string, std::string>& extra = {},
                                           bool half = false);
// Writes `cube` with the fixed convention attributes plus `extra` (keys must start with
// "shrm:"); atomic (temporary file, then rename). Errors name the file.
absl::Status WriteShrmFile(const std::string& path, const ShrmCube& cube,
                           const std::map<std::string, std::string>& extra, bool half = false);

// Reads and validates an SHRM file: format tag, kind, index, pmax consistent with the channel
// list, RGB triples in ShIndex order.
absl::StatusOr<ShrmFile> ReadShrmFile(const std::string& path, const ImageLimits& limits = {});

// The attributes every SHRM file carries whatever its container: shrm:format, shrm:basis,
// shrm:frame, shrm:face_order (the EXR's parts; the KTX2 writer states its own), shrm:eval,
// shrm:kind, shrm:index and shrm:pmax of `cube`.
std::map<std::string, std::string> ShrmConventionAttributes(const ShrmCube& cube);
// Checks the attributes ReadShrmFile needs (shrm:format, shrm:kind, shrm:index, shrm:pmax) and
// sets cube->kind, index and pmax from them; errors are InvalidArgument naming `label`.
absl::Status ParseShrmConventionAttributes(const std::string& label,
                                           const std::map<std::string, std::string>& attributes,
                                           ShrmCube* cube);

// The file's shrm:brdf (the spec its lights are summed with), or "" when it has none.
std::string BrdfAttribute(const ShrmFile& file);
// The BRDF of shrm:brdf, for summing the file's lights; errors (no or a bad spec, a table file
// that is gone) name `label`.
absl::StatusOr<std::unique_ptr<Brdf>> ShrmFileBrdf(const ShrmFile& file, const std::string& label);

// Channel group name of coefficient (p, q): "Y_<p>_<q>".
std::string ShrmChannelGroup(int p, int q);

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_FILE_H_
