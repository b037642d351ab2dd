// The viewer's live mode (`shrm-view --live`, docs/viewer.md "Live", issue 13 item 3): the
// lighting changes with a clock and each state's SHRM is recomputed by one LiveSession
// (core/live/live_session.h, docs/live.md), always for the latest state; the render loop shows
// the newest frame and never waits for a computation (except with a deterministic clock, below).
//
// The clock is in seconds: the wall time since the start, or, with --live-step DT, exactly
// k * DT at the k-th rendered frame (k = 0, 1, ...), each frame then waiting for its own state's
// SHRM (deterministic screenshots and tests). Lighting at clock t (LiveLighting::At):
//   rotate:   the --env map turned about +Y by yaw(t) = speed * t degrees (wrapped to [0, 360)),
//             the rotation `shrm prefilter --rotate yaw,0,0` applies (jobs::EnvironmentRotation:
//             active, L_R(w) = L(R^-1 w), docs/envmap.md "Rotation");
//   sequence: frame floor(t * fps) mod n of the --sequence maps (looping); maps are decoded on a
//             worker thread, the next one while the current one is shown (MapProducer);
//   sky:      the procedural sky (core/envmap/sky.h) at the time of day time0 + speed * t hours,
//             re-rendered on a worker thread (the newest time wins).
// Everything here is free of GL (tested without a display: tests/viewer_live_test.cc).
#ifndef SHRM_VIEWER_LIVE_SOURCE_H_
#define SHRM_VIEWER_LIVE_SOURCE_H_

#include <array>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "core/base/geometry.h"
#include "core/live/live_session.h"
#include "jobs/prefilter_job.h"
#include "viewer/scene_source.h"

namespace shrm::viewer {

enum class LiveKind { kRotate, kSequence, kSky };

// Defaults of the live options (docs/viewer.md "Live").
inline constexpr double kDefaultRotateSpeed = 30;  // degrees of yaw per second
inline constexpr double kDefaultSkySpeed = 0.5;    // hours of the day per second
inline constexpr double kDefaultSequenceFps = 24;  // sequence frames per second
inline constexpr int kDefaultSkyWidth = 256;       // lat-long width of the rendered sky
// A frame index floor(t * fps) computed with this slack, so that t = k / fps from a step of
// 1 / fps lands on k, not on k - 1 by a rounding of t * fps (t and fps are user numbers).
inline constexpr double kSequenceIndexSlack = 1e-9;
// Safety net of the waits of the deterministic clock (a map's decode, a frame's computation):
// far beyond their milliseconds to seconds; a broken worker fails instead of hanging.
inline constexpr absl::Duration kLiveWait = absl::Minutes(10);

// The procedural sky's place and time (core/envmap/sky.h).
struct LiveSkySpec {
  int day_of_year = 173;               // --date (default 2024-06-21, the June solstice)
  double time_h = 6;                   // --time, local standard time in hours
  double latitude_deg = 37.87;         // --lat (north positive)
  double longitude_deg = -122.27;      // --lon (EAST positive, as sky.h)
  std::optional<double> meridian_deg;  // --meridian (default: 15 * round(lon / 15))
  double turbidity = 3;                // --turbidity
  int width = kDefaultSkyWidth;        // --sky-width
};

struct LiveSpec {
  LiveKind kind = LiveKind::kRotate;
  std::string env;                    // rotate: the map
  std::vector<std::string> sequence;  // sequence: the maps, as given (files or one folder)
  std::optional<double> speed;        // rotate: degrees/s, sky: hours/s
  double fps = kDefaultSequenceFps;   // sequence
  double step = 0;                    // > 0: the deterministic clock, seconds per frame
  LiveSkySpec sky;
};

const char* LiveKindName(LiveKind kind);

// --sequence: one folder -> its *.exr files (any case) sorted by name; otherwise the files as
// given. Errors (NotFound / InvalidArgument) name the folder: missing, or no .exr files in it.
[[nodiscard]] absl::StatusOr<std::vector<std::string>> ExpandSequence(
    const std::vector<std::string>& args);

// Sequence frame at clock t (>= 0) for `count` maps at `fps`: floor(t fps) mod count.
int SequenceIndexAt(double t, double fps, int count);
// Yaw in [0, 360) degrees at clock t.
double RotateYawAt(double t, double speed_deg_per_s);

// A lighting map with its background (EnvironmentData without SH lighting or ground truth).
struct LiveMap {
  std::shared_ptr<const EnvironmentData> env;
  std::string label;   // the file, or the sky's date and time
  double make_ms = 0;  // decode or render
};

// The lighting map of `path` (any layout EnvMap reads) for the live mode. Errors name the file.
[[nodiscard]] absl::StatusOr<std::shared_ptr<const LiveMap>> LoadLiveMap(const std::string& path,
                                                                         int threads);

// Makes lighting maps on one worker thread by key (a sequence index, a sky time), the newest
// request first: the render loop asks (Request), takes what is made (Find) and never waits,
// except with the deterministic clock (Wait). After a map, the worker makes next(key) if there
// is one (the sequence's next frame) unless a request is waiting. The last `keep` results stay.
class MapProducer {
 public:
  using MakeFn = std::function<absl::StatusOr<std::shared_ptr<const LiveMap>>(int64_t key)>;
  using NextFn = std::function<std::optional<int64_t>(int64_t key)>;
  MapProducer(MakeFn make, NextFn next, int keep);
  ~MapProducer();  // stops the worker (a map in progress finishes first)
  MapProducer(const MapProducer&) = delete;
  MapProducer& operator=(const MapProducer&) = delete;

