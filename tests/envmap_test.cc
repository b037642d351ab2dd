// Environment maps: every layout round-trips through files built here from the documented cell
// tables and mappings (docs/envmap.md), sample solid angles integrate the sphere, lighting
// coefficients agree across layouts and methods, white furnace, exact SH-space rotation (column
// shifts, resampled rotated maps, pointwise identity), colour conversion on load, and clear
// errors for bad input.
#include "core/envmap/envmap.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/base/cubemap.h"
#include "core/envmap/lighting.h"
#include "core/io/colour.h"
#include "core/io/image.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/transform/sht.h"
#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace fs = std::filesystem;

constexpr double k4Pi = 4 * kPi;
// Cube texel solid angles are exact (atan formula): only rounding in the sum of 6 S^2 terms.
constexpr double kCubeSolidAngleTol = 1e-10;
// Angular map: midpoint rule for the disc Jacobian pi sin(pi rho)/rho with pixels cut by the rim
// (the Jacobian vanishes linearly there, so cut pixels carry little weight); measured 3.1e-7
// relative at D = 256.
constexpr double kAngularSolidAngleRelTol = 1e-5;
// Values read back at a layout's own pixel centres were written as the bilinear lookup of the
// source at exactly those directions: float storage only (weights at texel centres are exact
// to ~1e-13).
constexpr double kPixelCentreRelTol = 1e-5;
// Radiance at arbitrary directions goes through two bilinear interpolations (source -> layout ->
// lookup), so it differs where the image is not linear on a texel (edges, the sun). Measured over
// 20000 random directions on the 256 x 128 courtyard: mean |diff| / mean radiance 4.3 % (cube
// layouts), 3.1 % (angular).
constexpr double kBilinearMeanRelTol = 0.08;
// L_lm at degree 8 of a 64^2 cube built from the 256 x 128 map vs the map itself: both integrate
// interpolants of the same data; their difference is the resampling error at l <= 8, measured
// 5.3e-3 of L_00 (cube layouts; the sun), 1.7e-3 (angular).
constexpr double kLayoutCoeffRelTol = 1e-2;
// Resampled-SHT vs direct summation over the 6 x 64^2 cube texels, degree 8: bilinear interpolant
// vs piecewise-constant texels, both second order in the texel size; measured 2.4e-3 of L_00.
constexpr double kMethodCoeffRelTol = 5e-3;
// White furnace on a lat-long grid: Fejer weights sum to 2 and the FFT of a constant is exact.
constexpr double kFurnaceTol = 1e-12;
// The column shift is an exact symmetry of the grid; only rounding (FFT, rotation) remains
// (measured <= 8e-14).
constexpr double kShiftRelTol = 1e-11;
// Rotated 256 x 128 map resampled bilinearly on a 1024 x 512 grid vs SH-rotated coefficients,
// degree 8; measured 1.2e-3 of L_00 (bilinear resampling of the sun).
constexpr double kRotResampleRelTol = 1e-2;
// L_R(w) = L(R^-1 w) pointwise from the two coefficient sets: rounding of RotateSh and synthesis.
constexpr double kPointwiseTol = 1e-10;
// Closed-form directions and angles: a few ulps of sin/cos/atan2.
constexpr double kDirTol = 1e-14;
// Fejer weights sum to 2 and the direct sum on a lat-long grid IS the transform's quadrature for
// degrees plain Fejer resolves (lmax <= (H - 1) / 2): only summation order differs.
constexpr double kSameQuadratureTol = 1e-12;
// Float32 pixels and OCIO float processing.
constexpr double kFloatTol = 1e-6;
// Published 6-decimal matrix entries (tests/colour_test.cc).
constexpr double kPublishedMatrixTol = 1e-4;

std::string MapPath(const std::string& name) {
  return std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name;
}

std::string TempPath(const std::string& name) { return testing::UniqueTempPath("envmap_" + name); }

Image MakeImage(int w, int h) {
  Image img;
  img.width = w;
  img.height = h;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(w) * h * 3, 0.0f);
  return img;
}

void SetPixel(Image& img, int x, int y, const std::array<float, 3>& v) {
  for (int c = 0; c < 3; ++c) img.pixels[(static_cast<size_t>(y) * img.width + x) * 3 + c] = v[c];
}

// courtyard.exr box-downsampled 4 x 4 to 256 x 128.
const Image& Courtyard256() {
  static const Image* img = [] {
    auto full = ReadImageRgb(MapPath("courtyard.exr"));
    EXPECT_TRUE(full.ok()) << full.status();
    auto* out = new Image(MakeImage(256, 128));
    for (int y = 0; y < 128; ++y)
      for (int x = 0; x < 256; ++x)
        for (int c = 0; c < 3; ++c) {
          double s = 0;
          for (int dy = 0; dy < 4; ++dy)
            for (int dx = 0; dx < 4; ++dx) s += full->at(4 * x + dx, 4 * y + dy, c);
          out->pixels[(static_cast<size_t>(y) * 256 + x) * 3 + c] = static_cast<float>(s / 16);
        }
    return out;
  }();
  return *img;
}

