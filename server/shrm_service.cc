#include "server/shrm_service.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/time/clock.h"
#include "client/report.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_projection.h"
#include "core/envmap/envmap.h"
#include "core/envmap/lighting.h"
#include "core/io/sha256.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_reference.h"
#include "server/metrics.h"
#include "server/request_log.h"
#include "server/status_mapping.h"

namespace shrm::server {
namespace {

namespace v1 = ::shrm::v1;

// Output chunks: at most 1 MiB of file bytes per message (well under gRPC's 4 MiB default).
constexpr size_t kFileChunkBytes = 1 << 20;
// Retry hint for RESOURCE_EXHAUSTED (all job slots busy): about one short job.
constexpr int kRetryAfterMs = 1000;
// Request limits beyond core's own: P_B <= 31 is what the SHRM file holds ((P + 1)^2 <= 1024
// channel triples, core/io/cube_exr.cc), and the largest cube one job may allocate
// (6 S^2 (P + 1)^2 RGB values: 2^28 doubles = 2 GiB).
constexpr int kMaxRequestP = 31;
constexpr int kMaxRequestF = kMaxBrdfLmax;
constexpr int kMaxRequestFaceSize = 2048;
constexpr double kMaxCubeValues = 1 << 28;
// Defaults as the CLI's (docs/cli.md).
constexpr double kDefaultEpsilon = 0.03;
constexpr double kDefaultAnalyzeEpsilons[] = {0.2, 0.1, 0.05, 0.01};
constexpr char kDefaultWorkingSpace[] = "lin_rec709";

absl::StatusOr<EnvLayout> LayoutFromProto(v1::Layout layout) {
  switch (layout) {
    case v1::LAYOUT_UNSPECIFIED:
      return EnvLayout::kAuto;
    case v1::LAYOUT_LATLONG:
      return EnvLayout::kLatLong;
    case v1::LAYOUT_CUBE_FACES:
      return EnvLayout::kCubeFaces;
    case v1::LAYOUT_HCROSS:
      return EnvLayout::kHorizontalCross;
    case v1::LAYOUT_VCROSS:
      return EnvLayout::kVerticalCross;
    case v1::LAYOUT_HSTRIP:
      return EnvLayout::kHorizontalStrip;
    case v1::LAYOUT_VSTRIP:
      return EnvLayout::kVerticalStrip;
    case v1::LAYOUT_ANGULAR:
      return EnvLayout::kAngular;
    default:
      return absl::InvalidArgumentError(
          absl::StrCat("environment.layout: unknown value ", static_cast<int>(layout)));
  }
}

// A BRDF read from a blob: forwards everything to the parsed model except spec(), which names
// the blob's content ("table:@<sha256>") instead of its spool path. CachedPrefilter keys rho_lpq
// by spec(), so the BRDF cache is keyed by content and no message carries the path.
class BlobBrdf final : public Brdf {
 public:
  BlobBrdf(std::unique_ptr<Brdf> inner, std::string spec)
      : inner_(std::move(inner)), spec_(std::move(spec)) {}
  std::string spec() const override { return spec_; }
  int channels() const override { return inner_->channels(); }
  ReparamKind reparam() const override { return inner_->reparam(); }
  bool radially_symmetric() const override { return inner_->radially_symmetric(); }
  bool clipped_at_normal_horizon() const override { return inner_->clipped_at_normal_horizon(); }
  bool azimuth_independent() const override { return inner_->azimuth_independent(); }
  BrdfBandwidthHint bandwidth_hint() const override { return inner_->bandwidth_hint(); }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override {
    return inner_->Transfer(n, v, w, c);
  }
  double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const override {
    return inner_->ReparamTransfer(theta_i, theta_o, phi, c);
  }
  void ReparamTransferAll(double theta_i, double theta_o, double phi, double* out) const override {
    inner_->ReparamTransferAll(theta_i, theta_o, phi, out);
  }

