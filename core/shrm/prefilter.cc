#include "core/shrm/prefilter.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_projection.h"
#include "core/brdf/brdf_shader_params.h"
#include "core/envmap/light_split.h"
#include "core/envmap/lighting.h"
#include "core/sh/sh.h"
#include "core/shrm/fast_reference.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/shrm/tolerance.h"

namespace shrm {
namespace {

// Smallest and largest automatic S_B (sec. 5.5.2 suggests S ~ 10 F).
constexpr int kMinAutoFaceSize = 16;
constexpr int kMaxAutoFaceSize = 512;

bool ExplicitOrders(const PrefilterOptions& o) { return o.f >= 0 || o.p >= 0; }

// The synthesis grid's interpolation error allowed (ShrmSynthesizer::InterpolationRows):
// kSynthesisGridShare (a tenth) of the error the orders were chosen for, the per-direction
// tolerance or, under the paper's rule, sqrt(epsilon) (the relative RMS of the energy fraction it
// drops). Explicit orders name no error: BuildCube's fixed rule (0).
double InterpolationTolerance(const PrefilterOptions& o) {
  if (o.tolerance > 0) return kSynthesisGridShare * o.tolerance;
  if (!ExplicitOrders(o)) return kSynthesisGridShare * std::sqrt(o.epsilon);
  return 0;
}

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
  if (!(options.tolerance >= 0 && options.tolerance < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("tolerance must be in (0, 1), got ", options.tolerance));
  }
  if (options.tolerance > 0 && options.selection_pairs < 16) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the tolerance rule needs at least 16 selection pairs, got ", options.selection_pairs));
  }
  if (options.verify < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("verify must be >= 0 pairs, got ", options.verify));
  }
  if (!(options.size_budget_values >= 0 && std::isfinite(options.size_budget_values))) {
    return absl::InvalidArgumentError(
        absl::StrCat("the size budget must be >= 0 values, got ", options.size_budget_values));
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
    SHRM_ASSIGN_OR_RETURN(st.coefficients,
                          ComputeBrdfCoefficients(brdf, st.f_rho, st.p_rho, {}, options.view));
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
                             PrefilterResult* r, double max_cube_values,
                             const std::function<absl::Status(int, int)>& admit_cube,
                             SynthesisScratch* scratch) {
  StageClock clock(&r->timings, progress);
  r->brdf = brdf.coefficients;
  r->light_lmax = brdf.f_rho;
  r->window =
      options.window == RingingWindow::kLanczos ? RingingWindow::kLanczos : RingingWindow::kNone;
  r->light = ApplyWindow(r->window, brdf.f_rho, brdf.f_rho, 3,
                         std::span<const double>(lighting.light).first(ShCount(brdf.f_rho) * 3));
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
  const double cube_values = CubeValues(face_size, r->analysis.p_b);
  if (max_cube_values > 0 && cube_values > max_cube_values) {
    return absl::InvalidArgumentError(
        absl::StrCat("face size ", face_size, " with P_B = ", r->analysis.p_b, " needs ",
                     cube_values, " values, above the limit of ", max_cube_values));
  }
  if (admit_cube) {
    SHRM_RETURN_IF_ERROR(admit_cube(face_size, r->analysis.p_b));
  }
  SHRM_ASSIGN_OR_RETURN(ShrmSynthesizer synth,
                        ShrmSynthesizer::Create(r->light_lmax, 3, r->light, r->brdf,
                                                r->analysis.f_b, r->analysis.p_b));
  ShrmGridOptions gopt;
  gopt.threads = options.threads;
  gopt.scratch = scratch;
  gopt.alpha_samples = synth.InterpolationRows(options.kind, InterpolationTolerance(options));
  SHRM_ASSIGN_OR_RETURN(r->cube, synth.BuildCube(options.kind, face_size, gopt));
  clock.End();
  return absl::OkStatus();
}

