#include "core/shrm/shrm_explicit.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/sh/hbasis.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm {
namespace {

absl::Status CheckCube(const ShrmCube& cube, int threads) {
  if (cube.face_size < 1 || cube.pmax < 0 || cube.channels < 1 || cube.data.size() != cube.size())
    return absl::InvalidArgumentError(absl::StrCat(
        "SHRM cube: face size ", cube.face_size, ", pmax ", cube.pmax, ", channels ", cube.channels,
        ", ", cube.data.size(), " values (expected ", cube.size(), ")"));
  if (threads < 1) return absl::InvalidArgumentError(absl::StrCat("threads = ", threads));
  return absl::OkStatus();
}

template <typename Body>
void ParallelRows(int rows, int threads, Body&& body) {
  threads = std::max(1, std::min(threads, rows));
  if (threads == 1) {
    for (int r = 0; r < rows; ++r) body(r);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&body, t, threads, rows] {
      for (int r = t; r < rows; r += threads) body(r);
    });
  for (auto& th : pool) th.join();
}

RadianceCube EmptyMap(int face_size, int channels) {
  RadianceCube m;
  m.face_size = face_size;
  m.channels = channels;
  m.data.assign(m.size(), 0.0f);
  return m;
}

}  // namespace

absl::StatusOr<RadianceCube> ReflectionMapForView(const ShrmCube& cube, const Vec3& view,
                                                  int threads) {
  const Vec3 views[1] = {view};
  auto maps = ReflectionMapsForViews(cube, views, threads);
  if (!maps.ok()) return maps.status();
  return std::move((*maps)[0]);
}

absl::StatusOr<std::vector<RadianceCube>> ReflectionMapsForViews(const ShrmCube& cube,
                                                                 std::span<const Vec3> views,
                                                                 int threads) {
  if (absl::Status s = CheckCube(cube, threads); !s.ok()) return s;
  const int size = cube.face_size, n = cube.coeff_count(), ch = cube.channels;
  std::vector<RadianceCube> maps(views.size(), EmptyMap(size, ch));
  const int rows = kCubeFaceCount * size;
  if (cube.kind == ShrmKind::kGlobal) {
    std::vector<float> y(views.size() * n);
    for (size_t v = 0; v < views.size(); ++v) {
      const std::vector<double> yv = EvalSh(cube.pmax, ShFrameFromWorld(views[v]));
      for (int k = 0; k < n; ++k) y[v * n + k] = static_cast<float>(yv[k]);
    }
    const int width = size * ch;
    ParallelRows(rows, threads, [&](int row) {
      const int face = row / size, yy = row % size;
      std::vector<float> t(static_cast<size_t>(n) * width);
      const float* src = cube.data.data() + cube.Index(face, 0, yy, 0, 0);
      for (int x = 0; x < size; ++x)
        for (int k = 0; k < n; ++k)
          for (int c = 0; c < ch; ++c)
            t[static_cast<size_t>(k) * width + x * ch + c] =
                src[(static_cast<size_t>(x) * n + k) * ch + c];
      for (size_t v = 0; v < views.size(); ++v) {
        const float* yv = y.data() + v * n;
        float* acc = maps[v].data.data() + maps[v].Index(face, 0, yy, 0);
        for (int i = 0; i < width; ++i) acc[i] = yv[0] * t[i];
        for (int k = 1; k < n; ++k) {
          const float w = yv[k];
          const float* tk = t.data() + static_cast<size_t>(k) * width;
          for (int i = 0; i < width; ++i) acc[i] += w * tk[i];
        }
      }
    });
  } else {
    ParallelRows(rows, threads, [&](int row) {
      const int face = row / size, yy = row % size;
      for (int x = 0; x < size; ++x)
        for (size_t v = 0; v < views.size(); ++v) {
          const std::array<double, 3> b = ShrmTexelRadiance(cube, face, x, yy, views[v]);
          for (int c = 0; c < std::min(ch, 3); ++c)
            maps[v].data[maps[v].Index(face, x, yy, c)] = static_cast<float>(b[c]);
        }
    });
  }
  return maps;
}

std::array<Vec3, 12> IcosahedronVertices() {
  // Two poles on +-Y and two rings of five at latitude +-atan(1/2).
  std::array<Vec3, 12> v;
  v[0] = {0, 1, 0};
  v[11] = {0, -1, 0};
  const double y = 1 / std::sqrt(5.0), r = 2 / std::sqrt(5.0);
  for (int k = 0; k < 5; ++k) {
    const double a = 2 * kPi * k / 5, b = a + kPi / 5;
    v[1 + k] = {r * std::cos(a), y, r * std::sin(a)};
    v[6 + k] = {r * std::cos(b), -y, r * std::sin(b)};
  }
  return v;
}