  // A result made elsewhere (the first map, decoded before the window opens).
  void Seed(int64_t key, std::shared_ptr<const LiveMap> map);
  // Asks for `key` (replaces a request not started yet); a made key asks for its next().
  void Request(int64_t key);
  // `key`'s result once made (a map or its error), nullopt before.
  std::optional<absl::StatusOr<std::shared_ptr<const LiveMap>>> Find(int64_t key) const;
  // Requests `key` and waits for its result (DeadlineExceeded after `timeout`).
  [[nodiscard]] absl::StatusOr<std::shared_ptr<const LiveMap>> Wait(int64_t key,
                                                                    absl::Duration timeout);
  // The result made or seeded last, with its key (the sky: the newest time rendered).
  std::optional<std::pair<int64_t, absl::StatusOr<std::shared_ptr<const LiveMap>>>> Newest() const;

 private:
  using Result = absl::StatusOr<std::shared_ptr<const LiveMap>>;
  const Result* FindLocked(int64_t key) const;
  void Store(int64_t key, Result r);
  void Run();

  const MakeFn make_;
  const NextFn next_;
  const int keep_;
  mutable std::mutex mu_;
  std::condition_variable changed_;
  std::optional<int64_t> requested_, prefetch_;
  std::deque<std::pair<int64_t, Result>> results_;  // oldest first, at most keep_
  bool stop_ = false;
  std::thread worker_;
};

// The lighting of one instant.
struct LiveLightingState {
  std::shared_ptr<const LiveMap> map;                   // null: keep the last (LiveDriver::Push)
  Mat3 rotation = Mat3::Identity();                     // world rotation of the lighting
  std::optional<std::array<double, 3>> rotate_ypr_deg;  // as shrm:rotate_ypr_deg records it
  std::string text;  // overlay: "yaw 30.0 deg", "frame 2/5 a.exr"
};

// The lighting source of a LiveSpec.
class LiveLighting {
 public:
  // Decodes the rotate map or the sequence's first map, checks every sequence file's header,
  // renders the sky at t = 0: every input error before the window opens (they name the file).
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<LiveLighting>> Create(const LiveSpec& spec,
                                                                            int threads);
  // The lighting at clock t. wait = false: never blocks (a map not made yet: the newest made,
  // with its own text); wait = true: waits for the map of t.
  [[nodiscard]] absl::StatusOr<LiveLightingState> At(double t, bool wait);
  const LiveSpec& spec() const { return spec_; }
  const std::vector<std::string>& files() const { return files_; }
  std::shared_ptr<const LiveMap> first() const { return first_; }

 private:
  LiveLighting(LiveSpec spec, int threads) : spec_(std::move(spec)), threads_(threads) {}
  absl::StatusOr<std::shared_ptr<const LiveMap>> MakeSky(int64_t second_of_year) const;
  std::string SkyText(int64_t second_of_year) const;
  std::string FrameText(int index) const;

