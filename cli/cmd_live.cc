// `shrm live` (docs/cli.md, docs/live.md): a sequence of lighting states prefiltered by one live
// session (core/live/live_session.h): HDR frames (--sequence) or one map turned about the vertical
// axis (--env with --turntable N). Each frame's SHRM file is the one `shrm prefilter` writes for
// that frame (--epsilon/--orders, --verify 0, and --rotate for a turntable frame), byte for byte;
// with --ibl each frame's split-sum set is the folder `shrm ibl --verify 0` writes for it. The
// next frame is decoded while the session computes the current one.
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#if SHRM_CLI_HAS_CLIENT
#include "client/remote_jobs.h"
#include "client/shrm_client.h"
#include "proto/job_codec.h"
#endif
#include "core/base/status_macros.h"
#include "core/export/shrm_ktx2.h"
#include "core/io/atomic_file.h"
#include "core/io/image.h"
#include "core/live/live_session.h"
#include "core/shrm/shrm_file.h"
#include "jobs/cli_validators.h"
#include "jobs/ibl_job.h"
#include "jobs/ibl_outputs.h"
#include "jobs/option_text.h"
#include "jobs/prefilter_job.h"

namespace shrm::cli {
namespace {

#if SHRM_CLI_HAS_CLIENT
namespace v1 = ::shrm::v1;
#endif

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
  bool ktx2 = false;  // each frame's SHRM in the KTX2 container instead of the EXR
  // --ibl: each frame's split-sum set too (the `shrm ibl` job of these options, verify 0).
  bool ibl = false;
  std::string ibl_preset = ibl::RoughnessPresetName(ibl::RoughnessPreset::kFilament);
  int ibl_size = jobs::kDefaultIblFaceSize;
  std::string ibl_format = jobs::IblFormatName(jobs::IblFormat::kRgba16f);
  std::string ibl_containers = jobs::IblContainerName(jobs::IblContainer::kKtx2);
  std::string output;  // folder
  int threads = 0;
  bool json = false;
  std::string server;
};

// The prefilter job each frame is (its file attributes are that job's), and its IBL job with
// --ibl (the files of its split-sum set are that job's).
struct FrameJob {
  jobs::PrefilterJob job;
  std::string path;
  jobs::IblJob ibl;
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
  if (a.brdf.empty() && !a.ibl) {
    return absl::InvalidArgumentError("give --brdf (the SHRM of each frame), --ibl, or both");
  }
  if (a.brdf.empty() && a.ktx2) {
    return absl::InvalidArgumentError("--ktx2 needs --brdf: it is the SHRM's container");
  }
  if (a.brdf.empty() && !a.view.empty()) {
    return absl::InvalidArgumentError("--view needs --brdf: the view map is the SHRM's (eq. 5.35)");
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
      FrameJob f{base, path, {}};
      f.job.env.files = {path};
      frames.push_back(std::move(f));
    }
  } else {
    for (int k = 0; k < a.turntable; ++k) {
      FrameJob f{base, a.env, {}};
      f.job.env.files = {a.env};
      f.job.env.rotate_ypr_deg = std::array<double, 3>{360.0 * k / a.turntable, 0, 0};
      frames.push_back(std::move(f));
    }
  }
  jobs::IblJob ibl;
  ibl.verify = 0;
  if (a.ibl) {
    SHRM_ASSIGN_OR_RETURN(ibl.preset, ibl::ParseRoughnessPreset(a.ibl_preset));
    ibl.face_size = a.ibl_size;
    SHRM_ASSIGN_OR_RETURN(ibl.format, jobs::ParseIblFormat(a.ibl_format));
    SHRM_ASSIGN_OR_RETURN(ibl.containers, jobs::ParseIblContainers(a.ibl_containers));
  }
  for (FrameJob& f : frames) {
    if (!a.brdf.empty()) SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(f.job));
    if (!a.ibl) continue;
    f.ibl = ibl;
    f.ibl.env = f.job.env;
    SHRM_RETURN_IF_ERROR(jobs::ValidateIblJobNamingOptions(
        f.ibl, [](std::string_view option) { return "--ibl-" + std::string(option); }));
  }
  return frames;
}

std::string FramePath(const std::string& folder, int index, const char* suffix) {
  return absl::StrFormat("%s/frame_%04d.%s", folder, index, suffix);
}

