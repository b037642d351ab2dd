// The daemon's request validation (server/shrm_service.cc): what every RPC does with a request
// before any decoding or math, through the same functions the service calls:
//   Prefilter:  wire::DecodePrefilterRequest -> ResolveRequestBrdf -> PinEnvironment
//   Ibl:        wire::DecodeIblRequest -> PinEnvironment
//   Analyze:    ResolveRequestBrdf, jobs::ValidateAnalyzeEpsilons, DecodeEnvironment, Pin...
//   Reference:  ResolveRequestBrdf, jobs::UnitDirection (index, view), DecodeEnvironment, Pin...
//   Irradiance: DecodeEnvironment -> PinEnvironment
// against a blob store holding two blobs (a small SHRMBRDF table and a map), so valid hashes pin.
// Errors go through HideSpoolPaths as the service sends them.
//
// Input: byte 0 selects the RPC (bits 0-2) and the encoding (bit 3 set: the rest is the
// message's protobuf wire bytes, as gRPC delivers them; clear: the fields are built from the
// bytes with FuzzedDataProvider, which reaches the validation's branches sooner).
// Checked: no error message names a spool path; a decoded prefilter/IBL request encodes to a
// request that decodes to the same job (encode(decode(r)) is a fixed point).
#include <fuzzer/FuzzedDataProvider.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_table.h"
#include "core/io/sha256.h"
#include "fuzz/fuzz_util.h"
#include "jobs/analyze_job.h"
#include "jobs/point_jobs.h"
#include "proto/job_codec.h"
#include "server/blob_store.h"
#include "server/request_inputs.h"
#include "shrm/v1/shrm.pb.h"

