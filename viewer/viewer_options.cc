#include "viewer/viewer_options.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/envmap/sky.h"
#include "jobs/cli_validators.h"
#include "shrm/version.h"
#include "viewer/error_report.h"

namespace shrm::viewer {
namespace {

std::string Usage(const std::string& message) {
  PrintError(absl::StrCat(message, "\nRun with --help for more information."));
  return message;
}

// Folder of `path` exists and is a folder.
bool FolderExists(const std::string& path) {
  std::filesystem::path p(path);
  std::filesystem::path dir = p.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  return std::filesystem::is_directory(dir, ec);
}

// --date YYYY-MM-DD -> day of the year (1 = January 1st; sky::DayOfYear: the date must exist).
bool ParseDayOfYear(const std::string& text, int* day) {
  const std::vector<std::string> parts = absl::StrSplit(text, '-');
  int y = 0, m = 0, d = 0;
  if (parts.size() != 3 || !absl::SimpleAtoi(parts[0], &y) || !absl::SimpleAtoi(parts[1], &m) ||
      !absl::SimpleAtoi(parts[2], &d)) {
    return false;
  }
  const absl::StatusOr<int> doy = sky::DayOfYear(y, m, d);
  if (!doy.ok()) return false;
  *day = *doy;
  return true;
}

// --time HH:MM[:SS] -> hours in [0, 24).
bool ParseHours(const std::string& text, double* hours) {
  const std::vector<std::string> parts = absl::StrSplit(text, ':');
  int h = 0, m = 0, sec = 0;
  if (parts.size() < 2 || parts.size() > 3 || !absl::SimpleAtoi(parts[0], &h) ||
      !absl::SimpleAtoi(parts[1], &m) || (parts.size() == 3 && !absl::SimpleAtoi(parts[2], &sec)) ||
      h < 0 || h > 23 || m < 0 || m > 59 || sec < 0 || sec > 59) {
    return false;
  }
  *hours = h + m / 60.0 + sec / 3600.0;
  return true;
}

// The live options' consistency (docs/viewer.md "Live"): "" if fine, else the usage message.
std::string CheckLive(const CLI::App& app, const ViewerOptions& o, const std::string& kind) {
  const char* const kLiveOnly[] = {"--live-speed", "--live-fps",  "--live-step", "--sequence",
                                   "--date",       "--time",      "--lat",       "--lon",
                                   "--meridian",   "--turbidity", "--sky-width"};
  if (kind.empty()) {
    for (const char* name : kLiveOnly)
      if (app.count(name) > 0) return absl::StrCat(name, " needs --live rotate|sequence|sky");
    return "";
  }
  if (!o.shrm_file.empty()) {
    return "--live computes each frame's SHRM from the lighting: it does not show a file";
  }
  if (!o.server.empty()) return "--live runs its session here: --server is not supported with it";
  if (app.count("--tolerance") > 0) {
    return "--tolerance: the live session uses the paper's --epsilon rule or --orders (the "
           "tolerance rule takes seconds per frame; shrm prefilter has it)";
  }
  if (app.count("--verify") > 0) {
    return "--verify: live frames are not checked against brute force (shrm prefilter --verify "
           "is)";
  }
  if (o.brdf.empty()) return "--live needs --brdf SPEC";
  if (o.mode != 1 && o.mode != 2 && o.mode != 6) {
    return absl::StrCat(
        "--live shows the SHRM in mode 1 or 2 and the split-sum in mode 6, got --mode ", o.mode);
  }
  if (o.mode == 6 && !absl::StartsWith(o.brdf, "ggx")) {
    return "--live --mode 6: the split-sum shades GGX: --brdf ggx:alpha=A[,f0=F]";
  }
  if (o.diff) return "--diff needs the ground truth of a fixed map: not with --live";
  const bool sky_options = app.count("--date") + app.count("--time") + app.count("--lat") +
                               app.count("--lon") + app.count("--meridian") +
                               app.count("--turbidity") + app.count("--sky-width") >
                           0;
  if (kind != "sky" && sky_options) {
    return "--date, --time, --lat, --lon, --meridian, --turbidity and --sky-width need --live sky";
  }
  if (kind != "sequence" && app.count("--sequence") > 0) return "--sequence needs --live sequence";
  if (kind != "sequence" && app.count("--live-fps") > 0) return "--live-fps needs --live sequence";
  if (kind == "sequence" && app.count("--live-speed") > 0) {
    return "--live-speed applies to --live rotate and sky (a sequence plays at --live-fps)";
  }
  if (kind == "rotate" && o.env.empty()) return "--live rotate needs --env MAP (the map turned)";
  if (kind == "sequence" && o.live.sequence.empty()) {
    return "--live sequence needs --sequence FILES... or --sequence FOLDER";
  }
  if (kind != "rotate" && !o.env.empty()) {
    return absl::StrCat("--live ", kind, " makes its own lighting: --env is not used with it");
  }
  return "";
}

}  // namespace

int ParseViewerOptions(int argc, char** argv, ViewerOptions* o) {
  CLI::App app{
      "shrm-view: OpenGL viewer of Spherical Harmonic Reflection Maps (docs/viewer.md).\n"
      "Sources: an SHRM file; or --env MAP --brdf SPEC (computed here, or by --server).",
      "shrm-view"};
  app.set_version_flag("--version", VersionText("shrm-view"),
                       "print the version, git revision and conventions version and exit");
  std::string orders, view, size;
  app.add_option("shrm", o->shrm_file, "SHRM file (*.shrm.exr) to show");
  app.add_option("--env", o->env,
                 "environment map: background, ground truth, and the input of --brdf computations");
  app.add_option("--brdf", o->brdf,
                 "BRDF spec (docs/brdf.md); computes the SHRM from --env (default with a file: its "
                 "shrm:brdf)");
  app.add_option("--server", o->server, "compute through the shrmd service at host:port");
  app.add_option("--epsilon", o->epsilon, "tolerance for the orders, in (0, 1)")
      ->capture_default_str()
      ->check(jobs::kOpenUnitInterval);
  auto* orders_opt = app.add_option("--orders", orders, "explicit orders F,P instead of --epsilon")
                         ->check(jobs::kOrders);
  app.add_option("--tolerance", o->tolerance,
                 "per-direction tolerance instead of --epsilon (docs/shrm.md), e.g. 0.01")
      ->check(jobs::kOpenUnitInterval)
      ->excludes(orders_opt);
  app.add_option("--verify", o->verify,
                 "pairs each computed SHRM is checked at against the brute-force sum; the overlay "
                 "shows the measured error (0: none)")
      ->capture_default_str()
      ->check(jobs::InRange(0, jobs::kMaxVerifyPairs));
  app.add_option("--face-size", o->face_size, "cube face size S_B of computed SHRMs (0: ~10 F_B)")
      ->capture_default_str()
      ->check(jobs::InRange(0, 2048));
  app.add_option("--mesh", o->mesh, "sphere, torus or an OBJ file")->capture_default_str();
  app.add_option("--mode", o->mode, "render mode (the keys 1-9; docs/viewer.md)")
      ->capture_default_str()
      ->check(jobs::InRange(1, 9));
  app.add_flag("--diff", o->diff, "difference view against the ground truth (false colour)");
  app.add_option("--view", view,
                 "camera azimuth,elevation[,distance] in degrees (default 30,20,3)");
  app.add_option("--fov", o->fov_deg, "vertical field of view in degrees")
      ->capture_default_str()
      ->check(jobs::InRange(5.0, 120.0));
  app.add_option("--size", size, "window / image size W,H (default 1280,720)");
  app.add_option("--exposure", o->exposure, "exposure in EV (default: automatic from the map)");
  app.add_option("--screenshot", o->screenshot,
                 "render one frame offscreen and write it (.png/.tif tone-mapped, .exr linear)");
  app.add_flag("--overlay", o->overlay, "draw the overlay text into the --screenshot image");
  app.add_option("--bench-frames", o->bench_frames,
                 "render N frames offscreen per mode and print ms/frame")
      ->check(jobs::InRange(1, 100000));
  app.add_option("--frames", o->quit_after_frames,
                 "interactive window: close after N frames (smoke tests); with --live and "
                 "--screenshot: the frames rendered before it (frame k at clock k x --live-step)")
      ->check(jobs::InRange(1, 100000000));
  app.add_option("--ref-width", o->reference_width,
                 "lat-long width of the map the ground truth integrates (even)")
      ->capture_default_str()
      ->check(jobs::InRange(8, 1024));
  app.add_option("--threads", o->threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  app.add_flag("--verbose", o->verbose, "print GL information and timings");
  // --live (docs/viewer.md "Live").
  std::string live, date, time;
  app.add_option("--live", live,
                 "live lighting, each frame's SHRM recomputed: rotate (--env turned about +Y), "
                 "sequence (--sequence maps), sky (a procedural sky, moving sun)")
      ->check(CLI::IsMember({"rotate", "sequence", "sky"}));
  app.add_option("--live-speed", o->live.speed,
                 "rotate: degrees per second (default 30); sky: hours of the day per second "
                 "(default 0.5)")
      ->check(jobs::InRange(-1e4, 1e4));
  app.add_option("--live-fps", o->live.fps, "sequence: frames per second, looping")
      ->capture_default_str()
      ->check(jobs::InRange(1e-3, 1e3));
  app.add_option("--live-step", o->live.step,
                 "deterministic clock: SECONDS of live time per rendered frame, each frame "
                 "waiting for its state's SHRM (screenshots, tests)")
      ->check(jobs::InRange(1e-6, 86400.0));
  app.add_option("--sequence", o->live.sequence,
                 "sequence: the maps, one per frame (FILES...), or a folder of .exr frames")
      ->expected(1, -1);
  app.add_option("--date", date, "sky: date YYYY-MM-DD (default 2024-06-21)");
  app.add_option("--time", time, "sky: local standard time at the start, HH:MM (default 06:00)");
  app.add_option("--lat", o->live.sky.latitude_deg, "sky: latitude, degrees north")
      ->capture_default_str()
      ->check(jobs::InRange(-90.0, 90.0));
  app.add_option("--lon", o->live.sky.longitude_deg, "sky: longitude, degrees EAST")
      ->capture_default_str()
      ->check(jobs::InRange(-180.0, 180.0));
  app.add_option("--meridian", o->live.sky.meridian_deg,
                 "sky: standard meridian of the time zone, degrees east (default 15 round(lon/15))")
      ->check(jobs::InRange(-180.0, 180.0));
  app.add_option("--turbidity", o->live.sky.turbidity, "sky: atmospheric turbidity")
      ->capture_default_str()
      ->check(jobs::InRange(sky::kMinTurbidity, sky::kMaxTurbidity));
  app.add_option("--sky-width", o->live.sky.width, "sky: lat-long width of the rendered sky")
      ->capture_default_str()
      ->check(jobs::InRange(16, 4096));
  jobs::RefuseEmptyValues(&app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    std::printf("%s", app.help().c_str());
    return kExitOk;
  } catch (const CLI::CallForVersion& e) {
    std::printf("%s\n", e.what());
    return kExitOk;
  } catch (const CLI::ParseError& e) {
    const std::string unknown =
        dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr
            ? jobs::UnknownOptionMessage(app, std::vector<std::string>(argv + 1, argv + argc))
            : "";
    Usage(unknown.empty() ? e.what() : unknown);
    return kExitUsage;
  }
  o->exposure_set = app.count("--exposure") > 0;
  if (o->exposure_set && !(std::abs(o->exposure) <= 40)) {
    Usage("--exposure must be a number in [-40, 40]");
    return kExitUsage;
  }
  if (!orders.empty()) {
    std::vector<std::string> parts = absl::StrSplit(orders, ',');
    absl::SimpleAtoi(parts[0], &o->f);
    absl::SimpleAtoi(parts[1], &o->p);
  }
  if (!view.empty()) {
    absl::StatusOr<OrbitView> v = ParseOrbitView(view, "--view");
    if (!v.ok()) {
      Usage(std::string(v.status().message()));
      return kExitUsage;
    }
    o->view = *v;
  }
  if (!size.empty()) {
    std::vector<std::string> parts = absl::StrSplit(size, ',');
    if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &o->width) ||
        !absl::SimpleAtoi(parts[1], &o->height) || o->width < kMinImageSize ||
        o->height < kMinImageSize || o->width > kMaxImageSize || o->height > kMaxImageSize) {
      Usage(absl::StrCat("--size must be W,H with integers in [", kMinImageSize, ", ",
                         kMaxImageSize, "], got '", size, "'"));
      return kExitUsage;
    }
  }
  if (o->reference_width % 2 != 0) {
    Usage(absl::StrCat("--ref-width must be even, got ", o->reference_width));
    return kExitUsage;
  }
  if (const std::string live_error = CheckLive(app, *o, live); !live_error.empty()) {
    Usage(live_error);
    return kExitUsage;
  }
  o->live_mode = !live.empty();
  if (o->live_mode) {
    o->live.kind = live == "rotate"     ? LiveKind::kRotate
                   : live == "sequence" ? LiveKind::kSequence
                                        : LiveKind::kSky;
    o->live.env = o->env;
    if (!date.empty() && !ParseDayOfYear(date, &o->live.sky.day_of_year)) {
      Usage(absl::StrCat("--date must be a date YYYY-MM-DD, got '", date, "'"));
      return kExitUsage;
    }
    if (!time.empty() && !ParseHours(time, &o->live.sky.time_h)) {
      Usage(absl::StrCat("--time must be a time HH:MM[:SS] in 00:00 .. 23:59, got '", time, "'"));
      return kExitUsage;
    }
    if (o->live.sky.width % 2 != 0) {
      Usage(absl::StrCat("--sky-width must be even, got ", o->live.sky.width));
      return kExitUsage;
    }
  }
  // Sources.
  if (!o->live_mode && o->shrm_file.empty() && (o->env.empty() || o->brdf.empty())) {
    Usage("nothing to show: give an SHRM file, or --env MAP --brdf SPEC");
    return kExitUsage;
  }
  if (!o->shrm_file.empty() && !o->server.empty()) {
    Usage("--server computes an SHRM from --env and --brdf; it cannot be combined with a file");
    return kExitUsage;
  }
  if (!o->server.empty() && (o->env.empty() || o->brdf.empty())) {
    Usage("--server needs --env MAP and --brdf SPEC");
    return kExitUsage;
  }
#ifndef SHRM_VIEWER_HAVE_CLIENT
  if (!o->server.empty()) {
    Usage("--server: this shrm-view was built without the service client (SHRM_BUILD_SERVICE=OFF)");
    return kExitUsage;
  }
#endif
  if ((o->mode == 5 || o->diff) && o->env.empty()) {
    Usage("the ground truth (--mode 5, --diff) integrates the environment: give --env MAP");
    return kExitUsage;
  }
  const std::string mesh_lower = absl::AsciiStrToLower(o->mesh);
  if (mesh_lower != "sphere" && mesh_lower != "torus" && !absl::EndsWith(mesh_lower, ".obj")) {
    Usage(absl::StrCat("--mesh must be sphere, torus or a .obj file, got '", o->mesh, "'"));
    return kExitUsage;
  }
  if (mesh_lower == "sphere" || mesh_lower == "torus") o->mesh = mesh_lower;
  if (!o->screenshot.empty()) {
    const std::string ext =
        absl::AsciiStrToLower(std::filesystem::path(o->screenshot).extension().string());
    if (ext != ".png" && ext != ".tif" && ext != ".tiff" && ext != ".exr") {
      Usage(absl::StrCat("--screenshot must end in .png, .tif, .tiff or .exr, got '", o->screenshot,
                         "'"));
      return kExitUsage;
    }
    if (!FolderExists(o->screenshot)) {
      Usage(absl::StrCat("--screenshot: the folder of '", o->screenshot, "' does not exist"));
      return kExitUsage;
    }
  }
  if (!o->screenshot.empty() && o->bench_frames > 0) {
    Usage("--screenshot and --bench-frames are exclusive");
    return kExitUsage;
  }
  if (o->threads == 0) o->threads = std::max(1u, std::thread::hardware_concurrency());
  return -1;
}

}  // namespace shrm::viewer
