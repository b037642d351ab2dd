// `shrm prefilter`: the SHRM of a map and a BRDF, written as an SHRM file (and, with --ktx2, as
// KTX2 too) with an optional JSON report and PNG preview (SHRM paper sec. 5.6.2).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "cli/prefilter_job.h"
#if SHRM_CLI_HAS_CLIENT
#include "client/remote_jobs.h"
#endif
#include "core/base/status_macros.h"
#include "core/export/shrm_ktx2.h"
#include "core/io/atomic_file.h"
#include "core/io/image.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_synthesis.h"
#include "jobs/cli_validators.h"
#include "jobs/job_options.h"
#include "jobs/option_text.h"
#include "jobs/report.h"
#include "jobs/report_html.h"
#include "jobs/report_visuals.h"

namespace shrm::cli {
namespace {

// The SHRM as KTX2 (docs/formats.md "SHRM in KTX2"); `name` labels errors.
absl::Status WriteShrmKtx2(const std::string& tmp, const ShrmCube& cube,
                           const std::map<std::string, std::string>& attributes, bool half,
                           const std::string& name) {
  SHRM_ASSIGN_OR_RETURN(const std::string bytes, EncodeShrmKtx2(name, cube, attributes, half));
  return WriteFileAtomically(tmp, bytes);
}

// Preview: three spheres (front, side, above), each this many pixels across.
constexpr int kPreviewSize = 256;

// `brdf_spec`: the BRDF the cube was made with, for its lights (none: not parsed).
absl::Status WritePreview(const std::string& tmp, const ShrmCube& cube,
                          const std::string& brdf_spec, int threads) {
  std::unique_ptr<Brdf> brdf;
  if (!cube.lights.empty()) {
    SHRM_ASSIGN_OR_RETURN(brdf, ParseBrdfSpec(brdf_spec));
  }
  const Image spheres = jobs::RenderShrmSpheres(cube, kPreviewSize, brdf.get(), threads);
  return WritePreviewPng(tmp, spheres, jobs::MidGreyExposure(spheres));
}

// The visual report: the page (jobs/report_html.h) of the final report and the visuals.
absl::Status WriteReportHtml(const std::string& tmp, const nlohmann::json& report,
                             const nlohmann::json& visuals) {
  return WriteFileAtomically(tmp, jobs::RenderPrefilterReportHtml(report, visuals));
}

// Prints the summary lines of a run (both modes).
void PrintSummary(const jobs::PrefilterJob& job, const PrefilterRun& run,
                  const std::string& brdf_spec, int face_size, const ShrmAnalysis& an,
                  const nlohmann::json& report) {
  std::printf("wrote %s: %s SHRM, %d x %d x 6 texels, (F_B, P_B) = (%d, %d)\n", run.output.c_str(),
              jobs::ShrmKindName(job.kind), face_size, face_size, an.f_b, an.p_b);
  std::printf("  BRDF %s: (F_rho, P_rho) = (%d, %d), eps_brdf %.4g\n", brdf_spec.c_str(), an.f_brdf,
              an.p_brdf, an.eps_brdf);
  std::printf("  lighting: F_L %s, eps_light %.4g; eq. 5.19 bound %.4g\n",
              an.f_light >= 0 ? std::to_string(an.f_light).c_str() : "not reached", an.eps_light,
              an.eps_bound);
  if (report.contains("tolerance")) {
    const nlohmann::json& t = report["tolerance"];
    const nlohmann::json& e = t["estimate"];
    std::printf(
        "  tolerance %g (window %s): estimated front RMS %.4g, largest %.4g; grazing RMS %.4g%s\n",
        t["tolerance"].get<double>(), report["window"].get<std::string>().c_str(),
        e["front"]["rms"].get<double>(), e["front"]["max"].get<double>(),
        e["grazing"]["rms"].get<double>(), t["met"].get<bool>() ? "" : " (NOT MET)");
    std::printf("  view variable %s", report.value("view_variable", "view").c_str());
    for (const nlohmann::json& trial : t.value("view_trials", nlohmann::json::array()))
      std::printf("%s %s %.3g", &trial == &t["view_trials"].front() ? " (RMS scores:" : ",",
                  trial.value("view_variable", "").c_str(), trial.value("rms_score", 0.0));
    std::printf("%s\n", t.value("view_trials", nlohmann::json::array()).empty() ? "" : ")");
  }
  if (report.contains("peak_lights") && report["peak_lights"].value("mode", "") != "off") {
    const nlohmann::json& l = report["peak_lights"];
    if (l.value("count", 0) > 0) {
      std::printf("  peak lights (%s): %d pixels above luminance %.4g, summed beside the SHRM\n",
                  l.value("mode", "").c_str(), l.value("count", 0), l.value("threshold", 0.0));
    } else {
      std::printf("  peak lights (%s): none (%s)\n", l.value("mode", "").c_str(),
                  l.value("note", "").c_str());
    }
  }
  std::printf("  time:");
  for (const auto& [k, v] : report["timings"].items())
    std::printf(" %s %.1f", k.c_str(), v.get<double>());
  std::printf("\n");
}

// --server: the same job on shrmd; the SHRM file it returns is byte-identical to the embedded
// run's (tests/service_test.cc).
absl::Status RunPrefilterRemote(const jobs::PrefilterJob& job, const PrefilterRun& run,
                                PrefilterJobOutcome* outcome) {
#if !SHRM_CLI_HAS_CLIENT
  return RunWithClient();
#else
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> client, ConnectServer(run.server));
  Progress progress(run.verbose, run.quiet);
  StageLines lines(&progress);
  double upload_ms = 0;
  client::RemotePrefilterOptions options;
  options.on_upload_start = [&] { lines.Begin("upload"); };
  options.on_upload_end = [&] { upload_ms += lines.End(); };
  options.progress = [&](const shrm::v1::PrefilterProgress& p) {
    lines.Begin("remote " + p.stage());
  };
  options.on_retry = RetryReporter(run.server, run.quiet);
  options.report_visuals = !run.report_html.empty();
  int retries = 0;
  absl::StatusOr<client::RemotePrefilterResult> remote =
      client::RunRemotePrefilter(client.get(), run.server, job, options, &retries);
  lines.End();
  if (outcome != nullptr) outcome->retries = retries;
  if (!remote.ok()) return remote.status();
  const client::PrefilterOutcome& out = remote->outcome;
  OutputTransaction outputs;
  const std::string shrm_tmp = outputs.Temp(run.output);
  progress.Begin("write");
  SHRM_RETURN_IF_ERROR(WriteFileAtomically(shrm_tmp, out.shrm_file));
  const double write_ms = progress.End();
  const shrm::v1::PrefilterReport& rep = out.report;
  nlohmann::json report = nlohmann::json::parse(rep.report_json(), nullptr, false);
  if (report.is_discarded()) return absl::DataLossError("the server's report is not JSON");
  report["output"] = run.output;
  if (!run.ktx2.empty()) report["ktx2"] = run.ktx2;
  report["source"] = job.env.files;
  report["server"] = run.server;
  report["timings"]["upload_ms"] = upload_ms;
  report["retries"] = retries;
  report["timings"]["local_write_ms"] = write_ms;
  if (!run.preview.empty() || !run.ktx2.empty()) {
    // The cube and its attributes back from the server's file: the KTX2 equals the embedded run's.
    SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrmFile(shrm_tmp));
    if (!run.ktx2.empty()) {
      progress.Begin("ktx2");
      SHRM_RETURN_IF_ERROR(
          WriteShrmKtx2(outputs.Temp(run.ktx2), file.cube, file.attributes, job.half, run.ktx2));
      report["timings"]["ktx2_ms"] = progress.End();
    }
    if (!run.preview.empty()) {
      progress.Begin("preview");
      SHRM_RETURN_IF_ERROR(WritePreview(outputs.Temp(run.preview), file.cube, BrdfAttribute(file),
                                        ResolveThreads(run.threads)));
      report["timings"]["preview_ms"] = progress.End();
    }
  }
  if (!run.report.empty())
    SHRM_RETURN_IF_ERROR(jobs::WriteJsonFile(outputs.Temp(run.report), report));
  if (!run.report_html.empty()) {
    const nlohmann::json visuals = nlohmann::json::parse(rep.report_visuals_json(), nullptr, false);
    if (visuals.is_discarded() || !visuals.is_object()) {
      return absl::DataLossError("the server's visual report data is not a JSON object");
    }
    SHRM_RETURN_IF_ERROR(WriteReportHtml(outputs.Temp(run.report_html), report, visuals));
    if (outcome != nullptr) outcome->thumbnail_png_base64 = jobs::ReportThumbnail(visuals);
  }
  SHRM_RETURN_IF_ERROR(outputs.Commit());
  if (outcome != nullptr) {
    outcome->f_b = rep.f_b();
    outcome->p_b = rep.p_b();
    outcome->measured = PrefilterMeasuredError(report);
    outcome->written = true;
  }
  if (run.quiet) return jobs::ToleranceOutcome(job, report);
  if (run.json) {
    std::printf("%s\n", report.dump(2).c_str());
    return jobs::ToleranceOutcome(job, report);
  }
  ShrmAnalysis an;
  an.f_light = rep.f_light();
  an.f_brdf = rep.f_brdf();
  an.p_brdf = rep.p_brdf();
  an.f_b = rep.f_b();
  an.p_b = rep.p_b();
  an.eps_light = rep.eps_light();
  an.eps_brdf = rep.eps_brdf();
  an.eps_bound = rep.eps_bound();
  PrintSummary(job, run, rep.brdf(), rep.face_size(), an, report);
  std::printf("  server %s: lighting cache %s, BRDF cache %s\n", run.server.c_str(),
              rep.cache().lighting_hit() ? "hit" : "miss", rep.cache().brdf_hit() ? "hit" : "miss");
  return jobs::ToleranceOutcome(job, report);
#endif  // SHRM_CLI_HAS_CLIENT
}

