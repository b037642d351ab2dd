// The viewer's orbit camera: a perspective camera on a sphere around a target, in the world frame
// of docs/conventions.md (right-handed, +Y up).
//
//   eye = target + distance (cos(el) sin(az), sin(el), cos(el) cos(az)),
//
// so azimuth 0, elevation 0 looks from +Z towards -Z (at the centre of a lat-long map), positive
// azimuth moves the eye towards +X, positive elevation above the horizon. The image plane is
// right = normalize(forward x +Y), up = right x forward; pixel (x, y) of a W x H image (row 0 at
// the TOP, as images are stored) looks along
//   forward + right tan(fov/2) aspect ndc_x + up tan(fov/2) ndc_y,
//   ndc_x = 2 (x + 0.5)/W - 1, ndc_y = 1 - 2 (y + 0.5)/H,
// the same ray OpenGL rasterizes through the pixel centre with ProjectionMatrix() * ViewMatrix()
// (window row 0 at the bottom: the GL image is flipped when read back).
#ifndef SHRM_VIEWER_CAMERA_H_
#define SHRM_VIEWER_CAMERA_H_

#include <array>
#include <string>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"

namespace shrm::viewer {

// Column-major 4 x 4 matrix, as glUniformMatrix4fv takes it (transpose = GL_FALSE).
using Mat4f = std::array<float, 16>;

// Degrees of the orbit: --view azimuth,elevation[,distance].
struct OrbitView {
  double azimuth_deg = 30;
  double elevation_deg = 20;
  double distance = 3;
};

// Limits of OrbitView: |elevation| < 90 (the up vector is +Y), distance in (kMinDistance,
// kMaxDistance].
inline constexpr double kMaxElevationDeg = 89.5;
inline constexpr double kMinDistance = 1.05;  // the objects fit in the unit sphere
inline constexpr double kMaxDistance = 1000;

// Parses "azimuth,elevation[,distance]" (degrees, degrees, units); InvalidArgument naming `what`
// and the valid ranges.
[[nodiscard]] absl::StatusOr<OrbitView> ParseOrbitView(const std::string& text, const char* what);

class OrbitCamera {
 public:
  OrbitCamera() = default;
  explicit OrbitCamera(const OrbitView& view) : view_(view) {}

  const OrbitView& view() const { return view_; }
  void set_view(const OrbitView& view) { view_ = view; }
  double fov_y_deg() const { return fov_y_deg_; }
  void set_fov_y_deg(double fov) { fov_y_deg_ = fov; }

  // Interaction: add to azimuth / elevation (elevation clamped to +-kMaxElevationDeg), scale the
  // distance (clamped to the limits).
  void Orbit(double d_azimuth_deg, double d_elevation_deg);
  void Zoom(double factor);

  Vec3 Eye() const;
  Vec3 Forward() const;  // unit, eye -> target
  Vec3 Right() const;
  Vec3 Up() const;
  // The central view direction V of the image (towards the viewer): -Forward().
  Vec3 CentralView() const { return Forward() * -1.0; }

  // World direction (unit) through the centre of pixel (x, y), row 0 at the top.
  Vec3 PixelRay(double x, double y, int width, int height) const;

  Mat4f ViewMatrix() const;
  Mat4f ProjectionMatrix(double aspect) const;
  double near_plane() const;
  double far_plane() const;

 private:
  OrbitView view_;
  double fov_y_deg_ = 45;
};

Mat4f Multiply(const Mat4f& a, const Mat4f& b);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_CAMERA_H_
