// An engine tool's use of the shrm core (shrm::core) without the job layer or the service: decode
// a map, run the pipeline in process and compare the cube with an SHRM file made elsewhere (the
// CLI's output in tests/install_test.sh): every coefficient must be the same float.
//   prefilter_core MAP BRDF EPSILON THREADS SHRM_FILE
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_file.h"
#include "shrm/version.h"

namespace {

int Fail(const absl::Status& s) {
  std::fprintf(stderr, "prefilter_core: %s\n", std::string(s.message()).c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: %s MAP BRDF EPSILON THREADS SHRM_FILE\n", argv[0]);
    return 2;
  }
  absl::StatusOr<std::unique_ptr<shrm::Brdf>> brdf = shrm::ParseBrdfSpec(argv[2]);
  if (!brdf.ok()) return Fail(brdf.status());
  shrm::EnvMapOptions env_options;
  env_options.paths = {argv[1]};
  absl::StatusOr<shrm::EnvMap> env = shrm::EnvMap::Load(env_options);
  if (!env.ok()) return Fail(env.status());
  shrm::PrefilterOptions options;
  options.epsilon = std::strtod(argv[3], nullptr);
  options.threads = std::atoi(argv[4]);
  absl::StatusOr<shrm::PrefilterResult> result = shrm::Prefilter(*env, **brdf, options);
  if (!result.ok()) return Fail(result.status());

  absl::StatusOr<shrm::ShrmFile> file = shrm::ReadShrmFile(argv[5]);
  if (!file.ok()) return Fail(file.status());
  const shrm::ShrmCube& a = result->cube;
  const shrm::ShrmCube& b = file->cube;
  if (a.kind != b.kind || a.face_size != b.face_size || a.pmax != b.pmax ||
      a.channels != b.channels || a.data.size() != b.data.size()) {
    std::fprintf(stderr,
                 "prefilter_core: cube %d^2 P_B %d differs in shape from %s (%d^2 P_B %d)\n",
                 a.face_size, a.pmax, argv[5], b.face_size, b.pmax);
    return 1;
  }
  size_t differing = 0;
  for (size_t i = 0; i < a.data.size(); ++i) differing += a.data[i] != b.data[i];
  if (differing > 0) {
    std::fprintf(stderr, "prefilter_core: %zu of %zu coefficients differ from %s\n", differing,
                 a.data.size(), argv[5]);
    return 1;
  }
  std::printf("shrm %s core: F_B %d, P_B %d, face %d: all %zu coefficients equal %s\n",
              shrm::kVersion, result->analysis.f_b, result->analysis.p_b, a.face_size,
              a.data.size(), argv[5]);
  return 0;
}
