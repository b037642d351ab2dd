#include "core/shrm/prefilter.h"

#include <algorithm>
#include <chrono>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_projection.h"
#include "core/envmap/lighting.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm {
namespace {

// Smallest and largest automatic S_B (sec. 5.5.2 suggests S ~ 10 F).
constexpr int kMinAutoFaceSize = 16;
constexpr int kMaxAutoFaceSize = 512;

class StageClock {
 public:
  StageClock(std::vector<StageTiming>* timings, const PrefilterProgress& progress)
      : timings_(timings), progress_(progress) {}
  void Begin(const char* stage) {
    if (progress_) progress_(stage);
    stage_ = stage;
    start_ = std::chrono::steady_clock::now();
  }
  void End() {
    timings_->push_back({stage_, std::chrono::duration<double, std::milli>(
                                     std::chrono::steady_clock::now() - start_)
                                     .count()});
  }

 private:
  std::vector<StageTiming>* timings_;
  const PrefilterProgress& progress_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

absl::StatusOr<PrefilterResult> Prefilter(const EnvMap& env, const Brdf& brdf,
                                          const PrefilterOptions& options,
                                          const PrefilterProgress& progress) {
  const bool explicit_orders = options.f >= 0 || options.p >= 0;
  if (explicit_orders && (options.f < 0 || options.p < 0)) {
    return absl::InvalidArgumentError("explicit orders need both F and P (e.g. --orders 24,3)");
  }
  if (!(options.epsilon > 0 && options.epsilon < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("epsilon must be in (0, 1), got ", options.epsilon));
  }
  if (options.face_size < 0 || options.threads < 1) {
    return absl::InvalidArgumentError("face size must be >= 0 and threads >= 1");
  }
  PrefilterResult r;
  StageClock clock(&r.timings, progress);

  clock.Begin("brdf");
  int f_rho, p_rho;
  if (explicit_orders) {
    f_rho = options.f;
    p_rho = brdf.radially_symmetric() ? 0 : options.p;
    SHRM_ASSIGN_OR_RETURN(r.brdf, ComputeBrdfCoefficients(brdf, f_rho, p_rho));
  } else {
    SHRM_ASSIGN_OR_RETURN(BrdfOrders orders, SelectBrdfOrders(brdf, options.epsilon));
    f_rho = orders.F;
    p_rho = orders.P;
    r.brdf = std::move(orders.coefficients);
  }
  clock.End();

  clock.Begin("lighting");
  r.light_lmax = f_rho;
  SHRM_ASSIGN_OR_RETURN(r.light,
                        LightingCoefficients(env, r.light_lmax, options.rotation, options.threads));
  const std::array<double, 3> light_total = LightingEnergy(env);
  clock.End();

  clock.Begin("analysis");
  ShrmAnalysisOptions aopt;
  aopt.epsilon = options.epsilon;
  aopt.explicit_orders = explicit_orders;
  aopt.f_brdf = f_rho;
  aopt.p_brdf = p_rho;
  SHRM_ASSIGN_OR_RETURN(r.analysis,
                        AnalyzeShrm(r.light_lmax, 3, r.light, light_total, r.brdf, aopt));
  clock.End();
  if (!options.synthesize) return r;

  clock.Begin("synthesis");
  const int face_size = options.face_size > 0 ? options.face_size
                                              : std::clamp(r.analysis.suggested_face_size,
                                                           kMinAutoFaceSize, kMaxAutoFaceSize);
  SHRM_ASSIGN_OR_RETURN(
      ShrmSynthesizer synth,
      ShrmSynthesizer::Create(r.light_lmax, 3, r.light, r.brdf, r.analysis.f_b, r.analysis.p_b));
  ShrmGridOptions gopt;
  gopt.threads = options.threads;
  SHRM_ASSIGN_OR_RETURN(r.cube, synth.BuildCube(options.kind, face_size, gopt));
  clock.End();
  return r;
}

}  // namespace shrm
