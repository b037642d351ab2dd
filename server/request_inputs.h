// A request's inputs resolved against the blob store: the BRDF (analytic, or read from a BRDF
// blob and named by its hash) and the environment (its blobs pinned for the call, how core reads
// them, and the cache key of everything L_lm depends on besides the degree). Messages name blobs
// by hash, never by spool path (docs/server.md).
#ifndef SHRM_SERVER_REQUEST_INPUTS_H_
#define SHRM_SERVER_REQUEST_INPUTS_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "jobs/environment.h"
#include "proto/job_codec.h"
#include "server/blob_store.h"
#include "server/decoder_sandbox.h"

namespace shrm::server {

// The BRDF of a request and the spec its outputs record (shrm:brdf, report, response).
struct RequestBrdf {
  std::unique_ptr<Brdf> brdf;
  std::string display_spec;
};
// Analytic models: the spec string. File-based models travel as blobs ("table:@" / "merl:@" with
// blob_sha256); a spec naming a server file (table:PATH, merl:PATH) is refused.
absl::StatusOr<RequestBrdf> ResolveRequestBrdf(const wire::WireBrdf& brdf, BlobStore* blobs);

struct PinnedEnv {
  std::vector<std::unique_ptr<BlobStore::Lease>> leases;
  jobs::EnvironmentSpec spec;  // files: the client's names (shrm:source)
  EnvMapOptions options;       // paths: the pinned blob files
  jobs::SourceIdentity source;
  std::string key;  // cache key of L_lm (without the degree)
};
// NOT_FOUND (reason BLOB_NOT_FOUND) for a blob the server does not hold; each blob vetted by
// `guard` (decoded once in an isolated process, server/decoder_sandbox.h): its errors name the
// blob.
absl::StatusOr<PinnedEnv> PinEnvironment(const wire::WireEnvironment& env, BlobStore* blobs,
                                         DecodeGuard* guard);

// What decoding the pinned map will hold (jobs::MapBytes of its files' pixels, from their headers:
// read only for a job that decodes, after the blobs were vetted); errors name the blob.
absl::StatusOr<uint64_t> MapDecodeBytes(const PinnedEnv& env);
// The pinned map's input pixels (all files), from their headers; errors name the blob.
absl::StatusOr<int64_t> MapPixels(const PinnedEnv& env);

// Core messages name the spool files; clients know blobs by hash (`env` may be null).
absl::Status HideSpoolPaths(const absl::Status& status, const PinnedEnv* env);

}  // namespace shrm::server

#endif  // SHRM_SERVER_REQUEST_INPUTS_H_
