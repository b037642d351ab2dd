#include "jobs/environment.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/io/sha256.h"

namespace shrm::jobs {

absl::Status ValidateEnvironment(const EnvironmentSpec& env) {
  if (env.files.size() != 1 && env.files.size() != 6) {
    return absl::InvalidArgumentError(
        absl::StrCat("environment: give one map file, or six cube faces; got ", env.files.size()));
  }
  if (env.rotate_ypr_deg) {
    for (double a : *env.rotate_ypr_deg) {
      if (!std::isfinite(a)) return absl::InvalidArgumentError("rotate: angles must be finite");
    }
  }
  return absl::OkStatus();
}

Mat3 EnvironmentRotation(const EnvironmentSpec& env) {
  if (!env.rotate_ypr_deg) return Mat3::Identity();
  const std::array<double, 3>& r = *env.rotate_ypr_deg;
  return RotationFromYawPitchRoll(r[0], r[1], r[2]);
}

std::string RotationAttribute(const EnvironmentSpec& env) {
  return env.rotate_ypr_deg ? absl::StrJoin(*env.rotate_ypr_deg, ",") : std::string();
}

EnvMapOptions EnvMapOptionsFor(const EnvironmentSpec& env) {
  return EnvMapOptionsFor(env, env.files);
}

EnvMapOptions EnvMapOptionsFor(const EnvironmentSpec& env, const std::vector<std::string>& paths) {
  EnvMapOptions opt;
  opt.paths = paths;
  opt.layout = env.layout;
  opt.input_colour_space = env.input_colour_space;
  opt.working_colour_space = env.working_colour_space;
  opt.colour_config = env.ocio_config;
  opt.non_finite =
      env.replace_non_finite ? NonFinitePolicy::kReplaceZero : NonFinitePolicy::kReject;
  return opt;
}

std::string CombinedSourceSha256(const std::vector<std::string>& hashes) {
  if (hashes.size() == 1) return hashes[0];
  return Sha256Hex(absl::StrJoin(hashes, ","));
}

absl::StatusOr<SourceIdentity> LocalSourceIdentity(const EnvironmentSpec& env) {
  std::vector<std::string> hashes;
  for (const std::string& f : env.files) {
    SHRM_ASSIGN_OR_RETURN(std::string h, Sha256OfFile(f));
    hashes.push_back(std::move(h));
  }
  return SourceIdentity{absl::StrJoin(env.files, ","), CombinedSourceSha256(hashes)};
}

}  // namespace shrm::jobs
