#include "jobs/prefilter_job.h"

#include <unistd.h>

#include <chrono>
#include <cmath>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "core/base/status_macros.h"
#include "core/sh/rotation.h"
#include "jobs/report.h"
#include "jobs/report_visuals.h"
#include "shrm/version.h"

namespace shrm::jobs {

const char* ShrmKindName(ShrmKind kind) { return kind == ShrmKind::kLocal ? "local" : "global"; }

const char* ViewChoiceName(const std::optional<ViewVariable>& view) {
  return view ? ViewVariableName(*view) : "auto";
}

absl::StatusOr<std::optional<ViewVariable>> ParseViewChoice(absl::string_view name) {
  if (name == "auto") return std::optional<ViewVariable>();
  if (name == "view") return std::optional<ViewVariable>(ViewVariable::kView);
  if (name == "normal") return std::optional<ViewVariable>(ViewVariable::kNormal);
  return absl::InvalidArgumentError(
      absl::StrCat("view-variable must be auto, view or normal, got '", name, "'"));
}

bool AutoViewVariable(const PrefilterJob& job) {
  return !job.view && job.tolerance > 0 && !job.orders;
}

ViewVariable ResolvedViewVariable(const PrefilterJob& job) {
  if (job.view) return *job.view;
  return AutoViewVariable(job) ? ViewVariable::kNormal : ViewVariable::kView;
}

absl::StatusOr<ShrmKind> ParseShrmKind(absl::string_view name) {
  if (name == "global") return ShrmKind::kGlobal;
  if (name == "local") return ShrmKind::kLocal;
  return absl::InvalidArgumentError(absl::StrCat("kind must be local or global, got '", name, "'"));
}

void UseEpsilonRule(PrefilterJob* job, double epsilon) {
  job->epsilon = epsilon;
  job->tolerance = 0;
  job->orders.reset();
}

void UseExplicitOrders(PrefilterJob* job, Orders orders) {
  job->orders = orders;
  job->tolerance = 0;
}

void UseToleranceRule(PrefilterJob* job, double tolerance) {
  job->tolerance = tolerance;
  job->orders.reset();
}

absl::Status SetOrderRule(PrefilterJob* job, std::optional<double> epsilon,
                          std::optional<double> tolerance, std::optional<Orders> orders,
                          std::string_view names) {
  if (epsilon.has_value() + tolerance.has_value() + orders.has_value() > 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        absl::string_view(names.data(), names.size()),
        " exclude each other: give one order rule (default: --tolerance ", kDefaultTolerance, ")"));
  }
  if (epsilon) UseEpsilonRule(job, *epsilon);
  if (tolerance) UseToleranceRule(job, *tolerance);
  if (orders) UseExplicitOrders(job, *orders);
  return absl::OkStatus();
}

const char* OrderRuleName(const PrefilterJob& job) {
  return job.orders ? "explicit" : (job.tolerance > 0 ? "tolerance" : "epsilon");
}

