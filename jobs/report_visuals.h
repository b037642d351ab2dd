// The pictures and sampled values of a prefilter's visual report (`shrm prefilter --report-html`,
// docs/cli.md "Visual report"), computed where the map, the BRDF and the cube are (the embedded
// run, or shrmd, which returns them as JSON with the report): a thumbnail of the map, the BRDF's
// lobe, spheres rendered from the SHRM beside the brute-force sum at a grid of their pixels, and
// the SHRM against the brute-force sum at seeded (N, V) pairs (the job's own check's pairs: the
// first `--verify` of them are the ones it measured). The brute-force values come from
// FastReference (core/shrm/fast_reference.h: the sum over every pixel of the map to a relative
// 1e-3, ten times below the errors shown); `shrm reference` gives the full sum at any of them.
//
// Errors are per direction and channel, as the job's check measures them (core/shrm/tolerance.h):
// |got - ref| / max(|ref|, kRelativeFloor x the mean |ref| of the pairs); a pair or pixel shows
// its largest channel.
#ifndef SHRM_JOBS_REPORT_VISUALS_H_
#define SHRM_JOBS_REPORT_VISUALS_H_

#include <array>
#include <nlohmann/json.hpp>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/shrm/shrm_map.h"

namespace shrm {
class FastReference;
}  // namespace shrm

namespace shrm::jobs {

// Pixels of one rendered sphere (square).
inline constexpr int kSpherePixels = 192;
// Cells across a sphere where the brute-force sum is taken (about 200 inside the disc per view:
// 0.1-0.3 s for the three views on one core at 1024 x 512).
inline constexpr int kReferenceCells = 16;
// Seeded pairs of the error map (kVerifySeed: the job's own check uses the first --verify).
inline constexpr int kReportPairs = 256;
// Pixels of one sphere in a report's thumbnail (the batch index, the page's icon).
inline constexpr int kThumbnailSpherePixels = 64;
// Width of the map's thumbnail (lat-long, height half of it).
inline constexpr int kThumbnailWidth = 384;
// The error colour scale: log10 of the relative error from kErrorScaleLow to kErrorScaleHigh.
inline constexpr double kErrorScaleLow = -4;
inline constexpr double kErrorScaleHigh = 0;

// The three views of the preview and the report: front (+Z), side (+X) and from above.
struct SphereView {
  const char* name;
  Vec3 view;  // towards the viewer
};
inline constexpr int kSphereViews = 3;
std::array<SphereView, kSphereViews> SphereViews();

// Orthographic renders of a unit sphere carrying the SHRM, the three views side by side
// (3 size x size pixels, black outside the discs), linear radiance; the cube's lights summed
// with `brdf` when it is given (ShrmEvalWithLights). Rows split over `threads` threads (the same
// pixels for any count).
Image RenderShrmSpheres(const ShrmCube& cube, int size, const Brdf* brdf = nullptr,
                        int threads = 1);
// Exposure (stops) that brings the mean luminance of the non-black pixels to mid-grey (0.18).
double MidGreyExposure(const Image& linear);
// The colour of a value in [0, 1] on the report's error scale: luminance rises monotonically
// (dark blue to pale yellow), so it reads in grey scale.
std::array<uint8_t, 3> ErrorColour(double t);
// t in [0, 1] of a relative error on the log scale [kErrorScaleLow, kErrorScaleHigh].
double ErrorScalePosition(double relative_error);

// The report's pictures and samples (keys in docs/cli.md "Visual report"). `rotation` is the
// lighting's rotation the cube was made with. `reference`: the map's FastReference when the
// caller has one (the job's check kept it, PrefilterOptions::keep_reference), else made here.
// Errors: those of FastReference::Create and of the image encoding.
absl::StatusOr<nlohmann::json> PrefilterVisuals(const EnvMap& env, const Brdf& brdf,
                                                const Mat3& rotation, const ShrmCube& cube,
                                                int threads,
                                                const FastReference* reference = nullptr);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_REPORT_VISUALS_H_
