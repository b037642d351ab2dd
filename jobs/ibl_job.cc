#include "jobs/ibl_job.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_explicit.h"
#include "jobs/point_jobs.h"
#include "shrm/version.h"

namespace shrm::jobs {
namespace {

// Seeds of the job's own check, one per cube (fixed: the same job measures the same texels).
constexpr uint64_t kSpecularVerifySeed = 0x5eed'1b10'0001;
constexpr uint64_t kSheenVerifySeed = 0x5eed'1b10'0002;
constexpr uint64_t kIrradianceVerifySeed = 0x5eed'1b10'0003;

double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// The checks of a cube's levels: `count` seeded texels each (seed + level).
void AddChecks(ibl::SpecularLobe lobe, int count, uint64_t seed, const IblCube& cube,
               std::vector<ibl::LevelCheck>& checks) {
  for (size_t k = 0; k < cube.chain.levels.size(); ++k)
    checks.push_back({lobe, &cube.chain.levels[k], count, seed + k});
}

// Clamps negatives to 0 and rounds every texel as `format` stores it.
void StoreAs(IblFormat format, IblCube& cube) {
  const ktx2::Format f = IblKtx2Format(format);
  for (ibl::SpecularLevel& level : cube.chain.levels) {
    std::vector<float>& d = level.cube.data;
    // Most levels have no negative value: one branch-free pass finds that, and only a level with
    // some takes the mean (of the values before clamping) and the clamping pass.
    bool any_negative = false;
    for (const float v : d) any_negative |= v < 0;
    if (!any_negative) {
      ktx2::RoundTripRgb(f, d);
      continue;
    }
    double sum = 0;
    for (size_t i = 0; i < d.size(); i += 3)
      sum += 0.2126 * d[i] + 0.7152 * d[i + 1] + 0.0722 * d[i + 2];
    const double mean = d.empty() ? 0.0 : sum / static_cast<double>(d.size() / 3);
    for (float& v : d) {
      if (v < 0) {
        ++cube.clamped;
        if (mean > 0) cube.most_negative = std::min(cube.most_negative, v / mean);
        v = 0;
      }
    }
    ktx2::RoundTripRgb(f, d);
  }
}

nlohmann::json CubeJson(const IblCube& cube) {
  nlohmann::json levels = nlohmann::json::array();
  for (size_t k = 0; k < cube.chain.levels.size(); ++k) {
    const ibl::SpecularLevel& l = cube.chain.levels[k];
    nlohmann::json j = {{"level", k},
                        {"face_size", l.face_size},
                        {"roughness", l.roughness},
                        {"alpha", l.alpha},
                        {"degree", l.degree},
                        {"truncation_estimate", l.truncation_estimate}};
    if (k < cube.measured.size() && cube.measured[k].count > 0) {
      const ibl::LevelError& e = cube.measured[k];
      j["measured"] = {{"count", e.count}, {"rms", e.rms}, {"max", e.max}};
    }
    levels.push_back(j);
  }
  return {{"lobe", ibl::SpecularLobeName(cube.chain.lobe)},
          {"light_degree", cube.chain.light_degree},
          {"peaks", {{"count", cube.chain.peaks}, {"threshold", cube.chain.peak_threshold}}},
          {"clamped_negative_values", cube.clamped},
          {"most_negative_relative", cube.most_negative},
          {"levels", levels}};
}

}  // namespace

const char* IblFormatName(IblFormat format) {
  switch (format) {
    case IblFormat::kRgba16f:
      return "rgba16f";
    case IblFormat::kRgba32f:
      return "rgba32f";
    case IblFormat::kB10g11r11:
      return "r11g11b10f";
    default:
      return "rgb9e5";
  }
}

absl::StatusOr<IblFormat> ParseIblFormat(absl::string_view name) {
  for (IblFormat f :
       {IblFormat::kRgba16f, IblFormat::kRgba32f, IblFormat::kB10g11r11, IblFormat::kE5b9g9r9}) {
    if (name == IblFormatName(f)) return f;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("format must be rgba16f, rgba32f, r11g11b10f or rgb9e5, got '", name, "'"));
}

const char* IblShWindowName(IblShWindow window) {
  switch (window) {
    case IblShWindow::kAuto:
      return "auto";
    case IblShWindow::kNone:
      return "none";
    default:
      return "cmgen";
  }
}

absl::StatusOr<IblShWindow> ParseIblShWindow(absl::string_view name) {
  for (IblShWindow w : {IblShWindow::kAuto, IblShWindow::kNone, IblShWindow::kCmgen}) {
    if (name == IblShWindowName(w)) return w;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("SH window must be auto, none or cmgen, got '", name, "'"));
}

namespace {
constexpr ibl::DfgConsumer kDfgConsumers[] = {ibl::DfgConsumer::kFilament,
                                              ibl::DfgConsumer::kFilamentCmgenExact,
                                              ibl::DfgConsumer::kFilamentSingleScatter,
                                              ibl::DfgConsumer::kGltfLutGgx,
                                              ibl::DfgConsumer::kGltfLutCharlie,
                                              ibl::DfgConsumer::kGltfLutSheenE,
                                              ibl::DfgConsumer::kBabylon,
                                              ibl::DfgConsumer::kKaris};
}  // namespace

absl::Status ValidateDfgChoice(absl::string_view choice) {
  if (choice == "auto" || choice == "none") return absl::OkStatus();
  std::string names = "auto, none";
  for (ibl::DfgConsumer c : kDfgConsumers) {
    if (choice == ibl::DfgConsumerName(c)) return absl::OkStatus();
    absl::StrAppend(&names, ", ", ibl::DfgConsumerName(c));
  }
  return absl::InvalidArgumentError(
      absl::StrCat("DFG table must be one of ", names, ", got '", choice, "'"));
}

std::optional<ibl::DfgConsumer> ResolvedDfg(const IblJob& job) {
  if (job.dfg == "none") return std::nullopt;
  if (job.dfg == "auto") {
    return job.preset == ibl::RoughnessPreset::kFilament  ? ibl::DfgConsumer::kFilament
           : job.preset == ibl::RoughnessPreset::kBabylon ? ibl::DfgConsumer::kBabylon
                                                          : ibl::DfgConsumer::kGltfLutGgx;
  }
  for (ibl::DfgConsumer c : kDfgConsumers)
    if (job.dfg == ibl::DfgConsumerName(c)) return c;
  return std::nullopt;
}

ktx2::Format IblKtx2Format(IblFormat format) {
  switch (format) {
    case IblFormat::kRgba16f:
      return ktx2::Format::kR16G16B16A16Sfloat;
    case IblFormat::kRgba32f:
      return ktx2::Format::kR32G32B32A32Sfloat;
    case IblFormat::kB10g11r11:
      return ktx2::Format::kB10G11R11UfloatPack32;
    default:
      return ktx2::Format::kE5B9G9R9UfloatPack32;
  }
}

double IblFormatRounding(IblFormat format) {
  switch (format) {
    case IblFormat::kRgba16f:
      return std::ldexp(1.0, -11);  // 10 mantissa bits
    case IblFormat::kRgba32f:
      return std::ldexp(1.0, -24);
    case IblFormat::kB10g11r11:
      return std::ldexp(1.0, -6);  // the 5 mantissa bits of blue
    default:
      return std::ldexp(1.0, -9);  // 9 bits below the shared exponent
  }
}

const char* IblContainerName(IblContainer container) {
  switch (container) {
    case IblContainer::kKtx2:
      return "ktx2";
    case IblContainer::kKtx1:
      return "ktx1";
    default:
      return "gltf";
  }
}

absl::StatusOr<std::vector<IblContainer>> ParseIblContainers(absl::string_view list) {
  constexpr IblContainer kAll[] = {IblContainer::kKtx2, IblContainer::kKtx1, IblContainer::kGltf};
  if (list == "all") return std::vector<IblContainer>(std::begin(kAll), std::end(kAll));
  std::vector<IblContainer> out;
  for (absl::string_view name : absl::StrSplit(list, ',')) {
    const IblContainer* c = std::find_if(std::begin(kAll), std::end(kAll), [&](IblContainer x) {
      return name == IblContainerName(x);
    });
    if (c == std::end(kAll)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "unknown container \"", name, "\" (expected a list of ktx2, ktx1, gltf, or all)"));
    }
    if (std::find(out.begin(), out.end(), *c) != out.end()) {
      return absl::InvalidArgumentError(absl::StrCat("container ", name, " given twice"));
    }
    out.push_back(*c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string IblContainersText(const std::vector<IblContainer>& containers) {
  std::string out;
  for (IblContainer c : containers)
    absl::StrAppend(&out, out.empty() ? "" : ",", IblContainerName(c));
  return out;
}

bool HasContainer(const IblJob& job, IblContainer container) {
  return std::find(job.containers.begin(), job.containers.end(), container) != job.containers.end();
}

absl::Status ValidateIblJob(const IblJob& job) {
  SHRM_RETURN_IF_ERROR(ValidateEnvironment(job.env));
  if (!(job.tolerance > 0 && job.tolerance < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("tolerance must be in (0, 1), got ", job.tolerance));
  }
  if (job.verify < 0 || job.verify > kMaxIblVerify) {
    return absl::InvalidArgumentError(absl::StrCat("verify must be in [0, ", kMaxIblVerify,
                                                   "] directions per level, got ", job.verify));
  }
  if (job.irradiance_size < 1 || job.irradiance_size > ibl::kMaxIblFaceSize) {
    return absl::InvalidArgumentError(absl::StrCat(
        "irradiance size must be in [1, ", ibl::kMaxIblFaceSize, "], got ", job.irradiance_size));
  }
  if (job.dfg_size < 1 || job.dfg_size > kMaxDfgSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("DFG size must be in [1, ", kMaxDfgSize, "], got ", job.dfg_size));
  }
  SHRM_RETURN_IF_ERROR(ValidateDfgChoice(job.dfg));
  if (job.containers.empty()) {
    return absl::InvalidArgumentError("containers: give at least one of ktx2, ktx1, gltf");
  }
  if (!std::is_sorted(job.containers.begin(), job.containers.end()) ||
      std::adjacent_find(job.containers.begin(), job.containers.end()) != job.containers.end()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "containers must be sorted without repeats, got ", IblContainersText(job.containers)));
  }
  if (HasContainer(job, IblContainer::kKtx1) && job.format == IblFormat::kE5b9g9r9) {
    return absl::InvalidArgumentError(
        "the ktx1 container cannot hold rgb9e5 (Filament's KTX1 reader has no pixel type for "
        "RGB9_E5): use the format rgba16f, rgba32f or r11g11b10f");
  }
  if (job.preset != ibl::RoughnessPreset::kExplicit && !job.roughness.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("a roughness list needs the explicit preset (got preset ",
                     ibl::RoughnessPresetName(job.preset), ")"));
  }
  return IblJobChain(job).status();
}

