// The image input path as the CLI (`--env FILE`) and shrmd (an uploaded blob) use it:
// EnvMap::Load -> format detection by magic bytes, header checks (ProbeImage), decoding
// (ReadImageRgb), the colour conversion and the layouts (lat-long, cube faces, crosses, strips,
// angular), then the decoded map's samples, lookups and resampling.
//
// Input: byte 0 chooses the options (bits 0-2: the layout, kAuto .. kAngular; bit 3: replace
// NaN/Inf by 0 instead of rejecting; bit 4: pass the layout's six cube faces as six copies of
// the file), the rest is the file. Limits are lower than the CLI's so that a header claiming a
// large image is refused before decoding, as the real limits do at their scale.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "fuzz/fuzz_util.h"

namespace {

constexpr int kMaxSide = 2048;
constexpr int64_t kMaxPixels = int64_t{1} << 16;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t opts = data[0];
  const std::string path =
      shrm::fuzz::WriteScratchFile("env.img", shrm::fuzz::AsView(data + 1, size - 1));

  shrm::EnvMapOptions options;
  options.layout = static_cast<shrm::EnvLayout>(opts & 7);
  options.non_finite =
      (opts & 8) ? shrm::NonFinitePolicy::kReplaceZero : shrm::NonFinitePolicy::kReject;
  options.limits.max_width = kMaxSide;
  options.limits.max_height = kMaxSide;
  options.limits.max_pixels = kMaxPixels;
  options.paths.assign((opts & 16) ? 6 : 1, path);

  // The header check alone, as `shrm analyze` and the daemon's admission read it.
  (void)shrm::ProbeImage(path, options.limits);

  absl::StatusOr<shrm::EnvMap> map = shrm::EnvMap::Load(options);
  if (!map.ok()) return 0;
  // What every job does next with a decoded map.
  (void)map->TotalSolidAngle();
  for (const shrm::Vec3& d : {shrm::Vec3{1, 0, 0}, shrm::Vec3{0, -1, 0}, shrm::Vec3{0.3, 0.2, -1}})
    (void)map->Radiance(d);
  (void)map->PixelDirection(0, 0, 0);
  (void)map->PixelDirection(0, map->width() - 1, map->height() - 1);
  (void)map->ToLatLong(8);
  return 0;
}
