#include "core/envmap/envmap.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <thread>
#include <utility>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/io/colour.h"
#include "core/sh/quadrature.h"

namespace shrm {

struct EnvMap::Lazy {
  std::once_flag once;
  std::vector<EnvSample> samples;
};

namespace {

constexpr const char* kGlFaceLabel[kCubeFaceCount] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};

// Where face f sits in a cube-based single image: cell (column, row) in units of S, and whether
// the face is stored rotated by 180 degrees.
struct Cell {
  int col = 0, row = 0;
  bool rot180 = false;
};

Cell FaceCell(EnvLayout layout, int face) {
  switch (layout) {
    case EnvLayout::kHorizontalCross: {
      static constexpr Cell kCells[6] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
      return kCells[face];
    }
    case EnvLayout::kVerticalCross: {
      static constexpr Cell kCells[6] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {1, 3, true}};
      return kCells[face];
    }
    case EnvLayout::kHorizontalStrip:
      return {face, 0};
    case EnvLayout::kVerticalStrip:
      return {0, face};
    default:
      return {0, 0};
  }
}

// Cells per (width, height) of the single-image layouts.
std::pair<int, int> LayoutCells(EnvLayout layout) {
  switch (layout) {
    case EnvLayout::kLatLong:
      return {2, 1};
    case EnvLayout::kHorizontalCross:
      return {4, 3};
    case EnvLayout::kVerticalCross:
      return {3, 4};
    case EnvLayout::kHorizontalStrip:
      return {6, 1};
    case EnvLayout::kVerticalStrip:
      return {1, 6};
    default:
      return {1, 1};
  }
}

const char* LayoutDescription(EnvLayout layout) {
  switch (layout) {
    case EnvLayout::kLatLong:
      return "lat-long (2:1)";
    case EnvLayout::kHorizontalCross:
      return "horizontal cross (4:3, 4 S x 3 S)";
    case EnvLayout::kVerticalCross:
      return "vertical cross (3:4, 3 S x 4 S)";
    case EnvLayout::kHorizontalStrip:
      return "horizontal strip (6:1, 6 S x S)";
    case EnvLayout::kVerticalStrip:
      return "vertical strip (1:6, S x 6 S)";
    case EnvLayout::kAngular:
      return "angular map (1:1, square)";
    case EnvLayout::kCubeFaces:
      return "cube face (1:1, square)";
    default:
      return "auto";
  }
}

constexpr char kExpectedRatios[] =
    "expected 2:1 lat-long, 4:3 horizontal cross, 3:4 vertical cross, 6:1 horizontal strip, "
    "1:6 vertical strip or 1:1 angular map (or six square files for a cube map)";

bool Fits(EnvLayout layout, int w, int h) {
  const auto [cw, ch] = LayoutCells(layout);
  // w / cw == h / ch == S with both divisions exact.
  return w % cw == 0 && h % ch == 0 && w / cw == h / ch && w / cw >= 1;
}

// Layout of a single image of size w x h: `requested` checked, or detected for kAuto.
absl::StatusOr<EnvLayout> SingleImageLayout(EnvLayout requested, int w, int h,
                                            const std::string& name) {
  if (requested == EnvLayout::kAuto) {
    for (EnvLayout l :
         {EnvLayout::kLatLong, EnvLayout::kHorizontalCross, EnvLayout::kVerticalCross,
          EnvLayout::kHorizontalStrip, EnvLayout::kVerticalStrip, EnvLayout::kAngular}) {
      if (Fits(l, w, h)) return l;
    }
    return absl::InvalidArgumentError(absl::StrCat(
        name, ": ", w, " x ", h, " matches no environment-map layout; ", kExpectedRatios));
  }
  if (requested == EnvLayout::kCubeFaces) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ": the cube-face layout needs six files (+X, -X, +Y, -Y, +Z, -Z), got one"));
  }
  // Lat-long maps are accepted at any size when asked for explicitly (the mapping is defined for
  // every W x H); the others must fit exactly.
  if (requested == EnvLayout::kLatLong || Fits(requested, w, h)) return requested;
  return absl::InvalidArgumentError(
      absl::StrCat(name, ": ", w, " x ", h, " is not a ", LayoutDescription(requested), " image"));
}

float* PixelPtr(Image& img, int x, int y) {
  return &img.pixels[(static_cast<size_t>(y) * img.width + x) * 3];
}
const float* PixelPtr(const Image& img, int x, int y) {
  return &img.pixels[(static_cast<size_t>(y) * img.width + x) * 3];
}

