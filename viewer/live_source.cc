#include "viewer/live_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/envmap/sky.h"
#include "jobs/environment.h"
#include "viewer/split_sum_shading.h"

namespace shrm::viewer {
namespace {

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// Maps the producer keeps: the one shown, the next one (prefetched) and the one being replaced.
constexpr int kSequenceKeep = 3;
constexpr int kSkyKeep = 2;

}  // namespace

const char* LiveKindName(LiveKind kind) {
  switch (kind) {
    case LiveKind::kRotate:
      return "rotate";
    case LiveKind::kSequence:
      return "sequence";
    case LiveKind::kSky:
      return "sky";
  }
  return "?";
}

absl::StatusOr<std::vector<std::string>> ExpandSequence(const std::vector<std::string>& args) {
  std::error_code ec;
  if (args.size() != 1 || !std::filesystem::is_directory(args.front(), ec)) return args;
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(args.front(), ec)) {
    if (entry.is_regular_file(ec) &&
        absl::AsciiStrToLower(entry.path().extension().string()) == ".exr") {
      files.push_back(entry.path().string());
    }
  }
  if (ec) {
    return absl::NotFoundError(
        absl::StrCat("--sequence: cannot list the folder '", args.front(), "': ", ec.message()));
  }
  if (files.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--sequence: the folder '", args.front(), "' has no .exr files"));
  }
  std::sort(files.begin(), files.end());
  return files;
}

int SequenceIndexAt(double t, double fps, int count) {
  const double frame = std::floor(std::max(0.0, t) * fps + kSequenceIndexSlack);
  return static_cast<int>(std::fmod(frame, static_cast<double>(count)));
}

double RotateYawAt(double t, double speed_deg_per_s) {
  const double yaw = std::fmod(speed_deg_per_s * t, 360.0);
  return yaw < 0 ? yaw + 360.0 : yaw;
}

absl::StatusOr<std::shared_ptr<const LiveMap>> LoadLiveMap(const std::string& path, int threads) {
  const auto start = std::chrono::steady_clock::now();
  // Read as `shrm prefilter --env PATH` reads it (the job layer's defaults: colour spaces).
  jobs::EnvironmentSpec spec;
  spec.files = {path};
  SHRM_ASSIGN_OR_RETURN(EnvMap map, EnvMap::Load(jobs::EnvMapOptionsFor(spec)));
  auto m = std::make_shared<LiveMap>();
  SHRM_ASSIGN_OR_RETURN(m->env, EnvironmentBackground(std::move(map), path, threads));
  m->label = std::filesystem::path(path).filename().string();
  m->make_ms = MsSince(start);
  return std::shared_ptr<const LiveMap>(std::move(m));
}

// --- MapProducer ----------------------------------------------------------------------------

MapProducer::MapProducer(MakeFn make, NextFn next, int keep)
    : make_(std::move(make)), next_(std::move(next)), keep_(std::max(1, keep)) {
  worker_ = std::thread([this] { Run(); });
}

MapProducer::~MapProducer() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  changed_.notify_all();
  worker_.join();
}

const MapProducer::Result* MapProducer::FindLocked(int64_t key) const {
  for (const auto& [k, r] : results_)
    if (k == key) return &r;
  return nullptr;
}

void MapProducer::Store(int64_t key, Result r) {
  for (auto it = results_.begin(); it != results_.end(); ++it) {
    if (it->first == key) {
      results_.erase(it);
      break;
    }
  }
  results_.emplace_back(key, std::move(r));
  while (static_cast<int>(results_.size()) > keep_) results_.pop_front();
}

void MapProducer::Seed(int64_t key, std::shared_ptr<const LiveMap> map) {
  std::lock_guard<std::mutex> lock(mu_);
  Store(key, std::move(map));
}

void MapProducer::Request(int64_t key) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (FindLocked(key) == nullptr) {
      requested_ = key;
    } else if (const std::optional<int64_t> next = next_ ? next_(key) : std::nullopt;
               next && FindLocked(*next) == nullptr) {
      prefetch_ = next;
    } else {
      return;
    }
  }
  changed_.notify_all();
}

std::optional<absl::StatusOr<std::shared_ptr<const LiveMap>>> MapProducer::Find(int64_t key) const {
  std::lock_guard<std::mutex> lock(mu_);
  const Result* r = FindLocked(key);
  if (r == nullptr) return std::nullopt;
  return *r;
}

