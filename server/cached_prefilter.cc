#include "server/cached_prefilter.h"

#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_projection.h"
#include "core/envmap/lighting.h"
#include "core/shrm/shrm_analysis.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm::server {
namespace {

// Exact text of a double for cache keys.
std::string KeyNumber(double x) { return absl::StrFormat("%a", x); }

}  // namespace

absl::StatusOr<CachedPrefilterResult> CachedPrefilter(const CachedPrefilterInput& input,
                                                      PrefilterCaches* caches,
                                                      const StageHook& hook) {
  const PrefilterOptions& options = input.options;
  const Brdf& brdf = *input.brdf;
  SHRM_RETURN_IF_ERROR(ValidatePrefilterOptions(options));
  const bool explicit_orders = options.f >= 0 || options.p >= 0;
  CachedPrefilterResult out;
  PrefilterResult& r = out.result;
  StageClock clock(&r.timings, hook);
  const bool may_split =
      options.peak_lights != PeakLights::kOff && PeakLightsSkipReason(options, brdf).empty();
  if ((options.tolerance > 0 && !explicit_orders) || may_split) {
    // The tolerance rule computes rho_lpq and L_lm at reference orders it grows per job
    // (core/shrm/prefilter.cc), and peak lights take the lighting of the map's rest: the map is
    // decoded and the core pipeline runs whole, uncached.
    SHRM_RETURN_IF_ERROR(clock.Begin("decode"));
    SHRM_ASSIGN_OR_RETURN(EnvMap env, EnvMap::Load(input.env));
    clock.End();
    PrefilterOptions bounded = options;
    bounded.max_cube_values = input.max_cube_values;
    SHRM_ASSIGN_OR_RETURN(PrefilterResult full, Prefilter(env, brdf, bounded, hook));
    std::vector<StageTiming> timings = std::move(r.timings);
    r = std::move(full);
    timings.insert(timings.end(), r.timings.begin(), r.timings.end());
    r.timings = std::move(timings);
    out.layout = env.layout();
    return out;
  }

  // 1. rho_lpq.
  SHRM_RETURN_IF_ERROR(clock.Begin("brdf"));
  const std::string brdf_key =
      explicit_orders
          ? absl::StrCat(brdf.spec(), "|orders=", options.f, ",",
                         brdf.radially_symmetric() ? 0 : options.p,
                         "|view=", ViewVariableName(EffectiveViewVariable(brdf, options.view)))
          : absl::StrCat(brdf.spec(), "|epsilon=", KeyNumber(options.epsilon));
  std::shared_ptr<const CachedBrdf> cb = caches->brdf.Get(brdf_key);
  out.brdf_hit = cb != nullptr;
  if (!cb) {
    auto fresh = std::make_shared<CachedBrdf>();
    SHRM_ASSIGN_OR_RETURN(fresh->stage, ComputeBrdfStage(brdf, options));
    const size_t bytes =
        (fresh->stage.coefficients.values.size() + fresh->stage.coefficients.total_energy.size()) *
        sizeof(double);
    caches->brdf.Put(brdf_key, fresh, bytes);
    cb = std::move(fresh);
  }
  const int f_rho = cb->stage.f_rho;
  clock.End();

  // 2. L_lm up to F_rho (and the map's energy), decoding the map only on a miss.
  const std::string light_key = absl::StrCat(input.env_key, "|F=", f_rho);
  std::shared_ptr<const CachedLighting> cl = caches->lighting.Get(light_key);
  out.lighting_hit = cl != nullptr;
  std::optional<EnvMap> env;  // decoded on a lighting miss, or for the check (verify)
  auto decode = [&]() -> absl::Status {
    SHRM_RETURN_IF_ERROR(clock.Begin("decode"));
    SHRM_ASSIGN_OR_RETURN(EnvMap map, EnvMap::Load(input.env));
    env.emplace(std::move(map));
    clock.End();
    return absl::OkStatus();
  };
  if (!cl) {
    SHRM_RETURN_IF_ERROR(decode());
    SHRM_RETURN_IF_ERROR(clock.Begin("lighting"));
    auto fresh = std::make_shared<CachedLighting>();
    SHRM_ASSIGN_OR_RETURN(fresh->stage, ComputeLightingStage(*env, f_rho, options));
    fresh->layout = env->layout();
    clock.End();
    caches->lighting.Put(light_key, fresh, fresh->stage.light.size() * sizeof(double));
    cl = std::move(fresh);
  } else {
    SHRM_RETURN_IF_ERROR(clock.Begin("lighting"));
    clock.End();
  }
  out.layout = cl->layout;
  SHRM_RETURN_IF_ERROR(FinishPrefilter(cb->stage, cl->stage, options, hook, &r,
                                       input.max_cube_values, options.admit_cube));
  if (options.verify > 0 && options.synthesize) {
    if (!env) SHRM_RETURN_IF_ERROR(decode());
    SHRM_RETURN_IF_ERROR(clock.Begin("verify"));
    SHRM_ASSIGN_OR_RETURN(r.measured, MeasureCubeError(*env, brdf, options.rotation, r.cube,
                                                       options.verify, options.threads));
    r.verified_pairs = options.verify;
    clock.End();
  }
  r.peak_lights_note = PeakLightsSkipReason(options, brdf);  // the embedded run's note
  return out;
}

}  // namespace shrm::server
