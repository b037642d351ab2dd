// The Spherical Harmonic Reflection Map (SHRM paper sec. 5.4, eqs. 5.10-5.14) resampled onto
// cube faces: every texel, addressed by the reflection direction R (or the tangent T for
// Kajiya-Kay), holds an order-P real-SH expansion of the view dependence.
//
//   local  (eq. 5.10): B(R, V) = sum_{p,q} B_pq(R) Y_pq(w_o'), w_o' = Rot(R)^T V in the SH frame,
//                      Rot(R) = Rz(beta) Ry(alpha), (alpha, beta) the SH angles of R;
//   global (eq. 5.11): B(R, V) = sum_{p,q} B^_pq(R) Y_pq(V), V in the SH frame.
// With ViewVariable::kNormal (brdf_coefficients.h) the argument is the normal N = (R + V) / |R + V|
// instead of V in both forms: Y_pq(Rot(R)^T N) and Y_pq(N) (N.R >= 0: the upper hemisphere of
// R's frame, the only part the coefficients fit).
//
// Coefficients are real SH (docs/conventions.md), converted from the paper's complex B_pq with
// ComplexToReal (the view-dependent function is real). Texels follow core/base/cubemap.h.
#ifndef SHRM_CORE_SHRM_SHRM_MAP_H_
#define SHRM_CORE_SHRM_SHRM_MAP_H_

#include <array>
#include <cstddef>
#include <vector>

#include "core/brdf/brdf_coefficients.h"
#include "core/sh/sh.h"

namespace shrm {

enum class ShrmKind { kLocal, kGlobal };

// A directional light shipped beside the expansion (PrefilterOptions::peak_lights): one of the
// map's brightest pixels split off (core/envmap/light_split.h), its world direction (after the
// lighting's rotation) and its radiance times the pixel's solid angle, per channel. A cube with
// lights holds the rest of the map's reflection; the whole is
//   B(N, V) = the expansion + sum_k weight_k rho-hat(N, V, dir_k)    (ShrmLightsRadiance),
// the sum the brute-force reference makes over those pixels: nothing is approximated in it.
struct ShrmLight {
  std::array<float, 3> dir{};
  std::array<float, 3> weight{};
};

struct ShrmCube {
  ShrmKind kind = ShrmKind::kGlobal;
  ReparamKind index = ReparamKind::kReflection;  // what addresses the texels: R or T
  ViewVariable view = ViewVariable::kView;       // the argument of Y_pq: V or N
  int face_size = 0;                             // S_B
  int pmax = 0;  // P_B: ShCount(pmax) coefficients per texel and channel
  int channels = 3;
  // data[Index(face, x, y, k, c)], k = ShIndex(p, q).
  std::vector<float> data;
  // The Fresnel table (brdf_coefficients.h) the expansion is multiplied by at N.V
  // (FresnelCosine: N.R for kNormal, |R + V| / 2 for kView), (kFresnelIntervals + 1) x 1 or x
  // channels values; empty: no factor.
  std::vector<float> fresnel;
  // Lights summed directly (empty: the expansion is the whole reflection).
  std::vector<ShrmLight> lights;

  int coeff_count() const { return ShCount(pmax); }
  size_t Index(int face, int x, int y, int k, int c) const {
    return ((((static_cast<size_t>(face) * face_size + y) * face_size + x) * coeff_count() + k) *
            channels) +
           c;
  }
  size_t size() const {
    return static_cast<size_t>(6) * face_size * face_size * coeff_count() * channels;
  }
};

// The Fresnel factor of `cube` at N.V = cos_n for channel c (1 without a table).
inline double ShrmFresnel(const ShrmCube& cube, double cos_n, int c) {
  return FresnelFactor(cube.fresnel, cos_n, c);
}

}  // namespace shrm

#endif  // SHRM_CORE_SHRM_SHRM_MAP_H_