// Test's own transcription of the cell tables of docs/envmap.md: (column, row, rotated 180).
struct TestCell {
  int col, row;
  bool rot;
};
TestCell CellOf(EnvLayout layout, int face) {
  // GL order +X, -X, +Y, -Y, +Z, -Z.
  static constexpr TestCell kHCross[6] = {{2, 1, false}, {0, 1, false}, {1, 0, false},
                                          {1, 2, false}, {1, 1, false}, {3, 1, false}};
  static constexpr TestCell kVCross[6] = {{2, 1, false}, {0, 1, false}, {1, 0, false},
                                          {1, 2, false}, {1, 1, false}, {1, 3, true}};
  switch (layout) {
    case EnvLayout::kHorizontalCross:
      return kHCross[face];
    case EnvLayout::kVerticalCross:
      return kVCross[face];
    case EnvLayout::kHorizontalStrip:
      return {face, 0, false};
    default:
      return {0, face, false};  // vertical strip
  }
}

// Six S x S GL faces sampled from `src` at the texel centres.
std::vector<Image> CubeFacesFrom(const EnvMap& src, int s) {
  std::vector<Image> faces;
  for (int f = 0; f < 6; ++f) {
    Image face = MakeImage(s, s);
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x)
        SetPixel(face, x, y, src.Radiance(CubeTexelDirection(f, x, y, s)));
    faces.push_back(std::move(face));
  }
  return faces;
}

Image Assemble(EnvLayout layout, const std::vector<Image>& faces) {
  const int s = faces[0].width;
  const int cols = layout == EnvLayout::kHorizontalCross   ? 4
                   : layout == EnvLayout::kVerticalCross   ? 3
                   : layout == EnvLayout::kHorizontalStrip ? 6
                                                           : 1;
  const int rows = layout == EnvLayout::kHorizontalCross   ? 3
                   : layout == EnvLayout::kVerticalCross   ? 4
                   : layout == EnvLayout::kHorizontalStrip ? 1
                                                           : 6;
  Image img = MakeImage(cols * s, rows * s);
  for (int f = 0; f < 6; ++f) {
    const TestCell cell = CellOf(layout, f);
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x) {
        const int fx = cell.rot ? s - 1 - x : x, fy = cell.rot ? s - 1 - y : y;
        SetPixel(img, cell.col * s + x, cell.row * s + y,
                 {faces[f].at(fx, fy, 0), faces[f].at(fx, fy, 1), faces[f].at(fx, fy, 2)});
      }
  }
  return img;
}

// Debevec angular map of size d from `src`, written from the documented inverse mapping; pixels
// outside the disc are black.
Image AngularFrom(const EnvMap& src, int d) {
  Image img = MakeImage(d, d);
  for (int j = 0; j < d; ++j)
    for (int i = 0; i < d; ++i) {
      const double u = 2.0 * (i + 0.5) / d - 1, v = 1 - 2.0 * (j + 0.5) / d;
      const double rho = std::sqrt(u * u + v * v);
      if (rho > 1) continue;
      const double phi = kPi * rho;  // angle from -Z
      const Vec3 dir = rho == 0
                           ? Vec3{0, 0, -1}
                           : Vec3{std::sin(phi) * u / rho, std::sin(phi) * v / rho, -std::cos(phi)};
      SetPixel(img, i, j, src.Radiance(dir));
    }
  return img;
}

double Lum(const std::array<float, 3>& v) { return (v[0] + v[1] + v[2]) / 3.0; }

Vec3 RandomDirection(std::mt19937& rng) {
  std::normal_distribution<double> g;
  return Vec3{g(rng), g(rng), g(rng)}.Normalized();
}

double MaxRelCoeffDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double l00 = std::max({std::abs(b[0]), std::abs(b[1]), std::abs(b[2])});
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
  return worst / l00;
}

// --- Layout round trips on real data -------------------------------------------------------

struct LayoutCase {
  EnvLayout layout;
  const char* name;
};

class LayoutRoundTrip : public ::testing::TestWithParam<LayoutCase> {};

TEST_P(LayoutRoundTrip, DetectsLayoutAndReproducesRadiance) {
  const EnvLayout layout = GetParam().layout;
  const EnvMap src = EnvMap::FromLatLong(Courtyard256());
  constexpr int kFace = 64, kProbe = 256;
  std::vector<std::string> paths;
  if (layout == EnvLayout::kCubeFaces) {
    const std::vector<Image> faces = CubeFacesFrom(src, kFace);
    for (int f = 0; f < 6; ++f) {
      paths.push_back(TempPath(std::string("face_") + kCubeFaceNames[f] + ".exr"));
      ASSERT_TRUE(WriteExr(paths.back(), faces[f]).ok());
    }
  } else {
    const Image img = layout == EnvLayout::kAngular ? AngularFrom(src, kProbe)
                                                    : Assemble(layout, CubeFacesFrom(src, kFace));
    paths.push_back(TempPath(std::string(GetParam().name) + ".exr"));
    ASSERT_TRUE(WriteExr(paths.back(), img).ok());
  }
  EnvMapOptions opts;
  opts.paths = paths;
  auto map = EnvMap::Load(opts);
  for (const auto& p : paths) fs::remove(p);
  ASSERT_TRUE(map.ok()) << map.status();

  // (a) auto-detection.
  EXPECT_EQ(map->layout(), layout);
  if (layout != EnvLayout::kAngular) {
    EXPECT_EQ(map->face_size(), kFace);
  }

  // (b1) every native pixel holds the source radiance towards its direction.
  for (const EnvSample& s : map->samples()) {
    const std::array<float, 3> want = src.Radiance(s.dir);
    for (int c = 0; c < 3; ++c)
      ASSERT_NEAR(s.rgb[c], want[c], kPixelCentreRelTol * (std::abs(want[c]) + 1e-3))
          << GetParam().name << " dir " << s.dir.x << " " << s.dir.y << " " << s.dir.z;
  }
  // (b2) radiance at random directions, within the bilinear-resampling tolerance.
  std::mt19937 rng(11);
  double diff = 0, ref = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 d = RandomDirection(rng);
    const double a = Lum(map->Radiance(d)), b = Lum(src.Radiance(d));
    diff += std::abs(a - b);
    ref += std::abs(b);
  }
  EXPECT_LT(diff / ref, kBilinearMeanRelTol) << GetParam().name;

  // (c) the samples integrate the sphere.
  if (layout == EnvLayout::kAngular) {
    EXPECT_NEAR(map->TotalSolidAngle() / k4Pi, 1.0, kAngularSolidAngleRelTol);
  } else {
    EXPECT_NEAR(map->TotalSolidAngle(), k4Pi, kCubeSolidAngleTol);
    EXPECT_EQ(map->samples().size(), 6u * kFace * kFace);
  }

  // (d) lighting coefficients at degree 8 match the lat-long source's.
  auto want = LightingCoefficients(src, 8);
  auto got = LightingCoefficients(*map, 8);
  ASSERT_TRUE(want.ok() && got.ok());
  EXPECT_LT(MaxRelCoeffDiff(*got, *want), kLayoutCoeffRelTol) << GetParam().name;
}

