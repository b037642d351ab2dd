// `shrm live` (docs/cli.md, docs/live.md): a sequence of lighting states prefiltered by one live
// session (core/shrm/live_session.h): HDR frames (--sequence) or one map turned about the vertical
// axis (--env with --turntable N). Each frame's SHRM file is the one `shrm prefilter` writes for
// that frame (--epsilon/--orders, --verify 0, and --rotate for a turntable frame), byte for byte;
// the next frame is decoded while the session computes the current one.
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "core/base/status_macros.h"
#include "core/io/image.h"
#include "core/shrm/live_session.h"
#include "core/shrm/shrm_file.h"
#include "jobs/cli_validators.h"
#include "jobs/option_text.h"
#include "jobs/prefilter_job.h"

namespace shrm::cli {
namespace {

// Frames a turntable may have (one per degree step of 0.1 at most).
constexpr int kMaxTurntableFrames = 3600;
// A frame is waited for at most this long (a safety net: frames take milliseconds to seconds).
constexpr absl::Duration kFrameWait = absl::Minutes(10);

struct LiveArgs {
  std::vector<std::string> sequence;  // one map per frame
  std::string env;                    // with turntable
  int turntable = 0;
  std::string brdf;
  std::optional<double> epsilon;
  std::string orders;
  std::string kind = jobs::ShrmKindName(ShrmKind::kGlobal);
  int size = 0;
  std::string view;
  std::string output;  // folder
  int threads = 0;
  bool json = false;
};

// The prefilter job each frame is (its file attributes are that job's).
struct FrameJob {
  jobs::PrefilterJob job;
  std::string path;
};

absl::StatusOr<std::vector<FrameJob>> FrameJobs(const LiveArgs& a) {
  if (a.sequence.empty() == a.env.empty()) {
    return absl::InvalidArgumentError("give either --sequence FILES or --env FILE --turntable N");
  }
  if (!a.env.empty() && a.turntable < 1) {
    return absl::InvalidArgumentError("--env needs --turntable N (frames per turn, >= 1)");
  }
  if (a.env.empty() && a.turntable > 0) {
    return absl::InvalidArgumentError("--turntable turns one map: give it with --env");
  }
  jobs::PrefilterJob base;
  base.brdf = a.brdf;
  base.verify = 0;
  std::optional<jobs::Orders> orders;
  if (!a.orders.empty()) {
    SHRM_ASSIGN_OR_RETURN(orders, jobs::ParseOrdersText(a.orders, "--orders"));
  }
  // The paper's rule at 0.03 unless one is given (the tolerance rule takes seconds a frame).
  SHRM_RETURN_IF_ERROR(
      jobs::SetOrderRule(&base, orders ? a.epsilon : a.epsilon.value_or(jobs::kDefaultEpsilon),
                         std::nullopt, orders, "--epsilon and --orders"));
  SHRM_ASSIGN_OR_RETURN(base.kind, jobs::ParseShrmKind(a.kind));
  base.face_size = a.size;
  std::vector<FrameJob> frames;
  if (a.env.empty()) {
    for (const std::string& path : a.sequence) {
      FrameJob f{base, path};
      f.job.env.files = {path};
      frames.push_back(std::move(f));
    }
  } else {
    for (int k = 0; k < a.turntable; ++k) {
      FrameJob f{base, a.env};
      f.job.env.files = {a.env};
      f.job.env.rotate_ypr_deg = std::array<double, 3>{360.0 * k / a.turntable, 0, 0};
      frames.push_back(std::move(f));
    }
  }
  for (const FrameJob& f : frames) SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(f.job));
  return frames;
}

std::string FramePath(const std::string& folder, int index, const char* suffix) {
  return absl::StrFormat("%s/frame_%04d.%s", folder, index, suffix);
}

std::string StageText(const LiveFrame& f) {
  std::string s;
  for (const StageTiming& t : f.result.timings)
    absl::StrAppendFormat(&s, " %s %.1f", t.stage, t.ms);
  return s;
}

absl::Status RunLive(const LiveArgs& a) {
  SHRM_ASSIGN_OR_RETURN(const std::vector<FrameJob> frames, FrameJobs(a));
  std::optional<Vec3> view;
  if (!a.view.empty()) {
    SHRM_ASSIGN_OR_RETURN(view, ParseDirection(a.view, "--view"));
  }
  // Everything checked before the first frame: the BRDF, every map's header, the folder.
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> parsed, ParseBrdfSpec(a.brdf));
  const std::shared_ptr<const Brdf> brdf(std::move(parsed));
  for (const FrameJob& f : frames) {
    if (&f != &frames.front() && f.path == frames.front().path) continue;
    absl::Status probe = ProbeImage(f.path).status();
    if (!probe.ok()) return probe;
  }
  std::error_code ec;
  std::filesystem::create_directories(a.output, ec);  // CheckOutputPath names what fails
  SHRM_RETURN_IF_ERROR(CheckOutputPath(FramePath(a.output, 0, "shrm.exr"), "--output"));

