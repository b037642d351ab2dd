// The OpenImageIO / OpenColorIO half of shrm_io, built as a module (libshrm_imageio.so) that is
// loaded with dlopen the first time a job needs it: reading Radiance HDR, PFM, TIFF and PNG
// files, writing TIFF, and converting between colour spaces. EXR files, PNG outputs and the
// identity colour conversion (the bundled maps, every default job) never load it, so `shrm` does
// not pay for OpenImageIO's dependency tree at start (docs/architecture.md "Start-up").
//
// Where the module is looked for, in order: $SHRM_MODULE_DIR; "../lib/shrm" beside the running
// executable (the build tree and an installed prefix); the install prefix compiled in. Both
// halves come from one build, so the interface is plain C++ with a version number.
// Internal to core/io (and its tests).
#ifndef SHRM_CORE_IO_IMAGE_MODULE_H_
#define SHRM_CORE_IO_IMAGE_MODULE_H_

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/image.h"

namespace shrm::image_module {

inline constexpr int kAbiVersion = 1;
inline constexpr char kFileName[] = "libshrm_imageio.so";
inline constexpr char kEntryPoint[] = "shrm_imageio_api";

struct Api {
  int abi_version = kAbiVersion;
  // Opens `path` with OpenImageIO's reader for `format` (chosen by the caller from the magic
  // bytes) and checks the header against `limits`: the width, height and channels of `header`
  // are set; the other fields are the caller's.
  absl::Status (*probe)(const std::string& path, const ImageLimits& limits, ImageHeader* header);
  // Probe, then every channel as float, interleaved. OpenImageIO multiplies the colour of an
  // image with alpha by the alpha (as ReadImageRgb has always returned it) unless
  // `unassociated_alpha` (tests: the stored values).
  absl::StatusOr<std::vector<float>> (*read)(const std::string& path, const ImageLimits& limits,
                                             ImageHeader* header, bool unassociated_alpha);
  // Whether the file's pixel type is float or half (probe's checks first).
  absl::StatusOr<bool> (*is_float)(const std::string& path, const ImageLimits& limits,
                                   const std::string& format);
  // Writes 8-bit `bytes` (image's size and channels) to `path` as `format` ("tiff", "png").
  absl::Status (*write8)(const std::string& path, const Image& image, const std::string& format,
                         const unsigned char* bytes);
  // colour.h's ListColourSpaces and ConvertColourSpace through OpenColorIO, for the config in
  // `file` ("": `builtin_text`), called `source` in messages. The module links nothing of shrm
  // but this interface: what it needs comes as arguments.
  absl::StatusOr<std::vector<std::string>> (*list_colour_spaces)(const std::string& file,
                                                                 const std::string& source,
                                                                 std::string_view builtin_text);
  absl::Status (*convert_colour_space)(std::span<float> rgb, const std::string& from,
                                       const std::string& to, const std::string& file,
                                       const std::string& source, std::string_view builtin_text);
};

// The module, loaded on the first call (thread-safe). FailedPrecondition naming every path tried
// and dlopen's reason when it cannot be loaded.
absl::StatusOr<const Api*> Get();

// The folders shrm's run-time parts (this module, the `shrm-remote` program) are looked for in,
// in order: $SHRM_MODULE_DIR, then lib/shrm and LIBDIR/shrm under the running program's prefix
// (the build tree; any install prefix), then the configured LIBDIR/shrm.
std::vector<std::string> SearchDirs();

// Whether this process has loaded it (tests: an EXR-only job never does).
bool Loaded();

}  // namespace shrm::image_module

// The module's entry point (dlsym by kEntryPoint).
extern "C" const shrm::image_module::Api* shrm_imageio_api();

#endif  // SHRM_CORE_IO_IMAGE_MODULE_H_
