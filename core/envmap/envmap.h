// Environment maps: layouts, colour conversion to the linear working space, radiance samples
// for brute-force integration, and SH lighting coefficients L_lm (SHRM paper eqs. 5.20-5.21; the
// coefficients live in core/envmap/lighting.h).
//
// Every layout is decoded to radiance samples in the WORLD frame of docs/conventions.md
// (right-handed, +Y up; lat-long pixel (i, j) -> d = (sin t sin p, cos t, -sin t cos p)).
// Cube maps use the OpenGL face order and orientation (+X, -X, +Y, -Y, +Z, -Z; the GL
// specification's major-axis table, core/base/cubemap.h). docs/envmap.md states every layout
// precisely; in short (S = face size, images rows from the top):
//  - kLatLong (2:1): docs/conventions.md. Samples: pixel centres, solid angle = Fejer-1 ring
//    weight x 2 pi / W (the quadrature rule of the transform; sums to 4 pi).
//  - kCubeFaces: six S x S files in GL order; each face image as glTexImage2D uploads it (row 0 is
//    t = 0 of the GL table). Samples: texel centres, exact texel solid angles.
//  - kHorizontalCross (4S x 3S): cells (column, row) +Y (1,0); -X (0,1), +Z (1,1), +X (2,1),
//    -Z (3,1); -Y (1,2). Every face stored as in kCubeFaces (the cross is a continuous unfolding).
//  - kVerticalCross (3S x 4S): +Y (1,0); -X (0,1), +Z (1,1), +X (2,1); -Y (1,2); -Z (1,3)
//    stored ROTATED BY 180 degrees (cell pixel (x, y) = face texel (S-1-x, S-1-y)), which keeps
//    the -Y / -Z edge continuous. Other cells are ignored.
//  - kHorizontalStrip (6S x S) / kVerticalStrip (S x 6S): the six faces in GL order, left to
//    right / top to bottom, each stored as in kCubeFaces.
//  - kAngular (D x D, Debevec light probe): the centre looks down -Z, +X is to the right, +Y up.
//    Pixel (i, j) -> (u, v) = (2 (i + 0.5)/D - 1, 1 - 2 (j + 0.5)/D) in the unit disc; with
//    rho = |(u, v)| <= 1 the direction is d = (sin(pi rho) u/rho, sin(pi rho) v/rho,
//    -cos(pi rho)); conversely r = acos(-d_z) / (pi sqrt(d_x^2 + d_y^2)), (u, v) = (d_x r, d_y r).
//    Pixels whose centre lies outside the disc are not part of the map. Samples: solid angle =
//    Jacobian pi sin(pi rho) / rho x pixel area (4 / D^2) at the pixel centre.
//
// Colour: pixels are converted from the input colour space to the working space (core/io/colour.h)
// when the map is loaded; an EnvMap always holds working-space linear RGB.
#ifndef SHRM_CORE_ENVMAP_ENVMAP_H_
#define SHRM_CORE_ENVMAP_ENVMAP_H_

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/io/image.h"