// Returns an RGB copy of `img` (1 channel -> grey, >= 3 -> the first three), or an error.
absl::StatusOr<Image> ToRgb(Image img, const std::string& name) {
  if (img.width <= 0 || img.height <= 0 || img.channels <= 0 ||
      img.pixels.size() != static_cast<size_t>(img.width) * img.height * img.channels) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": inconsistent image (", img.width, " x ",
                                                   img.height, " x ", img.channels, ")"));
  }
  if (img.channels == 3) return img;
  Image out;
  out.width = img.width;
  out.height = img.height;
  out.channels = 3;
  out.replaced_non_finite = img.replaced_non_finite;
  out.pixels.resize(static_cast<size_t>(img.width) * img.height * 3);
  const size_t n = static_cast<size_t>(img.width) * img.height;
  for (size_t p = 0; p < n; ++p) {
    for (int c = 0; c < 3; ++c) {
      const int src = img.channels >= 3 ? c : 0;
      out.pixels[p * 3 + c] = img.pixels[p * img.channels + src];
    }
  }
  return out;
}

// Bilinear lookup with pixel centres at integer (x, y); x wraps (period W) or clamps; y clamps.
std::array<float, 3> Bilinear(const Image& img, double x, double y, bool wrap_x) {
  const int w = img.width, h = img.height;
  y = std::clamp(y, 0.0, static_cast<double>(h - 1));
  if (!wrap_x) x = std::clamp(x, 0.0, static_cast<double>(w - 1));
  const double fx0 = std::floor(x), fy0 = std::floor(y);
  const double ax = x - fx0, ay = y - fy0;
  int x0 = static_cast<int>(fx0), y0 = static_cast<int>(fy0);
  int x1 = x0 + 1, y1 = std::min(y0 + 1, h - 1);
  if (wrap_x) {
    // x0 is almost always in [-1, w - 1] (an azimuth in [-pi, pi]): compares instead of integer
    // divisions, which took most of a lookup's time.
    x0 = x0 >= 0 && x0 < w ? x0 : x0 < 0 && x0 >= -w ? x0 + w : ((x0 % w) + w) % w;
    x1 = x0 + 1 < w ? x0 + 1 : 0;
  } else {
    x1 = std::min(x1, w - 1);
  }
  const float* p00 = PixelPtr(img, x0, y0);
  const float* p10 = PixelPtr(img, x1, y0);
  const float* p01 = PixelPtr(img, x0, y1);
  const float* p11 = PixelPtr(img, x1, y1);
  std::array<float, 3> out;
  for (int c = 0; c < 3; ++c) {
    const double top = (1 - ax) * p00[c] + ax * p10[c];
    const double bottom = (1 - ax) * p01[c] + ax * p11[c];
    out[c] = static_cast<float>((1 - ay) * top + ay * bottom);
  }
  return out;
}

// Disc coordinate of pixel centre i of a D-pixel-wide angular map.
double AngularCoord(int i, int d) { return 2.0 * (i + 0.5) / d - 1.0; }

}  // namespace

const char* EnvLayoutName(EnvLayout layout) {
  switch (layout) {
    case EnvLayout::kAuto:
      return "auto";
    case EnvLayout::kLatLong:
      return "latlong";
    case EnvLayout::kCubeFaces:
      return "cube";
    case EnvLayout::kHorizontalCross:
      return "hcross";
    case EnvLayout::kVerticalCross:
      return "vcross";
    case EnvLayout::kHorizontalStrip:
      return "hstrip";
    case EnvLayout::kVerticalStrip:
      return "vstrip";
    case EnvLayout::kAngular:
      return "angular";
  }
  return "?";
}

absl::StatusOr<EnvLayout> ParseEnvLayout(std::string_view name) {
  const std::string n = absl::AsciiStrToLower(std::string(name));
  for (EnvLayout l :
       {EnvLayout::kAuto, EnvLayout::kLatLong, EnvLayout::kCubeFaces, EnvLayout::kHorizontalCross,
        EnvLayout::kVerticalCross, EnvLayout::kHorizontalStrip, EnvLayout::kVerticalStrip,
        EnvLayout::kAngular}) {
    if (n == EnvLayoutName(l)) return l;
  }
  if (n == "lat-long" || n == "equirect" || n == "equirectangular") return EnvLayout::kLatLong;
  if (n == "cubefaces" || n == "faces") return EnvLayout::kCubeFaces;
  if (n == "probe" || n == "lightprobe") return EnvLayout::kAngular;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown environment-map layout '", std::string(name),
                   "'; valid: auto, latlong, cube, hcross, vcross, hstrip, vstrip, angular"));
}

