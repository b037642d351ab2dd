// Jobs run on an shrm server (docs/server.md): the job layer's descriptions (jobs/) sent through
// the client library, with their inputs uploaded by hash and the whole job retried when that can
// succeed. Used by `shrm ... --server`, `shrm batch --server` and `shrm-view --server`.
#ifndef SHRM_CLIENT_REMOTE_JOBS_H_
#define SHRM_CLIENT_REMOTE_JOBS_H_

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "client/shrm_client.h"
#include "jobs/environment.h"
#include "jobs/ibl_job.h"
#include "jobs/prefilter_job.h"
#include "shrm/v1/shrm.pb.h"

namespace shrm::client {

// Uploads the environment's files the server lacks and describes them for a request (errors
// name the file). Options a server cannot honour (an OCIO config file) are refused.
absl::Status UploadEnvironment(const jobs::EnvironmentSpec& env, ShrmClient* client,
                               shrm::v1::Environment* out);

// `message` with each "blob <sha256>" of `files` (uploaded files by their paths, each's SHA-256)
// replaced by the path: the server names an input by its blob (never by a path of its own), the
// user by the file uploaded as that blob.
std::string NameUploadedFiles(std::string message,
                              const std::vector<std::pair<std::string, std::string>>& files);

// Called before each retry of a remote job with the failure and the attempt about to start.
using RetryCallback =
    std::function<void(const absl::Status& failure, int attempt, int max_attempts)>;

// Runs one idempotent remote job: `attempt` uploads what the server lacks, then calls it.
// Retried whole, with backoff, on transient errors (IsTransient), on RESOURCE_EXHAUSTED with a
// retry delay (every job slot busy; the delay is waited too) and on missing blobs (IsMissingBlob:
// behind a load balancer the call may reach a replica the inputs were never uploaded to; after k
// such answers k + 1 copies are uploaded). The map's SHA-256 (one file) is the calls' affinity
// key. `retries` (optional) gets the attempts beyond the first, counting the calls the client sent
// again by itself (ShrmClient::resent_calls). Errors are prefixed with the
// server's target (and the number of retries), and name the map's files and `other_files` (a
// BRDF table or MERL file the job uploads) where the server names their blobs.
absl::Status RunRemoteJob(ShrmClient* client, const jobs::EnvironmentSpec& env,
                          const std::string& target, const std::function<absl::Status()>& attempt,
                          const RetryCallback& on_retry = nullptr, int* retries = nullptr,
                          const std::vector<std::string>& other_files = {});

// The file of a table:PATH or merl:PATH BRDF spec (none for an analytic model): RunRemoteJob's
// other_files.
std::vector<std::string> BrdfFiles(const std::string& spec);

// What a front end sees of a remote job besides its result.
struct RemoteJobOptions {
  ProgressCallback progress;  // each server stage
  RetryCallback on_retry;
  std::function<void()> on_upload_start, on_upload_end;
  bool report_visuals = false;  // prefilter: also the visual report's data
};

// A prefilter job on the server: the SHRM file it returns is byte-identical to the embedded
// run's (tests/service_test.cc).
using RemotePrefilterOptions = RemoteJobOptions;
struct RemotePrefilterResult {
  PrefilterOutcome outcome;  // the report and the file
  int retries = 0;
};
absl::StatusOr<RemotePrefilterResult> RunRemotePrefilter(ShrmClient* client,
                                                         const std::string& target,
                                                         const jobs::PrefilterJob& job,
                                                         const RemotePrefilterOptions& options,
                                                         int* retries = nullptr);

// An IBL job on the server: the files it returns are byte-identical to the embedded run's
// (jobs::EncodeIblOutputs on both sides; tests/ibl_service_test.cc).
struct RemoteIblResult {
  IblCallOutcome outcome;  // the report and the files
  int retries = 0;
};
absl::StatusOr<RemoteIblResult> RunRemoteIbl(ShrmClient* client, const std::string& target,
                                             const jobs::IblJob& job,
                                             const RemoteJobOptions& options);

}  // namespace shrm::client

#endif  // SHRM_CLIENT_REMOTE_JOBS_H_