INSTANTIATE_TEST_SUITE_P(AllLayouts, LayoutRoundTrip,
                         ::testing::Values(LayoutCase{EnvLayout::kCubeFaces, "cube"},
                                           LayoutCase{EnvLayout::kHorizontalCross, "hcross"},
                                           LayoutCase{EnvLayout::kVerticalCross, "vcross"},
                                           LayoutCase{EnvLayout::kHorizontalStrip, "hstrip"},
                                           LayoutCase{EnvLayout::kVerticalStrip, "vstrip"},
                                           LayoutCase{EnvLayout::kAngular, "angular"}),
                         [](const ::testing::TestParamInfo<LayoutCase>& tp) {
                           return std::string(tp.param.name);
                         });

TEST(EnvMapLayout, CrossesAreContinuousUnfoldings) {
  // Neighbouring pixels of a cross (inside a cell or across a shared cell edge) look in nearby
  // directions: no cell is flipped or rotated against the documented table. The texel pitch is at
  // most 2 atan(1 / S) (face centre); a misplaced or flipped cell gives tens of degrees.
  constexpr int kS = 16;
  for (EnvLayout layout : {EnvLayout::kHorizontalCross, EnvLayout::kVerticalCross}) {
    const bool h = layout == EnvLayout::kHorizontalCross;
    auto map = EnvMap::FromImages({MakeImage(h ? 4 * kS : 3 * kS, h ? 3 * kS : 4 * kS)}, layout);
    ASSERT_TRUE(map.ok()) << map.status();
    int pairs = 0;
    for (int y = 0; y < map->height(); ++y)
      for (int x = 0; x < map->width(); ++x) {
        const auto a = map->PixelDirection(0, x, y);
        if (!a) continue;
        for (auto [nx, ny] : {std::pair{x + 1, y}, std::pair{x, y + 1}}) {
          const auto b = map->PixelDirection(0, nx, ny);
          if (!b) continue;
          ++pairs;
          EXPECT_LT(std::acos(std::clamp(a->Dot(*b), -1.0, 1.0)), 1.01 * 2 * std::atan(1.0 / kS))
              << EnvLayoutName(layout) << " at " << x << "," << y << " -> " << nx << "," << ny;
        }
      }
    // Every adjacent pair of the 6 cells: 5 shared edges in a cross, all traversed.
    EXPECT_EQ(pairs, 6 * 2 * kS * (kS - 1) + 5 * kS);
  }
}

TEST(EnvMapLayout, KnownDirectionsOfEachLayout) {
  // Spot checks written from the documentation: the centre of the horizontal cross's cell (1, 1)
  // looks down +Z, the angular map's centre down -Z and its right edge midpoint towards +X at
  // 90 degrees, the lat-long image centre down -Z.
  auto hc = EnvMap::FromImages({MakeImage(40, 30)}, EnvLayout::kAuto);
  ASSERT_TRUE(hc.ok());
  EXPECT_EQ(hc->layout(), EnvLayout::kHorizontalCross);
  EXPECT_GT(hc->PixelDirection(0, 15, 15)->z, 0.99);   // +Z cell (1, 1)
  EXPECT_GT(hc->PixelDirection(0, 25, 15)->x, 0.99);   // +X cell (2, 1)
  EXPECT_LT(hc->PixelDirection(0, 35, 15)->z, -0.99);  // -Z cell (3, 1)
  EXPECT_LT(hc->PixelDirection(0, 5, 15)->x, -0.99);   // -X cell (0, 1)
  EXPECT_GT(hc->PixelDirection(0, 15, 5)->y, 0.99);    // +Y cell (1, 0)
  EXPECT_LT(hc->PixelDirection(0, 15, 25)->y, -0.99);  // -Y cell (1, 2)
  EXPECT_FALSE(hc->PixelDirection(0, 0, 0).has_value());
  const auto uv = AngularMapCoordinates({1, 0, 0});
  EXPECT_NEAR(uv[0], 0.5, kDirTol);
  EXPECT_NEAR(uv[1], 0.0, kDirTol);
  const auto up = AngularMapCoordinates({0, 1, 1});  // 135 degrees from -Z, straight up
  EXPECT_NEAR(up[0], 0.0, kDirTol);
  EXPECT_NEAR(up[1], 0.75, kDirTol);
  const Vec3 d = *AngularMapDirection(0.3, -0.4);
  const auto back = AngularMapCoordinates(d);
  EXPECT_NEAR(back[0], 0.3, kDirTol);
  EXPECT_NEAR(back[1], -0.4, kDirTol);
  EXPECT_FALSE(AngularMapDirection(0.8, 0.7).has_value());
}

