// The `shrm-view` program after argument parsing: loads the sources, then runs the interactive
// window, or renders headless (--screenshot, --bench-frames). docs/viewer.md.
#ifndef SHRM_VIEWER_APP_H_
#define SHRM_VIEWER_APP_H_

#include "viewer/viewer_options.h"

namespace shrm::viewer {

// Returns the process exit code (kExitOk, kExitError).
int RunViewer(const ViewerOptions& options);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_APP_H_
