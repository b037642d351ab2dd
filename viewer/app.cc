#include "viewer/app.h"

#include <epoxy/gl.h>
// GLFW without its own GL header (libepoxy provides GL).
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/image.h"
#include "core/sh/sh.h"
#include "viewer/brdf_edit.h"
#include "viewer/error_report.h"
#include "viewer/gl_util.h"
#include "viewer/live_source.h"
#include "viewer/mesh.h"
#include "viewer/renderer.h"
#include "viewer/scene_source.h"
#ifdef SHRM_VIEWER_HAVE_CLIENT
#include "viewer/remote_source.h"
#endif

namespace shrm::viewer {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// Meshes: sphere (128 x 64), torus, or the OBJ file.
absl::StatusOr<Mesh> BuildMesh(const std::string& which) {
  if (which == "sphere") return MakeSphere(128, 64);
  if (which == "torus") return MakeTorus(0.7, 0.3, 128, 48);
  return LoadObjMesh(which);
}

// Automatic exposure: mean luminance of the map (or of the SHRM's c_00 radiance) -> 0.18.
double AutoExposure(const SceneData& scene) {
  double mean = 0;
  if (scene.env != nullptr) {
    mean = scene.env->mean_luminance;
  } else if (scene.shrm != nullptr) {
    const ShrmCube& c = scene.shrm->global;
    const size_t texels = c.size() / (c.coeff_count() * c.channels);
    for (size_t t = 0; t < texels; ++t) {
      const float* v = &c.data[t * c.coeff_count() * c.channels];
      mean += (0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]) / (2 * std::sqrt(kPi));
    }
    mean /= std::max<size_t>(1, texels);
  }
  return mean > 0 ? std::log2(0.18 / mean) : 0.0;
}

// The overlay's items, one per line of the in-frame text (viewer/overlay_gl.h); joined by " | "
// they are the window title and the stdout line of screenshots. `error`: the last error reported
// (Viewer::ReportError), "" if none.
std::vector<std::string> OverlayLines(const ModeInfo& mode, const SceneData& scene,
                                      const Renderer& r, double frame_ms, bool diff,
                                      double exposure, const std::string& error) {
  std::vector<std::string> lines = {absl::StrCat("mode ", mode.key, " ", mode.name)};
  if (scene.shrm != nullptr) {
    const ShrmData& d = *scene.shrm;
    lines.push_back(d.brdf_spec.empty() ? "BRDF ?" : d.brdf_spec);
    lines.push_back(ShrmSummaryLine(d));
  }
  lines.push_back(absl::StrFormat("%.1f ms", frame_ms));
  lines.push_back(absl::StrFormat("EV %+.1f", exposure));
  const std::string ms = r.ModeStatus(mode.key);
  if (!ms.empty()) lines.push_back(ms);
  if (diff) {
    const DiffStats& st = r.diff_stats();
    if (st.valid) {
      lines.push_back(absl::StrFormat("diff: rel. RMS %.4f, median %.4f, p99 %.4f (%d px)",
                                      st.rel_rms, st.rel_median, st.rel_p99, st.pixels));
    } else {
      lines.push_back("diff: ground truth computing");
    }
  }
  if (!error.empty()) lines.push_back(error);
  return lines;
}

std::string Overlay(const std::vector<std::string>& lines) { return absl::StrJoin(lines, " | "); }