TEST(EnvMapLatLong, SamplesUseFejerRingWeightsAndToLatLong) {
  const EnvMap src = EnvMap::FromLatLong(Courtyard256());
  EXPECT_NEAR(src.TotalSolidAngle(), k4Pi, kSameQuadratureTol);
  ASSERT_EQ(src.samples().size(), 256u * 128u);
  // Sample (i, j) is pixel (i, j) at its documented direction.
  const EnvSample& s = src.samples()[5 * 256 + 17];
  const double theta = kPi * 5.5 / 128, p = 2 * kPi * (17.5 / 256 - 0.5);
  EXPECT_NEAR(s.dir.x, std::sin(theta) * std::sin(p), kDirTol);
  EXPECT_NEAR(s.dir.y, std::cos(theta), kDirTol);
  EXPECT_NEAR(s.dir.z, -std::sin(theta) * std::cos(p), kDirTol);
  EXPECT_EQ(s.rgb[1], Courtyard256().at(17, 5, 1));
  // Same size: unchanged; Radiance at a pixel centre is that pixel.
  auto same = src.ToLatLong(256);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->pixels, Courtyard256().pixels);
  EXPECT_NEAR(src.Radiance(s.dir)[1], s.rgb[1], kPixelCentreRelTol * s.rgb[1]);
  // Halving: every output pixel centre sits at the corner of 2 x 2 input pixels -> their mean.
  auto half = src.ToLatLong(128, 2);
  ASSERT_TRUE(half.ok());
  const Image& in = Courtyard256();
  const double mean =
      (in.at(20, 10, 0) + in.at(21, 10, 0) + in.at(20, 11, 0) + in.at(21, 11, 0)) / 4.0;
  EXPECT_NEAR(half->at(10, 5, 0), mean, kPixelCentreRelTol * mean);
  EXPECT_FALSE(src.ToLatLong(101).ok());
}

// Across the seam (azimuth +-pi) the lookup blends the last and the first column, as the
// written-out bilinear weights say; an azimuth turned by whole turns looks up the same place; the
// batched lookup equals the single one.
TEST(EnvMapLatLong, BilinearWrapsTheSeamAndWholeTurns) {
  const Image& in = Courtyard256();
  const EnvMap src = EnvMap::FromLatLong(in);
  const int w = in.width, j = 40;
  const double theta = kPi * (j + 0.5) / in.height;
  // x = 0.25 past the last column's centre: 3/4 of column w - 1 and 1/4 of column 0.
  for (const double x : {w - 0.75, -0.75}) {
    const double p = 2 * kPi * ((x + 0.5) / w - 0.5);
    const std::array<float, 3> got = src.LatLongRadianceAt(theta, p);
    const double ax = x - std::floor(x);
    const int x0 = (static_cast<int>(std::floor(x)) + w) % w, x1 = (x0 + 1) % w;
    for (int c = 0; c < 3; ++c) {
      const double want = (1 - ax) * in.at(x0, j, c) + ax * in.at(x1, j, c);
      EXPECT_NEAR(got[c], want, kPixelCentreRelTol * want) << "x " << x << " c " << c;
    }
  }
  std::vector<double> thetas, phis;
  for (int k = -3; k <= 3; ++k) {
    const double p = 0.3 + 2 * kPi * k;
    const std::array<float, 3> turned = src.LatLongRadianceAt(theta, p);
    const std::array<float, 3> base = src.LatLongRadianceAt(theta, 0.3);
    for (int c = 0; c < 3; ++c) {
      // The turns shift x by whole widths, changing its rounding only (~1e-13 of a pixel).
      EXPECT_NEAR(turned[c], base[c], kPixelCentreRelTol * base[c]) << "turns " << k;
    }
    thetas.push_back(theta + 0.01 * k);
    phis.push_back(p);
  }
  std::vector<float> batch(3 * thetas.size());
  src.LatLongRadianceAt(thetas.data(), phis.data(), 0.125, static_cast<int>(thetas.size()),
                        batch.data());
  for (size_t k = 0; k < thetas.size(); ++k) {
    const std::array<float, 3> one = src.LatLongRadianceAt(thetas[k], phis[k] + 0.125);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(batch[3 * k + c], one[c]) << k;
  }
}

