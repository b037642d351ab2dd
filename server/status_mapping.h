// The one place where absl::Status becomes grpc::Status (docs/server.md lists the codes).
#ifndef SHRM_SERVER_STATUS_MAPPING_H_
#define SHRM_SERVER_STATUS_MAPPING_H_

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace shrm::server {

grpc::Status ToGrpcStatus(const absl::Status& status);

}  // namespace shrm::server

#endif  // SHRM_SERVER_STATUS_MAPPING_H_
