// Structured request logs: one JSON object per line on stderr for every call (request id, peer,
// call, status, bytes in/out, per-stage milliseconds, total milliseconds).
#ifndef SHRM_SERVER_REQUEST_LOG_H_
#define SHRM_SERVER_REQUEST_LOG_H_

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace shrm::server {

class RequestLog {
 public:
  // Takes the request id from the client's "x-request-id" metadata, or makes one.
  RequestLog(grpc::ServerContext* context, const char* call);
  void AddBytesIn(uint64_t n) { bytes_in_ += n; }
  void AddBytesOut(uint64_t n) { bytes_out_ += n; }
  void AddStage(std::string stage, double ms) { stages_.emplace_back(std::move(stage), ms); }
  void Set(std::string key, std::string value) {
    extra_.emplace_back(std::move(key), std::move(value));
  }
  const std::string& request_id() const { return request_id_; }
  // Writes the line and returns `status`.
  grpc::Status Finish(grpc::Status status);

 private:
  std::string request_id_, peer_, call_;
  uint64_t bytes_in_ = 0, bytes_out_ = 0;
  std::vector<std::pair<std::string, double>> stages_;
  std::vector<std::pair<std::string, std::string>> extra_;
  std::chrono::steady_clock::time_point start_;
};

// A server lifecycle line ({"event": ..., plus fields}).
void LogEvent(const std::string& event,
              const std::vector<std::pair<std::string, std::string>>& fields);

}  // namespace shrm::server

#endif  // SHRM_SERVER_REQUEST_LOG_H_