 private:
  std::unique_ptr<Brdf> inner_;
  std::string spec_;
};

// The BRDF of a request and the spec reported for it (shrm:brdf, report, response).
struct RequestBrdf {
  std::unique_ptr<Brdf> brdf;
  std::string display_spec;
};

// Parses the BRDF of a request. Analytic models: the spec string. File-based models travel as
// blobs ("table:@" / "merl:@" with brdf_blob_sha256); a spec naming a server file (table:PATH,
// merl:PATH) is refused, and no message names the spool file.
absl::StatusOr<RequestBrdf> ParseRequestBrdf(const std::string& spec, const std::string& blob_sha,
                                             const std::string& display_spec, BlobStore* blobs) {
  if (spec.empty()) return absl::InvalidArgumentError("brdf: a BRDF spec is required");
  const std::string stripped(absl::StripAsciiWhitespace(spec));
  const size_t colon = stripped.find(':');
  const std::string model =
      absl::AsciiStrToLower(absl::StripAsciiWhitespace(stripped.substr(0, colon)));
  const std::string rest(
      colon == std::string::npos
          ? absl::string_view()
          : absl::StripAsciiWhitespace(absl::string_view(stripped).substr(colon + 1)));
  RequestBrdf out;
  if (model == "table" || model == "merl") {
    if (rest != "@") {
      return absl::InvalidArgumentError(
          absl::StrCat("brdf: '", model,
                       ":' specs name files, which the service does not read; "
                       "upload the file and send '",
                       model, ":@' with brdf_blob_sha256"));
    }
    if (!IsSha256Hex(blob_sha)) {
      return absl::InvalidArgumentError(absl::StrCat("brdf_blob_sha256: '", model,
                                                     ":@' needs the BRDF blob's hash (64 "
                                                     "lowercase hex digits)"));
    }
    absl::StatusOr<std::unique_ptr<BlobStore::Lease>> lease = blobs->Pin(blob_sha);
    if (!lease.ok()) {
      return absl::Status(lease.status().code(),
                          absl::StrCat("brdf_blob_sha256: BRDF ", lease.status().message()));
    }
    // The model reads the whole file now; the lease only has to outlive the parse.
    const std::string path = (*lease)->path();
    absl::StatusOr<std::unique_ptr<Brdf>> parsed = ParseBrdfSpec(absl::StrCat(model, ":", path));
    if (!parsed.ok()) {
      // Core's message names the file: name the blob instead.
      const std::string name = absl::StrCat("BRDF blob ", blob_sha);
      const absl::string_view msg = parsed.status().message();
      return absl::InvalidArgumentError(
          absl::StrContains(msg, path)
              ? absl::StrCat("brdf: ", absl::StrReplaceAll(msg, {{path, name}}))
              : absl::StrCat("brdf: ", name, ": ", msg));
    }
    const std::string key_spec = absl::StrCat(model, ":@", blob_sha);
    out.brdf = std::make_unique<BlobBrdf>(std::move(*parsed), key_spec);
    out.display_spec = display_spec.empty() ? key_spec : display_spec;
    return out;
  }
  if (!blob_sha.empty() || !display_spec.empty()) {
    return absl::InvalidArgumentError(
        "brdf_blob_sha256 and brdf_display_spec go only with a 'table:@' or 'merl:@' brdf");
  }
  absl::StatusOr<std::unique_ptr<Brdf>> brdf = ParseBrdfSpec(spec);
  if (!brdf.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("brdf: ", brdf.status().message()));
  }
  out.brdf = std::move(*brdf);
  out.display_spec = out.brdf->spec();
  return out;
}

// A pinned environment: leases on its blobs, the EnvMapOptions that read them, and the cache key
// of everything L_lm depends on besides the degree.
struct PinnedEnv {
  std::vector<std::unique_ptr<BlobStore::Lease>> leases;
  EnvMapOptions options;
  std::string key;
  Mat3 rotation = Mat3::Identity();
  std::string source_sha256;
  std::string source_names;
  std::string rotate_attr;  // "" = no rotation
  std::string working_space;
};

absl::StatusOr<PinnedEnv> PinEnvironment(const v1::Environment& env, BlobStore* blobs) {
  PinnedEnv p;
  if (env.sha256_size() != 1 && env.sha256_size() != 6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "environment.sha256: give one blob, or six cube faces; got ", env.sha256_size()));
  }
  std::vector<std::string> hashes;
  for (const std::string& h : env.sha256()) {
    if (!IsSha256Hex(h)) {
      return absl::InvalidArgumentError(absl::StrCat("environment.sha256: '", h.substr(0, 80),
                                                     "' is not 64 lowercase hex digits"));
    }
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<BlobStore::Lease> lease, blobs->Pin(h));
    p.options.paths.push_back(lease->path());
    p.leases.push_back(std::move(lease));
    hashes.push_back(h);
  }
  SHRM_ASSIGN_OR_RETURN(p.options.layout, LayoutFromProto(env.layout()));
  p.options.input_colour_space = env.input_colour_space();
  p.working_space =
      env.working_colour_space().empty() ? kDefaultWorkingSpace : env.working_colour_space();
  p.options.working_colour_space = p.working_space;
  switch (env.non_finite()) {
    case v1::NON_FINITE_POLICY_UNSPECIFIED:
    case v1::NON_FINITE_POLICY_REJECT:
      p.options.non_finite = NonFinitePolicy::kReject;
      break;
    case v1::NON_FINITE_POLICY_REPLACE_ZERO:
      p.options.non_finite = NonFinitePolicy::kReplaceZero;
      break;
    default:
      return absl::InvalidArgumentError("environment.non_finite: unknown value");
  }
  std::string rot_key = "none";
  if (env.has_rotation()) {
    const v1::Rotation& r = env.rotation();
    const std::vector<double> ypr = {r.yaw_deg(), r.pitch_deg(), r.roll_deg()};
    for (double a : ypr) {
      if (!std::isfinite(a)) {
        return absl::InvalidArgumentError("environment.rotation: angles must be finite");
      }
    }
    p.rotation = RotationFromYawPitchRoll(ypr[0], ypr[1], ypr[2]);
    p.rotate_attr = absl::StrJoin(ypr, ",");  // as the CLI's shrm:rotate_ypr_deg
    rot_key = absl::StrFormat("%a,%a,%a", ypr[0], ypr[1], ypr[2]);
  }
  p.source_sha256 =
      hashes.size() == 1 ? hashes[0] : Sha256Hex(absl::StrJoin(hashes, ","));  // as the CLI
  p.source_names = env.source_names_size() > 0 ? absl::StrJoin(env.source_names(), ",")
                                               : absl::StrJoin(hashes, ",");
  p.key = absl::StrCat(absl::StrJoin(hashes, ","), "|layout=", static_cast<int>(p.options.layout),
                       "|in=", p.options.input_colour_space, "|work=", p.working_space,
                       "|nonfinite=", static_cast<int>(p.options.non_finite), "|rot=", rot_key);
  return p;
}

