// How `shrm-view` tells the user about an error: one line "shrm-view: <message>" on stderr. The
// running program reports through Viewer::ReportError (viewer/app.cc), which also puts the
// message into the window title and the in-frame overlay; before the program runs (usage errors,
// viewer/viewer_options.cc and main.cc) this is the whole path. Nothing else in viewer/ prints
// errors: the rest returns them as absl::Status values.
#ifndef SHRM_VIEWER_ERROR_REPORT_H_
#define SHRM_VIEWER_ERROR_REPORT_H_

#include <cstdio>
#include <string>

#include "absl/strings/string_view.h"

namespace shrm::viewer {

inline void PrintError(absl::string_view message) {
  std::fprintf(stderr, "shrm-view: %s\n", std::string(message).c_str());
  std::fflush(stderr);
}

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_ERROR_REPORT_H_