// An error as one overlay item: its first line (shader logs follow on the next ones).
std::string ErrorLine(const absl::Status& s) {
  const absl::string_view message = s.message();
  return absl::StrCat("error: ", message.substr(0, message.find('\n')));
}

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& o) : o_(o), camera_(o.view) {
    camera_.set_fov_y_deg(o.fov_deg);
    settings_.mode = o.mode;
    settings_.diff = o.diff;
  }
  ~Viewer() {
    SetGlfwErrorHandler(nullptr);  // GLFW's last words (glfwTerminate) go to stderr directly
  }
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // The one way an error reaches the user: one line "shrm-view: <message>" on stderr, and the
  // message's first line in the window title and the overlay (until the next scene upload that
  // succeeds). Fatal errors (RunViewer) come here too, before the exit code.
  void ReportError(const absl::Status& s) {
    if (s.ok()) return;
    PrintError(s.message());
    error_line_ = ErrorLine(s);
  }

  // Loads everything that does not need GL.
  [[nodiscard]] absl::Status Load() {
    SHRM_ASSIGN_OR_RETURN(mesh_, BuildMesh(o_.mesh));
    if (o_.live_mode) return LoadLive();
    if (!o_.env.empty()) {
      const auto t0 = Clock::now();
      SHRM_ASSIGN_OR_RETURN(scene_.env, LoadEnvironment(o_.env, o_.reference_width, o_.threads));
      Log(absl::StrFormat(
          "environment %s: %d x %d, SH to degree %d, ground truth over %d x %d "
          "(%.0f ms)",
          o_.env, scene_.env->map.width(), scene_.env->map.height(), scene_.env->sh_lmax,
          o_.reference_width, o_.reference_width / 2, Ms(Clock::now() - t0)));
    }
    brdf_spec_ = o_.brdf;
    if (!o_.shrm_file.empty()) {
      SHRM_ASSIGN_OR_RETURN(ShrmData d, LoadShrmData(o_.shrm_file, o_.threads));
      if (brdf_spec_.empty()) brdf_spec_ = d.brdf_spec;
      scene_.shrm = std::make_shared<const ShrmData>(std::move(d));
    }
    if (!brdf_spec_.empty()) {
      absl::StatusOr<std::unique_ptr<Brdf>> b = ParseBrdfSpec(brdf_spec_);
      if (b.ok()) {
        scene_.brdf = std::move(*b);
        scene_.brdf_spec = scene_.brdf->spec();
      } else if (o_.mode == 5 || o_.diff || o_.shrm_file.empty()) {
        return b.status();
      }
    }
    if ((o_.mode == 5 || o_.diff) && scene_.brdf == nullptr) {
      return absl::InvalidArgumentError(
          "the ground truth needs the BRDF: give --brdf (the SHRM file has no shrm:brdf)");
    }
    if (!o_.env.empty()) {
#ifdef SHRM_VIEWER_HAVE_CLIENT
      job_ = std::make_unique<AsyncShrmJob>(o_.server.empty() ? EmbeddedCompute(scene_.env)
                                                              : RemoteCompute(o_.server, o_.env));
#else
      job_ = std::make_unique<AsyncShrmJob>(EmbeddedCompute(scene_.env));
#endif
    }
    if (scene_.shrm == nullptr) StartCompute(brdf_spec_);
    exposure_ = o_.exposure_set ? o_.exposure : AutoExposure(scene_);
    return absl::OkStatus();
  }

  [[nodiscard]] absl::Status CreateGl(bool visible) {
    SetGlfwErrorHandler([this](const absl::Status& s) { ReportError(s); });
    SHRM_ASSIGN_OR_RETURN(context_, GlContext::Create(o_.width, o_.height, visible, "shrm-view"));
    if (o_.verbose) Log(context_->Describe());
    SHRM_ASSIGN_OR_RETURN(renderer_, Renderer::Create(o_.width, o_.height, o_.threads));
    ReportError(renderer_->InitErrors());  // unavailable modes; the others go on
    renderer_->SetMesh(mesh_);
    UploadScene();
    return absl::OkStatus();
  }

  // --screenshot: one frame (waiting for a computation and the ground truth), then the file.
  [[nodiscard]] absl::Status Screenshot() {
    if (job_ != nullptr) SHRM_RETURN_IF_ERROR(TakeJobResult(job_->Wait()));
    if (live_ != nullptr) SHRM_RETURN_IF_ERROR(LiveFramesBeforeScreenshot());
    if (scene_.shrm == nullptr && (settings_.mode == 1 || settings_.mode == 2)) {
      return absl::FailedPreconditionError("no SHRM to show");
    }
    if (!o_.exposure_set) exposure_ = AutoExposure(scene_);
    settings_.exposure = static_cast<float>(exposure_);
    if (!renderer_->ModeReady(settings_.mode)) {
      const absl::Status why = renderer_->ModeError(settings_.mode);
      return absl::FailedPreconditionError(
          absl::StrCat("mode ", settings_.mode, " has no data to draw",
                       why.ok() ? "" : absl::StrCat(" (", why.message(), ")")));
    }
    const auto t0 = Clock::now();
    SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));
    if (renderer_->reference_active()) {
      renderer_->reference().Wait();
      SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));  // uploads the truth
      SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));  // difference statistics
    }
    glFinish();
    const double ms = Ms(Clock::now() - t0);
    const std::vector<std::string> lines = Lines(ms);
    std::printf("%s\n", Overlay(lines).c_str());
    if (o_.overlay) {  // --overlay: the same frame again with the text drawn in
      settings_.overlay = lines;
      SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));
      glFinish();
    }
    const bool exr =
        o_.screenshot.size() > 4 && (o_.screenshot.substr(o_.screenshot.size() - 4) == ".exr" ||
                                     o_.screenshot.substr(o_.screenshot.size() - 4) == ".EXR");
    if (exr) {
      const std::vector<float> rgba = renderer_->ReadHdr();
      Image img;
      img.width = renderer_->width();
      img.height = renderer_->height();
      img.channels = 3;
      img.pixels.resize(static_cast<size_t>(img.width) * img.height * 3);
      for (size_t i = 0; i < rgba.size() / 4; ++i)
        for (int c = 0; c < 3; ++c) img.pixels[3 * i + c] = rgba[4 * i + c];
      SHRM_RETURN_IF_ERROR(WriteExr(o_.screenshot, img));
    } else {
      SHRM_RETURN_IF_ERROR(WriteImage8Bit(o_.screenshot, renderer_->ReadLdr()));
    }
    std::printf("wrote %s (%d x %d, mode %d%s)\n", o_.screenshot.c_str(), renderer_->width(),
                renderer_->height(), settings_.mode, settings_.diff ? ", difference view" : "");
    return absl::OkStatus();
  }

  // --bench-frames N: N frames per ready mode, the camera turning 1 degree per frame.
  [[nodiscard]] absl::Status Bench() {
    if (live_ != nullptr) return LiveBench();
    if (job_ != nullptr) SHRM_RETURN_IF_ERROR(TakeJobResult(job_->Wait()));
    settings_.exposure = static_cast<float>(exposure_);
    std::printf("frame times at %d x %d (%s), mesh %s, %d frames per mode:\n", renderer_->width(),
                renderer_->height(), context_->Describe().c_str(), o_.mesh.c_str(),
                o_.bench_frames);
    for (const ModeInfo& m : RegisteredModes()) {
      if (!renderer_->ModeReady(m.key)) {
        std::printf("  mode %d %-12s not ready (%s)\n", m.key, m.name,
                    renderer_->ModeError(m.key).ok() ? "missing inputs" : "error reported above");
        continue;
      }
      RenderSettings s = settings_;
      s.mode = m.key;
      s.diff = false;
      OrbitCamera cam = camera_;
      SHRM_RETURN_IF_ERROR(renderer_->Render(cam, s));  // warm-up (programs, uploads)
      glFinish();
      s.reference_may_restart = false;  // mode 5: draw cost only, the truth stays running
      const auto t0 = Clock::now();
      for (int i = 0; i < o_.bench_frames; ++i) {
        cam.Orbit(1, 0);
        SHRM_RETURN_IF_ERROR(renderer_->Render(cam, s));
        glFinish();
      }
      const double ms = Ms(Clock::now() - t0) / o_.bench_frames;
      std::printf("  mode %d %-12s %8.2f ms/frame  %s\n", m.key, m.name, ms,
                  renderer_->ModeStatus(m.key).c_str());
      renderer_->reference().Cancel();
    }
    return absl::OkStatus();
  }

  [[nodiscard]] absl::Status Interactive() {
    GLFWwindow* w = context_->window();
    glfwSetWindowUserPointer(w, this);
    glfwSetKeyCallback(w, [](GLFWwindow* win, int key, int, int action, int mods) {
      static_cast<Viewer*>(glfwGetWindowUserPointer(win))->OnKey(key, action, mods);
    });
    glfwSetMouseButtonCallback(w, [](GLFWwindow* win, int button, int action, int) {
      auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(win));
      if (button == GLFW_MOUSE_BUTTON_LEFT) v->dragging_ = action == GLFW_PRESS;
      glfwGetCursorPos(win, &v->last_x_, &v->last_y_);
    });
    glfwSetCursorPosCallback(w, [](GLFWwindow* win, double x, double y) {
      auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(win));
      if (v->dragging_) {
        v->camera_.Orbit(-0.3 * (x - v->last_x_), 0.3 * (y - v->last_y_));
        v->last_move_ = Clock::now();
      }
      v->last_x_ = x;
      v->last_y_ = y;
    });
    glfwSetScrollCallback(w, [](GLFWwindow* win, double, double dy) {
      auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(win));
      v->camera_.Zoom(std::pow(0.9, dy));
      v->last_move_ = Clock::now();
    });
    PrintHelp();
    auto last_title = Clock::now() - std::chrono::seconds(1);
    double frame_ms = 0;
    auto prev = Clock::now();
    std::string last_stats;
    int frames = 0;
    while (!glfwWindowShouldClose(w)) {
      // --frames counts the frames drawn once no computation is pending (live: every frame).
      if (o_.quit_after_frames > 0 && !(job_ != nullptr && job_->busy()) &&
          frames++ >= o_.quit_after_frames)
        break;
      glfwPollEvents();
      if (live_ != nullptr) {
        // A lighting or frame error is reported once; the loop goes on with the last SHRM.
        const absl::Status s = LiveTick(false);
        if (!s.ok() && s != live_error_) ReportError(s);
        if (!s.ok()) live_error_ = s;
      }
      if (job_ != nullptr) {
        if (std::optional<absl::StatusOr<ShrmData>> r = job_->Poll()) {
          ReportError(TakeJobResult(std::move(r)));
        }
      }
      int fw, fh;
      glfwGetFramebufferSize(w, &fw, &fh);
      if (fw > 0 && fh > 0) {
        absl::Status s = renderer_->Resize(fw, fh);
        if (!s.ok()) return s;
      }
      settings_.exposure = static_cast<float>(exposure_);
      settings_.compute_progress = job_ != nullptr && job_->busy() ? job_->fraction() : -1;
      settings_.reference_may_restart =
          !dragging_ && Clock::now() - last_move_ > std::chrono::milliseconds(200);
      if (renderer_->ModeReady(settings_.mode)) {
        // A mode's Draw() error leaves it not ready (render_mode.h): reported once, the window
        // stays.
        ReportError(renderer_->Render(camera_, settings_));
      } else {
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glClearColor(0.05f, 0.05f, 0.05f, 1);
        glClear(GL_COLOR_BUFFER_BIT);
      }
      renderer_->BlitToWindow(fw, fh);
      glfwSwapBuffers(w);
      ++rendered_;
      const auto now = Clock::now();
      frame_ms = 0.9 * frame_ms + 0.1 * Ms(now - prev);
      prev = now;
      if (now - last_title > std::chrono::milliseconds(250)) {
        last_title = now;
        std::vector<std::string> lines = Lines(frame_ms);
        if (job_ != nullptr && job_->busy())
          lines.push_back(
              absl::StrFormat("computing %s %.0f%%", job_->stage(), 100 * job_->fraction()));
        glfwSetWindowTitle(w, ("shrm-view | " + Overlay(lines)).c_str());
        if (show_overlay_) {
          settings_.overlay = std::move(lines);
        } else {
          settings_.overlay.clear();
        }
        const DiffStats& st = renderer_->diff_stats();
        if (settings_.diff && st.valid) {
          const std::string line = absl::StrFormat(
              "difference mode %d vs ground truth: rel. RMS %.4f, median %.4f, p99 %.4f (%d px)",
              settings_.mode, st.rel_rms, st.rel_median, st.rel_p99, st.pixels);
          if (line != last_stats) Log(line);
          last_stats = line;
        }
      }
    }
    return absl::OkStatus();
  }

 private:
  // The overlay's items (OverlayLines, and the live mode's figures after the SHRM's).
  std::vector<std::string> Lines(double frame_ms) const {
    std::vector<std::string> lines = OverlayLines(*FindMode(settings_.mode), scene_, *renderer_,
                                                  frame_ms, settings_.diff, exposure_, error_line_);
    if (live_ != nullptr && live_shown_ != nullptr) {
      const std::vector<std::string> live = LiveOverlayLines(
          o_.live, *live_shown_, live_->Stats(), live_rate_.rate(), render_rate_.rate());
      lines.insert(lines.begin() + std::min<size_t>(lines.size(), 3), live.begin(), live.end());
    }
    return lines;
  }

  // --live: the lighting source (its first map decoded or rendered, every sequence header
  // checked: input errors before the window), the session, the BRDF.
  [[nodiscard]] absl::Status LoadLive() {
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(o_.brdf));
    brdf_spec_ = brdf->spec();
    scene_.brdf = std::move(brdf);
    scene_.brdf_spec = brdf_spec_;
    const auto t0 = Clock::now();
    SHRM_ASSIGN_OR_RETURN(live_lighting_, LiveLighting::Create(o_.live, o_.threads));
    ComputeRequest req;
    req.brdf_spec = brdf_spec_;
    req.epsilon = o_.epsilon;
    req.f = o_.f;
    req.p = o_.p;
    req.verify = 0;  // the session has no per-frame check (docs/live.md)
    req.face_size = o_.face_size;
    SHRM_ASSIGN_OR_RETURN(
        live_,
        LiveDriver::Create(PrefilterJobFor(req, live_lighting_->first()->env->path), o_.threads));
    scene_.env = live_lighting_->first()->env;  // the automatic exposure: the first map's
    exposure_ = o_.exposure_set ? o_.exposure : AutoExposure(scene_);
    Log(absl::StrFormat("live %s: %s, %d x %d (%.0f ms), %s", LiveKindName(o_.live.kind),
                        live_lighting_->first()->label, scene_.env->map.width(),
                        scene_.env->map.height(), Ms(Clock::now() - t0), brdf_spec_));
    return absl::OkStatus();
  }

  // One frame of the live mode: the lighting at the clock and the material pushed into the
  // session, then the newest frame taken (wait, or the deterministic clock: this state's frame).
  [[nodiscard]] absl::Status LiveTick(bool wait) {
    const auto now = Clock::now();
    const bool step = o_.live.step > 0;
    if (rendered_ == 0 && live_shown_ == nullptr) live_last_tick_ = now;  // the clock starts here
    if (!live_paused_) live_t_ += std::chrono::duration<double>(now - live_last_tick_).count();
    live_last_tick_ = now;
    const double t = step ? static_cast<double>(live_steps_) * o_.live.step : live_t_;
    if (step && !live_paused_) ++live_steps_;
    SHRM_ASSIGN_OR_RETURN(const LiveLightingState lighting, live_lighting_->At(t, step));
    live_->SetNeedLocal(settings_.mode == 2);
    live_->SetNeedSplitSum(settings_.mode == 6);
    SHRM_ASSIGN_OR_RETURN(const uint64_t update, live_->Push(lighting, brdf_spec_));
    std::shared_ptr<const LiveShown> shown;
    if (step || wait) {
      SHRM_ASSIGN_OR_RETURN(shown, live_->WaitFor(update, kLiveWait));
    } else {
      shown = live_->Latest();
    }
    const double seconds = std::chrono::duration<double>(now - live_start_).count();
    live_rate_.Add(seconds, live_->Stats().frames);
    render_rate_.Add(seconds, rendered_);
    // Mode 2 takes a frame once its local SHRM is converted (LiveDriver::SetNeedLocal), mode 6
    // once it has its split-sum set (LiveDriver::SetNeedSplitSum).
    const bool usable =
        shown != nullptr &&
        (!shown->status.ok() || ((settings_.mode != 2 || shown->has_local) &&
                                 (settings_.mode != 6 || shown->split_sum != nullptr)));
    if (usable && shown != live_shown_) {
      live_shown_ = shown;
      if (!shown->status.ok()) return shown->status;  // the last SHRM stays on screen
      live_error_ = absl::OkStatus();
      scene_.shrm = shown->shrm;
      scene_.env = shown->map->env;
      scene_.brdf = shown->brdf;
      scene_.split_sum = shown->split_sum;
      settings_.background_rotation = shown->rotation;
      if (renderer_ != nullptr) UploadScene();
      ++live_totals_.frames;
      for (const StageTiming& st : shown->timings) {
        auto it = std::find_if(live_totals_.stage_ms.begin(), live_totals_.stage_ms.end(),
                               [&](const auto& e) { return e.first == st.stage; });
        if (it == live_totals_.stage_ms.end()) {
          live_totals_.stage_ms.emplace_back(st.stage, st.ms);
        } else {
          it->second += st.ms;
        }
      }
      live_totals_.compute_ms += shown->compute_ms;
      live_totals_.convert_ms += shown->convert_ms;
    } else if (usable && !shown->status.ok()) {
      return shown->status;
    }
    return absl::OkStatus();
  }

  // --screenshot with --live: --frames N frames (default 1), the last one waiting for its state;
  // with --live-step, frame k shows clock k x step.
  [[nodiscard]] absl::Status LiveFramesBeforeScreenshot() {
    const int frames = std::max(1, o_.quit_after_frames);
    settings_.exposure = static_cast<float>(exposure_);
    for (int k = 0; k < frames; ++k) {
      SHRM_RETURN_IF_ERROR(LiveTick(k + 1 == frames));
      if (k + 1 < frames && renderer_->ModeReady(settings_.mode)) {
        SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));
        ++rendered_;
      }
    }
    return absl::OkStatus();
  }

  // --bench-frames N with --live: N frames of the loop (the wall clock, or --live-step), then
  // the render and live frames per second and the mean ms per stage of the frames shown.
  [[nodiscard]] absl::Status LiveBench() {
    settings_.exposure = static_cast<float>(exposure_);
    SHRM_RETURN_IF_ERROR(LiveTick(true));  // warm-up: the first frame, programs, uploads
    SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));
    glFinish();
    const uint64_t rendered0 = rendered_, frames0 = live_->Stats().frames;
    live_totals_ = {};
    const auto t0 = Clock::now();
    for (int k = 0; k < o_.bench_frames; ++k) {
      SHRM_RETURN_IF_ERROR(LiveTick(false));
      if (renderer_->ModeReady(settings_.mode)) {
        SHRM_RETURN_IF_ERROR(renderer_->Render(camera_, settings_));
        glFinish();
        ++rendered_;
      }
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    const LiveStats stats = live_->Stats();
    std::printf(
        "live %s at %d x %d (%s), mode %d, %s: %llu frames rendered in %.2f s (%.1f frames/s); "
        "%llu live frames computed (%.1f frames/s), %llu of %llu states dropped\n",
        LiveKindName(o_.live.kind), renderer_->width(), renderer_->height(),
        context_->Describe().c_str(), settings_.mode, brdf_spec_.c_str(),
        static_cast<unsigned long long>(rendered_ - rendered0), seconds,
        (rendered_ - rendered0) / seconds, static_cast<unsigned long long>(stats.frames - frames0),
        (stats.frames - frames0) / seconds, static_cast<unsigned long long>(stats.dropped),
        static_cast<unsigned long long>(stats.updates));
    const LiveTotals& t = live_totals_;
    std::string stages;
    for (const auto& [stage, ms] : t.stage_ms)
      absl::StrAppendFormat(&stages, " %s %.2f", stage, ms / std::max(1, t.frames));
    std::printf("  mean ms per shown frame (%d frames):%s | compute %.2f convert %.2f\n", t.frames,
                stages.c_str(), t.compute_ms / std::max(1, t.frames),
                t.convert_ms / std::max(1, t.frames));
    if (live_shown_ != nullptr && live_shown_->shrm != nullptr) {
      std::printf("  %s\n", ShrmSummaryLine(*live_shown_->shrm).c_str());
    }
    return absl::OkStatus();
  }

  void Log(const std::string& line) {
    std::printf("%s\n", line.c_str());
    std::fflush(stdout);
  }

  void PrintHelp() {
    Log("keys: 1-5 mode, D difference view, B next BRDF, [ ] lobe narrower/wider, +/- exposure,\n"
        "      M next mesh, O overlay, arrows orbit, PgUp/PgDn zoom, R reset view, H help,\n"
        "      Space pause/resume the live lighting (--live), Esc quit;\n"
        "      mouse: drag to orbit, wheel to zoom");
    for (const ModeInfo& m : RegisteredModes())
      Log(absl::StrFormat("  mode %d %-12s %s", m.key, m.name, m.description));
  }

  void StartCompute(const std::string& spec) {
    if (live_ != nullptr) {  // the next frame pushes the material into the session
      brdf_spec_ = pending_spec_ = spec;
      Log(absl::StrCat("material ", spec));
      return;
    }
    if (job_ == nullptr) {
      Log("changing the BRDF needs --env (the map the SHRM is computed from)");
      return;
    }
    ComputeRequest req;
    req.brdf_spec = spec;
    req.epsilon = o_.epsilon;
    req.tolerance = o_.tolerance;
    req.verify = o_.verify;
    req.f = o_.f;
    req.p = o_.p;
    req.face_size = o_.face_size;
    req.threads = o_.threads;
    pending_spec_ = spec;
    Log(absl::StrCat("computing the SHRM of ", spec, o_.server.empty() ? "" : " on ", o_.server,
                     " ..."));
    job_->Start(req);
  }

  [[nodiscard]] absl::Status TakeJobResult(std::optional<absl::StatusOr<ShrmData>> r) {
    if (!r.has_value()) return absl::OkStatus();
    if (!r->ok()) return r->status();
    auto d = std::make_shared<const ShrmData>(*std::move(*r));
    absl::StatusOr<std::unique_ptr<Brdf>> b = ParseBrdfSpec(d->brdf_spec);
    if (b.ok()) {
      scene_.brdf = std::move(*b);
      scene_.brdf_spec = scene_.brdf->spec();
      brdf_spec_ = scene_.brdf_spec;
    }
    scene_.shrm = d;
    Log(absl::StrFormat("SHRM %s (%s): F_B %d, P_B %d, %d coefficients, S_B %d, %.0f ms",
                        d->brdf_spec, d->origin, d->f_b, d->p_b, ShCount(d->p_b),
                        d->global.face_size, d->compute_ms));
    if (renderer_ != nullptr) UploadScene();
    return absl::OkStatus();
  }

  // A mode that cannot take the scene (e.g. a cube beyond the GL limits) is not ready; the others
  // go on (the renderer keeps each mode's error for a screenshot in that mode: ModeError). The
  // same error again (the next SHRM for the same BRDF) is not reported twice.
  void UploadScene() {
    const absl::Status s = renderer_->SetScene(
        scene_, live_ != nullptr ? std::optional<int>(settings_.mode) : std::nullopt);
    if (s.ok()) {
      // Every available mode takes the scene: earlier errors are over, unavailable modes are not.
      const absl::Status unavailable = renderer_->InitErrors();
      error_line_ = unavailable.ok() ? "" : ErrorLine(unavailable);
    } else if (s != last_upload_error_) {
      ReportError(s);
    }
    last_upload_error_ = s;
  }

  void OnKey(int key, int action, int mods) {
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    if (key >= GLFW_KEY_1 && key <= GLFW_KEY_9) {
      const int m = key - GLFW_KEY_0;
      const ModeInfo* info = FindMode(m);
      if (live_ != nullptr && info != nullptr) {
        if (m != 1 && m != 2 && m != 6) {
          Log(absl::StrCat("mode ", m,
                           ": the live mode shows the SHRM in modes 1 and 2, the split-sum in 6"));
          return;
        }
        // The live scene goes to the active mode only; mode 2 waits for a frame converted to
        // the local SHRM (the next frame, or the newest converted again), mode 6 for a frame
        // with the split-sum set (computed from then on).
        settings_.mode = m;
        live_->SetNeedLocal(m == 2);
        live_->SetNeedSplitSum(m == 6);
        if (scene_.shrm != nullptr && (m == 1 || (m == 2 && !scene_.shrm->local.data.empty()) ||
                                       (m == 6 && scene_.split_sum != nullptr))) {
          ReportError(renderer_->SyncMode(m));
        }
        Log(absl::StrCat("mode ", m, ": ", info->description));
        return;
      }
      if (info == nullptr) {
        Log(absl::StrCat("mode ", m, " is not available in this build"));
      } else if (!renderer_->ModeReady(m)) {
        const absl::Status why = renderer_->ModeError(m);
        Log(absl::StrCat("mode ", m, " (", info->name, ") has no data yet",
                         !why.ok() ? absl::StrCat(": ", why.message())
                         : m == 5  ? ": the ground truth needs --env and a BRDF"
                         : m == 6  ? ": the split-sum needs --env and a GGX BRDF "
                                     "(--brdf ggx:alpha=A[,f0=F])"
                                   : ""));
      } else {
        settings_.mode = m;
        Log(absl::StrCat("mode ", m, ": ", info->description));
      }
      return;
    }
    switch (key) {
      case GLFW_KEY_ESCAPE:
      case GLFW_KEY_Q:
        glfwSetWindowShouldClose(context_->window(), GLFW_TRUE);
        break;
      case GLFW_KEY_SPACE:
        if (live_ != nullptr) {
          live_paused_ = !live_paused_;
          Log(live_paused_ ? "live lighting paused" : "live lighting resumed");
        }
        break;
      case GLFW_KEY_D:
        if (live_ != nullptr) {
          Log("the difference view needs the ground truth of a fixed map: not in live mode");
        } else if (scene_.env == nullptr || scene_.brdf == nullptr) {
          Log("the difference view needs --env and a BRDF");
        } else {
          settings_.diff = !settings_.diff;
          Log(settings_.diff ? "difference view on (blue 1e-3 .. red 1 relative error)"
                             : "difference view off");
        }
        break;
      case GLFW_KEY_B: {
        const std::vector<std::string>& presets = BrdfPresets();
        preset_ = (preset_ + 1) % static_cast<int>(presets.size());
        StartCompute(presets[preset_]);
        break;
      }
      case GLFW_KEY_LEFT_BRACKET:
      case GLFW_KEY_RIGHT_BRACKET: {
        const std::string base = pending_spec_.empty() ? brdf_spec_ : pending_spec_;
        absl::StatusOr<std::string> s =
            ScaleBrdfLobe(base, key == GLFW_KEY_LEFT_BRACKET ? 0.8 : 1.25);
        if (s.ok()) {
          StartCompute(*s);
        } else {
          ReportError(s.status());
        }
        break;
      }
      case GLFW_KEY_EQUAL:
      case GLFW_KEY_KP_ADD:
        exposure_ += 0.5;
        break;
      case GLFW_KEY_MINUS:
      case GLFW_KEY_KP_SUBTRACT:
        exposure_ -= 0.5;
        break;
      case GLFW_KEY_M: {
        std::vector<std::string> meshes = {"sphere", "torus"};
        if (o_.mesh != "sphere" && o_.mesh != "torus") meshes.push_back(o_.mesh);
        mesh_index_ = (mesh_index_ + 1) % static_cast<int>(meshes.size());
        absl::StatusOr<Mesh> m = BuildMesh(meshes[mesh_index_]);
        if (m.ok()) {
          renderer_->SetMesh(*m);
          Log(absl::StrCat("mesh ", meshes[mesh_index_]));
        } else {
          ReportError(m.status());
        }
        break;
      }
      case GLFW_KEY_LEFT:
        camera_.Orbit(-5, 0);
        break;
      case GLFW_KEY_RIGHT:
        camera_.Orbit(5, 0);
        break;
      case GLFW_KEY_UP:
        camera_.Orbit(0, 5);
        break;
      case GLFW_KEY_DOWN:
        camera_.Orbit(0, -5);
        break;
      case GLFW_KEY_PAGE_UP:
        camera_.Zoom(0.9);
        break;
      case GLFW_KEY_PAGE_DOWN:
        camera_.Zoom(1 / 0.9);
        break;
      case GLFW_KEY_R:
        camera_.set_view(o_.view);
        break;
      case GLFW_KEY_H:
        PrintHelp();
        break;
      case GLFW_KEY_O:
        show_overlay_ = !show_overlay_;
        if (!show_overlay_) settings_.overlay.clear();
        Log(show_overlay_ ? "overlay on" : "overlay off");
        break;
      default: {
        std::string message;  // keys of the active mode (RenderMode::OnKey)
        if (renderer_->ModeKey(settings_.mode, key, &message)) Log(message);
        break;
      }
    }
    (void)mods;
  }

  const ViewerOptions& o_;
  OrbitCamera camera_;
  RenderSettings settings_;
  Mesh mesh_;
  int mesh_index_ = 0;
  SceneData scene_;
  std::string brdf_spec_, pending_spec_;
  std::string error_line_;  // the last error, shown in the title and the overlay
  absl::Status last_upload_error_;
  int preset_ = -1;
  double exposure_ = 0;
  std::unique_ptr<AsyncShrmJob> job_;
  // --live: the lighting source, the session, the frame on screen and the figures.
  std::unique_ptr<LiveLighting> live_lighting_;
  std::unique_ptr<LiveDriver> live_;
  std::shared_ptr<const LiveShown> live_shown_;
  absl::Status live_error_;  // the last lighting or frame error reported
  int64_t live_steps_ = 0;   // --live-step: frames the clock has advanced
  double live_t_ = 0;        // the wall clock's live time, seconds (paused: not advancing)
  bool live_paused_ = false;
  Clock::time_point live_last_tick_, live_start_ = Clock::now();
  RateMeter live_rate_, render_rate_;
  uint64_t rendered_ = 0;
  struct LiveTotals {
    int frames = 0;
    std::vector<std::pair<std::string, double>> stage_ms;  // in the session's order
    double compute_ms = 0, convert_ms = 0;
  } live_totals_;
  std::unique_ptr<GlContext> context_;
  std::unique_ptr<Renderer> renderer_;
  bool dragging_ = false;
  bool show_overlay_ = true;  // key O: the in-frame text of the interactive window
  double last_x_ = 0, last_y_ = 0;
  Clock::time_point last_move_ = Clock::now();
};

}  // namespace

int RunViewer(const ViewerOptions& o) {
  Viewer viewer(o);
  absl::Status s = viewer.Load();
  const bool headless = !o.screenshot.empty() || o.bench_frames > 0;
  if (s.ok()) s = viewer.CreateGl(!headless);
  if (s.ok()) {
    if (!o.screenshot.empty()) {
      s = viewer.Screenshot();
    } else if (o.bench_frames > 0) {
      s = viewer.Bench();
    } else {
      s = viewer.Interactive();
    }
  }
  if (!s.ok()) {
    viewer.ReportError(s);
    return kExitError;
  }
  return kExitOk;
}

}  // namespace shrm::viewer