absl::Status RunPrefilterEmbedded(const jobs::PrefilterJob& job, const PrefilterRun& run,
                                  PrefilterJobOutcome* outcome) {
  Progress progress(run.verbose, run.quiet);
  bool first = true;
  auto on_stage = [&](std::string_view stage) {
    if (!first) progress.End();
    first = false;
    progress.Begin(std::string(stage));
    return absl::OkStatus();
  };
  absl::StatusOr<jobs::PrefilterRun> r = jobs::RunPrefilterJob(
      job, ResolveThreads(run.threads), on_stage, /*visuals=*/!run.report_html.empty());
  if (!first) progress.End();
  if (!r.ok()) return r.status();
  WarnReplacedNonFinite(r->replaced_non_finite);
  const ShrmAnalysis& an = r->result.analysis;
  OutputTransaction outputs;
  progress.Begin("write");
  SHRM_RETURN_IF_ERROR(
      WriteShrmFile(outputs.Temp(run.output), r->result.cube, r->attributes, job.half));
  const double write_ms = progress.End();

  nlohmann::json report = r->report;
  report["output"] = run.output;
  if (!run.ktx2.empty()) report["ktx2"] = run.ktx2;
  report["source"] = job.env.files;
  nlohmann::json timings = jobs::TimingsJson(r->result.timings);
  timings["decode_ms"] = r->decode_ms;
  timings["write_ms"] = write_ms;
  if (!run.ktx2.empty()) {
    progress.Begin("ktx2");
    SHRM_RETURN_IF_ERROR(
        WriteShrmKtx2(outputs.Temp(run.ktx2), r->result.cube, r->attributes, job.half, run.ktx2));
    timings["ktx2_ms"] = progress.End();
  }
  if (!run.preview.empty()) {
    progress.Begin("preview");
    SHRM_RETURN_IF_ERROR(WritePreview(outputs.Temp(run.preview), r->result.cube,
                                      r->provenance.brdf_spec, ResolveThreads(run.threads)));
    timings["preview_ms"] = progress.End();
  }
  if (!run.report_html.empty()) timings["report_ms"] = r->visuals_ms;
  report["timings"] = timings;
  if (!run.report.empty())
    SHRM_RETURN_IF_ERROR(jobs::WriteJsonFile(outputs.Temp(run.report), report));
  if (!run.report_html.empty()) {
    SHRM_RETURN_IF_ERROR(WriteReportHtml(outputs.Temp(run.report_html), report, r->visuals));
    if (outcome != nullptr) outcome->thumbnail_png_base64 = jobs::ReportThumbnail(r->visuals);
  }
  SHRM_RETURN_IF_ERROR(outputs.Commit());
  if (outcome != nullptr) {
    outcome->f_b = an.f_b;
    outcome->p_b = an.p_b;
    outcome->measured = PrefilterMeasuredError(report);
    outcome->written = true;
  }
  if (run.quiet) return jobs::ToleranceOutcome(job, report);
  if (run.json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    PrintSummary(job, run, r->provenance.brdf_spec, r->result.cube.face_size, an, report);
  }
  return jobs::ToleranceOutcome(job, report);
}