std::array<double, 2> AngularMapCoordinates(const Vec3& world_dir) {
  const Vec3 d = world_dir.Normalized();
  const double q = std::hypot(d.x, d.y);
  if (q == 0) return d.z <= 0 ? std::array<double, 2>{0, 0} : std::array<double, 2>{1, 0};
  // Angle from -Z, accurate near both poles; r = angle / (pi q).
  const double r = std::atan2(q, -d.z) / (kPi * q);
  return {d.x * r, d.y * r};
}

std::optional<Vec3> AngularMapDirection(double u, double v) {
  const double rho = std::hypot(u, v);
  if (rho > 1) return std::nullopt;
  if (rho == 0) return Vec3{0, 0, -1};
  const double s = std::sin(kPi * rho) / rho;
  return Vec3{s * u, s * v, -std::cos(kPi * rho)};
}

EnvMap EnvMap::FromLatLong(Image image) {
  auto rgb = ToRgb(std::move(image), "lat-long image");
  if (!rgb.ok()) {
    std::fprintf(stderr, "EnvMap::FromLatLong: %s\n", std::string(rgb.status().message()).c_str());
    std::abort();
  }
  EnvMap map;
  map.layout_ = EnvLayout::kLatLong;
  map.width_ = rgb->width;
  map.height_ = rgb->height;
  map.replaced_non_finite_ = rgb->replaced_non_finite;
  map.images_->push_back(*std::move(rgb));
  map.lazy_ = std::make_shared<Lazy>();
  return map;
}

absl::StatusOr<EnvMap> EnvMap::FromImages(std::vector<Image> images, EnvLayout layout,
                                          const std::vector<std::string>& names) {
  auto name_of = [&](size_t i) {
    if (i < names.size()) return names[i];
    return images.size() == 6 ? absl::StrCat("cube face ", kGlFaceLabel[i], " (image ", i, ")")
                              : absl::StrCat("image ", i);
  };
  EnvMap map;
  map.lazy_ = std::make_shared<Lazy>();
  for (size_t i = 0; i < images.size(); ++i) {
    SHRM_ASSIGN_OR_RETURN(images[i], ToRgb(std::move(images[i]), name_of(i)));
    map.replaced_non_finite_ += images[i].replaced_non_finite;
  }
  if (images.size() == 6) {
    if (layout != EnvLayout::kAuto && layout != EnvLayout::kCubeFaces) {
      return absl::InvalidArgumentError(absl::StrCat("six images given but layout '",
                                                     EnvLayoutName(layout),
                                                     "' takes one (six files are cube faces)"));
    }
    const int s = images[0].width;
    for (size_t i = 0; i < 6; ++i) {
      if (images[i].width != images[i].height || images[i].width != s) {
        return absl::InvalidArgumentError(
            absl::StrCat(name_of(i), ": cube face is ", images[i].width, " x ", images[i].height,
                         "; all six faces must be square and of the same size (", name_of(0),
                         " is ", images[0].width, " x ", images[0].height, ")"));
      }
    }
    map.layout_ = EnvLayout::kCubeFaces;
    map.width_ = map.height_ = map.face_size_ = s;
    *map.images_ = std::move(images);
    return map;
  }
  if (images.size() != 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "an environment map is one image or six cube faces, got ", images.size(), " images"));
  }
  Image& img = images[0];
  SHRM_ASSIGN_OR_RETURN(map.layout_, SingleImageLayout(layout, img.width, img.height, name_of(0)));
  map.width_ = img.width;
  map.height_ = img.height;
  if (map.layout_ == EnvLayout::kLatLong || map.layout_ == EnvLayout::kAngular) {
    map.images_->push_back(std::move(img));
    return map;
  }
  const int s = img.width / LayoutCells(map.layout_).first;
  map.face_size_ = s;
  map.images_->resize(6);
  for (int f = 0; f < 6; ++f) {
    const Cell cell = FaceCell(map.layout_, f);
    Image& face = (*map.images_)[f];
    face.width = face.height = s;
    face.channels = 3;
    face.pixels.resize(static_cast<size_t>(s) * s * 3);
    for (int y = 0; y < s; ++y) {
      for (int x = 0; x < s; ++x) {
        const int fx = cell.rot180 ? s - 1 - x : x, fy = cell.rot180 ? s - 1 - y : y;
        const float* src = PixelPtr(img, cell.col * s + x, cell.row * s + y);
        std::copy(src, src + 3, PixelPtr(face, fx, fy));
      }
    }
  }
  return map;
}