// Core messages name the spool files; clients know blobs by hash.
absl::Status HideSpoolPaths(const absl::Status& status, const PinnedEnv* env) {
  if (status.ok() || env == nullptr) return status;
  std::string msg(status.message());
  for (const auto& lease : env->leases) {
    msg = absl::StrReplaceAll(msg, {{lease->path(), absl::StrCat("blob ", lease->sha256())}});
  }
  return absl::Status(status.code(), msg);
}

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

void FillReport(const ShrmAnalysis& an, v1::PrefilterReport* rep) {
  rep->set_f_light(an.f_light);
  rep->set_f_brdf(an.f_brdf);
  rep->set_p_brdf(an.p_brdf);
  rep->set_f_b(an.f_b);
  rep->set_p_b(an.p_b);
  rep->set_eps_light(an.eps_light);
  rep->set_eps_brdf(an.eps_brdf);
  rep->set_eps_estimate(an.eps_estimate);
  rep->set_eps_bound(an.eps_bound);
  rep->set_suggested_face_size(an.suggested_face_size);
  rep->set_suggested_view_size(an.suggested_view_size);
}

void FillResult(const ShrmAnalysis& an, v1::AnalyzeResult* res) {
  res->set_epsilon(an.epsilon);
  res->set_f_light(an.f_light);
  res->set_f_brdf(an.f_brdf);
  res->set_p_brdf(an.p_brdf);
  res->set_f_b(an.f_b);
  res->set_p_b(an.p_b);
  res->set_eps_light(an.eps_light);
  res->set_eps_brdf(an.eps_brdf);
  res->set_eps_estimate(an.eps_estimate);
  res->set_eps_bound(an.eps_bound);
  res->set_suggested_face_size(an.suggested_face_size);
  res->set_suggested_view_size(an.suggested_view_size);
}

}  // namespace

// A held job slot; releases it on destruction.
class ShrmServiceImpl::JobSlot {
 public:
  explicit JobSlot(std::atomic<int>* running) : running_(running) {
    Metrics::Global().JobStarted();
  }
  ~JobSlot() {
    running_->fetch_sub(1);
    Metrics::Global().JobFinished();
  }

 private:
  std::atomic<int>* running_;
};

