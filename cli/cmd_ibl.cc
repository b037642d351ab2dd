// `shrm ibl`: the split-sum image-based-lighting set of a map (jobs/ibl_job.h, docs/ibl.md),
// written into one output folder, computed here or on shrmd (--server) with the same bytes.
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "cli/ibl_job.h"
#if SHRM_CLI_HAS_CLIENT
#include "client/remote_jobs.h"
#endif
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"
#include "jobs/cli_validators.h"
#include "jobs/ibl_job.h"
#include "jobs/ibl_outputs.h"
#include "jobs/job_options.h"
#include "jobs/report.h"

namespace shrm::cli {
namespace {

std::string Help(std::string_view option) {
  return std::string(jobs::FindIblJobOption(option)->help);
}

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Before any work: the output folder is a writable folder, or can be created (its parent is a
// writable folder). Returns whether it must be created.
absl::StatusOr<bool> CheckFolder(const std::string& dir) {
  struct stat st;
  if (stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) {
      return absl::InvalidArgumentError(absl::StrCat("--output: ", dir, " is not a folder"));
    }
    SHRM_RETURN_IF_ERROR(CheckOutputPath(dir + "/ibl.json", "--output"));
    return false;
  }
  SHRM_RETURN_IF_ERROR(CheckOutputPath(dir, "--output"));
  return true;
}

// Creates the folder after the computation succeeded (so a failed run leaves nothing).
absl::Status CreateFolder(const std::string& dir) {
  if (mkdir(dir.c_str(), 0777) != 0 && errno != EEXIST) {
    return absl::InvalidArgumentError(
        absl::StrCat("--output: cannot create folder ", dir, ": ", std::strerror(errno)));
  }
  return absl::OkStatus();
}

// What a run produced, wherever it ran: the files and the job's report.
struct IblResult {
  std::vector<jobs::IblFile> files;
  nlohmann::json report;  // jobs::IblReportJson
  std::vector<StageTiming> timings;
  int retries = 0;
};

absl::StatusOr<IblResult> RunEmbedded(const jobs::IblJob& job, const IblCommandRun& run) {
  Progress progress(run.verbose, run.quiet || run.json);
  StageLines lines(&progress);
  auto on_stage = [&](std::string_view stage) {
    lines.Begin(std::string(stage));
    return absl::OkStatus();
  };
  absl::StatusOr<jobs::IblRun> r = jobs::RunIblJob(job, ResolveThreads(run.threads), on_stage);
  lines.End();
  if (!r.ok()) return r.status();
  if (!run.quiet) WarnReplacedNonFinite(r->replaced_non_finite);
  IblResult out;
  const auto t0 = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(out.files, jobs::EncodeIblOutputs(job, *r));
  out.timings = std::move(r->timings);
  out.timings.push_back({"encode", MsSince(t0)});
  out.report = std::move(r->report);
  return out;
}

// --server: the same job on shrmd; the files it returns (each checked against its SHA-256 by the
// client library) are byte-identical to the embedded run's.
absl::StatusOr<IblResult> RunRemote(const jobs::IblJob& job, const IblCommandRun& run) {
#if !SHRM_CLI_HAS_CLIENT
  return RunWithClient();
#else
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> client, ConnectServer(run.server));
  Progress progress(run.verbose, run.quiet || run.json);
  StageLines lines(&progress);
  double upload_ms = 0;
  client::RemoteJobOptions options;
  options.on_upload_start = [&] { lines.Begin("upload"); };
  options.on_upload_end = [&] { upload_ms += lines.End(); };
  options.progress = [&](const shrm::v1::PrefilterProgress& p) {
    lines.Begin("remote " + p.stage());
  };
  options.on_retry = RetryReporter(run.server, run.quiet);
  absl::StatusOr<client::RemoteIblResult> remote =
      client::RunRemoteIbl(client.get(), run.server, job, options);
  lines.End();
  if (!remote.ok()) return remote.status();
  const shrm::v1::IblReport& rep = remote->outcome.report;
  IblResult out;
  out.retries = remote->retries;
  out.report = nlohmann::json::parse(rep.report_json(), nullptr, false);
  if (out.report.is_discarded() || !out.report.is_object()) {
    return absl::DataLossError("the server's report is not a JSON object");
  }
  for (size_t i = 0; i < remote->outcome.files.size(); ++i) {
    client::ReceivedFile& f = remote->outcome.files[i];
    out.files.push_back({f.name, std::move(f.bytes), rep.files(static_cast<int>(i)).what(),
                         /*type=*/std::string()});
  }
  out.timings.push_back({"upload", upload_ms});
  for (const shrm::v1::StageTiming& t : rep.timings()) {
    out.timings.push_back({absl::StrCat("server_", t.stage()), t.ms()});
  }
  return out;
#endif  // SHRM_CLI_HAS_CLIENT
}

void PrintSummary(const IblCommandRun& run, const IblResult& r) {
  const nlohmann::json& levels = r.report["specular"]["levels"];
  const int face = levels.empty() ? 0 : levels[0]["face_size"].get<int>();
  std::printf("%s: %s preset, %zu levels from %d x %d\n",
              r.report["source"].get<std::string>().c_str(),
              r.report["preset"].get<std::string>().c_str(), levels.size(), face, face);
  for (const nlohmann::json& l : levels) {
    std::printf("  level %d: %4d x %-4d roughness %.3f", l["level"].get<int>(),
                l["face_size"].get<int>(), l["face_size"].get<int>(), l["roughness"].get<double>());
    // The base level is the map sampled at the texel centres: no degree (-1 in ibl.json).
    if (const int degree = l["degree"].get<int>(); degree >= 0)
      std::printf(" degree %4d", degree);
    else
      std::printf(" degree  map");
    if (l.contains("measured")) {
      std::printf("  measured rms %.2e max %.2e", l["measured"]["rms"].get<double>(),
                  l["measured"]["max"].get<double>());
    }
    std::printf("\n");
  }
  for (const jobs::IblFile& f : r.files) {
    std::printf("wrote %s/%s (%s, %zu bytes)\n", run.output.c_str(), f.name.c_str(), f.what.c_str(),
                f.bytes.size());
  }
  if (!run.server.empty()) std::printf("  server %s, %d retries\n", run.server.c_str(), r.retries);
}

}  // namespace

