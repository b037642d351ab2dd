#include "core/envmap/lighting.h"

#include <algorithm>
#include <thread>

#include "absl/strings/str_cat.h"
#include "core/base/geometry.h"
#include "core/base/status_macros.h"
#include "core/sh/quadrature.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/transform/sht.h"

namespace shrm {
namespace {

constexpr int kChannels = 3;

absl::Status CheckArgs(int lmax, const Mat3& rot, int num_threads) {
  if (lmax < 0) return absl::InvalidArgumentError(absl::StrCat("lmax must be >= 0, got ", lmax));
  if (num_threads < 1) {
    return absl::InvalidArgumentError(absl::StrCat("num_threads must be >= 1, got ", num_threads));
  }
  if (!rot.IsIdentity()) {
    SHRM_RETURN_IF_ERROR(ValidateRotationMatrix(rot));
    if (lmax > kMaxRotationLmax) {
      return absl::InvalidArgumentError(
          absl::StrCat("rotated lighting supports lmax <= ", kMaxRotationLmax, ", got ", lmax));
    }
  }
  return absl::OkStatus();
}

}  // namespace

Mat3 RotationFromYawPitchRoll(double yaw_deg, double pitch_deg, double roll_deg) {
  constexpr double kDeg = kPi / 180;
  return RotationY(yaw_deg * kDeg) * RotationX(pitch_deg * kDeg) * RotationZ(roll_deg * kDeg);
}

std::optional<Yaw> YawOf(const Mat3& world_rotation) {
  const auto& r = world_rotation.m;
  if (r[1][1] != 1 || r[0][1] != 0 || r[2][1] != 0 || r[1][0] != 0 || r[1][2] != 0) {
    return std::nullopt;
  }
  return Yaw{r[0][0], r[0][2]};
}

Mat3 WorldToShFrameMatrix() { return Mat3{{{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}}}; }

Mat3 ShFrameRotationFromWorld(const Mat3& world_rotation) {
  const Mat3 m = WorldToShFrameMatrix();
  return m * world_rotation * m.Transposed();
}

absl::Status RotateLighting(int lmax, const Mat3& world_rotation, std::span<double> rgb_coeffs) {
  if (lmax < 0 || lmax > kMaxRotationLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("rotated lighting needs 0 <= lmax <= ", kMaxRotationLmax, ", got ", lmax));
  }
  const size_t n = ShCount(lmax);
  if (rgb_coeffs.size() != n * kChannels) {
    return absl::InvalidArgumentError(absl::StrCat("expected ", n * kChannels,
                                                   " RGB coefficients for lmax ", lmax, ", got ",
                                                   rgb_coeffs.size()));
  }
  SHRM_RETURN_IF_ERROR(ValidateRotationMatrix(world_rotation));
  if (world_rotation.IsIdentity()) return absl::OkStatus();
  const Mat3 rot_s = ShFrameRotationFromWorld(world_rotation);
  std::vector<double> in(n), out(n);
  // A turn about the world's vertical (a yaw: a turntable, the viewer's --live rotate) is a turn
  // by the same angle about the SH frame's z axis (z_s = Y), diagonal per m (SHRM paper App. B):
  // O(lmax^2) instead of the zxzxz path's O(lmax^3) (and no operator to build).
  if (const std::optional<Yaw> yaw = YawOf(world_rotation)) {
    for (int c = 0; c < kChannels; ++c) {
      for (size_t i = 0; i < n; ++i) in[i] = rgb_coeffs[i * kChannels + c];
      RotateShZ(lmax, yaw->cos, yaw->sin, in, out);
      for (size_t i = 0; i < n; ++i) rgb_coeffs[i * kChannels + c] = out[i];
    }
    return absl::OkStatus();
  }
  for (int c = 0; c < kChannels; ++c) {
    for (size_t i = 0; i < n; ++i) in[i] = rgb_coeffs[i * kChannels + c];
    RotateSh(lmax, rot_s, in, out);
    for (size_t i = 0; i < n; ++i) rgb_coeffs[i * kChannels + c] = out[i];
  }
  return absl::OkStatus();
}

int LightingResampleWidth(const EnvMap& map, int lmax) {
  int w = std::max(map.NativeLatLongWidth(), 2 * lmax + 2);
  return w + (w % 2);
}

