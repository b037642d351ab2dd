#include "viewer/brdf_edit.h"

#include <cstdlib>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"

namespace shrm::viewer {

const std::vector<std::string>& BrdfPresets() {
  static const std::vector<std::string> presets = {
      "microfacet:sigma=0.2", "phong:s=32", "ggx:alpha=0.3,f0=0.04",
      "ward:alpha=0.2,rho_s=0.1,rho_d=0", "lafortune:cx=-1,cy=-1,cz=1,n=20,rho=1"};
  return presets;
}

absl::StatusOr<std::string> ScaleBrdfLobe(const std::string& spec, double factor) {
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(spec));
  const std::string canonical = brdf->spec();
  const size_t colon = canonical.find(':');
  const std::string model = canonical.substr(0, colon);
  std::string key;
  if (model == "phong" || model == "kajiya-kay") key = "s";
  if (model == "microfacet") key = "sigma";
  if (model == "ggx" || model == "ward") key = "alpha";
  if (model == "lafortune") key = "n";
  if (key.empty() || colon == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf '", model, "' has no lobe parameter to change"));
  }
  // The first "key=" after the colon or a separator.
  size_t pos = colon;
  for (;;) {
    pos = canonical.find(key + "=", pos + 1);
    if (pos == std::string::npos) {
      return absl::InvalidArgumentError(absl::StrCat("brdf '", canonical, "': no '", key, "'"));
    }
    const char before = canonical[pos - 1];
    if (before == ':' || before == ',' || before == ';') break;
  }
  const size_t vbegin = pos + key.size() + 1;
  const size_t vend = canonical.find_first_of(",;", vbegin);
  const std::string value = canonical.substr(vbegin, vend - vbegin);
  const double x = std::strtod(value.c_str(), nullptr) * factor;
  const std::string edited = canonical.substr(0, vbegin) + FormatSpecNumber(x) +
                             (vend == std::string::npos ? "" : canonical.substr(vend));
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> check, ParseBrdfSpec(edited));
  return check->spec();
}

}  // namespace shrm::viewer
