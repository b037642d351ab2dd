// Mode 1: global SHRM, one dynamic reflection map per frame (SHRM paper eq. 5.35). For the
// camera's central view V a GPU pass of the shipped shader library (shaders/glsl/shrm_global.glsl,
// docs/shaders.md) sums B~(R) = sum_pq B^_pq(R) Y_pq(V) into an RGBA32F cube map, one draw per
// face, from the coefficients laid out as the KTX2 SHRM stores them; the fragment shader then looks
// the map up by the reflection vector of each pixel, R = 2 (N.V_pixel) N - V_pixel (seamless cube
// filtering), or by the tangent for Kajiya-Kay SHRMs. The view dependence is evaluated at the
// central V for the whole object (eq. 5.35's premise), the reflection direction per pixel.
// viewer/reflection_sum.h is the same sum on the CPU (benchmarks, tests).
#ifndef SHRM_VIEWER_MODE_GLOBAL_SHRM_H_
#define SHRM_VIEWER_MODE_GLOBAL_SHRM_H_

#include <memory>

#include "viewer/render_mode.h"

namespace shrm::viewer {

std::unique_ptr<RenderMode> MakeGlobalShrmMode();

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_GLOBAL_SHRM_H_