std::string Help(std::string_view option) {
  return std::string(jobs::FindPrefilterJobOption(option)->help);
}

}  // namespace

void AddPrefilterJobOptions(CLI::App* sub, PrefilterArgs* args) {
  AddEnvOptions(sub, &args->env, /*required=*/true);
  sub->add_option("--brdf", args->brdf, Help("brdf"))->required();
  sub->add_option("--epsilon", args->epsilon, Help("epsilon"))->check(jobs::kOpenUnitInterval);
  sub->add_option("--tolerance", args->tolerance, Help("tolerance"))
      ->check(jobs::kOpenUnitInterval);
  sub->add_option("--window", args->window, Help("window"))
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "lanczos", "auto"}));
  sub->add_option("--view-variable", args->view_variable, Help("view_variable"))
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "view", "normal"}));
  sub->add_option("--verify", args->verify, Help("verify"))
      ->capture_default_str()
      ->check(jobs::InRange(0, jobs::kMaxVerifyPairs));
  sub->add_option("--orders", args->orders, Help("orders"))->check(jobs::kOrders);
  sub->add_option("--kind", args->kind, Help("kind"))
      ->capture_default_str()
      ->check(CLI::IsMember({"global", "local"}));
  sub->add_option("--size", args->size, Help("size"))
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_flag("--half", args->half, Help("half"));
  // A bare --peak-lights (the flag it was until session 37) leaves "" here: "on".
  sub->add_option("--peak-lights", args->peak_lights,
                  Help("peak_lights") + " [default: auto; a bare --peak-lights: on]")
      ->expected(0, 1)
      ->check(CLI::IsMember({"", "auto", "on", "off"}));  // (default auto: in the help text)
  sub->add_option("--max-size", args->max_size_mb, Help("max_size"))
      ->capture_default_str()
      ->check(jobs::InRange(0.0, jobs::kMaxSizeMbLimit));
}

