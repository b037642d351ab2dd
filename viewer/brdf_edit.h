// The BRDF edits of the viewer's UI: a list of presets to cycle through and the scaling of a
// model's lobe parameter (docs/brdf.md spec strings). Every result is validated by
// ParseBrdfSpec, so an edit that leaves a parameter's range is an error, not a bad job.
#ifndef SHRM_VIEWER_BRDF_EDIT_H_
#define SHRM_VIEWER_BRDF_EDIT_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm::viewer {

// Specs cycled by the B key: glossy models with small orders first.
const std::vector<std::string>& BrdfPresets();

// The canonical spec with its lobe parameter (phong / kajiya-kay s, microfacet sigma, ggx / ward
// alpha, lafortune n of the first lobe) multiplied by `factor`. Errors: InvalidArgument for a bad
// spec, a model without a lobe parameter (lambert, tables), or a result out of range.
[[nodiscard]] absl::StatusOr<std::string> ScaleBrdfLobe(const std::string& spec, double factor);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_BRDF_EDIT_H_
