// The wire's error model (proto/status_details.h) and the client's decisions on it: retried or
// not, a missing blob or not, how long to wait; decided by code, reason and where the call failed
// (a status without an shrm ErrorInfo came from the transport or a proxy), never by the message.
#include "proto/status_details.h"

#include <grpcpp/support/status.h>
#include <gtest/gtest.h>

#include "absl/status/status.h"
#include "client/shrm_client.h"

namespace shrm {
namespace {

// What the client library makes of a status the server sent (ToGrpcStatus then FromGrpcStatus,
// as over the wire).
absl::Status RoundTrip(const absl::Status& server_side) {
  return wire::FromGrpcStatus(wire::ToGrpcStatus(server_side));
}

TEST(StatusDetails, ReasonAndRetryDelaySurviveTheWire) {
  const absl::Status busy = wire::WithRetryDelay(
      wire::WithErrorReason(absl::ResourceExhaustedError("server busy"), wire::kReasonServerBusy),
      absl::Milliseconds(1250));
  const absl::Status got = RoundTrip(busy);
  EXPECT_EQ(got.code(), absl::StatusCode::kResourceExhausted);
  EXPECT_EQ(got.message(), "server busy");
  EXPECT_EQ(wire::ErrorReason(got), wire::kReasonServerBusy);
  EXPECT_EQ(client::ServerRetryDelay(got), absl::Milliseconds(1250));
  EXPECT_TRUE(wire::FromShrmServer(got));
}

TEST(StatusDetails, EveryServerStatusSaysWhereItCameFrom) {
  const absl::Status got = RoundTrip(absl::InvalidArgumentError("orders: F must be ..."));
  EXPECT_TRUE(wire::FromShrmServer(got));
  EXPECT_EQ(wire::ErrorReason(got), "INVALID_ARGUMENT");
}

TEST(ClientDecisions, MissingBlobByReasonNotByMessage) {
  const absl::Status missing = RoundTrip(wire::WithErrorReason(
      absl::NotFoundError("not on the server"), wire::kReasonBlobNotFound, "sha256", "ab"));
  EXPECT_TRUE(client::IsMissingBlob(missing));
  // A NOT_FOUND whose message happens to mention a blob, without the reason, is not one.
  EXPECT_FALSE(client::IsMissingBlob(RoundTrip(absl::NotFoundError("blob 1234 missing"))));
  EXPECT_FALSE(client::IsMissingBlob(absl::NotFoundError("blob 1234 missing")));
}

TEST(ClientDecisions, ServerRetryDelayOnlyWhenTheServerGivesOne) {
  // nginx's 413 (an upload above its limit) arrives as RESOURCE_EXHAUSTED without details:
  // waiting does not help.
  EXPECT_EQ(client::ServerRetryDelay(wire::FromGrpcStatus(
                grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "Received RST_STREAM"))),
            absl::ZeroDuration());
  EXPECT_EQ(client::ServerRetryDelay(RoundTrip(absl::ResourceExhaustedError("too large"))),
            absl::ZeroDuration());
}

// Each path of IsTransient.
TEST(ClientDecisions, TransientByCodeAndOrigin) {
  // UNAVAILABLE: a draining server, no connection, a proxy without upstream.
  EXPECT_TRUE(client::IsTransient(
      RoundTrip(wire::WithErrorReason(absl::UnavailableError("draining"), wire::kReasonDraining))));
  EXPECT_TRUE(client::IsTransient(wire::FromGrpcStatus(
      grpc::Status(grpc::StatusCode::UNAVAILABLE, "failed to connect to all addresses"))));
  // INTERNAL / UNKNOWN from the transport or a proxy (a replica died mid-call): no ErrorInfo.
  for (grpc::StatusCode code : {grpc::StatusCode::INTERNAL, grpc::StatusCode::UNKNOWN}) {
    EXPECT_TRUE(client::IsTransient(wire::FromGrpcStatus(grpc::Status(code, "any text"))));
    // Undecodable details are not an shrm server's either.
    EXPECT_TRUE(client::IsTransient(
        wire::FromGrpcStatus(grpc::Status(code, "any text", std::string("\xff\x01", 2)))));
  }
  // The server's own INTERNAL / UNKNOWN are final, whatever the message says.
  EXPECT_FALSE(client::IsTransient(RoundTrip(absl::InternalError("RST_STREAM GOAWAY 503"))));
  EXPECT_FALSE(client::IsTransient(RoundTrip(absl::UnknownError("Socket closed"))));
  // Never deadlines, cancellations or answers about the request.
  for (grpc::StatusCode code :
       {grpc::StatusCode::DEADLINE_EXCEEDED, grpc::StatusCode::CANCELLED,
        grpc::StatusCode::INVALID_ARGUMENT, grpc::StatusCode::NOT_FOUND,
        grpc::StatusCode::RESOURCE_EXHAUSTED, grpc::StatusCode::UNAUTHENTICATED}) {
    EXPECT_FALSE(client::IsTransient(wire::FromGrpcStatus(grpc::Status(code, "RST_STREAM"))))
        << code;
  }
}

}  // namespace
}  // namespace shrm
