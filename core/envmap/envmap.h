// Environment maps: layouts, colour conversion to the linear working space, radiance samples
// for brute-force integration, and SH lighting coefficients L_lm (SHRM paper eqs. 5.20-5.21).
//
// Every layout is decoded to radiance samples in the WORLD frame of docs/conventions.md
// (right-handed, +Y up; lat-long pixel (i, j) -> d = (sin t sin p, cos t, -sin t cos p)).
// Cube maps use the OpenGL face order and orientation (+X, -X, +Y, -Y, +Z, -Z; the GL
// specification's major-axis table).
#ifndef SHRM_CORE_ENVMAP_ENVMAP_H_
#define SHRM_CORE_ENVMAP_ENVMAP_H_

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace shrm {

enum class EnvLayout {
  kAuto,             // from the aspect ratio (and the number of files)
  kLatLong,          // 2:1 equirectangular
  kCubeFaces,        // six square files in GL order +X, -X, +Y, -Y, +Z, -Z
  kHorizontalCross,  // 4:3
  kVerticalCross,    // 3:4
  kHorizontalStrip,  // 6:1, faces in GL order
  kVerticalStrip,    // 1:6, faces in GL order
  kAngular,          // 1:1 Debevec angular map (light probe)
};

// One radiance sample of a decoded map: world direction (unit), solid angle (sr) and linear RGB
// in the working space. The samples of a map integrate the sphere: sum of solid angles = 4 pi
// (to the accuracy of the layout's texel solid-angle formula).
struct EnvSample {
  Vec3 dir;
  double solid_angle = 0;
  std::array<float, 3> rgb{};
};

}  // namespace shrm

#endif  // SHRM_CORE_ENVMAP_ENVMAP_H_
