#include "server/shrm_service.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_projection.h"
#include "core/envmap/envmap.h"
#include "core/export/shrm_ktx2.h"
#include "core/io/image.h"
#include "core/io/sha256.h"
#include "core/live/live_session.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_reference.h"
#include "jobs/analyze_job.h"
#include "jobs/ibl_job.h"
#include "jobs/ibl_outputs.h"
#include "jobs/memory_estimate.h"
#include "jobs/point_jobs.h"
#include "jobs/prefilter_job.h"
#include "jobs/report.h"
#include "jobs/report_visuals.h"
#include "proto/job_codec.h"
#include "proto/status_details.h"
#include "server/metrics.h"
#include "server/request_inputs.h"
#include "server/request_log.h"

namespace shrm::server {
namespace {

namespace v1 = ::shrm::v1;

// Output chunks: at most 1 MiB of file bytes per message (well under gRPC's 4 MiB default).
constexpr size_t kFileChunkBytes = 1 << 20;
// Retry hint for RESOURCE_EXHAUSTED (all job slots busy): about one short job.
constexpr absl::Duration kRetryAfter = absl::Milliseconds(1000);
// The largest cube one job may allocate (6 S^2 (P + 1)^2 RGB values: 2^28 doubles = 2 GiB).
constexpr double kMaxCubeValues = 1 << 28;
// Progress fractions: the stages brdf, decode, lighting, analysis, synthesis, write.
constexpr double kStages = 6;

absl::Status CheckContext(grpc::ServerContext* context) {
  if (!context->IsCancelled()) return absl::OkStatus();
  if (context->deadline() <= std::chrono::system_clock::now()) {
    return absl::DeadlineExceededError("deadline exceeded; the job was stopped between stages");
  }
  return absl::CancelledError("cancelled by the client; the job was stopped between stages");
}

// CheckContext before `stage`; a stop is counted in shrm_jobs_abandoned_total.
absl::Status CheckStage(grpc::ServerContext* context, std::string_view stage) {
  absl::Status s = CheckContext(context);
  if (!s.ok()) {
    Metrics::Global().RecordAbandoned(absl::IsDeadlineExceeded(s) ? "deadline" : "cancelled",
                                      std::string(stage));
  }
  return s;
}

// The analysis fields shared by PrefilterReport and AnalyzeResult.
template <typename Message>
void FillAnalysis(const ShrmAnalysis& an, Message* m) {
  m->set_f_light(an.f_light);
  m->set_f_brdf(an.f_brdf);
  m->set_p_brdf(an.p_brdf);
  m->set_f_b(an.f_b);
  m->set_p_b(an.p_b);
  m->set_eps_light(an.eps_light);
  m->set_eps_brdf(an.eps_brdf);
  m->set_eps_estimate(an.eps_estimate);
  m->set_eps_bound(an.eps_bound);
  m->set_suggested_face_size(an.suggested_face_size);
  m->set_suggested_view_size(an.suggested_view_size);
}

void RecordCaches(bool lighting_hit, bool brdf_hit, v1::CacheReport* report) {
  report->set_lighting_hit(lighting_hit);
  report->set_brdf_hit(brdf_hit);
  Metrics::Global().RecordCache("lighting", lighting_hit);
  Metrics::Global().RecordCache("brdf", brdf_hit);
}

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// A pinned environment, decoded between stage checks (before decoding and before `next_stage`);
// errors name blobs, not spool files.
struct DecodedEnv {
  PinnedEnv pinned;
  EnvMap map;
};
absl::StatusOr<DecodedEnv> PinAndDecode(
    grpc::ServerContext* context, const v1::Environment& env, BlobStore* blobs, DecodeGuard* guard,
    std::string_view next_stage,
    const std::function<absl::Status(uint64_t bytes, std::string_view what)>& reserve) {
  SHRM_ASSIGN_OR_RETURN(wire::WireEnvironment wire_env, wire::DecodeEnvironment(env));
  SHRM_ASSIGN_OR_RETURN(PinnedEnv pinned, PinEnvironment(wire_env, blobs, guard));
  SHRM_ASSIGN_OR_RETURN(const uint64_t map_bytes, MapDecodeBytes(pinned));
  SHRM_RETURN_IF_ERROR(reserve(map_bytes, "decoding the map"));
  SHRM_RETURN_IF_ERROR(CheckStage(context, "decode"));
  absl::StatusOr<EnvMap> map = EnvMap::Load(pinned.options);
  if (!map.ok()) return HideSpoolPaths(map.status(), &pinned);
  SHRM_RETURN_IF_ERROR(CheckStage(context, next_stage));
  return DecodedEnv{std::move(pinned), *std::move(map)};
}

// A request direction as a unit vector (jobs::UnitDirection); InvalidArgument when missing.
absl::StatusOr<Vec3> RequestDirection(bool present, const v1::Direction& d, const char* name) {
  if (!present) return absl::InvalidArgumentError(absl::StrCat(name, ": required"));
  return jobs::UnitDirection(Vec3{d.x(), d.y(), d.z()}, name);
}

// Streams `file` in chunks of at most kFileChunkBytes, the last with the file's SHA-256;
// `chunk_of` gives the FileChunk of a new event (and fills the event's other fields).
// `watch` gets the progress of every chunk written.
template <typename Event, typename ChunkOf>
absl::Status StreamFile(std::string_view file, grpc::internal::WriterInterface<Event>* writer,
                        RequestLog* log, IdleWatchdog::Call* watch, const ChunkOf& chunk_of) {
  Sha256Stream sha;  // hashed chunk by chunk, while the client receives the previous one
  size_t offset = 0;
  do {
    const size_t n = std::min(kFileChunkBytes, file.size() - offset);
    Event ev;
    v1::FileChunk* chunk = chunk_of(&ev);
    chunk->set_offset(offset);
    chunk->set_total_size(file.size());
    chunk->set_data(file.data() + offset, n);
    sha.Update(file.substr(offset, n));
    offset += n;
    if (offset == file.size()) {
      chunk->set_last(true);
      chunk->set_sha256(sha.Hex());
    }
    log->AddBytesOut(n);
    if (!writer->Write(ev)) {
      return absl::UnavailableError("client went away during the file transfer");
    }
    watch->Progress();
  } while (offset < file.size());
  return absl::OkStatus();
}

// Writes one progress event.
template <typename Event>
void WriteProgress(grpc::ServerWriter<Event>* writer, std::string_view stage, double fraction) {
  Event ev;
  ev.mutable_progress()->set_stage(std::string(stage));
  ev.mutable_progress()->set_fraction(fraction);
  writer->Write(ev);
}

// Writes an event that must arrive (the report); the context's status when the client is gone.
template <typename Event>
absl::Status WriteOrFail(grpc::ServerContext* context, grpc::ServerWriter<Event>* writer,
                         const Event& ev, RequestLog* log) {
  log->AddBytesOut(ev.ByteSizeLong());
  if (writer->Write(ev)) return absl::OkStatus();
  absl::Status s = CheckContext(context);
  return s.ok() ? absl::UnavailableError("client went away") : s;
}

}  // namespace

// A Prefilter call between its stages: the decoded job and its resolved inputs, then the result.
struct ShrmServiceImpl::PrefilterCall {
  JobSlot* slot = nullptr;
  wire::WirePrefilter request;
  RequestBrdf brdf;
  std::optional<PinnedEnv> env;
  CachedPrefilterResult result;
  jobs::PrefilterProvenance provenance;
  std::string file;  // the SHRM file (when asked for)
  double write_ms = 0;
  std::string visuals;  // the visual report's data (JSON, when asked for)
  double visuals_ms = 0;
};

// An Ibl call between its stages: the decoded job and its pinned map, then the files.
struct ShrmServiceImpl::IblCall {
  JobSlot* slot = nullptr;
  wire::WireIbl request;
  std::optional<PinnedEnv> env;
  std::string source_sha256;
  nlohmann::json report;
  std::vector<StageTiming> timings;
  std::vector<jobs::IblFile> files;
};

// A held job slot; releases it on destruction.
// A held job slot and the memory its stages reserved; releases both on destruction.
class ShrmServiceImpl::JobSlot {
 public:
  JobSlot(std::atomic<int>* running, MemoryBudget* memory) : running_(running), memory_(memory) {
    Metrics::Global().JobStarted();
  }
  ~JobSlot() {
    running_->fetch_sub(1);
    Metrics::Global().JobFinished();
  }
  // Reserves a stage's estimated peak (jobs/memory_estimate.h) before it runs; the first
  // reservation adds the job's base (jobs::kJobBaseBytes).
  absl::Status Reserve(uint64_t bytes, std::string_view what) {
    if (memory_.bytes() == 0) bytes += jobs::kJobBaseBytes;
    return memory_.Add(bytes, what);
  }