// The batched lookup (eight points per vector group, the corners gathered) against the bilinear
// weights written out here, at points that cover every case of a group: the poles' clamped rows,
// the last row and column (the map's last pixel), the seam from both sides, azimuths a turn or
// more away (taken by the scalar lookup inside a group), and a tail shorter than a group. Each
// point of the batch equals the same point looked up alone.
TEST(EnvMapLatLong, BatchedLookupIsTheBilinearBlendEverywhere) {
  const Image& in = Courtyard256();
  const EnvMap src = EnvMap::FromLatLong(in);
  const int w = in.width, h = in.height;
  std::vector<double> thetas, phis;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int k = 0; k < 29; ++k) {  // 3 full groups and a tail of 5
    thetas.push_back(kPi * unit(rng));
    phis.push_back(2 * kPi * (unit(rng) - 0.5));
  }
  // Rows: above the first centre, below the last; columns: the last centre and past it (the seam).
  const double last_x = (w - 0.5 + 0.5) / w;  // the last column's centre, x = w - 1
  for (const double theta : {0.0, 0.1 / h, kPi, kPi * (h - 0.5) / h})
    for (const double u : {last_x - 0.5 / w, last_x, last_x + 0.25 / w, 0.1 / w}) {
      thetas.push_back(theta);
      phis.push_back(2 * kPi * (u - 0.5));
    }
  for (const double turns : {-3.0, -1.0, 1.0, 2.0}) {  // a turn or more away
    thetas.push_back(1.0);
    phis.push_back(0.7 + 2 * kPi * turns);
  }
  const int n = static_cast<int>(thetas.size());
  std::vector<float> batch(3 * static_cast<size_t>(n));
  src.LatLongRadianceAt(thetas.data(), phis.data(), 0.0, n, batch.data());
  for (int k = 0; k < n; ++k) {
    const std::array<float, 3> one = src.LatLongRadianceAt(thetas[k], phis[k]);
    // The written-out blend: x, y pixel coordinates, clamped rows, wrapped columns.
    const double p = std::remainder(phis[k], 2 * kPi);
    const double x = (p / (2 * kPi) + 0.5) * w - 0.5;
    const double y = std::clamp(thetas[k] / kPi * h - 0.5, 0.0, h - 1.0);
    const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
    const double ax = x - x0, ay = y - y0;
    const int c0 = (x0 + w) % w, c1 = (x0 + 1 + w) % w, r1 = std::min(y0 + 1, h - 1);
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(batch[3 * k + c], one[c]) << "point " << k << " channel " << c;
      const double want = (1 - ay) * ((1 - ax) * in.at(c0, y0, c) + ax * in.at(c1, y0, c)) +
                          ay * ((1 - ax) * in.at(c0, r1, c) + ax * in.at(c1, r1, c));
      // Turned azimuths move x by whole widths: their rounding only (~1e-13 of a pixel).
      EXPECT_NEAR(batch[3 * k + c], want, kPixelCentreRelTol * want + 1e-30)
          << "point " << k << " theta " << thetas[k] << " phi " << phis[k] << " channel " << c;
    }
  }
}

// --- Lighting coefficients -----------------------------------------------------------------

TEST(EnvMapLighting, CubeResampledShtAgreesWithDirectSummation) {
  const EnvMap src = EnvMap::FromLatLong(Courtyard256());
  auto cube = EnvMap::FromImages(CubeFacesFrom(src, 64), EnvLayout::kAuto);
  ASSERT_TRUE(cube.ok());
  auto sht = LightingCoefficients(*cube, 8);
  auto direct = LightingCoefficientsDirect(*cube, 8, Mat3::Identity(), 2);
  ASSERT_TRUE(sht.ok() && direct.ok());
  EXPECT_LT(MaxRelCoeffDiff(*sht, *direct), kMethodCoeffRelTol);
  // On a lat-long map the direct sum uses the transform's own quadrature: identical up to
  // rounding for degrees plain Fejer quadrature resolves.
  auto a = LightingCoefficients(src, 8);
  auto b = LightingCoefficientsDirect(src, 8);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_LT(MaxRelCoeffDiff(*a, *b), kSameQuadratureTol);
}

TEST(EnvMapLighting, WhiteFurnaceInEveryLayout) {
  constexpr float kC = 0.75f;
  auto constant = [&](int w, int h) {
    Image img = MakeImage(w, h);
    std::fill(img.pixels.begin(), img.pixels.end(), kC);
    return img;
  };
  std::vector<EnvMap> maps = {EnvMap::FromLatLong(constant(64, 32))};
  std::vector<Image> faces;
  for (int f = 0; f < 6; ++f) faces.push_back(constant(16, 16));
  maps.push_back(*EnvMap::FromImages(faces, EnvLayout::kAuto));
  const std::vector<std::pair<int, int>> sizes = {{64, 48}, {48, 64}, {96, 16}, {16, 96}, {40, 40}};
  for (auto [w, h] : sizes) maps.push_back(*EnvMap::FromImages({constant(w, h)}, EnvLayout::kAuto));
  for (const EnvMap& m : maps) {
    auto c = LightingCoefficients(m, 6);
    ASSERT_TRUE(c.ok()) << c.status();
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR((*c)[ch], kC * std::sqrt(k4Pi), kFurnaceTol) << EnvLayoutName(m.layout());
      for (int i = 1; i < ShCount(6); ++i)
        EXPECT_NEAR((*c)[i * 3 + ch], 0.0, kFurnaceTol) << EnvLayoutName(m.layout()) << " " << i;
    }
  }
  // Direct summation over cube texels: L_00 exact (solid angles sum to 4 pi); higher bands are
  // the midpoint rule's error on the cube (l = 4 has a cube-invariant harmonic), O(1/S^2).
  auto d = LightingCoefficientsDirect(maps[1], 4);
  ASSERT_TRUE(d.ok());
  EXPECT_NEAR((*d)[0], kC * std::sqrt(k4Pi), kCubeSolidAngleTol);
  for (int l = 1; l <= 3; ++l)
    for (int m = -l; m <= l; ++m) EXPECT_NEAR((*d)[ShIndex(l, m) * 3], 0.0, kFurnaceTol);
}