// The files of one split-sum set into `folder` (created; each file through a temporary, all
// renamed once every one is written, as `shrm ibl` does).
absl::Status WriteFolder(const std::string& folder, const std::vector<jobs::IblFile>& files) {
  for (const jobs::IblFile& f : files) {  // (a server's names too)
    if (f.name.empty() || f.name == "." || f.name == ".." ||
        f.name.find('/') != std::string::npos) {
      return absl::DataLossError(absl::StrCat("a split-sum file named '", f.name, "'"));
    }
  }
  std::error_code ec;
  std::filesystem::create_directories(folder, ec);
  if (ec) {
    return absl::InvalidArgumentError(
        absl::StrCat("--output: cannot create folder ", folder, ": ", ec.message()));
  }
  OutputTransaction tx;
  for (const jobs::IblFile& f : files) {
    SHRM_RETURN_IF_ERROR(WriteFileAtomically(tx.Temp(folder + "/" + f.name), f.bytes));
  }
  return tx.Commit();
}

std::string StageText(const LiveFrame& f) {
  std::string s;
  for (const StageTiming& t : f.result.timings)
    absl::StrAppendFormat(&s, " %s %.1f", t.stage, t.ms);
  return s;
}

// What one frame's summary says, from a local frame or a server's.
struct FrameFigures {
  int f_b = 0, p_b = 0;
  double decode_ms = 0, compute_ms = 0, write_ms = 0;
  std::string stages;  // " brdf 0.1 lighting 2.0 ..."
  std::string view_path;
  std::string ibl_path;  // the split-sum set's folder (--ibl)
};

void ReportFrame(const LiveArgs& a, size_t k, const FrameJob& f, const std::string& shrm_path,
                 const FrameFigures& fig, nlohmann::json* report) {
  nlohmann::json j = {{"frame", k},
                      {"source", f.path},
                      {"output", shrm_path},
                      {"F_B", fig.f_b},
                      {"P_B", fig.p_b},
                      {"decode_ms", fig.decode_ms},
                      {"compute_ms", fig.compute_ms},
                      {"write_ms", fig.write_ms}};
  if (f.job.env.rotate_ypr_deg) j["rotate_ypr_deg"] = *f.job.env.rotate_ypr_deg;
  if (!fig.view_path.empty()) j["view_map"] = fig.view_path;
  if (!fig.ibl_path.empty()) j["ibl"] = fig.ibl_path;
  if (shrm_path.empty()) j.erase("output");
  report->push_back(j);
  if (!a.json) {
    std::string outputs = shrm_path;
    if (!shrm_path.empty())
      absl::StrAppendFormat(&outputs, ", (F_B, P_B) = (%d, %d)", fig.f_b, fig.p_b);
    if (!fig.ibl_path.empty()) {
      absl::StrAppend(&outputs, outputs.empty() ? "" : " and ", fig.ibl_path, "/");
    }
    std::printf("frame %zu: %s -> %s, %.1f ms (decode %.1f;%s; write %.1f)\n", k, f.path.c_str(),
                outputs.c_str(), fig.decode_ms + fig.compute_ms + fig.write_ms, fig.decode_ms,
                fig.stages.c_str(), fig.write_ms);
  }
}

void PrintTotal(const LiveArgs& a, const nlohmann::json& report, double seconds, uint64_t dropped,
                const std::string& where) {
  const double fps = static_cast<double>(report.size()) / seconds;
  if (a.json) {
    std::printf("%s\n", nlohmann::json({{"frames", report},
                                        {"seconds", seconds},
                                        {"frames_per_second", fps},
                                        {"dropped", dropped}})
                            .dump(2)
                            .c_str());
  } else {
    std::printf("%zu frames in %.2f s: %.1f frames/s (%s)\n", report.size(), seconds, fps,
                where.c_str());
  }
}