absl::StatusOr<std::vector<double>> LightingCoefficients(const EnvMap& map, int lmax,
                                                         const Mat3& world_rotation,
                                                         int num_threads,
                                                         ShtQuadrature quadrature) {
  SHRM_RETURN_IF_ERROR(CheckArgs(lmax, world_rotation, num_threads));
  std::vector<double> coeffs;
  if (const Image* img = map.lat_long_image()) {
    const ShtGrid grid{img->width, img->height, ShtGridKind::kEquiangular};
    if (lmax > ShtMaxDegree(grid)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "a ", img->width, " x ", img->height, " lat-long map resolves SH degrees up to ",
          ShtMaxDegree(grid), " (min(H - 1, (W - 1) / 2)), asked for ", lmax));
    }
    SHRM_ASSIGN_OR_RETURN(coeffs,
                          ForwardSht(grid, lmax, kChannels, img->pixels, num_threads, quadrature));
  } else {
    const int w = LightingResampleWidth(map, lmax);
    SHRM_ASSIGN_OR_RETURN(Image resampled, map.ToLatLong(w, num_threads));
    const ShtGrid grid{resampled.width, resampled.height, ShtGridKind::kEquiangular};
    SHRM_ASSIGN_OR_RETURN(
        coeffs, ForwardSht(grid, lmax, kChannels, resampled.pixels, num_threads, quadrature));
  }
  if (!world_rotation.IsIdentity()) {
    SHRM_RETURN_IF_ERROR(RotateLighting(lmax, world_rotation, coeffs));
  }
  return coeffs;
}

absl::StatusOr<std::vector<double>> LightingCoefficientsDirect(const EnvMap& map, int lmax,
                                                               const Mat3& world_rotation,
                                                               int num_threads) {
  SHRM_RETURN_IF_ERROR(CheckArgs(lmax, world_rotation, num_threads));
  const std::span<const EnvSample> samples = map.samples();
  const size_t n_coeff = ShCount(lmax);
  const int threads = static_cast<int>(
      std::clamp<size_t>(num_threads, 1, std::max<size_t>(1, samples.size() / 4096)));
  std::vector<std::vector<double>> partial(threads, std::vector<double>(n_coeff * kChannels, 0.0));
  auto work = [&](int t) {
    const size_t begin = samples.size() * t / threads, end = samples.size() * (t + 1) / threads;
    constexpr size_t kChunk = 512;
    std::vector<Vec3> dirs;
    std::vector<double> y;
    std::vector<double>& acc = partial[t];
    for (size_t c0 = begin; c0 < end; c0 += kChunk) {
      const size_t n = std::min(kChunk, end - c0);
      dirs.resize(n);
      for (size_t k = 0; k < n; ++k) dirs[k] = ShFrameFromWorld(samples[c0 + k].dir);
      y.resize(n_coeff * n);
      EvalShBatch(lmax, dirs, y);
      for (size_t i = 0; i < n_coeff; ++i) {
        double s[kChannels] = {0, 0, 0};
        const double* yi = &y[i * n];
        for (size_t k = 0; k < n; ++k) {
          const EnvSample& smp = samples[c0 + k];
          const double wy = yi[k] * smp.solid_angle;
          for (int c = 0; c < kChannels; ++c) s[c] += wy * smp.rgb[c];
        }
        for (int c = 0; c < kChannels; ++c) acc[i * kChannels + c] += s[c];
      }
    }
  };
  if (threads == 1) {
    work(0);
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(work, t);
    for (auto& th : pool) th.join();
  }
  std::vector<double> coeffs(n_coeff * kChannels, 0.0);
  for (const auto& p : partial)
    for (size_t i = 0; i < coeffs.size(); ++i) coeffs[i] += p[i];
  if (!world_rotation.IsIdentity()) {
    SHRM_RETURN_IF_ERROR(RotateLighting(lmax, world_rotation, coeffs));
  }
  return coeffs;
}

std::array<double, 3> LightingEnergy(const EnvMap& map) {
  std::array<double, 3> e{0, 0, 0};
  if (const Image* img = map.lat_long_image()) {
    // The lat-long samples' solid angles are one per ring (EnvMap::BuildSamples): the sum ring by
    // ring, without building the samples (a 1024 x 512 map's cost 30-60 ms and 24 MB).
    const RingQuadrature q = FejerFirstRule(img->height);
    const size_t w = static_cast<size_t>(img->width);
    // A ring's squares in 24 partial sums (eight pixels' values, each its own chain, so the loop
    // runs in vector lanes without reassociating a sum: one dependent chain per channel kept it
    // scalar), then added by channel.
    constexpr size_t kRun = 24;
    for (int j = 0; j < img->height; ++j) {
      const float* row = img->pixels.data() + j * w * 3;
      double part[kRun] = {};
      const size_t values = w * 3, whole = values / kRun * kRun;
      for (size_t i = 0; i < whole; i += kRun)
        for (size_t k = 0; k < kRun; ++k) part[k] += double{row[i + k]} * row[i + k];
      for (size_t i = whole; i < values; ++i) part[i % 3] += double{row[i]} * row[i];
      double ring[3] = {0, 0, 0};
      for (size_t k = 0; k < kRun; ++k) ring[k % 3] += part[k];
      const double omega = q.weight[j] * 2 * kPi / static_cast<double>(w);
      for (int c = 0; c < 3; ++c) e[c] += omega * ring[c];
    }
    return e;
  }
  for (const EnvSample& smp : map.samples())
    for (int c = 0; c < 3; ++c) e[c] += smp.solid_angle * double{smp.rgb[c]} * smp.rgb[c];
  return e;
}

}  // namespace shrm
