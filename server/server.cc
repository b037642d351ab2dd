#include "server/server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include <chrono>
#include <thread>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "server/request_log.h"
#include "shrm/version.h"

namespace shrm::server {

namespace {
// How long a draining server stays after its last call completed, for the transport to deliver
// what it still holds (see Shutdown).
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
  server_->Shutdown(std::chrono::system_clock::now() +
                    std::chrono::milliseconds(absl::ToInt64Milliseconds(grace)));
  // A call is complete for Shutdown once its last message and status are handed to the
  // transport, which may still be writing them (a result of megabytes waits on the client's flow
  // control): the transport keeps running while the server object lives, so stay a moment
  // before the process can exit (measured: a 6 MB result of a job that finished during the drain
  // was lost when the process exited 25 ms after it, and the client's retry found no server).
  if (grace > absl::ZeroDuration()) std::this_thread::sleep_for(kFlushLinger);
  LogEvent("stopped", {});
}

void ShrmServer::Wait() {
  if (server_) server_->Wait();
}

}  // namespace shrm::server