// --server: the maps uploaded (each once), one Live call; each frame waited for before the next
// state is sent, so none is dropped. The files are the embedded run's.
absl::Status RunLiveRemote(const LiveArgs& a, const std::vector<FrameJob>& frames) {
#if !SHRM_CLI_HAS_CLIENT
  return RunWithClient();
#else
  std::optional<Vec3> view;
  if (!a.view.empty()) {
    SHRM_ASSIGN_OR_RETURN(view, ParseDirection(a.view, "--view"));
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> client, ConnectServer(a.server));
  std::map<std::string, std::string> sha_of;
  for (const FrameJob& f : frames) {
    if (sha_of.count(f.path)) continue;
    SHRM_ASSIGN_OR_RETURN(sha_of[f.path], client->UploadIfMissing(f.path));
  }
  std::error_code ec;
  std::filesystem::create_directories(a.output, ec);
  SHRM_RETURN_IF_ERROR(CheckOutputPath(FramePath(a.output, 0, "shrm.exr"), "--output"));
  const jobs::PrefilterJob& job = frames.front().job;
  v1::LiveOpen open;
  if (job.orders) {
    open.mutable_orders()->set_f(job.orders->f);
    open.mutable_orders()->set_p(job.orders->p);
  } else {
    open.set_epsilon(job.epsilon);
  }
  open.set_kind(job.kind == ShrmKind::kLocal ? v1::SHRM_KIND_LOCAL : v1::SHRM_KIND_GLOBAL);
  open.set_face_size(job.face_size);
  open.set_shrm_ktx2(a.ktx2);
  if (a.ibl) {
    // The frames' IBL job without its environment (the session's lighting) and check.
    *open.mutable_ibl() = wire::EncodeIblRequest(frames.front().ibl, v1::Environment());
    open.mutable_ibl()->clear_environment();
    open.mutable_ibl()->clear_verify();
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::LiveCall> call, client->OpenLive(open));
  // The server's errors name the maps by their blobs: by their files here.
  const std::vector<std::pair<std::string, std::string>> uploaded(sha_of.begin(), sha_of.end());
  const auto named = [&](const absl::Status& s) {
    return absl::Status(s.code(), client::NameUploadedFiles(std::string(s.message()), uploaded));
  };
  auto ended = [&](const char* what) {
    const absl::Status s = call->Finish();
    return s.ok() ? absl::DataLossError(absl::StrCat("the live call ended ", what)) : named(s);
  };
  uint64_t request = 0;
  if (!a.brdf.empty()) {
    v1::LiveRequest brdf;
    brdf.set_brdf(a.brdf);
    if (!call->Send(brdf)) return ended("before the BRDF was sent");
    ++request;
  }
  if (view) {
    v1::LiveRequest r;
    r.mutable_view()->mutable_direction()->set_x(view->x);
    r.mutable_view()->mutable_direction()->set_y(view->y);
    r.mutable_view()->mutable_direction()->set_z(view->z);
    if (!call->Send(r)) return ended("before the view was sent");
    ++request;
  }
  const auto start = std::chrono::steady_clock::now();
  nlohmann::json report = nlohmann::json::array();
  uint64_t dropped = 0;
  for (size_t k = 0; k < frames.size(); ++k) {
    const FrameJob& f = frames[k];
    v1::LiveRequest r;
    if (k == 0 || f.path != frames[k - 1].path) {
      SHRM_RETURN_IF_ERROR(
          wire::EncodeEnvironment(f.job.env, {sha_of[f.path]}, r.mutable_environment()));
    } else {
      const std::array<double, 3> ypr = f.job.env.rotate_ypr_deg.value_or(std::array<double, 3>{});
      r.mutable_rotation()->set_yaw_deg(ypr[0]);
      r.mutable_rotation()->set_pitch_deg(ypr[1]);
      r.mutable_rotation()->set_roll_deg(ypr[2]);
    }
    if (!call->Send(r)) return ended("while sending a frame's state");
    ++request;
    std::optional<client::LiveFrameOutcome> frame;
    do {
      absl::StatusOr<std::optional<client::LiveFrameOutcome>> next = call->Next();
      if (!next.ok()) return named(next.status());
      frame = *std::move(next);
      if (!frame) return ended(absl::StrCat("before the frame of ", f.path).c_str());
    } while (frame->update < request);
    const auto write_start = std::chrono::steady_clock::now();
    std::string shrm_path;
    if (!a.brdf.empty()) {
      shrm_path = FramePath(a.output, static_cast<int>(k), a.ktx2 ? "shrm.ktx2" : "shrm.exr");
      SHRM_RETURN_IF_ERROR(WriteFileAtomically(shrm_path, frame->shrm_file));
    }
    FrameFigures fig;
    if (a.ibl) {
      if (frame->ibl_files.empty()) return ended("with a frame without its split-sum set");
      std::vector<jobs::IblFile> files;
      for (client::ReceivedFile& received : frame->ibl_files) {
        files.push_back({received.name, std::move(received.bytes), "", ""});
      }
      fig.ibl_path = FramePath(a.output, static_cast<int>(k), "ibl");
      SHRM_RETURN_IF_ERROR(WriteFolder(fig.ibl_path, files));
    }
    if (view && !a.brdf.empty()) {
      fig.view_path = FramePath(a.output, static_cast<int>(k), "view.exr");
      SHRM_RETURN_IF_ERROR(WriteFileAtomically(fig.view_path, frame->view_file));
    }
    fig.f_b = frame->f_b;
    fig.p_b = frame->p_b;
    for (const v1::StageTiming& t : frame->timings) {
      absl::StrAppendFormat(&fig.stages, " %s %.1f", t.stage(), t.ms());
      fig.compute_ms += t.ms();
    }
    fig.write_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - write_start)
            .count();
    dropped = frame->dropped;
    ReportFrame(a, k, f, shrm_path, fig, &report);
  }
  call->CloseSending();
  while (true) {
    SHRM_ASSIGN_OR_RETURN(std::optional<client::LiveFrameOutcome> rest, call->Next());
    if (!rest) break;
  }
  SHRM_RETURN_IF_ERROR(call->Finish());
  PrintTotal(a, report,
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
             dropped, absl::StrCat("server ", a.server));
  return absl::OkStatus();
