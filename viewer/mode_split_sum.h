// Mode 6: the split-sum IBL an engine shades GGX with (viewer/split_sum_shading.h: the GGX chain
// of `shrm ibl`'s Filament preset sampled trilinearly at R and Filament's lod, times the DFG
// integrals f0 A(N.V) + B(N.V)), beside the SHRM (modes 1, 2) and the ground truth (mode 5); the
// difference view (key D) shows where the split-sum's N = V = R assumption fails: towards grazing
// views. Needs --env and a GGX BRDF (--brdf ggx:alpha=A[,f0=F]).
#ifndef SHRM_VIEWER_MODE_SPLIT_SUM_H_
#define SHRM_VIEWER_MODE_SPLIT_SUM_H_

#include <memory>

#include "viewer/render_mode.h"

namespace shrm::viewer {

std::unique_ptr<RenderMode> MakeSplitSumMode();

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_SPLIT_SUM_H_
