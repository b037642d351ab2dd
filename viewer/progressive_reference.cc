#include "viewer/progressive_reference.h"

#include <algorithm>

namespace shrm::viewer {

void ProgressiveReference::Start(GeometryBuffer geometry,
                                 std::shared_ptr<const ReferenceIntegrator> integrator,
                                 std::shared_ptr<const Brdf> brdf) {
  Cancel();
  geometry_ = std::move(geometry);
  integrator_ = std::move(integrator);
  brdf_ = std::move(brdf);
  tasks_.clear();
  for (int step = kReferenceCoarsestStep; step >= 1; step /= 2)
    for (int y = 0; y < geometry_.height; y += step) tasks_.push_back({step, y});
  total_pixels_ = 0;
  for (const PixelGeometry& p : geometry_.pixels) total_pixels_ += p.hit ? 1 : 0;
  {
    std::lock_guard<std::mutex> lock(mu_);
    rgba_.assign(static_cast<size_t>(geometry_.width) * geometry_.height * 4, 0.0f);
    ++version_;
  }
  next_task_ = 0;
  done_pixels_ = 0;
  cancel_ = false;
  finished_ = false;
  started_ = true;
  running_ = threads_;
  for (int t = 0; t < threads_; ++t) workers_.emplace_back([this] { Worker(); });
}

void ProgressiveReference::Cancel() {
  cancel_ = true;
  for (std::thread& t : workers_) t.join();
  workers_.clear();
}

void ProgressiveReference::Wait() {
  for (std::thread& t : workers_) t.join();
  workers_.clear();
}

bool ProgressiveReference::Poll(std::vector<float>* rgba) {
  std::lock_guard<std::mutex> lock(mu_);
  if (version_ == polled_) return false;
  polled_ = version_;
  *rgba = rgba_;
  return true;
}

double ProgressiveReference::progress() const {
  return total_pixels_ == 0 ? 1.0 : static_cast<double>(done_pixels_) / total_pixels_;
}

void ProgressiveReference::Worker() {
  for (;;) {
    if (cancel_) break;
    const size_t task = next_task_++;
    if (task >= tasks_.size()) break;
    RunTask(task);
  }
  if (--running_ == 0 && !cancel_) finished_ = true;
}

void ProgressiveReference::RunTask(size_t task) {
  const auto [step, y] = tasks_[task];
  const int w = geometry_.width, h = geometry_.height;
  const Brdf& brdf = *brdf_;
  const int bc = brdf.channels();
  const bool tangent = brdf.reparam() == ReparamKind::kTangent;
  TransferFunction transfer = [&brdf, bc](const Vec3& n, const Vec3& v, const Vec3& wi, int c) {
    return brdf.Transfer(n, v, wi, bc == 1 ? 0 : c);
  };
  ReferenceOptions options;
  options.grey = bc == 1;
  struct Value {
    int x;
    std::array<double, 3> rgb;
  };
  std::vector<Value> values;
  for (int x = 0; x < w; x += step) {
    // Computed on a coarser lattice already.
    if (step < kReferenceCoarsestStep && x % (2 * step) == 0 && y % (2 * step) == 0) continue;
    const PixelGeometry& p = geometry_.at(x, y);
    if (!p.hit) continue;
    if (cancel_) return;
    values.push_back(
        {x, integrator_->Radiance(transfer, tangent ? p.tangent : p.normal, p.view, options)});
  }
  std::lock_guard<std::mutex> lock(mu_);
  for (const Value& v : values) {
    for (int by = y; by < std::min(h, y + step); ++by)
      for (int bx = v.x; bx < std::min(w, v.x + step); ++bx) {
        float* px = &rgba_[(static_cast<size_t>(by) * w + bx) * 4];
        const bool self = bx == v.x && by == y;
        if (!geometry_.at(bx, by).hit || (!self && px[3] == 1.0f)) continue;
        for (int c = 0; c < 3; ++c) px[c] = static_cast<float>(v.rgb[c]);
        px[3] = self ? 1.0f : 0.5f;
      }
  }
  done_pixels_ += static_cast<int64_t>(values.size());
  ++version_;
}

}  // namespace shrm::viewer
