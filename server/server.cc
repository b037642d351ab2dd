#include "server/server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "server/request_log.h"
#include "shrm/version.h"

namespace shrm::server {

namespace {
// How long a draining server waits after its last job, before the shutdown, for the transport to
// deliver what it still holds (see Shutdown).
constexpr std::chrono::milliseconds kFlushLinger{500};
}  // namespace

absl::StatusOr<std::unique_ptr<ShrmServer>> ShrmServer::Start(const ServerOptions& options) {
  std::unique_ptr<ShrmServer> s(new ShrmServer());
  SHRM_ASSIGN_OR_RETURN(std::shared_ptr<grpc::ServerCredentials> creds,
                        MakeServerCredentials(options.security, options.listen));
  SHRM_ASSIGN_OR_RETURN(s->service_, ShrmServiceImpl::Create(options.service));
  grpc::EnableDefaultHealthCheckService(true);
  if (options.reflection) grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.listen, creds, &s->port_);
  builder.RegisterService(s->service_.get());
  s->server_ = builder.BuildAndStart();
  if (!s->server_ || s->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("cannot listen on ", options.listen));
  }
  if (options.metrics_port >= 0) {
    SHRM_ASSIGN_OR_RETURN(s->metrics_,
                          MetricsHttpServer::Start(options.metrics_address, options.metrics_port));
    LogEvent("metrics",
             {{"address", options.metrics_address}, {"port", std::to_string(s->metrics_->port())}});
  }
  grpc::HealthCheckServiceInterface* health = s->server_->GetHealthCheckService();
  health->SetServingStatus(kLivenessService, true);
  health->SetServingStatus(kReadinessService, true);
  health->SetServingStatus("", true);
  LogEvent("listening",
           {{"address", options.listen},
            {"port", std::to_string(s->port_)},
            {"reflection", options.reflection ? "on" : "off"},
            {"decode_isolation", options.service.decoder_sandbox ? "process" : "off"},
            {"memory_budget",
             options.service.memory_bytes > 0 ? options.service.memory_text : std::string("off")},
            {"job_memory_mib", std::to_string(s->service_->memory().job_bytes() >> 20)},
            {"tls", options.security.tls_cert_file.empty()   ? "off"
                    : options.security.tls_client_ca.empty() ? "on"
                                                             : "mutual"},
            {"tokens", options.security.token_file.empty() ? "off" : "on"},
            {"version", kVersion},
            {"revision", GitRevision()}});
  return s;
}

ShrmServer::~ShrmServer() { Shutdown(absl::ZeroDuration()); }

void ShrmServer::Shutdown(absl::Duration grace) {
  if (shut_down_ || !server_) return;  // !server_: Start failed before building it
  shut_down_ = true;
  LogEvent("draining", {{"grace_ms", std::to_string(absl::ToInt64Milliseconds(grace))}});
  server_->GetHealthCheckService()->SetServingStatus(kReadinessService, false);
  service_->BeginDrain();
  // gRPC's Shutdown counts a call complete once its last message is handed to the transport, and
  // then tears the connections down with whatever the transport still holds: a 6 MB result of a
  // job that finished during the drain was lost that way (deploy_test). So the running jobs
  // finish first, with the server still up (new ones are refused by BeginDrain), and the
  // transport gets a moment to deliver their results before the shutdown; the grace period
  // bounds it all.
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(absl::ToInt64Milliseconds(grace));
  const auto left = [&] {
    return std::max(std::chrono::milliseconds(0),
                    std::chrono::duration_cast<std::chrono::milliseconds>(
                        deadline - std::chrono::steady_clock::now()));
  };
  while (service_->running_jobs() > 0 && left() > std::chrono::milliseconds(0)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::min(kFlushLinger, left()));
  server_->Shutdown(std::chrono::system_clock::now() + left());
  LogEvent("stopped", {});
}

void ShrmServer::Wait() {
  if (server_) server_->Wait();
}

}  // namespace shrm::server