absl::StatusOr<jobs::PrefilterJob> PrefilterJobFromArgs(const PrefilterArgs& a) {
  jobs::PrefilterJob job;
  SHRM_ASSIGN_OR_RETURN(job.env, EnvSpecFromArgs(a.env));
  job.brdf = a.brdf;
  job.verify = a.verify;
  absl::StatusOr<RingingWindow> window = ParseRingingWindow(a.window);
  if (!window.ok())
    return WithMessage(window.status(), absl::StrCat("--", window.status().message()));
  job.window = *window;
  absl::StatusOr<std::optional<ViewVariable>> view = jobs::ParseViewChoice(a.view_variable);
  if (!view.ok()) return WithMessage(view.status(), absl::StrCat("--", view.status().message()));
  job.view = *view;
  std::optional<jobs::Orders> orders;
  if (!a.orders.empty()) {
    SHRM_ASSIGN_OR_RETURN(orders, jobs::ParseOrdersText(a.orders, "--orders"));
  }
  SHRM_RETURN_IF_ERROR(jobs::SetOrderRule(&job, a.epsilon, a.tolerance, orders,
                                          "--epsilon, --tolerance and --orders"));
  absl::StatusOr<ShrmKind> kind = jobs::ParseShrmKind(a.kind);
  if (!kind.ok()) return WithMessage(kind.status(), absl::StrCat("--", kind.status().message()));
  job.kind = *kind;
  job.face_size = a.size;
  job.half = a.half;
  job.peak_lights = a.peak_lights.empty()
                        ? PeakLights::kOn
                        : ParsePeakLights(a.peak_lights).value_or(PeakLights::kAuto);
  job.max_size_mb = a.max_size_mb;
  return job;
}

