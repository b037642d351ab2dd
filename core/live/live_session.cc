#include "core/live/live_session.h"

#include <chrono>
#include <cmath>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_explicit.h"

namespace shrm {

absl::StatusOr<std::unique_ptr<LiveSession>> LiveSession::Create(
    const PrefilterOptions& options, std::function<void(uint64_t)> before_frame,
    std::optional<ibl::SplitSumSetOptions> split_sum) {
  if (options.tolerance > 0) {
    return absl::InvalidArgumentError(
        "a live session uses the paper's epsilon rule or explicit orders (the tolerance rule "
        "takes seconds per frame)");
  }
  if (options.verify > 0) {
    return absl::InvalidArgumentError("a live session does not check its frames (verify)");
  }
  SHRM_RETURN_IF_ERROR(ValidatePrefilterOptions(options));
  if (split_sum) {
    const ibl::MipChain& chain = split_sum->chain;
    if (chain.levels() < 1 || chain.roughness.size() != chain.face_size.size()) {
      return absl::InvalidArgumentError("live split-sum set: the mip chain has no levels");
    }
    if (!(split_sum->tolerance > 0 && split_sum->tolerance < 1)) {
      return absl::InvalidArgumentError(absl::StrCat("live split-sum set: tolerance ",
                                                     split_sum->tolerance, " must be in (0, 1)"));
    }
    const double one[] = {1.0};
    SHRM_RETURN_IF_ERROR(
        ibl::MakeMipChain(ibl::RoughnessPreset::kExplicit, split_sum->irradiance_size, 1, one)
            .status());
  }
  return std::unique_ptr<LiveSession>(
      new LiveSession(options, std::move(before_frame), std::move(split_sum)));
}

LiveSession::LiveSession(const PrefilterOptions& options,
                         std::function<void(uint64_t)> before_frame,
                         std::optional<ibl::SplitSumSetOptions> split_sum)
    : options_(options), before_frame_(std::move(before_frame)), split_sum_(std::move(split_sum)) {
  pending_.rotation = options.rotation;
  worker_ = std::thread([this] { Run(); });
}

LiveSession::~LiveSession() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  changed_.notify_all();
  worker_.join();
}

uint64_t LiveSession::Update(const std::function<void(State*)>& change,
                             std::shared_ptr<const void> tag) {
  uint64_t u;
  {
    std::lock_guard<std::mutex> lock(mu_);
    change(&pending_);
    if (tag) pending_.tag = std::move(tag);
    u = ++latest_update_;
    ++stats_.updates;
  }
  changed_.notify_all();
  return u;
}

uint64_t LiveSession::SetMap(std::shared_ptr<const EnvMap> map, std::optional<Mat3> rotation,
                             std::shared_ptr<const void> tag) {
  return Update(
      [&](State* s) {
        s->map = std::move(map);
        s->coefficients.reset();
        if (rotation) s->rotation = *rotation;
      },
      std::move(tag));
}

uint64_t LiveSession::SetCoefficients(std::shared_ptr<const std::vector<double>> rgb, int lmax,
                                      std::array<double, 3> energy,
                                      std::shared_ptr<const void> tag) {
  return Update(
      [&](State* s) {
        s->coefficients = std::move(rgb);
        s->coefficients_lmax = lmax;
        s->energy = energy;
        s->map.reset();
      },
      std::move(tag));
}

uint64_t LiveSession::SetRotation(const Mat3& rotation, std::shared_ptr<const void> tag) {
  return Update([&](State* s) { s->rotation = rotation; }, std::move(tag));
}

uint64_t LiveSession::SetSplitSum(bool on, std::shared_ptr<const void> tag) {
  return Update([&](State* s) { s->split_sum = on; }, std::move(tag));
}

uint64_t LiveSession::SetView(std::optional<Vec3> view, std::shared_ptr<const void> tag) {
  return Update([&](State* s) { s->view = view; }, std::move(tag));
}

bool LiveSession::State::SameLighting(const State& o) const {
  return map == o.map && coefficients == o.coefficients &&
         coefficients_lmax == o.coefficients_lmax && energy == o.energy &&
         rotation.m == o.rotation.m;
}