absl::StatusOr<EnvMap> EnvMap::Load(const EnvMapOptions& options) {
  const auto& paths = options.paths;
  if (paths.size() != 1 && paths.size() != 6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "an environment map is one file or six cube-face files (+X, -X, +Y, -Y, +Z, -Z), got ",
        paths.size(), " files"));
  }
  if (paths.size() == 6 && options.layout != EnvLayout::kAuto &&
      options.layout != EnvLayout::kCubeFaces) {
    return absl::InvalidArgumentError(absl::StrCat("six files given but layout '",
                                                   EnvLayoutName(options.layout),
                                                   "' takes one (six files are cube faces)"));
  }
  std::vector<std::string> names;
  for (size_t i = 0; i < paths.size(); ++i) {
    names.push_back(paths.size() == 6 ? absl::StrCat(paths[i], " (cube face ", kGlFaceLabel[i], ")")
                                      : paths[i]);
    std::error_code ec;
    if (!std::filesystem::exists(paths[i], ec)) {
      return absl::NotFoundError(absl::StrCat(names[i], ": file not found"));
    }
  }
  // Validate names of the colour spaces and the layout from the headers before decoding pixels.
  SHRM_RETURN_IF_ERROR(ConvertColourSpace(
      {}, options.input_colour_space.empty() ? std::string(kLinRec709) : options.input_colour_space,
      options.working_colour_space, options.colour_config));
  std::vector<ImageHeader> headers;
  for (size_t i = 0; i < paths.size(); ++i) {
    auto header = ProbeImage(paths[i], options.limits);
    if (!header.ok()) return header.status();
    headers.push_back(*header);
  }
  if (paths.size() == 1) {
    SHRM_RETURN_IF_ERROR(
        SingleImageLayout(options.layout, headers[0].width, headers[0].height, names[0]).status());
  } else {
    for (size_t i = 0; i < 6; ++i) {
      if (headers[i].width != headers[i].height || headers[i].width != headers[0].width) {
        return absl::InvalidArgumentError(
            absl::StrCat(names[i], ": cube face is ", headers[i].width, " x ", headers[i].height,
                         "; all six faces must be square and of the same size (", names[0], " is ",
                         headers[0].width, " x ", headers[0].height, ")"));
      }
    }
  }
  std::vector<Image> images;
  for (size_t i = 0; i < paths.size(); ++i) {
    SHRM_ASSIGN_OR_RETURN(Image img, ReadImageRgb(paths[i], options.limits, options.non_finite));
    std::string from = options.input_colour_space;
    if (from.empty()) {
      SHRM_ASSIGN_OR_RETURN(from, DefaultInputColourSpace(paths[i], options.limits));
    }
    absl::Status st = ConvertColourSpace(std::span<float>(img.pixels), from,
                                         options.working_colour_space, options.colour_config);
    if (!st.ok()) return absl::Status(st.code(), absl::StrCat(names[i], ": ", st.message()));
    images.push_back(std::move(img));
  }
  return FromImages(std::move(images), options.layout, names);
}

std::span<const EnvSample> EnvMap::samples() const {
  std::call_once(lazy_->once, [this] { BuildSamples(&lazy_->samples); });
  return lazy_->samples;
}

double EnvMap::TotalSolidAngle() const {
  double sum = 0;
  for (const EnvSample& s : samples()) sum += s.solid_angle;
  return sum;
}

LatLongSampler::LatLongSampler(const EnvMap& map) {
  const Image& img = *map.lat_long_image();
  pixels_ = img.pixels.data();
  width_ = img.width;
  height_ = img.height;
  const RingQuadrature q = FejerFirstRule(height_);
  row_sin_ = q.sin_theta;
  row_cos_ = q.cos_theta;
  row_omega_.resize(height_);
  for (int j = 0; j < height_; ++j) row_omega_[j] = q.weight[j] * 2 * kPi / width_;
  col_sin_.resize(width_);
  col_cos_.resize(width_);
  for (int i = 0; i < width_; ++i) {
    const double p = 2 * kPi * ((i + 0.5) / width_ - 0.5);
    col_sin_[i] = std::sin(p);
    col_cos_[i] = std::cos(p);
  }
}