absl::StatusOr<jobs::PrefilterJob> ParsePrefilterCommandLine(std::vector<std::string> args) {
  PrefilterArgs a;
  SHRM_RETURN_IF_ERROR(ParseJobCommandLine(
      std::move(args), "prefilter", [&](CLI::App* sub) { AddPrefilterJobOptions(sub, &a); }));
  return PrefilterJobFromArgs(a);
}

absl::Status RunPrefilterJob(const jobs::PrefilterJob& job, const PrefilterRun& run,
                             PrefilterJobOutcome* outcome) {
  SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(job));
  if (run.threads < 0) return absl::InvalidArgumentError("--threads must be >= 0");
  const OptionPath outputs[] = {{"--output", run.output},
                                {"--preview", run.preview},
                                {"--ktx2", run.ktx2},
                                {"--report", run.report},
                                {"--report-html", run.report_html}};
  SHRM_RETURN_IF_ERROR(CheckDistinctOutputs(outputs));
  const std::vector<OptionPath> inputs = JobInputFiles(job.env, job.brdf);
  for (const OptionPath& o : outputs)
    SHRM_RETURN_IF_ERROR(CheckOutputPath(o.path, o.option, inputs));
  SHRM_RETURN_IF_ERROR(
      CheckOutputExtension(run.output, "--output", {".exr"}, "the SHRM is written as OpenEXR"));
  SHRM_RETURN_IF_ERROR(
      CheckOutputExtension(run.ktx2, "--ktx2", {".ktx2"}, "the SHRM is written there as KTX2"));
  if (!run.preview.empty() && !Check8BitExtension(run.preview).ok()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--preview ", run.preview, ": needs a .png, .tif or .tiff extension (an 8-bit image)"));
  }
  if (!run.server.empty()) return RunPrefilterRemote(job, run, outcome);
  return RunPrefilterEmbedded(job, run, outcome);
}

void DefinePrefilter(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<PrefilterArgs>();
  auto run = std::make_shared<PrefilterRun>();
  AddPrefilterJobOptions(sub, args.get());
  sub->add_option("-o,--output", run->output, "output SHRM file (.shrm.exr)")->required();
  sub->add_option("--report", run->report, "write a JSON report here");
  sub->add_option("--preview", run->preview, "write a PNG preview (three spheres) here");
  sub->add_option("--report-html", run->report_html,
                  "write a visual report here: one self-contained HTML file (the map, the "
                  "BRDF's lobe, why these orders, spheres beside brute force, the error over "
                  "(N, V), timings; docs/cli.md)");
  sub->add_option("--ktx2", run->ktx2,
                  "also write the SHRM here as KTX2 (a cube-map array: docs/formats.md, for the "
                  "shaders of docs/shaders.md)");
  sub->add_option("--threads", run->threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_flag("--json", run->json, "print the report as JSON on stdout");
  sub->add_flag("--verbose", run->verbose, "stage timings on stderr");
  AddServerOption(sub, &run->server);
  sub->callback([args, run, status] {
    absl::StatusOr<jobs::PrefilterJob> job = PrefilterJobFromArgs(*args);
    *status = job.ok() ? RunPrefilterJob(*job, *run) : job.status();
  });
}

}  // namespace shrm::cli