absl::Status ValidatePrefilterJob(const PrefilterJob& job) {
  SHRM_RETURN_IF_ERROR(ValidateEnvironment(job.env));
  if (job.brdf.empty()) return absl::InvalidArgumentError("brdf: a BRDF spec is required");
  if (!(job.epsilon > 0 && job.epsilon < 1)) {
    return absl::InvalidArgumentError(absl::StrCat("epsilon must be in (0, 1), got ", job.epsilon));
  }
  if (!(job.tolerance >= 0 && job.tolerance < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("tolerance must be in (0, 1), got ", job.tolerance));
  }
  if (job.verify < 0 || job.verify > kMaxVerifyPairs) {
    return absl::InvalidArgumentError(
        absl::StrCat("verify must be in [0, ", kMaxVerifyPairs, "] pairs, got ", job.verify));
  }
  if (!(job.max_size_mb >= 0 && job.max_size_mb <= kMaxSizeMbLimit)) {
    return absl::InvalidArgumentError(absl::StrCat("max_size must be in [0, ", kMaxSizeMbLimit,
                                                   "] MB (0: no budget), got ", job.max_size_mb));
  }
  if (job.tolerance > 0 && job.orders) {
    return absl::InvalidArgumentError(
        "tolerance and orders exclude each other (the tolerance chooses the orders)");
  }
  if (job.view == ViewVariable::kNormal && job.tolerance == 0 && !job.orders) {
    return absl::InvalidArgumentError(
        "view-variable normal needs the tolerance rule or explicit orders: the epsilon rule's "
        "analysis (eqs. 5.15-5.19) is the paper's, in the view variable");
  }
  if (job.orders) {
    const Orders& o = *job.orders;
    if (o.f < 0 || o.p < 0 || o.f > kMaxOrderF || o.p > kMaxOrderP) {
      return absl::InvalidArgumentError(absl::StrCat("orders: F must be in [0, ", kMaxOrderF,
                                                     "] and P in [0, ", kMaxOrderP, "], got ", o.f,
                                                     ",", o.p));
    }
    // Refused here, not when a rotated frame's lighting is made: a turntable's first frame (yaw
    // 0) would be written before the second failed.
    if (job.env.rotate_ypr_deg && o.f > kMaxRotationLmax) {
      return absl::InvalidArgumentError(
          absl::StrCat("orders: F ", o.f, " is above ", kMaxRotationLmax,
                       ", the largest degree a rotated map's lighting supports (--rotate)"));
    }
  }
  if (job.face_size < 0 || job.face_size > kMaxFaceSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("size (S_B) must be in [0, ", kMaxFaceSize, "], got ", job.face_size));
  }
  return absl::OkStatus();
}

double SizeBudgetValues(const PrefilterJob& job) {
  return job.max_size_mb * 1e6 / (job.half ? 2.0 : 4.0);
}

double EmbeddedCubeValueLimit() {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page <= 0) return 0;  // unknown: no limit
  return 0.5 * static_cast<double>(pages) * static_cast<double>(page) / sizeof(float);
}

PrefilterOptions CorePrefilterOptions(const PrefilterJob& job, int threads) {
  PrefilterOptions opt;
  opt.epsilon = job.epsilon;
  if (job.orders) {
    opt.f = job.orders->f;
    opt.p = job.orders->p;
  }
  opt.tolerance = job.tolerance;
  if (job.tolerance > 0) opt.size_budget_values = SizeBudgetValues(job);
  opt.window = job.window;
  opt.view = ResolvedViewVariable(job);
  opt.try_other_view = AutoViewVariable(job);
  opt.verify = job.verify;
  opt.peak_lights = job.peak_lights;
  opt.kind = job.kind;
  opt.face_size = job.face_size;
  opt.rotation = EnvironmentRotation(job.env);
  opt.threads = threads;
  return opt;
}

std::string EpsilonAttribute(const PrefilterJob& job) {
  if (job.orders) return kExplicitOrdersAttribute;
  if (job.tolerance > 0) return kToleranceRuleAttribute;
  return absl::StrCat(job.epsilon);
}

namespace {

std::string EstimateText(const DirectionalError& e) {
  return absl::StrCat(e.front.rms, ",", e.front.max, ",", e.grazing.rms, ",", e.grazing.max);
}

// The estimate's total: truncation and interpolation in quadrature (RMS), summed (largest).
nlohmann::json StatsJson(const ErrorStats& s) { return {{"rms", s.rms}, {"max", s.max}}; }

nlohmann::json ViewTrialsJson(const std::vector<std::pair<ViewVariable, double>>& trials) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [view, score] : trials)
    out.push_back({{"view_variable", ViewVariableName(view)}, {"rms_score", score}});
  return out;
}

}  // namespace

