// `shrm ibl`: the split-sum image-based-lighting set of a map (jobs/ibl_job.h, docs/ibl.md),
// written into one output folder.
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"
#include "jobs/ibl_job.h"
#include "jobs/ibl_outputs.h"
#include "jobs/report.h"

namespace shrm::cli {
namespace {

struct IblArgs {
  EnvArgs env;
  std::string output;
  std::string preset = "filament";
  std::string roughness;  // "r0,r1,..." for the explicit preset
  int size = jobs::kDefaultIblFaceSize;
  int levels = 0;
  bool sheen = false;
  std::string format = "rgba16f";
  int irradiance_size = jobs::kDefaultIrradianceSize;
  int dfg_size = jobs::kDefaultDfgSize;
  double tolerance = jobs::kDefaultIblTolerance;
  int verify = jobs::kDefaultIblVerify;
  std::string sh_window = "auto";
  std::string dfg = "auto";
  int threads = 0;
  bool json = false;
  bool verbose = false;
};

absl::StatusOr<jobs::IblJob> JobFromArgs(const IblArgs& a) {
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
  SHRM_RETURN_IF_ERROR(jobs::ValidateIblJob(job));
  return job;
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

absl::Status RunIbl(const IblArgs& a) {
  SHRM_ASSIGN_OR_RETURN(const jobs::IblJob job, JobFromArgs(a));
  SHRM_ASSIGN_OR_RETURN(const bool create, CheckFolder(a.output));
  const int threads = ResolveThreads(a.threads);
  Progress progress(a.verbose, a.json);
  progress.Begin("ibl");
  SHRM_ASSIGN_OR_RETURN(jobs::IblRun run, jobs::RunIblJob(job, threads));
  progress.End();
  WarnReplacedNonFinite(run.replaced_non_finite);
  if (run.specular.chain.levels.size() == 1) {
    std::fprintf(stderr,
                 "shrm: warning: the chain has only its base level (roughness 0): use a larger "
                 "--size or --levels for rough levels\n");
  }
  const auto t0 = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(std::vector<jobs::IblFile> files, jobs::EncodeIblOutputs(job, run));
  if (create) SHRM_RETURN_IF_ERROR(CreateFolder(a.output));
  OutputTransaction tx;
  for (const jobs::IblFile& f : files) {
    SHRM_RETURN_IF_ERROR(WriteFileAtomically(tx.Temp(a.output + "/" + f.name), f.bytes));
  }
  SHRM_RETURN_IF_ERROR(tx.Commit());
  run.timings.push_back(
      {"write",
       std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()});
  nlohmann::json report = run.report;
  report["timings"] = jobs::TimingsJson(run.timings);
  if (a.json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    std::printf("%s: %s preset, %d levels from %d x %d\n", run.source.names.c_str(),
                ibl::RoughnessPresetName(job.preset),
                static_cast<int>(run.specular.chain.levels.size()), job.face_size, job.face_size);
    for (size_t k = 0; k < run.specular.chain.levels.size(); ++k) {
      const ibl::SpecularLevel& l = run.specular.chain.levels[k];
      std::printf("  level %zu: %4d x %-4d roughness %.3f degree %4d", k, l.face_size, l.face_size,
                  l.roughness, l.degree);
      if (k < run.specular.measured.size() && run.specular.measured[k].count > 0)
        std::printf("  measured rms %.2e max %.2e", run.specular.measured[k].rms,
                    run.specular.measured[k].max);
      std::printf("\n");
    }
    for (const jobs::IblFile& f : files)
      std::printf("wrote %s/%s (%s, %zu bytes)\n", a.output.c_str(), f.name.c_str(), f.what.c_str(),
                  f.bytes.size());
  }
  return jobs::IblOutcome(job, report);
}

}  // namespace

void RegisterIbl(CLI::App& app, absl::Status* status) {
  auto args = std::make_shared<IblArgs>();
  CLI::App* sub = app.add_subcommand(
      "ibl",
      "the split-sum IBL set: GGX (and sheen) radiance mips, irradiance cube and SH, DFG LUT");
  AddEnvOptions(sub, &args->env, /*required=*/true);
  sub->add_option("-o,--output", args->output, "output folder (created if missing; its parent must exist)")->required();
  sub->add_option("--preset", args->preset,
                  "roughness per mip: filament (cmgen), gltf (glTF-IBL-Sampler) or explicit")
      ->capture_default_str()
      ->check(CLI::IsMember({"filament", "gltf", "explicit"}));
  sub->add_option("--roughness", args->roughness,
                  "explicit perceptual roughness per level, r0,r1,... (implies --preset explicit)");
  sub->add_option("--size", args->size, "base face size (a power of two)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--levels", args->levels, "mip levels (0: the preset's default)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--sheen", args->sheen, "also the Charlie sheen chain");
  sub->add_option("--format", args->format, "radiance storage")
      ->capture_default_str()
      ->check(CLI::IsMember({"rgba16f", "rgba32f", "r11g11b10f", "rgb9e5"}));
  sub->add_option("--irradiance-size", args->irradiance_size, "irradiance cube face size")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--dfg-size", args->dfg_size, "DFG lookup table size")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  sub->add_option("--tolerance", args->tolerance,
                  "relative RMS per direction allowed on every level (largest: 5x)")
      ->capture_default_str();
  sub->add_option("--verify", args->verify,
                  "directions per level checked against the brute-force sum (0: none)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--sh-window", args->sh_window,
                  "SH9 ringing control: auto (weakest window keeping the irradiance >= 0), none, "
                  "cmgen (cmgen's --sh-window=auto)")
      ->capture_default_str()
      ->check(CLI::IsMember({"auto", "none", "cmgen"}));
  sub->add_option("--dfg", args->dfg,
                  "DFG table for: auto (the preset's engine), none, filament, "
                  "filament-cmgen-exact, filament-single-scatter, gltf-lut-ggx, gltf-lut-charlie, "
                  "gltf-lut-sheen-e, babylon, karis")
      ->capture_default_str();
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--json", args->json, "print the report as JSON on stdout");
  sub->add_flag("--verbose", args->verbose, "stage timings on stderr");
  sub->callback([args, status] { *status = RunIbl(*args); });
}

}  // namespace shrm::cli
