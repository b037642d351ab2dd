// The prefilter pipeline of the SHRM paper (sec. 5.6.2) in one call, shared by the `shrm` command
// and the service: an environment map and a BRDF in, the orders (sec. 5.5) and the SHRM cube out.
//   1. BRDF orders (F_rho, P_rho) for epsilon (eqs. 5.17/5.18, smallest P then smallest F) and
//      the coefficients rho_lpq (eq. 5.22), or the orders given explicitly;
//   2. lighting coefficients L_lm (eqs. 5.20-5.21) up to F_rho, rotated exactly if asked;
//   3. F_B, P_B, eps estimates and the eq. 5.19 bound (core/shrm/shrm_analysis.h);
//   4. the local or global SHRM (eqs. 5.23-5.24, 5.14) on cube faces of size S_B.
#ifndef SHRM_CORE_SHRM_PREFILTER_H_
#define SHRM_CORE_SHRM_PREFILTER_H_

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_coefficients.h"
#include "core/envmap/envmap.h"
#include "core/shrm/shrm_analysis.h"
#include "core/shrm/shrm_map.h"

namespace shrm {

struct PrefilterOptions {
  double epsilon = 0.03;  // tolerance for the order selection, in (0, 1)
  int f = -1;             // explicit F_B (with p): skips the selection; -1 = from epsilon
  int p = -1;             // explicit P_B
  ShrmKind kind = ShrmKind::kGlobal;
  int face_size = 0;                 // S_B; 0 = the suggestion S ~ 10 F_B, clamped to [16, 512]
  Mat3 rotation = Mat3::Identity();  // world rotation of the lighting (exact, in SH space)
  int threads = 1;
  bool synthesize = true;  // false: orders and analysis only
};

struct StageTiming {
  std::string stage;
  double ms = 0;
};

struct PrefilterResult {
  ShrmAnalysis analysis;
  BrdfCoefficients brdf;  // at (F_rho, P_rho) or the explicit orders
  int light_lmax = 0;
  std::vector<double> light;  // RGB L_lm, degree light_lmax (transform layout)
  ShrmCube cube;              // empty when !synthesize
  std::vector<StageTiming> timings;
};

// Called at the start of each stage with its name ("brdf", "lighting", "analysis", "synthesis").
using PrefilterProgress = std::function<void(std::string_view stage)>;

// Errors: InvalidArgument for bad options (epsilon outside (0, 1), one of f/p without the other,
// negative orders, an order above what the map resolves), OutOfRange when the BRDF cannot reach
// epsilon within the supported orders, and those of the stages.
absl::StatusOr<PrefilterResult> Prefilter(const EnvMap& env, const Brdf& brdf,
                                          const PrefilterOptions& options,
                                          const PrefilterProgress& progress = nullptr);

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_PREFILTER_H_
