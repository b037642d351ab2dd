// The error model of the wire (proto/shrm/v1/shrm.proto "Errors"): absl::Status payloads carry
// an ErrorInfo (reason) and a RetryInfo (delay) through core, the job layer and the server, and
// travel as the gRPC status details; this file is the one mapping between absl::Status and
// grpc::Status in both directions (the server sends, the client library reads).
#ifndef SHRM_PROTO_STATUS_DETAILS_H_
#define SHRM_PROTO_STATUS_DETAILS_H_

#include <grpcpp/support/status.h>

#include <optional>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "absl/time/time.h"

namespace shrm::wire {

// ErrorInfo.domain of every status an shrm server sends.
inline constexpr char kErrorDomain[] = "shrm.v1";
// Reasons (ErrorInfo.reason) clients act on; other statuses carry their code's name.
inline constexpr char kReasonBlobNotFound[] = "BLOB_NOT_FOUND";  // metadata "sha256"
inline constexpr char kReasonServerBusy[] = "SERVER_BUSY";       // with a RetryInfo
inline constexpr char kReasonDraining[] = "DRAINING";
// The spool's disk is full (or a file-size limit hit): RESOURCE_EXHAUSTED with a RetryInfo.
inline constexpr char kReasonSpoolFull[] = "SPOOL_FULL";
// An input killed the isolated decoder (server/decoder_sandbox.h): final, never sent again.
inline constexpr char kReasonDecoderCrashed[] = "DECODER_CRASHED";  // metadata "sha256"
// Memory admission (server/memory_budget.h): a job that does not fit the memory free now
// (RESOURCE_EXHAUSTED with a RetryInfo), and one larger than the whole budget (INVALID_ARGUMENT,
// final); metadata "needed_mib".
inline constexpr char kReasonMemoryBusy[] = "MEMORY_BUSY";
inline constexpr char kReasonJobTooLarge[] = "JOB_TOO_LARGE";

// `status` with an ErrorInfo of kErrorDomain (`metadata_key`: `metadata_value` when given).
absl::Status WithErrorReason(absl::Status status, absl::string_view reason,
                             absl::string_view metadata_key = "",
                             absl::string_view metadata_value = "");
// `status` with a RetryInfo of `delay`.
absl::Status WithRetryDelay(absl::Status status, absl::Duration delay);
// The ErrorInfo reason of kErrorDomain ("" when there is none).
std::string ErrorReason(const absl::Status& status);
// The RetryInfo delay (nullopt when there is none).
std::optional<absl::Duration> RetryDelay(const absl::Status& status);
// Whether an shrm server produced `status` (it carries an ErrorInfo of kErrorDomain).
bool FromShrmServer(const absl::Status& status);

// absl -> gRPC: same code and message; the payloads, plus an ErrorInfo naming the code when the
// status has none, packed into an RpcStatus sent as the status details.
grpc::Status ToGrpcStatus(const absl::Status& status);
// gRPC -> absl: same code and message; the details' ErrorInfo and RetryInfo back as payloads
// (undecodable details are dropped: the status then counts as not from an shrm server).
absl::Status FromGrpcStatus(const grpc::Status& status);

}  // namespace shrm::wire

#endif  // SHRM_PROTO_STATUS_DETAILS_H_