void AddIblJobOptions(CLI::App* sub, IblArgs* args) {
  AddEnvOptions(sub, &args->env, /*required=*/true);
  sub->add_option("--preset", args->preset, Help("preset"))
      ->capture_default_str()
      ->check(CLI::IsMember({"filament", "gltf", "babylon", "explicit"}));
  sub->add_option("--roughness", args->roughness, Help("roughness"));
  sub->add_option("--size", args->size, Help("size"))
      ->capture_default_str()
      ->check(jobs::kPositive);
  sub->add_option("--levels", args->levels, Help("levels"))
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_flag("--sheen", args->sheen, Help("sheen"));
  sub->add_option("--format", args->format, Help("format"))
      ->capture_default_str()
      ->check(CLI::IsMember({"rgba16f", "rgba32f", "r11g11b10f", "rgb9e5"}));
  sub->add_option("--irradiance-size", args->irradiance_size, Help("irradiance_size"))
      ->capture_default_str()
      ->check(jobs::kPositive);
  sub->add_option("--dfg-size", args->dfg_size, Help("dfg_size"))
      ->capture_default_str()
      ->check(jobs::kPositive);
  sub->add_option("--tolerance", args->tolerance, Help("tolerance"))->capture_default_str();
  sub->add_option("--verify", args->verify, Help("verify"))
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_option("--sh-window", args->sh_window, Help("sh_window"))
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "none", "cmgen"}));
  sub->add_option("--dfg", args->dfg, Help("dfg"))->capture_default_str();
  sub->add_option("--containers", args->containers, Help("containers"))->capture_default_str();
  sub->add_flag("--preview", args->preview, Help("preview"));
}

