#include "proto/status_details.h"

#include <google/protobuf/any.pb.h>
#include <google/protobuf/duration.pb.h>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "shrm/v1/shrm.pb.h"

namespace shrm::wire {
namespace {

namespace v1 = ::shrm::v1;

// absl::Status payload URLs: the Any type URLs of the messages.
const std::string& ErrorInfoUrl() {
  static const std::string url =
      absl::StrCat("type.googleapis.com/", v1::ErrorInfo::descriptor()->full_name());
  return url;
}
const std::string& RetryInfoUrl() {
  static const std::string url =
      absl::StrCat("type.googleapis.com/", v1::RetryInfo::descriptor()->full_name());
  return url;
}

// absl::StatusCode and grpc::StatusCode share their numbers (both are the canonical codes).
static_assert(static_cast<int>(absl::StatusCode::kUnavailable) ==
              static_cast<int>(grpc::StatusCode::UNAVAILABLE));
static_assert(static_cast<int>(absl::StatusCode::kUnauthenticated) ==
              static_cast<int>(grpc::StatusCode::UNAUTHENTICATED));

std::optional<v1::ErrorInfo> GetErrorInfo(const absl::Status& status) {
  auto p = status.GetPayload(ErrorInfoUrl());
  v1::ErrorInfo info;
  if (!p || !info.ParseFromString(std::string(*p))) return std::nullopt;
  return info;
}

}  // namespace

absl::Status WithErrorReason(absl::Status status, absl::string_view reason,
                             absl::string_view metadata_key, absl::string_view metadata_value) {
  if (status.ok()) return status;
  v1::ErrorInfo info;
  info.set_reason(std::string(reason));
  info.set_domain(kErrorDomain);
  if (!metadata_key.empty()) {
    (*info.mutable_metadata())[std::string(metadata_key)] = std::string(metadata_value);
  }
  status.SetPayload(ErrorInfoUrl(), absl::Cord(info.SerializeAsString()));
  return status;
}

absl::Status WithRetryDelay(absl::Status status, absl::Duration delay) {
  if (status.ok()) return status;
  v1::RetryInfo info;
  const int64_t ns = absl::ToInt64Nanoseconds(delay);
  info.mutable_retry_delay()->set_seconds(ns / 1000000000);
  info.mutable_retry_delay()->set_nanos(static_cast<int32_t>(ns % 1000000000));
  status.SetPayload(RetryInfoUrl(), absl::Cord(info.SerializeAsString()));
  return status;
}

std::string ErrorReason(const absl::Status& status) {
  std::optional<v1::ErrorInfo> info = GetErrorInfo(status);
  return info && info->domain() == kErrorDomain ? info->reason() : std::string();
}

std::optional<absl::Duration> RetryDelay(const absl::Status& status) {
  auto p = status.GetPayload(RetryInfoUrl());
  v1::RetryInfo info;
  if (!p || !info.ParseFromString(std::string(*p))) return std::nullopt;
  return absl::Seconds(info.retry_delay().seconds()) +
         absl::Nanoseconds(info.retry_delay().nanos());
}

bool FromShrmServer(const absl::Status& status) {
  std::optional<v1::ErrorInfo> info = GetErrorInfo(status);
  return info && info->domain() == kErrorDomain;
}

grpc::Status ToGrpcStatus(const absl::Status& in) {
  if (in.ok()) return grpc::Status::OK;
  absl::Status status = in;
  if (!FromShrmServer(status))
    status = WithErrorReason(status, absl::StatusCodeToString(in.code()));
  v1::RpcStatus rpc;
  rpc.set_code(static_cast<int>(status.code()));
  rpc.set_message(std::string(status.message()));
  status.ForEachPayload([&](absl::string_view url, const absl::Cord& payload) {
    google::protobuf::Any* any = rpc.add_details();
    any->set_type_url(std::string(url));
    any->set_value(std::string(payload));
  });
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()),
                      rpc.SerializeAsString());
}

absl::Status FromGrpcStatus(const grpc::Status& status) {
  if (status.ok()) return absl::OkStatus();
  absl::Status out(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
  v1::RpcStatus rpc;
  if (status.error_details().empty() || !rpc.ParseFromString(status.error_details())) return out;
  for (const google::protobuf::Any& any : rpc.details()) {
    if (any.type_url() == ErrorInfoUrl() || any.type_url() == RetryInfoUrl()) {
      out.SetPayload(any.type_url(), absl::Cord(any.value()));
    }
  }
  return out;
}

}  // namespace shrm::wire