absl::StatusOr<std::unique_ptr<ShrmServiceImpl>> ShrmServiceImpl::Create(
    const ServiceOptions& options) {
  if (options.max_jobs < 1 || options.job_threads < 1) {
    return absl::InvalidArgumentError("max jobs and job threads must be >= 1");
  }
  if (options.spool_dir.empty()) return absl::InvalidArgumentError("a spool directory is required");
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<BlobStore> blobs,
                        BlobStore::Open(options.spool_dir, options.spool_bytes));
  return std::unique_ptr<ShrmServiceImpl>(new ShrmServiceImpl(options, std::move(blobs)));
}

ShrmServiceImpl::ShrmServiceImpl(const ServiceOptions& options, std::unique_ptr<BlobStore> blobs)
    : options_(options), blobs_(std::move(blobs)), caches_(options.cache_bytes) {}

absl::StatusOr<std::unique_ptr<ShrmServiceImpl::JobSlot>> ShrmServiceImpl::Admit(
    grpc::ServerContext* context) {
  if (draining_) return absl::UnavailableError("server is shutting down; retry on another server");
  int running = running_jobs_.load();
  while (true) {
    if (running >= options_.max_jobs) {
      context->AddTrailingMetadata("retry-after-ms", std::to_string(kRetryAfterMs));
      return absl::ResourceExhaustedError(
          absl::StrCat("server busy: ", running, " of ", options_.max_jobs,
                       " job slots in use; retry after about ", kRetryAfterMs, " ms"));
    }
    if (running_jobs_.compare_exchange_weak(running, running + 1)) break;
  }
  return std::make_unique<JobSlot>(&running_jobs_);
}