absl::Status ValidateIblJobNamingOptions(
    const IblJob& job, const std::function<std::string(std::string_view option)>& name) {
  const absl::Status whole = ValidateIblJob(job);
  if (whole.ok()) return whole;
  using Copy = void (*)(const IblJob& from, IblJob* to);
  constexpr std::pair<std::string_view, Copy> kOptions[] = {
      {"env", [](const IblJob& f, IblJob* t) { t->env = f.env; }},
      {"size", [](const IblJob& f, IblJob* t) { t->face_size = f.face_size; }},
      {"roughness",
       [](const IblJob& f, IblJob* t) {
         t->preset = f.preset;
         t->roughness = f.roughness;
       }},
      {"levels", [](const IblJob& f, IblJob* t) { t->levels = f.levels; }},
      {"tolerance", [](const IblJob& f, IblJob* t) { t->tolerance = f.tolerance; }},
      {"verify", [](const IblJob& f, IblJob* t) { t->verify = f.verify; }},
      {"irradiance_size",
       [](const IblJob& f, IblJob* t) { t->irradiance_size = f.irradiance_size; }},
      {"dfg_size", [](const IblJob& f, IblJob* t) { t->dfg_size = f.dfg_size; }},
      {"dfg", [](const IblJob& f, IblJob* t) { t->dfg = f.dfg; }},
      {"format", [](const IblJob& f, IblJob* t) { t->format = f.format; }},
      {"containers", [](const IblJob& f, IblJob* t) { t->containers = f.containers; }}};
  IblJob probe;
  for (const auto& [option, copy] : kOptions) {
    copy(job, &probe);
    const absl::Status s = ValidateIblJob(probe);
    if (s.ok()) continue;
    // The environment's messages name its fields already (environment, rotate).
    if (option == "env") return s;
    return absl::InvalidArgumentError(absl::StrCat(name(option), ": ", s.message()));
  }
  return whole;
}