#endif  // SHRM_CLI_HAS_CLIENT
}

absl::Status RunLive(const LiveArgs& a) {
  SHRM_ASSIGN_OR_RETURN(const std::vector<FrameJob> frames, FrameJobs(a));
  if (!a.server.empty()) return RunLiveRemote(a, frames);
  std::optional<Vec3> view;
  if (!a.view.empty()) {
    SHRM_ASSIGN_OR_RETURN(view, ParseDirection(a.view, "--view"));
  }
  // Everything checked before the first frame: the BRDF, every map's header, the folder.
  std::shared_ptr<const Brdf> brdf;
  if (!a.brdf.empty()) {
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> parsed, ParseBrdfSpec(a.brdf));
    brdf = std::move(parsed);
  }
  std::set<std::string> probed;
  for (const FrameJob& f : frames) {
    if (probed.insert(f.path).second) SHRM_RETURN_IF_ERROR(ProbeImage(f.path).status());
  }
  std::error_code ec;
  std::filesystem::create_directories(a.output, ec);  // CheckOutputPath names what fails
  SHRM_RETURN_IF_ERROR(CheckOutputPath(FramePath(a.output, 0, "shrm.exr"), "--output"));

  const int threads = ResolveThreads(a.threads);
  PrefilterOptions options = jobs::CorePrefilterOptions(frames.front().job, threads);
  std::optional<ibl::SplitSumSetOptions> split_sum;
  if (a.ibl) {
    SHRM_ASSIGN_OR_RETURN(split_sum, jobs::IblSplitSumSetOptions(frames.front().ibl));
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<LiveSession> session,
                        LiveSession::Create(options, nullptr, split_sum));
  if (brdf) session->SetBrdf(brdf);
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
    if (brdf) d.provenance.brdf_spec = brdf->spec();
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
    const uint64_t update = session->SetMap(current.map, jobs::EnvironmentRotation(f.job.env));
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
    std::string shrm_path, view_path, ibl_path;
    if (frame->has_shrm) {
      const auto attributes =
          jobs::PrefilterFileAttributes(f.job, current.provenance, frame->result);
      if (a.ktx2) {
        shrm_path = FramePath(a.output, static_cast<int>(k), "shrm.ktx2");
        SHRM_ASSIGN_OR_RETURN(const std::string bytes,
                              EncodeShrmKtx2(shrm_path, frame->result.cube, attributes));
        SHRM_RETURN_IF_ERROR(WriteFileAtomically(shrm_path, bytes));
      } else {
        shrm_path = FramePath(a.output, static_cast<int>(k), "shrm.exr");
        SHRM_RETURN_IF_ERROR(WriteShrmFile(shrm_path, frame->result.cube, attributes));
      }
      if (view) {
        view_path = FramePath(a.output, static_cast<int>(k), "view.exr");
        SHRM_RETURN_IF_ERROR(WriteRadianceCross(view_path, frame->view_map));
      }
    }
    if (a.ibl) {
      ibl_path = FramePath(a.output, static_cast<int>(k), "ibl");
      SHRM_ASSIGN_OR_RETURN(
          const jobs::IblRun run,
          jobs::IblRunFromSet(f.ibl, *frame->split_sum, current.provenance.source,
                              current.map->layout(), current.map->replaced_non_finite(), threads));
      SHRM_ASSIGN_OR_RETURN(const std::vector<jobs::IblFile> files,
                            jobs::EncodeIblOutputs(f.ibl, run));
      SHRM_RETURN_IF_ERROR(WriteFolder(ibl_path, files));
    }
    const double write_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - write_start)
            .count();
    FrameFigures fig;
    fig.f_b = frame->result.analysis.f_b;
    fig.p_b = frame->result.analysis.p_b;
    fig.decode_ms = current.ms;
    fig.compute_ms = frame->compute_ms;
    fig.write_ms = write_ms;
    fig.stages = StageText(*frame);
    fig.view_path = view_path;
    fig.ibl_path = ibl_path;
    ReportFrame(a, k, f, shrm_path, fig, &report);
    if (next) current = *std::move(next);
  }
  PrintTotal(
      a, report, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
      session->Stats().dropped,
      absl::StrCat("decode, compute and write; ", threads, threads == 1 ? " thread" : " threads"));
  return absl::OkStatus();
}

}  // namespace

