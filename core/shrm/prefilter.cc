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

bool ExplicitOrders(const PrefilterOptions& o) { return o.f >= 0 || o.p >= 0; }

}  // namespace

absl::Status StageClock::Begin(const char* stage) {
  if (progress_) SHRM_RETURN_IF_ERROR(progress_(stage));
  stage_ = stage;
  start_ = std::chrono::steady_clock::now();
  return absl::OkStatus();
}

void StageClock::End() {
  timings_->push_back(
      {stage_, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_)
                   .count()});
}

absl::Status ValidatePrefilterOptions(const PrefilterOptions& options) {
  if (ExplicitOrders(options) && (options.f < 0 || options.p < 0)) {
    return absl::InvalidArgumentError("explicit orders need both F and P (e.g. --orders 24,3)");
  }
  if (!(options.epsilon > 0 && options.epsilon < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("epsilon must be in (0, 1), got ", options.epsilon));
  }
  if (options.face_size < 0 || options.threads < 1) {
    return absl::InvalidArgumentError("face size must be >= 0 and threads >= 1");
  }
  return absl::OkStatus();
}

absl::StatusOr<BrdfStage> ComputeBrdfStage(const Brdf& brdf, const PrefilterOptions& options) {
  BrdfStage st;
  if (ExplicitOrders(options)) {
    st.f_rho = options.f;
    st.p_rho = brdf.radially_symmetric() ? 0 : options.p;
    SHRM_ASSIGN_OR_RETURN(st.coefficients, ComputeBrdfCoefficients(brdf, st.f_rho, st.p_rho));
  } else {
    SHRM_ASSIGN_OR_RETURN(BrdfOrders orders, SelectBrdfOrders(brdf, options.epsilon));
    st.f_rho = orders.F;
    st.p_rho = orders.P;
    st.coefficients = std::move(orders.coefficients);
  }
  return st;
}

absl::StatusOr<LightingStage> ComputeLightingStage(const EnvMap& env, int lmax,
                                                   const PrefilterOptions& options) {
  LightingStage st;
  SHRM_ASSIGN_OR_RETURN(st.light,
                        LightingCoefficients(env, lmax, options.rotation, options.threads));
  st.energy = LightingEnergy(env);
  return st;
}

absl::Status FinishPrefilter(const BrdfStage& brdf, const LightingStage& lighting,
                             const PrefilterOptions& options, const PrefilterProgress& progress,
                             PrefilterResult* r, double max_cube_values) {
  StageClock clock(&r->timings, progress);
  r->brdf = brdf.coefficients;
  r->light_lmax = brdf.f_rho;
  r->light = lighting.light;
  SHRM_RETURN_IF_ERROR(clock.Begin("analysis"));
  ShrmAnalysisOptions aopt;
  aopt.epsilon = options.epsilon;
  aopt.explicit_orders = ExplicitOrders(options);
  aopt.f_brdf = brdf.f_rho;
  aopt.p_brdf = brdf.p_rho;
  SHRM_ASSIGN_OR_RETURN(r->analysis,
                        AnalyzeShrm(r->light_lmax, 3, r->light, lighting.energy, r->brdf, aopt));
  clock.End();
  if (!options.synthesize) return absl::OkStatus();

  SHRM_RETURN_IF_ERROR(clock.Begin("synthesis"));
  const int face_size = options.face_size > 0 ? options.face_size
                                              : std::clamp(r->analysis.suggested_face_size,
                                                           kMinAutoFaceSize, kMaxAutoFaceSize);
  const double cube_values =
      6.0 * face_size * face_size * (r->analysis.p_b + 1.0) * (r->analysis.p_b + 1.0) * 3;
  if (max_cube_values > 0 && cube_values > max_cube_values) {
    return absl::InvalidArgumentError(
        absl::StrCat("face size ", face_size, " with P_B = ", r->analysis.p_b, " needs ",
                     cube_values, " values, above the limit of ", max_cube_values));
  }
  SHRM_ASSIGN_OR_RETURN(ShrmSynthesizer synth,
                        ShrmSynthesizer::Create(r->light_lmax, 3, r->light, r->brdf,
                                                r->analysis.f_b, r->analysis.p_b));
  ShrmGridOptions gopt;
  gopt.threads = options.threads;
  SHRM_ASSIGN_OR_RETURN(r->cube, synth.BuildCube(options.kind, face_size, gopt));
  clock.End();
  return absl::OkStatus();
}

absl::StatusOr<PrefilterResult> Prefilter(const EnvMap& env, const Brdf& brdf,
                                          const PrefilterOptions& options,
                                          const PrefilterProgress& progress) {
  SHRM_RETURN_IF_ERROR(ValidatePrefilterOptions(options));
  PrefilterResult r;
  StageClock clock(&r.timings, progress);
  SHRM_RETURN_IF_ERROR(clock.Begin("brdf"));
  SHRM_ASSIGN_OR_RETURN(BrdfStage b, ComputeBrdfStage(brdf, options));
  clock.End();
  SHRM_RETURN_IF_ERROR(clock.Begin("lighting"));
  SHRM_ASSIGN_OR_RETURN(LightingStage l, ComputeLightingStage(env, b.f_rho, options));
  clock.End();
  SHRM_RETURN_IF_ERROR(FinishPrefilter(b, l, options, progress, &r));
  return r;
}

}  // namespace shrm
