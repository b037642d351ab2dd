#include "viewer/cpu_images.h"

#include <cmath>

#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm::viewer {

GeometryBuffer SphereGeometry(const OrbitCamera& camera, int width, int height) {
  GeometryBuffer g;
  g.width = width;
  g.height = height;
  g.pixels.resize(static_cast<size_t>(width) * height);
  const Vec3 eye = camera.Eye();
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const Vec3 d = camera.PixelRay(x, y, width, height);
      // |eye + t d|^2 = 1.
      const double b = eye.Dot(d), c = eye.Dot(eye) - 1;
      const double disc = b * b - c;
      if (disc < 0) continue;
      const double t = -b - std::sqrt(disc);
      if (t <= 0) continue;
      PixelGeometry& p = g.pixels[static_cast<size_t>(y) * width + x];
      p.hit = true;
      p.position = eye + d * t;
      p.normal = p.position.Normalized();
      const double azimuth = std::atan2(p.normal.x, -p.normal.z);
      p.tangent = {std::cos(azimuth), 0, std::sin(azimuth)};
      p.view = d * -1.0;
    }
  return g;
}

Image ShadeImage(const GeometryBuffer& g, const PixelShader& shader, int threads,
                 std::array<float, 3> background) {
  Image img;
  img.width = g.width;
  img.height = g.height;
  img.channels = 3;
  img.pixels.resize(static_cast<size_t>(g.width) * g.height * 3);
  ParallelChunks(g.height, threads, [&](int begin, int end) {
    for (int y = begin; y < end; ++y)
      for (int x = 0; x < g.width; ++x) {
        const PixelGeometry& p = g.at(x, y);
        float* out = &img.pixels[(static_cast<size_t>(y) * g.width + x) * 3];
        if (!p.hit) {
          for (int c = 0; c < 3; ++c) out[c] = background[c];
          continue;
        }
        const std::array<double, 3> v = shader(p);
        for (int c = 0; c < 3; ++c) out[c] = static_cast<float>(v[c]);
      }
  });
  return img;
}

PixelShader ShrmPixelShader(const ShrmCube& cube, ViewModel model, const Vec3& central_view,
                            const Brdf* lights_brdf) {
  return [&cube, model, central_view, lights_brdf](const PixelGeometry& p) {
    const bool tangent = cube.index == ReparamKind::kTangent;
    const Vec3 index = tangent ? p.tangent : p.normal * (2 * p.normal.Dot(p.view)) - p.view;
    std::array<double, 3> out{0, 0, 0};
    if (model == ViewModel::kCentral && cube.view == ViewVariable::kNormal) {
      // Eq. 5.35's map in the normal variable: each texel at its own normal (R_texel + V) /
      // |R_texel + V|, then bilinear in R (what the GPU pass and its filtering compute).
      for (const CubeTap& tap : ShrmBilinearTaps(cube.face_size, index)) {
        if (tap.weight == 0) continue;
        const std::array<double, 3> t =
            ShrmTexelRadiance(cube, tap.face, tap.x, tap.y, central_view);
        for (int c = 0; c < 3; ++c) out[c] += tap.weight * t[c];
      }
    } else {
      out = ShrmEvalAt(cube, index, model == ViewModel::kCentral ? central_view : p.view);
    }
    if (lights_brdf == nullptr || cube.lights.empty()) return out;
    if (model == ViewModel::kPerPixel) {
      const std::array<double, 3> lit =
          ShrmLightsRadiance(cube, *lights_brdf, tangent ? p.tangent : p.normal, p.view);
      for (int c = 0; c < 3; ++c) out[c] += lit[c];
      return out;
    }
    for (const CubeTap& tap : ShrmBilinearTaps(cube.face_size, index)) {
      if (tap.weight == 0) continue;
      const Vec3 r = CubeTexelDirection(tap.face, tap.x, tap.y, cube.face_size);
      const Vec3 n = tangent ? r : ShrmViewArgument(ViewVariable::kNormal, r, central_view);
      const std::array<double, 3> lit = ShrmLightsRadiance(cube, *lights_brdf, n, central_view);
      for (int c = 0; c < 3; ++c) out[c] += tap.weight * lit[c];
    }
    return out;
  };
}

}  // namespace shrm::viewer
