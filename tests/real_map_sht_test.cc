// The transform on the bundled real HDR maps (suns up to ~34,000): exact grid symmetries of the
// lat-long image must act on the coefficients as the corresponding SH rotations/reflections, and
// the irradiance from the coefficients must equal brute-force integration over the pixels.
#include <cmath>
#include <string>
#include <vector>

#include "core/io/image.h"
#include "core/sh/hbasis.h"
#include "core/sh/quadrature.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/transform/sht.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Symmetry checks compare two transforms of the same pixels reordered: only rounding differs,
// relative to the largest coefficient (the sun makes coefficients span ~6 decades).
constexpr double kSymmetryTol = 1e-12;
// Irradiance by band factors (degree <= 127) against a pixel sum of L max(n.w, 0): the pixel sum
// integrates a kinked kernel with an O(h^2) error, h = pi/128, and the SH route truncates A_l
// (|A_l| ~ l^-2.5); measured worst case 4.9e-4 over the four maps and six normals.
constexpr double kIrradianceTol = 1e-3;

constexpr int kFactor = 4;  // 1024 x 512 -> 256 x 128: keeps the tests fast

Image LoadDownsampled(const std::string& name) {
  return testing::LoadBundledMap(name, 1024 / kFactor);
}

class RealMapShtTest : public ::testing::TestWithParam<std::string> {};

double MaxAbs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// Shifting the columns by k is a rotation about +Y by -2 pi k / W of the lighting (the image
// azimuth runs clockwise seen from +Y): coefficients change by the App. B z-rotation.
TEST_P(RealMapShtTest, ColumnShiftIsZRotation) {
  const Image img = LoadDownsampled(GetParam());
  const ShtGrid grid{img.width, img.height, ShtGridKind::kEquiangular};
  constexpr int kLmax = 100;
  constexpr int kShift = 37;
  std::vector<float> shifted(img.pixels.size());
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width; ++i)
      for (int c = 0; c < 3; ++c)
        shifted[(j * img.width + (i + kShift) % img.width) * 3 + c] = img.at(i, j, c);
  auto a = ForwardSht(grid, kLmax, 3, img.pixels);
  auto b = ForwardSht(grid, kLmax, 3, shifted);
  ASSERT_TRUE(a.ok() && b.ok());
  const double alpha = -2 * kPi * kShift / img.width;
  std::vector<double> in(ShCount(kLmax)), out(ShCount(kLmax));
  const double scale = MaxAbs(*a);
  for (int c = 0; c < 3; ++c) {
    for (int i = 0; i < ShCount(kLmax); ++i) in[i] = (*a)[i * 3 + c];
    RotateShZ(kLmax, alpha, in, out);
    for (int i = 0; i < ShCount(kLmax); ++i)
      ASSERT_NEAR(out[i], (*b)[i * 3 + c], kSymmetryTol * scale) << "index " << i;
  }
}

// Flipping the rows is the reflection y -> -y (world), z_s -> -z_s: Y_lm picks up (-1)^(l+m).
TEST_P(RealMapShtTest, RowFlipIsParity) {
  const Image img = LoadDownsampled(GetParam());
  const ShtGrid grid{img.width, img.height, ShtGridKind::kEquiangular};
  constexpr int kLmax = 127;  // = H - 1: exercises the exact theta-resampling path
  std::vector<float> flipped(img.pixels.size());
  for (int j = 0; j < img.height; ++j)
    for (int i = 0; i < img.width * 3; ++i)
      flipped[(img.height - 1 - j) * img.width * 3 + i] = img.pixels[j * img.width * 3 + i];
  auto a = ForwardSht(grid, kLmax, 3, img.pixels);
  auto b = ForwardSht(grid, kLmax, 3, flipped);
  ASSERT_TRUE(a.ok() && b.ok());
  const double scale = MaxAbs(*a);
  for (int l = 0; l <= kLmax; ++l)
    for (int m = -l; m <= l; ++m)
      for (int c = 0; c < 3; ++c) {
        const double sign = (l + std::abs(m)) % 2 ? -1.0 : 1.0;
        ASSERT_NEAR(sign * (*a)[ShIndex(l, m) * 3 + c], (*b)[ShIndex(l, m) * 3 + c],
                    kSymmetryTol * scale)
            << l << " " << m;
      }
}

// Irradiance E(n) = integral L(w) max(n.w, 0) dw two ways: E_lm = A_l L_lm (H-basis paper eq. 6
// times pi; Ramamoorthi-Hanrahan) synthesized at n, and a direct sum over the map's pixels with
// their quadrature solid angles.
TEST_P(RealMapShtTest, IrradianceFromCoefficientsEqualsPixelSum) {
  const Image img = LoadDownsampled(GetParam());
  const ShtGrid grid{img.width, img.height, ShtGridKind::kEquiangular};
  constexpr int kLmax = 127;
  auto coeffs = ForwardSht(grid, kLmax, 3, img.pixels);
  ASSERT_TRUE(coeffs.ok());
  std::vector<double> irr(coeffs->size());
  for (int l = 0; l <= kLmax; ++l)
    for (int m = -l; m <= l; ++m)
      for (int c = 0; c < 3; ++c)
        irr[ShIndex(l, m) * 3 + c] = LambertianBandFactor(l) * (*coeffs)[ShIndex(l, m) * 3 + c];
  const RingQuadrature q = FejerFirstRule(img.height);
  const std::vector<Vec3> normals = {{0, 1, 0},  {0, -1, 0},         {1, 0, 0},
                                     {0, 0, -1}, {0.6, 0.48, -0.64}, {-0.36, -0.48, 0.8}};
  std::vector<double> sh(normals.size() * 3);
  ASSERT_TRUE(SynthesizeAtDirections(kLmax, 3, irr, normals, sh).ok());
  for (size_t k = 0; k < normals.size(); ++k) {
    double ref[3] = {0, 0, 0};
    for (int j = 0; j < img.height; ++j)
      for (int i = 0; i < img.width; ++i) {
        const double cosine = std::max(0.0, normals[k].Dot(ShtGridDirection(grid, i, j)));
        const double w = q.weight[j] * 2 * kPi / img.width * cosine;
        for (int c = 0; c < 3; ++c) ref[c] += w * img.at(i, j, c);
      }
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(sh[k * 3 + c], ref[c], kIrradianceTol * ref[c]) << "normal " << k << " c " << c;
  }
}

INSTANTIATE_TEST_SUITE_P(BundledMaps, RealMapShtTest,
                         ::testing::Values("city.exr", "courtyard.exr", "forest.exr",
                                           "interior.exr"),
                         [](const auto& test_info) {
                           return test_info.param.substr(0, test_info.param.find('.'));
                         });

}  // namespace
}  // namespace shrm
