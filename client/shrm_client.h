// Client library of the shrm service (shrm.v1.Shrm, docs/server.md): typed calls returning
// absl::StatusOr, with the server's error details (proto/status_details.h) as payloads.
// Idempotent calls (HasBlob, UploadBlob, Analyze, ListBrdfModels, Reference, Irradiance) are
// retried on transient errors (IsTransient) with exponential backoff. Prefilter is sent again only
// when it failed in the transport before any server answered; otherwise a retry may need the
// inputs uploaded again (another replica), so callers retry the whole job (client/remote_jobs.h),
// which is idempotent (the same request gives the same bytes).
#ifndef SHRM_CLIENT_SHRM_CLIENT_H_
#define SHRM_CLIENT_SHRM_CLIENT_H_

#include <array>
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "proto/job_codec.h"
#include "shrm/v1/shrm.grpc.pb.h"

namespace shrm::client {

struct ClientOptions {
  int max_attempts = 6;  // per idempotent call (and per remote job), including the first
  absl::Duration initial_backoff = absl::Milliseconds(100);
  absl::Duration max_backoff = absl::Seconds(2);
  // Deadline of each idempotent call attempt (uploads: per attempt of the whole blob).
  absl::Duration call_timeout = absl::Minutes(5);
  // Open this client's own TCP connection(s) instead of sharing gRPC's process-wide pool with
  // other clients of the same target (load tests: N clients = N connections).
  bool own_connection = false;

  // Security (docs/server.md, "Security"). Empty fields fall back to the environment variables
  // SHRM_TOKEN_FILE, SHRM_TLS_CA, SHRM_TLS_CERT, SHRM_TLS_KEY (so `shrm --server` picks them up).
  // TLS when tls_ca_file or tls_cert_file is set (client certificate for mutual TLS with both
  // tls_cert_file and tls_key_file); else local credentials (loopback only) when a token is
  // set; else an insecure channel. The token goes in `authorization: Bearer <token>`.
  std::string token;       // the bearer token itself (wins over token_file)
  std::string token_file;  // a file whose first non-blank, non-'#' line is the token
  std::string tls_ca_file;
  std::string tls_cert_file;
  std::string tls_key_file;
  std::string tls_server_name;  // overrides the name checked against the server certificate
};

struct PrefilterOutcome {
  shrm::v1::PrefilterReport report;  // report.report_json: the CLI's --report JSON
  std::string shrm_file;             // the SHRM file bytes, SHA-256 verified
  std::string shrm_sha256;
};

// One output file of an Ibl call.
struct ReceivedFile {
  std::string name;    // file name inside the output folder
  std::string bytes;   // SHA-256 verified
  std::string sha256;  // of `bytes`
};
struct IblCallOutcome {
  shrm::v1::IblReport report;       // report.report_json: the job's report (jobs::IblReportJson)
  std::vector<ReceivedFile> files;  // in the order of report.files
};

// Called for every progress event (the stage starting and the fraction of stages done).
using ProgressCallback = std::function<void(const shrm::v1::PrefilterProgress&)>;

// One frame of a live call (docs/live.md): the SHRM file of the state after request `update`.
struct LiveFrameOutcome {
  uint64_t update = 0;   // the last request the frame includes
  uint64_t dropped = 0;  // states the server did not compute so far
  int f_b = 0, p_b = 0;
  std::vector<shrm::v1::StageTiming> timings;
  std::string shrm_file;  // SHA-256 verified; empty with LiveOpen.view_only
  // With a view set (LiveRequest.view): the frame's view (normalized) and its view map, a
  // horizontal-cross float EXR (jobs::RadianceCrossImage), SHA-256 verified.
  std::optional<std::array<double, 3>> view;
  std::string view_file;
  // With LiveOpen.ibl: the frame's split-sum set, the Ibl call's files (SHA-256 verified).
  std::vector<ReceivedFile> ibl_files;
};

// A live call: Send updates (false once the call has ended: Finish says why), CloseSending after
// the last, Next for each frame (nullopt once the server has ended the call), then Finish.
// One thread may Send while another reads (gRPC allows one of each at a time).
class LiveCall {
 public:
  bool Send(const shrm::v1::LiveRequest& request) { return stream_->Write(request); }
  bool CloseSending() { return stream_->WritesDone(); }
  absl::StatusOr<std::optional<LiveFrameOutcome>> Next();
  absl::Status Finish();
  void Cancel() { context_.TryCancel(); }

 private:
  friend class ShrmClient;
  LiveCall() = default;
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReaderWriter<shrm::v1::LiveRequest, shrm::v1::LiveEvent>> stream_;
  bool view_only_ = false;
};

class ShrmClient {
 public:
  // `target`: "host:port" or "dns:///host:port" (round-robin over the resolved addresses).
  // Credentials from `options` (see ClientOptions). Does not wait for the connection.
  static absl::StatusOr<std::unique_ptr<ShrmClient>> Connect(const std::string& target,
                                                             const ClientOptions& options = {});