std::map<std::string, std::string> PrefilterFileAttributes(const PrefilterJob& job,
                                                           const PrefilterProvenance& provenance,
                                                           const PrefilterResult& result) {
  const ShrmAnalysis& an = result.analysis;
  std::map<std::string, std::string> attrs = {
      {"shrm:brdf", provenance.brdf_spec},
      {"shrm:epsilon", EpsilonAttribute(job)},
      {"shrm:orders", absl::StrCat(an.f_b, ",", an.p_b)},
      {"shrm:brdf_orders", absl::StrCat(an.f_brdf, ",", an.p_brdf)},
      {"shrm:eps_light", absl::StrCat(an.eps_light)},
      {"shrm:eps_brdf", absl::StrCat(an.eps_brdf)},
      {"shrm:eps_bound", absl::StrCat(an.eps_bound)},
      {"shrm:window", RingingWindowName(result.window)},
      {"shrm:source", provenance.source.names},
      {"shrm:source_sha256", provenance.source.sha256},
      {"shrm:working_space", job.env.working_colour_space},
      {"shrm:layout", EnvLayoutName(provenance.layout)},
      {"shrm:version", kVersion},
  };
  if (job.env.rotate_ypr_deg) attrs["shrm:rotate_ypr_deg"] = RotationAttribute(job.env);
  attrs["shrm:peak_lights"] = PeakLightsName(job.peak_lights);
  if (!result.cube.lights.empty())
    attrs["shrm:peak_threshold"] = absl::StrCat(result.peak_threshold);
  if (result.tolerance_rule) {
    attrs["shrm:tolerance"] = absl::StrCat(job.tolerance);
    attrs["shrm:max_size_mb"] = absl::StrCat(job.max_size_mb);
    attrs["shrm:rules"] = absl::StrCat(kToleranceRulesRevision);
    attrs["shrm:estimated_error"] = EstimateText(TotalEstimate(result.choice));
  }
  if (result.verified_pairs > 0) {
    attrs["shrm:measured_error"] =
        absl::StrCat(EstimateText(result.measured), ",", result.verified_pairs);
  }
  if (result.tolerance_rule) {
    // The verdict the front ends give (exit code, batch status), so that a resumed batch that
    // skips the file still reports a miss.
    const bool met = ToleranceOutcome(job, PrefilterReportJson(job, provenance, result)).ok();
    attrs["shrm:tolerance_met"] = met ? "true" : "false";
  }
  return attrs;
}

nlohmann::json PrefilterReportJson(const PrefilterJob& job, const PrefilterProvenance& provenance,
                                   const PrefilterResult& result) {
  nlohmann::json report = AnalysisJson(result.analysis);
  report["brdf"] = provenance.brdf_spec;
  report["kind"] = ShrmKindName(job.kind);
  report["face_size"] = result.cube.face_size;
  report["window"] = RingingWindowName(result.window);
  report["view_variable"] = ViewVariableName(result.brdf.view);
  report["order_rule"] = OrderRuleName(job);
  report["peak_lights"] = {{"mode", PeakLightsName(job.peak_lights)},
                           {"count", result.cube.lights.size()},
                           {"threshold", result.peak_threshold}};
  if (!result.peak_lights_note.empty()) report["peak_lights"]["note"] = result.peak_lights_note;
  if (result.verified_pairs > 0) {
    report["measured"] = {{"pairs", result.verified_pairs},
                          {"front", StatsJson(result.measured.front)},
                          {"grazing", StatsJson(result.measured.grazing)},
                          {"negative", result.measured.negative}};
  }
  if (result.tolerance_rule) {
    const ToleranceChoice& c = result.choice;
    const ToleranceTargets t = TargetsForTolerance(job.tolerance, result.brdf.view);
    const double bytes = job.half ? 2.0 : 4.0;
    const DirectionalError total = TotalEstimate(c);
    report["tolerance"] = {
        {"tolerance", job.tolerance},
        {"targets",
         {{"front_rms", t.rms},
          {"front_max", t.max},
          {"grazing_rms", t.grazing_rms},
          {"grazing_is_target", t.grazing}}},
        {"estimate",
         {{"front", StatsJson(total.front)},
          {"grazing", StatsJson(total.grazing)},
          {"truncation",
           {{"front", StatsJson(c.truncation.front)},
            {"grazing", StatsJson(c.truncation.grazing)}}},
          {"interpolation",
           {{"front", StatsJson(c.interpolation.front)},
            {"grazing", StatsJson(c.interpolation.grazing)}}}}},
        {"reference_orders", {c.f_ref, c.p_ref}},
        {"view_trials", ViewTrialsJson(result.view_trials)},
        {"met", c.met},
        {"size_mb", CubeValues(result.cube.face_size, result.analysis.p_b) * bytes / 1e6},
        {"max_size_mb", job.max_size_mb},
        {"budget_limited", c.budget_limited}};
    if (c.budget_limited)
      report["tolerance"]["unlimited_size_mb"] = c.unlimited_values * bytes / 1e6;
  }
  report["source_sha256"] = provenance.source.sha256;
  report["layout"] = EnvLayoutName(provenance.layout);
  report["shrm_version"] = kVersion;
  return report;
}

