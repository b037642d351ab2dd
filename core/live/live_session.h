// A live prefiltering session (issue 13, docs/live.md): the SHRM recomputed whenever the lighting
// or the material changes, always for the latest state.
//
// Updates (a new map, a rotation, lighting coefficients given directly, a new BRDF) replace the
// pending state and return their number; one worker thread computes frames. When it takes the
// pending state, every update since its last frame is in it: the states in between are never
// computed (counted in LiveStats::dropped), so a producer faster than the computation costs no
// queue, only the one pending state. A frame recomputes only what changed:
//   - rho_lpq (the BRDF stage) is cached by the BRDF's canonical spec (the last kLiveBrdfCache
//     specs: switching back to a material is free);
//   - L_lm of the current map is cached unrotated per degree F_rho used with it (a material
//     change back and forth transforms nothing); a rotation is applied to a copy in SH space
//     (RotateLighting, exact), as Prefilter() does after its transform, so the values are those
//     of Prefilter() bit for bit;
//   - analysis and synthesis run for every frame whose lighting or material changed;
//   - with a view set (SetView), the frame also holds the reflection map of that view (eq. 5.35,
//     ReflectionMapForView); a change of the view alone reuses the previous frame's cube;
//   - a session created with split-sum options also hands out the split-sum IBL set of each
//     lighting state (core/ibl/split_sum.h: the specular chain, the irradiance cube and the
//     radiance SH9, before storage): recomputed when the lighting changes (a map, a rotation),
//     reused when only the material or the view does; the map's coefficients to the degree the
//     chain needs are cached unrotated, as for the SHRM, and turned per frame. Without a BRDF
//     such a session's frames hold the set alone.
// Each frame's cube is what Prefilter() of the same map, rotation, BRDF and options gives, and its
// split-sum set what PrefilterSplitSumSet() of ComputeSpecularLight() gives (`shrm ibl`).
#ifndef SHRM_CORE_LIVE_LIVE_SESSION_H_
#define SHRM_CORE_LIVE_LIVE_SESSION_H_

#include <array>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/ibl/split_sum.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/radiance_cube.h"

namespace shrm {

// BRDF stages (rho_lpq at the session's rule) kept per session, by canonical spec.
inline constexpr int kLiveBrdfCache = 8;
// Released frames' cube buffers kept for reuse (a frame is computed while the previous one is
// still held: two cover a consumer that lets each frame go once it has the next).
inline constexpr size_t kPooledCubes = 2;

// One computed state of a session.
struct LiveFrame {
  uint64_t update = 0;      // the last update the frame includes
  absl::Status status;      // an update that cannot be computed (e.g. F_rho above the lighting's
                            // degree) gives a frame with its error; the next valid update recovers
  bool incomplete = false;  // no lighting or no BRDF yet (status FailedPrecondition)
  bool has_shrm = false;    // result holds an SHRM (false: a split-sum-only frame, or an error)
  PrefilterResult result;   // analysis, cube and the timings of the stages run for this frame
                            // (the split-sum set's stages too)
  // With split-sum options: the set of the frame's lighting (shared with the frames that reuse it).
  std::shared_ptr<const ibl::SplitSumSet> split_sum;
  bool split_sum_reused = false;    // the previous frame's set (the lighting did not change)
  bool brdf_reused = false;         // rho_lpq from the session's cache
  bool lighting_reused = false;     // L_lm from the session's cache (rotated again if asked)
  bool shrm_reused = false;         // only the view changed: the previous frame's cube
  std::optional<Vec3> view;         // the view of view_map (normalized)
  RadianceCube view_map;            // eq. 5.35 for `view` (empty without a view)
  double compute_ms = 0;            // the whole frame
  std::shared_ptr<const void> tag;  // the state's (SetMap ... SetView)
};

struct LiveStats {
  uint64_t updates = 0;  // updates received
  uint64_t frames = 0;   // frames computed
  uint64_t dropped = 0;  // states replaced while pending (never computed)
};

class LiveSession {
 public:
  // `options`: the paper's epsilon rule or explicit orders, kind, face size, threads (the
  // tolerance rule, which takes seconds, and the job's check are refused: InvalidArgument).
  // options.max_cube_values and options.admit_cube apply to every frame (as in Prefilter();
  // admit_cube is called on the worker thread).
  // `before_frame` (tests): called on the worker with the update about to be computed, before
  // it takes the pending state.
  // `split_sum` (optional): each frame also holds the split-sum set of its lighting (the lighting
  // must then be a map: the base level is the map itself; coefficients give the frame an error).
  static absl::StatusOr<std::unique_ptr<LiveSession>> Create(
      const PrefilterOptions& options, std::function<void(uint64_t)> before_frame = nullptr,
      std::optional<ibl::SplitSumSetOptions> split_sum = std::nullopt);
  ~LiveSession();  // stops the worker (a frame in progress finishes first)
  LiveSession(const LiveSession&) = delete;
  LiveSession& operator=(const LiveSession&) = delete;