namespace shrm {

enum class EnvLayout {
  kAuto,             // from the aspect ratio (and the number of files)
  kLatLong,          // 2:1 equirectangular
  kCubeFaces,        // six square files in GL order +X, -X, +Y, -Y, +Z, -Z
  kHorizontalCross,  // 4:3
  kVerticalCross,    // 3:4
  kHorizontalStrip,  // 6:1, faces in GL order
  kVerticalStrip,    // 1:6, faces in GL order
  kAngular,          // 1:1 Debevec angular map (light probe)
};

// Short names used on the command line and in messages: "auto", "latlong", "cube", "hcross",
// "vcross", "hstrip", "vstrip", "angular".
const char* EnvLayoutName(EnvLayout layout);
// Parses a short name (case-insensitive; also accepts "lat-long", "equirect", "cubefaces",
// "probe"). InvalidArgument listing the valid names otherwise.
absl::StatusOr<EnvLayout> ParseEnvLayout(std::string_view name);

// One radiance sample of a decoded map: world direction (unit), solid angle (sr) and linear RGB
// in the working space. The samples of a map integrate the sphere: sum of solid angles = 4 pi
// (to the accuracy of the layout's texel solid-angle formula).
struct EnvSample {
  Vec3 dir;
  double solid_angle = 0;
  std::array<float, 3> rgb{};
};

struct EnvMapOptions {
  // One file, or six files (GL order +X, -X, +Y, -Y, +Z, -Z) for kCubeFaces.
  std::vector<std::string> paths;
  // kAuto: six files -> kCubeFaces; one file -> by aspect ratio (2:1 lat-long, 4:3 / 3:4 cross,
  // 6:1 / 1:6 strip, 1:1 angular).
  EnvLayout layout = EnvLayout::kAuto;
  // Colour space of the input pixels; "" = per file from the pixel type (float/half:
  // "lin_rec709", integer (8/16-bit PNG, TIFF): "srgb_texture"). See core/io/colour.h.
  std::string input_colour_space;
  // Linear working space of the decoded map.
  std::string working_colour_space = "lin_rec709";
  // OCIO config file; "" = $OCIO, then the built-in config (core/io/colour.h).
  std::string colour_config;
  ImageLimits limits;
  // NaN/Inf pixels: rejected (error naming the file and the first position) or replaced by 0.
  NonFinitePolicy non_finite = NonFinitePolicy::kReject;
};

// A decoded environment map in one of the layouts, in the working colour space. Immutable;
// copies share the (lazily built) sample list. Thread-safe for concurrent const use.
class EnvMap {
 public:
  // Reads, validates, colour-converts and decodes the file(s). Errors name the file:
  // NotFound (missing file, e.g. one of six faces), InvalidArgument (a size that fits no layout or
  // not the requested one, unequal or non-square cube faces, a wrong number of files, an unknown
  // colour space, NaN/Inf pixels under kReject), and ReadImageRgb()'s errors.
  static absl::StatusOr<EnvMap> Load(const EnvMapOptions& options);

  // A lat-long map from pixels already in the working space (any W x H >= 1; 3 channels, or 1
  // channel expanded to grey). Aborts on an inconsistent Image (programming error).
  static EnvMap FromLatLong(Image image);

  // A map in `layout` from images already in the working space: six images for kCubeFaces, one
  // otherwise (kAuto detects from the sizes). `names` (optional, one per image) are used in error
  // messages. Same size errors as Load().
  static absl::StatusOr<EnvMap> FromImages(std::vector<Image> images, EnvLayout layout,
                                           const std::vector<std::string>& names = {});

  EnvLayout layout() const { return layout_; }
  // Size of the input image (for kCubeFaces: of one face file).
  int width() const { return width_; }
  int height() const { return height_; }
  // Face size S of the cube-based layouts (cube faces, crosses, strips); 0 for lat-long and
  // angular maps.
  int face_size() const { return face_size_; }
  // Non-finite values replaced by 0 when loading (NonFinitePolicy::kReplaceZero).
  int64_t replaced_non_finite() const { return replaced_non_finite_; }

  // One sample per native pixel (lat-long: row-major; cube-based layouts: face-major in GL order,
  // then rows, then columns of the face in GL orientation; angular: row-major, pixels inside the
  // disc only). Built on first use (about 48 bytes per pixel) and kept.
  std::span<const EnvSample> samples() const;
  // The same samples, in the same order, handed to `fn` one at a time without being kept (for a
  // caller that stores its own form of them: no 48 bytes per pixel).
  void ForEachSample(absl::FunctionRef<void(const EnvSample&)> fn) const;
  // How many samples there are (the length of samples()).
  size_t sample_count() const;
  // Sum of the samples' solid angles (4 pi up to the layout's quadrature accuracy).
  double TotalSolidAngle() const;

  // Radiance towards a (nonzero, not necessarily unit) world direction, bilinear in the native
  // layout: lat-long wraps in azimuth and clamps at the poles; cube faces clamp at face edges;
  // the angular map uses only taps whose centres lie inside the disc.
  std::array<float, 3> Radiance(const Vec3& world_dir) const;

  // World direction of pixel (x, y) of input image `image` (0, or 0..5 for kCubeFaces), or
  // nullopt for a pixel that holds no direction (outside the angular disc, an empty cross cell,
  // out of range).
  std::optional<Vec3> PixelDirection(int image, int x, int y) const;

  // Resamples to a W x W/2 lat-long grid (W even, >= 2) by bilinear lookup (Radiance) at every
  // pixel centre, rows split over `num_threads` threads. A lat-long map of the same size is
  // returned unchanged. InvalidArgument for a bad width or num_threads < 1.
  absl::StatusOr<Image> ToLatLong(int width, int num_threads = 1) const;