  absl::StatusOr<shrm::v1::HasBlobResponse> HasBlob(const std::string& sha256);
  // Streams `bytes` (1 MiB chunks) under its SHA-256; returns the hash the server verified.
  absl::StatusOr<std::string> UploadBytes(std::string_view bytes);
  // The file's SHA-256; uploads it only when the server does not have it. With
  // set_upload_copies(k), k > 0, it skips the question and uploads k times in a row instead.
  absl::StatusOr<std::string> UploadIfMissing(const std::string& path);

  // Routing hints for jobs behind a load balancer (docs/deploy.md):
  // - the affinity key (the SHA-256 of the job's map) goes with every call as metadata
  //   `x-shrm-affinity`, so a proxy hashing on it (nginx `hash $http_x_shrm_affinity`) sends the
  //   uploads and the job of one map to the same replica, whose caches then hit;
  // - upload copies: after a replica answered NOT_FOUND for a blob, uploading k times in a row
  //   puts the blob on k replicas of a round-robin channel (consecutive calls go to distinct
  //   replicas), so the retried job finds it wherever it lands.
  void set_affinity_key(std::string key) { affinity_key_ = std::move(key); }
  void set_upload_copies(int copies) { upload_copies_ = copies; }
  // Runs the job; `deadline` is relative (absl::InfiniteDuration() for none). The file is
  // checked against the SHA-256 of the last chunk (DataLoss on a mismatch).
  // `cancel` (optional) is read after every event: once true, the call is cancelled (the server
  // stops the job before its next stage) and Prefilter returns CANCELLED.
  absl::StatusOr<PrefilterOutcome> Prefilter(const shrm::v1::PrefilterRequest& request,
                                             const ProgressCallback& progress = nullptr,
                                             absl::Duration deadline = absl::InfiniteDuration(),
                                             const std::atomic<bool>* cancel = nullptr);
  // The IBL job (`shrm ibl`): sent again as Prefilter is; every file is checked against the
  // SHA-256 of its last chunk, and the files must be those the report lists (DataLoss).
  absl::StatusOr<IblCallOutcome> Ibl(const shrm::v1::IblRequest& request,
                                     const ProgressCallback& progress = nullptr,
                                     absl::Duration deadline = absl::InfiniteDuration(),
                                     const std::atomic<bool>* cancel = nullptr);
  absl::StatusOr<shrm::v1::AnalyzeResponse> Analyze(
      const shrm::v1::AnalyzeRequest& request, absl::Duration deadline = absl::InfiniteDuration());
  absl::StatusOr<shrm::v1::ListBrdfModelsResponse> ListBrdfModels();
  // `shrm reference` and `shrm irradiance` on the server (retried on transient errors).
  absl::StatusOr<shrm::v1::ReferenceResponse> Reference(
      const shrm::v1::ReferenceRequest& request,
      absl::Duration deadline = absl::InfiniteDuration());
  absl::StatusOr<shrm::v1::IrradianceResponse> Irradiance(
      const shrm::v1::IrradianceRequest& request,
      absl::Duration deadline = absl::InfiniteDuration());

  // Opens a live session (sends `open` as request 0); `deadline` bounds the whole call. Not
  // retried (the session's state is the call's).
  absl::StatusOr<std::unique_ptr<LiveCall>> OpenLive(
      const shrm::v1::LiveOpen& open, absl::Duration deadline = absl::InfiniteDuration());

  const ClientOptions& options() const { return options_; }
  // SHA-256 of a file, remembered per path while its size and modification time stay the same
  // (a job's retries and the affinity key hash a map once).
  absl::StatusOr<std::string> FileSha256(const std::string& path);

  // The server's retry delay (RetryInfo) of the last RESOURCE_EXHAUSTED answer, ms (0: none).
  int64_t last_retry_after_ms() const { return last_retry_after_ms_; }
  // Prefilter and Ibl calls sent again because the transport failed before any answer (a
  // replica killed while the call was on its way): a job's retries count them (remote_jobs.h).
  int resent_calls() const { return resent_calls_.load(); }

