// Mode 2: local SHRM per pixel (SHRM paper eq. 5.10), B = sum_pq B_pq Y_pq(Rot^T V) with V the
// pixel's own view direction and Rot = Rz(beta) Ry(alpha) the local frame. The coefficient cube
// ((P + 1)^2 RGB coefficients per texel) is uploaded as 6 (P + 1)^2 layers (k * 6 + face).
//  - Pass 1 (GL >= 4.0, a cube-map array): away from the +-Y poles the local coefficient field is
//    smooth, so it is filtered in hardware (seamless) and evaluated once in the frame of the
//    pixel's own R = 2 (N.V) N - V (or T); pixels within kPoleTexels texel pitches of a pole are
//    discarded.
//  - Pass 2 (a 2D array, exact texel fetches), shaded only where pass 1 left no depth (GL_LESS
//    with the same invariant vertex shader), or everywhere with GL 3.3: the four nearest texel
//    centres as ShrmEvalAt takes them (neighbours beyond a face edge from the adjacent face),
//    each evaluated in ITS OWN frame, then interpolated. So the pole singularity of the local
//    frame never mixes coefficients of different frames, and the GPU matches the CPU's ShrmEval
//    (tests/viewer_render_test.cc).
#ifndef SHRM_VIEWER_MODE_LOCAL_SHRM_H_
#define SHRM_VIEWER_MODE_LOCAL_SHRM_H_

#include <memory>

#include "viewer/render_mode.h"

namespace shrm::viewer {

std::unique_ptr<RenderMode> MakeLocalShrmMode();

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_LOCAL_SHRM_H_
