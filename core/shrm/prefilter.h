// The prefilter pipeline of the SHRM paper (sec. 5.6.2) in one call, shared by the `shrm` command
// and the service: an environment map and a BRDF in, the orders (sec. 5.5) and the SHRM cube out.
//   1. BRDF orders (F_rho, P_rho) for epsilon (eqs. 5.17/5.18, smallest P then smallest F) and
//      the coefficients rho_lpq (eq. 5.22), or the orders given explicitly;
//   2. lighting coefficients L_lm (eqs. 5.20-5.21) up to F_rho, rotated exactly if asked;
//   3. F_B, P_B, eps estimates and the eq. 5.19 bound (core/shrm/shrm_analysis.h);
//   4. the local or global SHRM (eqs. 5.23-5.24, 5.14) on cube faces of size S_B.
#ifndef SHRM_CORE_SHRM_PREFILTER_H_
#define SHRM_CORE_SHRM_PREFILTER_H_

#include <array>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
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
#include "core/shrm/shrm_synthesis.h"
#include "core/shrm/tolerance.h"

namespace shrm {

// Peak lights (PrefilterOptions::peak_lights): off, on (split where it pays: the rest keeps at
// most kPeakSpreadShare of the map's non-constant luminance energy), or auto (the same split, for
// the jobs whose every consumer can sum the lights: PeakLightsSkipReason).
enum class PeakLights { kOff, kAuto, kOn };
const char* PeakLightsName(PeakLights mode);  // "off", "auto", "on"
std::optional<PeakLights> ParsePeakLights(std::string_view name);

struct PrefilterOptions;
// Why `options.peak_lights` (kAuto) splits nothing whatever the map: the rule, the BRDF (the
// report's note); "" when the map decides (kOn, kOff, and kAuto where the map's peaks would be
// split).
std::string PeakLightsSkipReason(const PrefilterOptions& options, const Brdf& brdf);

struct PrefilterOptions {
  double epsilon = 0.03;  // tolerance for the order selection, in (0, 1)
  int f = -1;             // explicit F_B (with p): skips the selection; -1 = from epsilon
  int p = -1;             // explicit P_B
  ShrmKind kind = ShrmKind::kGlobal;
  int face_size = 0;                 // S_B; 0 = the suggestion S ~ 10 F_B, clamped to [16, 512]
  Mat3 rotation = Mat3::Identity();  // world rotation of the lighting (exact, in SH space)
  int threads = 1;
  bool synthesize = true;  // false: orders and analysis only
  // > 0 (and no explicit orders): F_B, P_B, the ringing window and S_B (unless face_size is
  // given) are chosen for this per-direction tolerance (core/shrm/tolerance.h; epsilon then
  // only names the analysis' energy figures); 0 = the paper's epsilon rule (sec. 5.5).
  double tolerance = 0;
  // Ringing window on the lighting bands; kAuto (tolerance rule only) = chosen per job.
  RingingWindow window = RingingWindow::kNone;
  // The view expansion's variable (brdf_coefficients.h) for the tolerance rule and explicit
  // orders; the epsilon rule (eqs. 5.15-5.19, Table 5.5) is the paper's and always takes kView.
  ViewVariable view = ViewVariable::kView;
  // Tolerance rule only: when the choice in `view` misses the tolerance in front RMS (its
  // estimate, FrontScore > 1), the choice in the other variable is made too, and taken when its
  // RmsScore (front and grazing RMS against their targets) is the smaller (docs/shrm.md "The
  // view variable": the normal variable
  // converges at grazing views but halves the view expansion's angular room, so the sharpest and
  // most Fresnel-driven lobes can need more P than the orders allow in it).
  bool try_other_view = false;
  // Pairs of the tolerance rule's estimate (seeded: kSelectionSeed); four times as many for a
  // radially symmetric BRDF (prefilter.cc SelectionPairs).
  int selection_pairs = 256;
  // Tolerance rule only, > 0: the size budget on CubeValues(S_B, P_B) (ToleranceOptions::
  // max_cube_values): the most accurate choice within it when the tolerance's needs more.
  double size_budget_values = 0;
  // Prefilter() only (FinishPrefilter takes it as an argument): > 0 bounds 6 S_B^2 (P_B + 1)^2 3.
  double max_cube_values = 0;
  // Prefilter() only (FinishPrefilter takes it as an argument): called with S_B and P_B once they
  // are known, before the cube is allocated; a non-OK status (e.g. a memory budget's refusal)
  // stops the pipeline with it.
  std::function<absl::Status(int face_size, int p_b)> admit_cube;
  // > 0: the synthesized cube (ShrmEval) is measured at this many seeded pairs
  // (StratifiedDirectionPairs from kVerifySeed, never the selection's) against FastReference (the
  // brute-force sum to 1e-3 per direction): PrefilterResult::measured, stage "verify".
  int verify = 0;
  // The map's brightest pixels (a sun, lamps) split off by SplitLightPeaks
  // (core/envmap/light_split.h) where that pays, and shipped as the cube's lights
  // (ShrmCube::lights: summed exactly at evaluation, ShrmEvalWithLights); every other stage,
  // the order choice included, sees the rest of the map, whose dynamic range the split caps
  // (docs/shrm.md "Peak lights"). The check measures the whole (expansion + lights) against
  // the whole map. kAuto (the job layer's default) splits as kOn does, but only under the
  // tolerance rule (the epsilon rule's analysis and explicit orders see the whole map) and for a
  // view-dependent BRDF the shipped shaders evaluate (BrdfShaderParamsFor). Until session 45 it
  // split only a sun (the rest at most 1% of the energy: city.exr 0.02%, interior.exr 0.05%);
  // forest.exr's bright sky (11%) then went unsplit, and with its lights its seven default rows
  // measure better on every target (docs/results.md "Session 45").
  PeakLights peak_lights = PeakLights::kOff;
  // With verify > 0: the check's FastReference is kept in PrefilterResult::reference for a
  // caller that measures against the same map again (the visual report), instead of being
  // built twice (~0.1-0.3 s and ~100 MB for a 1024 x 512 map).
  bool keep_reference = false;
};

struct StageTiming {
  std::string stage;
  double ms = 0;
};

class FastReference;

struct PrefilterResult {
  ShrmAnalysis analysis;
  BrdfCoefficients brdf;  // at (F_rho, P_rho) or the explicit orders
  int light_lmax = 0;
  std::vector<double> light;  // RGB L_lm, degree light_lmax (transform layout)
  ShrmCube cube;              // empty when !synthesize
  std::vector<StageTiming> timings;
  RingingWindow window = RingingWindow::kNone;  // applied to `light` before synthesis
  bool tolerance_rule = false;                  // orders from options.tolerance
  ToleranceChoice choice;                       // the tolerance rule's estimate (tolerance_rule)
  // try_other_view: the RmsScore of the choice in each variable tried, in the order tried (empty
  // when only one was).
  std::vector<std::pair<ViewVariable, double>> view_trials;
  // peak_lights: the luminance above which pixels were split (0: the map was not split, and
  // cube.lights is empty).
  double peak_threshold = 0;
  // Why no lights were split when peak_lights asked for them ("" when some were).
  std::string peak_lights_note;
  int verified_pairs = 0;     // options.verify when the cube was measured
  DirectionalError measured;  // the cube against FastReference
  // The check's reference when PrefilterOptions::keep_reference (else null).
  std::shared_ptr<const FastReference> reference;
};

// The measured error of `cube` (made from `env` rotated by `rotation` and `brdf`; its lights
// included, ShrmEvalWithLights) at `pairs` seeded pairs (StratifiedDirectionPairs from kVerifySeed)
// against FastReference. Errors: no samples, pairs < 1, threads < 1.
absl::StatusOr<DirectionalError> MeasureCubeError(const EnvMap& env, const Brdf& brdf,
                                                  const Mat3& rotation, const ShrmCube& cube,
                                                  int pairs, int threads);
// The same against a reference built once (FastReference::Create of the map's samples), for
// callers that check many cubes of one map (the viewer).
absl::StatusOr<DirectionalError> MeasureCubeError(const FastReference& reference, const Brdf& brdf,
                                                  const Mat3& rotation, const ShrmCube& cube,
                                                  int pairs, int threads);

// Called at the start of each stage with its name ("brdf", "lighting", "analysis", "synthesis");
// a non-OK status (e.g. a cancelled or expired request) stops the pipeline with that status.
using PrefilterProgress = std::function<absl::Status(std::string_view stage)>;

// Times stages into a StageTiming list, calling the progress hook at each start.
class StageClock {
 public:
  StageClock(std::vector<StageTiming>* timings, const PrefilterProgress& progress)
      : timings_(timings), progress_(progress) {}
  // Calls the hook (its error stops the caller) and starts timing `stage`.
  absl::Status Begin(const char* stage);
  // Appends the running stage's time.
  void End();

