// Error-propagation macros for absl::Status / absl::StatusOr.
//
// Abseil 20220623 (Debian 12) does not export its RETURN_IF_ERROR / ASSIGN_OR_RETURN macros, so
// shrm defines its own two. Recoverable errors (anything a user can cause) travel as values;
// CHECK-style aborts are only for programming invariants.
#ifndef SHRM_CORE_BASE_STATUS_MACROS_H_
#define SHRM_CORE_BASE_STATUS_MACROS_H_

#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

#define SHRM_STATUS_CONCAT_INNER_(a, b) a##b
#define SHRM_STATUS_CONCAT_(a, b) SHRM_STATUS_CONCAT_INNER_(a, b)

// Evaluates `expr` (an absl::Status); returns it from the enclosing function if not OK. The
// status variable's name is unique per expansion, so uses nested in `expr` (a lambda's body)
// do not shadow it.
#define SHRM_RETURN_IF_ERROR(expr) \
  SHRM_RETURN_IF_ERROR_IMPL_(SHRM_STATUS_CONCAT_(shrm_status_, __COUNTER__), expr)
#define SHRM_RETURN_IF_ERROR_IMPL_(status, expr) \
  do {                                           \
    ::absl::Status status = (expr);              \
    if (!status.ok()) return status;             \
  } while (0)

// `lhs = value of rexpr`, where rexpr is an absl::StatusOr<T>; returns its status if not OK.
#define SHRM_ASSIGN_OR_RETURN(lhs, rexpr) \
  SHRM_ASSIGN_OR_RETURN_IMPL_(SHRM_STATUS_CONCAT_(shrm_statusor_, __LINE__), lhs, rexpr)
#define SHRM_ASSIGN_OR_RETURN_IMPL_(statusor, lhs, rexpr) \
  auto statusor = (rexpr);                                \
  if (!statusor.ok()) return statusor.status();           \
  lhs = std::move(statusor).value()

namespace shrm {

// `status` with its message replaced by `message` (code and payloads kept: the wire's error
// details travel as payloads, proto/status_details.h). OK stays OK.
inline absl::Status WithMessage(const absl::Status& status, std::string message) {
  if (status.ok()) return status;
  absl::Status out(status.code(), std::move(message));
  status.ForEachPayload(
      [&](absl::string_view url, const absl::Cord& payload) { out.SetPayload(url, payload); });
  return out;
}

}  // namespace shrm

#endif  // SHRM_CORE_BASE_STATUS_MACROS_H_
