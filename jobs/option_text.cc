#include "jobs/option_text.h"

#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "jobs/point_jobs.h"

namespace shrm::jobs {

absl::StatusOr<Vec3> ParseDirectionText(absl::string_view text, absl::string_view what) {
  std::vector<std::string> parts = absl::StrSplit(text, ',');
  double v[3];
  if (parts.size() != 3 || !absl::SimpleAtod(parts[0], &v[0]) ||
      !absl::SimpleAtod(parts[1], &v[1]) || !absl::SimpleAtod(parts[2], &v[2])) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " must be three numbers x,y,z, got '", text, "'"));
  }
  return UnitDirection(Vec3{v[0], v[1], v[2]}, what);
}

absl::StatusOr<Orders> ParseOrdersText(absl::string_view text, absl::string_view what) {
  std::vector<std::string> parts = absl::StrSplit(text, ',');
  Orders o;
  if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &o.f) || !absl::SimpleAtoi(parts[1], &o.p) ||
      o.f < 0 || o.p < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " must be F,P with integers F, P >= 0, got '", text, "'"));
  }
  return o;
}

absl::StatusOr<double> ParseToleranceText(absl::string_view text, absl::string_view what) {
  double e;
  if (!absl::SimpleAtod(text, &e) || !(e > 0 && e < 1)) {
    return absl::InvalidArgumentError(absl::StrCat(what, " must be in (0, 1), got '", text, "'"));
  }
  return e;
}

}  // namespace shrm::jobs
