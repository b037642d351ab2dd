// The prefilter job (`shrm prefilter`, `shrm batch`, the service's Prefilter call, the viewer's
// recomputation): an environment map and a BRDF in, an SHRM file out (SHRM paper sec. 5.6.2).
// This header is the one description of the job: its options and their defaults and limits,
// their validation, the SHRM file's attributes (docs/formats.md), the report's keys, the check a
// resumed batch makes against an existing output, and the embedded run. Every front end maps its
// own syntax (flags, manifest keys, request fields) onto PrefilterJob and nothing else.
#ifndef SHRM_JOBS_PREFILTER_JOB_H_
#define SHRM_JOBS_PREFILTER_JOB_H_

#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_coefficients.h"
#include "core/brdf/brdf_projection.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_file.h"
#include "jobs/environment.h"

namespace shrm::jobs {

// The order rule when none is given: the per-direction tolerance rule (core/shrm/tolerance.h,
// docs/shrm.md "Tolerance") at 1% relative RMS, within the size budget kDefaultMaxSizeMb.
inline constexpr double kDefaultTolerance = 0.01;
// The paper's energy tolerance (SHRM paper sec. 5.5) when --epsilon is given without a value
// (the viewer's and `shrm analyze`'s rule).
inline constexpr double kDefaultEpsilon = 0.03;
// The job's own check when none is asked for: 64 seeded (N, V) pairs against the brute-force sum
// (about 0.1-0.3 s on one core, most of it the reference's hierarchy of the map).
inline constexpr int kDefaultVerify = 64;
// Limits of a job's request: P_B <= 31 is what the SHRM file holds ((P + 1)^2 <= 1024 channel
// triples, core/io/cube_exr.cc); F_B up to the BRDF projection's degree; faces up to 2048.
inline constexpr int kMaxOrderF = kMaxBrdfLmax;
inline constexpr int kMaxOrderP = 31;
inline constexpr int kMaxFaceSize = 2048;
// The largest SHRM cube (6 S_B^2 (P_B + 1)^2 RGB float values) an embedded run allocates: half
// the machine's physical memory, so that orders too high for the machine (e.g. GGX at the
// default epsilon, which asks for F_B ~ 100 and P_B ~ 30) are refused with their sizes before
// the allocation, not killed by it. shrmd has its own limit and budget.
double EmbeddedCubeValueLimit();
// The size budget of the tolerance rule when none is given: the SHRM file's stored values (6 S_B^2
// (P_B + 1)^2 RGB at 4 bytes, 2 with --half) within this many MB (10^6 bytes). The tolerance
// is met within it when it can be; otherwise the most accurate choice within it is written and
// reported as missing the tolerance (docs/shrm.md "Size budget").
inline constexpr double kDefaultMaxSizeMb = 256;
inline constexpr double kMaxSizeMbLimit = 1e6;
// Most pairs a job's own check may ask for (about 1 ms each).
inline constexpr int kMaxVerifyPairs = 100000;
// shrm:epsilon of a job with explicit orders.
inline constexpr char kExplicitOrdersAttribute[] = "explicit orders";
// shrm:epsilon of a job with the per-direction tolerance rule.
inline constexpr char kToleranceRuleAttribute[] = "per-direction tolerance";

struct Orders {
  int f = 0;  // F_B
  int p = 0;  // P_B
  bool operator==(const Orders&) const = default;
};

// The order rule is one of three (set them with SetOrderRule or the Use* functions below, which
// keep the fields consistent): the per-direction tolerance (tolerance > 0, the default), the
// paper's epsilon (tolerance == 0, no orders) or explicit orders (tolerance == 0).
struct PrefilterJob {
  EnvironmentSpec env;
  std::string brdf;                  // BRDF spec (docs/brdf.md)
  double epsilon = kDefaultEpsilon;  // the epsilon rule's tolerance, in (0, 1)
  std::optional<Orders> orders;      // explicit (F_B, P_B) instead of the selection
  // > 0: the per-direction tolerance rule (core/shrm/tolerance.h) chooses F_B, P_B, the window
  // and S_B; 0 = the paper's epsilon rule (or explicit orders). Excludes `orders`.
  double tolerance = kDefaultTolerance;
  // Ringing window on the lighting bands; kAuto = chosen by the tolerance rule (none otherwise).
  RingingWindow window = RingingWindow::kAuto;
  // The variable of the view expansion (core/brdf/brdf_coefficients.h, docs/shrm.md "The view
  // variable"); nullopt = auto: the tolerance rule chooses (the normal first, the view too when
  // the normal misses the front RMS: AutoViewVariable), the paper's view with the epsilon rule
  // and explicit orders. The epsilon rule takes the view only.
  std::optional<ViewVariable> view;
  // > 0: the job measures its cube at this many seeded pairs against the brute-force sum
  // (FastReference): the report's "measured", shrm:measured_error; 0 = no check.
  int verify = kDefaultVerify;
  ShrmKind kind = ShrmKind::kGlobal;
  int face_size = 0;  // S_B; 0 = about 10 F_B in [16, 512]
  bool half = false;  // half floats in the SHRM file
  // The map's brightest pixels shipped as the SHRM's lights (PrefilterOptions::peak_lights):
  // by default a sun's, with the tolerance rule and a view-dependent analytic BRDF.
  PeakLights peak_lights = PeakLights::kAuto;
  // Tolerance rule only: the size budget of the file in MB (0: none).
  double max_size_mb = kDefaultMaxSizeMb;

