// Where the viewer's data comes from, all of it prepared off the GL thread:
//  - the environment (--env): the decoded map, a lat-long copy for the background, its SH
//    lighting coefficients (core/envmap/lighting.h, for modes that light with SH) and a
//    brute-force integrator over a downsampled copy (the ground truth of mode 5);
//  - the SHRM: read from an SHRM file (core/shrm/shrm_file.h), computed embedded with core's
//    Prefilter exactly as `shrm prefilter` runs it, or computed by a shrmd service (--server,
//    viewer/remote_source.h). Either kind is converted to the other (viewer/cube_convert.h), so
//    modes 1 (global) and 2 (local) always have theirs.
// AsyncShrmJob runs a computation on a worker thread with a progress fraction and cancellation;
// the UI swaps the result in when it is ready.
#ifndef SHRM_VIEWER_SCENE_SOURCE_H_
#define SHRM_VIEWER_SCENE_SOURCE_H_

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_shader_params.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/shrm/fast_reference.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_map.h"
#include "core/shrm/shrm_reference.h"
#include "jobs/prefilter_job.h"

namespace shrm::viewer {

// SH degree of EnvironmentData::sh (low-frequency lighting modes).
inline constexpr int kSceneLightLmax = 8;
// Largest width of the background texture (larger maps are resampled to it).
inline constexpr int kMaxBackgroundWidth = 4096;

struct EnvironmentData {
  explicit EnvironmentData(EnvMap m) : map(std::move(m)) {}
  std::string path;
  EnvMap map;
  Image latlong;                  // working-space linear RGB, rows from the top (background)
  int sh_lmax = kSceneLightLmax;  // less for lat-long maps too small to resolve it; -1: no sh
  std::vector<double> sh;         // RGB real SH L_lm, sh[ShIndex(l, m) * 3 + c], SH frame
  int reference_width = 0;        // lat-long width of the reference's samples
  std::shared_ptr<const ReferenceIntegrator> reference;
  // The brute-force sum over the full map, built once: each computed SHRM's own check
  // (ComputeRequest::verify) then costs ~1 ms per pair instead of the hierarchy's build.
  std::shared_ptr<const FastReference> fast_reference;
  double mean_luminance = 0;  // of the lat-long map, for the automatic exposure
};

// The part of EnvironmentData a map's background needs: the map, its lat-long copy (at most
// kMaxBackgroundWidth wide) and mean luminance; no SH lighting (sh_lmax -1) and no ground truth
// (the live mode's maps, viewer/live_source.h). Errors: those of the resampling.
[[nodiscard]] absl::StatusOr<std::shared_ptr<EnvironmentData>> EnvironmentBackground(
    EnvMap map, const std::string& path, int threads);

// Loads --env: decode (layout by aspect ratio), lat-long copy, SH to kSceneLightLmax, and the
// reference integrator over the map box-filtered to a reference_width x reference_width/2
// lat-long grid. Errors name the file.
[[nodiscard]] absl::StatusOr<std::shared_ptr<const EnvironmentData>> LoadEnvironment(
    const std::string& path, int reference_width, int threads);

// A lat-long image box-filtered to `width` (an even number; integer factors exactly, otherwise
// by bilinear resampling to a multiple of width first). Errors: those of the resampling.
[[nodiscard]] absl::StatusOr<Image> DownsampleLatLong(const Image& image, int width);

struct ShrmData {
  ShrmCube global, local;
  std::map<std::string, std::string> attributes;  // shrm:* of the file (or as prefilter writes)
  std::string brdf_spec;  // the BRDF (file attribute shrm:brdf, or the computed one)
  // The peak lights' BRDF as the shaders take it (shrm_lights.glsl), when the SHRM has lights.
  BrdfShaderParams light_brdf;
  int f_b = -1, p_b = -1;
  std::string epsilon;  // "0.03" or "explicit orders" (or "" when unknown)
  double eps_bound = -1;
  // shrm:measured_error (the job's check against the brute-force sum): relative RMS and largest
  // error over the front (N.V >= 0.3) and grazing pairs; pairs = 0 when not measured.
  struct Measured {
    double front_rms = 0, front_max = 0, grazing_rms = 0, grazing_max = 0;
    int pairs = 0;
  } measured;
  std::string tolerance;  // shrm:tolerance ("" without the per-direction tolerance rule)
  std::string origin;     // "file PATH", "embedded", "server HOST"
  double compute_ms = 0;
};

// Fills global + local from one cube (conversion, `threads` workers) and the fields from the
// attributes. convert = false leaves the other kind empty (face_size 0): the live mode converts
// only while mode 2 shows the local SHRM.
[[nodiscard]] absl::StatusOr<ShrmData> ShrmDataFromCube(
    ShrmCube cube, std::map<std::string, std::string> attributes, std::string origin, int threads,
    bool convert = true);
[[nodiscard]] absl::StatusOr<ShrmData> LoadShrmData(const std::string& path, int threads);

// The overlay's SHRM line: orders, size, the rule, and the measured error of the job's check
// (or, for an unchecked file, the eq. 5.19 bound, labelled as such).
std::string ShrmSummaryLine(const ShrmData& d);

// Pairs a computed SHRM is checked at by default (~1 ms each with the cached reference).
inline constexpr int kViewerVerifyPairs = 64;

// What to compute: the `shrm prefilter` options the viewer exposes.
struct ComputeRequest {
  std::string brdf_spec;
  double epsilon = jobs::kDefaultEpsilon;
  double tolerance = 0;             // > 0: the per-direction tolerance rule instead of epsilon
  int f = -1, p = -1;               // explicit orders (both or neither)
  int verify = kViewerVerifyPairs;  // pairs of the SHRM's own check (0: none)
  int face_size = 0;                // 0 = automatic (about 10 F_B)
  int threads = 1;
};

// The prefilter job of a request (a global SHRM of the map at `env_path`).
jobs::PrefilterJob PrefilterJobFor(const ComputeRequest& request, const std::string& env_path);

// Computes an SHRM; calls `progress` at each stage (its error cancels).
using ShrmComputeFn =
    std::function<absl::StatusOr<ShrmData>(const ComputeRequest&, const PrefilterProgress&)>;

// Embedded: core's Prefilter on env->map (kind global, then converted).
ShrmComputeFn EmbeddedCompute(std::shared_ptr<const EnvironmentData> env);

// One asynchronous computation at a time; Start() cancels the running one (its result is
// dropped). Poll() hands over a finished result once.
class AsyncShrmJob {
 public:
  explicit AsyncShrmJob(ShrmComputeFn compute) : compute_(std::move(compute)) {}
  ~AsyncShrmJob();
  AsyncShrmJob(const AsyncShrmJob&) = delete;
  AsyncShrmJob& operator=(const AsyncShrmJob&) = delete;

  void Start(const ComputeRequest& request);
  bool busy() const { return busy_.load(); }
  // Stage name and fraction of the stages done (brdf, lighting, analysis, synthesis, convert).
  std::string stage() const;
  double fraction() const { return fraction_.load(); }
  // The finished result (once), or nullopt while running / idle.
  [[nodiscard]] std::optional<absl::StatusOr<ShrmData>> Poll();
  // Blocks until the running job has finished (headless use), then Poll().
  [[nodiscard]] std::optional<absl::StatusOr<ShrmData>> Wait();

 private:
  void RunJob(const ComputeRequest& request, uint64_t gen);

  ShrmComputeFn compute_;
  std::atomic<uint64_t> generation_{0};
  std::atomic<bool> busy_{false};
  std::atomic<double> fraction_{0};
  mutable std::mutex mu_;
  std::string stage_;                               // guarded by mu_
  std::optional<absl::StatusOr<ShrmData>> result_;  // guarded by mu_
  // Workers and their "finished" flags: finished ones are joined by Start(), the rest (a
  // superseded job still in a stage) by the destructor.
  struct Worker {
    std::thread thread;
    std::shared_ptr<std::atomic<bool>> done;
  };
  std::vector<Worker> threads_;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_SCENE_SOURCE_H_
