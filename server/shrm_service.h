// The shrm.v1.Shrm service: a thin layer that decodes requests into jobs (proto/job_codec.h),
// resolves their blobs (server/request_inputs.h), runs them through core (server/cached_prefilter.h
// for the prefilter pipeline) and encodes the results; the job layer (jobs/) says what a job's
// outputs hold. All math lives in core/. docs/server.md documents the behaviour and the statuses.
#ifndef SHRM_SERVER_SHRM_SERVICE_H_
#define SHRM_SERVER_SHRM_SERVICE_H_

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/blob_store.h"
#include "server/cached_prefilter.h"
#include "server/decoder_sandbox.h"
#include "server/idle_watchdog.h"
#include "server/memory_budget.h"
#include "server/request_log.h"
#include "shrm/v1/shrm.grpc.pb.h"

namespace shrm::server {

struct ServiceOptions {
  std::string spool_dir;                 // blob store directory (created if needed)
  uint64_t spool_bytes = 8ull << 30;     // LRU bound of the blob store
  uint64_t max_blob_bytes = 1ull << 30;  // largest accepted upload
  int max_jobs = 1;                      // concurrent jobs (Prefilter, Analyze, ..., Ibl calls)
  int job_threads = 1;                   // worker threads of one job
  size_t cache_bytes = 512ull << 20;     // L_lm + rho_lpq caches together
  // The daemon's memory budget (server/memory_budget.h): jobs reserve their stages' estimated
  // peaks from it less the memory at start, the caches and kServiceReserveBytes; 0 = jobs are
  // admitted by max_jobs only. `memory_text` names it in refusals (e.g. "--memory-mib 2048").
  uint64_t memory_bytes = 0;
  std::string memory_text = "the memory budget";
  // Isolated decoding of uploaded maps (server/decoder_sandbox.h; not owned, outlives the
  // service); null: maps are decoded in the daemon only.
  DecoderSandbox* decoder_sandbox = nullptr;
  DecodeLimits decode_limits;  // of each isolated decode (its image limits: the job's)
  // An upload without a chunk, or a result transfer without a chunk read, for this long is
  // ended (server/idle_watchdog.h); <= 0: never.
  absl::Duration idle_timeout = absl::Seconds(60);
  // Testing only: sleep this long at the start of every pipeline stage (makes jobs slow).
  absl::Duration test_stage_delay = absl::ZeroDuration();
  // Testing only: called at the start of every Prefilter and Ibl stage, after the delay (tests
  // hold a job in its slot with it: tests/stage_gate.h).
  std::function<void(std::string_view stage)> test_stage_hook;
  // Testing only (shrmd --test-hold-brdf; tests/deploy_test.sh's drain): a Prefilter job whose
  // brdf spec, as the request spelled it, is this one waits before its write stage until the
  // server begins draining (at most 120 s), so that it is surely in flight at SIGTERM.
  std::string test_hold_brdf;
};

class ShrmServiceImpl final : public shrm::v1::Shrm::Service {
 public:
  static absl::StatusOr<std::unique_ptr<ShrmServiceImpl>> Create(const ServiceOptions& options);

  // Refuse new jobs with UNAVAILABLE (graceful shutdown); running jobs continue.
  void BeginDrain() { draining_ = true; }
  // Calls ended by the idle watchdog (ServiceOptions::idle_timeout).
  int64_t idle_calls_ended() const { return idle_.ended(); }
  // Jobs holding a slot now.
  int running_jobs() const { return running_jobs_.load(); }
  // What jobs may reserve together (0: no memory admission), and what they hold now.
  const MemoryBudget& memory() const { return *memory_; }