TEST(EnvMapLighting, LatLongTooSmallForDegreeIsAnError) {
  const EnvMap small = EnvMap::FromLatLong(MakeImage(16, 8));
  EXPECT_EQ(LightingCoefficients(small, 8).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(LightingCoefficients(small, 7).ok());
  EXPECT_EQ(LightingCoefficients(small, -1).status().code(), absl::StatusCode::kInvalidArgument);
  Mat3 bad = Mat3::Identity();
  bad.m[0][0] = 2;
  EXPECT_EQ(LightingCoefficients(small, 2, bad).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// --- Rotation ------------------------------------------------------------------------------

// Rodrigues' formula: active right-handed rotation by `deg` about unit `axis` (independent of
// geometry.h's axis matrices).
Mat3 AxisAngle(const Vec3& axis, double deg) {
  const double a = deg * kPi / 180, c = std::cos(a), s = std::sin(a);
  const Vec3 k = axis.Normalized();
  Mat3 r;
  const double kk[3] = {k.x, k.y, k.z};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = (i == j ? c : 0) + (1 - c) * kk[i] * kk[j];
  r.m[0][1] -= s * k.z;
  r.m[0][2] += s * k.y;
  r.m[1][0] += s * k.z;
  r.m[1][2] -= s * k.x;
  r.m[2][0] -= s * k.y;
  r.m[2][1] += s * k.x;
  return r;
}

void ExpectMatNear(const Mat3& a, const Mat3& b, double tol) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(a.m[i][j], b.m[i][j], tol) << i << "," << j;
}

TEST(EnvMapRotation, YawPitchRollConvention) {
  auto apply = [](const Mat3& r, Vec3 v) { return r * v; };
  const Vec3 a = apply(RotationFromYawPitchRoll(90, 0, 0), {1, 0, 0});  // +X -> -Z
  EXPECT_NEAR(a.z, -1, kDirTol);
  const Vec3 b = apply(RotationFromYawPitchRoll(0, 90, 0), {0, 1, 0});  // +Y -> +Z
  EXPECT_NEAR(b.z, 1, kDirTol);
  const Vec3 c = apply(RotationFromYawPitchRoll(0, 0, 90), {1, 0, 0});  // +X -> +Y
  EXPECT_NEAR(c.y, 1, kDirTol);
  // Roll first, then pitch, then yaw.
  const Mat3 want = AxisAngle({0, 1, 0}, 25) * AxisAngle({1, 0, 0}, -40) * AxisAngle({0, 0, 1}, 70);
  ExpectMatNear(RotationFromYawPitchRoll(25, -40, 70), want, kDirTol);
  // M R M^T is the same rotation written in the SH frame.
  const Mat3 rs = ShFrameRotationFromWorld(want);
  const Vec3 w{0.3, -0.5, 0.8};
  const Vec3 lhs = rs * ShFrameFromWorld(w), rhs = ShFrameFromWorld(want * w);
  EXPECT_NEAR(lhs.x, rhs.x, kDirTol);
  EXPECT_NEAR(lhs.y, rhs.y, kDirTol);
  EXPECT_NEAR(lhs.z, rhs.z, kDirTol);
}

TEST(EnvMapRotation, YawByWholeColumnsEqualsShiftedImage) {
  const Image& img = Courtyard256();
  constexpr int kLmax = 40;
  for (int k : {1, 37, -64, 128}) {
    // A yaw of 2 pi k / W moves content k columns to the left: column i shows old column i + k.
    Image shifted = MakeImage(img.width, img.height);
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const int sx = ((x + k) % img.width + img.width) % img.width;
        SetPixel(shifted, x, y, {img.at(sx, y, 0), img.at(sx, y, 1), img.at(sx, y, 2)});
      }
    const double yaw = 360.0 * k / img.width;
    auto rotated =
        LightingCoefficients(EnvMap::FromLatLong(img), kLmax, RotationFromYawPitchRoll(yaw, 0, 0));
    auto want = LightingCoefficients(EnvMap::FromLatLong(shifted), kLmax);
    ASSERT_TRUE(rotated.ok() && want.ok());
    EXPECT_LT(MaxRelCoeffDiff(*rotated, *want), kShiftRelTol) << "k = " << k;
  }
}

// A yaw takes RotateLighting's z-rotation path (App. B, O(lmax^2)): the shifted image above is its
// independent reference; here, at a degree where the zxzxz path's cost shows, it agrees with that
// general path (RotateSh of the same matrix) to rounding.
TEST(EnvMapRotation, YawTakesTheZRotationPathAndEqualsTheGeneralRotation) {
  constexpr int kLmax = 120;
  // Rounding of ~2 lmax^2 operations per band in the zxzxz path, and the cos/sin(m alpha)
  // recurrence of App. B (measured 3e-14 relative to the largest coefficient).
  constexpr double kPathTol = 1e-12;
  const EnvMap src = EnvMap::FromLatLong(Courtyard256());
  auto orig = LightingCoefficients(src, kLmax);
  ASSERT_TRUE(orig.ok());
  for (double yaw : {17.0, -133.0, 90.0, 180.0}) {
    const Mat3 rot = RotationFromYawPitchRoll(yaw, 0, 0);
    std::vector<double> fast = *orig;
    ASSERT_TRUE(RotateLighting(kLmax, rot, fast).ok());
    const Mat3 rot_s = ShFrameRotationFromWorld(rot);
    const size_t n = ShCount(kLmax);
    std::vector<double> general(orig->size()), in(n), out(n);
    for (int c = 0; c < 3; ++c) {
      for (size_t i = 0; i < n; ++i) in[i] = (*orig)[i * 3 + c];
      ASSERT_TRUE(RotateShChecked(kLmax, rot_s, in, out).ok());
      for (size_t i = 0; i < n; ++i) general[i * 3 + c] = out[i];
    }
    double largest = 0, diff = 0;
    for (size_t i = 0; i < fast.size(); ++i) {
      largest = std::max(largest, std::abs(general[i]));
      diff = std::max(diff, std::abs(fast[i] - general[i]));
    }
    EXPECT_LE(diff, kPathTol * largest) << "yaw " << yaw;
  }
}

TEST(EnvMapRotation, GeneralRotationMatchesResampledRotatedMap) {
  const EnvMap src = EnvMap::FromLatLong(Courtyard256());
  const Mat3 rot = RotationFromYawPitchRoll(30, 20, -50);
  const Mat3 inv = rot.Transposed();
  constexpr int kW = 1024, kH = 512, kLmax = 8;
  Image fine = MakeImage(kW, kH);
  const ShtGrid grid{kW, kH, ShtGridKind::kEquiangular};
  for (int j = 0; j < kH; ++j)
    for (int i = 0; i < kW; ++i)
      SetPixel(fine, i, j, src.Radiance(inv * ShtGridDirection(grid, i, j)));
  auto want = LightingCoefficients(EnvMap::FromLatLong(fine), kLmax);
  auto got = LightingCoefficients(src, kLmax, rot);
  ASSERT_TRUE(want.ok() && got.ok());
  EXPECT_LT(MaxRelCoeffDiff(*got, *want), kRotResampleRelTol);
  // Direct summation with the same rotation applies the same SH-space rotation.
  auto direct = LightingCoefficientsDirect(src, kLmax, rot);
  ASSERT_TRUE(direct.ok());
  EXPECT_LT(MaxRelCoeffDiff(*direct, *got), kSameQuadratureTol);
}

TEST(EnvMapRotation, RotatedCoefficientsEvaluateToTheRotatedLighting) {
  const EnvMap src = EnvMap::FromLatLong(Courtyard256());
  constexpr int kLmax = 16;
  const Mat3 rot = RotationFromYawPitchRoll(-123, 47, 15);
  auto orig = LightingCoefficients(src, kLmax);
  auto rotated = LightingCoefficients(src, kLmax, rot);
  ASSERT_TRUE(orig.ok() && rotated.ok());
  std::mt19937 rng(3);
  std::vector<Vec3> dirs, pre;
  for (int k = 0; k < 500; ++k) {
    dirs.push_back(RandomDirection(rng));
    pre.push_back(rot.Transposed() * dirs.back());
  }
  std::vector<double> a(dirs.size() * 3), b(dirs.size() * 3);
  ASSERT_TRUE(SynthesizeAtDirections(kLmax, 3, *rotated, dirs, a).ok());
  ASSERT_TRUE(SynthesizeAtDirections(kLmax, 3, *orig, pre, b).ok());
  const double scale = std::abs((*orig)[0]);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], kPointwiseTol * scale) << i;
}

