#include "core/shrm/shrm_explicit.h"

#include <algorithm>
#include <cmath>
#include <thread>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/sh/hbasis.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_eval.h"
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

void AddLightsToViewMap(const ShrmCube& cube, const Brdf& brdf, const Vec3& view, RadianceCube& map,
                        int threads) {
  if (cube.lights.empty()) return;
  const int size = map.face_size;
  ParallelChunks(6 * size, std::max(threads, 1), [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const int face = row / size, y = row % size;
      for (int x = 0; x < size; ++x) {
        const Vec3 r = CubeTexelDirection(face, x, y, size);
        const Vec3 n = cube.index == ReparamKind::kTangent
                           ? r
                           : ShrmViewArgument(ViewVariable::kNormal, r, view);
        const std::array<double, 3> lit = ShrmLightsRadiance(cube, brdf, n, view);
        for (int c = 0; c < map.channels; ++c)
          map.data[map.Index(face, x, y, c)] += static_cast<float>(lit[std::min(c, 2)]);
      }
    }
  });
}

namespace {

// Sizes `m` for (face_size, channels), reusing its storage when it already has the right size
// (then the old values are simply overwritten: no allocation, no page faults).
void PrepareMap(RadianceCube& m, int face_size, int channels) {
  m.face_size = face_size;
  m.channels = channels;
  if (m.data.size() != m.size()) {
    m.data.clear();
    m.data.shrink_to_fit();
    m.data.resize(m.size());
  }
}

// out[v][i] = sum_k y[v * n + k] t[k * tstride + i] for i < width and views v0 .. v0 + NV - 1:
// eq. 5.35 on one block of texels (one face row), t the transposed coefficients (k-major, the
// texel-channel index contiguous). Register-blocked: every 16-float slice of t[k] is loaded once
// for NV views; each output row is written once, sequentially.
template <int NV>
void ProductBlock(const float* t, size_t tstride, int n, int width, const float* y,
                  float* const* out) {
#if defined(__AVX512F__)
  int i = 0;
  for (; i + 16 <= width; i += 16) {
    __m512 acc[NV];
    for (int v = 0; v < NV; ++v) acc[v] = _mm512_setzero_ps();
    for (int k = 0; k < n; ++k) {
      const __m512 tk = _mm512_loadu_ps(t + k * tstride + i);
      for (int v = 0; v < NV; ++v)
        acc[v] = _mm512_fmadd_ps(_mm512_set1_ps(y[v * n + k]), tk, acc[v]);
    }
    for (int v = 0; v < NV; ++v) _mm512_storeu_ps(out[v] + i, acc[v]);
  }
  if (i < width) {
    const __mmask16 mask = static_cast<__mmask16>((1u << (width - i)) - 1);
    __m512 acc[NV];
    for (int v = 0; v < NV; ++v) acc[v] = _mm512_setzero_ps();
    for (int k = 0; k < n; ++k) {
      const __m512 tk = _mm512_maskz_loadu_ps(mask, t + k * tstride + i);
      for (int v = 0; v < NV; ++v)
        acc[v] = _mm512_fmadd_ps(_mm512_set1_ps(y[v * n + k]), tk, acc[v]);
    }
    for (int v = 0; v < NV; ++v) _mm512_mask_storeu_ps(out[v] + i, mask, acc[v]);
  }
#else
  for (int v = 0; v < NV; ++v) {
    float* o = out[v];
    const float* yv = y + v * n;
    for (int i = 0; i < width; ++i) o[i] = yv[0] * t[i];
    for (int k = 1; k < n; ++k)
      for (int i = 0; i < width; ++i) o[i] += yv[k] * t[k * tstride + i];
  }
#endif
}

}  // namespace

