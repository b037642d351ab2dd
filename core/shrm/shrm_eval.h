// Evaluation of an SHRM cube (Ramamoorthi & Hanrahan, "Frequency Space Environment Map
// Rendering", sec. 5.4):
//   eq. 5.10 (local):  B(R, V) = sum_{p,q} B_pq(R) Y_pq(Rot^T V), Rot = Rz(beta) Ry(alpha);
//   eq. 5.11 (global): B(R, V) = sum_{p,q} B^_pq(R) Y_pq(V),
// V in the SH frame, Y_pq the real SH of core/sh/sh.h. (alpha, beta) are the SH angles
// (docs/conventions.md) of the texel direction R (the reflection vector; the tangent T for
// ReparamKind::kTangent, where only q = 0 terms exist), and Rot = Rz(beta) Ry(alpha) is the local
// frame of eqs. 5.10 and 5.14 (core/shrm/shrm_synthesis.h builds the cubes). Texels follow
// core/base/cubemap.h; the cube layout is core/shrm/shrm_map.h.
#ifndef SHRM_CORE_SHRM_SHRM_EVAL_H_
#define SHRM_CORE_SHRM_SHRM_EVAL_H_

#include <array>

#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/shrm/shrm_map.h"

namespace shrm {

// SH angles (alpha, beta) of a world direction (SH frame pole +Y): alpha in [0, pi],
// beta in (-pi, pi]. The local frame is Rot = Rz(beta) Ry(alpha) (SH frame).
void ShrmAnglesFromWorld(const Vec3& world_dir, double* alpha, double* beta);
// Rot = Rz(beta) Ry(alpha) as a matrix acting on SH-frame vectors.
Mat3 ShrmLocalFrame(double alpha, double beta);

// The world direction whose Y_pq a cube's view expansion takes at (R, V): V for
// ViewVariable::kView; for kNormal the normal N = (R + V) / |R + V| that reflects V into R
// (for V = -R, where every N on R's equator does, the one of the SH frame's azimuth 0).
Vec3 ShrmViewArgument(ViewVariable variable, const Vec3& index_dir, const Vec3& view);

// The four texels ShrmEvalAt interpolates for a texel-addressing direction on faces of size S:
// (face, x, y) and the bilinear weight of each (weights sum to 1; a tap beyond the face's outer
// texel centres is the adjacent face's texel holding the extrapolated centre direction).
struct CubeTap {
  int face = 0, x = 0, y = 0;
  double weight = 0;
};
std::array<CubeTap, 4> ShrmBilinearTaps(int face_size, const Vec3& index_dir);

// Evaluation of a cube (eq. 5.10 / 5.11) at the texel-addressing direction (R, or T for
// kTangent) and the view V (world). kNormal cubes take N = ShrmViewArgument(R, V) once and
// evaluate every texel at that N (the texels' B(R_t, V_t) with V_t the reflection of R_t about
// N: the normal, not the view, is held fixed across the texels, so that near V = -R the four
// texels agree on it). Bilinear interpolation between the four nearest texel
// centres of the face; beyond a face's outer texel centres the missing neighbours are taken from
// the adjacent face (the texel containing the extrapolated centre direction). Global cubes
// interpolate coefficients and evaluate Y_pq(V) once; local cubes evaluate each of the four
// texels in its own frame (Rot of that texel's centre) and interpolate the values, so the pole
// singularity of the local frame never mixes coefficients of different frames.
std::array<double, 3> ShrmEvalAt(const ShrmCube& cube, const Vec3& index_dir, const Vec3& view);
// The same from the normal: R = 2 (N.V) N - V for kReflection cubes (kNormal cubes take N
// itself as the argument); for kTangent cubes `n` is the tangent T. N and V world, unit.
std::array<double, 3> ShrmEval(const ShrmCube& cube, const Vec3& n, const Vec3& v);
// Evaluation at the texel-addressing direction with the argument of Y_pq given (V or N, world,
// unit; ShrmViewArgument).
std::array<double, 3> ShrmEvalArgument(const ShrmCube& cube, const Vec3& index_dir,
                                       const Vec3& argument);
// Exact texel value at the texel centre (no interpolation): B(R_texel, V) (kNormal: at
// N = ShrmViewArgument(R_texel, V)).
std::array<double, 3> ShrmTexelRadiance(const ShrmCube& cube, int face, int x, int y,
                                        const Vec3& view);

// The cube's lights at (N, V) (world, unit; `n` is the tangent T for kTangent cubes):
// sum_k weight_k rho-hat(N, V, dir_k) with rho-hat = brdf.Transfer, the BRDF the cube was made
// with (its shrm:brdf). Zero without lights.
std::array<double, 3> ShrmLightsRadiance(const ShrmCube& cube, const Brdf& brdf, const Vec3& n,
                                         const Vec3& v);
// The whole reflection of a cube: ShrmEval plus its lights.
std::array<double, 3> ShrmEvalWithLights(const ShrmCube& cube, const Brdf& brdf, const Vec3& n,
                                         const Vec3& v);

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_EVAL_H_
