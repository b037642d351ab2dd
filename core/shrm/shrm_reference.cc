#include "core/shrm/shrm_reference.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"

namespace shrm {
namespace {

constexpr int kBucketsPerSide = 8;
constexpr int kBucketCount = kCubeFaceCount * kBucketsPerSide * kBucketsPerSide;

int BucketOf(const Vec3& d) {
  int face;
  double s, t;
  CubeFaceCoordinates(d, &face, &s, &t);
  const int x = std::clamp(static_cast<int>(s * kBucketsPerSide), 0, kBucketsPerSide - 1);
  const int y = std::clamp(static_cast<int>(t * kBucketsPerSide), 0, kBucketsPerSide - 1);
  return (face * kBucketsPerSide + y) * kBucketsPerSide + x;
}

Vec3 AxisFor(const ReferenceOptions& o, const Vec3& n, const Vec3& v) {
  if (o.axis == ReferenceOptions::Axis::kNormal) return n;
  return n * (2 * n.Dot(v)) - v;
}

}  // namespace

double PhongConeAngle(double exponent, double eps) {
  return std::acos(std::pow(eps, 1.0 / (exponent + 1)));
}

std::array<double, 3> ReferenceRadiance(std::span<const EnvSample> samples,
                                        const TransferFunction& transfer, const Vec3& n,
                                        const Vec3& v) {
  std::array<double, 3> out{0, 0, 0};
  for (const EnvSample& s : samples)
    for (int c = 0; c < 3; ++c)
      out[c] += static_cast<double>(s.rgb[c]) * s.solid_angle * transfer(n, v, s.dir, c);
  return out;
}

std::array<double, 3> BrdfReferenceRadiance(std::span<const EnvSample> samples, const Brdf& brdf,
                                            const Mat3& rotation, const Vec3& index,
                                            const Vec3& view) {
  const Mat3 inv = rotation.Transposed();
  const int channels = brdf.channels();
  TransferFunction transfer = [&brdf, channels](const Vec3& n, const Vec3& v, const Vec3& w,
                                                int c) {
    return brdf.Transfer(n, v, w, channels == 1 ? 0 : c);
  };
  return ReferenceRadiance(samples, transfer, inv * index, inv * view);
}

absl::StatusOr<ReferenceIntegrator> ReferenceIntegrator::Create(
    std::span<const EnvSample> samples) {
  if (samples.empty()) return absl::InvalidArgumentError("reference: no environment samples");
  ReferenceIntegrator r;
  std::vector<int> bucket(samples.size());
  std::vector<int> count(kBucketCount + 1, 0);
  for (size_t i = 0; i < samples.size(); ++i) {
    const Vec3& d = samples[i].dir;
    const double norm = d.Norm();
    if (!std::isfinite(norm) || std::abs(norm - 1) > 1e-6) {
      return absl::InvalidArgumentError(
          absl::StrCat("reference: sample ", i, " has a non-unit direction (norm ", norm, ")"));
    }
    bucket[i] = BucketOf(d);
    ++count[bucket[i] + 1];
  }
  for (int b = 0; b < kBucketCount; ++b) count[b + 1] += count[b];
  r.bucket_begin_ = count;
  const size_t n = samples.size();
  r.dir_x_.resize(n);
  r.dir_y_.resize(n);
  r.dir_z_.resize(n);
  r.rad_.resize(3 * n);
  std::vector<int> fill(count.begin(), count.end() - 1);
  for (size_t i = 0; i < n; ++i) {
    const int k = fill[bucket[i]]++;
    const EnvSample& s = samples[i];
    r.dir_x_[k] = s.dir.x;
    r.dir_y_[k] = s.dir.y;
    r.dir_z_[k] = s.dir.z;
    for (int c = 0; c < 3; ++c) r.rad_[3 * k + c] = static_cast<double>(s.rgb[c]) * s.solid_angle;
  }
  r.bucket_centre_.resize(kBucketCount);
  r.bucket_radius_.assign(kBucketCount, 0.0);
  for (int b = 0; b < kBucketCount; ++b) {
    Vec3 sum;
    for (int k = r.bucket_begin_[b]; k < r.bucket_begin_[b + 1]; ++k)
      sum = sum + Vec3{r.dir_x_[k], r.dir_y_[k], r.dir_z_[k]};
    if (sum.Norm() == 0) continue;
    const Vec3 c = sum.Normalized();
    r.bucket_centre_[b] = c;
    double min_dot = 1;
    for (int k = r.bucket_begin_[b]; k < r.bucket_begin_[b + 1]; ++k)
      min_dot = std::min(min_dot, c.Dot(Vec3{r.dir_x_[k], r.dir_y_[k], r.dir_z_[k]}));
    r.bucket_radius_[b] = std::acos(std::clamp(min_dot, -1.0, 1.0)) + 1e-9;
  }
  return r;
}

std::vector<double> ReferenceIntegrator::CosLimits(double cone_angle) const {
  std::vector<double> lim(kBucketCount);
  for (int b = 0; b < kBucketCount; ++b) {
    const double a = cone_angle + bucket_radius_[b];
    lim[b] = a >= kPi ? -2.0 : std::cos(a);
  }
  return lim;
}

std::array<double, 3> ReferenceIntegrator::Sum(const TransferFunction& transfer, const Vec3& n,
                                               const Vec3& v, const Vec3& axis, double cos_cone,
                                               bool grey,
                                               std::span<const double> cos_limits) const {
  std::array<double, 3> out{0, 0, 0};
  for (int b = 0; b < kBucketCount; ++b) {
    const int begin = bucket_begin_[b], end = bucket_begin_[b + 1];
    if (begin == end) continue;
    if (cos_limits[b] > -1.5 && bucket_centre_[b].Dot(axis) < cos_limits[b]) continue;
    for (int k = begin; k < end; ++k) {
      const Vec3 w{dir_x_[k], dir_y_[k], dir_z_[k]};
      if (w.Dot(axis) < cos_cone) continue;
      if (grey) {
        const double t = transfer(n, v, w, 0);
        if (t == 0) continue;
        for (int c = 0; c < 3; ++c) out[c] += rad_[3 * k + c] * t;
      } else {
        for (int c = 0; c < 3; ++c) out[c] += rad_[3 * k + c] * transfer(n, v, w, c);
      }
    }
  }
  return out;
}

std::array<double, 3> ReferenceIntegrator::Radiance(const TransferFunction& transfer, const Vec3& n,
                                                    const Vec3& v,
                                                    const ReferenceOptions& options) const {
  const bool full = options.cone_angle >= kPi;
  const std::vector<double> lim =
      full ? std::vector<double>(kBucketCount, -2.0) : CosLimits(options.cone_angle);
  return Sum(transfer, n, v, AxisFor(options, n, v), full ? -2.0 : std::cos(options.cone_angle),
             options.grey, lim);
}

size_t ReferenceIntegrator::VisitedSamples(const Vec3& axis, double cone_angle) const {
  const double cos_cone = cone_angle >= kPi ? -2.0 : std::cos(cone_angle);
  size_t n = 0;
  for (size_t k = 0; k < dir_x_.size(); ++k)
    if (Vec3{dir_x_[k], dir_y_[k], dir_z_[k]}.Dot(axis) >= cos_cone) ++n;
  return n;
}

absl::StatusOr<RadianceCube> ReferenceIntegrator::ReflectionMap(const TransferFunction& transfer,
                                                                const Vec3& view, int face_size,
                                                                const ReferenceOptions& options,
                                                                int texel_stride) const {
  if (face_size < 1 || options.threads < 1 || texel_stride < 1) {
    return absl::InvalidArgumentError(absl::StrCat("reference map: face size ", face_size,
                                                   ", threads ", options.threads, ", texel stride ",
                                                   texel_stride));
  }
  RadianceCube cube;
  cube.face_size = face_size;
  cube.channels = 3;
  cube.data.assign(cube.size(), 0.0f);
  const bool full = options.cone_angle >= kPi;
  const std::vector<double> lim =
      full ? std::vector<double>(kBucketCount, -2.0) : CosLimits(options.cone_angle);
  const double cos_cone = full ? -2.0 : std::cos(options.cone_angle);
  const int rows = kCubeFaceCount * face_size;
  auto work = [&](int t, int nt) {
    for (int row = t; row < rows; row += nt) {
      const int face = row / face_size, y = row % face_size;
      if (y % texel_stride) continue;
      for (int x = 0; x < face_size; x += texel_stride) {
        const Vec3 r = CubeTexelDirection(face, x, y, face_size);
        const Vec3 h = r + view;
        if (h.Norm() < 1e-9) continue;
        const Vec3 n = h.Normalized();
        const std::array<double, 3> b =
            Sum(transfer, n, view, AxisFor(options, n, view), cos_cone, options.grey, lim);
        for (int c = 0; c < 3; ++c) cube.data[cube.Index(face, x, y, c)] = static_cast<float>(b[c]);
      }
    }
  };
  if (options.threads == 1) {
    work(0, 1);
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < options.threads; ++t) pool.emplace_back(work, t, options.threads);
    for (auto& th : pool) th.join();
  }
  return cube;
}

}  // namespace shrm
