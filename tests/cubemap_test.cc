// Cube-map geometry: the GL major-axis table round trip, face orientation facts from the GL
// specification, and texel solid angles summing to the sphere.
#include "core/base/cubemap.h"

#include <random>

#include "gtest/gtest.h"

namespace shrm {
namespace {

constexpr double kRoundTripTol = 1e-14;   // a few ulps
constexpr double kSolidAngleTol = 1e-12;  // sum of 6 S^2 exact atan terms

TEST(CubemapTest, FaceCentresAreTheAxes) {
  const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int f = 0; f < 6; ++f) {
    const Vec3 d = CubeFaceDirection(f, 0.5, 0.5);
    EXPECT_EQ(d.x, axes[f].x);
    EXPECT_EQ(d.y, axes[f].y);
    EXPECT_EQ(d.z, axes[f].z);
  }
}

TEST(CubemapTest, GlOrientation) {
  // GL table: +X face: s grows towards -Z, t grows towards -Y; +Y face: s towards +X, t towards +Z.
  Vec3 d = CubeFaceDirection(kPosX, 1, 0.5);
  EXPECT_LT(d.z, 0);
  d = CubeFaceDirection(kPosX, 0.5, 1);
  EXPECT_LT(d.y, 0);
  d = CubeFaceDirection(kPosY, 0.5, 1);
  EXPECT_GT(d.z, 0);
  d = CubeFaceDirection(kNegZ, 1, 0.5);
  EXPECT_LT(d.x, 0);
}

TEST(CubemapTest, CoordinatesRoundTrip) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.001, 0.999);
  for (int f = 0; f < 6; ++f)
    for (int k = 0; k < 200; ++k) {
      const double s = u(rng), t = u(rng);
      int f2;
      double s2, t2;
      CubeFaceCoordinates(CubeFaceDirection(f, s, t) * 3.7, &f2, &s2, &t2);
      EXPECT_EQ(f2, f);
      EXPECT_NEAR(s2, s, kRoundTripTol);
      EXPECT_NEAR(t2, t, kRoundTripTol);
    }
}

TEST(CubemapTest, SolidAnglesCoverTheSphere) {
  for (int size : {1, 2, 7, 64}) {
    double sum = 0;
    for (int f = 0; f < 6; ++f)
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) sum += CubeTexelSolidAngle(x, y, size);
    EXPECT_NEAR(sum, 4 * kPi, kSolidAngleTol) << size;
  }
  // One face of a 1-texel cube is a sixth of the sphere.
  EXPECT_NEAR(CubeTexelSolidAngle(0, 0, 1), 4 * kPi / 6, kSolidAngleTol);
}

}  // namespace
}  // namespace shrm