absl::StatusOr<ibl::MipChain> IblJobChain(const IblJob& job) {
  return ibl::MakeMipChain(job.preset, job.face_size, job.levels, job.roughness);
}

absl::StatusOr<IblRun> RunIblJob(const IblJob& job, int threads,
                                 const PrefilterProgress& progress) {
  SHRM_RETURN_IF_ERROR(ValidateIblJob(job));
  const auto t0 = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(EnvMap map, EnvMap::Load(EnvMapOptionsFor(job.env)));
  SHRM_ASSIGN_OR_RETURN(const SourceIdentity source, LocalSourceIdentity(job.env));
  return RunIblJobOnMap(job, map, source, MsSince(t0), threads, progress);
}

absl::StatusOr<ibl::SplitSumSetOptions> IblSplitSumSetOptions(const IblJob& job) {
  ibl::SplitSumSetOptions o;
  SHRM_ASSIGN_OR_RETURN(o.chain, IblJobChain(job));
  o.tolerance = job.tolerance / kIblSphereToDirectionFactor;
  o.sheen = job.sheen;
  o.irradiance_size = job.irradiance_size;
  return o;
}

namespace {

// After the set: the SH window, the DFG table, negatives clamped and storage rounding, then (with
// `map` and job.verify > 0) the check against the pixel sum, and the report.
absl::Status FinishIblRun(const IblJob& job, ibl::SplitSumSet set, const EnvMap* map,
                          const Mat3& rotation, int threads, const PrefilterProgress& progress,
                          IblRun& run) {
  auto stage = [&](std::string_view name) { return progress ? progress(name) : absl::OkStatus(); };
  run.specular.name = "specular";
  run.specular.chain = std::move(set.specular);
  run.sheen.name = "sheen";
  run.sheen.chain = std::move(set.sheen);
  run.irradiance.name = "irradiance";
  run.irradiance.chain = std::move(set.irradiance);
  run.radiance_sh9 = std::move(set.radiance_sh9);
  auto t0 = std::chrono::steady_clock::now();
  ibl::Sh9WindowOptions window;
  window.automatic = job.sh_window != IblShWindow::kNone;
  window.cmgen_compatible = job.sh_window == IblShWindow::kCmgen;
  window.window = ibl::ShWindow::kHanning;
  SHRM_ASSIGN_OR_RETURN(run.sh_window, ibl::WindowSh9(run.radiance_sh9, 2, window));
  // (The window is counted with the irradiance, the stage before it.)
  if (!run.timings.empty() && run.timings.back().stage == "irradiance") {
    run.timings.back().ms += MsSince(t0);
  }
  if (const std::optional<ibl::DfgConsumer> consumer = ResolvedDfg(job)) {
    SHRM_RETURN_IF_ERROR(stage("dfg"));
    t0 = std::chrono::steady_clock::now();
    SHRM_ASSIGN_OR_RETURN(run.dfg, ibl::ComputeDfgLut(job.dfg_size, *consumer, threads));
    run.timings.push_back({"dfg", MsSince(t0)});
  }
  SHRM_RETURN_IF_ERROR(stage("storage"));
  t0 = std::chrono::steady_clock::now();
  for (IblCube* cube : {&run.specular, &run.sheen, &run.irradiance}) StoreAs(job.format, *cube);
  run.timings.push_back({"storage", MsSince(t0)});
  if (job.verify > 0 && map != nullptr) {
    SHRM_RETURN_IF_ERROR(stage("verify"));
    t0 = std::chrono::steady_clock::now();
    // Every check of the job in one pass over the map's pixels.
    std::vector<ibl::LevelCheck> checks;
    AddChecks(ibl::SpecularLobe::kGgx, job.verify, kSpecularVerifySeed, run.specular, checks);
    if (job.sheen)
      AddChecks(ibl::SpecularLobe::kCharlie, job.verify, kSheenVerifySeed, run.sheen, checks);
    AddChecks(ibl::SpecularLobe::kLambert, job.verify, kIrradianceVerifySeed, run.irradiance,
              checks);
    // The check of E_lm = A_l L_lm, the form `shrm irradiance` states, at the irradiance cube
    // check's normals: MeasureLevelErrors makes their pixel sums once for both.
    SHRM_ASSIGN_OR_RETURN(const std::vector<double> e9,
                          IrradianceCoefficients(2, 3, run.radiance_sh9));
    ibl::SpecularLevel sh9_level;
    SHRM_ASSIGN_OR_RETURN(
        const ibl::LevelCheck sh9_check,
        IrradianceSh9Check(e9, job.verify, &sh9_level, job.irradiance_size, kIrradianceVerifySeed));
    checks.push_back(sh9_check);
    const std::vector<ibl::LevelError> errors =
        ibl::MeasureLevelErrors(*map, checks, rotation, threads);
    auto next = errors.begin();
    for (IblCube* cube : {&run.specular, &run.sheen, &run.irradiance}) {
      if (cube == &run.sheen && !job.sheen) continue;
      cube->measured.assign(next, next + static_cast<std::ptrdiff_t>(cube->chain.levels.size()));
      next += static_cast<std::ptrdiff_t>(cube->chain.levels.size());
    }
    run.sh9_measured = *next;
    run.timings.push_back({"verify", MsSince(t0)});
  }
  run.report = IblReportJson(job, run);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<IblRun> RunIblJobOnMap(const IblJob& job, const EnvMap& map,
                                      const SourceIdentity& source, double decode_ms, int threads,
                                      const PrefilterProgress& progress) {
  SHRM_RETURN_IF_ERROR(ValidateIblJob(job));
  IblRun run;
  run.source = source;
  run.layout = map.layout();
  run.replaced_non_finite = map.replaced_non_finite();
  run.timings.push_back({"decode", decode_ms});
  const auto t0 = std::chrono::steady_clock::now();
  const Mat3 rotation = EnvironmentRotation(job.env);
  SHRM_ASSIGN_OR_RETURN(const ibl::SplitSumSetOptions options, IblSplitSumSetOptions(job));
  if (progress) SHRM_RETURN_IF_ERROR(progress("lighting"));
  SHRM_ASSIGN_OR_RETURN(const ibl::SpecularLight light,
                        ibl::ComputeSplitSumLight(map, rotation, options, threads));
  run.timings.push_back({"lighting", MsSince(t0)});
  SHRM_ASSIGN_OR_RETURN(
      ibl::SplitSumSet set,
      ibl::PrefilterSplitSumSet(map, light, options, threads, progress, &run.timings));
  SHRM_RETURN_IF_ERROR(FinishIblRun(job, std::move(set), &map, rotation, threads, progress, run));
  return run;
}

absl::StatusOr<IblRun> IblRunFromSet(const IblJob& job, ibl::SplitSumSet set,
                                     const SourceIdentity& source, EnvLayout layout,
                                     int64_t replaced_non_finite, int threads) {
  SHRM_RETURN_IF_ERROR(ValidateIblJob(job));
  if (job.verify != 0) {
    return absl::InvalidArgumentError("a set computed elsewhere is not checked: verify must be 0");
  }
  IblRun run;
  run.source = source;
  run.layout = layout;
  run.replaced_non_finite = replaced_non_finite;
  SHRM_RETURN_IF_ERROR(FinishIblRun(job, std::move(set), nullptr, EnvironmentRotation(job.env),
                                    threads, nullptr, run));
  return run;
}

nlohmann::json IblOptionsJson(const IblJob& job) {
  nlohmann::json o = {{"preset", ibl::RoughnessPresetName(job.preset)},
                      {"roughness", job.roughness},
                      {"size", job.face_size},
                      {"levels", job.levels},
                      {"sheen", job.sheen},
                      {"format", IblFormatName(job.format)},
                      {"irradiance_size", job.irradiance_size},
                      {"dfg_size", job.dfg_size},
                      {"tolerance", job.tolerance},
                      {"verify", job.verify},
                      {"sh_window", IblShWindowName(job.sh_window)},
                      {"dfg", job.dfg},
                      {"containers", IblContainersText(job.containers)},
                      {"preview", job.preview}};
  o["rotate"] = job.env.rotate_ypr_deg ? nlohmann::json(*job.env.rotate_ypr_deg) : nlohmann::json();
  return o;
}

nlohmann::json IblReportJson(const IblJob& job, const IblRun& run) {
  nlohmann::json r;
  r["shrm_version"] = kVersion;
  r["rules"] = kIblRulesRevision;
  r["options"] = IblOptionsJson(job);
  r["source"] = run.source.names;
  r["source_sha256"] = run.source.sha256;
  r["layout"] = EnvLayoutName(run.layout);
  r["working_space"] = job.env.working_colour_space;
  if (job.env.rotate_ypr_deg) r["rotate_ypr_deg"] = RotationAttribute(job.env);
  r["preset"] = ibl::RoughnessPresetName(job.preset);
  r["format"] = IblFormatName(job.format);
  const double rms = std::max(job.tolerance, IblFormatRounding(job.format));
  r["tolerance"] = {{"rms", rms}, {"max", kIblMaxErrorFactor * rms}};
  r["specular"] = CubeJson(run.specular);
  if (job.sheen) r["sheen"] = CubeJson(run.sheen);
  r["irradiance"] = CubeJson(run.irradiance);
  // L_lm, l <= 2, in the project's real SH and SH frame (docs/conventions.md): [[r, g, b] x 9]
  // in ShIndex order.
  nlohmann::json sh = nlohmann::json::array();
  for (int k = 0; k < 9 && static_cast<size_t>(3 * k + 2) < run.radiance_sh9.size(); ++k)
    sh.push_back(
        {run.radiance_sh9[3 * k], run.radiance_sh9[3 * k + 1], run.radiance_sh9[3 * k + 2]});
  r["radiance_sh9"] = sh;
  nlohmann::json w = {{"mode", IblShWindowName(job.sh_window)},
                      {"width", run.sh_window.width},
                      {"min_before", run.sh_window.min_before},
                      {"min_after", run.sh_window.min_after},
                      {"rms_change_relative", run.sh_window.rms_change_relative}};
  if (run.sh_window.width > 0)
    w["window"] = run.sh_window.window == ibl::ShWindow::kSinc4 ? "sinc4" : "hanning";
  r["sh_window"] = w;
  if (run.dfg) {
    const std::optional<ibl::DfgConsumer> consumer = ResolvedDfg(job);
    r["dfg"] = {{"consumer", ibl::DfgConsumerName(*consumer)},
                {"size", run.dfg->size},
                {"channels", run.dfg->channels}};
  }
  if (run.sh9_measured.count > 0) {
    // The l <= 2 truncation itself (about 3-10% on real maps; the irradiance cube is the exact
    // form): reported, not held to the tolerance.
    r["sh9_measured"] = {{"count", run.sh9_measured.count},
                         {"rms", run.sh9_measured.rms},
                         {"max", run.sh9_measured.max}};
  }
  bool met = true;
  for (const char* key : {"specular", "sheen", "irradiance"}) {
    if (!r.contains(key)) continue;
    for (const nlohmann::json& l : r[key]["levels"]) {
      if (!l.contains("measured")) continue;
      met &= l["measured"]["rms"].get<double>() <= rms &&
             l["measured"]["max"].get<double>() <= kIblMaxErrorFactor * rms;
    }
  }
  r["met"] = met;
  return r;
}

absl::Status IblOutcome(const IblJob& job, const nlohmann::json& report) {
  const double rms = report["tolerance"]["rms"].get<double>();
  const double largest = report["tolerance"]["max"].get<double>();
  for (const char* key : {"specular", "sheen", "irradiance"}) {
    if (!report.contains(key)) continue;
    for (const nlohmann::json& l : report[key]["levels"]) {
      if (!l.contains("measured")) continue;
      const double m_rms = l["measured"]["rms"].get<double>();
      const double m_max = l["measured"]["max"].get<double>();
      if (m_rms > rms || m_max > largest) {
        return absl::FailedPreconditionError(absl::StrCat(
            key, " level ", l["level"].get<int>(), " (roughness ", l["roughness"].get<double>(),
            "): measured relative RMS ", m_rms, " (target ", rms, "), largest ", m_max, " (target ",
            largest, ") at ", l["measured"]["count"].get<int>(),
            " directions; the outputs were written"));
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace shrm::jobs