  const int threads = ResolveThreads(a.threads);
  PrefilterOptions options = jobs::CorePrefilterOptions(frames.front().job, threads);
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<LiveSession> session, LiveSession::Create(options));
  session->SetBrdf(brdf);
  session->SetView(view);

  // The map of frame k (decoded once for a turntable) and its source identity.
  struct Decoded {
    std::shared_ptr<const EnvMap> map;
    jobs::PrefilterProvenance provenance;
    double ms = 0;
  };
  auto decode = [&](const FrameJob& f) -> absl::StatusOr<Decoded> {
    const auto start = std::chrono::steady_clock::now();
    Decoded d;
    SHRM_ASSIGN_OR_RETURN(EnvMap map, LoadEnv(f.job.env));
    SHRM_ASSIGN_OR_RETURN(d.provenance.source, jobs::LocalSourceIdentity(f.job.env));
    d.provenance.brdf_spec = brdf->spec();
    d.provenance.layout = map.layout();
    d.map = std::make_shared<const EnvMap>(std::move(map));
    d.ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return d;
  };
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json report = nlohmann::json::array();
  SHRM_ASSIGN_OR_RETURN(Decoded current, decode(frames.front()));
  for (size_t k = 0; k < frames.size(); ++k) {
    const FrameJob& f = frames[k];
    session->SetRotation(jobs::EnvironmentRotation(f.job.env));
    const uint64_t update = session->SetMap(current.map);
    // The next frame's map while this one is computed (a turntable keeps its one map).
    std::optional<Decoded> next;
    if (k + 1 < frames.size()) {
      if (a.env.empty()) {
        SHRM_ASSIGN_OR_RETURN(next, decode(frames[k + 1]));
      } else {
        next = current;
        next->ms = 0;
      }
    }
    SHRM_ASSIGN_OR_RETURN(const std::shared_ptr<const LiveFrame> frame,
                          session->WaitFor(update, kFrameWait));
    if (!frame->status.ok()) {
      return absl::Status(frame->status.code(),
                          absl::StrCat(f.path, ": ", frame->status.message()));
    }
    const auto write_start = std::chrono::steady_clock::now();
    const auto attributes = jobs::PrefilterFileAttributes(f.job, current.provenance, frame->result);
    const std::string shrm_path = FramePath(a.output, static_cast<int>(k), "shrm.exr");
    SHRM_RETURN_IF_ERROR(WriteShrmFile(shrm_path, frame->result.cube, attributes));
    std::string view_path;
    if (view) {
      view_path = FramePath(a.output, static_cast<int>(k), "view.exr");
      SHRM_RETURN_IF_ERROR(WriteRadianceCross(view_path, frame->view_map));
    }
    const double write_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - write_start)
            .count();
    const ShrmAnalysis& an = frame->result.analysis;
    nlohmann::json j = {{"frame", k},
                        {"source", f.path},
                        {"output", shrm_path},
                        {"F_B", an.f_b},
                        {"P_B", an.p_b},
                        {"decode_ms", current.ms},
                        {"compute_ms", frame->compute_ms},
                        {"write_ms", write_ms}};
    if (f.job.env.rotate_ypr_deg) j["rotate_ypr_deg"] = *f.job.env.rotate_ypr_deg;
    if (!view_path.empty()) j["view_map"] = view_path;
    for (const StageTiming& t : frame->result.timings) j["stages"][t.stage + "_ms"] = t.ms;
    report.push_back(j);
    if (!a.json) {
      std::printf(
          "frame %zu: %s -> %s, (F_B, P_B) = (%d, %d), %.1f ms (decode %.1f;%s; write %.1f)\n", k,
          f.path.c_str(), shrm_path.c_str(), an.f_b, an.p_b,
          current.ms + frame->compute_ms + write_ms, current.ms, StageText(*frame).c_str(),
          write_ms);
    }
    if (next) current = *std::move(next);
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const LiveStats stats = session->Stats();
  if (a.json) {
    std::printf("%s\n", nlohmann::json({{"frames", report},
                                        {"seconds", seconds},
                                        {"frames_per_second", frames.size() / seconds},
                                        {"updates", stats.updates},
                                        {"computed", stats.frames}})
                            .dump(2)
                            .c_str());
  } else {
    std::printf("%zu frames in %.2f s: %.1f frames/s (decode, compute and write; %d thread%s)\n",
                frames.size(), seconds, frames.size() / seconds, threads, threads == 1 ? "" : "s");
  }
  return absl::OkStatus();
}

}  // namespace

void RegisterLive(CLI::App& app, absl::Status* status) {
  auto args = std::make_shared<LiveArgs>();
  CLI::App* sub = app.add_subcommand(
      "live", "prefilter a sequence of lighting states with one live session (docs/live.md)");
  sub->add_option("--sequence", args->sequence, "maps, one per frame (e.g. frames/*.exr)")
      ->expected(1, -1);
  sub->add_option("--env", args->env, "one map turned about the vertical axis (with --turntable)");
  sub->add_option("--turntable", args->turntable,
                  "frames per turn of --env (frame k rotated by 360 k / N degrees of yaw)")
      ->check(CLI::Range(1, kMaxTurntableFrames));
  sub->add_option("--brdf", args->brdf, "BRDF spec, e.g. microfacet:sigma=0.2 (docs/brdf.md)")
      ->required();
  sub->add_option("--epsilon", args->epsilon,
                  "the paper's energy tolerance for the orders (default 0.03; the tolerance "
                  "rule takes seconds per frame: use shrm prefilter for it)")
      ->check(jobs::kOpenUnitInterval);
  sub->add_option("--orders", args->orders, "explicit orders F,P instead of --epsilon")
      ->check(jobs::kOrders);
  sub->add_option("--kind", args->kind, "global or local SHRM")
      ->capture_default_str()
      ->check(CLI::IsMember({"global", "local"}));
  sub->add_option("--size", args->size, "cube face size S_B (0: about 10 F_B)")
      ->check(CLI::Range(0, jobs::kMaxFaceSize));
  sub->add_option("--view", args->view,
                  "also write each frame's reflection map for this view (eq. 5.35), x,y,z")
      ->check(jobs::kDirection);
  sub->add_option("-o,--output", args->output,
                  "folder for frame_NNNN.shrm.exr (and frame_NNNN.view.exr with --view)")
      ->required();
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--json", args->json, "print the frames' report as JSON on stdout");
  sub->callback([args, status] { *status = RunLive(*args); });
}

}  // namespace shrm::cli