bool LiveSession::State::SameShrm(const State& o) const {
  return SameLighting(o) && brdf == o.brdf;
}

uint64_t LiveSession::SetBrdf(std::shared_ptr<const Brdf> brdf, std::shared_ptr<const void> tag) {
  return Update([&](State* s) { s->brdf = std::move(brdf); }, std::move(tag));
}

absl::StatusOr<std::shared_ptr<const LiveFrame>> LiveSession::WaitFor(
    uint64_t update, absl::Duration timeout) const {
  std::unique_lock<std::mutex> lock(mu_);
  if (update > latest_update_) {
    return absl::InvalidArgumentError(
        absl::StrCat("update ", update, " was never made (the last is ", latest_update_, ")"));
  }
  const bool done = changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                                      [&] { return computed_update_ >= update; });
  if (!done) {
    return absl::DeadlineExceededError(
        absl::StrCat("no frame of update ", update, " within ", absl::FormatDuration(timeout)));
  }
  return latest_frame_;
}

std::shared_ptr<const LiveFrame> LiveSession::WaitNewer(uint64_t after,
                                                        absl::Duration timeout) const {
  std::unique_lock<std::mutex> lock(mu_);
  changed_.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                    [&] { return latest_frame_ != nullptr && latest_frame_->update > after; });
  return latest_frame_ != nullptr && latest_frame_->update > after ? latest_frame_ : nullptr;
}

std::shared_ptr<const LiveFrame> LiveSession::Latest() const {
  std::lock_guard<std::mutex> lock(mu_);
  return latest_frame_;
}

LiveStats LiveSession::Stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stats_;
}

std::vector<float> LiveSession::CubePool::Take() {
  std::lock_guard<std::mutex> lock(mu_);
  if (free_.empty()) return {};
  std::vector<float> data = std::move(free_.back());
  free_.pop_back();
  return data;
}

void LiveSession::CubePool::Put(std::vector<float> data) {
  if (data.empty()) return;
  std::lock_guard<std::mutex> lock(mu_);
  if (free_.size() < kPooledCubes) free_.push_back(std::move(data));
}

void LiveSession::Run() {
  std::unique_lock<std::mutex> lock(mu_);
  for (;;) {
    changed_.wait(lock, [&] { return stop_ || latest_update_ > computed_update_; });
    if (stop_) return;
    if (before_frame_) {
      const uint64_t next = latest_update_;
      lock.unlock();
      before_frame_(next);
      lock.lock();
      if (stop_) return;
    }
    const uint64_t update = latest_update_;
    const State state = pending_;
    const std::shared_ptr<const LiveFrame> previous = latest_frame_;
    stats_.dropped += update - computed_update_ - 1;
    lock.unlock();
    // The frame's cube storage goes back to the pool when the last holder lets it go.
    std::shared_ptr<LiveFrame> frame(
        new LiveFrame(Compute(state, previous.get(), &computed_state_)),
        [pool = std::weak_ptr<CubePool>(cube_pool_)](LiveFrame* f) {
          if (auto p = pool.lock(); p != nullptr) p->Put(std::move(f->result.cube.data));
          delete f;
        });
    frame->update = update;
    frame->tag = state.tag;
    computed_state_ = state;
    lock.lock();
    computed_update_ = update;
    ++stats_.frames;
    latest_frame_ = std::move(frame);
    changed_.notify_all();
  }
}

absl::StatusOr<std::shared_ptr<const BrdfStage>> LiveSession::BrdfStageFor(const Brdf& brdf,
                                                                           bool* reused) {
  const std::string spec = brdf.spec();
  for (auto it = brdf_cache_.begin(); it != brdf_cache_.end(); ++it) {
    if (it->spec != spec) continue;
    brdf_cache_.splice(brdf_cache_.begin(), brdf_cache_, it);  // most recent first
    *reused = true;
    return brdf_cache_.front().stage;
  }
  *reused = false;
  SHRM_ASSIGN_OR_RETURN(BrdfStage stage, ComputeBrdfStage(brdf, options_));
  brdf_cache_.push_front({spec, std::make_shared<const BrdfStage>(std::move(stage))});
  if (brdf_cache_.size() > kLiveBrdfCache) brdf_cache_.pop_back();
  return brdf_cache_.front().stage;
}