namespace {
// A measured error within the job's targets (the grazing RMS counted where it is one): the
// verdict of a check, in ToleranceOutcome and for the files that record only the measurement.
bool MeasurementMeets(double front_rms, double front_max, double grazing_rms,
                      const ToleranceTargets& t) {
  return front_rms <= t.rms && front_max <= t.max && (!t.grazing || grazing_rms <= t.grazing_rms);
}
}  // namespace

std::optional<RecordedError> FileRecordedError(const std::map<std::string, std::string>& attributes,
                                               const std::string& attribute) {
  auto it = attributes.find(attribute);
  if (it == attributes.end()) return std::nullopt;
  const std::vector<std::string> v = absl::StrSplit(it->second, ',');
  RecordedError r;
  DirectionalError& e = r.error;
  if (v.size() < 4 || v.size() > 5 || !absl::SimpleAtod(v[0], &e.front.rms) ||
      !absl::SimpleAtod(v[1], &e.front.max) || !absl::SimpleAtod(v[2], &e.grazing.rms) ||
      !absl::SimpleAtod(v[3], &e.grazing.max) ||
      (v.size() == 5 && (!absl::SimpleAtoi(v[4], &r.pairs) || r.pairs <= 0))) {
    return std::nullopt;
  }
  return r;
}

std::string RecordedToleranceMiss(const ShrmFile& file) {
  const std::map<std::string, std::string>& a = file.attributes;
  auto tol_it = a.find("shrm:tolerance");
  double tolerance = 0;
  if (tol_it == a.end() || !absl::SimpleAtod(tol_it->second, &tolerance) || !(tolerance > 0))
    return "";
  const ToleranceTargets targets = TargetsForTolerance(tolerance, file.cube.view);
  const std::optional<RecordedError> measured = FileRecordedError(a, "shrm:measured_error");
  const auto figures = [&](const char* what, const RecordedError& r) {
    return absl::StrCat(what, " front RMS ", r.error.front.rms, " (target ", targets.rms,
                        "), largest ", r.error.front.max, " (target ", targets.max, ")",
                        targets.grazing ? absl::StrCat(", grazing RMS ", r.error.grazing.rms,
                                                       " (target ", targets.grazing_rms, ")")
                                        : "",
                        r.pairs > 0 ? absl::StrCat(" at ", r.pairs, " pairs") : "");
  };
  bool met = true;
  if (auto it = a.find("shrm:tolerance_met"); it != a.end()) {
    met = it->second != "false";
  } else if (measured) {  // written before the verdict was recorded: the measurement decides
    const DirectionalError& e = measured->error;
    met = MeasurementMeets(e.front.rms, e.front.max, e.grazing.rms, targets);
  }
  if (met) return "";
  const std::string prefix = absl::StrCat("tolerance ", tol_it->second, " not met when written: ");
  if (measured) return prefix + figures("measured", *measured);
  const std::optional<RecordedError> estimated = FileRecordedError(a, "shrm:estimated_error");
  return estimated ? prefix + figures("estimated", *estimated) : prefix + "(no figures recorded)";
}

