#include "core/ibl/light_peaks.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>

#include "core/base/constants.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"

namespace shrm::ibl {
namespace {

// Rec. 709 luminance, as the transform's energies (split_sum.cc) weigh the channels.
constexpr std::array<double, 3> kLuma = {0.2126, 0.7152, 0.0722};

double Luminance(const float* px) { return kLuma[0] * px[0] + kLuma[1] * px[1] + kLuma[2] * px[2]; }

}  // namespace

PeakSplit SplitLightPeaks(const EnvMap& map) {
  PeakSplit out;
  const Image* img = map.lat_long_image();
  if (img == nullptr || img->width < 1 || img->height < 1 || img->channels != 3) return out;
  const int w = img->width, h = img->height;
  const RingQuadrature rule = FejerFirstRule(h);
  // Pass 1: the moments (as MapLightMoments) and the mean luminance over the sphere.
  double sum = 0, sum_sq = 0;
  for (int j = 0; j < h; ++j) {
    const float* row = img->pixels.data() + static_cast<size_t>(j) * w * 3;
    double s = 0, s2 = 0;
    for (int i = 0; i < w; ++i) {
      const double y = Luminance(row + 3 * i);
      s += y;
      s2 += y * y;
    }
    const double weight = 2 * kPi / w * rule.weight[j];
    sum += weight * s;
    sum_sq += weight * s2;
  }
  const double mean = sum / (4 * kPi);
  if (!(mean > 0)) return out;
  // Pass 2: the candidates above kPeakRatio x the mean; the threshold rises to keep at most
  // kMaxPeaks of them (ties at the threshold stay in the rest).
  double threshold = kPeakRatio * mean;
  struct Candidate {
    double y;
    int index;
  };
  std::vector<Candidate> candidates;
  for (int k = 0; k < w * h; ++k) {
    const double y = Luminance(img->pixels.data() + static_cast<size_t>(k) * 3);
    if (y > threshold) candidates.push_back({y, k});
  }
  if (candidates.size() > static_cast<size_t>(kMaxPeaks)) {
    std::nth_element(candidates.begin(), candidates.begin() + kMaxPeaks, candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.y > b.y; });
    threshold = candidates[kMaxPeaks].y;
    std::erase_if(candidates, [threshold](const Candidate& c) { return !(c.y > threshold); });
  }
  if (candidates.empty()) return out;
  // Does it pay? The rest's non-constant energy against the map's.
  double rest_sum = sum, rest_sum_sq = sum_sq;
  for (const Candidate& c : candidates) {
    const double weight = 2 * kPi / w * rule.weight[c.index / w];
    rest_sum -= weight * (c.y - threshold);
    rest_sum_sq -= weight * (c.y * c.y - threshold * threshold);
  }
  const double spread = sum_sq - sum * sum / (4 * kPi);
  const double rest_spread = rest_sum_sq - rest_sum * rest_sum / (4 * kPi);
  if (!(rest_spread <= kPeakSpreadShare * spread)) return out;
  // The split: T / Y of each candidate's radiance stays, the rest of it becomes a peak.
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.index < b.index; });
  Image rest = *img;
  LightPeaks& peaks = out.peaks;
  peaks.threshold = threshold;
  for (const Candidate& c : candidates) {
    const int i = c.index % w, j = c.index / w;
    const std::optional<Vec3> d = map.PixelDirection(0, i, j);
    if (!d) continue;
    float* px = rest.pixels.data() + static_cast<size_t>(c.index) * 3;
    const double keep = threshold / c.y;
    const double weight = 2 * kPi / w * rule.weight[j];
    std::array<double, 3> part;
    for (int ch = 0; ch < 3; ++ch) {
      const float kept = static_cast<float>(px[ch] * keep);
      part[ch] = (static_cast<double>(px[ch]) - kept) * weight;
      px[ch] = kept;
    }
    peaks.x.push_back(static_cast<float>(d->x));
    peaks.y.push_back(static_cast<float>(d->y));
    peaks.z.push_back(static_cast<float>(d->z));
    peaks.r.push_back(static_cast<float>(part[0]));
    peaks.g.push_back(static_cast<float>(part[1]));
    peaks.b.push_back(static_cast<float>(part[2]));
  }
  out.rest = EnvMap::FromLatLong(std::move(rest));
  return out;
}

LightPeaks RotatedPeaks(const LightPeaks& peaks, const Mat3& rotation) {
  if (rotation.IsIdentity()) return peaks;
  LightPeaks out = peaks;
  for (size_t k = 0; k < peaks.size(); ++k) {
    const Vec3 d = rotation * Vec3{peaks.x[k], peaks.y[k], peaks.z[k]};
    out.x[k] = static_cast<float>(d.x);
    out.y[k] = static_cast<float>(d.y);
    out.z[k] = static_cast<float>(d.z);
  }
  return out;
}

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