absl::StatusOr<std::shared_ptr<const LiveMap>> MapProducer::Wait(int64_t key,
                                                                 absl::Duration timeout) {
  Request(key);
  std::unique_lock<std::mutex> lock(mu_);
  const bool made = changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                                      [&] { return FindLocked(key) != nullptr; });
  if (!made) {
    return absl::DeadlineExceededError(
        absl::StrCat("the lighting map ", key, " was not made in ", absl::FormatDuration(timeout)));
  }
  return *FindLocked(key);
}

std::optional<std::pair<int64_t, absl::StatusOr<std::shared_ptr<const LiveMap>>>>
MapProducer::Newest() const {
  std::lock_guard<std::mutex> lock(mu_);
  if (results_.empty()) return std::nullopt;
  return results_.back();
}

void MapProducer::Run() {
  std::unique_lock<std::mutex> lock(mu_);
  while (true) {
    changed_.wait(lock, [&] { return stop_ || requested_ || prefetch_; });
    if (stop_) return;
    // A request before a prefetch; either is skipped when it is made already.
    const bool requested = requested_.has_value();
    const int64_t key = requested ? *requested_ : *prefetch_;
    if (requested) {
      requested_.reset();
    } else {
      prefetch_.reset();
    }
    if (FindLocked(key) == nullptr) {
      lock.unlock();
      Result r = make_(key);
      lock.lock();
      Store(key, std::move(r));
      changed_.notify_all();
    }
    // One map ahead of the requests only (a prefetch does not prefetch: a looping sequence
    // would otherwise be decoded round and round).
    if (requested && !requested_ && next_) {
      if (const std::optional<int64_t> next = next_(key); next && FindLocked(*next) == nullptr) {
        prefetch_ = next;
      }
    }
  }
}

// --- LiveLighting ---------------------------------------------------------------------------

absl::StatusOr<std::unique_ptr<LiveLighting>> LiveLighting::Create(const LiveSpec& spec,
                                                                   int threads) {
  std::unique_ptr<LiveLighting> l(new LiveLighting(spec, threads));
  switch (spec.kind) {
    case LiveKind::kRotate: {
      SHRM_ASSIGN_OR_RETURN(l->first_, LoadLiveMap(spec.env, threads));
      break;
    }
    case LiveKind::kSequence: {
      SHRM_ASSIGN_OR_RETURN(l->files_, ExpandSequence(spec.sequence));
      for (const std::string& f : l->files_) {
        // Every header before the window opens (a missing or truncated file, by name).
        SHRM_RETURN_IF_ERROR(ProbeImage(f).status());
      }
      SHRM_ASSIGN_OR_RETURN(l->first_, LoadLiveMap(l->files_.front(), threads));
      const std::vector<std::string> files = l->files_;
      const int count = static_cast<int>(files.size());
      l->producer_ = std::make_unique<MapProducer>(
          [files, threads](int64_t key) { return LoadLiveMap(files[key], threads); },
          [count](int64_t key) -> std::optional<int64_t> {
            if (count == 1) return std::nullopt;
            return (key + 1) % count;
          },
          kSequenceKeep);
      l->producer_->Seed(0, l->first_);
      break;
    }
    case LiveKind::kSky: {
      const int64_t key = static_cast<int64_t>(std::llround(spec.sky.time_h * 3600));
      SHRM_ASSIGN_OR_RETURN(l->first_, l->MakeSky(key));
      const LiveLighting* self = l.get();
      l->producer_ = std::make_unique<MapProducer>([self](int64_t k) { return self->MakeSky(k); },
                                                   nullptr, kSkyKeep);
      l->producer_->Seed(key, l->first_);
      break;
    }
  }
  return l;
}

