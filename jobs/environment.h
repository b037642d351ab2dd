// The environment map of a job (every job kind that reads one): its files, how to read them, and
// the identity of the source recorded in outputs (shrm:source, shrm:source_sha256;
// docs/formats.md). The CLI's --env/--layout/... flags, the batch manifest and the wire's
// Environment message all map onto EnvironmentSpec (docs/cli.md, docs/server.md).
#ifndef SHRM_JOBS_ENVIRONMENT_H_
#define SHRM_JOBS_ENVIRONMENT_H_

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/envmap/envmap.h"

namespace shrm::jobs {

// The linear working colour space when none is given (docs/envmap.md).
inline constexpr char kDefaultWorkingSpace[] = "lin_rec709";

struct EnvironmentSpec {
  std::vector<std::string> files;  // one map, or six cube faces (+X -X +Y -Y +Z -Z)
  EnvLayout layout = EnvLayout::kAuto;
  std::string input_colour_space;  // "" = from the file's pixel type
  std::string working_colour_space = kDefaultWorkingSpace;
  std::string ocio_config;  // "" = $OCIO, then the built-in config (embedded runs only)
  std::optional<std::array<double, 3>> rotate_ypr_deg;  // lighting rotation, degrees
  bool replace_non_finite = false;                      // NaN/Inf -> 0 (default: reject)

  bool operator==(const EnvironmentSpec&) const = default;
};

// One file or six; finite rotation angles.
[[nodiscard]] absl::Status ValidateEnvironment(const EnvironmentSpec& env);
// R = Ry(yaw) Rx(pitch) Rz(roll) (identity without a rotation).
Mat3 EnvironmentRotation(const EnvironmentSpec& env);
// "yaw,pitch,roll" as recorded in shrm:rotate_ypr_deg ("" without a rotation).
std::string RotationAttribute(const EnvironmentSpec& env);
// How core reads the spec's files (`paths` replaces the files: the service reads blobs).
EnvMapOptions EnvMapOptionsFor(const EnvironmentSpec& env);
EnvMapOptions EnvMapOptionsFor(const EnvironmentSpec& env, const std::vector<std::string>& paths);

// Where a job's map came from, as its outputs record it.
struct SourceIdentity {
  std::string names;   // the file names joined by ','
  std::string sha256;  // one file's SHA-256, or the SHA-256 of the six hashes joined by ','
};
// The source SHA-256 of files whose SHA-256s are `hashes` (one or six).
std::string CombinedSourceSha256(const std::vector<std::string>& hashes);
// Hashes the spec's files.
absl::StatusOr<SourceIdentity> LocalSourceIdentity(const EnvironmentSpec& env);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_ENVIRONMENT_H_