  LiveSpec spec_;
  int threads_;
  std::vector<std::string> files_;  // sequence
  std::shared_ptr<const LiveMap> first_;
  std::unique_ptr<MapProducer> producer_;
};

// One state's SHRM as the viewer shows it.
struct LiveShown {
  uint64_t update = 0;  // the session's update the frame includes
  absl::Status status;  // the frame's error (the SHRM of the previous frame stays on screen)
  std::shared_ptr<const ShrmData> shrm;  // global and local cubes, orders, attributes
  std::shared_ptr<const LiveMap> map;    // the lighting it was computed from (the background)
  Mat3 rotation = Mat3::Identity();
  std::string lighting;  // LiveLightingState::text
  std::string brdf_spec;
  std::vector<StageTiming> timings;  // the session's stages (brdf, lighting, analysis, synthesis)
  double compute_ms = 0;             // the session's whole frame
  double convert_ms = 0;   // ShrmData and, for mode 2, global -> local (viewer/cube_convert.h)
  bool has_local = false;  // shrm->local converted (LiveDriver::SetNeedLocal)
  // Mode 6 (LiveDriver::SetNeedSplitSum): the session's split-sum set of this lighting
  // (kSplitSumFaceSize chain, viewer/split_sum_shading.h), and the BRDF it is shaded with.
  std::shared_ptr<const ibl::SplitSumSet> split_sum;
  std::shared_ptr<const Brdf> brdf;
  bool brdf_reused = false, lighting_reused = false;
};

// The LiveSession of the viewer: Push() sends what changed of the lighting and the material; a
// presenter thread turns each newest frame into what the render loop uploads (both SHRM kinds),
// so that the loop only swaps pointers.
class LiveDriver {
 public:
  // `job`: the order rule (epsilon or explicit orders), the face size; kind global. Errors: the
  // session's (the tolerance rule and the job's check are refused).
  [[nodiscard]] static absl::StatusOr<std::unique_ptr<LiveDriver>> Create(
      const jobs::PrefilterJob& job, int threads);
  ~LiveDriver();
  LiveDriver(const LiveDriver&) = delete;
  LiveDriver& operator=(const LiveDriver&) = delete;

  // Sends the changes of (lighting, brdf_spec) since the last Push (a map: SetMap with its
  // rotation; a rotation alone: SetRotation; a BRDF: SetBrdf) and returns the update that holds
  // them (the last one if nothing changed). lighting.map null keeps the last map. Errors: a bad
  // spec (nothing sent).
  [[nodiscard]] absl::StatusOr<uint64_t> Push(const LiveLightingState& lighting,
                                              const std::string& brdf_spec);
  // The newest shown frame (null before the first).
  std::shared_ptr<const LiveShown> Latest() const;
  // The first shown frame that includes `update` (DeadlineExceeded after `timeout`).
  [[nodiscard]] absl::StatusOr<std::shared_ptr<const LiveShown>> WaitFor(
      uint64_t update, absl::Duration timeout) const;
  LiveStats Stats() const { return session_->Stats(); }
  // Whether shown frames need the local SHRM (mode 2): the conversion global -> local costs about
  // as much as a frame (docs/viewer.md "Live"), so it is done only while it is shown. Setting it
  // converts the newest frame again; WaitFor then waits for a frame that has it.
  void SetNeedLocal(bool need);
  // Whether frames need the split-sum set (mode 6): the session computes it only while it is
  // shown (a GGX chain of kSplitSumFaceSize per lighting change). Render thread only (it sends an
  // update when the need changes, which the next Push returns); WaitFor then waits for a frame
  // that has it.
  void SetNeedSplitSum(bool need);

 private:
  struct Sent;  // what was sent: the tag of each update
  LiveDriver(jobs::PrefilterJob job, int threads, std::unique_ptr<LiveSession> session);
  LiveShown Convert(const LiveFrame& frame, bool local) const;
  void Present();
  // Has the local SHRM and the split-sum set if needed (mu_ held).
  bool Complete(const LiveShown& shown) const;

  const jobs::PrefilterJob job_;
  const int threads_;
  std::unique_ptr<LiveSession> session_;
  std::shared_ptr<const Sent> sent_;  // render thread only
  uint64_t last_update_ = 0;          // render thread only

  mutable std::mutex mu_;
  mutable std::condition_variable shown_changed_;
  std::shared_ptr<const LiveShown> shown_;
  bool need_local_ = false;
  bool need_split_sum_ = false;  // written on the render thread under mu_
  bool stop_ = false;
  std::thread presenter_;
};

// Events per second over the last `window` seconds (frames computed, frames rendered): Add()
// a running count at time t (seconds, any origin; the caller's clock, so tests need none).
class RateMeter {
 public:
  explicit RateMeter(double window_s = 1.0) : window_(window_s) {}
  void Add(double t, uint64_t count);
  // (count now - count at the oldest sample in the window) / (their time span); 0 before two.
  double rate() const;

 private:
  double window_;
  std::deque<std::pair<double, uint64_t>> samples_;
};

// The overlay's live lines: the lighting, the stages of the shown frame in ms (each stage the
// session ran, then compute and convert), the live and render frames per second, the states
// dropped, and (F_B, P_B).
std::vector<std::string> LiveOverlayLines(const LiveSpec& spec, const LiveShown& shown,
                                          const LiveStats& stats, double live_fps,
                                          double render_fps);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_LIVE_SOURCE_H_
