#include "core/shrm/shrm_eval.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <vector>

#include "core/base/cubemap.h"
#include "core/sh/sh.h"

namespace shrm {

void ShrmAnglesFromWorld(const Vec3& world_dir, double* alpha, double* beta) {
  const Vec3 s = ShFrameFromWorld(world_dir);
  *alpha = std::atan2(std::hypot(s.x, s.y), s.z);
  *beta = std::atan2(s.y, s.x);
}

Mat3 ShrmLocalFrame(double alpha, double beta) { return RotationZ(beta) * RotationY(alpha); }

Vec3 ShrmViewArgument(ViewVariable variable, const Vec3& index_dir, const Vec3& view) {
  if (variable == ViewVariable::kView) return view;
  const Vec3 h = index_dir + view;
  const double len = h.Norm();
  // |R + V| = 2 N.V: below 1e-12 the direction of h is rounding.
  if (len > 1e-12) return h * (1.0 / len);
  double alpha, beta;
  ShrmAnglesFromWorld(index_dir, &alpha, &beta);
  return WorldFromShFrame(ShrmLocalFrame(alpha, beta) * Vec3{1, 0, 0});
}

namespace {

// Real SH coefficients of one texel in its local frame evaluated at the world view.
double DotSh(std::span<const double> y, const float* coeffs, int count, int channels, int c) {
  double s = 0;
  for (int k = 0; k < count; ++k) s += y[k] * coeffs[static_cast<size_t>(k) * channels + c];
  return s;
}

// out[c] += weight x DotSh(y, coeffs, count, channels, c) for the first min(channels, 3)
// channels: with three or more, the three sums run side by side, each over k in order (one chain
// at a time waited on every addition's latency: 4 x 625 x 3 of them per ShrmEval at P = 24).
// The compiler may fuse each product and sum (as it does here for -march=native builds), which
// moves a value by an ulp or so from the channel-at-a-time loop it replaced.
void AddDotSh(std::span<const double> y, const float* coeffs, int count, int channels,
              double weight, std::array<double, 3>& out) {
  if (channels < 3) {
    for (int c = 0; c < channels; ++c) out[c] += weight * DotSh(y, coeffs, count, channels, c);
    return;
  }
  double s0 = 0, s1 = 0, s2 = 0;
  for (int k = 0; k < count; ++k) {
    const float* v = coeffs + static_cast<size_t>(k) * channels;
    s0 += y[k] * v[0];
    s1 += y[k] * v[1];
    s2 += y[k] * v[2];
  }
  out[0] += weight * s0;
  out[1] += weight * s1;
  out[2] += weight * s2;
}

// Value of texel (face, x, y) of `cube` for the argument of Y_pq (V or N, SH frame), channel-wise
// into out.
void TexelValue(const ShrmCube& cube, int face, int x, int y, const Vec3& view_sh,
                std::span<const double> y_global, double weight, std::array<double, 3>& out) {
  const int n = cube.coeff_count();
  const float* coeffs = cube.data.data() + cube.Index(face, x, y, 0, 0);
  if (cube.kind == ShrmKind::kGlobal) {
    AddDotSh(y_global, coeffs, n, cube.channels, weight, out);
    return;
  }
  double alpha, beta;
  ShrmAnglesFromWorld(CubeTexelDirection(face, x, y, cube.face_size), &alpha, &beta);
  const Vec3 w = ShrmLocalFrame(alpha, beta).Transposed() * view_sh;
  double ybuf[256];
  std::vector<double> yvec;
  std::span<double> ys;
  if (n <= 256) {
    ys = std::span<double>(ybuf, n);
  } else {
    yvec.resize(n);
    ys = yvec;
  }
  EvalSh(cube.pmax, w, ys);
  AddDotSh(ys, coeffs, n, cube.channels, weight, out);
}

// Cubes with a Fresnel table: the expansion times w(N.V) (brdf_coefficients.h).
void ScaleByFresnel(const ShrmCube& cube, const Vec3& index_dir, const Vec3& argument,
                    std::array<double, 3>& out) {
  if (cube.fresnel.empty()) return;
  const double cos_nv = FresnelCosine(cube.view, index_dir, argument);
  for (int c = 0; c < std::min(cube.channels, 3); ++c) out[c] *= ShrmFresnel(cube, cos_nv, c);
}

// Texel of `face` at integer coordinates that may lie one step outside the face: the texel of the
// adjacent face containing the extrapolated centre direction.
void ResolveTexel(int face, int x, int y, int size, int* of, int* ox, int* oy) {
  if (x >= 0 && x < size && y >= 0 && y < size) {
    *of = face;
    *ox = x;
    *oy = y;
    return;
  }
  const Vec3 d = CubeFaceDirection(face, (x + 0.5) / size, (y + 0.5) / size);
  double s, t;
  CubeFaceCoordinates(d, of, &s, &t);
  *ox = std::clamp(static_cast<int>(std::floor(s * size)), 0, size - 1);
  *oy = std::clamp(static_cast<int>(std::floor(t * size)), 0, size - 1);
}

}  // namespace

std::array<CubeTap, 4> ShrmBilinearTaps(int face_size, const Vec3& index_dir) {
  const int size = face_size;
  int face;
  double s, t;
  CubeFaceCoordinates(index_dir, &face, &s, &t);
  const double x = s * size - 0.5, y = t * size - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  std::array<CubeTap, 4> taps;
  for (int dy = 0; dy < 2; ++dy)
    for (int dx = 0; dx < 2; ++dx) {
      CubeTap& tap = taps[dy * 2 + dx];
      tap.weight = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
      ResolveTexel(face, x0 + dx, y0 + dy, size, &tap.face, &tap.x, &tap.y);
    }
  return taps;
}

std::array<double, 3> ShrmEvalAt(const ShrmCube& cube, const Vec3& index_dir, const Vec3& view) {
  return ShrmEvalArgument(cube, index_dir, ShrmViewArgument(cube.view, index_dir, view));
}

std::array<double, 3> ShrmEvalArgument(const ShrmCube& cube, const Vec3& index_dir,
                                       const Vec3& argument) {
  std::array<double, 3> out{0, 0, 0};
  if (cube.face_size < 1 || cube.data.size() != cube.size()) return out;
  const Vec3 view_sh = ShFrameFromWorld(argument);
  std::vector<double> y_global;
  if (cube.kind == ShrmKind::kGlobal) y_global = EvalSh(cube.pmax, view_sh);
  for (const CubeTap& tap : ShrmBilinearTaps(cube.face_size, index_dir)) {
    if (tap.weight == 0) continue;
    TexelValue(cube, tap.face, tap.x, tap.y, view_sh, y_global, tap.weight, out);
  }
  ScaleByFresnel(cube, index_dir, argument, out);
  return out;
}

std::array<double, 3> ShrmEval(const ShrmCube& cube, const Vec3& n, const Vec3& v) {
  if (cube.index == ReparamKind::kTangent) return ShrmEvalAt(cube, n, v);
  const Vec3 r = n * (2 * n.Dot(v)) - v;
  if (cube.view == ViewVariable::kNormal) return ShrmEvalArgument(cube, r, n);
  return ShrmEvalAt(cube, r, v);
}

std::array<double, 3> ShrmTexelRadiance(const ShrmCube& cube, int face, int x, int y,
                                        const Vec3& view) {
  std::array<double, 3> out{0, 0, 0};
  const Vec3 texel = CubeTexelDirection(face, x, y, cube.face_size);
  const Vec3 argument = ShrmViewArgument(cube.view, texel, view);
  const Vec3 view_sh = ShFrameFromWorld(argument);
  std::vector<double> y_global;
  if (cube.kind == ShrmKind::kGlobal) y_global = EvalSh(cube.pmax, view_sh);
  TexelValue(cube, face, x, y, view_sh, y_global, 1.0, out);
  ScaleByFresnel(cube, texel, argument, out);
  return out;
}

std::array<double, 3> ShrmLightsRadiance(const ShrmCube& cube, const Brdf& brdf, const Vec3& n,
                                         const Vec3& v) {
  std::array<double, 3> out{0, 0, 0};
  const int channels = brdf.channels();
  for (const ShrmLight& light : cube.lights) {
    const Vec3 w{light.dir[0], light.dir[1], light.dir[2]};
    if (channels == 1) {
      const double t = brdf.Transfer(n, v, w, 0);
      for (int c = 0; c < 3; ++c) out[c] += light.weight[c] * t;
    } else {
      for (int c = 0; c < 3; ++c)
        out[c] += light.weight[c] * brdf.Transfer(n, v, w, std::min(c, channels - 1));
    }
  }
  return out;
}

std::array<double, 3> ShrmEvalWithLights(const ShrmCube& cube, const Brdf& brdf, const Vec3& n,
                                         const Vec3& v) {
  std::array<double, 3> out = ShrmEval(cube, n, v);
  if (cube.lights.empty()) return out;
  const std::array<double, 3> lit = ShrmLightsRadiance(cube, brdf, n, v);
  for (int c = 0; c < 3; ++c) out[c] += lit[c];
  return out;
}

}  // namespace shrm
