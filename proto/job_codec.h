// Jobs on the wire: the one mapping between the job layer's descriptions (jobs/) and the
// shrm.v1 request messages, used by the client side to build requests and by the server to read
// them. Map files travel as blob hashes (uploaded first: docs/server.md); the names the client
// knows them by go along, so that outputs record the same shrm:source as an embedded run. A
// request decoded from an encoded job is that job again (tests/job_front_ends_test.cc).
#ifndef SHRM_PROTO_JOB_CODEC_H_
#define SHRM_PROTO_JOB_CODEC_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "jobs/ibl_job.h"
#include "jobs/prefilter_job.h"
#include "shrm/v1/shrm.pb.h"

namespace shrm::wire {

absl::StatusOr<EnvLayout> LayoutFromProto(shrm::v1::Layout layout);
shrm::v1::Layout LayoutToProto(EnvLayout layout);

// The environment of a request: the spec (files = the source names, or the hashes when the
// client sent none) and the blobs holding the files.
struct WireEnvironment {
  jobs::EnvironmentSpec spec;
  std::vector<std::string> sha256;  // 64 lowercase hex digits each, one or six
};
// InvalidArgument for options a server cannot honour (an OCIO config file of the client) and for
// an invalid environment (jobs::ValidateEnvironment).
absl::Status CheckRemoteEnvironment(const jobs::EnvironmentSpec& env);
// CheckRemoteEnvironment, then the message.
absl::Status EncodeEnvironment(const jobs::EnvironmentSpec& env,
                               const std::vector<std::string>& sha256, shrm::v1::Environment* out);
// InvalidArgument naming the field for malformed hashes, counts, enums and angles.
absl::StatusOr<WireEnvironment> DecodeEnvironment(const shrm::v1::Environment& env);

// The BRDF fields of a request: an analytic spec as it is, or for a file-based BRDF
// ("table:PATH", "merl:PATH") "table:@" / "merl:@" with the uploaded file's hash and the spec the
// outputs record (the client's "table:PATH").
struct WireBrdf {
  std::string spec;
  std::string blob_sha256;
  std::string display_spec;
  bool operator==(const WireBrdf&) const = default;
};

// `visuals`: also ask for the visual report's data (OUTPUT_REPORT_VISUALS).
shrm::v1::PrefilterRequest EncodePrefilterRequest(const jobs::PrefilterJob& job,
                                                  const shrm::v1::Environment& env,
                                                  const WireBrdf& brdf, bool visuals = false);
struct WirePrefilter {
  jobs::PrefilterJob job;  // job.brdf: WireBrdf::spec; job.env: WireEnvironment::spec
  std::vector<std::string> sha256;
  WireBrdf brdf;
  bool want_file = true;
  bool want_report = true;
  bool want_visuals = false;  // OUTPUT_REPORT_VISUALS
};
// Decodes and validates (jobs::ValidatePrefilterJob); errors name the request field.
absl::StatusOr<WirePrefilter> DecodePrefilterRequest(const shrm::v1::PrefilterRequest& request);

// The IBL job (jobs/ibl_job.h): every option, explicitly (the request's zero defaults are for
// hand-written clients).
shrm::v1::IblRequest EncodeIblRequest(const jobs::IblJob& job, const shrm::v1::Environment& env);
struct WireIbl {
  jobs::IblJob job;  // job.env: WireEnvironment::spec
  std::vector<std::string> sha256;
};
// Decodes and validates (jobs::ValidateIblJob); InvalidArgument naming the request field.
absl::StatusOr<WireIbl> DecodeIblRequest(const shrm::v1::IblRequest& request);

}  // namespace shrm::wire

#endif  // SHRM_PROTO_JOB_CODEC_H_