grpc::Status ShrmServiceImpl::HasBlob(grpc::ServerContext* context,
                                      const v1::HasBlobRequest* request,
                                      v1::HasBlobResponse* response) {
  RequestLog log(context, "HasBlob");
  if (!IsSha256Hex(request->sha256())) {
    return log.Finish(
        ToGrpcStatus(absl::InvalidArgumentError("sha256: expected 64 lowercase hex digits")));
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
  auto fail = [&](const absl::Status& s) { return log.Finish(ToGrpcStatus(s)); };
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
  const PinnedEnv* pinned_for_messages = nullptr;
  auto fail = [&](const absl::Status& s) {
    return log.Finish(ToGrpcStatus(HideSpoolPaths(s, pinned_for_messages)));
  };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit(context);
  if (!slot.ok()) return fail(slot.status());

  // Request -> core types.
  absl::StatusOr<RequestBrdf> brdf = ParseRequestBrdf(request->brdf(), request->brdf_blob_sha256(),
                                                      request->brdf_display_spec(), blobs_.get());
  if (!brdf.ok()) return fail(brdf.status());
  CachedPrefilterInput in;
  in.brdf = brdf->brdf.get();
  in.options.epsilon = kDefaultEpsilon;
  if (request->has_orders()) {
    const int f = request->orders().f(), p = request->orders().p();
    if (f < 0 || p < 0 || f > kMaxRequestF || p > kMaxRequestP) {
      return fail(absl::InvalidArgumentError(absl::StrCat("orders: F must be in [0, ", kMaxRequestF,
                                                          "] and P in [0, ", kMaxRequestP,
                                                          "], got ", f, ",", p)));
    }
    in.options.f = f;
    in.options.p = p;
  } else if (request->order_choice_case() == v1::PrefilterRequest::kEpsilon) {
    in.options.epsilon = request->epsilon();
  }
  switch (request->kind()) {
    case v1::SHRM_KIND_UNSPECIFIED:
    case v1::SHRM_KIND_GLOBAL:
      in.options.kind = ShrmKind::kGlobal;
      break;
    case v1::SHRM_KIND_LOCAL:
      in.options.kind = ShrmKind::kLocal;
      break;
    default:
      return fail(absl::InvalidArgumentError("kind: unknown value"));
  }
  if (request->face_size() < 0 || request->face_size() > kMaxRequestFaceSize) {
    return fail(absl::InvalidArgumentError(absl::StrCat(
        "face_size must be in [0, ", kMaxRequestFaceSize, "], got ", request->face_size())));
  }
  in.options.face_size = request->face_size();
  in.options.threads = options_.job_threads;
  in.max_cube_values = kMaxCubeValues;
  bool want_file = request->outputs_size() == 0, want_report = request->outputs_size() == 0;
  for (int o : request->outputs()) {
    if (o == v1::OUTPUT_SHRM_FILE) want_file = true;
    if (o == v1::OUTPUT_REPORT) want_report = true;
  }
  absl::StatusOr<PinnedEnv> env = PinEnvironment(request->environment(), blobs_.get());
  if (!env.ok()) return fail(env.status());
  pinned_for_messages = &*env;
  in.env = env->options;
  in.env_key = env->key;
  in.options.rotation = env->rotation;

  // Core call, with progress events and cancellation checks between stages.
  constexpr double kStages = 6;  // brdf, decode, lighting, analysis, synthesis, write
  int stage_index = 0;
  StageHook hook = [&](std::string_view stage) -> absl::Status {
    SHRM_RETURN_IF_ERROR(CheckStage(context, stage));
    if (options_.test_stage_delay > absl::ZeroDuration()) absl::SleepFor(options_.test_stage_delay);
    v1::PrefilterEvent ev;
    ev.mutable_progress()->set_stage(std::string(stage));
    ev.mutable_progress()->set_fraction(std::min(stage_index++, 5) / kStages);
    writer->Write(ev);
    return CheckStage(context, stage);
  };
  absl::StatusOr<CachedPrefilterResult> res = CachedPrefilter(in, &caches_, hook);
  if (!res.ok()) return fail(res.status());
  for (const StageTiming& t : res->result.timings) log.AddStage(t.stage, t.ms);
  const ShrmAnalysis& an = res->result.analysis;
  if (absl::Status s = hook("write"); !s.ok()) return fail(s);

  // The SHRM file with the CLI's attributes (client/cmd_prefilter.cc), written in the spool.
  const auto write_start = std::chrono::steady_clock::now();
  std::map<std::string, std::string> attrs = {
      {"shrm:brdf", brdf->display_spec},
      {"shrm:epsilon",
       request->has_orders() ? "explicit orders" : absl::StrCat(in.options.epsilon)},
      {"shrm:orders", absl::StrCat(an.f_b, ",", an.p_b)},
      {"shrm:brdf_orders", absl::StrCat(an.f_brdf, ",", an.p_brdf)},
      {"shrm:eps_light", absl::StrCat(an.eps_light)},
      {"shrm:eps_brdf", absl::StrCat(an.eps_brdf)},
      {"shrm:eps_bound", absl::StrCat(an.eps_bound)},
      {"shrm:source", env->source_names},
      {"shrm:source_sha256", env->source_sha256},
      {"shrm:working_space", env->working_space},
      {"shrm:layout", EnvLayoutName(res->layout)},
  };
  if (!env->rotate_attr.empty()) attrs["shrm:rotate_ypr_deg"] = env->rotate_attr;
  std::string file;
  if (want_file) {
    absl::StatusOr<std::string> bytes =
        EncodeShrmFile("the SHRM file", res->result.cube, attrs, request->half());
    if (!bytes.ok())
      return fail(absl::InternalError(
          absl::StrCat("writing the SHRM file failed: ", bytes.status().message())));
    file = std::move(*bytes);
  }
  const double write_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - write_start)
          .count();
  log.AddStage("write", write_ms);

  // Core -> response: the report, then the file.
  v1::PrefilterEvent ev;
  v1::PrefilterReport* rep = ev.mutable_report();
  FillReport(an, rep);
  rep->set_face_size(res->result.cube.face_size);
  rep->set_brdf(brdf->display_spec);
  rep->set_layout(EnvLayoutName(res->layout));
  rep->set_source_sha256(env->source_sha256);
  for (const StageTiming& t : res->result.timings) {
    auto* st = rep->add_timings();
    st->set_stage(t.stage);
    st->set_ms(t.ms);
  }
  auto* wt = rep->add_timings();
  wt->set_stage("write");
  wt->set_ms(write_ms);
  rep->mutable_cache()->set_lighting_hit(res->lighting_hit);
  rep->mutable_cache()->set_brdf_hit(res->brdf_hit);
  Metrics::Global().RecordCache("lighting", res->lighting_hit);
  Metrics::Global().RecordCache("brdf", res->brdf_hit);
  log.Set("lighting_cache", res->lighting_hit ? "hit" : "miss");
  log.Set("brdf_cache", res->brdf_hit ? "hit" : "miss");
  if (want_report) {
    nlohmann::json report = cli::AnalysisJson(an);
    report["brdf"] = brdf->display_spec;
    report["kind"] = in.options.kind == ShrmKind::kLocal ? "local" : "global";
    report["face_size"] = res->result.cube.face_size;
    report["source_sha256"] = env->source_sha256;
    report["layout"] = EnvLayoutName(res->layout);
    nlohmann::json timings = cli::TimingsJson(res->result.timings);
    timings["write_ms"] = write_ms;
    report["timings"] = timings;
    report["cache"] = {{"lighting", res->lighting_hit ? "hit" : "miss"},
                       {"brdf", res->brdf_hit ? "hit" : "miss"}};
    rep->set_report_json(report.dump(2));
  }
  log.AddBytesOut(ev.ByteSizeLong());
  if (!writer->Write(ev))
    return fail(CheckContext(context).ok() ? absl::UnavailableError("client went away")
                                           : CheckContext(context));
  if (want_file) {
    Sha256Stream sha;  // hashed chunk by chunk, while the client receives the previous one
    size_t offset = 0;
    do {
      const size_t n = std::min(kFileChunkBytes, file.size() - offset);
      v1::PrefilterEvent chunk_ev;
      v1::FileChunk* chunk = chunk_ev.mutable_shrm_file();
      chunk->set_offset(offset);
      chunk->set_total_size(file.size());
      chunk->set_data(file.data() + offset, n);
      sha.Update(std::string_view(file.data() + offset, n));
      offset += n;
      if (offset == file.size()) {
        chunk->set_last(true);
        chunk->set_sha256(sha.Hex());
      }
      log.AddBytesOut(n);
      if (!writer->Write(chunk_ev)) {
        return fail(absl::UnavailableError("client went away during the file transfer"));
      }
    } while (offset < file.size());
  }
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::Analyze(grpc::ServerContext* context,
                                      const v1::AnalyzeRequest* request,
                                      v1::AnalyzeResponse* response) {
  RequestLog log(context, "Analyze");
  const PinnedEnv* pinned_for_messages = nullptr;
  auto fail = [&](const absl::Status& s) {
    return log.Finish(ToGrpcStatus(HideSpoolPaths(s, pinned_for_messages)));
  };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit(context);
  if (!slot.ok()) return fail(slot.status());
  absl::StatusOr<RequestBrdf> brdf = ParseRequestBrdf(request->brdf(), request->brdf_blob_sha256(),
                                                      request->brdf_display_spec(), blobs_.get());
  if (!brdf.ok()) return fail(brdf.status());
  std::vector<double> epsilons(request->epsilon().begin(), request->epsilon().end());
  if (epsilons.empty()) {
    epsilons.assign(std::begin(kDefaultAnalyzeEpsilons), std::end(kDefaultAnalyzeEpsilons));
  }
  for (double e : epsilons) {
    if (!(e > 0 && e < 1)) {
      return fail(
          absl::InvalidArgumentError(absl::StrCat("epsilon values must be in (0, 1), got ", e)));
    }
  }
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
  absl::StatusOr<PinnedEnv> env = PinEnvironment(request->environment(), blobs_.get());
  if (!env.ok()) return fail(env.status());
  pinned_for_messages = &*env;
  for (double e : epsilons) {
    CachedPrefilterInput in;
    in.brdf = brdf->brdf.get();
    in.env = env->options;
    in.env_key = env->key;
    in.options.epsilon = e;
    in.options.rotation = env->rotation;
    in.options.threads = options_.job_threads;
    in.options.synthesize = false;
    StageHook hook = [&](std::string_view stage) { return CheckStage(context, stage); };
    absl::StatusOr<CachedPrefilterResult> res = CachedPrefilter(in, &caches_, hook);
    if (!res.ok()) return fail(res.status());
    v1::AnalyzeResult* r = response->add_results();
    FillResult(res->result.analysis, r);
    nlohmann::json j = cli::AnalysisJson(res->result.analysis);
    j["timings"] = cli::TimingsJson(res->result.timings);
    r->set_analysis_json(j.dump(2));
    response->mutable_cache()->set_lighting_hit(res->lighting_hit);
    response->mutable_cache()->set_brdf_hit(res->brdf_hit);
    Metrics::Global().RecordCache("lighting", res->lighting_hit);
    Metrics::Global().RecordCache("brdf", res->brdf_hit);
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

namespace {

// |length - 1| below which a request direction counts as unit (a few ulps of rounding).
constexpr double kUnitTolerance = 1e-14;

// A request direction as a unit vector; InvalidArgument for a missing, zero or non-finite one.
absl::StatusOr<Vec3> UnitDirection(const v1::ReferenceRequest& request, bool view) {
  const char* name = view ? "view" : "index";
  if (!(view ? request.has_view() : request.has_index())) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": required"));
  }
  const v1::Direction& d = view ? request.view() : request.index();
  const Vec3 v{d.x(), d.y(), d.z()};
  const double len = v.Norm();
  if (!std::isfinite(len) || len < 1e-12) {
    return absl::InvalidArgumentError(
        absl::StrCat(name, ": (", d.x(), ", ", d.y(), ", ", d.z(), ") is not a direction"));
  }
  // Unit vectors (what the CLI sends) are used as they are, so the sum is the embedded run's
  // bit for bit; others are normalized.
  if (std::abs(len - 1) <= kUnitTolerance) return v;
  return v * (1.0 / len);
}

// A pinned environment, decoded between stage checks (before decoding and before `next_stage`);
// errors name blobs, not spool files.
struct DecodedEnv {
  PinnedEnv pinned;
  EnvMap map;
};
absl::StatusOr<DecodedEnv> PinAndDecode(grpc::ServerContext* context, const v1::Environment& env,
                                        BlobStore* blobs, std::string_view next_stage) {
  SHRM_ASSIGN_OR_RETURN(PinnedEnv pinned, PinEnvironment(env, blobs));
  SHRM_RETURN_IF_ERROR(CheckStage(context, "decode"));
  absl::StatusOr<EnvMap> map = EnvMap::Load(pinned.options);
  if (!map.ok()) return HideSpoolPaths(map.status(), &pinned);
  SHRM_RETURN_IF_ERROR(CheckStage(context, next_stage));
  return DecodedEnv{std::move(pinned), *std::move(map)};
}

}  // namespace