LiveFrame LiveSession::Compute(const State& state, const LiveFrame* previous,
                               const State* previous_state) {
  LiveFrame f;
  const auto start = std::chrono::steady_clock::now();
  const PrefilterProgress no_progress;  // StageClock keeps a reference to it
  auto view_map = [&]() -> absl::Status {
    f.view = state.view;
    if (!state.view) return absl::OkStatus();
    const double norm = state.view->Norm();
    if (!(norm > 0 && std::isfinite(norm))) {
      return absl::InvalidArgumentError("the view must be a finite nonzero direction");
    }
    f.view = state.view->Normalized();
    StageClock clock(&f.result.timings, no_progress);
    SHRM_RETURN_IF_ERROR(clock.Begin("view"));
    SHRM_ASSIGN_OR_RETURN(f.view_map,
                          ReflectionMapForView(f.result.cube, *f.view, options_.threads));
    clock.End();
    return absl::OkStatus();
  };
  // Only the view or the split-sum flag changed: the previous frame's cube (a frame with neither
  // an SHRM nor a set asked for takes the path below, whose error says why).
  if (previous != nullptr && previous->status.ok() && state.SameShrm(*previous_state) &&
      (previous->has_shrm || (split_sum_ && state.split_sum))) {
    f.shrm_reused = f.brdf_reused = f.lighting_reused = true;
    f.has_shrm = previous->has_shrm;
    f.result.analysis = previous->result.analysis;
    f.result.cube = previous->result.cube;
    f.status = split_sum_ && state.split_sum ? ComputeSplitSum(state, previous, previous_state, f)
                                             : absl::OkStatus();
    if (f.status.ok() && f.has_shrm) f.status = view_map();
    f.compute_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return f;
  }
  const bool lit = state.map || state.coefficients;
  const bool split_sum = split_sum_ && state.split_sum;
  auto run = [&]() -> absl::Status {
    if (!state.brdf && !split_sum) return absl::FailedPreconditionError("no BRDF yet (SetBrdf)");
    if (!lit) return absl::FailedPreconditionError("no lighting yet (SetMap or SetCoefficients)");
    if (split_sum) SHRM_RETURN_IF_ERROR(ComputeSplitSum(state, previous, previous_state, f));
    if (!state.brdf) return absl::OkStatus();  // the split-sum set alone
    StageClock clock(&f.result.timings, no_progress);
    SHRM_RETURN_IF_ERROR(clock.Begin("brdf"));
    SHRM_ASSIGN_OR_RETURN(std::shared_ptr<const BrdfStage> brdf,
                          BrdfStageFor(*state.brdf, &f.brdf_reused));
    clock.End();
    const int lmax = brdf->f_rho;
    SHRM_RETURN_IF_ERROR(clock.Begin("lighting"));
    LightingStage lighting;
    if (state.map) {
      if (lighting_map_ != state.map) {  // the cache holds one map (its pointer keeps it alive)
        lighting_unrotated_.clear();
        lighting_map_ = state.map;
        lighting_energy_ = LightingEnergy(*state.map);
      }
      auto it = lighting_unrotated_.find(lmax);
      f.lighting_reused = it != lighting_unrotated_.end();
      if (!f.lighting_reused) {
        SHRM_ASSIGN_OR_RETURN(
            std::vector<double> light,
            LightingCoefficients(*state.map, lmax, Mat3::Identity(), options_.threads));
        it = lighting_unrotated_.emplace(lmax, std::move(light)).first;
      }
      lighting.light = it->second;
      lighting.energy = lighting_energy_;
    } else {
      if (state.coefficients_lmax < lmax ||
          state.coefficients->size() < ShCount(lmax) * static_cast<size_t>(3)) {
        return absl::InvalidArgumentError(absl::StrCat("the lighting coefficients go to degree ",
                                                       state.coefficients_lmax,
                                                       "; the BRDF's F_rho is ", lmax));
      }
      f.lighting_reused = true;
      lighting.light.assign(state.coefficients->begin(),
                            state.coefficients->begin() + ShCount(lmax) * 3);
      lighting.energy = state.energy;
    }
    if (!state.rotation.IsIdentity()) {
      SHRM_RETURN_IF_ERROR(RotateLighting(lmax, state.rotation, lighting.light));
    }
    clock.End();
    shrm_scratch_.cube = cube_pool_->Take();
    SHRM_RETURN_IF_ERROR(FinishPrefilter(*brdf, lighting, options_, nullptr, &f.result,
                                         options_.max_cube_values, options_.admit_cube,
                                         &shrm_scratch_));
    f.has_shrm = true;
    return view_map();
  };
  f.status = run();
  if (!f.status.ok()) f.has_shrm = false;
  f.incomplete = (!state.brdf && !split_sum) || !lit;
  f.compute_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return f;
}