void DefineLive(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<LiveArgs>();
  sub->add_option("--sequence", args->sequence, "maps, one per frame (e.g. frames/*.exr)")
      ->expected(1, -1);
  sub->add_option("--env", args->env, "one map turned about the vertical axis (with --turntable)");
  sub->add_option("--turntable", args->turntable,
                  "frames per turn of --env (frame k rotated by 360 k / N degrees of yaw)")
      ->check(jobs::InRange(1, kMaxTurntableFrames));
  sub->add_option("--brdf", args->brdf,
                  "BRDF spec of each frame's SHRM, e.g. microfacet:sigma=0.2 (docs/brdf.md); "
                  "optional with --ibl");
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
      ->check(jobs::InRange(0, jobs::kMaxFaceSize));
  sub->add_option("--view", args->view,
                  "also write each frame's reflection map for this view (eq. 5.35), x,y,z")
      ->check(jobs::kDirection);
  sub->add_flag("--ktx2", args->ktx2,
                "each frame's SHRM as frame_NNNN.shrm.ktx2 (the KTX2 container shrm prefilter "
                "--ktx2 writes: coefficient planes for the shader library) instead of the EXR");
  sub->add_flag("--ibl", args->ibl,
                "also each frame's split-sum IBL set: the folder frame_NNNN.ibl that "
                "`shrm ibl --verify 0` writes for the frame");
  sub->add_option("--ibl-preset", args->ibl_preset,
                  "--ibl: roughness per mip (as shrm ibl --preset)")
      ->capture_default_str()
      ->check(CLI::IsMember({"filament", "gltf", "babylon"}));
  sub->add_option("--ibl-size", args->ibl_size, "--ibl: base face size (as shrm ibl --size)")
      ->capture_default_str()
      ->check(jobs::kPositive);
  sub->add_option("--ibl-format", args->ibl_format, "--ibl: storage (as shrm ibl --format)")
      ->capture_default_str()
      ->check(CLI::IsMember({"rgba16f", "rgba32f", "r11g11b10f", "rgb9e5"}));
  sub->add_option("--ibl-containers", args->ibl_containers,
                  "--ibl: containers (as shrm ibl --containers)")
      ->capture_default_str();
  sub->add_option("-o,--output", args->output,
                  "folder for frame_NNNN.shrm.exr (frame_NNNN.view.exr with --view, "
                  "frame_NNNN.ibl/ with --ibl)")
      ->required();
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(jobs::kNonNegative);
  sub->add_flag("--json", args->json, "print the frames' report as JSON on stdout");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunLive(*args); });
}

}  // namespace shrm::cli