grpc::Status ShrmServiceImpl::Reference(grpc::ServerContext* context,
                                        const v1::ReferenceRequest* request,
                                        v1::ReferenceResponse* response) {
  RequestLog log(context, "Reference");
  auto fail = [&](const absl::Status& s) { return log.Finish(ToGrpcStatus(s)); };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit(context);
  if (!slot.ok()) return fail(slot.status());
  absl::StatusOr<RequestBrdf> brdf =
      ParseRequestBrdf(request->brdf(), request->brdf_blob_sha256(), "", blobs_.get());
  if (!brdf.ok()) return fail(brdf.status());
  absl::StatusOr<Vec3> index = UnitDirection(*request, /*view=*/false);
  if (!index.ok()) return fail(index.status());
  absl::StatusOr<Vec3> view = UnitDirection(*request, /*view=*/true);
  if (!view.ok()) return fail(view.status());
  absl::StatusOr<DecodedEnv> env =
      PinAndDecode(context, request->environment(), blobs_.get(), "reference");
  if (!env.ok()) return fail(env.status());
  const std::array<double, 3> rgb =
      BrdfReferenceRadiance(env->map.samples(), *brdf->brdf, env->pinned.rotation, *index, *view);
  for (double c : rgb) response->add_rgb(c);
  return log.Finish(grpc::Status::OK);
}

grpc::Status ShrmServiceImpl::Irradiance(grpc::ServerContext* context,
                                         const v1::IrradianceRequest* request,
                                         v1::IrradianceResponse* response) {
  RequestLog log(context, "Irradiance");
  auto fail = [&](const absl::Status& s) { return log.Finish(ToGrpcStatus(s)); };
  absl::StatusOr<std::unique_ptr<JobSlot>> slot = Admit(context);
  if (!slot.ok()) return fail(slot.status());
  absl::StatusOr<DecodedEnv> env =
      PinAndDecode(context, request->environment(), blobs_.get(), "lighting");
  if (!env.ok()) return fail(env.status());
  // The CLI's computation (client/cmd_outputs.cc): L_lm to l = 2, then A_l.
  absl::StatusOr<std::vector<double>> light =
      LightingCoefficients(env->map, 2, env->pinned.rotation, options_.job_threads);
  if (!light.ok()) return fail(light.status());
  absl::StatusOr<std::vector<double>> e9 = IrradianceCoefficients(2, 3, *light);
  if (!e9.ok()) return fail(e9.status());
  for (double c : *e9) response->add_coefficients(c);
  return log.Finish(grpc::Status::OK);
}

}  // namespace shrm::server
