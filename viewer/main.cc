// shrm-view: the OpenGL reflection-map viewer (docs/viewer.md).
#include <string>

#include "core/io/atomic_file.h"
#include "viewer/app.h"
#include "viewer/error_report.h"
#include "viewer/render_mode.h"
#include "viewer/viewer_options.h"

int main(int argc, char** argv) {
  using namespace shrm::viewer;
  shrm::RemoveTempFilesOnSignal();  // an interrupted screenshot leaves no temporary
  ViewerOptions options;
  const int code = ParseViewerOptions(argc, argv, &options);
  if (code >= 0) return code;
  if (FindMode(options.mode) == nullptr) {
    std::string available;
    for (const ModeInfo& m : RegisteredModes())
      available +=
          std::string(available.empty() ? "" : ", ") + std::to_string(m.key) + " " + m.name;
    PrintError("--mode " + std::to_string(options.mode) +
               " is not available in this build (available: " + available + ")");
    return kExitUsage;
  }
  return RunViewer(options);
}