namespace {

// The tolerance rule's reference orders: the first, the growth while the choice comes within
// kReferenceMargin of them (its estimate would miss the tail beyond), and the caps.
constexpr int kFirstReferenceF = 32;
constexpr int kFirstReferenceP = 8;
constexpr double kReferenceMargin = 0.75;
constexpr int kMaxReferenceF = 256;
constexpr int kMaxReferenceP = 31;
constexpr int kMaxReferenceRounds = 3;

// Highest lighting degree the map resolves (lat-long: the SHT's limit; other layouts are
// resampled by LightingCoefficients).
int MaxLightingDegree(const EnvMap& env) {
  if (env.layout() == EnvLayout::kLatLong) return std::min(env.height() - 1, (env.width() - 1) / 2);
  return kMaxReferenceF;
}

// Sums the timings of stages run more than once (the reference rounds), keeping first-run order.
void MergeTimings(std::vector<StageTiming>* timings) {
  std::vector<StageTiming> merged;
  for (const StageTiming& t : *timings) {
    auto it = std::find_if(merged.begin(), merged.end(),
                           [&](const StageTiming& m) { return m.stage == t.stage; });
    if (it == merged.end())
      merged.push_back(t);
    else
      it->ms += t.ms;
  }
  timings->swap(merged);
}

// The selection's pair count: options.selection_pairs, times kRadialSelectionFactor for a
// radially symmetric BRDF (Phong). Its error depends on R alone, a function of two angles the
// pairs sample, and a pair costs 1 / (P_ref + 1)^2 of a view-dependent one. At 256 directions
// (about 13 degrees apart) the sun's ringing, a few degrees wide at s = 128, fell between them:
// forest.exr Phong s = 128 took F = 39, whose largest error over 2048 other pairs is 7.5%; 1024
// directions (6 degrees apart) take F = 41 and measure 3.6% (docs/results.md, session 34).
constexpr int kRadialSelectionFactor = 4;
int SelectionPairs(const Brdf& brdf, const PrefilterOptions& options) {
  return brdf.radially_symmetric() ? kRadialSelectionFactor * options.selection_pairs
                                   : options.selection_pairs;
}

// The selection's pairs are this many times as many for the rest of a split map (peak lights)
// and a view-dependent BRDF. The rest's errors are heavy-tailed (a few (N, V) near its brightest
// texels carry them) and 256 pairs missed them: forest.exr microfacet sigma 0.2 took P = 12 and
// measures 2.3% front RMS and 65% largest at 1024 other pairs, with 1024 pairs it takes P = 25
// and measures 0.51% / 12.5%; interior's seven rows meet every target on five instead of none
// (docs/results.md, "Peak lights, session 36"). The rest's orders are low enough that the 4x
// dearer choice still leaves 12 of the 14 city and interior jobs quicker than the whole map's
// expansion (interior microfacet sigma 0.2: 1.2 s against 4.4 s on 2 threads); forest's rest
// needs more P than the whole map was given and its jobs take 1.3-4x longer.
constexpr int kLightsSelectionFactor = 4;
// From this many pairs on, a view-dependent BRDF's selection is drawn stratified as the check's
// (StratifiedDirectionPairs: a quarter grazing), so the grazing estimate rests on 256 pairs
// instead of ~92 while 768 remain in front. Measured on the 14 city and interior default rows
// (peak lights, 1024 pairs; docs/results.md "Stratified selection, session 37"): every row meets
// every target instead of 11 (city microfacet sigma 0.1's grazing RMS 6.1% -> 5.0%, interior's
// sharpest lobes' largest 5.4-5.7% -> 3.2-4.2%) and 10 of the 14 files are smaller (city GGX
// alpha 0.1 f0 0.04: 184 -> 58 MB). At the 256 pairs of an unsplit map the 192 front pairs missed
// more front tails (forest and courtyard: 3 of 14 rows met, 1 stratified), so those keep the plain
// draw.
constexpr int kStratifiedSelectionPairs = 1024;

// The tolerance rule (core/shrm/tolerance.h): rho_lpq and L_lm at reference orders, the band
// table at the selection pairs, the choice; the reference grows while the choice is near it.
absl::Status ChooseOrdersForTolerance(const EnvMap& env, const Brdf& brdf,
                                      const PrefilterOptions& options, StageClock& clock,
                                      BrdfStage* b, LightingStage* l, ToleranceChoice* choice) {
  const int f_cap = std::min({kMaxReferenceF, kMaxBrdfLmax, MaxLightingDegree(env)});
  const int p_cap = brdf.radially_symmetric() ? 0 : std::min(kMaxReferenceP, kMaxBrdfPmax);
  int f_ref = std::min(kFirstReferenceF, f_cap);
  int p_ref = std::min(kFirstReferenceP, p_cap);
  // Many pairs of a view-dependent BRDF (a split map's rest, kLightsSelectionFactor): drawn
  // stratified, a quarter of them grazing (kStratifiedSelectionPairs).
  const int count = SelectionPairs(brdf, options);
  const std::vector<DirectionPair> pairs =
      !brdf.radially_symmetric() && count >= kStratifiedSelectionPairs
          ? StratifiedDirectionPairs(kSelectionSeed, count, brdf.reparam())
          : SeededDirectionPairs(kSelectionSeed, count, brdf.reparam());
  l->energy = LightingEnergy(env);
  ToleranceOptions topt;
  topt.tolerance = options.tolerance;
  topt.window = options.window;
  topt.threads = options.threads;
  BandTable table_of_last_round;
  for (int round = 0;; ++round) {
    SHRM_RETURN_IF_ERROR(clock.Begin("brdf"));
    SHRM_ASSIGN_OR_RETURN(b->coefficients,
                          ComputeBrdfCoefficients(brdf, f_ref, p_ref, {}, options.view));
    clock.End();
    SHRM_RETURN_IF_ERROR(clock.Begin("lighting"));
    SHRM_ASSIGN_OR_RETURN(l->light,
                          LightingCoefficients(env, f_ref, options.rotation, options.threads));
    clock.End();
    SHRM_RETURN_IF_ERROR(clock.Begin("orders"));
    SHRM_ASSIGN_OR_RETURN(
        ShrmSynthesizer reference,
        ShrmSynthesizer::Create(f_ref, 3, l->light, b->coefficients, f_ref, p_ref));
    table_of_last_round = BandTable::Compute(reference, pairs, options.threads);
    *choice = ChooseOrders(table_of_last_round, topt);
    clock.End();
    const bool grow_f = f_ref < f_cap && (choice->f > kReferenceMargin * f_ref || !choice->met);
    const bool grow_p = p_ref < p_cap && (choice->p > kReferenceMargin * p_ref || !choice->met);
    if (!(grow_f || grow_p) || round + 1 >= kMaxReferenceRounds) break;
    if (grow_f) f_ref = std::min(f_cap, 2 * f_ref);
    if (grow_p) p_ref = std::min(p_cap, 2 * p_ref);
  }
  SHRM_RETURN_IF_ERROR(clock.Begin("orders"));
  InterpolationMemo memo;  // the face-size search's estimates, reused by the budget step
  if (options.face_size > 0) {
    choice->face_size = options.face_size;
  } else {
    SHRM_RETURN_IF_ERROR(
        ChooseFaceSize(pairs, f_ref, 3, l->light, b->coefficients, topt, choice,
                       table_of_last_round.Values(choice->f, choice->p, choice->window), &memo));
  }
  // The size budget: the most accurate choice within it when this one needs more.
  if (options.size_budget_values > 0 &&
      CubeValues(choice->face_size, choice->p) > options.size_budget_values) {
    topt.max_cube_values = options.size_budget_values;
    topt.face_size = options.face_size;
    SHRM_RETURN_IF_ERROR(ChooseWithinBudget(table_of_last_round, pairs, f_ref, 3, l->light,
                                            b->coefficients, topt, choice, &memo));
  }
  clock.End();
  b->f_rho = choice->f;
  b->p_rho = choice->p;
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<DirectionalError> MeasureCubeError(const EnvMap& env, const Brdf& brdf,
                                                  const Mat3& rotation, const ShrmCube& cube,
                                                  int pairs, int threads) {
  // The arguments are checked by the overload (the reference costs ~0.3 s; errors are rare).
  SHRM_ASSIGN_OR_RETURN(FastReference reference, FastReference::Create(env, pairs));
  return MeasureCubeError(reference, brdf, rotation, cube, pairs, threads);
}

absl::StatusOr<DirectionalError> MeasureCubeError(const FastReference& reference, const Brdf& brdf,
                                                  const Mat3& rotation, const ShrmCube& cube,
                                                  int pairs, int threads) {
  if (pairs < 1 || threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("verify: pairs and threads must be >= 1, got ", pairs, ", ", threads));
  }
  const std::vector<DirectionPair> set =
      StratifiedDirectionPairs(kVerifySeed, pairs, brdf.reparam());
  std::vector<Vec3> index, view;
  for (const DirectionPair& p : set) {
    index.push_back(p.index);
    view.push_back(p.view);
  }
  const std::vector<Rgb> ref =
      reference.RadianceMany(brdf, rotation, index, view, threads, kCheckReferenceTolerance);
  std::vector<Rgb> got(set.size());
  for (size_t k = 0; k < set.size(); ++k)
    got[k] = ShrmEvalWithLights(cube, brdf, set[k].index, set[k].view);
  return MeasureDirectionalError(set, got, ref);
}

namespace {

// The "verify" stage of Prefilter().
absl::Status VerifyStage(const EnvMap& env, const Brdf& brdf, const PrefilterOptions& options,
                         const PrefilterProgress& progress, PrefilterResult* r) {
  if (options.verify <= 0 || !options.synthesize) return absl::OkStatus();
  StageClock clock(&r->timings, progress);
  SHRM_RETURN_IF_ERROR(clock.Begin("verify"));
  SHRM_ASSIGN_OR_RETURN(FastReference made, FastReference::Create(env, options.verify));
  auto reference = std::make_shared<const FastReference>(std::move(made));
  SHRM_ASSIGN_OR_RETURN(r->measured, MeasureCubeError(*reference, brdf, options.rotation, r->cube,
                                                      options.verify, options.threads));
  if (options.keep_reference) r->reference = std::move(reference);
  r->verified_pairs = options.verify;
  clock.End();
  return absl::OkStatus();
}

}  // namespace

const char* PeakLightsName(PeakLights mode) {
  switch (mode) {
    case PeakLights::kOff:
      return "off";
    case PeakLights::kAuto:
      return "auto";
    case PeakLights::kOn:
      return "on";
  }
  return "?";
}

std::optional<PeakLights> ParsePeakLights(std::string_view name) {
  for (PeakLights m : {PeakLights::kOff, PeakLights::kAuto, PeakLights::kOn})
    if (name == PeakLightsName(m)) return m;
  return std::nullopt;
}

std::string PeakLightsSkipReason(const PrefilterOptions& options, const Brdf& brdf) {
  if (options.peak_lights != PeakLights::kAuto) return "";
  if (!(options.tolerance > 0) || ExplicitOrders(options)) {
    return "auto: with the tolerance rule only (the epsilon rule and explicit orders see the "
           "whole map)";
  }
  if (brdf.radially_symmetric())
    return "auto: not for a radially symmetric BRDF (one degree per band already)";
  if (!BrdfShaderParamsFor(brdf).ok())
    return "auto: not for a BRDF the shipped shaders cannot sum lights with";
  return "";
}

absl::StatusOr<PrefilterResult> Prefilter(const EnvMap& env, const Brdf& brdf,
                                          const PrefilterOptions& options,
                                          const PrefilterProgress& progress) {
  SHRM_RETURN_IF_ERROR(ValidatePrefilterOptions(options));
  std::string peak_note = PeakLightsSkipReason(options, brdf);
  std::vector<StageTiming> split_timing;  // the split's pass, reported whether or not it split
  if (options.peak_lights != PeakLights::kOff && peak_note.empty()) {
    StageClock clock(&split_timing, progress);
    SHRM_RETURN_IF_ERROR(clock.Begin("lights"));
    PeakSplit split = SplitLightPeaks(env, kPeakSpreadShare);
    clock.End();
    if (split.rest) {
      // The rest through every stage but the check, which measures the whole.
      PrefilterOptions rest = options;
      rest.peak_lights = PeakLights::kOff;
      rest.verify = 0;
      if (!brdf.radially_symmetric()) rest.selection_pairs *= kLightsSelectionFactor;
      SHRM_ASSIGN_OR_RETURN(PrefilterResult r, Prefilter(*split.rest, brdf, rest, progress));
      const LightPeaks peaks = RotatedPeaks(split.peaks, options.rotation);
      r.cube.lights.resize(peaks.size());
      for (size_t k = 0; k < peaks.size(); ++k) {
        r.cube.lights[k].dir = {peaks.x[k], peaks.y[k], peaks.z[k]};
        r.cube.lights[k].weight = {peaks.r[k], peaks.g[k], peaks.b[k]};
      }
      r.peak_threshold = split.peaks.threshold;
      r.timings.insert(r.timings.begin(), split_timing.begin(), split_timing.end());
      SHRM_RETURN_IF_ERROR(VerifyStage(env, brdf, options, progress, &r));
      return r;
    }
    if (env.lat_long_image() == nullptr) {
      peak_note = "not a lat-long map";
    } else if (split.rest_share >= 1) {
      peak_note = absl::StrFormat("no pixel above %g x the mean luminance", kPeakRatio);
    } else {
      peak_note = absl::StrFormat(
          "no sun: the brightest pixels would leave %.3g%% of the map's luminance energy in the "
          "rest (split at most %g%%)",
          100 * split.rest_share, 100 * kPeakSpreadShare);
    }
  }
  if (!peak_note.empty()) {
    PrefilterOptions plain = options;
    plain.peak_lights = PeakLights::kOff;
    SHRM_ASSIGN_OR_RETURN(PrefilterResult r, Prefilter(env, brdf, plain, progress));
    r.peak_lights_note = std::move(peak_note);
    r.timings.insert(r.timings.begin(), split_timing.begin(), split_timing.end());
    return r;
  }
  if (options.tolerance > 0 && !ExplicitOrders(options)) {
    PrefilterResult r;
    StageClock clock(&r.timings, progress);
    BrdfStage b;
    LightingStage l;
    SHRM_RETURN_IF_ERROR(ChooseOrdersForTolerance(env, brdf, options, clock, &b, &l, &r.choice));
    PrefilterOptions chosen = options;
    const ViewVariable other =
        options.view == ViewVariable::kNormal ? ViewVariable::kView : ViewVariable::kNormal;
    if (options.try_other_view && EffectiveViewVariable(brdf, other) == other &&
        FrontScore(r.choice, options.tolerance) > 1) {
      PrefilterOptions alt = options;
      alt.view = other;
      BrdfStage b2;
      LightingStage l2;
      ToleranceChoice c2;
      SHRM_RETURN_IF_ERROR(ChooseOrdersForTolerance(env, brdf, alt, clock, &b2, &l2, &c2));
      const double first = RmsScore(r.choice, options.tolerance);
      const double second = RmsScore(c2, options.tolerance);
      r.view_trials = {{EffectiveViewVariable(brdf, options.view), first}, {other, second}};
      if (second < first) {
        b = std::move(b2);
        l = std::move(l2);
        r.choice = c2;
      }
    }
    chosen.f = r.choice.f;
    chosen.p = r.choice.p;
    chosen.window = r.choice.window;
    chosen.face_size = r.choice.face_size;
    SHRM_RETURN_IF_ERROR(
        FinishPrefilter(b, l, chosen, progress, &r, options.max_cube_values, options.admit_cube));
    r.tolerance_rule = true;
    MergeTimings(&r.timings);
    SHRM_RETURN_IF_ERROR(VerifyStage(env, brdf, options, progress, &r));
    return r;
  }
  PrefilterResult r;
  StageClock clock(&r.timings, progress);
  SHRM_RETURN_IF_ERROR(clock.Begin("brdf"));
  SHRM_ASSIGN_OR_RETURN(BrdfStage b, ComputeBrdfStage(brdf, options));
  clock.End();
  SHRM_RETURN_IF_ERROR(clock.Begin("lighting"));
  SHRM_ASSIGN_OR_RETURN(LightingStage l, ComputeLightingStage(env, b.f_rho, options));
  clock.End();
  SHRM_RETURN_IF_ERROR(
      FinishPrefilter(b, l, options, progress, &r, options.max_cube_values, options.admit_cube));
  SHRM_RETURN_IF_ERROR(VerifyStage(env, brdf, options, progress, &r));
  return r;
}

}  // namespace shrm