absl::StatusOr<jobs::IblJob> IblJobFromArgs(const IblArgs& a) {
  jobs::IblJob job;
  SHRM_ASSIGN_OR_RETURN(job.env, EnvSpecFromArgs(a.env));
  SHRM_ASSIGN_OR_RETURN(job.preset, ibl::ParseRoughnessPreset(a.preset));
  if (!a.roughness.empty()) {
    for (absl::string_view part : absl::StrSplit(a.roughness, ',')) {
      double r = 0;
      if (!absl::SimpleAtod(part, &r)) {
        return absl::InvalidArgumentError(
            absl::StrCat("--roughness: '", part, "' is not a number"));
      }
      job.roughness.push_back(r);
    }
    if (a.preset == "filament") job.preset = ibl::RoughnessPreset::kExplicit;
  }
  job.face_size = a.size;
  job.levels = a.levels;
  job.sheen = a.sheen;
  SHRM_ASSIGN_OR_RETURN(job.format, jobs::ParseIblFormat(a.format));
  job.irradiance_size = a.irradiance_size;
  job.dfg_size = a.dfg_size;
  job.tolerance = a.tolerance;
  job.verify = a.verify;
  SHRM_ASSIGN_OR_RETURN(job.sh_window, jobs::ParseIblShWindow(a.sh_window));
  job.dfg = a.dfg;
  absl::StatusOr<std::vector<jobs::IblContainer>> containers =
      jobs::ParseIblContainers(a.containers);
  if (!containers.ok()) {
    return WithMessage(containers.status(),
                       absl::StrCat("--containers: ", containers.status().message()));
  }
  job.containers = *std::move(containers);
  job.preview = a.preview;
  SHRM_RETURN_IF_ERROR(jobs::ValidateIblJob(job));
  return job;
}

absl::StatusOr<jobs::IblJob> ParseIblCommandLine(std::vector<std::string> args) {
  IblArgs a;
  SHRM_RETURN_IF_ERROR(ParseJobCommandLine(std::move(args), "ibl",
                                           [&](CLI::App* sub) { AddIblJobOptions(sub, &a); }));
  return IblJobFromArgs(a);
}

absl::Status RunIblJob(const jobs::IblJob& job, const IblCommandRun& run, IblJobOutcome* outcome) {
  SHRM_RETURN_IF_ERROR(jobs::ValidateIblJob(job));
  if (run.threads < 0) return absl::InvalidArgumentError("--threads must be >= 0");
  SHRM_ASSIGN_OR_RETURN(const bool create, CheckFolder(run.output));
  absl::StatusOr<IblResult> r = run.server.empty() ? RunEmbedded(job, run) : RunRemote(job, run);
  if (outcome != nullptr && r.ok()) outcome->retries = r->retries;
  if (!r.ok()) return r.status();
  const auto t0 = std::chrono::steady_clock::now();
  if (create) SHRM_RETURN_IF_ERROR(CreateFolder(run.output));
  OutputTransaction tx;
  for (const jobs::IblFile& f : r->files) {
    SHRM_RETURN_IF_ERROR(WriteFileAtomically(tx.Temp(run.output + "/" + f.name), f.bytes));
  }
  SHRM_RETURN_IF_ERROR(tx.Commit());
  r->timings.push_back({"write", MsSince(t0)});
  nlohmann::json report = r->report;
  report["timings"] = jobs::TimingsJson(r->timings);
  if (!run.server.empty()) {
    report["server"] = run.server;
    report["retries"] = r->retries;
  }
  if (outcome != nullptr) {
    outcome->levels = static_cast<int>(report["specular"]["levels"].size());
    outcome->measured = IblMeasuredError(report);
    outcome->written = true;
  }
  if (run.quiet) return jobs::IblOutcome(job, report);
  if (run.json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    PrintSummary(run, *r);
  }
  return jobs::IblOutcome(job, report);
}

void DefineIbl(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<IblArgs>();
  auto run = std::make_shared<IblCommandRun>();
  AddIblJobOptions(sub, args.get());
  sub->add_option("-o,--output", run->output, "output folder (created if missing)")->required();
  sub->add_option("--threads", run->threads, "worker threads (0: all cores)")
      ->check(jobs::kNonNegative);
  sub->add_flag("--json", run->json, "print the report as JSON on stdout");
  sub->add_flag("--verbose", run->verbose, "stage timings on stderr");
  AddServerOption(sub, &run->server);
  sub->callback([args, run, status] {
    absl::StatusOr<jobs::IblJob> job = IblJobFromArgs(*args);
    *status = job.ok() ? RunIblJob(*job, *run) : job.status();
  });
}

}  // namespace shrm::cli
