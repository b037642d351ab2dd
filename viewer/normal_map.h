// Procedural tangent-space normal maps of modes 3 and 4 (rotation paper sec. 5.2, H-basis paper
// sec. 5): generated in code, no image files.
//
// A normal map holds, per texel, a tangent-space unit normal (x, y, z) relative to the frame
// (t, b, n) of the mesh (viewer/gpu_mesh.h: t = the tangent attribute, b = w n x t, n = the
// interpolated normal): the perturbed normal is x t + y b + z n. Texel (i, j) of a W x H map is
// centred at uv = ((i + 0.5) / W, (j + 0.5) / H) (row j = 0 at v = 0, the first row GL uploads),
// and maps are sampled as GL_LINEAR with GL_REPEAT samples them (NormalMap::Sample is the CPU
// twin of the shaders' texture() call; no mipmaps).
//
// Kinds (key N in modes 3 and 4 cycles none -> bumps -> steep -> flat):
//  - none:  no normal map, the interpolated frame itself;
//  - flat:  every texel (0, 0, 1); renders exactly like none (the check of the normal-mapping
//           path, tests/viewer_mode34_render_test.cc);
//  - bumps: an "egg crate" of smooth bumps, the gradient of
//           h(u, v) = sin(2 pi P_u u) sin(2 pi P_v v) scaled so that the tilt of the normal from
//           +z is at most `max_tilt_deg`:
//             (x, y, z) = normalize(-k cos(2 pi P_u u) sin(2 pi P_v v),
//                                   -k sin(2 pi P_u u) cos(2 pi P_v v), 1),  k = tan(max tilt),
//           P_u = 32 periods around the sphere's u and P_v = 16 along v (square bumps at the
//           equator of MakeSphere's parameterization), tilts up to 20 degrees: the "rather small
//           angles" of the rotation paper's sec. 5.2, where its Taylor rotation is meant to work;
//  - steep: the same bumps with tilts up to 50 degrees: irradiance normal mapping (mode 4) is
//           exact for any tilt and its bases differ away from the pole; mode 3 shows where the
//           Taylor rotation stops being accurate.
#ifndef SHRM_VIEWER_NORMAL_MAP_H_
#define SHRM_VIEWER_NORMAL_MAP_H_

#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace shrm::viewer {

enum class NormalMapKind { kNone, kFlat, kBumps, kSteepBumps };
// "none", "flat", "bumps", "steep".
std::string_view NormalMapKindName(NormalMapKind kind);
// The inverse; InvalidArgument naming the valid kinds.
[[nodiscard]] absl::StatusOr<NormalMapKind> ParseNormalMapKind(std::string_view name);

// Defaults of the bump map: periods along u and v, texels per period, and the largest tilt
// (the rotation paper's normal maps modulate the normal by "rather small angles", sec. 5.2).
inline constexpr int kBumpPeriodsU = 32;
inline constexpr int kBumpPeriodsV = 16;
inline constexpr int kBumpTexelsPerPeriod = 16;
inline constexpr double kBumpMaxTiltDeg = 20;
inline constexpr double kSteepBumpMaxTiltDeg = 50;

struct NormalMap {
  int width = 0, height = 0;
  std::vector<float> texels;  // xyz per texel, row-major from v = 0

  // Bilinear between texel centres with wrap-around in u and v (GL_LINEAR + GL_REPEAT); the
  // result is not renormalized (the shaders normalize it).
  Vec3 Sample(double u, double v) const;
};

// All texels (0, 0, 1).
NormalMap FlatNormalMap(int width = 4, int height = 4);
// The egg crate above, (periods_u * texels_per_period) x (periods_v * texels_per_period) texels.
NormalMap BumpNormalMap(int periods_u = kBumpPeriodsU, int periods_v = kBumpPeriodsV,
                        int texels_per_period = kBumpTexelsPerPeriod,
                        double max_tilt_deg = kBumpMaxTiltDeg);
// The analytic normal the bump map samples (unit).
Vec3 BumpNormal(double u, double v, int periods_u = kBumpPeriodsU, int periods_v = kBumpPeriodsV,
                double max_tilt_deg = kBumpMaxTiltDeg);
// The map of a kind (kNone: an empty map).
NormalMap MakeNormalMap(NormalMapKind kind);
// The key N's cycle: none -> bumps -> steep -> flat -> none.
NormalMapKind NextNormalMapKind(NormalMapKind kind);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_NORMAL_MAP_H_