namespace {

namespace v1 = shrm::v1;
namespace wire = shrm::wire;
using shrm::server::BlobStore;

struct Store {
  std::unique_ptr<BlobStore> blobs;
  std::vector<std::string> hashes;  // the table's, the map's
};

std::string Put(BlobStore* blobs, const std::string& bytes) {
  auto up = blobs->BeginUpload();
  shrm::fuzz::Check(up.ok() && (*up)->Append(bytes).ok(), "upload a blob");
  auto hash = blobs->Commit(up->get(), shrm::Sha256Hex(bytes));
  shrm::fuzz::Check(hash.ok(), "commit a blob");
  return *hash;
}

Store& TheStore() {
  static Store* store = [] {
    auto* s = new Store;
    auto blobs = BlobStore::Open(shrm::fuzz::ScratchDir() + "/spool", uint64_t{64} << 20);
    shrm::fuzz::Check(blobs.ok(), "open the blob store");
    s->blobs = std::move(*blobs);
    auto lambert = shrm::ParseBrdfSpec("lambert");
    auto table = shrm::SampleBrdfTable(**lambert, 2, 2, 1);
    const std::string table_path = shrm::fuzz::ScratchDir() + "/table.brdf";
    shrm::fuzz::Check(table.ok() && shrm::WriteBrdfTable(table_path, *table).ok(), "a table");
    std::ifstream in(table_path, std::ios::binary);
    s->hashes.push_back(Put(s->blobs.get(), std::string(std::istreambuf_iterator<char>(in), {})));
    s->hashes.push_back(Put(s->blobs.get(), "#?RADIANCE\nnot decoded before admission\n"));
    return s;
  }();
  return *store;
}

// A hash: one of the stored blobs', or any string.
std::string Hash(FuzzedDataProvider* fdp) {
  const int pick = fdp->ConsumeIntegralInRange(0, 3);
  if (pick < 2) return TheStore().hashes[pick];
  if (pick == 2) return shrm::Sha256Hex(fdp->ConsumeBytesAsString(4));
  return fdp->ConsumeRandomLengthString(70);
}

double Number(FuzzedDataProvider* fdp) {
  switch (fdp->ConsumeIntegralInRange(0, 3)) {
    case 0:
      return fdp->ConsumeFloatingPointInRange(0.0, 1.0);
    case 1:
      return fdp->ConsumeIntegralInRange(-4, 600);
    default:
      return fdp->ConsumeFloatingPoint<double>();
  }
}

std::string Text(FuzzedDataProvider* fdp) { return fdp->ConsumeRandomLengthString(48); }

void FillEnvironment(FuzzedDataProvider* fdp, v1::Environment* env) {
  const int n = fdp->ConsumeBool() ? 1 : fdp->ConsumeIntegralInRange(0, 7);
  for (int i = 0; i < n; ++i) env->add_sha256(Hash(fdp));
  env->set_layout(static_cast<v1::Layout>(fdp->ConsumeIntegralInRange(-1, 8)));
  if (fdp->ConsumeBool()) env->set_input_colour_space(Text(fdp));
  if (fdp->ConsumeBool()) env->set_working_colour_space(Text(fdp));
  if (fdp->ConsumeBool()) {
    env->mutable_rotation()->set_yaw_deg(Number(fdp));
    env->mutable_rotation()->set_pitch_deg(Number(fdp));
    env->mutable_rotation()->set_roll_deg(Number(fdp));
  }
  env->set_non_finite(static_cast<v1::NonFinitePolicy>(fdp->ConsumeIntegralInRange(-1, 3)));
  const int names = fdp->ConsumeIntegralInRange(0, 7);
  for (int i = 0; i < names; ++i) env->add_source_names(Text(fdp));
}

void FillBrdf(FuzzedDataProvider* fdp, std::string* spec, std::string* sha, std::string* display) {
  static const char* const kSpecs[] = {"table:@",   "merl:@",        "lambert",
                                       "phong:s=8", "ggx:alpha=0.3", "table:/etc/passwd"};
  *spec = fdp->ConsumeBool() ? std::string(fdp->PickValueInArray(kSpecs)) : Text(fdp);
  if (fdp->ConsumeBool()) *sha = Hash(fdp);
  if (fdp->ConsumeBool()) *display = Text(fdp);
}

void BuildPrefilter(FuzzedDataProvider* fdp, v1::PrefilterRequest* r) {
  if (fdp->ConsumeBool()) FillEnvironment(fdp, r->mutable_environment());
  FillBrdf(fdp, r->mutable_brdf(), r->mutable_brdf_blob_sha256(), r->mutable_brdf_display_spec());
  switch (fdp->ConsumeIntegralInRange(0, 3)) {
    case 1:
      r->set_epsilon(Number(fdp));
      break;
    case 2:
      r->mutable_orders()->set_f(fdp->ConsumeIntegralInRange(-2, 200));
      r->mutable_orders()->set_p(fdp->ConsumeIntegralInRange(-2, 40));
      break;
    case 3:
      r->set_tolerance(Number(fdp));
      break;
  }
  r->set_kind(static_cast<v1::ShrmKind>(fdp->ConsumeIntegralInRange(-1, 3)));
  r->set_face_size(fdp->ConsumeBool() ? fdp->ConsumeIntegral<int32_t>()
                                      : fdp->ConsumeIntegralInRange(-1, 4097));
  r->set_half(fdp->ConsumeBool());
  const int outputs = fdp->ConsumeIntegralInRange(0, 3);
  for (int i = 0; i < outputs; ++i)
    r->add_outputs(static_cast<v1::Output>(fdp->ConsumeIntegralInRange(-1, 3)));
  r->set_window(static_cast<v1::RingingWindow>(fdp->ConsumeIntegralInRange(-1, 3)));
  r->set_verify(fdp->ConsumeBool() ? fdp->ConsumeIntegral<int32_t>()
                                   : fdp->ConsumeIntegralInRange(-1, 100001));
}

void BuildIbl(FuzzedDataProvider* fdp, v1::IblRequest* r) {
  if (fdp->ConsumeBool()) FillEnvironment(fdp, r->mutable_environment());
  r->set_preset(static_cast<v1::IblPreset>(fdp->ConsumeIntegralInRange(-1, 5)));
  const int levels = fdp->ConsumeIntegralInRange(0, 16);
  for (int i = 0; i < levels; ++i) r->add_roughness(Number(fdp));
  r->set_face_size(fdp->ConsumeBool() ? fdp->ConsumeIntegral<int32_t>()
                                      : 1 << fdp->ConsumeIntegralInRange(0, 13));
  r->set_levels(fdp->ConsumeIntegralInRange(-1, 16));
  r->set_sheen(fdp->ConsumeBool());
  r->set_format(static_cast<v1::IblFormat>(fdp->ConsumeIntegralInRange(-1, 5)));
  r->set_irradiance_size(fdp->ConsumeIntegralInRange(-1, 1025));
  r->set_dfg_size(fdp->ConsumeIntegralInRange(-1, 1025));
  r->set_tolerance(Number(fdp));
  if (fdp->ConsumeBool()) r->set_verify(fdp->ConsumeIntegralInRange(-1, 100001));
  r->set_sh_window(static_cast<v1::IblShWindow>(fdp->ConsumeIntegralInRange(-1, 4)));
  static const char* const kDfg[] = {"", "auto", "none", "filament", "gltf-lut-ggx", "babylon"};
  r->set_dfg(fdp->ConsumeBool() ? std::string(fdp->PickValueInArray(kDfg)) : Text(fdp));
  static const char* const kContainers[] = {"", "all", "ktx2", "ktx1,gltf", "ktx2,ktx2"};
  r->set_containers(fdp->ConsumeBool() ? std::string(fdp->PickValueInArray(kContainers))
                                       : Text(fdp));
  r->set_preview(fdp->ConsumeBool());
}

void BuildAnalyze(FuzzedDataProvider* fdp, v1::AnalyzeRequest* r) {
  if (fdp->ConsumeBool()) FillEnvironment(fdp, r->mutable_environment());
  FillBrdf(fdp, r->mutable_brdf(), r->mutable_brdf_blob_sha256(), r->mutable_brdf_display_spec());
  const int n = fdp->ConsumeIntegralInRange(0, 6);
  for (int i = 0; i < n; ++i) r->add_epsilon(Number(fdp));
}

void BuildReference(FuzzedDataProvider* fdp, v1::ReferenceRequest* r) {
  if (fdp->ConsumeBool()) FillEnvironment(fdp, r->mutable_environment());
  std::string display;
  FillBrdf(fdp, r->mutable_brdf(), r->mutable_brdf_blob_sha256(), &display);
  for (v1::Direction* d : {r->mutable_index(), r->mutable_view()}) {
    if (!fdp->ConsumeBool()) continue;
    d->set_x(Number(fdp));
    d->set_y(Number(fdp));
    d->set_z(Number(fdp));
  }
  if (fdp->ConsumeBool()) r->clear_index();
}

// Set per input: the request itself holds the spool folder's path (messages may echo it).
bool request_names_spool = false;

// Errors as the service sends them: core's messages name blobs, never spool files.
void CheckSent(const absl::Status& s, const shrm::server::PinnedEnv* env) {
  const absl::Status sent = shrm::server::HideSpoolPaths(s, env);
  shrm::fuzz::Check(sent.ok() == s.ok(), "HideSpoolPaths keeps the outcome");
  shrm::fuzz::Check(
      request_names_spool || sent.message().find(TheStore().blobs->dir()) == std::string::npos,
      "no message names a spool path");
}

absl::StatusOr<shrm::server::PinnedEnv> Pin(const wire::WireEnvironment& env) {
  static shrm::server::DecodeGuard no_isolation(nullptr, {});  // maps are not decoded here
  absl::StatusOr<shrm::server::PinnedEnv> pinned =
      shrm::server::PinEnvironment(env, TheStore().blobs.get(), &no_isolation);
  CheckSent(pinned.status(), nullptr);
  if (pinned.ok()) {
    for (const auto& lease : pinned->leases)
      shrm::fuzz::Check(shrm::IsSha256Hex(lease->sha256()), "only hashes are pinned");
  }
  return pinned;
}

absl::Status Brdf(const wire::WireBrdf& brdf) {
  absl::StatusOr<shrm::server::RequestBrdf> b =
      shrm::server::ResolveRequestBrdf(brdf, TheStore().blobs.get());
  CheckSent(b.status(), nullptr);
  return b.status();
}

absl::Status EnvironmentOf(const v1::Environment& env) {
  absl::StatusOr<wire::WireEnvironment> w = wire::DecodeEnvironment(env);
  CheckSent(w.status(), nullptr);
  if (!w.ok()) return w.status();
  return Pin(*w).status();
}

void Prefilter(const v1::PrefilterRequest& r) {
  absl::StatusOr<wire::WirePrefilter> p = wire::DecodePrefilterRequest(r);
  CheckSent(p.status(), nullptr);
  if (!p.ok()) return;
  // The client's encoding of the decoded job decodes to the same job.
  v1::Environment env;
  if (wire::EncodeEnvironment(p->job.env, p->sha256, &env).ok()) {
    const v1::PrefilterRequest again = wire::EncodePrefilterRequest(p->job, env, p->brdf);
    absl::StatusOr<wire::WirePrefilter> q = wire::DecodePrefilterRequest(again);
    shrm::fuzz::Check(q.ok(), "a decoded prefilter request encodes to a valid request");
    shrm::fuzz::Check(wire::EncodePrefilterRequest(q->job, env, q->brdf).SerializeAsString() ==
                          again.SerializeAsString(),
                      "prefilter requests: encode(decode(r)) is a fixed point");
  }
  if (!Brdf(p->brdf).ok()) return;
  (void)Pin({p->job.env, p->sha256});
}

void Ibl(const v1::IblRequest& r) {
  absl::StatusOr<wire::WireIbl> p = wire::DecodeIblRequest(r);
  CheckSent(p.status(), nullptr);
  if (!p.ok()) return;
  v1::Environment env;
  if (wire::EncodeEnvironment(p->job.env, p->sha256, &env).ok()) {
    const v1::IblRequest again = wire::EncodeIblRequest(p->job, env);
    absl::StatusOr<wire::WireIbl> q = wire::DecodeIblRequest(again);
    shrm::fuzz::Check(q.ok(), "a decoded IBL request encodes to a valid request");
    shrm::fuzz::Check(
        wire::EncodeIblRequest(q->job, env).SerializeAsString() == again.SerializeAsString(),
        "IBL requests: encode(decode(r)) is a fixed point");
  }
  (void)Pin({p->job.env, p->sha256});
}

void Analyze(const v1::AnalyzeRequest& r) {
  if (!Brdf({r.brdf(), r.brdf_blob_sha256(), r.brdf_display_spec()}).ok()) return;
  std::vector<double> eps(r.epsilon().begin(), r.epsilon().end());
  if (!eps.empty() && !shrm::jobs::ValidateAnalyzeEpsilons(eps).ok()) return;
  if (r.has_environment()) (void)EnvironmentOf(r.environment());
}

void Reference(const v1::ReferenceRequest& r) {
  if (!Brdf({r.brdf(), r.brdf_blob_sha256(), ""}).ok()) return;
  if (!r.has_index() || !r.has_view()) return;
  for (const v1::Direction* d : {&r.index(), &r.view()}) {
    if (!shrm::jobs::UnitDirection(shrm::Vec3{d->x(), d->y(), d->z()}, "index").ok()) return;
  }
  (void)EnvironmentOf(r.environment());
}

template <typename Message, typename Build, typename Validate>
void Run(bool wire_bytes, FuzzedDataProvider* fdp, const Build& build, const Validate& validate) {
  Message m;
  if (wire_bytes) {
    const std::string bytes = fdp->ConsumeRemainingBytesAsString();
    if (!m.ParseFromString(bytes)) return;
  } else {
    build(fdp, &m);
  }
  request_names_spool = m.SerializeAsString().find(TheStore().blobs->dir()) != std::string::npos;
  validate(m);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  TheStore();
  const int rpc = data[0] & 7;
  const bool wire_bytes = data[0] & 8;
  FuzzedDataProvider fdp(data + 1, size - 1);
  switch (rpc % 5) {
    case 0:
      Run<v1::PrefilterRequest>(wire_bytes, &fdp, BuildPrefilter, Prefilter);
      break;
    case 1:
      Run<v1::IblRequest>(wire_bytes, &fdp, BuildIbl, Ibl);
      break;
    case 2:
      Run<v1::AnalyzeRequest>(wire_bytes, &fdp, BuildAnalyze, Analyze);
      break;
    case 3:
      Run<v1::ReferenceRequest>(wire_bytes, &fdp, BuildReference, Reference);
      break;
    case 4:
      Run<v1::IrradianceRequest>(
          wire_bytes, &fdp,
          [](FuzzedDataProvider* f, v1::IrradianceRequest* r) {
            FillEnvironment(f, r->mutable_environment());
          },
          [](const v1::IrradianceRequest& r) { (void)EnvironmentOf(r.environment()); });
      break;
  }
  return 0;
}
