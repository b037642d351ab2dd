// Angular-domain reference for the SHRM (Ramamoorthi & Hanrahan sec. 5.6.3, Table 5.3: cost
// O(W S_L^2) per output pixel): the reflected radiance
//   B(N, V) = integral L(w) rho-hat(N, V, w) dw ~= sum over the map's samples L_k rho-hat dOmega_k,
// accumulated in double, where rho-hat is the world-frame transfer function (BRDF times the
// cosine, as reparameterized in docs/conventions.md "BRDF coefficients"). Optionally only the
// samples within a cone of half-angle theta* around the lobe axis are summed (the paper's
// truncation to the BRDF's angular width W; for the normalized Phong lobe eq. 5.30 gives
// cos theta* = eps^(1/(s+1)) for a fraction eps of the lobe's energy left out).
#ifndef SHRM_CORE_SHRM_SHRM_REFERENCE_H_
#define SHRM_CORE_SHRM_SHRM_REFERENCE_H_

#include <array>
#include <functional>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/shrm/radiance_cube.h"

namespace shrm {

// rho-hat(n, v, w) for channel c, all world directions (unit).
using TransferFunction = std::function<double(const Vec3& n, const Vec3& v, const Vec3& w, int c)>;

struct ReferenceOptions {
  enum class Axis { kReflection, kNormal };
  // Truncation cone: samples w with angle(w, axis) > cone_angle are skipped; cone_angle >= pi
  // sums every sample. axis = R = 2 (N.V) N - V (lobes) or N (cosine-weighted BRDFs).
  double cone_angle = kPi;
  Axis axis = Axis::kReflection;
  // Call the transfer function once per sample (c = 0) and use it for all channels.
  bool grey = false;
  int threads = 1;
};

// Half-angle of the cone that holds 1 - eps of the normalized Phong lobe's energy, eq. 5.30:
// acos(eps^(1/(s+1))).
double PhongConeAngle(double exponent, double eps);

// Brute force over every sample (no truncation), double accumulation.
std::array<double, 3> ReferenceRadiance(std::span<const EnvSample> samples,
                                        const TransferFunction& transfer, const Vec3& n,
                                        const Vec3& v);

// `shrm reference` and the service's Reference call: ReferenceRadiance for `brdf` (its channel 0
// for all three colours when it is grey) at (index = N, or T for tangent-indexed models, V) in an
// environment rotated by `rotation`, L'(w) = L(R^-1 w): the geometry is rotated by R^-1 instead
// of the samples.
std::array<double, 3> BrdfReferenceRadiance(std::span<const EnvSample> samples, const Brdf& brdf,
                                            const Mat3& rotation, const Vec3& index,
                                            const Vec3& view);

// Samples binned by direction (cube faces of 8 x 8 buckets) so a truncated query visits only the
// buckets that can intersect its cone: O(W S_L^2 + 384) per output value.
class ReferenceIntegrator {
 public:
  // Errors: no samples, non-finite or non-unit directions.
  static absl::StatusOr<ReferenceIntegrator> Create(std::span<const EnvSample> samples);

  size_t sample_count() const { return dir_x_.size(); }
  std::array<double, 3> Radiance(const TransferFunction& transfer, const Vec3& n, const Vec3& v,
                                 const ReferenceOptions& options = {}) const;
  // The reflection map for one view V (world): texel R -> N = normalize(R + V), value B(N, V);
  // texels with |R + V| < 1e-9 (R = -V) are 0. Multi-threaded over texel rows.
  // If texel_stride > 1 only every texel_stride-th texel (in x and y) is computed (timing
  // subsets; the others stay 0). Errors: face_size < 1, threads < 1, texel_stride < 1.
  absl::StatusOr<RadianceCube> ReflectionMap(const TransferFunction& transfer, const Vec3& view,
                                             int face_size, const ReferenceOptions& options = {},
                                             int texel_stride = 1) const;
  // Number of samples summed by the last queries is not tracked; this gives the count one query
  // would visit (for reporting the effective W).
  size_t VisitedSamples(const Vec3& axis, double cone_angle) const;

 private:
  ReferenceIntegrator() = default;
  // Sum over buckets whose cap may intersect the cone; cos_limits[b] = cos(min(pi, cone +
  // radius_b)) (or -2 when every bucket is visited).
  std::array<double, 3> Sum(const TransferFunction& transfer, const Vec3& n, const Vec3& v,
                            const Vec3& axis, double cos_cone, bool grey,
                            std::span<const double> cos_limits) const;
  std::vector<double> CosLimits(double cone_angle) const;

  std::vector<double> dir_x_, dir_y_, dir_z_;
  std::vector<double> rad_;        // L_c dOmega, 3 per sample
  std::vector<int> bucket_begin_;  // bucket b holds samples [begin[b], begin[b + 1])
  std::vector<Vec3> bucket_centre_;
  std::vector<double> bucket_radius_;  // max angle centre -> sample
};

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_REFERENCE_H_