 private:
  ShrmClient(std::shared_ptr<grpc::Channel> channel, const ClientOptions& options);
  // Runs `attempt` (returning a grpc::Status) until it is not UNAVAILABLE or attempts run out.
  absl::Status WithRetries(const std::function<grpc::Status(grpc::ClientContext*)>& attempt,
                           absl::Duration deadline);
  // One idempotent unary call with retries (WithRetries); `method` is the stub's blocking method.
  template <typename Request, typename Response>
  absl::StatusOr<Response> Unary(grpc::Status (shrm::v1::Shrm::Stub::*method)(grpc::ClientContext*,
                                                                              const Request&,
                                                                              Response*),
                                 const Request& request, absl::Duration deadline) {
    Response resp;
    absl::Status s = WithRetries(
        [&](grpc::ClientContext* c) {
          resp.Clear();
          return (stub_.get()->*method)(c, request, &resp);
        },
        deadline);
    if (!s.ok()) return s;
    return resp;
  }
  // Adds the bearer token (when there is one) to a call's metadata.
  void Authorize(grpc::ClientContext* context) const;
  // One streaming call; *answered: the server sent an event.
  template <typename Request, typename Outcome>
  using OnceCall = absl::StatusOr<Outcome> (ShrmClient::*)(const Request&, const ProgressCallback&,
                                                           absl::Duration,
                                                           const std::atomic<bool>* cancel,
                                                           bool* answered);
  // Runs `once` again only while it fails in the transport before any answer of a server.
  template <typename Request, typename Outcome>
  absl::StatusOr<Outcome> SendUntilAnswered(OnceCall<Request, Outcome> once, const Request& request,
                                            const ProgressCallback& progress,
                                            absl::Duration deadline,
                                            const std::atomic<bool>* cancel);
  // One Prefilter call; *answered: the server sent an event.
  absl::StatusOr<PrefilterOutcome> PrefilterOnce(const shrm::v1::PrefilterRequest& request,
                                                 const ProgressCallback& progress,
                                                 absl::Duration deadline,
                                                 const std::atomic<bool>* cancel, bool* answered);
  absl::StatusOr<IblCallOutcome> IblOnce(const shrm::v1::IblRequest& request,
                                         const ProgressCallback& progress, absl::Duration deadline,
                                         const std::atomic<bool>* cancel, bool* answered);
  // A call's final status as absl::Status (wire::FromGrpcStatus); notes its retry delay.
  absl::Status Received(const grpc::Status& status);
  grpc::Status UploadOnce(grpc::ClientContext* context, std::string_view bytes,
                          const std::string& sha256, std::string* verified);

  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<shrm::v1::Shrm::Stub> stub_;
  ClientOptions options_;
  int64_t last_retry_after_ms_ = 0;
  std::atomic<int> resent_calls_{0};
  std::string affinity_key_;
  int upload_copies_ = 0;
  struct FileHash {
    uintmax_t size;
    std::filesystem::file_time_type mtime;
    std::string sha256;
  };
  std::map<std::string, FileHash> file_hashes_;
};

// The BRDF fields of a request for a BRDF spec. "table:PATH" and "merl:PATH" upload the file
// (UploadIfMissing) and become spec "table:@" / "merl:@" with its hash, and the local spec
// ("table:PATH", as core's TableBrdf::spec()) as display spec, so that the SHRM file's shrm:brdf
// is the embedded run's. Other specs pass through unchanged (no blob, no display spec).
using RemoteBrdf = wire::WireBrdf;
absl::StatusOr<RemoteBrdf> ResolveRemoteBrdf(const std::string& spec, ShrmClient* client);

// Whether an idempotent call that failed with `status` may succeed when sent again, decided by
// the code and by where the call failed, never by the message: UNAVAILABLE (server draining or
// unreachable, proxy without upstream), and INTERNAL or UNKNOWN that did not come from an shrm
// server (no ErrorInfo: the transport or a proxy failed, e.g. a replica died mid-call). Never
// DEADLINE_EXCEEDED, CANCELLED or an answer about the request itself.
bool IsTransient(const absl::Status& status);
// CANCELLED without an shrm ErrorInfo on a call this client did not cancel: a server that shut
// down with the call received but not yet taken by a handler (gRPC cancels those), or a proxy,
// dropped it before any answer. Sent again like a transient error by the calls that never cancel
// themselves (unary calls, uploads) and by the streaming calls when no answer came and the
// caller's cancel flag is not set. A CANCELLED the server sent (ErrorInfo) is final.
bool IsDroppedCall(const absl::Status& status);
// NOT_FOUND with reason BLOB_NOT_FOUND: the server lacks an input blob (upload it again).
bool IsMissingBlob(const absl::Status& status);
// How long a RESOURCE_EXHAUSTED answer asks to wait (RetryInfo; zero: none, e.g. a too large
// input, which waiting does not help).
absl::Duration ServerRetryDelay(const absl::Status& status);

// The backoff before attempt `attempt` (1 = the first retry): initial * 2^(attempt - 1), capped.
absl::Duration RetryBackoff(const ClientOptions& options, int attempt);

}  // namespace shrm::client

#endif  // SHRM_CLIENT_SHRM_CLIENT_H_
