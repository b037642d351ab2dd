// Mode 1: global SHRM, one dynamic reflection map per frame (SHRM paper eq. 5.35). For the
// camera's central view V the CPU sums B~(R) = sum_pq B^_pq(R) Y_pq(V) into an RGB cube map
// (viewer/reflection_sum.h: ~0.2 ms for 64 x 64 x 6 texels at P = 3, docs/results.md "Viewer"),
// uploads it, and the fragment shader looks it up by the reflection vector of each pixel,
// R = 2 (N.V_pixel) N - V_pixel (seamless cube filtering), or by the tangent for Kajiya-Kay SHRMs.
// The view dependence is evaluated at the central V for the whole object (eq. 5.35's premise),
// the reflection direction per pixel.
#ifndef SHRM_VIEWER_MODE_GLOBAL_SHRM_H_
#define SHRM_VIEWER_MODE_GLOBAL_SHRM_H_

#include <memory>

#include "viewer/render_mode.h"

namespace shrm::viewer {

std::unique_ptr<RenderMode> MakeGlobalShrmMode();

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_GLOBAL_SHRM_H_
