// The text syntax of job options shared by every command-line front end (`shrm`, `shrm-view`,
// batch manifests): "x,y,z" directions, "F,P" orders, tolerances in (0, 1). Errors name the option
// (`what`) and quote the text.
#ifndef SHRM_JOBS_OPTION_TEXT_H_
#define SHRM_JOBS_OPTION_TEXT_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/base/geometry.h"
#include "jobs/prefilter_job.h"

namespace shrm::jobs {

// "x,y,z": three finite numbers, not all zero; the unit vector (UnitDirection).
absl::StatusOr<Vec3> ParseDirectionText(absl::string_view text, absl::string_view what);
// "F,P": two integers >= 0.
absl::StatusOr<Orders> ParseOrdersText(absl::string_view text, absl::string_view what);
// A number in the open interval (0, 1).
absl::StatusOr<double> ParseToleranceText(absl::string_view text, absl::string_view what);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_OPTION_TEXT_H_
