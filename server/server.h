// An shrmd server: the service, gRPC health checking ("shrm.v1.readiness", "shrm.v1.liveness"),
// optional reflection, and graceful shutdown. Used by shrmd_main.cc and by the tests (in
// process, on an ephemeral port).
#ifndef SHRM_SERVER_SERVER_H_
#define SHRM_SERVER_SERVER_H_

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "server/auth.h"
#include "server/metrics.h"
#include "server/shrm_service.h"

namespace shrm::server {

inline constexpr char kReadinessService[] = "shrm.v1.readiness";
inline constexpr char kLivenessService[] = "shrm.v1.liveness";

struct ServerOptions {
  std::string listen = "[::]:50051";  // host:port; port 0 = pick a free port
  bool reflection = false;
  SecurityOptions security;  // tokens, TLS (server/auth.h)
  // Prometheus metrics over HTTP on GET /metrics: -1 off, 0 any free port (server/metrics.h).
  int metrics_port = -1;
  std::string metrics_address = "127.0.0.1";
  ServiceOptions service;
};

class ShrmServer {
 public:
  static absl::StatusOr<std::unique_ptr<ShrmServer>> Start(const ServerOptions& options);
  ~ShrmServer();

  int port() const { return port_; }
  int metrics_port() const { return metrics_ ? metrics_->port() : -1; }
  // Calls the idle watchdog ended so far (ServiceOptions::idle_timeout).
  int64_t idle_calls_ended() const { return service_->idle_calls_ended(); }
  int running_jobs() const { return service_->running_jobs(); }
  const MemoryBudget& memory() const { return service_->memory(); }
  // Readiness NOT_SERVING, new jobs refused with UNAVAILABLE, running calls get until `grace`
  // to finish (then they are cancelled), then the server stops. Idempotent.
  void Shutdown(absl::Duration grace);
  // Blocks until the server has stopped.
  void Wait();

 private:
  ShrmServer() = default;
  std::unique_ptr<ShrmServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<MetricsHttpServer> metrics_;
  int port_ = 0;
  bool shut_down_ = false;
};

}  // namespace shrm::server

#endif  // SHRM_SERVER_SERVER_H_