std::string WhyFileDiffers(const PrefilterJob& job, const std::string& canonical_brdf,
                           const std::string& source_sha256, const ShrmFile& file) {
  const std::map<std::string, std::string>& a = file.attributes;
  auto differs = [&](const char* key, const std::string& want) -> std::string {
    auto it = a.find(key);
    const std::string have = it == a.end() ? std::string("(none)") : it->second;
    return have == want ? "" : absl::StrCat(key, " ", have, " != ", want);
  };
  std::string why;
  if (!(why = differs("shrm:brdf", canonical_brdf)).empty()) return why;
  if (!differs("shrm:source_sha256", source_sha256).empty()) return "source changed";
  if (!(why = differs("shrm:epsilon", EpsilonAttribute(job))).empty()) return why;
  if (job.tolerance > 0 && !(why = differs("shrm:tolerance", absl::StrCat(job.tolerance))).empty())
    return why;
  if (job.tolerance > 0 &&
      !(why = differs("shrm:max_size_mb", absl::StrCat(job.max_size_mb))).empty())
    return why;
  if (job.tolerance > 0) {
    // A file without the attribute was chosen by revision 1 of the rule.
    auto it = a.find("shrm:rules");
    const std::string have = it == a.end() ? "1" : it->second;
    if (have != absl::StrCat(kToleranceRulesRevision))
      return absl::StrCat("chosen by an older tolerance rule (shrm:rules ", have,
                          " != ", kToleranceRulesRevision, ")");
  }
  if (job.window != RingingWindow::kAuto &&
      !(why = differs("shrm:window", RingingWindowName(job.window))).empty())
    return why;
  // The normal variable is not asked of the BRDFs it does not apply to (P = 0, tangent): a file
  // in the view variable differs only when the job asks for the view explicitly and it is normal.
  if (job.view == ViewVariable::kView && file.cube.view == ViewVariable::kNormal)
    return "view variable normal != view";
  if (job.orders &&
      !(why = differs("shrm:orders", absl::StrCat(job.orders->f, ",", job.orders->p))).empty())
    return why;
  if (!(why = differs("shrm:rotate_ypr_deg",
                      job.env.rotate_ypr_deg ? RotationAttribute(job.env) : "(none)"))
           .empty())
    return why;
  {
    // Files written before the modes held the threshold (made "on") or nothing ("off").
    auto it = a.find("shrm:peak_lights");
    const std::string have = it == a.end()                             ? "off"
                             : ParsePeakLights(it->second).has_value() ? it->second
                                                                       : "on";
    if (have != PeakLightsName(job.peak_lights))
      return absl::StrCat("peak lights ", have, " != ", PeakLightsName(job.peak_lights));
  }
  if (file.cube.kind != job.kind) return absl::StrCat("kind != ", ShrmKindName(job.kind));
  if (job.face_size > 0 && file.cube.face_size != job.face_size)
    return absl::StrCat("size ", file.cube.face_size, " != ", job.face_size);
  return "";
}

absl::StatusOr<PrefilterRun> RunPrefilterJob(const PrefilterJob& job, int threads,
                                             const PrefilterProgress& progress, bool visuals) {
  SHRM_RETURN_IF_ERROR(ValidatePrefilterJob(job));
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(job.brdf));
  if (progress) SHRM_RETURN_IF_ERROR(progress("decode"));
  const auto decode_start = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(EnvMap env, EnvMap::Load(EnvMapOptionsFor(job.env)));
  PrefilterRun run;
  SHRM_ASSIGN_OR_RETURN(run.provenance.source, LocalSourceIdentity(job.env));
  run.decode_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - decode_start)
          .count();
  run.replaced_non_finite = env.replaced_non_finite();
  run.provenance.brdf_spec = brdf->spec();
  run.provenance.layout = env.layout();
  PrefilterOptions options = CorePrefilterOptions(job, threads);
  options.max_cube_values = EmbeddedCubeValueLimit();
  options.keep_reference = visuals;  // the report measures against the same map
  absl::StatusOr<PrefilterResult> result = Prefilter(env, *brdf, options, progress);
  if (!result.ok() && absl::IsInvalidArgument(result.status()) &&
      absl::StrContains(result.status().message(), "above the limit")) {
    return absl::ResourceExhaustedError(
        absl::StrCat(result.status().message(),
                     " (half this machine's memory): give smaller --orders, a "
                     "--size, or a larger --epsilon / --tolerance"));
  }
  if (!result.ok()) return result.status();
  run.result = *std::move(result);
  run.attributes = PrefilterFileAttributes(job, run.provenance, run.result);
  run.report = PrefilterReportJson(job, run.provenance, run.result);
  if (visuals) {
    if (progress) SHRM_RETURN_IF_ERROR(progress("report"));
    const auto start = std::chrono::steady_clock::now();
    SHRM_ASSIGN_OR_RETURN(
        run.visuals, PrefilterVisuals(env, *brdf, EnvironmentRotation(job.env), run.result.cube,
                                      threads, run.result.reference.get()));
    run.visuals_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  run.result.reference.reset();  // (its ~100 MB are not the run's result)
  return run;
}

