// Explicit (tabular) forms computed from an SHRM cube (Ramamoorthi & Hanrahan, end of sec. 5.6.2
// and sec. 5.7.5), and Lambertian irradiance maps:
//   eq. 5.35: the reflection map of one global view V, B~(R) = sum_pq B^_pq(R) Y_pq(V) (cubes in
//             the normal variable: Y_pq of each texel's N = (R + V) / |R + V|);
//   Cabral et al.'s twelve views (V = icosahedron vertices) and a T_B x T_B set of views;
//   eq. 5.25: Kautz & McCool's 3D texture B(alpha, beta, theta_o) = sum_p B_p0 Y_p0(theta_o) from
//             the q = 0 terms of a LOCAL SHRM, at T_B slices theta_o,k = pi (k + 1/2) / T_B;
//   irradiance (Ramamoorthi & Hanrahan 2001): E_lm = A_l L_lm for l <= 2 (9 coefficients) and the
//             cube map E(N) = sum E_lm Y_lm(N).
// Every map holds the exact texel-centre values (no interpolation), so a map equals ShrmEval of
// its cube at the texel centres.
#ifndef SHRM_CORE_SHRM_SHRM_EXPLICIT_H_
#define SHRM_CORE_SHRM_SHRM_EXPLICIT_H_

#include <array>
#include <span>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/shrm/radiance_cube.h"
#include "core/shrm/shrm_map.h"

namespace shrm {

// Eq. 5.35 for one world view. Errors: empty or inconsistent cube, threads < 1.
absl::StatusOr<RadianceCube> ReflectionMapForView(const ShrmCube& cube, const Vec3& view,
                                                  int threads = 1);
// Adds the cube's lights (ShrmLightsRadiance with `brdf`, the BRDF it was made with) to `map`,
// the reflection map of `cube` for `view` (ReflectionMapForView): texel R gets them at the normal
// N = (R + V) / |R + V| that reflects V into R (the tangent R itself for kTangent cubes). Rows
// of faces split over `threads`. Nothing to do without lights.
void AddLightsToViewMap(const ShrmCube& cube, const Brdf& brdf, const Vec3& view, RadianceCube& map,
                        int threads = 1);
// Eq. 5.35 for many views at once. Global cubes run a blocked product per texel row (each row's
// coefficients transposed once, then sum_k Y_k(V) T_k[texel, channel] per view, float
// accumulation of the (P + 1)^2 terms); local cubes evaluate each texel in its own frame.
absl::StatusOr<std::vector<RadianceCube>> ReflectionMapsForViews(const ShrmCube& cube,
                                                                 std::span<const Vec3> views,
                                                                 int threads = 1);
// The same into caller-owned maps: `maps` is resized to views.size(); a map whose storage already
// has the right size is overwritten in place (no allocation: for repeated prefiltering, reusing
// the maps avoids the page faults of ~1.2 MB fresh memory per S_B = 128 map). Same errors.
absl::Status ReflectionMapsForViewsInto(const ShrmCube& cube, std::span<const Vec3> views,
                                        std::vector<RadianceCube>& maps, int threads = 1);
// The 12 vertices of the icosahedron (unit, world frame; two of them +-Y).
std::array<Vec3, 12> IcosahedronVertices();
// Cabral's 12 prerendered maps: ReflectionMapsForViews at IcosahedronVertices().
absl::StatusOr<std::vector<RadianceCube>> CabralMaps(const ShrmCube& cube, int threads = 1);
// The largest T_B of the view grid and the Kautz-McCool slices (a grid of 128 x 128 views is
// 16384 maps); larger is InvalidArgument.
inline constexpr int kMaxExplicitTb = 128;
// T_B x T_B world views on a lat-long grid (docs/conventions.md pixel directions of a T_B x T_B
// image: theta = pi (j + 1/2)/T_B, p = 2 pi ((i + 1/2)/T_B - 1/2)), index j * T_B + i.
std::vector<Vec3> ViewGrid(int t_b);
absl::StatusOr<std::vector<RadianceCube>> ViewGridMaps(const ShrmCube& cube, int t_b,
                                                       int threads = 1);
absl::Status ViewGridMapsInto(const ShrmCube& cube, int t_b, std::vector<RadianceCube>& maps,
                              int threads = 1);

// Eq. 5.25 slices; the cube must be local (kLocal). slices[k] at KautzMcCoolTheta(k, t_b).
double KautzMcCoolTheta(int k, int t_b);
absl::StatusOr<std::vector<RadianceCube>> KautzMcCoolSlices(const ShrmCube& local_cube, int t_b);

// Irradiance E_lm = A_l L_lm, l <= 2: 9 * channels values, out[ShIndex(l, m) * channels + c],
// from real L_lm of degree light_lmax >= 2. E is irradiance (W/m^2), not E / pi.
absl::StatusOr<std::vector<double>> IrradianceCoefficients(int light_lmax, int channels,
                                                           std::span<const double> light);
// Irradiance cube map indexed by the normal N: E(N) = sum_{l<=2} E_lm Y_lm(N).
absl::StatusOr<RadianceCube> IrradianceCube(std::span<const double> irradiance9, int channels,
                                            int face_size);

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_EXPLICIT_H_