  bool operator==(const PrefilterJob&) const = default;
};

// The order rules. UseEpsilonRule: the paper's energy tolerance; UseExplicitOrders: F_B, P_B as
// given; UseToleranceRule: the per-direction tolerance (the default).
void UseEpsilonRule(PrefilterJob* job, double epsilon);
void UseExplicitOrders(PrefilterJob* job, Orders orders);
void UseToleranceRule(PrefilterJob* job, double tolerance);
// A front end's choice: at most one of the three given (InvalidArgument naming them, with the
// front end's spelling `names`, e.g. "--epsilon, --tolerance and --orders"), none = the default.
[[nodiscard]] absl::Status SetOrderRule(PrefilterJob* job, std::optional<double> epsilon,
                                        std::optional<double> tolerance,
                                        std::optional<Orders> orders, std::string_view names);
// "epsilon", "tolerance" or "explicit" (the report's order_rule).
const char* OrderRuleName(const PrefilterJob& job);

// "global" / "local", and back (InvalidArgument naming the accepted values).
const char* ShrmKindName(ShrmKind kind);
absl::StatusOr<ShrmKind> ParseShrmKind(absl::string_view name);
// "auto" (nullopt), "view", "normal", and back (InvalidArgument naming the accepted values).
const char* ViewChoiceName(const std::optional<ViewVariable>& view);
absl::StatusOr<std::optional<ViewVariable>> ParseViewChoice(absl::string_view name);
// The view variable the job asks the core pipeline for (auto resolved by the order rule).
ViewVariable ResolvedViewVariable(const PrefilterJob& job);
// Whether the job leaves the variable to the tolerance rule (auto with --tolerance): the normal
// first, the view too when the normal's choice misses the front targets
// (PrefilterOptions::try_other_view).
bool AutoViewVariable(const PrefilterJob& job);

// Every option within its range (names as in docs/cli.md without the dashes); the BRDF spec is
// checked when it is parsed (ParseBrdfSpec).
[[nodiscard]] absl::Status ValidatePrefilterJob(const PrefilterJob& job);
// The size budget in stored values (max_size_mb over 4 bytes a value, 2 with half).
double SizeBudgetValues(const PrefilterJob& job);
// The core pipeline's options for the job.
PrefilterOptions CorePrefilterOptions(const PrefilterJob& job, int threads);

// What a run of the job produced, beyond the cube: what its outputs record.
struct PrefilterProvenance {
  std::string brdf_spec;  // canonical spec (file-based BRDFs: "table:PATH" as the user gave it)
  SourceIdentity source;
  EnvLayout layout = EnvLayout::kAuto;  // the resolved layout of the decoded map
};

// The revision of the tolerance rule's choices for given inputs (orders, face size, window, peak
// lights), recorded in the files it writes (shrm:rules) and raised whenever the rule comes to
// choose differently, so that a resumed batch recomputes what an older rule chose instead of
// taking it for up to date. A file without shrm:rules is revision 1 (sessions 23-45).
// 2: `--peak-lights auto` splits wherever the rest keeps at most half of the map's non-constant
//    luminance energy (session 45; before, at most 1%).
// 3: a view-dependent BRDF's truncation is chosen for half the largest-error target
//    (kViewLargestShare, session 46).
inline constexpr int kToleranceRulesRevision = 3;

// shrm:epsilon: the tolerance, "explicit orders" or "per-direction tolerance".
std::string EpsilonAttribute(const PrefilterJob& job);
// The SHRM file's attributes (docs/formats.md): shrm:brdf, shrm:epsilon, shrm:orders,
// shrm:brdf_orders, shrm:eps_light, shrm:eps_brdf, shrm:eps_bound, shrm:window, shrm:source,
// shrm:source_sha256, shrm:working_space, shrm:layout, shrm:version (shrm::kVersion), when
// rotated shrm:rotate_ypr_deg, with the tolerance rule shrm:tolerance, shrm:rules
// (kToleranceRulesRevision) and shrm:estimated_error
// ("front_rms,front_max,grazing_rms,grazing_max", core/shrm/tolerance.h) and, when checked,
// shrm:measured_error (the same four and the number of pairs), and with the tolerance rule
// shrm:tolerance_met ("true" or "false": ToleranceOutcome's verdict on the job's report).
std::map<std::string, std::string> PrefilterFileAttributes(const PrefilterJob& job,
                                                           const PrefilterProvenance& provenance,
                                                           const PrefilterResult& result);
// The report (docs/cli.md "--report"): the analysis (AnalysisJson) with brdf, kind, face_size,
// window, order_rule ("epsilon", "tolerance" or "explicit"), source_sha256, layout and shrm_version
// and, with the tolerance rule, "tolerance" (the targets, the estimate, the reference orders, met).
// Front ends add what only they know (output, source, timings, cache).
nlohmann::json PrefilterReportJson(const PrefilterJob& job, const PrefilterProvenance& provenance,
                                   const PrefilterResult& result);
// The tolerance rule's estimate and, when checked, the measured error against the job's targets,
// from the report (PrefilterReportJson, embedded or from a server): FailedPrecondition naming the
// figures when one misses them (the outputs are written all the same: the most accurate orders
// within the limits), OK when both meet them or the job has no tolerance. Where the job checked
// itself (--verify), the measurement is the verdict: an estimate that missed (within a size
// budget, or at the reference orders) with every measured target met is OK (session 23).
absl::Status ToleranceOutcome(const PrefilterJob& job, const nlohmann::json& report);

// An error an SHRM file records: shrm:estimated_error ("front_rms,front_max,grazing_rms,
// grazing_max") or shrm:measured_error (the same and the number of pairs); docs/formats.md.
struct RecordedError {
  DirectionalError error;
  int pairs = 0;  // measured: > 0
};
// `attribute`'s value among a file's `attributes`, parsed; nullopt when absent or malformed.
std::optional<RecordedError> FileRecordedError(const std::map<std::string, std::string>& attributes,
                                               const std::string& attribute);

// What an existing SHRM file says it missed when it was written ("" when it met its tolerance or
// was made without one): shrm:tolerance_met "false" (ToleranceOutcome's verdict, recorded since
// session 44), or in a file written before it, its shrm:measured_error against the targets of
// shrm:tolerance. A resumed batch reports such a file as missed, without recomputing it.
std::string RecordedToleranceMiss(const ShrmFile& file);

// Why an existing SHRM file was not made by `job` from a source with `source_sha256` and a BRDF
// whose canonical spec is `canonical_brdf` ("" when it was): a resumed batch recomputes it then.
std::string WhyFileDiffers(const PrefilterJob& job, const std::string& canonical_brdf,
                           const std::string& source_sha256, const ShrmFile& file);

// The embedded run: parse the BRDF, decode and hash the map, run the pipeline (`progress` is
// called at each stage, "decode" first), and describe the file to write.
struct PrefilterRun {
  PrefilterResult result;
  PrefilterProvenance provenance;
  std::map<std::string, std::string> attributes;  // PrefilterFileAttributes
  nlohmann::json report;                          // PrefilterReportJson, timings not included
  double decode_ms = 0;                           // decode and hash
  int64_t replaced_non_finite = 0;                // pixels set to 0 (replace_non_finite)
  // With `visuals`: the visual report's pictures and samples (jobs/report_visuals.h), and the
  // time they took (stage "report", after the pipeline's stages).
  nlohmann::json visuals;
  double visuals_ms = 0;
};
absl::StatusOr<PrefilterRun> RunPrefilterJob(const PrefilterJob& job, int threads,
                                             const PrefilterProgress& progress = nullptr,
                                             bool visuals = false);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_PREFILTER_JOB_H_