// Sums kernel(e) L over the peaks for the texel directions (x, y, z) of one run, into (r, g, b).
template <typename Kernel>
void SumRun(const LightPeaks& p, const Kernel& kernel, Lanes x, Lanes y, Lanes z, Lanes& r,
            Lanes& g, Lanes& b) {
  for (size_t k = 0; k < p.size(); ++k) {
    const Lanes ex = x - p.x[k], ey = y - p.y[k], ez = z - p.z[k];
    const Lanes e = ex * ex + ey * ey + ez * ez;
    const Lanes v = kernel(e);
    r += v * p.r[k];
    g += v * p.g[k];
    b += v * p.b[k];
  }
}

}  // namespace

void AddPeakSums(const LightPeaks& peaks, const PeakKernel& kernel, RadianceCube& cube,
                 int threads) {
  if (peaks.empty()) return;
  const int s = cube.face_size;
  const float scale = static_cast<float>(kernel.scale);
  const float a2 = static_cast<float>(kernel.alpha2), slope = (1 - a2) / 4;
  const Lanes zero = {};
  // (1 - e / 2)+: the cosine, kept exact near e = 0.
  const auto cosine = [zero](Lanes e) {
    const Lanes c = 1.0f - 0.5f * e;
    return c > zero ? c : zero;
  };
  const auto ggx = [&](Lanes e) {
    const Lanes den = a2 + slope * e;
    return cosine(e) / (den * den);
  };
  // Every kernel is 0 at 90 degrees or more from its axis: a run of texels at least 90 degrees
  // from every peak (beyond the peaks' bounding cone by a right angle) adds nothing. The cone:
  // the peaks' mean direction and the sine of the widest angle from it (> 1: no cone).
  Vec3 axis{0, 0, 0};
  for (size_t k = 0; k < peaks.size(); ++k) axis = axis + Vec3{peaks.x[k], peaks.y[k], peaks.z[k]};
  double sin_radius = 2;
  if (axis.Norm() > 0) {
    axis = axis.Normalized();
    double min_cos = 1;
    for (size_t k = 0; k < peaks.size(); ++k)
      min_cos = std::min(min_cos, axis.Dot(Vec3{peaks.x[k], peaks.y[k], peaks.z[k]}));
    // (A margin for the single-precision directions.)
    if (min_cos > 0) sin_radius = std::sqrt(std::max(0.0, 1 - min_cos * min_cos)) + 1e-5;
  }
  ParallelChunks(kCubeFaceCount * s, threads, [&](int begin, int end) {
    for (int row = begin; row < end; ++row) {
      const int face = row / s, y = row % s;
      for (int x0 = 0; x0 < s; x0 += kLanes) {
        const int n = std::min(kLanes, s - x0);
        Lanes dx = {}, dy = {}, dz = {};
        bool any = false;
        for (int i = 0; i < kLanes; ++i) {
          const Vec3 d = CubeTexelDirection(face, std::min(x0 + i, s - 1), y, s);
          dx[i] = static_cast<float>(d.x);
          dy[i] = static_cast<float>(d.y);
          dz[i] = static_cast<float>(d.z);
          any |= !(sin_radius <= 1 && d.Dot(axis) <= -sin_radius);
        }
        if (!any) continue;
        Lanes r = {}, g = {}, b = {};
        switch (kernel.form) {
          case PeakKernel::Form::kGgx:
            SumRun(peaks, ggx, dx, dy, dz, r, g, b);
            break;
          case PeakKernel::Form::kCosine:
            SumRun(peaks, cosine, dx, dy, dz, r, g, b);
            break;
          case PeakKernel::Form::kGeneric:
            for (int i = 0; i < n; ++i) {
              double acc[3] = {0, 0, 0};
              for (size_t k = 0; k < peaks.size(); ++k) {
                const double c = static_cast<double>(dx[i]) * peaks.x[k] +
                                 static_cast<double>(dy[i]) * peaks.y[k] +
                                 static_cast<double>(dz[i]) * peaks.z[k];
                const double v = kernel.generic(c);
                acc[0] += v * peaks.r[k];
                acc[1] += v * peaks.g[k];
                acc[2] += v * peaks.b[k];
              }
              r[i] = static_cast<float>(acc[0]);
              g[i] = static_cast<float>(acc[1]);
              b[i] = static_cast<float>(acc[2]);
            }
            break;
        }
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
