#include "core/envmap/light_split.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/base/constants.h"
#include "core/sh/quadrature.h"

namespace shrm {
namespace {

// Rec. 709 luminance, as the transform's energies (split_sum.cc) weigh the channels.
constexpr std::array<double, 3> kLuma = {0.2126, 0.7152, 0.0722};

double Luminance(const float* px) { return kLuma[0] * px[0] + kLuma[1] * px[1] + kLuma[2] * px[2]; }

}  // namespace

LuminanceRow SumLuminanceRow(const float* rgb, int width) {
  double s[4] = {0, 0, 0, 0}, s2[4] = {0, 0, 0, 0}, top[4] = {0, 0, 0, 0};
  for (int i = 0; i < width; ++i) {
    const double y = Luminance(rgb + 3 * static_cast<size_t>(i));
    s[i % 4] += y;
    s2[i % 4] += y * y;
    top[i % 4] = std::max(top[i % 4], y);
  }
  LuminanceRow out;
  out.sum = (s[0] + s[1]) + (s[2] + s[3]);
  out.sum_sq = (s2[0] + s2[1]) + (s2[2] + s2[3]);
  out.max = std::max(std::max(top[0], top[1]), std::max(top[2], top[3]));
  return out;
}

PeakSplit SplitLightPeaks(const EnvMap& map, double max_rest_share) {
  PeakSplit out;
  const Image* img = map.lat_long_image();
  if (img == nullptr || img->width < 1 || img->height < 1 || img->channels != 3) return out;
  const int w = img->width, h = img->height;
  const RingQuadrature rule = FejerFirstRule(h);
  // Pass 1: the moments (as MapLightMoments), the mean luminance over the sphere, and each
  // row's largest luminance.
  double sum = 0, sum_sq = 0;
  std::vector<double> row_max(h, 0.0);
  for (int j = 0; j < h; ++j) {
    const LuminanceRow row =
        SumLuminanceRow(img->pixels.data() + static_cast<size_t>(j) * w * 3, w);
    const double weight = 2 * kPi / w * rule.weight[j];
    sum += weight * row.sum;
    sum_sq += weight * row.sum_sq;
    row_max[j] = row.max;
  }
  // (The map's moments, unless a split below replaces them by the rest's.)
  out.moments_known = true;
  out.sum_y = sum;
  out.sum_y2 = sum_sq;
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
  for (int j = 0; j < h; ++j) {
    if (!(row_max[j] > threshold)) continue;
    for (int k = j * w; k < (j + 1) * w; ++k) {
      const double y = Luminance(img->pixels.data() + static_cast<size_t>(k) * 3);
      if (y > threshold) candidates.push_back({y, k});
    }
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
  if (spread > 0) out.rest_share = std::max(0.0, rest_spread / spread);
  if (!(rest_spread <= max_rest_share * spread)) return out;
  // The split: T / Y of each candidate's radiance stays, the rest of it becomes a peak.
  std::sort(candidates.begin(), candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.index < b.index; });
  Image rest = *img;
  LightPeaks& peaks = out.peaks;
  peaks.threshold = threshold;
  // The rest's moments: the map's less each split pixel's luminance and its square, with the
  // values the rest holds (rounded to single precision).
  double moved = 0, moved_sq = 0;
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
    const double y_kept = Luminance(px);
    moved += weight * (c.y - y_kept);
    moved_sq += weight * (c.y * c.y - y_kept * y_kept);
    peaks.x.push_back(static_cast<float>(d->x));
    peaks.y.push_back(static_cast<float>(d->y));
    peaks.z.push_back(static_cast<float>(d->z));
    peaks.r.push_back(static_cast<float>(part[0]));
    peaks.g.push_back(static_cast<float>(part[1]));
    peaks.b.push_back(static_cast<float>(part[2]));
  }
  out.rest = EnvMap::FromLatLong(std::move(rest));
  out.sum_y = sum - moved;
  out.sum_y2 = sum_sq - moved_sq;
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

}  // namespace shrm