absl::StatusOr<LiveLightingState> LiveLighting::At(double t, bool wait) {
  LiveLightingState s;
  switch (spec_.kind) {
    case LiveKind::kRotate: {
      const double yaw = RotateYawAt(t, spec_.speed.value_or(kDefaultRotateSpeed));
      jobs::EnvironmentSpec env;
      env.rotate_ypr_deg = std::array<double, 3>{yaw, 0, 0};
      s.map = first_;
      s.rotation = jobs::EnvironmentRotation(env);
      s.rotate_ypr_deg = env.rotate_ypr_deg;
      s.text = absl::StrFormat("yaw %.1f deg", yaw);
      return s;
    }
    case LiveKind::kSequence: {
      const int index = SequenceIndexAt(t, spec_.fps, static_cast<int>(files_.size()));
      s.text = FrameText(index);
      if (wait) {
        SHRM_ASSIGN_OR_RETURN(s.map, producer_->Wait(index, kLiveWait));
        return s;
      }
      // This frame's map if it is decoded, else the newest decoded (the loop never waits).
      producer_->Request(index);
      if (auto r = producer_->Find(index)) {
        if (!r->ok()) return r->status();
        s.map = **r;
      } else if (auto newest = producer_->Newest(); newest && newest->second.ok()) {
        s.map = *newest->second;
        s.text = FrameText(static_cast<int>(newest->first));
      }
      return s;
    }
    case LiveKind::kSky: {
      const double hours = spec_.sky.time_h + spec_.speed.value_or(kDefaultSkySpeed) * t;
      const int64_t key = static_cast<int64_t>(std::llround(hours * 3600));
      s.text = SkyText(key);
      if (wait) {
        SHRM_ASSIGN_OR_RETURN(s.map, producer_->Wait(key, kLiveWait));
        return s;
      }
      // The newest sky made (a slightly earlier time while the worker renders this one).
      producer_->Request(key);
      if (auto r = producer_->Newest()) {
        if (!r->second.ok()) return r->second.status();
        s.map = *r->second;
        s.text = SkyText(r->first);
      }
      return s;
    }
  }
  return absl::InternalError("unknown live kind");
}

namespace {

// Seconds of the sky's clock -> (day of the year, standard time): days wrap after 365.
void SkyDayAndTime(const LiveSkySpec& sky, int64_t second, int* day, double* hours) {
  const int64_t days = second >= 0 ? second / 86400 : -((-second + 86399) / 86400);
  const int64_t in_day = second - days * 86400;
  *day = static_cast<int>(((sky.day_of_year - 1 + days) % 365 + 365) % 365) + 1;
  *hours = static_cast<double>(in_day) / 3600;
}

}  // namespace

std::string LiveLighting::FrameText(int index) const {
  return absl::StrFormat("frame %d/%d %s", index + 1, static_cast<int>(files_.size()),
                         std::filesystem::path(files_[index]).filename().string());
}

std::string LiveLighting::SkyText(int64_t second) const {
  int day = 0;
  double hours = 0;
  SkyDayAndTime(spec_.sky, second, &day, &hours);
  const int minutes = static_cast<int>(std::floor(hours * 60 + 1e-9));
  return absl::StrFormat("day %d %02d:%02d, lat %.2f lon %.2f, T %.1f", day, minutes / 60,
                         minutes % 60, spec_.sky.latitude_deg, spec_.sky.longitude_deg,
                         spec_.sky.turbidity);
}

absl::StatusOr<std::shared_ptr<const LiveMap>> LiveLighting::MakeSky(int64_t second) const {
  const auto start = std::chrono::steady_clock::now();
  sky::SunInput in;
  SkyDayAndTime(spec_.sky, second, &in.day_of_year, &in.standard_time_h);
  in.latitude_deg = spec_.sky.latitude_deg;
  in.longitude_deg = spec_.sky.longitude_deg;
  in.standard_meridian_deg =
      spec_.sky.meridian_deg.value_or(15 * std::round(spec_.sky.longitude_deg / 15));
  SHRM_ASSIGN_OR_RETURN(const sky::SunPosition sun, sky::ComputeSunPosition(in));
  sky::SkyOptions options;
  options.turbidity = spec_.sky.turbidity;
  SHRM_ASSIGN_OR_RETURN(Image image,
                        sky::RenderSkyLatLong(sky::SunDirection(sun), options, spec_.sky.width));
  auto m = std::make_shared<LiveMap>();
  m->label = absl::StrCat("sky ", SkyText(second));
  SHRM_ASSIGN_OR_RETURN(
      m->env, EnvironmentBackground(EnvMap::FromLatLong(std::move(image)), m->label, threads_));
  m->make_ms = MsSince(start);
  return std::shared_ptr<const LiveMap>(std::move(m));
}

// --- LiveDriver -----------------------------------------------------------------------------

// The state sent so far; each update's tag is a copy (LiveSession: a frame carries its state's).
struct LiveDriver::Sent {
  LiveLightingState lighting;
  std::shared_ptr<const Brdf> brdf;
  std::string brdf_spec;
};