// --- Loading: colour and errors ---------------------------------------------------------------

TEST(EnvMapLoad, ConvertsInputColourSpaces) {
  // 8-bit PNG: sRGB-encoded by default, decoded to linear Rec.709.
  Image enc = MakeImage(16, 8);
  std::fill(enc.pixels.begin(), enc.pixels.end(), 128 / 255.0f);
  const std::string png = TempPath("srgb.png");
  ASSERT_TRUE(WriteImage8Bit(png, enc).ok());
  EnvMapOptions opts;
  opts.paths = {png};
  auto map = EnvMap::Load(opts);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(map->layout(), EnvLayout::kLatLong);
  const double want = std::pow((128 / 255.0 + 0.055) / 1.055, 2.4);
  EXPECT_NEAR(map->samples()[0].rgb[0], want, kFloatTol);
  // Explicit raw input: no decoding.
  opts.input_colour_space = "raw";
  map = EnvMap::Load(opts);
  ASSERT_TRUE(map.ok());
  EXPECT_NEAR(map->samples()[0].rgb[0], 128 / 255.0, kFloatTol);
  fs::remove(png);
  // Float EXR: scene-linear Rec.709 by default; into an ACEScg working space.
  Image red = MakeImage(16, 8);
  for (size_t p = 0; p < red.pixels.size(); p += 3) red.pixels[p] = 1.0f;
  const std::string exr = TempPath("red.exr");
  ASSERT_TRUE(WriteExr(exr, red).ok());
  opts = {};
  opts.paths = {exr};
  opts.working_colour_space = "lin_ap1";
  map = EnvMap::Load(opts);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_NEAR(map->samples()[0].rgb[0], 0.613097, kPublishedMatrixTol);
  EXPECT_NEAR(map->samples()[0].rgb[1], 0.070194, kPublishedMatrixTol);
  EXPECT_NEAR(map->samples()[0].rgb[2], 0.020616, kPublishedMatrixTol);
  // Unknown colour space: InvalidArgument listing the valid names.
  opts.working_colour_space = "linear";
  auto bad = EnvMap::Load(opts);
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.status().message().find("lin_rec709"), std::string::npos) << bad.status();
  fs::remove(exr);
}

