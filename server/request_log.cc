#include "server/request_log.h"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "absl/time/time.h"
#include "server/metrics.h"

namespace shrm::server {
namespace {

std::mutex& LogMutex() {
  static std::mutex mu;
  return mu;
}

void WriteLine(const nlohmann::json& j) {
  const std::string line = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::lock_guard<std::mutex> lock(LogMutex());
  std::fprintf(stderr, "%s\n", line.c_str());
  std::fflush(stderr);
}

std::string Now() {
  return absl::FormatTime("%Y-%m-%dT%H:%M:%E3SZ", absl::Now(), absl::UTCTimeZone());
}

const char* CodeName(grpc::StatusCode code) {
  static const char* kNames[] = {"OK",
                                 "CANCELLED",
                                 "UNKNOWN",
                                 "INVALID_ARGUMENT",
                                 "DEADLINE_EXCEEDED",
                                 "NOT_FOUND",
                                 "ALREADY_EXISTS",
                                 "PERMISSION_DENIED",
                                 "RESOURCE_EXHAUSTED",
                                 "FAILED_PRECONDITION",
                                 "ABORTED",
                                 "OUT_OF_RANGE",
                                 "UNIMPLEMENTED",
                                 "INTERNAL",
                                 "UNAVAILABLE",
                                 "DATA_LOSS",
                                 "UNAUTHENTICATED"};
  const int i = static_cast<int>(code);
  return i >= 0 && i < 17 ? kNames[i] : "UNKNOWN";
}

}  // namespace

RequestLog::RequestLog(grpc::ServerContext* context, const char* call)
    : peer_(context->peer()), call_(call), start_(std::chrono::steady_clock::now()) {
  static std::atomic<uint64_t> counter{0};
  const auto& md = context->client_metadata();
  auto it = md.find("x-request-id");
  if (it != md.end()) {
    request_id_.assign(it->second.data(), std::min<size_t>(it->second.size(), 128));
  } else {
    request_id_ = absl::StrCat("shrmd-", absl::ToUnixMillis(absl::Now()), "-", counter++);
  }
}

grpc::Status RequestLog::Finish(grpc::Status status) {
  nlohmann::json j;
  j["ts"] = Now();
  j["request_id"] = request_id_;
  j["peer"] = peer_;
  j["call"] = call_;
  j["status"] = CodeName(status.error_code());
  if (!status.ok()) j["message"] = status.error_message();
  j["bytes_in"] = bytes_in_;
  j["bytes_out"] = bytes_out_;
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& [k, v] : stages_) stages[k + "_ms"] = v;
  j["stages"] = stages;
  for (const auto& [k, v] : extra_) j[k] = v;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  j["total_ms"] = seconds * 1000;
  WriteLine(j);
  Metrics::Global().RecordRequest(call_, CodeName(status.error_code()), seconds);
  switch (status.error_code()) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::NOT_FOUND:
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
    case grpc::StatusCode::OUT_OF_RANGE:
    case grpc::StatusCode::FAILED_PRECONDITION:
      Metrics::Global().RecordRejected(absl::AsciiStrToLower(CodeName(status.error_code())));
      break;
    default:
      break;
  }
  return status;
}

void LogEvent(const std::string& event,
              const std::vector<std::pair<std::string, std::string>>& fields) {
  nlohmann::json j;
  j["ts"] = Now();
  j["event"] = event;
  for (const auto& [k, v] : fields) j[k] = v;
  WriteLine(j);
}

}  // namespace shrm::server