absl::StatusOr<std::unique_ptr<LiveDriver>> LiveDriver::Create(const jobs::PrefilterJob& job,
                                                               int threads) {
  SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(job));
  PrefilterOptions options = jobs::CorePrefilterOptions(job, std::max(1, threads));
  options.max_cube_values = jobs::EmbeddedCubeValueLimit();
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<LiveSession> session,
                        LiveSession::Create(options, nullptr, ViewerSplitSumOptions()));
  session->SetSplitSum(false);  // until mode 6 is shown
  return std::unique_ptr<LiveDriver>(new LiveDriver(job, threads, std::move(session)));
}

LiveDriver::LiveDriver(jobs::PrefilterJob job, int threads, std::unique_ptr<LiveSession> session)
    : job_(std::move(job)), threads_(std::max(1, threads)), session_(std::move(session)) {
  sent_ = std::make_shared<const Sent>();
  presenter_ = std::thread([this] { Present(); });
}

LiveDriver::~LiveDriver() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  presenter_.join();
  session_.reset();
}

absl::StatusOr<uint64_t> LiveDriver::Push(const LiveLightingState& lighting,
                                          const std::string& brdf_spec) {
  const Sent& old = *sent_;
  if (brdf_spec != old.brdf_spec) {
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> parsed, ParseBrdfSpec(brdf_spec));
    auto next = std::make_shared<Sent>(*sent_);
    next->brdf = std::shared_ptr<const Brdf>(std::move(parsed));
    next->brdf_spec = brdf_spec;
    sent_ = next;
    last_update_ = session_->SetBrdf(next->brdf, sent_);
  }
  const LiveLightingState& was = sent_->lighting;
  // A state without a map (a sequence frame not decoded yet) changes nothing: the last stays.
  if (lighting.map == nullptr) return last_update_;
  const bool new_map = lighting.map != was.map;
  const bool new_rotation = lighting.rotation.m != was.rotation.m;
  if (!new_map && !new_rotation) return last_update_;
  auto next = std::make_shared<Sent>(*sent_);
  next->lighting = lighting;
  sent_ = next;
  if (new_map) {
    // The session keeps the map alive through its LiveMap (aliasing shared pointer).
    const std::shared_ptr<const EnvMap> map(lighting.map->env, &lighting.map->env->map);
    last_update_ = session_->SetMap(map, lighting.rotation, sent_);
  } else {
    last_update_ = session_->SetRotation(lighting.rotation, sent_);
  }
  return last_update_;
}

std::shared_ptr<const LiveShown> LiveDriver::Latest() const {
  std::lock_guard<std::mutex> lock(mu_);
  return shown_;
}

absl::StatusOr<std::shared_ptr<const LiveShown>> LiveDriver::WaitFor(uint64_t update,
                                                                     absl::Duration timeout) const {
  std::unique_lock<std::mutex> lock(mu_);
  const bool shown = shown_changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout), [&] {
    return shown_ != nullptr && shown_->update >= update && Complete(*shown_);
  });
  if (!shown) {
    return absl::DeadlineExceededError(absl::StrCat(
        "live: the frame of update ", update, " did not come in ", absl::FormatDuration(timeout)));
  }
  return shown_;
}

void LiveDriver::SetNeedLocal(bool need) {
  std::lock_guard<std::mutex> lock(mu_);
  need_local_ = need;
}

void LiveDriver::SetNeedSplitSum(bool need) {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (need == need_split_sum_) return;
    need_split_sum_ = need;
  }
  last_update_ = session_->SetSplitSum(need, sent_);
}

bool LiveDriver::Complete(const LiveShown& shown) const {
  return !shown.status.ok() ||
         ((!need_local_ || shown.has_local) && (!need_split_sum_ || shown.split_sum != nullptr));
}