absl::Status ReflectionMapsForViewsInto(const ShrmCube& cube, std::span<const Vec3> views,
                                        std::vector<RadianceCube>& maps, int threads) {
  if (absl::Status s = CheckCube(cube, threads); !s.ok()) return s;
  const int size = cube.face_size, n = cube.coeff_count(), ch = cube.channels;
  maps.resize(views.size());
  for (RadianceCube& m : maps) PrepareMap(m, size, ch);
  const int rows = kCubeFaceCount * size;
  // kNormal cubes take Y_pq of each texel's own normal (R_texel + V) / |R_texel + V|: per texel.
  if (cube.kind == ShrmKind::kGlobal && cube.view == ViewVariable::kView) {
    std::vector<float> y(views.size() * n);
    for (size_t v = 0; v < views.size(); ++v) {
      const std::vector<double> yv = EvalSh(cube.pmax, ShFrameFromWorld(views[v]));
      for (int k = 0; k < n; ++k) y[v * n + k] = static_cast<float>(yv[k]);
    }
    const int width = size * ch;
    const size_t tstride = (static_cast<size_t>(width) + 15) / 16 * 16;
    ParallelChunks(rows, threads, [&](int begin, int end) {
      std::vector<float> t(static_cast<size_t>(n) * tstride);
      for (int row = begin; row < end; ++row) {
        const int face = row / size, yy = row % size;
        const float* src = cube.data.data() + cube.Index(face, 0, yy, 0, 0);
        for (int x = 0; x < size; ++x)
          for (int k = 0; k < n; ++k)
            for (int c = 0; c < ch; ++c)
              t[k * tstride + x * ch + c] = src[(static_cast<size_t>(x) * n + k) * ch + c];
        size_t v = 0;
        float* out[4];
        for (; v + 4 <= views.size(); v += 4) {
          for (int j = 0; j < 4; ++j)
            out[j] = maps[v + j].data.data() + maps[v + j].Index(face, 0, yy, 0);
          ProductBlock<4>(t.data(), tstride, n, width, y.data() + v * n, out);
        }
        for (; v < views.size(); ++v) {
          out[0] = maps[v].data.data() + maps[v].Index(face, 0, yy, 0);
          ProductBlock<1>(t.data(), tstride, n, width, y.data() + v * n, out);
        }
        // A Fresnel table (conventions 4): times w(N.V) at each texel, N.V = |R_texel + V| / 2.
        if (cube.fresnel.empty()) continue;
        for (int x = 0; x < size; ++x) {
          const Vec3 texel = CubeTexelDirection(face, x, yy, size);
          for (size_t vi = 0; vi < views.size(); ++vi) {
            const double cos_nv =
                FresnelCosine(cube.view, texel, ShrmViewArgument(cube.view, texel, views[vi]));
            for (int c = 0; c < ch; ++c)
              maps[vi].data[maps[vi].Index(face, x, yy, c)] *=
                  static_cast<float>(ShrmFresnel(cube, cos_nv, c));
          }
        }
      }
    });
  } else {
    ParallelRows(rows, threads, [&](int row) {
      const int face = row / size, yy = row % size;
      for (int x = 0; x < size; ++x)
        for (size_t v = 0; v < views.size(); ++v) {
          const std::array<double, 3> b = ShrmTexelRadiance(cube, face, x, yy, views[v]);
          for (int c = 0; c < ch; ++c)
            maps[v].data[maps[v].Index(face, x, yy, c)] = c < 3 ? static_cast<float>(b[c]) : 0.0f;
        }
    });
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<RadianceCube>> ReflectionMapsForViews(const ShrmCube& cube,
                                                                 std::span<const Vec3> views,
                                                                 int threads) {
  std::vector<RadianceCube> maps;
  if (absl::Status s = ReflectionMapsForViewsInto(cube, views, maps, threads); !s.ok()) return s;
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
  std::vector<RadianceCube> maps;
  if (absl::Status s = ViewGridMapsInto(cube, t_b, maps, threads); !s.ok()) return s;
  return maps;
}

absl::Status ViewGridMapsInto(const ShrmCube& cube, int t_b, std::vector<RadianceCube>& maps,
                              int threads) {
  if (t_b < 1 || t_b > kMaxExplicitTb) {
    return absl::InvalidArgumentError(
        absl::StrCat("T_B = ", t_b, " is outside [1, ", kMaxExplicitTb, "]"));
  }
  const std::vector<Vec3> views = ViewGrid(t_b);
  return ReflectionMapsForViewsInto(cube, views, maps, threads);
}

double KautzMcCoolTheta(int k, int t_b) { return kPi * (k + 0.5) / t_b; }

absl::StatusOr<std::vector<RadianceCube>> KautzMcCoolSlices(const ShrmCube& local_cube, int t_b) {
  if (absl::Status s = CheckCube(local_cube, 1); !s.ok()) return s;
  if (local_cube.kind != ShrmKind::kLocal)
    return absl::InvalidArgumentError("Kautz-McCool slices need a local SHRM (q = 0 terms)");
  if (t_b < 1 || t_b > kMaxExplicitTb) {
    return absl::InvalidArgumentError(
        absl::StrCat("T_B = ", t_b, " is outside [1, ", kMaxExplicitTb, "]"));
  }
  const int size = local_cube.face_size, ch = local_cube.channels, pm = local_cube.pmax;
  std::vector<RadianceCube> slices(t_b, EmptyMap(size, ch));
  std::vector<double> lambda(LegendreCount(pm));
  for (int k = 0; k < t_b; ++k) {
    // kNormal: the view at theta_o' is the normal at theta_o' / 2.
    const double theta =
        KautzMcCoolTheta(k, t_b) * (local_cube.view == ViewVariable::kNormal ? 0.5 : 1.0);
    NormalizedLegendre(pm, std::cos(theta), std::sin(theta), lambda);
    const double cos_nv = std::cos(0.5 * KautzMcCoolTheta(k, t_b));
    for (int f = 0; f < kCubeFaceCount; ++f)
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
          for (int c = 0; c < ch; ++c) {
            double s = 0;
            for (int p = 0; p <= pm; ++p)
              s += lambda[LegendreIndex(p, 0)] *
                   local_cube.data[local_cube.Index(f, x, y, ShIndex(p, 0), c)];
            // Times the Fresnel factor at N.V = cos(theta_o' / 2) (shrm_map.h).
            s *= ShrmFresnel(local_cube, cos_nv, c);
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
