// Mode 1's per-frame work: the reflection map of ONE view from a global SHRM (SHRM paper eq. 5.35),
//   B~(R) = sum_{p,q} B^_pq(R) Y_pq(V),   V the current view direction in the SH frame,
// summed on the CPU into a plain RGB cube map that the GPU then samples by the reflection vector.
//
// Fast twin of core's ReflectionMapForView (core/shrm/shrm_explicit.h), which the tests compare
// it with: the coefficients are stored once as (P + 1)^2 planes (plane k holds coefficient k of
// every texel and channel, in RadianceCube order), so one frame is (P + 1)^2 float axpy passes
// over cache-sized chunks of the output: 6 S^2 3 (P + 1)^2 multiply-adds, e.g. 1.2 M for
// S = 64, P = 3 (docs/results.md "Viewer": about 0.2 ms on one core).
#ifndef SHRM_VIEWER_REFLECTION_SUM_H_
#define SHRM_VIEWER_REFLECTION_SUM_H_

#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/shrm/radiance_cube.h"
#include "core/shrm/shrm_map.h"

namespace shrm::viewer {

class GlobalReflectionSum {
 public:
  // Errors (InvalidArgument): a local cube, an empty or inconsistent cube.
  [[nodiscard]] static absl::StatusOr<GlobalReflectionSum> Create(const ShrmCube& global_cube);

  int face_size() const { return face_size_; }
  int pmax() const { return pmax_; }
  int channels() const { return channels_; }

  // Eq. 5.35 for the world view direction `view` (unit, towards the viewer) into *out (resized to
  // face_size() and channels() on first use; no allocation afterwards). threads > 1 splits the
  // texels (worth it from about S = 128).
  void Compute(const Vec3& view, RadianceCube* out, int threads = 1) const;

 private:
  GlobalReflectionSum() = default;
  int face_size_ = 0, pmax_ = 0, channels_ = 3;
  size_t plane_size_ = 0;      // 6 S^2 channels floats
  std::vector<float> planes_;  // planes_[k * plane_size_ + RadianceCube index]
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_REFLECTION_SUM_H_
