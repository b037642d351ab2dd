#include "core/ibl/light_peaks.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/base/constants.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/ibl/quarter_power.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"

namespace shrm::ibl {

void AddPeakCoefficients(const LightPeaks& peaks, int lmax, std::span<double> coeffs) {
  std::vector<double> y(ShCount(lmax));
  for (size_t k = 0; k < peaks.size(); ++k) {
    EvalSh(lmax, ShFrameFromWorld(Vec3{peaks.x[k], peaks.y[k], peaks.z[k]}), y);
    const double rgb[3] = {peaks.r[k], peaks.g[k], peaks.b[k]};
    for (int i = 0; i < ShCount(lmax); ++i) {
      for (int c = 0; c < 3; ++c) coeffs[static_cast<size_t>(i) * 3 + c] += y[i] * rgb[c];
    }
  }
}

namespace {

// 16 texels side by side (GCC's generic vectors: one AVX-512 register, or split by the compiler
// on narrower targets).
constexpr int kLanes = 16;
typedef float Lanes __attribute__((vector_size(kLanes * sizeof(float))));

// Sums kernel(e) L over peaks k0 .. k1 - 1 for the texel directions (x, y, z) of one run, into
// (r, g, b).
template <typename Kernel>
void SumRun(const LightPeaks& p, size_t k0, size_t k1, const Kernel& kernel, Lanes x, Lanes y,
            Lanes z, Lanes& r, Lanes& g, Lanes& b) {
  Lanes ar = {}, ag = {}, ab = {};  // (in registers through the loop)
  for (size_t k = k0; k < k1; ++k) {
    const Lanes ex = x - p.x[k], ey = y - p.y[k], ez = z - p.z[k];
    const Lanes e = ex * ex + ey * ey + ez * ez;
    const Lanes v = kernel(e);
    ar += v * p.r[k];
    ag += v * p.g[k];
    ab += v * p.b[k];
  }
  r += ar;
  g += ag;
  b += ab;
}

// The peaks in groups of nearby directions (at most kGroup each), each with its bounding cone:
// a run of texels 90 degrees or more beyond a group's cone gets nothing from it (every kernel is
// 0 from 90 degrees on), about half of all (texel, peak) pairs.
constexpr size_t kGroup = 16;
struct PeakGroups {
  LightPeaks peaks;               // reordered, group after group
  std::vector<size_t> first;      // group g: peaks first[g] .. first[g + 1] - 1
  std::vector<Vec3> axis;         // unit
  std::vector<float> sin_radius;  // > 1: no cone (never skipped)
};

PeakGroups GroupPeaks(const LightPeaks& in) {
  // Buckets: the cube face of the direction and its quadrant (24 cells of about 45 degrees),
  // each cut into groups of kGroup.
  const size_t n = in.size();
  std::vector<std::pair<int, size_t>> keyed(n);
  for (size_t k = 0; k < n; ++k) {
    const Vec3 d{in.x[k], in.y[k], in.z[k]};
    int face;
    double sf, tf;
    CubeFaceCoordinates(d, &face, &sf, &tf);
    keyed[k] = {face * 4 + (sf >= 0.5 ? 1 : 0) + (tf >= 0.5 ? 2 : 0), k};
  }
  std::stable_sort(keyed.begin(), keyed.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  PeakGroups out;
  for (size_t i = 0; i < n; ++i) {
    const size_t k = keyed[i].second;
    if (i == 0 || keyed[i].first != keyed[i - 1].first || i - out.first.back() == kGroup)
      out.first.push_back(i);
    out.peaks.x.push_back(in.x[k]);
    out.peaks.y.push_back(in.y[k]);
    out.peaks.z.push_back(in.z[k]);
    out.peaks.r.push_back(in.r[k]);
    out.peaks.g.push_back(in.g[k]);
    out.peaks.b.push_back(in.b[k]);
  }
  out.first.push_back(n);
  for (size_t g = 0; g + 1 < out.first.size(); ++g) {
    Vec3 axis{0, 0, 0};
    const LightPeaks& p = out.peaks;
    for (size_t k = out.first[g]; k < out.first[g + 1]; ++k)
      axis = axis + Vec3{p.x[k], p.y[k], p.z[k]};
    float sin_radius = 2;
    if (axis.Norm() > 0) {
      axis = axis.Normalized();
      double min_cos = 1;
      for (size_t k = out.first[g]; k < out.first[g + 1]; ++k)
        min_cos = std::min(min_cos, axis.Dot(Vec3{p.x[k], p.y[k], p.z[k]}));
      // (A margin for the single-precision directions.)
      if (min_cos > 0)
        sin_radius = static_cast<float>(std::sqrt(std::max(0.0, 1 - min_cos * min_cos)) + 1e-5);
    }
    out.axis.push_back(axis);
    out.sin_radius.push_back(sin_radius);
  }
  return out;
}

// 1 / d: the AVX-512 estimate (within 2^-14 relative, 8 times below a half float's rounding
// and far below any tolerance a job takes), else a division.
inline Lanes Reciprocal(Lanes d) {
#if defined(__AVX512F__)
  const __m512 x = reinterpret_cast<__m512>(d);
  const __m512 r = _mm512_maskz_rcp14_ps(0xFFFF, x);
  return reinterpret_cast<Lanes>(r);
#else
  return 1.0f / d;
#endif
}

// (e / 4)^x (quarter_power.h), else libm's powf per lane.
inline Lanes PowerOfQuarter(Lanes e, float x) {
#if defined(__AVX512F__)
  return reinterpret_cast<Lanes>(shrm::internal::QuarterPower(reinterpret_cast<__m512>(e), x));
#else
  Lanes v;
  for (int i = 0; i < kLanes; ++i) v[i] = std::pow(0.25f * e[i], x);
  return v;
#endif
}

// The unit directions of texels x0 .. x0 + kLanes - 1 of row y of a face of size s
// (CubeTexelDirection in single precision; lanes past the face's edge are directions off it).
void RunDirections(int face, int x0, int y, int s, Lanes& dx, Lanes& dy, Lanes& dz) {
  Lanes sc;
  for (int i = 0; i < kLanes; ++i) sc[i] = static_cast<float>((2.0 * (x0 + i) + 1) / s - 1);
  const float tc = static_cast<float>((2.0 * y + 1) / s - 1);
  const Lanes one = sc * 0.0f + 1.0f;
  switch (face) {  // CubeFaceDirection
    case kPosX:
      dx = one, dy = one * -tc, dz = -sc;
      break;
    case kNegX:
      dx = -one, dy = one * -tc, dz = sc;
      break;
    case kPosY:
      dx = sc, dy = one, dz = one * tc;
      break;
    case kNegY:
      dx = sc, dy = -one, dz = one * -tc;
      break;
    case kPosZ:
      dx = sc, dy = one * -tc, dz = one;
      break;
    default:
      dx = -sc, dy = one * -tc, dz = -one;
      break;
  }
  Lanes inv;
  for (int i = 0; i < kLanes; ++i) inv[i] = 1.0f / std::sqrt(1.0f + sc[i] * sc[i] + tc * tc);
  dx *= inv;
  dy *= inv;
  dz *= inv;
}

}  // namespace

void AddPeakSums(const LightPeaks& peaks, const PeakKernel& kernel, RadianceCube& cube,
                 int threads) {
  if (peaks.empty()) return;
  const int s = cube.face_size;
  const float scale = static_cast<float>(kernel.scale);
  const float slope = static_cast<float>(kernel.slope);
  const Lanes zero = {};
  // (1 - e / 2)+: the cosine, kept exact near e = 0.
  const auto cosine = [zero](Lanes e) {
    const Lanes c = 1.0f - 0.5f * e;
    return c > zero ? c : zero;
  };
  const float exponent = static_cast<float>(kernel.exponent);
  const auto power = [&](Lanes e) { return cosine(e) * PowerOfQuarter(e, exponent); };
  const auto ggx = [&](Lanes e) {
    const Lanes den = 1.0f + slope * e;
    return cosine(e) * Reciprocal(den * den);
  };
  const PeakGroups groups = GroupPeaks(peaks);
  const LightPeaks& sorted = groups.peaks;
  const size_t group_count = groups.axis.size();
  ParallelChunks(kCubeFaceCount * s, threads, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const int face = row / s, y = row % s;
      for (int x0 = 0; x0 < s; x0 += kLanes) {
        const int n = std::min(kLanes, s - x0);
        Lanes dx, dy, dz;
        RunDirections(face, x0, y, s, dx, dy, dz);
        Lanes r = {}, g = {}, b = {};
        bool any = false;
        for (size_t gi = 0; gi < group_count; ++gi) {
          const float sin_radius = groups.sin_radius[gi];
          if (sin_radius <= 1) {
            const Vec3& a = groups.axis[gi];
            const Lanes along = dx * static_cast<float>(a.x) + dy * static_cast<float>(a.y) +
                                dz * static_cast<float>(a.z);
            bool reached = false;
            for (int i = 0; i < n; ++i) reached |= along[i] > -sin_radius;
            if (!reached) continue;
          }
          any = true;
          const size_t k0 = groups.first[gi], k1 = groups.first[gi + 1];
          switch (kernel.form) {
            case PeakKernel::Form::kGgx:
              SumRun(sorted, k0, k1, ggx, dx, dy, dz, r, g, b);
              break;
            case PeakKernel::Form::kCosine:
              SumRun(sorted, k0, k1, cosine, dx, dy, dz, r, g, b);
              break;
            case PeakKernel::Form::kPower:
              SumRun(sorted, k0, k1, power, dx, dy, dz, r, g, b);
              break;
          }
        }
        if (!any) continue;
        for (int i = 0; i < n; ++i) {
          float* t = &cube.data[cube.Index(face, x0 + i, y, 0)];
          t[0] += scale * r[i];
          t[1] += scale * g[i];
          t[2] += scale * b[i];
        }
      }
    }
  });
}

}  // namespace shrm::ibl