absl::StatusOr<std::vector<RadianceCube>> CabralMaps(const ShrmCube& cube, int threads) {
  const std::array<Vec3, 12> v = IcosahedronVertices();
  return ReflectionMapsForViews(cube, v, threads);
}

std::vector<Vec3> ViewGrid(int t_b) {
  std::vector<Vec3> views;
  for (int j = 0; j < t_b; ++j)
    for (int i = 0; i < t_b; ++i) {
      const double t = kPi * (j + 0.5) / t_b, p = 2 * kPi * ((i + 0.5) / t_b - 0.5);
      views.push_back({std::sin(t) * std::sin(p), std::cos(t), -std::sin(t) * std::cos(p)});
    }
  return views;
}

absl::StatusOr<std::vector<RadianceCube>> ViewGridMaps(const ShrmCube& cube, int t_b, int threads) {
  if (t_b < 1) return absl::InvalidArgumentError(absl::StrCat("T_B = ", t_b, " (must be >= 1)"));
  const std::vector<Vec3> views = ViewGrid(t_b);
  return ReflectionMapsForViews(cube, views, threads);
}

double KautzMcCoolTheta(int k, int t_b) { return kPi * (k + 0.5) / t_b; }

absl::StatusOr<std::vector<RadianceCube>> KautzMcCoolSlices(const ShrmCube& local_cube, int t_b) {
  if (absl::Status s = CheckCube(local_cube, 1); !s.ok()) return s;
  if (local_cube.kind != ShrmKind::kLocal)
    return absl::InvalidArgumentError("Kautz-McCool slices need a local SHRM (q = 0 terms)");
  if (t_b < 1) return absl::InvalidArgumentError(absl::StrCat("T_B = ", t_b, " (must be >= 1)"));
  const int size = local_cube.face_size, ch = local_cube.channels, pm = local_cube.pmax;
  std::vector<RadianceCube> slices(t_b, EmptyMap(size, ch));
  std::vector<double> lambda(LegendreCount(pm));
  for (int k = 0; k < t_b; ++k) {
    const double theta = KautzMcCoolTheta(k, t_b);
    NormalizedLegendre(pm, std::cos(theta), std::sin(theta), lambda);
    for (int f = 0; f < kCubeFaceCount; ++f)
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
          for (int c = 0; c < ch; ++c) {
            double s = 0;
            for (int p = 0; p <= pm; ++p)
              s += lambda[LegendreIndex(p, 0)] *
                   local_cube.data[local_cube.Index(f, x, y, ShIndex(p, 0), c)];
            slices[k].data[slices[k].Index(f, x, y, c)] = static_cast<float>(s);
          }
  }
  return slices;
}

absl::StatusOr<std::vector<double>> IrradianceCoefficients(int light_lmax, int channels,
                                                           std::span<const double> light) {
  if (light_lmax < 2 || channels < 1 ||
      light.size() != static_cast<size_t>(ShCount(light_lmax)) * channels)
    return absl::InvalidArgumentError(
        absl::StrCat("irradiance: need real L_lm of degree >= 2: lmax ", light_lmax, ", channels ",
                     channels, ", ", light.size(), " values"));
  std::vector<double> e(static_cast<size_t>(9) * channels);
  for (int l = 0; l <= 2; ++l)
    for (int m = -l; m <= l; ++m)
      for (int c = 0; c < channels; ++c)
        e[static_cast<size_t>(ShIndex(l, m)) * channels + c] =
            LambertianBandFactor(l) * light[static_cast<size_t>(ShIndex(l, m)) * channels + c];
  return e;
}

absl::StatusOr<RadianceCube> IrradianceCube(std::span<const double> irradiance9, int channels,
                                            int face_size) {
  if (face_size < 1 || channels < 1 || irradiance9.size() != static_cast<size_t>(9) * channels)
    return absl::InvalidArgumentError(absl::StrCat("irradiance cube: face size ", face_size,
                                                   ", channels ", channels, ", ",
                                                   irradiance9.size(), " coefficients"));
  RadianceCube m = EmptyMap(face_size, channels);
  double y[9];
  for (int f = 0; f < kCubeFaceCount; ++f)
    for (int yy = 0; yy < face_size; ++yy)
      for (int x = 0; x < face_size; ++x) {
        EvalSh(2, ShFrameFromWorld(CubeTexelDirection(f, x, yy, face_size)), y);
        for (int c = 0; c < channels; ++c) {
          double s = 0;
          for (int k = 0; k < 9; ++k)
            s += y[k] * irradiance9[static_cast<size_t>(k) * channels + c];
          m.data[m.Index(f, x, yy, c)] = static_cast<float>(s);
        }
      }
  return m;
}

}  // namespace shrm