absl::Status LiveSession::ComputeSplitSum(const State& state, const LiveFrame* previous,
                                          const State* previous_state, LiveFrame& f) {
  if (!state.map) {
    return absl::InvalidArgumentError(
        "the split-sum set needs a map (its base level is the map itself resampled); the "
        "lighting was given as coefficients");
  }
  if (previous != nullptr && previous->split_sum != nullptr && previous_state != nullptr &&
      state.SameLighting(*previous_state)) {
    f.split_sum = previous->split_sum;
    f.split_sum_reused = true;
    return absl::OkStatus();
  }
  const PrefilterProgress no_progress;  // StageClock keeps a reference to it
  StageClock clock(&f.result.timings, no_progress);
  SHRM_RETURN_IF_ERROR(clock.Begin("split-sum lighting"));
  if (split_sum_map_ != state.map) {  // one map (its pointer keeps it alive)
    split_sum_unrotated_.clear();
    split_sum_first_failed_ = false;
    split_sum_map_ = state.map;
    split_sum_split_ = ibl::SplitLightPeaks(*state.map);
    split_sum_moments_ = ibl::SplitLightMoments(
        split_sum_split_, split_sum_split_.rest ? *split_sum_split_.rest : *state.map);
  }
  // What ibl::ComputeSplitSumLight transforms: the map less its peaks.
  const EnvMap& source = split_sum_split_.rest ? *split_sum_split_.rest : *state.map;
  // The degrees `shrm ibl` tries (ibl::ComputeSplitSumLight), each map's coefficients kept per
  // degree: the first try when it suffices, else what the set's lobes need.
  const ibl::SplitSumLightTry tries = ibl::SplitSumLightTries(
      source, state.rotation, *split_sum_, split_sum_moments_, split_sum_split_.rest.has_value());
  ibl::SpecularLight light;
  for (const int degree : {tries.first, tries.full}) {
    if (degree != tries.full && (degree <= 0 || split_sum_first_failed_)) continue;
    auto it = split_sum_unrotated_.find(degree);
    if (it == split_sum_unrotated_.end()) {
      SHRM_ASSIGN_OR_RETURN(std::vector<double> unrotated,
                            LightingCoefficients(source, degree, Mat3::Identity(), options_.threads,
                                                 ShtQuadrature::kPixelSum));
      it = split_sum_unrotated_
               .emplace(degree, std::make_shared<const std::vector<double>>(std::move(unrotated)))
               .first;
    }
    SHRM_ASSIGN_OR_RETURN(
        light, ibl::SpecularLightFromCoefficients(
                   degree, state.rotation, *it->second,
                   ibl::SpecularLightDegree(source, state.rotation, 0), split_sum_moments_.total));
    light.peaks = ibl::RotatedPeaks(split_sum_split_.peaks, state.rotation);
    if (degree == tries.full || ibl::SplitSumLightSuffices(light, *split_sum_)) break;
    split_sum_first_failed_ = true;
  }
  clock.End();
  SHRM_ASSIGN_OR_RETURN(ibl::SplitSumSet set,
                        ibl::PrefilterSplitSumSet(*state.map, light, *split_sum_, options_.threads,
                                                  nullptr, &f.result.timings, &split_sum_scratch_));
  f.split_sum = std::make_shared<const ibl::SplitSumSet>(std::move(set));
  return absl::OkStatus();
}

}  // namespace shrm
