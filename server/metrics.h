// Prometheus metrics of shrmd (text exposition format 0.0.4, docs/server.md "Metrics"), and a
// tiny HTTP/1.0 responder serving them on GET /metrics (a POSIX socket thread, loopback by
// default). The counters are process-wide (Metrics::Global()).
#ifndef SHRM_SERVER_METRICS_H_
#define SHRM_SERVER_METRICS_H_

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "absl/status/statusor.h"

namespace shrm::server {

class Metrics {
 public:
  // Upper bounds (seconds) of the latency histogram buckets (+Inf is implicit).
  static constexpr std::array<double, 14> kLatencyBuckets = {
      0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 120};

  static Metrics& Global();

  // One finished call: `code` is the gRPC code name ("OK", "INVALID_ARGUMENT", ...).
  void RecordRequest(const std::string& method, const std::string& code, double seconds);
  void JobStarted() { jobs_in_flight_.fetch_add(1); }
  void JobFinished() { jobs_in_flight_.fetch_sub(1); }
  // Jobs holding a slot now, over all services of the process (tests, the gauge).
  int64_t JobsInFlight() const { return jobs_in_flight_.load(); }
  // `cache`: "lighting" or "brdf".
  void RecordCache(const std::string& cache, bool hit);
  // The number of finished calls of `method` with `code` (tests).
  uint64_t RequestCount(const std::string& method, const std::string& code) const;
  // A refused input or request, by reason (the gRPC code name in lower case).
  void RecordRejected(const std::string& reason);
  // A job stopped before its end because its deadline passed or its client cancelled:
  // `reason` "deadline" or "cancelled", `stage` the stage it was stopped before.
  void RecordAbandoned(const std::string& reason, const std::string& stage);
  // The number of abandoned jobs with `reason`, over all stages (tests, logs).
  uint64_t AbandonedCount(const std::string& reason) const;

  // All metrics in the Prometheus text format.
  std::string Render() const;

 private:
  struct Histogram {
    std::array<uint64_t, kLatencyBuckets.size()> buckets{};  // non-cumulative
    uint64_t count = 0;
    double sum = 0;
  };
  mutable std::mutex mu_;
  std::map<std::pair<std::string, std::string>, uint64_t> requests_;  // (method, code)
  std::map<std::string, Histogram> latency_;                          // per method
  std::map<std::pair<std::string, bool>, uint64_t> cache_;            // (cache, hit)
  std::map<std::string, uint64_t> rejected_;
  std::map<std::pair<std::string, std::string>, uint64_t> abandoned_;  // (reason, stage)
  std::atomic<int64_t> jobs_in_flight_{0};
};

// Serves Metrics::Global().Render() on GET /metrics (404 for other paths, 405 for other
// methods), one connection at a time, HTTP/1.0 with "Connection: close".
class MetricsHttpServer {
 public:
  // `address`: an IPv4 literal ("127.0.0.1" by default in shrmd); port 0 picks a free port.
  static absl::StatusOr<std::unique_ptr<MetricsHttpServer>> Start(const std::string& address,
                                                                  int port);
  ~MetricsHttpServer();  // stops the thread and closes the socket
  int port() const { return port_; }

 private:
  MetricsHttpServer() = default;
  void Loop();
  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace shrm::server

#endif  // SHRM_SERVER_METRICS_H_