  // The lighting: a map (its coefficients are computed by the session), or RGB L_lm in the
  // transform layout up to `lmax` with the lighting's energy (integral L^2 dw per channel, eq.
  // 5.15, for the analysis). Each replaces the other; the rotation applies to both.
  // SetMap with a rotation sets both in one update (a frame never has one without the other).
  // `tag` (optional, every update): the caller's description of the new state (e.g. what the
  // frame's outputs record), replacing the previous one in the same update; each frame carries
  // the tag of the state it was computed from (no queue of descriptions either).
  uint64_t SetMap(std::shared_ptr<const EnvMap> map, std::optional<Mat3> rotation = std::nullopt,
                  std::shared_ptr<const void> tag = nullptr);
  uint64_t SetCoefficients(std::shared_ptr<const std::vector<double>> rgb, int lmax,
                           std::array<double, 3> energy, std::shared_ptr<const void> tag = nullptr);
  uint64_t SetRotation(const Mat3& rotation, std::shared_ptr<const void> tag = nullptr);
  uint64_t SetBrdf(std::shared_ptr<const Brdf> brdf, std::shared_ptr<const void> tag = nullptr);
  // With split-sum options: whether the frames compute the set (on from the start; a viewer
  // showing the SHRM turns it off until the split-sum is shown). Turned on, the next frame
  // computes it (or reuses the previous frame's when the lighting is the same).
  uint64_t SetSplitSum(bool on, std::shared_ptr<const void> tag = nullptr);
  // The world view V of the frames' reflection map (eq. 5.35; normalized by the session, a zero
  // or non-finite one is the frame's error), or none (no map).
  uint64_t SetView(std::optional<Vec3> view, std::shared_ptr<const void> tag = nullptr);

  // The first frame that includes update `update`, waiting up to `timeout` (DeadlineExceeded).
  absl::StatusOr<std::shared_ptr<const LiveFrame>> WaitFor(uint64_t update,
                                                           absl::Duration timeout) const;
  // The newest frame once its update is above `after`, waiting up to `timeout` (null if none
  // came: a consumer polls with it, e.g. to notice its own stop flag).
  std::shared_ptr<const LiveFrame> WaitNewer(uint64_t after, absl::Duration timeout) const;
  // The newest frame (null before the first).
  std::shared_ptr<const LiveFrame> Latest() const;
  LiveStats Stats() const;

 private:
  struct State {
    std::shared_ptr<const EnvMap> map;
    std::shared_ptr<const std::vector<double>> coefficients;
    int coefficients_lmax = 0;
    std::array<double, 3> energy{};
    Mat3 rotation = Mat3::Identity();
    std::shared_ptr<const Brdf> brdf;
    std::optional<Vec3> view;
    bool split_sum = true;  // SetSplitSum
    std::shared_ptr<const void> tag;
    // The same lighting and material (pointers and values; the view aside).
    bool SameShrm(const State& o) const;
    // The same lighting (pointers and values).
    bool SameLighting(const State& o) const;
  };
  struct CachedBrdf {
    std::string spec;
    std::shared_ptr<const BrdfStage> stage;
  };

  LiveSession(const PrefilterOptions& options, std::function<void(uint64_t)> before_frame,
              std::optional<ibl::SplitSumSetOptions> split_sum);
  uint64_t Update(const std::function<void(State*)>& change, std::shared_ptr<const void> tag);
  void Run();
  // The frame of `state`, reusing the caches and `previous` (worker thread only).
  LiveFrame Compute(const State& state, const LiveFrame* previous, const State* previous_state);
  absl::StatusOr<std::shared_ptr<const BrdfStage>> BrdfStageFor(const Brdf& brdf, bool* reused);
  // The split-sum set of `state`'s lighting into `f` (worker thread only).
  absl::Status ComputeSplitSum(const State& state, const LiveFrame* previous,
                               const State* previous_state, LiveFrame& f);

  const PrefilterOptions options_;
  const std::function<void(uint64_t)> before_frame_;
  const std::optional<ibl::SplitSumSetOptions> split_sum_;

  mutable std::mutex mu_;
  mutable std::condition_variable changed_;  // an update, a frame, or stop
  State pending_;
  uint64_t latest_update_ = 0;
  uint64_t computed_update_ = 0;
  LiveStats stats_;
  std::shared_ptr<const LiveFrame> latest_frame_;
  bool stop_ = false;

  // Worker-only caches.
  std::list<CachedBrdf> brdf_cache_;                       // most recent first
  std::shared_ptr<const EnvMap> lighting_map_;             // the map of the entries below
  std::map<int, std::vector<double>> lighting_unrotated_;  // by degree
  std::array<double, 3> lighting_energy_{};
  // The split-sum set's coefficients of split_sum_map_, unrotated, by degree (the degrees
  // ibl::SplitSumLightTries gives: at most the map's own limit unrotated,
  // kMaxRotationLmax rotated), and the map's luminance moments that choose it.
  std::shared_ptr<const EnvMap> split_sum_map_;
  // Its peaks split off (ibl::SplitLightPeaks, unrotated), and the moments of the rest.
  ibl::PeakSplit split_sum_split_;
  ibl::LightMoments split_sum_moments_;
  std::map<int, std::shared_ptr<const std::vector<double>>> split_sum_unrotated_;
  // The map's first-try degree did not suffice (ibl::SplitSumLightSuffices: rotation keeps each
  // band's energy): later frames go straight to the full degree instead of turning a light only
  // to drop it.
  bool split_sum_first_failed_ = false;
  SynthesisScratch split_sum_scratch_;  // the chain's grids, reused frame after frame
  SynthesisScratch shrm_scratch_;       // the SHRM's synthesis grid, the same
  // Cube storage of released frames, handed to the next synthesis (SynthesisScratch::cube): no
  // zero-fill and no first-touch page faults of a fresh buffer (10 MB at P = 5) per frame. Shared
  // with the frames' deleters, which run on any thread, also after the session is gone.
  class CubePool {
   public:
    // A released buffer (empty when none is kept).
    std::vector<float> Take();
    // Keeps `data` for a later frame (up to kPooledCubes buffers; empty ones are not kept).
    void Put(std::vector<float> data);

   private:
    std::mutex mu_;
    std::vector<std::vector<float>> free_;
  };
  std::shared_ptr<CubePool> cube_pool_ = std::make_shared<CubePool>();
  State computed_state_;  // the state of latest_frame_

  std::thread worker_;
};

}  // namespace shrm

#endif  // SHRM_CORE_LIVE_LIVE_SESSION_H_