void EnvMap::ForEachSample(absl::FunctionRef<void(const EnvSample&)> fn) const {
  if (layout_ == EnvLayout::kLatLong) {
    const LatLongSampler sampler(*this);
    for (int j = 0; j < height_; ++j)
      for (int i = 0; i < width_; ++i) fn(sampler.At(i, j));
    return;
  }
  if (layout_ == EnvLayout::kAngular) {
    const Image& img = (*images_)[0];
    const int d = img.width;
    const double pixel_area = 4.0 / (static_cast<double>(d) * d);
    for (int j = 0; j < d; ++j) {
      const double v = -AngularCoord(j, d);
      for (int i = 0; i < d; ++i) {
        const double u = AngularCoord(i, d);
        const std::optional<Vec3> dir = AngularMapDirection(u, v);
        if (!dir) continue;
        const double rho = std::hypot(u, v);
        // d omega / dA = pi sin(pi rho) / rho (polar angle pi rho from -Z, azimuth unchanged).
        const double jac = rho == 0 ? kPi * kPi : kPi * std::sin(kPi * rho) / rho;
        EnvSample s;
        s.dir = *dir;
        s.solid_angle = jac * pixel_area;
        const float* px = PixelPtr(img, i, j);
        s.rgb = {px[0], px[1], px[2]};
        fn(s);
      }
    }
    return;
  }
  const int n = face_size_;
  for (int f = 0; f < 6; ++f) {
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        EnvSample s;
        s.dir = CubeTexelDirection(f, x, y, n);
        s.solid_angle = CubeTexelSolidAngle(x, y, n);
        const float* px = PixelPtr((*images_)[f], x, y);
        s.rgb = {px[0], px[1], px[2]};
        fn(s);
      }
    }
  }
}

size_t EnvMap::sample_count() const {
  if (layout_ == EnvLayout::kLatLong) {
    return static_cast<size_t>((*images_)[0].width) * (*images_)[0].height;
  }
  if (layout_ != EnvLayout::kAngular) return static_cast<size_t>(6) * face_size_ * face_size_;
  size_t n = 0;  // the disc's pixels
  ForEachSample([&n](const EnvSample&) { ++n; });
  return n;
}

void EnvMap::BuildSamples(std::vector<EnvSample>* out) const {
  out->clear();
  if (layout_ != EnvLayout::kAngular) out->reserve(sample_count());
  ForEachSample([out](const EnvSample& s) { out->push_back(s); });
}

std::array<float, 3> EnvMap::LatLongRadiance(const Vec3& d) const {
  return LatLongRadianceAt(std::atan2(std::hypot(d.x, d.z), d.y), std::atan2(d.x, -d.z));
}

std::array<float, 3> EnvMap::LatLongRadianceAt(double theta, double p) const {
  std::array<float, 3> v;
  LatLongRadianceAt(&theta, &p, 0.0, 1, v.data());
  return v;
}

