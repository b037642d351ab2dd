// Mode 5: the ground truth. The renderer computes the brute-force reflected radiance of every
// covered pixel for the current view on worker threads (viewer/progressive_reference.h: per-pixel
// N or T and V from a G-buffer pass, integration over a downsampled environment, coarse-to-fine)
// and uploads it as it goes; this mode draws the mesh with that image (pixels not reached yet in
// a dim grey).
#ifndef SHRM_VIEWER_MODE_REFERENCE_H_
#define SHRM_VIEWER_MODE_REFERENCE_H_

#include <memory>

#include "viewer/render_mode.h"

namespace shrm::viewer {

std::unique_ptr<RenderMode> MakeReferenceMode();

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_MODE_REFERENCE_H_