 private:
  std::atomic<int>* running_;
  MemoryBudget::Reservation memory_;
};

absl::StatusOr<std::unique_ptr<ShrmServiceImpl>> ShrmServiceImpl::Create(
    const ServiceOptions& options) {
  if (options.max_jobs < 1 || options.job_threads < 1) {
    return absl::InvalidArgumentError("max jobs and job threads must be >= 1");
  }
  if (options.spool_dir.empty()) return absl::InvalidArgumentError("a spool directory is required");
  uint64_t job_memory = 0;
  if (options.memory_bytes > 0) {
    // What jobs may hold: the budget less what the daemon holds now, what its caches may hold and
    // the reserve for calls in flight.
    const uint64_t rss = ProcessRssBytes();
    const uint64_t fixed = rss + options.cache_bytes + kServiceReserveBytes;
    if (options.memory_bytes <= fixed ||
        options.memory_bytes - fixed < jobs::kJobBaseBytes + jobs::MapBytes(1 << 20)) {
      return absl::InvalidArgumentError(
          absl::StrCat(options.memory_text, " (", options.memory_bytes >> 20,
                       " MiB) leaves too little for jobs: the daemon holds ", rss >> 20,
                       " MiB at start, the caches up to ", options.cache_bytes >> 20,
                       " MiB (--cache-mib), calls ", kServiceReserveBytes >> 20,
                       " MiB, and a job on a 1-Mpixel map needs ",
                       (jobs::kJobBaseBytes + jobs::MapBytes(1 << 20)) >> 20, " MiB"));
    }
    job_memory = options.memory_bytes - fixed;
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<BlobStore> blobs,
                        BlobStore::Open(options.spool_dir, options.spool_bytes));
  return std::unique_ptr<ShrmServiceImpl>(
      new ShrmServiceImpl(options, std::move(blobs), job_memory));
}

ShrmServiceImpl::ShrmServiceImpl(const ServiceOptions& options, std::unique_ptr<BlobStore> blobs,
                                 uint64_t job_memory_bytes)
    : options_(options),
      blobs_(std::move(blobs)),
      caches_(options.cache_bytes),
      decode_guard_(options.decoder_sandbox, options.decode_limits),
      idle_(options.idle_timeout),
      memory_(std::make_unique<MemoryBudget>(job_memory_bytes, options.memory_text)) {}

absl::StatusOr<std::unique_ptr<ShrmServiceImpl::JobSlot>> ShrmServiceImpl::Admit() {
  if (draining_) {
    return wire::WithErrorReason(
        absl::UnavailableError("server is shutting down; retry on another server"),
        wire::kReasonDraining);
  }
  int running = running_jobs_.load();
  while (true) {
    if (running >= options_.max_jobs) {
      return wire::WithRetryDelay(
          wire::WithErrorReason(absl::ResourceExhaustedError(absl::StrCat(
                                    "server busy: ", running, " of ", options_.max_jobs,
                                    " job slots in use; retry after about ",
                                    absl::ToInt64Milliseconds(kRetryAfter), " ms")),
                                wire::kReasonServerBusy),
          kRetryAfter);
    }
    if (running_jobs_.compare_exchange_weak(running, running + 1)) break;
  }
  return std::make_unique<JobSlot>(&running_jobs_, memory_.get());
}
absl::Status ShrmServiceImpl::WhileWatched(
    grpc::ServerContext* context, std::string_view what,
    const std::function<absl::Status(IdleWatchdog::Call*)>& transfer) {
  const std::unique_ptr<IdleWatchdog::Call> watch = idle_.Watch(context);
  const absl::Status s = transfer(watch.get());
  if (s.ok() || !watch->ended_idle()) return s;
  return absl::DeadlineExceededError(absl::StrCat("the client made no progress ", std::string(what),
                                                  " for ", absl::FormatDuration(idle_.timeout()),
                                                  " (--idle-timeout); the call was ended"));
}

void ShrmServiceImpl::TestStageHooks(std::string_view stage) const {
  if (options_.test_stage_delay > absl::ZeroDuration()) absl::SleepFor(options_.test_stage_delay);
  if (options_.test_stage_hook) options_.test_stage_hook(stage);
}

void ShrmServiceImpl::HoldUntilDrain(grpc::ServerContext* context) const {
  // A bound, so that a test whose SIGTERM never comes fails instead of hanging: far beyond the
  // few seconds deploy_test takes between the job's first progress event and its SIGTERM.
  constexpr absl::Duration kTestHoldLimit = absl::Seconds(120);
  const absl::Time until = absl::Now() + kTestHoldLimit;
  while (!draining_ && !context->IsCancelled() && absl::Now() < until) {
    absl::SleepFor(absl::Milliseconds(10));
  }
}

grpc::Status ShrmServiceImpl::HasBlob(grpc::ServerContext* context,
                                      const v1::HasBlobRequest* request,
                                      v1::HasBlobResponse* response) {
  RequestLog log(context, "HasBlob");
  if (!IsSha256Hex(request->sha256())) {
    return log.Finish(
        wire::ToGrpcStatus(absl::InvalidArgumentError("sha256: expected 64 lowercase hex digits")));
  }
  const std::optional<uint64_t> size = blobs_->Size(request->sha256());
  response->set_present(size.has_value());
  response->set_size(size.value_or(0));
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::UploadBlob(grpc::ServerContext* context,
                                         grpc::ServerReader<v1::UploadBlobChunk>* reader,
                                         v1::UploadBlobResponse* response) {
  RequestLog log(context, "UploadBlob");
  const std::unique_ptr<IdleWatchdog::Call> watch = idle_.Watch(context);
  auto fail = [&](const absl::Status& s) {
    if (!watch->ended_idle()) return log.Finish(wire::ToGrpcStatus(s));
    return log.Finish(wire::ToGrpcStatus(absl::DeadlineExceededError(
        absl::StrCat("upload: no data for ", absl::FormatDuration(idle_.timeout()),
                     " (--idle-timeout); the call was ended and nothing was kept"))));
  };
  v1::UploadBlobChunk chunk;
  if (!reader->Read(&chunk)) {
    return fail(absl::InvalidArgumentError("upload: no chunks received"));
  }
  const std::string expected = chunk.sha256();
  const uint64_t declared = chunk.total_size();
  if (!IsSha256Hex(expected)) {
    return fail(absl::InvalidArgumentError(
        "upload: the first chunk must carry sha256 (64 lowercase hex digits)"));
  }
  log.Set("sha256", expected);
  if (declared > options_.max_blob_bytes) {
    return fail(absl::ResourceExhaustedError(absl::StrCat("upload: declared size ", declared,
                                                          " bytes exceeds the server's limit of ",
                                                          options_.max_blob_bytes, " bytes")));
  }
  absl::StatusOr<std::unique_ptr<BlobStore::Upload>> up = blobs_->BeginUpload();
  if (!up.ok()) return fail(up.status());
  do {
    watch->Progress();  // a chunk arrived
    if (chunk.data().size() + (*up)->size() > options_.max_blob_bytes) {
      return fail(absl::ResourceExhaustedError(absl::StrCat(
          "upload: more than the server's limit of ", options_.max_blob_bytes, " bytes received")));
    }
    log.AddBytesIn(chunk.data().size());
    if (absl::Status s = (*up)->Append(chunk.data()); !s.ok()) return fail(s);
  } while (reader->Read(&chunk));
  if (context->IsCancelled()) return fail(absl::CancelledError("upload cancelled"));
  if ((*up)->size() != declared) {
    return fail(absl::InvalidArgumentError(absl::StrCat(
        "upload: declared total_size ", declared, " but received ", (*up)->size(), " bytes")));
  }
  absl::StatusOr<std::string> hash = blobs_->Commit(up->get(), expected);
  if (!hash.ok()) return fail(hash.status());
  response->set_sha256(*hash);
  response->set_size((*up)->size());
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::Prefilter(grpc::ServerContext* context,
                                        const v1::PrefilterRequest* request,
                                        grpc::ServerWriter<v1::PrefilterEvent>* writer) {
  RequestLog log(context, "Prefilter");
  PrefilterCall call;
  auto fail = [&](const absl::Status& s) {
    return log.Finish(wire::ToGrpcStatus(HideSpoolPaths(s, call.env ? &*call.env : nullptr)));
  };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit();
  if (!slot.ok()) return fail(slot.status());
  call.slot = slot->get();
  if (absl::Status s = ParsePrefilterCall(*request, &call); !s.ok()) return fail(s);
  if (absl::Status s = RunPrefilterCall(context, writer, &call, &log); !s.ok()) return fail(s);
  if (absl::Status s = WhileWatched(context, "reading the result",
                                    [&](IdleWatchdog::Call* watch) {
                                      return SendPrefilterResult(context, writer, call, &log,
                                                                 watch);
                                    });
      !s.ok()) {
    return fail(s);
  }
  return log.Finish(grpc::Status::OK);
}

absl::Status ShrmServiceImpl::ParsePrefilterCall(const v1::PrefilterRequest& request,
                                                 PrefilterCall* call) {
  SHRM_ASSIGN_OR_RETURN(call->request, wire::DecodePrefilterRequest(request));
  SHRM_ASSIGN_OR_RETURN(call->brdf, ResolveRequestBrdf(call->request.brdf, blobs_.get()));
  wire::WireEnvironment env{call->request.job.env, call->request.sha256};
  SHRM_ASSIGN_OR_RETURN(call->env, PinEnvironment(env, blobs_.get(), &decode_guard_));
  return absl::OkStatus();
}

absl::Status ShrmServiceImpl::RunPrefilterCall(grpc::ServerContext* context,
                                               grpc::ServerWriter<v1::PrefilterEvent>* writer,
                                               PrefilterCall* call, RequestLog* log) {
  const jobs::PrefilterJob& job = call->request.job;
  CachedPrefilterInput in;
  in.brdf = call->brdf.brdf.get();
  in.env = call->env->options;
  in.env_key = call->env->key;
  in.options = jobs::CorePrefilterOptions(job, options_.job_threads);
  in.max_cube_values = kMaxCubeValues;
  // Memory: the decoded map before decoding, the cube once S_B and P_B are known.
  in.options.admit_cube = [&](int face_size, int p_b) {
    return call->slot->Reserve(
        jobs::ShrmCubeBytes(face_size, p_b),
        absl::StrCat("an SHRM cube of face size ", face_size, " and P_B = ", p_b));
  };
  // Progress events and cancellation checks between stages.
  int stage_index = 0;
  StageHook hook = [&](std::string_view stage) -> absl::Status {
    SHRM_RETURN_IF_ERROR(CheckStage(context, stage));
    if (stage == "decode") {
      SHRM_ASSIGN_OR_RETURN(const uint64_t map_bytes, MapDecodeBytes(*call->env));
      SHRM_RETURN_IF_ERROR(call->slot->Reserve(map_bytes, "decoding the map"));
    } else if (stage == "verify") {
      SHRM_ASSIGN_OR_RETURN(const int64_t pixels, MapPixels(*call->env));
      SHRM_RETURN_IF_ERROR(
          call->slot->Reserve(jobs::ReferenceBytes(pixels), "the job's check (verify)"));
    }
    TestStageHooks(stage);
    if (stage == "write" && !options_.test_hold_brdf.empty() &&
        call->request.brdf.spec == options_.test_hold_brdf) {
      HoldUntilDrain(context);
    }
    WriteProgress(writer, stage, std::min(stage_index++, 5) / kStages);
    return CheckStage(context, stage);
  };
  SHRM_ASSIGN_OR_RETURN(call->result, CachedPrefilter(in, &caches_, hook));
  for (const StageTiming& t : call->result.result.timings) log->AddStage(t.stage, t.ms);
  SHRM_RETURN_IF_ERROR(hook("write"));
  call->provenance = {call->brdf.display_spec, call->env->source, call->result.layout};
  const auto write_start = std::chrono::steady_clock::now();
  if (call->request.want_file) {
    const auto attrs = jobs::PrefilterFileAttributes(job, call->provenance, call->result.result);
    absl::StatusOr<std::string> bytes =
        EncodeShrmFile("the SHRM file", call->result.result.cube, attrs, job.half);
    if (!bytes.ok()) {
      return absl::InternalError(
          absl::StrCat("writing the SHRM file failed: ", bytes.status().message()));
    }
    call->file = std::move(*bytes);
  }
  call->write_ms = MsSince(write_start);
  log->AddStage("write", call->write_ms);
  if (call->request.want_visuals) {
    // The map again (a lighting-cache hit never decoded it), within the job's memory.
    SHRM_RETURN_IF_ERROR(hook("report"));
    const auto start = std::chrono::steady_clock::now();
    SHRM_ASSIGN_OR_RETURN(const uint64_t map_bytes, MapDecodeBytes(*call->env));
    SHRM_RETURN_IF_ERROR(call->slot->Reserve(map_bytes, "decoding the map for the report"));
    SHRM_ASSIGN_OR_RETURN(const EnvMap env, EnvMap::Load(in.env));
    SHRM_ASSIGN_OR_RETURN(const nlohmann::json visuals,
                          jobs::PrefilterVisuals(env, *in.brdf, in.options.rotation,
                                                 call->result.result.cube, options_.job_threads));
    call->visuals = visuals.dump();
    call->visuals_ms = MsSince(start);
    log->AddStage("report", call->visuals_ms);
  }
  return absl::OkStatus();
}

absl::Status ShrmServiceImpl::SendPrefilterResult(grpc::ServerContext* context,
                                                  grpc::ServerWriter<v1::PrefilterEvent>* writer,
                                                  const PrefilterCall& call, RequestLog* log,
                                                  IdleWatchdog::Call* watch) {
  const PrefilterResult& r = call.result.result;
  v1::PrefilterEvent ev;
  v1::PrefilterReport* rep = ev.mutable_report();
  FillAnalysis(r.analysis, rep);
  rep->set_face_size(r.cube.face_size);
  rep->set_brdf(call.provenance.brdf_spec);
  rep->set_layout(EnvLayoutName(call.provenance.layout));
  rep->set_source_sha256(call.provenance.source.sha256);
  for (const StageTiming& t : r.timings) {
    auto* st = rep->add_timings();
    st->set_stage(t.stage);
    st->set_ms(t.ms);
  }
  auto* wt = rep->add_timings();
  wt->set_stage("write");
  wt->set_ms(call.write_ms);
  RecordCaches(call.result.lighting_hit, call.result.brdf_hit, rep->mutable_cache());
  log->Set("lighting_cache", call.result.lighting_hit ? "hit" : "miss");
  log->Set("brdf_cache", call.result.brdf_hit ? "hit" : "miss");
  if (call.request.want_report) {
    nlohmann::json report = jobs::PrefilterReportJson(call.request.job, call.provenance, r);
    nlohmann::json timings = jobs::TimingsJson(r.timings);
    timings["write_ms"] = call.write_ms;
    if (call.request.want_visuals) timings["report_ms"] = call.visuals_ms;
    report["timings"] = timings;
    report["cache"] = {{"lighting", call.result.lighting_hit ? "hit" : "miss"},
                       {"brdf", call.result.brdf_hit ? "hit" : "miss"}};
    rep->set_report_json(report.dump(2));
  }
  if (call.request.want_visuals) rep->set_report_visuals_json(call.visuals);
  SHRM_RETURN_IF_ERROR(WriteOrFail(context, writer, ev, log));
  if (!call.request.want_file) return absl::OkStatus();
  return StreamFile(call.file, writer, log, watch,
                    [](v1::PrefilterEvent* e) { return e->mutable_shrm_file(); });
}

grpc::Status ShrmServiceImpl::Analyze(grpc::ServerContext* context,
                                      const v1::AnalyzeRequest* request,
                                      v1::AnalyzeResponse* response) {
  RequestLog log(context, "Analyze");
  std::optional<PinnedEnv> env;
  auto fail = [&](const absl::Status& s) {
    return log.Finish(wire::ToGrpcStatus(HideSpoolPaths(s, env ? &*env : nullptr)));
  };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit();
  if (!slot.ok()) return fail(slot.status());
  absl::StatusOr<RequestBrdf> brdf = ResolveRequestBrdf(
      {request->brdf(), request->brdf_blob_sha256(), request->brdf_display_spec()}, blobs_.get());
  if (!brdf.ok()) return fail(brdf.status());
  std::vector<double> epsilons(request->epsilon().begin(), request->epsilon().end());
  if (epsilons.empty()) epsilons = jobs::kDefaultAnalyzeEpsilons;
  if (absl::Status s = jobs::ValidateAnalyzeEpsilons(epsilons); !s.ok()) return fail(s);
  response->set_brdf(brdf->display_spec);
  if (!request->has_environment()) {
    // BRDF only: (F_rho, P_rho) per epsilon (as `shrm analyze --brdf`).
    for (double e : epsilons) {
      if (absl::Status s = CheckContext(context); !s.ok()) return fail(s);
      absl::StatusOr<BrdfOrders> o = SelectBrdfOrders(*brdf->brdf, e);
      if (!o.ok()) return fail(o.status());
      v1::AnalyzeResult* r = response->add_results();
      r->set_epsilon(e);
      r->set_f_light(-1);
      r->set_f_brdf(o->F);
      r->set_p_brdf(o->P);
      r->set_f_b(o->F);
      r->set_p_b(o->P);
      r->set_eps_brdf(1 - o->captured);
    }
    return log.Finish(grpc::Status::OK);
  }
  absl::StatusOr<wire::WireEnvironment> wire_env = wire::DecodeEnvironment(request->environment());
  if (!wire_env.ok()) return fail(wire_env.status());
  absl::StatusOr<PinnedEnv> pinned = PinEnvironment(*wire_env, blobs_.get(), &decode_guard_);
  if (!pinned.ok()) return fail(pinned.status());
  env = std::move(*pinned);
  bool map_reserved = false;  // the map is decoded at most once at a time
  for (double e : epsilons) {
    jobs::PrefilterJob job;
    job.env = env->spec;
    jobs::UseEpsilonRule(&job, e);  // the analysis is the paper's (eq. 5.15-5.19)
    CachedPrefilterInput in;
    in.brdf = brdf->brdf.get();
    in.env = env->options;
    in.env_key = env->key;
    in.options = jobs::CorePrefilterOptions(job, options_.job_threads);
    in.options.synthesize = false;
    StageHook hook = [&](std::string_view stage) -> absl::Status {
      if (stage == "decode" && !map_reserved) {
        SHRM_ASSIGN_OR_RETURN(const uint64_t map_bytes, MapDecodeBytes(*env));
        SHRM_RETURN_IF_ERROR((*slot)->Reserve(map_bytes, "decoding the map"));
        map_reserved = true;
      }
      return CheckStage(context, stage);
    };
    absl::StatusOr<CachedPrefilterResult> res = CachedPrefilter(in, &caches_, hook);
    if (!res.ok()) return fail(res.status());
    v1::AnalyzeResult* r = response->add_results();
    r->set_epsilon(res->result.analysis.epsilon);
    FillAnalysis(res->result.analysis, r);
    nlohmann::json j = jobs::AnalysisJson(res->result.analysis);
    j["timings"] = jobs::TimingsJson(res->result.timings);
    r->set_analysis_json(j.dump(2));
    RecordCaches(res->lighting_hit, res->brdf_hit, response->mutable_cache());
  }
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::ListBrdfModels(grpc::ServerContext* context,
                                             const v1::ListBrdfModelsRequest* /*request*/,
                                             v1::ListBrdfModelsResponse* response) {
  RequestLog log(context, "ListBrdfModels");
  for (const BrdfModelInfo& m : shrm::ListBrdfModels()) {
    v1::BrdfModel* pm = response->add_models();
    pm->set_name(m.name);
    pm->set_syntax(m.syntax);
    pm->set_description(m.description);
    for (const BrdfParamInfo& p : m.params) {
      v1::BrdfParam* pp = pm->add_params();
      pp->set_name(p.name);
      pp->set_default_value(p.default_value);
      pp->set_range(p.range);
      pp->set_description(p.description);
    }
  }
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::Reference(grpc::ServerContext* context,
                                        const v1::ReferenceRequest* request,
                                        v1::ReferenceResponse* response) {
  RequestLog log(context, "Reference");
  auto fail = [&](const absl::Status& s) { return log.Finish(wire::ToGrpcStatus(s)); };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit();
  if (!slot.ok()) return fail(slot.status());
  absl::StatusOr<RequestBrdf> brdf =
      ResolveRequestBrdf({request->brdf(), request->brdf_blob_sha256(), ""}, blobs_.get());
  if (!brdf.ok()) return fail(brdf.status());
  absl::StatusOr<Vec3> index = RequestDirection(request->has_index(), request->index(), "index");
  if (!index.ok()) return fail(index.status());
  absl::StatusOr<Vec3> view = RequestDirection(request->has_view(), request->view(), "view");
  if (!view.ok()) return fail(view.status());
  absl::StatusOr<DecodedEnv> env = PinAndDecode(
      context, request->environment(), blobs_.get(), &decode_guard_, "reference",
      [&](uint64_t bytes, std::string_view what) { return (*slot)->Reserve(bytes, what); });
  if (!env.ok()) return fail(env.status());
  const std::array<double, 3> rgb = BrdfReferenceRadiance(
      env->map.samples(), *brdf->brdf, jobs::EnvironmentRotation(env->pinned.spec), *index, *view);
  for (double c : rgb) response->add_rgb(c);
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::Irradiance(grpc::ServerContext* context,
                                         const v1::IrradianceRequest* request,
                                         v1::IrradianceResponse* response) {
  RequestLog log(context, "Irradiance");
  auto fail = [&](const absl::Status& s) { return log.Finish(wire::ToGrpcStatus(s)); };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit();
  if (!slot.ok()) return fail(slot.status());
  absl::StatusOr<DecodedEnv> env = PinAndDecode(
      context, request->environment(), blobs_.get(), &decode_guard_, "lighting",
      [&](uint64_t bytes, std::string_view what) { return (*slot)->Reserve(bytes, what); });
  if (!env.ok()) return fail(env.status());
  const int verify = request->has_verify() ? request->verify() : jobs::kDefaultIrradianceVerify;
  if (verify < 0 || verify > jobs::kMaxIrradianceVerify) {
    return fail(absl::InvalidArgumentError(absl::StrCat(
        "verify must be in [0, ", jobs::kMaxIrradianceVerify, "] normals, got ", verify)));
  }
  const Mat3 rotation = jobs::EnvironmentRotation(env->pinned.spec);
  absl::StatusOr<std::vector<double>> e9 =
      jobs::IrradianceSh9(env->map, rotation, options_.job_threads);
  if (!e9.ok()) return fail(e9.status());
  for (double c : *e9) response->add_coefficients(c);
  const ibl::LevelError measured =
      jobs::MeasureIrradianceSh9(env->map, rotation, *e9, verify, options_.job_threads);
  response->set_measured_count(measured.count);
  response->set_measured_rms(measured.rms);
  response->set_measured_max(measured.max);
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::Ibl(grpc::ServerContext* context, const v1::IblRequest* request,
                                  grpc::ServerWriter<v1::IblEvent>* writer) {
  RequestLog log(context, "Ibl");
  IblCall call;
  auto fail = [&](const absl::Status& s) {
    return log.Finish(wire::ToGrpcStatus(HideSpoolPaths(s, call.env ? &*call.env : nullptr)));
  };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit();
  if (!slot.ok()) return fail(slot.status());
  call.slot = slot->get();
  if (absl::Status s = ParseIblCall(*request, &call); !s.ok()) return fail(s);
  if (absl::Status s = RunIblCall(context, writer, &call, &log); !s.ok()) return fail(s);
  if (absl::Status s = WhileWatched(context, "reading the files",
                                    [&](IdleWatchdog::Call* watch) {
                                      return SendIblResult(context, writer, call, &log, watch);
                                    });
      !s.ok()) {
    return fail(s);
  }
  return log.Finish(grpc::Status::OK);
}

absl::Status ShrmServiceImpl::ParseIblCall(const v1::IblRequest& request, IblCall* call) {
  SHRM_ASSIGN_OR_RETURN(call->request, wire::DecodeIblRequest(request));
  wire::WireEnvironment env{call->request.job.env, call->request.sha256};
  SHRM_ASSIGN_OR_RETURN(call->env, PinEnvironment(env, blobs_.get(), &decode_guard_));
  return absl::OkStatus();
}

absl::Status ShrmServiceImpl::RunIblCall(grpc::ServerContext* context,
                                         grpc::ServerWriter<v1::IblEvent>* writer, IblCall* call,
                                         RequestLog* log) {
  const jobs::IblJob& job = call->request.job;
  // decode, lighting, specular, [sheen], irradiance, [verify], encode.
  const double stages = 5 + job.sheen + (job.verify > 0);
  int stage_index = 0;
  auto hook = [&](std::string_view stage) -> absl::Status {
    SHRM_RETURN_IF_ERROR(CheckStage(context, stage));
    TestStageHooks(stage);
    WriteProgress(writer, stage, stage_index++ / stages);
    return CheckStage(context, stage);
  };
  SHRM_RETURN_IF_ERROR(hook("decode"));
  SHRM_ASSIGN_OR_RETURN(const uint64_t map_bytes, MapDecodeBytes(*call->env));
  SHRM_RETURN_IF_ERROR(
      call->slot->Reserve(map_bytes + jobs::IblOutputBytes(job), "the map and the IBL set"));
  const auto decode_start = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(const EnvMap map, EnvMap::Load(call->env->options));
  // The client's names and the blobs' hashes: the outputs record the embedded run's shrm:source.
  SHRM_ASSIGN_OR_RETURN(jobs::IblRun run,
                        jobs::RunIblJobOnMap(job, map, call->env->source, MsSince(decode_start),
                                             options_.job_threads, hook));
  SHRM_RETURN_IF_ERROR(hook("encode"));
  const auto encode_start = std::chrono::steady_clock::now();
  absl::StatusOr<std::vector<jobs::IblFile>> files = jobs::EncodeIblOutputs(job, run);
  if (!files.ok()) {
    return absl::InternalError(
        absl::StrCat("encoding the IBL files failed: ", files.status().message()));
  }
  call->files = *std::move(files);
  run.timings.push_back({"encode", MsSince(encode_start)});
  for (const StageTiming& t : run.timings) log->AddStage(t.stage, t.ms);
  call->source_sha256 = run.source.sha256;
  call->report = std::move(run.report);
  call->timings = std::move(run.timings);
  return absl::OkStatus();
}

absl::Status ShrmServiceImpl::SendIblResult(grpc::ServerContext* context,
                                            grpc::ServerWriter<v1::IblEvent>* writer,
                                            const IblCall& call, RequestLog* log,
                                            IdleWatchdog::Call* watch) {
  v1::IblEvent ev;
  v1::IblReport* rep = ev.mutable_report();
  rep->set_report_json(call.report.dump(2));
  rep->set_source_sha256(call.source_sha256);
  for (const StageTiming& t : call.timings) {
    v1::StageTiming* st = rep->add_timings();
    st->set_stage(t.stage);
    st->set_ms(t.ms);
  }
  for (const jobs::IblFile& f : call.files) {
    v1::IblFileInfo* info = rep->add_files();
    info->set_name(f.name);
    info->set_what(f.what);
    info->set_size(f.bytes.size());
  }
  SHRM_RETURN_IF_ERROR(WriteOrFail(context, writer, ev, log));
  for (const jobs::IblFile& f : call.files) {
    SHRM_RETURN_IF_ERROR(StreamFile(f.bytes, writer, log, watch, [&](v1::IblEvent* e) {
      e->mutable_file()->set_name(f.name);
      return e->mutable_file()->mutable_chunk();
    }));
  }
  return absl::OkStatus();
}

namespace {

// What a live call's frames are made from, as of one session update: the job whose file
// attributes the frame's file gets, its provenance, and the number of the request it came from.
// The highest degree of lighting coefficients a live call takes ((256 + 1)^2 x 3 doubles, 1.6 MB:
// well above any F_rho the analysis picks) and the relative slack of the energy check (the
// caller's energy and sum of squares come from two quadratures of the same map: they agree to
// rounding for band-limited lighting).
constexpr int kMaxLiveCoefficientsLmax = 256;
constexpr double kLiveEnergySlack = 1e-9;

struct LiveSnapshot {
  uint64_t request = 0;
  jobs::PrefilterJob job;
  jobs::PrefilterProvenance provenance;
  int64_t replaced_non_finite = 0;  // of the map (what the split-sum set's report records)
};

// The split-sum set's job of a live call (LiveOpen.ibl): the Ibl call's options, no environment
// (each frame's is the session's) and no check. InvalidArgument naming the field.
absl::StatusOr<jobs::IblJob> LiveIblJobFromOpen(const v1::IblRequest& ibl) {
  if (ibl.has_environment()) {
    return absl::InvalidArgumentError(
        "ibl.environment must be absent: the frames' lighting is the session's (environment and "
        "rotation requests)");
  }
  if (ibl.has_verify() && ibl.verify() != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("ibl.verify = ", ibl.verify(), ": live frames are not checked (absent or 0)"));
  }
  v1::IblRequest request = ibl;
  request.mutable_environment()->add_sha256(std::string(64, '0'));  // replaced by each frame's
  request.set_verify(0);
  absl::StatusOr<wire::WireIbl> decoded = wire::DecodeIblRequest(request);
  if (!decoded.ok()) {
    return absl::Status(decoded.status().code(), absl::StrCat("ibl.", decoded.status().message()));
  }
  return decoded->job;
}

// The job a live call's frames are made as, from the open request (InvalidArgument naming the
// field); the BRDF and the map are placeholders until their updates.
absl::StatusOr<jobs::PrefilterJob> LiveJobFromOpen(const v1::LiveOpen& open) {
  jobs::PrefilterJob job;
  if (open.has_orders()) {
    jobs::UseExplicitOrders(&job, jobs::Orders{open.orders().f(), open.orders().p()});
  } else {
    jobs::UseEpsilonRule(&job, open.order_choice_case() == v1::LiveOpen::kEpsilon
                                   ? open.epsilon()
                                   : jobs::kDefaultEpsilon);
  }
  job.kind = open.kind() == v1::SHRM_KIND_LOCAL ? ShrmKind::kLocal : ShrmKind::kGlobal;
  job.face_size = open.face_size();
  job.verify = 0;
  job.brdf = "lambert";
  job.env.files = {"live"};
  SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(job));
  return job;
}

// Lighting coefficients of a live request, checked: the degree, the count, finite values, and
// an energy per channel at least the coefficients' own (an orthonormal expansion cannot hold more
// than the function: Parseval), or that sum when none is given.
struct LiveLighting {
  int lmax = 0;
  std::shared_ptr<const std::vector<double>> rgb;
  std::array<double, 3> energy{};
  jobs::SourceIdentity source;
};

absl::StatusOr<LiveLighting> LiveLightingFromRequest(const v1::LightingCoefficients& c) {
  if (c.lmax() < 0 || c.lmax() > kMaxLiveCoefficientsLmax) {
    return absl::InvalidArgumentError(absl::StrCat(
        "coefficients.lmax = ", c.lmax(), " must be in [0, ", kMaxLiveCoefficientsLmax, "]"));
  }
  const size_t count = static_cast<size_t>(ShCount(c.lmax())) * 3;
  if (static_cast<size_t>(c.rgb_size()) != count) {
    return absl::InvalidArgumentError(absl::StrCat("coefficients.rgb holds ", c.rgb_size(),
                                                   " values; degree ", c.lmax(), " needs ", count,
                                                   " ((lmax + 1)^2 x RGB)"));
  }
  LiveLighting out;
  out.lmax = c.lmax();
  std::array<double, 3> own{};
  for (int i = 0; i < c.rgb_size(); ++i) {
    if (!std::isfinite(c.rgb(i))) {
      return absl::InvalidArgumentError(
          absl::StrCat("coefficients.rgb[", i, "] is not finite (", c.rgb(i), ")"));
    }
    own[i % 3] += c.rgb(i) * c.rgb(i);
  }
  if (c.energy_size() == 0) {
    out.energy = own;
  } else if (c.energy_size() != 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("coefficients.energy holds ", c.energy_size(), " values; 3 (RGB) or none"));
  } else {
    for (int ch = 0; ch < 3; ++ch) {
      const double e = c.energy(ch);
      if (!std::isfinite(e) || e < own[ch] * (1 - kLiveEnergySlack)) {
        return absl::InvalidArgumentError(absl::StrCat(
            "coefficients.energy[", ch, "] = ", e, " is below the coefficients' own energy ",
            own[ch], " (the sum of their squares: the lighting cannot hold less)"));
      }
      out.energy[ch] = e;
    }
  }
  std::string bytes(reinterpret_cast<const char*>(c.rgb().data()), count * sizeof(double));
  bytes.append(reinterpret_cast<const char*>(out.energy.data()), sizeof(out.energy));
  out.source = {absl::StrCat("coefficients (degree ", c.lmax(), ")"), Sha256Hex(bytes)};
  out.rgb = std::make_shared<const std::vector<double>>(c.rgb().begin(), c.rgb().end());
  return out;
}

}  // namespace

grpc::Status ShrmServiceImpl::Live(
    grpc::ServerContext* context,
    grpc::ServerReaderWriter<v1::LiveEvent, v1::LiveRequest>* stream) {
  RequestLog log(context, "Live");
  auto fail = [&](const absl::Status& s) { return log.Finish(wire::ToGrpcStatus(s)); };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit();
  if (!slot.ok()) return fail(slot.status());
  v1::LiveRequest request;
  if (!stream->Read(&request) || !request.has_open()) {
    return fail(absl::InvalidArgumentError("live: request 0 must open the session (open)"));
  }
  absl::StatusOr<jobs::PrefilterJob> job = LiveJobFromOpen(request.open());
  if (!job.ok()) {
    return fail(absl::Status(job.status().code(),
                             absl::StrCat("live: request 0: ", job.status().message())));
  }
  const bool view_only = request.open().view_only();
  const bool shrm_ktx2 = request.open().shrm_ktx2();
  std::optional<jobs::IblJob> ibl_job;
  std::optional<ibl::SplitSumSetOptions> split_sum;
  if (request.open().has_ibl()) {
    absl::StatusOr<jobs::IblJob> j = LiveIblJobFromOpen(request.open().ibl());
    absl::StatusOr<ibl::SplitSumSetOptions> o =
        j.ok() ? jobs::IblSplitSumSetOptions(*j) : j.status();
    if (!o.ok()) {
      return fail(
          absl::Status(o.status().code(), absl::StrCat("live: request 0: ", o.status().message())));
    }
    ibl_job = *std::move(j);
    split_sum = *std::move(o);
  }
  PrefilterOptions options = jobs::CorePrefilterOptions(*job, options_.job_threads);
  options.max_cube_values = kMaxCubeValues;
  // Memory: twice the largest cube (the frame computed and the one being sent) and twice the
  // largest map (the session's and the one being decoded), each reserved as it grows.
  std::mutex reserve_mu;
  uint64_t reserved_cube = 0, reserved_maps = 0;
  auto grow = [&](uint64_t need, uint64_t* reserved, std::string_view what) -> absl::Status {
    std::lock_guard<std::mutex> lock(reserve_mu);
    if (need <= *reserved) return absl::OkStatus();
    SHRM_RETURN_IF_ERROR((*slot)->Reserve(need - *reserved, what));
    *reserved = need;
    return absl::OkStatus();
  };
  options.admit_cube = [&](int face_size, int p_b) {
    return grow(2 * jobs::ShrmCubeBytes(face_size, p_b), &reserved_cube,
                absl::StrCat("two SHRM cubes of face size ", face_size, " and P_B = ", p_b));
  };
  // The split-sum set: twice its outputs (the frame's set and files, the one being sent).
  uint64_t reserved_ibl = 0;
  if (ibl_job) {
    if (absl::Status s =
            grow(2 * jobs::IblOutputBytes(*ibl_job), &reserved_ibl, "two split-sum sets");
        !s.ok()) {
      return fail(s);
    }
  }
  absl::StatusOr<std::unique_ptr<LiveSession>> session = LiveSession::Create(
      options, [this](uint64_t) { TestStageHooks("live frame"); }, split_sum);
  if (!session.ok()) return fail(session.status());

  std::mutex mu;                      // guards the flags and the writer's error
  LiveSnapshot current{0, *job, {}};  // the reader's; each update's copy travels as its tag
  bool reading_done = false, stop = false;
  uint64_t last_update = 0;  // the session's, after the last request
  absl::Status writer_error;
  std::thread writer([&] {
    uint64_t sent = 0;
    for (;;) {
      const std::shared_ptr<const LiveFrame> frame =
          (*session)->WaitNewer(sent, absl::Milliseconds(100));
      {
        std::lock_guard<std::mutex> lock(mu);
        if (stop || context->IsCancelled()) return;
        if (frame == nullptr) {
          if (reading_done && sent >= last_update) return;
          continue;
        }
      }
      sent = frame->update;
      if (frame->incomplete || frame->tag == nullptr) continue;  // no map or BRDF yet
      if (view_only && frame->status.ok() && !frame->view && !frame->split_sum) {
        continue;  // nothing asked for yet
      }
      const LiveSnapshot& snap = *std::static_pointer_cast<const LiveSnapshot>(frame->tag);
      absl::Status s = frame->status;
      std::string file, view_file;
      std::vector<jobs::IblFile> ibl_files;
      const bool send_shrm = !view_only && frame->has_shrm;
      if (s.ok() && send_shrm) {
        const auto attributes =
            jobs::PrefilterFileAttributes(snap.job, snap.provenance, frame->result);
        absl::StatusOr<std::string> bytes =
            shrm_ktx2 ? EncodeShrmKtx2("the live frame", frame->result.cube, attributes)
                      : EncodeShrmFile("the live frame", frame->result.cube, attributes, false);
        if (bytes.ok()) file = *std::move(bytes);
        s = bytes.status();
      }
      if (s.ok() && frame->view) {
        absl::StatusOr<std::string> bytes =
            EncodeImage(jobs::RadianceCrossImage(frame->view_map), ImageEncoding::kExrFloat);
        if (bytes.ok()) view_file = *std::move(bytes);
        s = bytes.status();
      }
      if (s.ok() && ibl_job && frame->split_sum) {
        // The Ibl call's files for the frame's lighting (the environment its requests gave).
        jobs::IblJob frame_job = *ibl_job;
        frame_job.env = snap.job.env;
        absl::StatusOr<jobs::IblRun> run = jobs::IblRunFromSet(
            frame_job, *frame->split_sum, snap.provenance.source, snap.provenance.layout,
            snap.replaced_non_finite, options_.job_threads);
        absl::StatusOr<std::vector<jobs::IblFile>> files =
            run.ok() ? jobs::EncodeIblOutputs(frame_job, *run) : run.status();
        if (files.ok()) ibl_files = *std::move(files);
        s = files.status();
      }
      if (s.ok()) {
        const LiveStats stats = (*session)->Stats();
        // Every event of the frame carries its figures; the SHRM file's chunks, then the view's.
        auto event = [&](v1::LiveEvent* ev) {
          ev->set_update(snap.request);
          ev->set_dropped(stats.dropped);
          ev->set_f_b(frame->result.analysis.f_b);
          ev->set_p_b(frame->result.analysis.p_b);
          ev->set_no_shrm(!frame->has_shrm);
          ev->set_ibl_files(static_cast<uint32_t>(ibl_files.size()));
          for (const StageTiming& t : frame->result.timings) {
            v1::StageTiming* st = ev->add_timings();
            st->set_stage(t.stage);
            st->set_ms(t.ms);
          }
          if (frame->view) {
            ev->mutable_view()->set_x(frame->view->x);
            ev->mutable_view()->set_y(frame->view->y);
            ev->mutable_view()->set_z(frame->view->z);
          }
        };
        s = WhileWatched(context, "reading live frames", [&](IdleWatchdog::Call* watch) {
          if (send_shrm) {
            SHRM_RETURN_IF_ERROR(StreamFile(file, stream, &log, watch, [&](v1::LiveEvent* ev) {
              event(ev);
              return ev->mutable_shrm_file();
            }));
          }
          if (frame->view) {
            SHRM_RETURN_IF_ERROR(StreamFile(view_file, stream, &log, watch, [&](v1::LiveEvent* ev) {
              event(ev);
              return ev->mutable_view_file();
            }));
          }
          for (const jobs::IblFile& f : ibl_files) {
            SHRM_RETURN_IF_ERROR(StreamFile(f.bytes, stream, &log, watch, [&](v1::LiveEvent* ev) {
              event(ev);
              ev->mutable_ibl_file()->set_name(f.name);
              return ev->mutable_ibl_file()->mutable_chunk();
            }));
          }
          return absl::OkStatus();
        });
      } else {
        s = absl::Status(s.code(), absl::StrCat("live: request ", snap.request, ": ", s.message()));
      }
      if (!s.ok()) {
        std::lock_guard<std::mutex> lock(mu);
        writer_error = s;
        stop = true;
        context->TryCancel();  // the reader's Read returns
        return;
      }
    }
  });
  auto end = [&](const absl::Status& s) {
    {
      std::lock_guard<std::mutex> lock(mu);
      stop = true;
    }
    writer.join();
    return fail(s);
  };

  // The reader: each request is one update of the session. A call that sends nothing for
  // --idle-timeout is ended (it holds a job slot; its frames are all sent by then).
  const absl::Status read = WhileWatched(
      context, "sending live requests", [&](IdleWatchdog::Call* watch) -> absl::Status {
        for (uint64_t n = 1; stream->Read(&request); ++n) {
          watch->Progress();
          auto at = [&](const absl::Status& s) {
            return absl::Status(s.code(), absl::StrCat("live: request ", n, ": ", s.message()));
          };
          // Each update carries a copy of the state's description as its tag (the frames bring
          // back the one they were computed from).
          current.request = n;
          auto tag = [&] { return std::make_shared<const LiveSnapshot>(current); };
          uint64_t update = 0;
          switch (request.update_case()) {
            case v1::LiveRequest::kEnvironment: {
              absl::StatusOr<DecodedEnv> env =
                  PinAndDecode(context, request.environment(), blobs_.get(), &decode_guard_,
                               "lighting", [&](uint64_t bytes, std::string_view what) {
                                 return grow(2 * bytes, &reserved_maps, what);
                               });
              if (!env.ok()) return at(env.status());
              current.job.env = env->pinned.spec;
              current.provenance.source = env->pinned.source;
              current.provenance.layout = env->map.layout();
              current.replaced_non_finite = env->map.replaced_non_finite();
              update = (*session)->SetMap(std::make_shared<const EnvMap>(std::move(env->map)),
                                          jobs::EnvironmentRotation(current.job.env), tag());
              break;
            }
            case v1::LiveRequest::kRotation: {
              const v1::Rotation& r = request.rotation();
              current.job.env.rotate_ypr_deg =
                  std::array<double, 3>{r.yaw_deg(), r.pitch_deg(), r.roll_deg()};
              if (absl::Status s = jobs::ValidateEnvironment(current.job.env); !s.ok()) {
                return at(s);
              }
              update = (*session)->SetRotation(jobs::EnvironmentRotation(current.job.env), tag());
              break;
            }
            case v1::LiveRequest::kBrdf: {
              absl::StatusOr<RequestBrdf> brdf =
                  ResolveRequestBrdf({request.brdf(), "", ""}, blobs_.get());
              if (!brdf.ok()) return at(brdf.status());
              current.job.brdf = brdf->display_spec;
              current.provenance.brdf_spec = brdf->display_spec;
              update =
                  (*session)->SetBrdf(std::shared_ptr<const Brdf>(std::move(brdf->brdf)), tag());
              break;
            }
            case v1::LiveRequest::kCoefficients: {
              absl::StatusOr<LiveLighting> light = LiveLightingFromRequest(request.coefficients());
              if (!light.ok()) return at(light.status());
              if (absl::Status s = grow(2 * light->rgb->size() * sizeof(double), &reserved_maps,
                                        "two sets of lighting coefficients");
                  !s.ok()) {
                return at(s);
              }
              current.job.env.files = {"coefficients"};
              current.provenance.source = light->source;
              current.provenance.layout = EnvLayout::kAuto;
              update = (*session)->SetCoefficients(light->rgb, light->lmax, light->energy, tag());
              break;
            }
            case v1::LiveRequest::kView: {
              std::optional<Vec3> view;
              if (request.view().has_direction()) {
                absl::StatusOr<Vec3> v =
                    RequestDirection(true, request.view().direction(), "view.direction");
                if (!v.ok()) return at(v.status());
                view = *v;
              }
              update = (*session)->SetView(view, tag());
              break;
            }
            default:
              return at(absl::InvalidArgumentError(
                  "expected environment, rotation, brdf, coefficients or view (open only as "
                  "request 0)"));
          }
          {
            std::lock_guard<std::mutex> lock(mu);
            last_update = update;
            if (stop) break;
          }
          TestStageHooks("live request");
        }
        return absl::OkStatus();
      });
  if (!read.ok()) return end(read);
  {
    std::lock_guard<std::mutex> lock(mu);
    reading_done = true;
  }
  writer.join();
  if (!writer_error.ok()) return fail(writer_error);
  if (context->IsCancelled()) return fail(absl::CancelledError("live: cancelled"));
  return log.Finish(grpc::Status::OK);
}

}  // namespace shrm::server
