// The IBL job (`shrm ibl`): one environment map in, the split-sum image-based-lighting set that
// PBR engines load out (docs/ibl.md): the GGX-prefiltered radiance mip chain (core/ibl/
// split_sum.h), optionally the Charlie sheen chain, the diffuse irradiance as a cube (E / pi, the
// cosine-weighted mean radiance) and as 9 SH coefficients, and the DFG lookup table. This header
// is the one description of the job: its options, defaults and limits, their validation, the
// report's keys and the embedded run; the containers the outputs are written in follow from the
// job (jobs/ibl_outputs.h).
#ifndef SHRM_JOBS_IBL_JOB_H_
#define SHRM_JOBS_IBL_JOB_H_

#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/export/ktx2.h"
#include "core/ibl/dfg.h"
#include "core/ibl/sh9.h"
#include "core/ibl/split_sum.h"
#include "core/shrm/prefilter.h"
#include "jobs/environment.h"

namespace shrm::jobs {

// Storage of the radiance cubes (KTX2 VkFormat; docs/ktx2.md).
enum class IblFormat { kRgba16f, kRgba32f, kB10g11r11, kE5b9g9r9 };

// "rgba16f", "rgba32f", "r11g11b10f", "rgb9e5", and back (InvalidArgument listing them).
const char* IblFormatName(IblFormat format);
absl::StatusOr<IblFormat> ParseIblFormat(absl::string_view name);

// Relative rounding of one stored value (half a unit in the last place of the mantissa, relative
// to the value; for the shared-exponent format, to the largest channel of the texel): the floor
// under any measured error of a stored level.
double IblFormatRounding(IblFormat format);

// The KTX2 format of the radiance cubes (4 channels for the float formats, alpha = 1).
ktx2::Format IblKtx2Format(IblFormat format);

// Defaults and limits.
inline constexpr int kDefaultIblFaceSize = 256;
inline constexpr int kDefaultIrradianceSize = 32;
inline constexpr int kDefaultDfgSize = 128;
inline constexpr int kMaxDfgSize = 1024;
inline constexpr double kDefaultIblTolerance = 1e-3;
// Directions per level of the job's own check (about 2 ms each at 1024 x 512).
inline constexpr int kDefaultIblVerify = 16;
inline constexpr int kMaxIblVerify = 4096;
// The per-direction error is measured at up to this multiple of the truncation's sphere RMS on
// the bundled maps (tests/split_sum_test.cc): the core tolerance is the job's divided by it.
inline constexpr double kIblSphereToDirectionFactor = 30;
// Largest relative error allowed, as a multiple of the RMS target (the accuracy issue's 1% / 5%).
inline constexpr double kIblMaxErrorFactor = 5;

// Ringing control of the SH9 (core/ibl/sh9.h): kAuto = the weakest Hanning window that keeps the
// l <= 2 irradiance non-negative (nothing when it already is), kCmgen = cmgen's --sh-window=auto.
enum class IblShWindow { kAuto, kNone, kCmgen };
const char* IblShWindowName(IblShWindow window);  // "auto", "none", "cmgen"
absl::StatusOr<IblShWindow> ParseIblShWindow(absl::string_view name);

// The containers the set is written in (docs/ibl.md "Files"; sh9.json, ibl.json and the DFG
// table's EXR and PNG are always written):
//   kKtx2  specular.ktx2, [sheen.ktx2], irradiance.ktx2, dfg.ktx2 (the default)
//   kKtx1  Filament's files as cmgen --deploy writes them: ibl.ktx (the specular chain with the
//          "sh" key), skybox.ktx (level 0) and sh.txt, in Filament's frame (docs/ibl.md)
//   kGltf  ibl.glb: glTF 2.0 with EXT_lights_image_based and a sphere per roughness
enum class IblContainer { kKtx2, kKtx1, kGltf };
const char* IblContainerName(IblContainer container);  // "ktx2", "ktx1", "gltf"
// "ktx1,ktx2" -> {kKtx2, kKtx1} (sorted as the enum; "all" = every container). InvalidArgument
// on an empty list, an unknown name or a repeated one.
absl::StatusOr<std::vector<IblContainer>> ParseIblContainers(absl::string_view list);
std::string IblContainersText(const std::vector<IblContainer>& containers);  // "ktx2,ktx1"

// The DFG lookup table's consumer (core/ibl/dfg.h): a name of DfgConsumerName, "auto" (the
// preset's: filament -> "filament", otherwise "gltf-lut-ggx") or "none".
absl::Status ValidateDfgChoice(absl::string_view choice);
// The consumer `job.dfg` resolves to; nullopt for "none".
struct IblJob;
std::optional<ibl::DfgConsumer> ResolvedDfg(const IblJob& job);

struct IblJob {
  EnvironmentSpec env;
  ibl::RoughnessPreset preset = ibl::RoughnessPreset::kFilament;
  std::vector<double> roughness;  // kExplicit: one perceptual roughness per level
  int face_size = kDefaultIblFaceSize;
  int levels = 0;      // 0 = the preset's default
  bool sheen = false;  // also the Charlie chain
  IblFormat format = IblFormat::kRgba16f;
  int irradiance_size = kDefaultIrradianceSize;
  int dfg_size = kDefaultDfgSize;
  // Per-direction relative RMS target of every level (the largest error: kIblMaxErrorFactor x).
  double tolerance = kDefaultIblTolerance;
  int verify = kDefaultIblVerify;  // directions per level of the job's own check; 0 = none
  IblShWindow sh_window = IblShWindow::kAuto;
  std::string dfg = "auto";
  std::vector<IblContainer> containers = {IblContainer::kKtx2};  // sorted, no repeats
  bool preview = false;  // preview.png: the contact sheet of the chain (jobs/ibl_outputs.h)
  bool operator==(const IblJob&) const = default;
};

bool HasContainer(const IblJob& job, IblContainer container);

// Every option within its range, the chain buildable (MakeMipChain's errors).
[[nodiscard]] absl::Status ValidateIblJob(const IblJob& job);

// ValidateIblJob with the first invalid option named: the options (by their names in
// jobs/job_options.h: env, size, roughness with the preset, levels, tolerance, verify,
// irradiance_size, dfg_size, dfg, format, containers) are added one by one to a default job, and
// the first that makes it invalid is reported as "<name(option)>: <the job's message>". Front ends
// name their fields with `name` (the wire's face_size, the manifest's $.options.size).
[[nodiscard]] absl::Status ValidateIblJobNamingOptions(
    const IblJob& job, const std::function<std::string(std::string_view option)>& name);

// The mip chain of the job.
absl::StatusOr<ibl::MipChain> IblJobChain(const IblJob& job);

// One convolved or resampled cube and what the job measured on it.
struct IblCube {
  std::string name;  // "specular", "sheen", "irradiance"
  ibl::SpecularChain chain;
  std::vector<ibl::LevelError> measured;  // per level (count 0 when not checked)
  // Negative values (ringing of the truncated expansion below dark texels) set to 0 before
  // storage, and the most negative one relative to the level's mean luminance.
  int64_t clamped = 0;
  double most_negative = 0;
};

struct IblRun {
  IblCube specular;
  IblCube sheen;  // levels empty unless job.sheen
  IblCube irradiance;
  // Radiance L_lm, l <= 2, RGB, SH frame (docs/conventions.md): rgb[ShIndex(l, m) * 3 + c],
  // after the SH window (sh_window says which and what it changed).
  std::vector<double> radiance_sh9;
  ibl::Sh9WindowReport sh_window;
  // The l <= 2 irradiance / pi against the pixel sum at job.verify seeded normals.
  ibl::LevelError sh9_measured;
  std::optional<ibl::DfgLut> dfg;
  SourceIdentity source;
  EnvLayout layout = EnvLayout::kAuto;
  int64_t replaced_non_finite = 0;
  std::vector<StageTiming> timings;
  nlohmann::json report;  // IblReportJson
};

// The embedded run: decode and hash the map, the chains, the irradiance; negatives clamped to 0
// and every value rounded as job.format stores it (ktx2::RoundTrip), then each level measured at
// job.verify seeded texel centres against the brute-force pixel sum. `progress` (optional) is
// called at the start of each stage: lighting, specular, [sheen], irradiance, [dfg], [verify]; an
// error it returns stops the job (the service's cancellation).
absl::StatusOr<IblRun> RunIblJob(const IblJob& job, int threads,
                                 const PrefilterProgress& progress = nullptr);

// The same on a map already decoded (the service decodes blobs): `source` is what the outputs
// record, `decode_ms` the time it took to get the map.
absl::StatusOr<IblRun> RunIblJobOnMap(const IblJob& job, const EnvMap& map,
                                      const SourceIdentity& source, double decode_ms, int threads,
                                      const PrefilterProgress& progress = nullptr);

// The core options of the job's split-sum set (its chain, the core tolerance, sheen, the
// irradiance size): what RunIblJobOnMap computes, and a live session for `shrm live --ibl`.
absl::StatusOr<ibl::SplitSumSetOptions> IblSplitSumSetOptions(const IblJob& job);

// A set computed elsewhere (a live session's frame, core/live/live_session.h) as the job's run,
// what RunIblJobOnMap does after its chains: the SH window, the DFG table, negatives clamped and
// storage rounding, the report. job.verify must be 0 (a live frame is not checked); the set must
// be of job.env's map and rotation and IblSplitSumSetOptions(job). The files it encodes are those
// of RunIblJobOnMap with verify 0, byte for byte (tests/live_session_test.cc).
absl::StatusOr<IblRun> IblRunFromSet(const IblJob& job, ibl::SplitSumSet set,
                                     const SourceIdentity& source, EnvLayout layout,
                                     int64_t replaced_non_finite, int threads);

// The revision of the rules that choose a set's degrees and levels for given inputs, recorded in
// ibl.json ("rules") and raised whenever they come to choose differently, so that a resumed batch
// recomputes what an older rule chose (as kToleranceRulesRevision for SHRM files). An ibl.json
// without "rules" is revision 1.
inline constexpr int kIblRulesRevision = 1;

// The job's options as the report records them ("options": every option of IblJobOptions()
// besides the environment's files, layout and colour spaces, by its name there): what
// `shrm batch` compares to skip an up-to-date set.
nlohmann::json IblOptionsJson(const IblJob& job);

// The report: source, layout, shrm_version, rules (kIblRulesRevision), options, preset, format,
// tolerance and, per cube and level, face_size, roughness, alpha, degree, truncation_estimate and
// measured {count, rms, max}; "met" is false when a measured level misses its target. Front ends
// add the files they wrote.
nlohmann::json IblReportJson(const IblJob& job, const IblRun& run);

// FailedPrecondition naming the first level whose measured error misses the targets (the files
// are written all the same), OK otherwise.
absl::Status IblOutcome(const IblJob& job, const nlohmann::json& report);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_IBL_JOB_H_