TEST(EnvMapLoad, RealMapLoadsAsLatLongUnchanged) {
  EnvMapOptions opts;
  opts.paths = {MapPath("forest.exr")};
  auto map = EnvMap::Load(opts);
  ASSERT_TRUE(map.ok()) << map.status();
  EXPECT_EQ(map->layout(), EnvLayout::kLatLong);
  EXPECT_EQ(map->width(), 1024);
  EXPECT_EQ(map->height(), 512);
  EXPECT_EQ(map->face_size(), 0);
  auto raw = ReadImageRgb(MapPath("forest.exr"));
  ASSERT_TRUE(raw.ok());
  // Float EXR defaults to lin_rec709 = the working space: pixels untouched.
  EXPECT_EQ(map->lat_long_image()->pixels, raw->pixels);
  auto c = LightingCoefficients(*map, 16, Mat3::Identity(), 2);
  ASSERT_TRUE(c.ok()) << c.status();
  EXPECT_GT((*c)[0], 0);
}

// LightingEnergy sums a lat-long map ring by ring from the image; the slow twin is the sum of
// L^2 d omega over the map's samples (their directions and solid angles, EnvMap::BuildSamples).
TEST(EnvMapLighting, LatLongEnergyEqualsTheSumOverTheSamples) {
  constexpr double kRoundingTol = 1e-12;  // relative: double sums of ~5e5 terms in two orders
  for (const char* name : {"city.exr", "courtyard.exr", "forest.exr", "interior.exr"}) {
    SCOPED_TRACE(name);
    EnvMapOptions opts;
    opts.paths = {MapPath(name)};
    auto map = EnvMap::Load(opts);
    ASSERT_TRUE(map.ok()) << map.status();
    const std::array<double, 3> fast = LightingEnergy(*map);
    std::array<double, 3> slow{0, 0, 0};
    for (const EnvSample& s : map->samples())
      for (int c = 0; c < 3; ++c) slow[c] += s.solid_angle * double{s.rgb[c]} * s.rgb[c];
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(fast[c], slow[c], kRoundingTol * slow[c]) << c;
  }
}

void ExpectError(const absl::Status& st, absl::StatusCode code,
                 const std::vector<std::string>& parts) {
  EXPECT_EQ(st.code(), code) << st;
  for (const auto& p : parts) EXPECT_NE(st.message().find(p), std::string::npos) << st;
}

TEST(EnvMapLoad, BadInputGivesClearErrors) {
  const std::string odd = TempPath("odd.exr");
  ASSERT_TRUE(WriteExr(odd, MakeImage(30, 20)).ok());
  EnvMapOptions opts;
  opts.paths = {odd};
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument,
              {odd, "30 x 20", "2:1", "4:3", "3:4", "6:1", "1:6", "1:1"});
  opts.layout = EnvLayout::kAngular;
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument,
              {odd, "30 x 20", "angular"});
  fs::remove(odd);

  const std::string cross = TempPath("cross.exr");
  ASSERT_TRUE(WriteExr(cross, MakeImage(42, 30)).ok());  // 4:3-ish, not 4 S x 3 S
  opts.paths = {cross};
  opts.layout = EnvLayout::kHorizontalCross;
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument,
              {cross, "42 x 30", "horizontal cross"});
  opts.layout = EnvLayout::kCubeFaces;
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument, {"six files"});
  fs::remove(cross);

  // Six faces: one missing, one of another size.
  std::vector<std::string> faces;
  for (int f = 0; f < 6; ++f) {
    faces.push_back(TempPath(std::string("bad_") + kCubeFaceNames[f] + ".exr"));
    ASSERT_TRUE(WriteExr(faces.back(), MakeImage(f == 4 ? 8 : 16, f == 4 ? 8 : 16)).ok());
  }
  opts = {};
  opts.paths = faces;
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument,
              {faces[4], "+Z", "8 x 8", "16 x 16"});
  fs::remove(faces[3]);
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kNotFound, {faces[3], "-Y"});
  for (const auto& f : faces) fs::remove(f);
  opts.paths = {faces[0], faces[1]};
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument, {"got 2 files"});

  // NaN pixels: rejected by default (naming the file), replaced by 0 on request.
  Image nan_img = MakeImage(16, 8);
  nan_img.pixels[3 * 19 + 1] = std::nanf("");
  const std::string nan_path = TempPath("nan.exr");
  ASSERT_TRUE(WriteExr(nan_path, nan_img).ok());
  opts = {};
  opts.paths = {nan_path};
  ExpectError(EnvMap::Load(opts).status(), absl::StatusCode::kInvalidArgument,
              {nan_path, "non-finite"});
  opts.non_finite = NonFinitePolicy::kReplaceZero;
  auto ok = EnvMap::Load(opts);
  ASSERT_TRUE(ok.ok()) << ok.status();
  EXPECT_EQ(ok->replaced_non_finite(), 1);
  EXPECT_EQ(ok->samples()[19].rgb[1], 0.0f);
  fs::remove(nan_path);

  EXPECT_EQ(ParseEnvLayout("HCross").value(), EnvLayout::kHorizontalCross);
  ExpectError(ParseEnvLayout("sphere").status(), absl::StatusCode::kInvalidArgument,
              {"sphere", "latlong", "angular"});
}

}  // namespace
}  // namespace shrm