LiveShown LiveDriver::Convert(const LiveFrame& frame, bool local) const {
  LiveShown s;
  s.update = frame.update;
  s.status = frame.status;
  s.timings = frame.result.timings;
  s.compute_ms = frame.compute_ms;
  s.brdf_reused = frame.brdf_reused;
  s.lighting_reused = frame.lighting_reused;
  const auto* sent = static_cast<const Sent*>(frame.tag.get());
  if (sent != nullptr) {
    s.map = sent->lighting.map;
    s.rotation = sent->lighting.rotation;
    s.lighting = sent->lighting.text;
    s.brdf_spec = sent->brdf_spec;
    s.brdf = sent->brdf;
  }
  s.split_sum = frame.split_sum;
  if (!s.status.ok() || sent == nullptr || sent->brdf == nullptr || s.map == nullptr) {
    if (s.status.ok()) s.status = absl::FailedPreconditionError("live: no lighting or BRDF yet");
    return s;
  }
  const auto start = std::chrono::steady_clock::now();
  // The attributes `shrm prefilter` writes for this state (the overlay's orders and rule).
  jobs::PrefilterJob job = job_;
  job.brdf = sent->brdf_spec;
  job.env.files = {s.map->env->path};
  job.env.rotate_ypr_deg = sent->lighting.rotate_ypr_deg;
  const jobs::PrefilterProvenance provenance{
      sent->brdf->spec(), {s.map->env->path, ""}, s.map->env->map.layout()};
  absl::StatusOr<ShrmData> d = ShrmDataFromCube(
      frame.result.cube, jobs::PrefilterFileAttributes(job, provenance, frame.result), "live",
      threads_, local);
  if (!d.ok()) {
    s.status = d.status();
    return s;
  }
  d->compute_ms = frame.compute_ms;
  s.shrm = std::make_shared<const ShrmData>(*std::move(d));
  s.has_local = local;
  s.convert_ms = MsSince(start);
  return s;
}

void LiveDriver::Present() {
  uint64_t after = 0;
  std::shared_ptr<const LiveFrame> last;  // the newest frame, converted again for mode 2
  while (true) {
    bool local = false, again = false;
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (stop_) return;
      local = need_local_;
      // Converted again only for the local SHRM (a missing split-sum set needs a new frame).
      again = last != nullptr && shown_ != nullptr && shown_->status.ok() && need_local_ &&
              !shown_->has_local;
    }
    // Polls so that the stop flag and SetNeedLocal are seen (the session cannot wake this thread).
    std::shared_ptr<const LiveFrame> frame =
        again ? nullptr : session_->WaitNewer(after, absl::Milliseconds(20));
    if (frame == nullptr && !again) continue;
    if (frame == nullptr) frame = last;
    after = frame->update;
    last = frame;
    auto shown = std::make_shared<const LiveShown>(Convert(*frame, local));
    {
      std::lock_guard<std::mutex> lock(mu_);
      shown_ = std::move(shown);
    }
    shown_changed_.notify_all();
  }
}

// --- Overlay --------------------------------------------------------------------------------

void RateMeter::Add(double t, uint64_t count) {
  samples_.emplace_back(t, count);
  // Keep one sample at or before the window's start, so the span covers the whole window.
  while (samples_.size() > 2 && samples_[1].first <= t - window_) samples_.pop_front();
}

double RateMeter::rate() const {
  if (samples_.size() < 2) return 0;
  const double span = samples_.back().first - samples_.front().first;
  if (!(span > 0)) return 0;
  return static_cast<double>(samples_.back().second - samples_.front().second) / span;
}

std::vector<std::string> LiveOverlayLines(const LiveSpec& spec, const LiveShown& shown,
                                          const LiveStats& stats, double live_fps,
                                          double render_fps) {
  std::vector<std::string> lines;
  lines.push_back(absl::StrCat("live ", LiveKindName(spec.kind), ": ", shown.lighting,
                               spec.step > 0 ? absl::StrFormat(" (step %g s)", spec.step) : ""));
  std::string stages = "ms:";
  for (const StageTiming& t : shown.timings)
    absl::StrAppendFormat(&stages, " %s %.1f", t.stage, t.ms);
  absl::StrAppendFormat(&stages, " | compute %.1f convert %.1f", shown.compute_ms,
                        shown.convert_ms);
  if (shown.brdf_reused || shown.lighting_reused) {
    absl::StrAppend(&stages, " (cached:", shown.brdf_reused ? " brdf" : "",
                    shown.lighting_reused ? " lighting" : "", ")");
  }
  lines.push_back(stages);
  lines.push_back(absl::StrFormat("live %.1f frames/s, render %.1f frames/s, dropped %d of %d",
                                  live_fps, render_fps, stats.dropped, stats.updates));
  if (shown.shrm != nullptr) {
    lines.push_back(absl::StrFormat("(F_B, P_B) = (%d, %d)", shown.shrm->f_b, shown.shrm->p_b));
  }
  return lines;
}

}  // namespace shrm::viewer
