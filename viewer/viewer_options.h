// Command line of `shrm-view` (docs/viewer.md). Every argument is validated before any work
// starts; malformed or inconsistent usage is exit code 2 with a message naming the option, as
// the `shrm` command does (jobs/cli_validators.h, docs/cli.md).
#ifndef SHRM_VIEWER_VIEWER_OPTIONS_H_
#define SHRM_VIEWER_VIEWER_OPTIONS_H_

#include <string>

#include "jobs/prefilter_job.h"
#include "viewer/camera.h"
#include "viewer/live_source.h"
#include "viewer/scene_source.h"

namespace shrm::viewer {

inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;  // bad input file, failed computation or output
inline constexpr int kExitUsage = 2;  // unknown option, missing or malformed argument

// Limits of --size W,H.
inline constexpr int kMinImageSize = 16;
inline constexpr int kMaxImageSize = 8192;

struct ViewerOptions {
  std::string shrm_file;  // positional: an SHRM file (*.shrm.exr)
  std::string env;        // environment map (background, embedded compute, ground truth)
  std::string brdf;       // BRDF spec; default: the file's shrm:brdf
  std::string server;     // compute through shrmd (host:port)
  double epsilon = jobs::kDefaultEpsilon;
  double tolerance = 0;             // --tolerance (0: --epsilon)
  int verify = kViewerVerifyPairs;  // --verify N: each computed SHRM's own check
  int f = -1, p = -1;               // --orders F,P
  int face_size = 0;                // --face-size S_B (0 = about 10 F_B)
  std::string mesh = "sphere";      // sphere | torus | PATH.obj
  int mode = 1;
  bool diff = false;
  OrbitView view;
  double fov_deg = 45;
  int width = 1280, height = 720;
  bool exposure_set = false;
  double exposure = 0;     // EV; automatic (mean env luminance -> 0.18) unless given
  std::string screenshot;  // .png / .tif / .tiff (tone-mapped frame) or .exr (linear radiance)
  bool overlay = false;    // --overlay: the overlay text drawn into a .png / .tif screenshot
  int bench_frames = 0;
  int quit_after_frames = 0;  // interactive: close after N frames (smoke tests); 0 = never
  int reference_width = 128;
  int threads = 0;  // 0 = hardware concurrency
  bool verbose = false;
  // --live KIND (docs/viewer.md "Live"): the lighting changes with a clock, each state's SHRM
  // recomputed by a live session; `live` holds its options when live_mode.
  bool live_mode = false;
  LiveSpec live;
};

// Parses argv. Returns -1 to go on, or the exit code to exit with (0 after --help); messages go
// to stderr (usage errors) or stdout (help).
int ParseViewerOptions(int argc, char** argv, ViewerOptions* options);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_VIEWER_OPTIONS_H_
