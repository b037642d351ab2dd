#include "viewer/camera.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace shrm::viewer {
namespace {

double Radians(double deg) { return deg * kPi / 180; }

}  // namespace

absl::StatusOr<OrbitView> ParseOrbitView(const std::string& text, const char* what) {
  std::vector<std::string> parts = absl::StrSplit(text, ',');
  OrbitView v;
  double x[3] = {0, 0, v.distance};
  bool ok = parts.size() == 2 || parts.size() == 3;
  for (size_t i = 0; ok && i < parts.size(); ++i)
    ok = absl::SimpleAtod(parts[i], &x[i]) && std::isfinite(x[i]);
  if (!ok) {
    return absl::InvalidArgumentError(absl::StrCat(
        what, " must be azimuth,elevation[,distance] (degrees, degrees, units), got '", text, "'"));
  }
  if (std::abs(x[1]) > kMaxElevationDeg) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": elevation ", x[1],
                                                   " is out of range; valid range [-",
                                                   kMaxElevationDeg, ", ", kMaxElevationDeg, "]"));
  }
  if (!(x[2] >= kMinDistance && x[2] <= kMaxDistance)) {
    return absl::InvalidArgumentError(absl::StrCat(what, ": distance ", x[2],
                                                   " is out of range; valid range [", kMinDistance,
                                                   ", ", kMaxDistance, "]"));
  }
  v.azimuth_deg = x[0];
  v.elevation_deg = x[1];
  v.distance = x[2];
  return v;
}

void OrbitCamera::Orbit(double d_azimuth_deg, double d_elevation_deg) {
  view_.azimuth_deg = std::remainder(view_.azimuth_deg + d_azimuth_deg, 360.0);
  view_.elevation_deg =
      std::clamp(view_.elevation_deg + d_elevation_deg, -kMaxElevationDeg, kMaxElevationDeg);
}

void OrbitCamera::Zoom(double factor) {
  view_.distance = std::clamp(view_.distance * factor, kMinDistance, kMaxDistance);
}

Vec3 OrbitCamera::Eye() const {
  const double az = Radians(view_.azimuth_deg), el = Radians(view_.elevation_deg);
  return Vec3{std::cos(el) * std::sin(az), std::sin(el), std::cos(el) * std::cos(az)} *
         view_.distance;
}

Vec3 OrbitCamera::Forward() const { return (Eye() * -1.0).Normalized(); }
Vec3 OrbitCamera::Right() const { return Forward().Cross(Vec3{0, 1, 0}).Normalized(); }
Vec3 OrbitCamera::Up() const { return Right().Cross(Forward()); }

Vec3 OrbitCamera::PixelRay(double x, double y, int width, int height) const {
  const double t = std::tan(Radians(fov_y_deg_) / 2);
  const double aspect = static_cast<double>(width) / height;
  const double nx = 2 * (x + 0.5) / width - 1, ny = 1 - 2 * (y + 0.5) / height;
  return (Forward() + Right() * (t * aspect * nx) + Up() * (t * ny)).Normalized();
}

double OrbitCamera::near_plane() const { return std::max(0.01, view_.distance - 1.5) * 0.5; }
double OrbitCamera::far_plane() const { return view_.distance + 2; }

Mat4f OrbitCamera::ViewMatrix() const {
  const Vec3 f = Forward(), r = Right(), u = Up(), e = Eye();
  // Rows r, u, -f; translation -R e.
  Mat4f m{};
  const Vec3 rows[3] = {r, u, f * -1.0};
  for (int i = 0; i < 3; ++i) {
    m[0 * 4 + i] = static_cast<float>(rows[i].x);
    m[1 * 4 + i] = static_cast<float>(rows[i].y);
    m[2 * 4 + i] = static_cast<float>(rows[i].z);
    m[3 * 4 + i] = static_cast<float>(-rows[i].Dot(e));
  }
  m[15] = 1;
  return m;
}

Mat4f OrbitCamera::ProjectionMatrix(double aspect) const {
  const double f = 1 / std::tan(Radians(fov_y_deg_) / 2);
  const double n = near_plane(), fa = far_plane();
  Mat4f m{};
  m[0] = static_cast<float>(f / aspect);
  m[5] = static_cast<float>(f);
  m[10] = static_cast<float>((fa + n) / (n - fa));
  m[11] = -1;
  m[14] = static_cast<float>(2 * fa * n / (n - fa));
  return m;
}

Mat4f Multiply(const Mat4f& a, const Mat4f& b) {
  Mat4f r{};
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) {
      float s = 0;
      for (int k = 0; k < 4; ++k) s += a[k * 4 + row] * b[c * 4 + k];
      r[c * 4 + row] = s;
    }
  return r;
}

}  // namespace shrm::viewer