void EnvMap::LatLongRadianceAt(const double* theta, const double* phi, double phi_offset, int n,
                               float* out) const {
  const Image& img = (*images_)[0];
  const int w = img.width, h = img.height;
  if (img.channels != 3 || w < 2) {
    for (int k = 0; k < n; ++k) {
      const double x = ((phi[k] + phi_offset) / (2 * kPi) + 0.5) * w - 0.5;
      const double y = theta[k] / kPi * h - 0.5;
      const std::array<float, 3> v = Bilinear(img, x, y, /*wrap_x=*/true);
      std::copy(v.begin(), v.end(), out + 3 * k);
    }
    return;
  }
#if defined(__AVX512F__)
  // (Pixel offsets in 32 bits: every map up to 2^31 / 3 floats; larger ones take the loop below.)
  // Eight points at a time, Bilinear()'s arithmetic with its products fused as written out in the
  // portable path below (so the two agree bit for bit, and one point, a call with n = 1, takes
  // the same path as a batch): the corners' channels gathered (12 gathers of 8 floats), widened
  // to double, blended. Lanes whose column lies outside the map after one wrap (azimuths beyond
  // a turn) take Bilinear() itself. The rows of the group after next are prefetched.
  if (img.pixels.size() < (size_t{1} << 31) / 3) {
    const float* pixels = img.pixels.data();
    const __m512d vw = _mm512_set1_pd(w), vh = _mm512_set1_pd(h);
    const __m512d half = _mm512_set1_pd(0.5), minus_half = _mm512_set1_pd(-0.5);
    const __m512d one = _mm512_set1_pd(1.0), zero = _mm512_setzero_pd();
    const __m512d top_row = _mm512_set1_pd(h - 1);
    const __m512d offset = _mm512_set1_pd(phi_offset);
    const __m512d vpi = _mm512_set1_pd(kPi), vturn = _mm512_set1_pd(2 * kPi);
    const __m256i iw = _mm256_set1_epi32(w), ilast = _mm256_set1_epi32(h - 1);
    const __m256i izero = _mm256_setzero_si256(), ione = _mm256_set1_epi32(1);
    const __m256i three = _mm256_set1_epi32(3);
    // A group's coordinates and corner offsets, made two groups ahead of its gathers so that its
    // rows' prefetches have time to land (the map, megabytes, is out of cache in a job).
    struct Group {
      __m512d x, y, fx0, fy0;
      __m256i i00, i01, i10, i11;
      __mmask8 fast;
    };
    const auto prepare = [&](int k, Group& g) {
      const __mmask8 live = static_cast<__mmask8>((1u << std::min(8, n - k)) - 1);
      const __m512d ph = _mm512_add_pd(_mm512_maskz_loadu_pd(live, phi + k), offset);
      g.x = _mm512_fmadd_pd(_mm512_add_pd(_mm512_div_pd(ph, vturn), half), vw, minus_half);
      const __m512d yr = _mm512_fmadd_pd(_mm512_div_pd(_mm512_maskz_loadu_pd(live, theta + k), vpi),
                                         vh, minus_half);
      g.y = _mm512_maskz_min_pd(0xFF, _mm512_maskz_max_pd(0xFF, yr, zero), top_row);
      // (The zero-masking forms with every lane kept: the plain intrinsics' undefined vectors trip
      // GCC 12's -Wmaybe-uninitialized once inlined; the same instructions either way.)
      g.fx0 = _mm512_maskz_roundscale_pd(0xFF, g.x, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
      g.fy0 = _mm512_maskz_roundscale_pd(0xFF, g.y, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
      __m256i x0 = _mm512_maskz_cvttpd_epi32(0xFF, g.fx0);
      const __m256i y0 = _mm512_maskz_cvttpd_epi32(0xFF, g.fy0);
      const __m256i y1 = _mm256_min_epi32(_mm256_add_epi32(y0, ione), ilast);
      // x0 < 0: one turn added; lanes still outside [0, w) go to Bilinear() and gather pixel 0.
      x0 = _mm256_add_epi32(x0, _mm256_and_si256(_mm256_cmpgt_epi32(izero, x0), iw));
      const __m256i inside =
          _mm256_andnot_si256(_mm256_cmpgt_epi32(izero, x0), _mm256_cmpgt_epi32(iw, x0));
      g.fast = static_cast<__mmask8>(live & _mm256_movemask_ps(_mm256_castsi256_ps(inside)));
      const __m256i xn = _mm256_add_epi32(x0, ione);
      const __m256i x1 = _mm256_and_si256(xn, _mm256_cmpgt_epi32(iw, xn));  // w -> 0
      const __m256i r0 = _mm256_mullo_epi32(y0, iw), r1 = _mm256_mullo_epi32(y1, iw);
      const auto index = [&](__m256i row, __m256i col) {
        return _mm256_and_si256(_mm256_mullo_epi32(_mm256_add_epi32(row, col), three), inside);
      };
      g.i00 = index(r0, x0);
      g.i01 = index(r0, x1);
      g.i10 = index(r1, x0);
      g.i11 = index(r1, x1);
      alignas(32) int32_t top[8], bottom[8];
      _mm256_store_si256(reinterpret_cast<__m256i*>(top), g.i00);
      _mm256_store_si256(reinterpret_cast<__m256i*>(bottom), g.i10);
      for (int i = 0; i < 8; ++i) {
        __builtin_prefetch(pixels + top[i]);
        __builtin_prefetch(pixels + bottom[i]);
      }
    };
    constexpr int kAhead = 2;
    Group ring[kAhead + 1];
    for (int j = 0; j < kAhead && 8 * j < n; ++j) prepare(8 * j, ring[j]);
    for (int k = 0, j = 0; k < n; k += 8, ++j) {
      if (k + 8 * kAhead < n) prepare(k + 8 * kAhead, ring[(j + kAhead) % (kAhead + 1)]);
      const Group& g = ring[j % (kAhead + 1)];
      const __m512d ax = _mm512_sub_pd(g.x, g.fx0), ay = _mm512_sub_pd(g.y, g.fy0);
      const __m512d bx = _mm512_sub_pd(one, ax), by = _mm512_sub_pd(one, ay);
      alignas(64) float res[3][8];
      for (int c = 0; c < 3; ++c) {
        const float* base = pixels + c;
        const auto corner = [&](__m256i idx) {
          return _mm512_maskz_cvtps_pd(0xFF, _mm256_i32gather_ps(base, idx, 4));
        };
        const __m512d top = _mm512_fmadd_pd(ax, corner(g.i01), _mm512_mul_pd(bx, corner(g.i00)));
        const __m512d bottom = _mm512_fmadd_pd(ax, corner(g.i11), _mm512_mul_pd(bx, corner(g.i10)));
        const __m512d v = _mm512_fmadd_pd(ay, bottom, _mm512_mul_pd(by, top));
        _mm256_store_ps(res[c], _mm512_maskz_cvtpd_ps(0xFF, v));
      }
      const int lanes = std::min(8, n - k);
      alignas(64) double xs[8], ys[8];  // for the lanes Bilinear() takes
      _mm512_store_pd(xs, g.x);
      _mm512_store_pd(ys, g.y);
      for (int i = 0; i < lanes; ++i) {
        float* o = out + 3 * (static_cast<size_t>(k) + i);
        if (g.fast & (1u << i)) {
          o[0] = res[0][i];
          o[1] = res[1][i];
          o[2] = res[2][i];
        } else {
          const std::array<float, 3> v = Bilinear(img, xs[i], ys[i], /*wrap_x=*/true);
          std::copy(v.begin(), v.end(), o);
        }
      }
    }
    return;
  }
#endif
  // The same arithmetic point by point: x, y and the blends fused as the vector path writes them.
  for (int k = 0; k < n; ++k) {
    const double x = std::fma((phi[k] + phi_offset) / (2 * kPi) + 0.5, w, -0.5);
    const double y = std::clamp(std::fma(theta[k] / kPi, h, -0.5), 0.0, static_cast<double>(h - 1));
    const double fx0 = std::floor(x), fy0 = std::floor(y);
    int x0 = static_cast<int>(fx0);
    const int y0 = static_cast<int>(fy0), y1 = std::min(y0 + 1, h - 1);
    if (x0 < 0) x0 += w;
    if (x0 < 0 || x0 >= w) {
      const std::array<float, 3> v = Bilinear(img, x, y, /*wrap_x=*/true);
      std::copy(v.begin(), v.end(), out + 3 * k);
      continue;
    }
    const int x1 = x0 + 1 < w ? x0 + 1 : 0;
    const double ax = x - fx0, ay = y - fy0;
    const float* p = img.pixels.data();
    const size_t r0 = static_cast<size_t>(y0) * w, r1 = static_cast<size_t>(y1) * w;
    for (int c = 0; c < 3; ++c) {
      const double top = std::fma(ax, p[(r0 + x1) * 3 + c], (1 - ax) * p[(r0 + x0) * 3 + c]);
      const double bottom = std::fma(ax, p[(r1 + x1) * 3 + c], (1 - ax) * p[(r1 + x0) * 3 + c]);
      out[3 * k + c] = static_cast<float>(std::fma(ay, bottom, (1 - ay) * top));
    }
  }
}

std::array<float, 3> EnvMap::CubeRadiance(const Vec3& d) const {
  int face;
  double s, t;
  CubeFaceCoordinates(d, &face, &s, &t);
  const int n = face_size_;
  return Bilinear((*images_)[face], s * n - 0.5, t * n - 0.5, /*wrap_x=*/false);
}

std::array<float, 3> EnvMap::AngularRadiance(const Vec3& d) const {
  const Image& img = (*images_)[0];
  const int n = img.width;
  const auto [u, v] = AngularMapCoordinates(d);
  const double x = (u + 1) / 2 * n - 0.5, y = (1 - v) / 2 * n - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const double ax = x - x0, ay = y - y0;
  double acc[3] = {0, 0, 0}, wsum = 0;
  for (int dy = 0; dy < 2; ++dy) {
    for (int dx = 0; dx < 2; ++dx) {
      const int xi = x0 + dx, yi = y0 + dy;
      if (xi < 0 || yi < 0 || xi >= n || yi >= n) continue;
      const double cu = AngularCoord(xi, n), cv = AngularCoord(yi, n);
      if (cu * cu + cv * cv > 1) continue;  // tap outside the disc
      const double w = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
      const float* px = PixelPtr(img, xi, yi);
      for (int c = 0; c < 3; ++c) acc[c] += w * px[c];
      wsum += w;
    }
  }
  if (wsum > 0) {
    return {static_cast<float>(acc[0] / wsum), static_cast<float>(acc[1] / wsum),
            static_cast<float>(acc[2] / wsum)};
  }
  // No tap inside the disc (only just inside its rim): the nearest pixel inside the disc.
  double best = 1e300;
  std::array<float, 3> out{0, 0, 0};
  for (int yi = std::max(0, y0 - 2); yi <= std::min(n - 1, y0 + 3); ++yi) {
    for (int xi = std::max(0, x0 - 2); xi <= std::min(n - 1, x0 + 3); ++xi) {
      const double cu = AngularCoord(xi, n), cv = AngularCoord(yi, n);
      if (cu * cu + cv * cv > 1) continue;
      const double dist = (xi - x) * (xi - x) + (yi - y) * (yi - y);
      if (dist < best) {
        best = dist;
        const float* px = PixelPtr(img, xi, yi);
        out = {px[0], px[1], px[2]};
      }
    }
  }
  return out;
}

std::array<float, 3> EnvMap::Radiance(const Vec3& world_dir) const {
  switch (layout_) {
    case EnvLayout::kLatLong:
      return LatLongRadiance(world_dir);
    case EnvLayout::kAngular:
      return AngularRadiance(world_dir);
    default:
      return CubeRadiance(world_dir);
  }
}

std::optional<Vec3> EnvMap::PixelDirection(int image, int x, int y) const {
  const int n_images = layout_ == EnvLayout::kCubeFaces ? 6 : 1;
  if (image < 0 || image >= n_images || x < 0 || y < 0 || x >= width_ || y >= height_) {
    return std::nullopt;
  }
  switch (layout_) {
    case EnvLayout::kLatLong: {
      const double theta = kPi * (y + 0.5) / height_;
      const double p = 2 * kPi * ((x + 0.5) / width_ - 0.5);
      return Vec3{std::sin(theta) * std::sin(p), std::cos(theta), -std::sin(theta) * std::cos(p)};
    }
    case EnvLayout::kAngular:
      return AngularMapDirection(AngularCoord(x, width_), -AngularCoord(y, height_));
    case EnvLayout::kCubeFaces:
      return CubeTexelDirection(image, x, y, face_size_);
    default: {
      const int s = face_size_;
      for (int f = 0; f < 6; ++f) {
        const Cell cell = FaceCell(layout_, f);
        if (x / s != cell.col || y / s != cell.row) continue;
        const int lx = x % s, ly = y % s;
        return cell.rot180 ? CubeTexelDirection(f, s - 1 - lx, s - 1 - ly, s)
                           : CubeTexelDirection(f, lx, ly, s);
      }
      return std::nullopt;
    }
  }
}

int EnvMap::NativeLatLongWidth() const {
  switch (layout_) {
    case EnvLayout::kLatLong:
      return width_;
    case EnvLayout::kAngular:
      return 2 * width_;
    default:
      return 4 * face_size_;
  }
}

absl::StatusOr<Image> EnvMap::ToLatLong(int width, int num_threads) const {
  constexpr int kMaxWidth = 1 << 16;
  if (num_threads < 1) return absl::InvalidArgumentError("num_threads must be >= 1");
  if (width < 2 || width % 2 != 0 || width > kMaxWidth) {
    return absl::InvalidArgumentError(
        absl::StrCat("lat-long width must be even and in [2, ", kMaxWidth, "], got ", width));
  }
  const int height = width / 2;
  if (layout_ == EnvLayout::kLatLong && width_ == width && height_ == height) return (*images_)[0];
  Image out;
  out.width = width;
  out.height = height;
  out.channels = 3;
  out.pixels.resize(static_cast<size_t>(width) * height * 3);
  std::vector<double> sin_p(width), cos_p(width);
  for (int i = 0; i < width; ++i) {
    const double p = 2 * kPi * ((i + 0.5) / width - 0.5);
    sin_p[i] = std::sin(p);
    cos_p[i] = std::cos(p);
  }
  auto rows = [&](int j0, int j1) {
    for (int j = j0; j < j1; ++j) {
      const double theta = kPi * (j + 0.5) / height;
      const double st = std::sin(theta), ct = std::cos(theta);
      for (int i = 0; i < width; ++i) {
        const std::array<float, 3> v = Radiance({st * sin_p[i], ct, -st * cos_p[i]});
        std::copy(v.begin(), v.end(), PixelPtr(out, i, j));
      }
    }
  };
  const int threads = std::clamp(num_threads, 1, std::max(1, height / 16));
  if (threads <= 1) {
    rows(0, height);
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) {
      pool.emplace_back(rows, height * t / threads, height * (t + 1) / threads);
    }
    for (auto& th : pool) th.join();
  }
  return out;
}

}  // namespace shrm