 private:
  std::vector<StageTiming>* timings_;
  const PrefilterProgress& progress_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

// Errors: InvalidArgument for bad options (epsilon outside (0, 1), one of f/p without the other,
// negative orders, an order above what the map resolves), OutOfRange when the BRDF cannot reach
// epsilon within the supported orders, and those of the stages.
absl::StatusOr<PrefilterResult> Prefilter(const EnvMap& env, const Brdf& brdf,
                                          const PrefilterOptions& options,
                                          const PrefilterProgress& progress = nullptr);

// The stages of Prefilter(), for callers that cache their results (the service): the BRDF stage
// depends only on the BRDF and (epsilon | F, P); the lighting stage only on the map, the rotation
// and the degree F_rho.
absl::Status ValidatePrefilterOptions(const PrefilterOptions& options);

struct BrdfStage {
  int f_rho = 0, p_rho = 0;
  BrdfCoefficients coefficients;  // at least (f_rho, p_rho)
};
// Stage 1: (F_rho, P_rho) and rho_lpq.
absl::StatusOr<BrdfStage> ComputeBrdfStage(const Brdf& brdf, const PrefilterOptions& options);

struct LightingStage {
  std::vector<double> light;       // RGB L_lm up to the stage's degree, rotated
  std::array<double, 3> energy{};  // integral L_c^2 dw (eq. 5.15)
};
// Stage 2: L_lm up to degree lmax (= F_rho) and the map's energy.
absl::StatusOr<LightingStage> ComputeLightingStage(const EnvMap& env, int lmax,
                                                   const PrefilterOptions& options);

// Stages 3-4 into *r (r->brdf, r->light, r->analysis, r->cube; "analysis" and "synthesis"
// appended to r->timings). max_cube_values > 0 bounds 6 S_B^2 (P_B + 1)^2 3 (InvalidArgument
// naming S_B and P_B above it). `scratch` (optional): the synthesis grid's storage, kept by a
// caller that synthesizes again and again (a live session).
absl::Status FinishPrefilter(const BrdfStage& brdf, const LightingStage& lighting,
                             const PrefilterOptions& options, const PrefilterProgress& progress,
                             PrefilterResult* r, double max_cube_values = 0,
                             const std::function<absl::Status(int, int)>& admit_cube = nullptr,
                             SynthesisScratch* scratch = nullptr);

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_PREFILTER_H_
