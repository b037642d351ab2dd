// Ground truth for mode 5 and the difference view: the brute-force reflected radiance
//   B(N, V) = sum_k L_k rho-hat(N, V, w_k) dOmega_k      (SHRM paper sec. 5.6.3)
// for every covered pixel of a geometry buffer (per-pixel N or T, and V), over the samples of a
// downsampled environment (core/shrm/shrm_reference.h ReferenceIntegrator, no truncation cone).
//
// Progressive: worker threads compute the pixels on coarse-to-fine lattices (every 16th pixel in
// x and y, then 8th, ... 1), each value also filling its not-yet-computed block, so a usable image
// exists after ~1/256 of the work. The image is RGBA float, row 0 at the top; alpha = 1 for
// computed pixels, 0.5 for block estimates, 0 for background or not reached yet.
#ifndef SHRM_VIEWER_PROGRESSIVE_REFERENCE_H_
#define SHRM_VIEWER_PROGRESSIVE_REFERENCE_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/shrm/shrm_reference.h"
#include "viewer/cpu_images.h"

namespace shrm::viewer {

// Coarsest lattice step of the progression.
inline constexpr int kReferenceCoarsestStep = 16;

class ProgressiveReference {
 public:
  explicit ProgressiveReference(int threads) : threads_(threads < 1 ? 1 : threads) {}
  ~ProgressiveReference() { Cancel(); }
  ProgressiveReference(const ProgressiveReference&) = delete;
  ProgressiveReference& operator=(const ProgressiveReference&) = delete;

  // Cancels any running computation and starts one for `geometry` (the index direction is the
  // pixel's normal, or its tangent for kTangent BRDFs).
  void Start(GeometryBuffer geometry, std::shared_ptr<const ReferenceIntegrator> integrator,
             std::shared_ptr<const Brdf> brdf);
  // Stops the workers (returns once they have left; the image keeps what was computed).
  void Cancel();
  // Blocks until every pixel is computed (or the run was cancelled).
  void Wait();

  // When the image changed since the last call: copies it into *rgba (width * height * 4) and
  // returns true.
  bool Poll(std::vector<float>* rgba);
  // Fraction of covered pixels computed exactly, in [0, 1]; 1 when nothing to do.
  double progress() const;
  bool finished() const { return finished_.load(); }
  bool started() const { return started_; }
  int width() const { return geometry_.width; }
  int height() const { return geometry_.height; }
  const GeometryBuffer& geometry() const { return geometry_; }

 private:
  void Worker();
  void RunTask(size_t task);

  int threads_;
  bool started_ = false;
  GeometryBuffer geometry_;
  std::shared_ptr<const ReferenceIntegrator> integrator_;
  std::shared_ptr<const Brdf> brdf_;
  // Tasks: (step, row) pairs, coarse to fine.
  std::vector<std::pair<int, int>> tasks_;
  std::atomic<size_t> next_task_{0};
  std::atomic<bool> cancel_{false};
  std::atomic<bool> finished_{false};
  std::atomic<int> running_{0};
  std::atomic<int64_t> done_pixels_{0};
  int64_t total_pixels_ = 0;
  std::mutex mu_;
  std::vector<float> rgba_;  // guarded by mu_
  uint64_t version_ = 0;     // guarded by mu_
  uint64_t polled_ = ~uint64_t{0};
  std::vector<std::thread> workers_;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_PROGRESSIVE_REFERENCE_H_
