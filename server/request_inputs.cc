#include "server/request_inputs.h"

#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "core/base/status_macros.h"
#include "core/io/image.h"
#include "core/io/sha256.h"
#include "jobs/memory_estimate.h"

namespace shrm::server {
namespace {

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
  void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                          double* out) const override {
    inner_->ReparamTransferArc(theta_i, theta_o, phi, out);
  }
  bool analytic() const override { return inner_->analytic(); }

 private:
  std::unique_ptr<Brdf> inner_;
  std::string spec_;
};

}  // namespace

absl::StatusOr<RequestBrdf> ResolveRequestBrdf(const wire::WireBrdf& in, BlobStore* blobs) {
  if (in.spec.empty()) return absl::InvalidArgumentError("brdf: a BRDF spec is required");
  RequestBrdf out;
  std::string model;
  const std::optional<std::string> file = BrdfSpecFile(in.spec, &model);
  if (file) {
    if (*file != "@") {
      return absl::InvalidArgumentError(
          absl::StrCat("brdf: '", model,
                       ":' specs name files, which the service does not read; "
                       "upload the file and send '",
                       model, ":@' with brdf_blob_sha256"));
    }
    if (!IsSha256Hex(in.blob_sha256)) {
      return absl::InvalidArgumentError(absl::StrCat("brdf_blob_sha256: '", model,
                                                     ":@' needs the BRDF blob's hash (64 "
                                                     "lowercase hex digits)"));
    }
    absl::StatusOr<std::unique_ptr<BlobStore::Lease>> lease = blobs->Pin(in.blob_sha256);
    if (!lease.ok()) {
      return WithMessage(lease.status(),
                         absl::StrCat("brdf_blob_sha256: BRDF ", lease.status().message()));
    }
    // The model reads the whole file now; the lease only has to outlive the parse.
    const std::string path = (*lease)->path();
    absl::StatusOr<std::unique_ptr<Brdf>> parsed = ParseBrdfSpec(absl::StrCat(model, ":", path));
    if (!parsed.ok()) {
      // Core's message names the file: name the blob instead.
      const std::string name = absl::StrCat("BRDF blob ", in.blob_sha256);
      const absl::string_view msg = parsed.status().message();
      return absl::InvalidArgumentError(
          absl::StrContains(msg, path)
              ? absl::StrCat("brdf: ", absl::StrReplaceAll(msg, {{path, name}}))
              : absl::StrCat("brdf: ", name, ": ", msg));
    }
    const std::string key_spec = absl::StrCat(model, ":@", in.blob_sha256);
    out.brdf = std::make_unique<BlobBrdf>(std::move(*parsed), key_spec);
    out.display_spec = in.display_spec.empty() ? key_spec : in.display_spec;
    return out;
  }
  if (!in.blob_sha256.empty() || !in.display_spec.empty()) {
    return absl::InvalidArgumentError(
        "brdf_blob_sha256 and brdf_display_spec go only with a 'table:@' or 'merl:@' brdf");
  }
  absl::StatusOr<std::unique_ptr<Brdf>> brdf = ParseBrdfSpec(in.spec);
  if (!brdf.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("brdf: ", brdf.status().message()));
  }
  out.brdf = std::move(*brdf);
  out.display_spec = out.brdf->spec();
  return out;
}

absl::StatusOr<PinnedEnv> PinEnvironment(const wire::WireEnvironment& env, BlobStore* blobs,
                                         DecodeGuard* guard) {
  PinnedEnv p;
  std::vector<std::string> paths;
  for (const std::string& h : env.sha256) {
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<BlobStore::Lease> lease, blobs->Pin(h));
    paths.push_back(lease->path());
    p.leases.push_back(std::move(lease));
  }
  p.spec = env.spec;
  p.options = jobs::EnvMapOptionsFor(env.spec, paths);
  p.options.colour_config.clear();  // the server's own config ($OCIO or built in)
  for (const auto& lease : p.leases) {
    SHRM_RETURN_IF_ERROR(
        HideSpoolPaths(guard->Vet(lease->sha256(), lease->path(), p.options.limits), &p));
  }
  p.source = {absl::StrJoin(env.spec.files, ","), jobs::CombinedSourceSha256(env.sha256)};
  const std::string rot_key =
      env.spec.rotate_ypr_deg
          ? absl::StrFormat("%a,%a,%a", (*env.spec.rotate_ypr_deg)[0],
                            (*env.spec.rotate_ypr_deg)[1], (*env.spec.rotate_ypr_deg)[2])
          : std::string("none");
  p.key =
      absl::StrCat(absl::StrJoin(env.sha256, ","), "|layout=", static_cast<int>(p.options.layout),
                   "|in=", p.options.input_colour_space, "|work=", p.options.working_colour_space,
                   "|nonfinite=", static_cast<int>(p.options.non_finite), "|rot=", rot_key);
  return p;
}

absl::StatusOr<int64_t> MapPixels(const PinnedEnv& env) {
  int64_t pixels = 0;
  for (const auto& lease : env.leases) {
    absl::StatusOr<ImageHeader> header = ProbeImage(lease->path(), env.options.limits);
    if (!header.ok()) return HideSpoolPaths(header.status(), &env);
    pixels += static_cast<int64_t>(header->width) * header->height;
  }
  return pixels;
}

absl::StatusOr<uint64_t> MapDecodeBytes(const PinnedEnv& env) {
  SHRM_ASSIGN_OR_RETURN(const int64_t pixels, MapPixels(env));
  return jobs::MapBytes(pixels);
}

absl::Status HideSpoolPaths(const absl::Status& status, const PinnedEnv* env) {
  if (status.ok() || env == nullptr) return status;
  std::string msg(status.message());
  for (const auto& lease : env->leases) {
    msg = absl::StrReplaceAll(msg, {{lease->path(), absl::StrCat("blob ", lease->sha256())}});
  }
  return WithMessage(status, std::move(msg));
}

}  // namespace shrm::server