namespace {
// Megabytes, rounded up to 0.1.
std::string FormatMb(double mb) { return absl::StrFormat("%.1f", std::ceil(mb * 10) / 10); }
}  // namespace

absl::Status ToleranceOutcome(const PrefilterJob& job, const nlohmann::json& report) {
  if (job.tolerance <= 0 || !report.contains("tolerance")) return absl::OkStatus();
  const nlohmann::json& t = report["tolerance"];
  const ToleranceTargets targets = TargetsForTolerance(
      job.tolerance, report.value("view_variable", "view") == "normal" ? ViewVariable::kNormal
                                                                       : ViewVariable::kView);
  const std::string where =
      absl::StrCat(" at (F_B, P_B) = (", report.value("F_B", 0), ", ", report.value("P_B", 0),
                   "), S_B ", report.value("face_size", 0));
  // The job's own check, where it ran, is the verdict: an estimate that missed (within a size
  // budget, or at the reference orders) is not an error when the measurement meets every target.
  const bool measured = report.contains("measured");
  double rms = 0, largest = 0, grazing_rms = 0;
  if (measured) {
    const nlohmann::json& m = report["measured"];
    rms = m["front"].value("rms", 0.0);
    largest = m["front"].value("max", 0.0);
    grazing_rms = m["grazing"].value("rms", 0.0);
  }
  const bool measured_met = measured && MeasurementMeets(rms, largest, grazing_rms, targets);
  if (!t.value("met", false) && !measured_met) {
    const nlohmann::json& front = t["estimate"]["front"];
    const std::string grazing =
        targets.grazing ? absl::StrCat(", grazing RMS ", t["estimate"]["grazing"].value("rms", 0.0),
                                       " (target ", targets.grazing_rms, ")")
                        : "";
    const std::string within =
        t.value("budget_limited", false)
            ? absl::StrCat("the most accurate within the size budget of ", job.max_size_mb,
                           " MB (the tolerance's choice needs ",
                           FormatMb(t.value("unlimited_size_mb", 0.0)),
                           " MB: raise --max-size, or give --half)")
            : absl::StrCat("the most accurate within the reference orders (",
                           t["reference_orders"][0].get<int>(), ", ",
                           t["reference_orders"][1].get<int>(), ")");
    return absl::FailedPreconditionError(absl::StrCat(
        "tolerance ", job.tolerance, " not met: estimated front RMS ", front.value("rms", 0.0),
        " (target ", targets.rms, "), largest ", front.value("max", 0.0), " (target ", targets.max,
        ")", grazing, where, ": ", within, "; the outputs were written"));
  }
  if (measured && !measured_met) {
    return absl::FailedPreconditionError(absl::StrCat(
        "tolerance ", job.tolerance, " not met: measured front RMS ", rms, " (target ", targets.rms,
        "), largest ", largest, " (target ", targets.max, ")",
        targets.grazing
            ? absl::StrCat(", grazing RMS ", grazing_rms, " (target ", targets.grazing_rms, ")")
            : "",
        " at ", report["measured"].value("pairs", 0), " pairs", where,
        "; the outputs were written"));
  }
  return absl::OkStatus();
}

}  // namespace shrm::jobs
