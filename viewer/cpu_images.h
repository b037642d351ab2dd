// CPU twins of what the GPU draws, for the tests and the ground truth (mode 5):
//  - per-pixel geometry (hit, position, normal, tangent, view direction) of the analytic unit
//    sphere seen by an OrbitCamera (ray through each pixel centre, as the rasterizer samples);
//  - images shaded by any per-pixel function of that geometry: SHRM evaluation (ShrmEval, as
//    modes 1 and 2 compute it), or brute-force integration (core/shrm/shrm_reference.h).
// Images are linear RGB, rows from the top (core/io/image.h).
#ifndef SHRM_VIEWER_CPU_IMAGES_H_
#define SHRM_VIEWER_CPU_IMAGES_H_

#include <array>
#include <functional>
#include <vector>

#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/io/image.h"
#include "core/shrm/shrm_map.h"
#include "viewer/camera.h"

namespace shrm::viewer {

// What a pixel sees: the surface point, its unit normal N and tangent T (world), and the unit
// view direction V (towards the eye).
struct PixelGeometry {
  bool hit = false;
  Vec3 position, normal, tangent, view;
};

// A W x H buffer of pixel geometry, row 0 at the top.
struct GeometryBuffer {
  int width = 0, height = 0;
  std::vector<PixelGeometry> pixels;
  const PixelGeometry& at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
};

// The analytic unit sphere at the origin: per pixel the first intersection of the pixel's ray.
// The tangent is MakeSphere's (along the latitude, (cos p, 0, sin p) at azimuth p).
GeometryBuffer SphereGeometry(const OrbitCamera& camera, int width, int height);

// Which view direction a mode shades with.
enum class ViewModel {
  kPerPixel,  // V = the pixel's own view direction (mode 2, the reference)
  kCentral,   // one V for the whole frame, the camera's central view (mode 1, eq. 5.35)
};

using PixelShader = std::function<std::array<double, 3>(const PixelGeometry&)>;
// RGB image: shader(pixel) where hit, `background` elsewhere. Rows split over `threads`.
Image ShadeImage(const GeometryBuffer& g, const PixelShader& shader, int threads = 1,
                 std::array<float, 3> background = {0, 0, 0});

// The SHRM as the GPU modes evaluate it: index direction = R = 2 (N.V_pixel) N - V_pixel (or T
// for tangent-indexed cubes), then ShrmEvalAt with V = the pixel's view (kPerPixel) or
// `central_view` (kCentral). With `lights_brdf`, plus the cube's peak lights summed with it
// (ShrmLightsRadiance) as the modes sum them: at the pixel's own N (T) and V (kPerPixel), or at
// each texel of the per-view map, interpolated bilinearly in R (kCentral, core's
// AddLightsToViewMap).
PixelShader ShrmPixelShader(const ShrmCube& cube, ViewModel model, const Vec3& central_view,
                            const Brdf* lights_brdf = nullptr);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_CPU_IMAGES_H_
