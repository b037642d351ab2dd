// Mode 6's data and its CPU twin: the split-sum IBL an engine shades GGX with, from the same
// files `shrm ibl` writes (docs/ibl.md), so the viewer shows it beside the SHRM (modes 1, 2) and
// the ground truth (mode 5, difference view D):
//   B(N, V) ~ prefiltered(R, roughness) x (f0 A(N.V) + B(N.V)),
// prefiltered = the GGX chain of the Filament preset (N = V = R, N.L weighted; core/ibl), sampled
// trilinearly at R = 2 (N.V) N - V at Filament's level for the BRDF's roughness r = sqrt(alpha),
// lod = (levels - 1) r (2 - r) (light_indirect.fs; exactly level k at the preset's r_k); (A, B) the
// DFG integrals of the BRDF's alpha at N.V (IntegrateGgxDfg), a table of kDfgEntries entries over
// N.V sampled linearly (column i at N.V = (i + 0.5) / n, the DFG LUTs' axis). f0 is the BRDF's
// Schlick f0; the BRDF is core's GgxBrdf (ggx:alpha=A,f0=F).
#ifndef SHRM_VIEWER_SPLIT_SUM_SHADING_H_
#define SHRM_VIEWER_SPLIT_SUM_SHADING_H_

#include <array>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/ibl/split_sum.h"
#include "core/shrm/shrm_map.h"

namespace shrm::viewer {

inline constexpr int kSplitSumFaceSize = 128;  // the chain's base face (Filament preset)
inline constexpr int kDfgEntries = 64;

// The chain's options as a live session computes it (core/live/live_session.h): the Filament
// preset at kSplitSumFaceSize, the truncation tolerance of Create, the smallest irradiance cube
// (mode 6 does not use it).
ibl::SplitSumSetOptions ViewerSplitSumOptions();

class SplitSumShading {
 public:
  // The chain of `map` turned by `rotation` (the lighting's world rotation). InvalidArgument
  // naming the BRDF when it is not GGX; the chain's errors.
  [[nodiscard]] static absl::StatusOr<SplitSumShading> Create(
      const EnvMap& map, const Brdf& brdf, int threads = 1,
      const Mat3& rotation = Mat3::Identity());
  // From a chain computed elsewhere (a live frame's set, ViewerSplitSumOptions()).
  [[nodiscard]] static absl::StatusOr<SplitSumShading> FromChain(ibl::SpecularChain chain,
                                                                 const Brdf& brdf);

  const ibl::SpecularChain& chain() const { return chain_; }
  double lod() const { return lod_; }  // fractional level of the BRDF's roughness
  double roughness() const { return roughness_; }
  double f0() const { return f0_; }
  // (A, B) interleaved, kDfgEntries pairs.
  const std::vector<float>& dfg() const { return dfg_; }

  // The shading of a pixel (N, V world, unit).
  std::array<double, 3> Eval(const Vec3& n, const Vec3& v) const;

 private:
  SplitSumShading() = default;
  ibl::SpecularChain chain_;
  std::vector<ShrmCube> levels_;  // each level as a P = 0 global SHRM (ShrmEvalAt's filtering)
  double lod_ = 0, roughness_ = 0, f0_ = 0;
  std::vector<float> dfg_;
};

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_SPLIT_SUM_SHADING_H_