  // Lat-long width that resolves the native layout about as finely as it is sampled: W for
  // lat-long maps, 4 S for cube-based layouts (the face-centre texel pitch pi / (2 S)), 2 D for
  // the angular map (twice its coarsest pitch 2 pi / D).
  int NativeLatLongWidth() const;

  // The lat-long image (layout() == kLatLong), else nullptr.
  const Image* lat_long_image() const {
    return layout_ == EnvLayout::kLatLong ? &(*images_)[0] : nullptr;
  }
  // The lat-long image's pixels (layout() == kLatLong, else null), owned with the map: a holder
  // keeps them alive after the map is gone (copies of a map share its images, which no method
  // changes).
  std::shared_ptr<const float> lat_long_pixels() const {
    if (layout_ != EnvLayout::kLatLong) return nullptr;
    return std::shared_ptr<const float>(images_, (*images_)[0].pixels.data());
  }
  // Radiance() of a lat-long map at polar angle theta from +Y and azimuth phi = atan2(x, -z)
  // (the angles Radiance() computes from a direction; docs/conventions.md), for callers that
  // have them already (layout() must be kLatLong).
  std::array<float, 3> LatLongRadianceAt(double theta, double phi) const;
  // The same at n points, theta[k] and phi[k] + phi_offset, into out[3 k .. 3 k + 2]: equal to
  // LatLongRadianceAt point by point (one call per row of a cube face instead of one per texel).
  void LatLongRadianceAt(const double* theta, const double* phi, double phi_offset, int n,
                         float* out) const;

 private:
  EnvMap() = default;
  struct Lazy;
  void BuildSamples(std::vector<EnvSample>* out) const;
  std::array<float, 3> CubeRadiance(const Vec3& d) const;
  std::array<float, 3> LatLongRadiance(const Vec3& d) const;
  std::array<float, 3> AngularRadiance(const Vec3& d) const;

  EnvLayout layout_ = EnvLayout::kLatLong;
  int width_ = 0, height_ = 0, face_size_ = 0;
  int64_t replaced_non_finite_ = 0;
  // Lat-long / angular: one image; cube-based layouts: the six faces in GL order and orientation.
  // Shared by copies of the map (set when it is made, never changed after).
  std::shared_ptr<std::vector<Image>> images_ = std::make_shared<std::vector<Image>>();
  std::shared_ptr<Lazy> lazy_;
};

// Debevec angular-map mapping (see the header comment): unit-disc coordinates of a nonzero
// direction (d = +Z, the rim, gives (1, 0)), and the direction of a disc point (nullopt outside
// the unit disc).
std::array<double, 2> AngularMapCoordinates(const Vec3& world_dir);
std::optional<Vec3> AngularMapDirection(double u, double v);

// The samples of a lat-long map by index (EnvMap::ForEachSample's order and values, computed
// when asked from per-row and per-column tables), for a caller that visits them out of order
// without the 48 bytes per pixel of EnvMap::samples(). `map` must be lat-long (3 channels) and
// outlive the sampler.
class LatLongSampler {
 public:
  explicit LatLongSampler(const EnvMap& map);
  size_t size() const { return static_cast<size_t>(width_) * height_; }
  EnvSample At(size_t i) const {
    return At(static_cast<int>(i % width_), static_cast<int>(i / width_));
  }
  int width() const { return width_; }
  int height() const { return height_; }
  const float* pixels() const { return pixels_; }  // RGB, row-major
  // A sample's direction is (RowSin(row) ColSin(col), RowCos(row), -RowSin(row) ColCos(col)).
  double RowSin(int row) const { return row_sin_[row]; }
  double RowCos(int row) const { return row_cos_[row]; }
  double RowSolidAngle(int row) const { return row_omega_[row]; }
  double ColSin(int col) const { return col_sin_[col]; }
  double ColCos(int col) const { return col_cos_[col]; }
  EnvSample At(int col, int row) const {
    EnvSample s;
    s.dir = {row_sin_[row] * col_sin_[col], row_cos_[row], -row_sin_[row] * col_cos_[col]};
    s.solid_angle = row_omega_[row];
    const float* px = pixels_ + (static_cast<size_t>(row) * width_ + col) * 3;
    s.rgb = {px[0], px[1], px[2]};
    return s;
  }

 private:
  const float* pixels_;
  int width_, height_;
  std::vector<double> row_sin_, row_cos_, row_omega_, col_sin_, col_cos_;
};

}  // namespace shrm

#endif  // SHRM_CORE_ENVMAP_ENVMAP_H_