  grpc::Status HasBlob(grpc::ServerContext* context, const shrm::v1::HasBlobRequest* request,
                       shrm::v1::HasBlobResponse* response) override;
  grpc::Status UploadBlob(grpc::ServerContext* context,
                          grpc::ServerReader<shrm::v1::UploadBlobChunk>* reader,
                          shrm::v1::UploadBlobResponse* response) override;
  grpc::Status Prefilter(grpc::ServerContext* context, const shrm::v1::PrefilterRequest* request,
                         grpc::ServerWriter<shrm::v1::PrefilterEvent>* writer) override;
  grpc::Status Analyze(grpc::ServerContext* context, const shrm::v1::AnalyzeRequest* request,
                       shrm::v1::AnalyzeResponse* response) override;
  grpc::Status ListBrdfModels(grpc::ServerContext* context,
                              const shrm::v1::ListBrdfModelsRequest* request,
                              shrm::v1::ListBrdfModelsResponse* response) override;
  grpc::Status Reference(grpc::ServerContext* context, const shrm::v1::ReferenceRequest* request,
                         shrm::v1::ReferenceResponse* response) override;
  grpc::Status Irradiance(grpc::ServerContext* context, const shrm::v1::IrradianceRequest* request,
                          shrm::v1::IrradianceResponse* response) override;
  grpc::Status Ibl(grpc::ServerContext* context, const shrm::v1::IblRequest* request,
                   grpc::ServerWriter<shrm::v1::IblEvent>* writer) override;
  // docs/live.md: one LiveSession per call; the handler thread reads the requests, a second
  // thread sends the frames.
  grpc::Status Live(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<shrm::v1::LiveEvent, shrm::v1::LiveRequest>* stream) override;

 private:
  class JobSlot;
  struct PrefilterCall;
  struct IblCall;
  ShrmServiceImpl(const ServiceOptions& options, std::unique_ptr<BlobStore> blobs,
                  uint64_t job_memory_bytes);
  // OK and a held slot, or RESOURCE_EXHAUSTED (reason SERVER_BUSY, with a retry delay) /
  // UNAVAILABLE (reason DRAINING).
  absl::StatusOr<std::unique_ptr<JobSlot>> Admit();
  // The Prefilter call in three steps: the request decoded and its blobs resolved; the job run
  // (progress events, cancellation between stages) and its file encoded; the report and the file
  // streamed back.
  absl::Status ParsePrefilterCall(const shrm::v1::PrefilterRequest& request, PrefilterCall* call);
  absl::Status RunPrefilterCall(grpc::ServerContext* context,
                                grpc::ServerWriter<shrm::v1::PrefilterEvent>* writer,
                                PrefilterCall* call, RequestLog* log);
  absl::Status SendPrefilterResult(grpc::ServerContext* context,
                                   grpc::ServerWriter<shrm::v1::PrefilterEvent>* writer,
                                   const PrefilterCall& call, RequestLog* log,
                                   IdleWatchdog::Call* watch);

  // The Ibl call in the same three steps: decoded and pinned; the map decoded, the job run
  // (progress events, cancellation between stages) and its files encoded; streamed back.
  absl::Status ParseIblCall(const shrm::v1::IblRequest& request, IblCall* call);
  absl::Status RunIblCall(grpc::ServerContext* context,
                          grpc::ServerWriter<shrm::v1::IblEvent>* writer, IblCall* call,
                          RequestLog* log);
  absl::Status SendIblResult(grpc::ServerContext* context,
                             grpc::ServerWriter<shrm::v1::IblEvent>* writer, const IblCall& call,
                             RequestLog* log, IdleWatchdog::Call* watch);
  // Runs `transfer` (the sending of a result) under the idle watchdog: a client that stops
  // reading for --idle-timeout gets its call ended (DEADLINE_EXCEEDED in the log: "no progress
  // `what`").
  absl::Status WhileWatched(grpc::ServerContext* context, std::string_view what,
                            const std::function<absl::Status(IdleWatchdog::Call*)>& transfer);
  // The testing hooks (ServiceOptions::test_stage_delay, test_stage_hook) at `stage`.
  void TestStageHooks(std::string_view stage) const;
  // Waits until BeginDrain (ServiceOptions::test_hold_brdf) or the call's cancellation, at most
  // 120 s.
  void HoldUntilDrain(grpc::ServerContext* context) const;

  const ServiceOptions options_;
  std::unique_ptr<BlobStore> blobs_;
  PrefilterCaches caches_;
  DecodeGuard decode_guard_;
  IdleWatchdog idle_;
  std::unique_ptr<MemoryBudget> memory_;
  std::atomic<int> running_jobs_{0};
  std::atomic<bool> draining_{false};
};

}  // namespace shrm::server

#endif  // SHRM_SERVER_SHRM_SERVICE_H_
