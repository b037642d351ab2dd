// Tests of core/sh/rotation.h: zyz decomposition (round trip, gimbal points), real band blocks
// against the definitional conj(U) D U^T, orthogonality and the group law up to l = 64, rotation
// of coefficients against projection of the rotated function on a Gauss-Legendre grid, App. B's
// z-rotation, the zxzxz-rotation, and argument validation.
#include "core/sh/rotation.h"

#include <cmath>
#include <random>
#include <vector>

#include "core/base/geometry.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"
#include "gtest/gtest.h"

namespace shrm {
namespace {

constexpr double kRoundTripTol = 1e-14;   // Euler -> matrix -> Euler, a few ulps of O(1) entries
constexpr double kBlockTol = 1e-13;       // direct real blocks vs complex conj(U) D U^T, l <= 12
constexpr double kUnitaryTol = 1e-12;     // R R^T = I, (2l+1)-term sums up to l = 64
constexpr double kGroupTol = 1e-12;       // D(R1) D(R2) = D(R1 R2), up to l = 64
constexpr double kProjectionTol = 1e-10;  // the bound: rotate vs project, l <= 64
constexpr double kPathTol = 1e-12;        // two exact rotation paths (z, y) agree, l <= 64
constexpr double kChainTol = 5e-12;       // zxzxz: five factors, 129-term sums at l = 64

Mat3 RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0, 1);
  Quaternion q{n(rng), n(rng), n(rng), n(rng)};
  return q.ToMatrix();
}

std::vector<double> RandomCoeffs(int lmax, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> c(ShCount(lmax));
  for (double& x : c) x = u(rng);
  return c;
}

double MaxMatDiff(const Mat3& a, const Mat3& b) {
  double d = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) d = std::max(d, std::abs(a.m[i][j] - b.m[i][j]));
  return d;
}

double MaxDiff(std::span<const double> a, std::span<const double> b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

TEST(EulerTest, RoundTripRandom) {
  std::mt19937_64 rng(1);
  for (int t = 0; t < 1000; ++t) {
    const Mat3 r = RandomRotation(rng);
    const EulerZYZ e = EulerFromMatrix(r);
    EXPECT_GE(e.beta, 0);
    EXPECT_LE(e.beta, kPi);
    EXPECT_GT(e.alpha, -kPi);
    EXPECT_LE(e.alpha, kPi);
    EXPECT_GT(e.gamma, -kPi);
    EXPECT_LE(e.gamma, kPi);
    EXPECT_LT(MaxMatDiff(MatrixFromEuler(e), r), kRoundTripTol);
    // Angles -> matrix -> angles, away from the gimbal points.
    const EulerZYZ e2 = EulerFromMatrix(MatrixFromEuler(e));
    EXPECT_NEAR(e2.beta, e.beta, 1e-13);
    if (std::sin(e.beta) > 1e-3) {
      EXPECT_NEAR(std::remainder(e2.alpha - e.alpha, 2 * kPi), 0, 1e-12);
      EXPECT_NEAR(std::remainder(e2.gamma - e.gamma, 2 * kPi), 0, 1e-12);
    }
    // The trig-free variant describes the same rotation.
    const ZyzCosSin cs = ZyzCosSinFromMatrix(r);
    EXPECT_NEAR(cs.cos_alpha, std::cos(e.alpha), 1e-13);
    EXPECT_NEAR(cs.sin_alpha, std::sin(e.alpha), 1e-13);
    EXPECT_NEAR(cs.cos_gamma, std::cos(e.gamma), 1e-13);
    EXPECT_NEAR(cs.sin_gamma, std::sin(e.gamma), 1e-13);
    EXPECT_NEAR(cs.cos_beta, std::cos(e.beta), 1e-13);
    EXPECT_NEAR(cs.sin_beta, std::sin(e.beta), 1e-13);
    EXPECT_NEAR(cs.beta, e.beta, 1e-13);
    // Quaternion path.
    const Quaternion q = QuaternionFromMatrix(r);
    EXPECT_LT(MaxMatDiff(q.ToMatrix(), r), kRoundTripTol);
    const EulerZYZ eq = EulerFromQuaternion(Quaternion{-2 * q.w, -2 * q.x, -2 * q.y, -2 * q.z});
    EXPECT_LT(MaxMatDiff(MatrixFromEuler(eq), r), kRoundTripTol);
  }
}

TEST(EulerTest, GimbalPoints) {
  for (double a : {-3.0, -0.5, 0.0, 1.2, kPi}) {
    for (double g : {-2.0, 0.0, 0.7}) {
      // beta = 0: only alpha + gamma is defined; gamma is set to 0.
      Mat3 r = RotationZ(a) * RotationZ(g);
      EulerZYZ e = EulerFromMatrix(r);
      EXPECT_EQ(e.beta, 0.0);
      EXPECT_EQ(e.gamma, 0.0);
      EXPECT_NEAR(std::remainder(e.alpha - (a + g), 2 * kPi), 0, 1e-14);
      EXPECT_LT(MaxMatDiff(MatrixFromEuler(e), r), kRoundTripTol);
      // beta = pi: only alpha - gamma is defined.
      r = RotationZ(a) * RotationY(kPi) * RotationZ(g);
      e = EulerFromMatrix(r);
      EXPECT_EQ(e.beta, kPi);
      EXPECT_EQ(e.gamma, 0.0);
      EXPECT_NEAR(std::remainder(e.alpha - (a - g), 2 * kPi), 0, 1e-14);
      EXPECT_LT(MaxMatDiff(MatrixFromEuler(e), r), kRoundTripTol);
      // Near the gimbal points the decomposition stays accurate.
      for (double b : {1e-12, 1e-9, 1e-6, kPi - 1e-9, kPi - 1e-6}) {
        r = RotationZ(a) * RotationY(b) * RotationZ(g);
        e = EulerFromMatrix(r);
        EXPECT_LT(MaxMatDiff(MatrixFromEuler(e), r), kRoundTripTol) << b;
        EXPECT_NEAR(e.beta, b, 1e-15 + 1e-12 * b);
      }
    }
  }
  const EulerZYZ id = EulerFromMatrix(Mat3::Identity());
  EXPECT_EQ(id.alpha, 0.0);
  EXPECT_EQ(id.beta, 0.0);
  EXPECT_EQ(id.gamma, 0.0);
}

TEST(RealRotationBlocksTest, MatchComplexDefinition) {
  constexpr int kLmax = 12;
  const EulerZYZ e{0.7, 1.9, -2.4};
  std::vector<double> blocks(WignerTableSize(kLmax));
  RealRotationBlocks(kLmax, e, blocks);
  const std::vector<std::complex<double>> d = WignerDTable(kLmax, e.alpha, e.beta, e.gamma);
  for (int l = 0; l <= kLmax; ++l) {
    const int w = 2 * l + 1;
    const std::vector<double> ref = RealBlockFromComplex(
        l, std::span<const std::complex<double>>(d).subspan(WignerBandOffset(l), w * w));
    EXPECT_LT(MaxDiff(ref, std::span<const double>(blocks).subspan(WignerBandOffset(l), w * w)),
              kBlockTol)
        << "l=" << l;
  }
}

TEST(RealRotationBlocksTest, KnownBandOne) {
  // f = z (prop. to Y_10) rotated by Ry(b) is z cos b + x sin b; Y_11 = -sqrt(3/4pi) x, so
  // c'_{1,0} = cos b, c'_{1,1} = -sin b, c'_{1,-1} = 0 for c = e_{1,0}.
  const double b = 0.6;
  std::vector<double> in(4, 0.0), out(4);
  in[ShIndex(1, 0)] = 1;
  RotateSh(1, RotationY(b), in, out);
  EXPECT_NEAR(out[ShIndex(1, 0)], std::cos(b), 1e-15);
  EXPECT_NEAR(out[ShIndex(1, 1)], -std::sin(b), 1e-15);
  EXPECT_NEAR(out[ShIndex(1, -1)], 0, 1e-15);
}

TEST(RealRotationBlocksTest, OrthogonalAndGroupLawToL64) {
  constexpr int kLmax = 64;
  std::mt19937_64 rng(2);
  for (int t = 0; t < 2; ++t) {
    const Mat3 r1 = RandomRotation(rng), r2 = RandomRotation(rng);
    const ShRotation d1 = ShRotation::Create(kLmax, r1);
    const ShRotation d2 = ShRotation::Create(kLmax, r2);
    const ShRotation d12 = ShRotation::Create(kLmax, r1 * r2);
    double worst_unit = 0, worst_group = 0;
    for (int l = 0; l <= kLmax; ++l) {
      const int w = 2 * l + 1;
      const auto a = d1.Band(l), b = d2.Band(l), c = d12.Band(l);
      for (int i = 0; i < w; ++i)
        for (int j = 0; j < w; ++j) {
          double s = 0, g = 0;
          for (int k = 0; k < w; ++k) {
            s += a[i * w + k] * a[j * w + k];
            g += a[i * w + k] * b[k * w + j];
          }
          worst_unit = std::max(worst_unit, std::abs(s - (i == j ? 1.0 : 0.0)));
          worst_group = std::max(worst_group, std::abs(g - c[i * w + j]));
        }
    }
    EXPECT_LT(worst_unit, kUnitaryTol);
    EXPECT_LT(worst_group, kGroupTol);
  }
}

// Rotating coefficients equals projecting the rotated function f(Rot^-1 w) on a Gauss-Legendre
// x uniform-phi grid that integrates degree-2 lmax products exactly.
void CheckAgainstProjection(int lmax, const Mat3& rot, const std::vector<double>& c) {
  const int n = ShCount(lmax);
  const int rings = lmax + 1, nphi = 2 * lmax + 1;
  const RingQuadrature q = GaussLegendreRule(rings);
  std::vector<double> projected(n, 0.0);
  std::vector<Vec3> dirs(nphi), rotated(nphi);
  std::vector<double> y(static_cast<size_t>(n) * nphi), yr(y.size()), f(nphi);
  const Mat3 inv = rot.Transposed();
  for (int j = 0; j < rings; ++j) {
    for (int k = 0; k < nphi; ++k) {
      dirs[k] = DirectionFromAngles(q.theta[j], 2 * kPi * k / nphi);
      rotated[k] = inv * dirs[k];
    }
    EvalShBatch(lmax, dirs, y);
    EvalShBatch(lmax, rotated, yr);
    std::fill(f.begin(), f.end(), 0.0);
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < nphi; ++k) f[k] += c[i] * yr[static_cast<size_t>(i) * nphi + k];
    const double wgt = q.weight[j] * 2 * kPi / nphi;
    for (int i = 0; i < n; ++i) {
      double s = 0;
      for (int k = 0; k < nphi; ++k) s += f[k] * y[static_cast<size_t>(i) * nphi + k];
      projected[i] += wgt * s;
    }
  }
  std::vector<double> rotated_coeffs(n);
  RotateSh(lmax, rot, c, rotated_coeffs);  // zxzxz path
  EXPECT_LT(MaxDiff(rotated_coeffs, projected), kProjectionTol) << "lmax=" << lmax;
  ShRotation::Create(lmax, rot).Apply(c, rotated_coeffs);  // band matrices
  EXPECT_LT(MaxDiff(rotated_coeffs, projected), kProjectionTol) << "lmax=" << lmax;
}

TEST(RotateShTest, EqualsProjectionOfRotatedFunction) {
  std::mt19937_64 rng(3);
  for (int lmax : {0, 1, 2, 3, 5, 8, 13, 21}) {
    for (int t = 0; t < 3; ++t)
      CheckAgainstProjection(lmax, RandomRotation(rng), RandomCoeffs(lmax, rng));
  }
  // Gimbal points and the axes.
  CheckAgainstProjection(6, RotationZ(0.4), RandomCoeffs(6, rng));
  CheckAgainstProjection(6, RotationZ(0.4) * RotationY(kPi), RandomCoeffs(6, rng));
  CheckAgainstProjection(6, RotationX(0.9), RandomCoeffs(6, rng));
}

TEST(RotateShTest, EqualsProjectionAtL64) {
  std::mt19937_64 rng(4);
  CheckAgainstProjection(64, RandomRotation(rng), RandomCoeffs(64, rng));
}

TEST(RotateShZTest, AppendixBEqualsGeneralPath) {
  constexpr int kLmax = 64;
  std::mt19937_64 rng(5);
  const std::vector<double> c = RandomCoeffs(kLmax, rng);
  std::vector<double> a(c.size()), b(c.size()), inplace = c;
  for (double alpha : {0.0, 1e-7, 0.3, -2.9, kPi}) {
    RotateShZ(kLmax, alpha, c, a);
    ShRotation::Create(kLmax, RotationZ(alpha)).Apply(c, b);  // band matrices
    EXPECT_LT(MaxDiff(a, b), kPathTol) << alpha;
    RotateSh(kLmax, RotationZ(alpha), c, b);  // zxzxz
    EXPECT_LT(MaxDiff(a, b), kChainTol) << alpha;
    // Independent reference: cos/sin(m alpha) from the library's trig functions.
    for (int l = 0; l <= kLmax; ++l)
      for (int m = 1; m <= l; ++m) {
        const double cm = std::cos(m * alpha), sm = std::sin(m * alpha);
        const double p = c[ShIndex(l, m)], q = c[ShIndex(l, -m)];
        ASSERT_NEAR(a[ShIndex(l, m)], cm * p - sm * q, kPathTol) << l << " " << m;
        ASSERT_NEAR(a[ShIndex(l, -m)], sm * p + cm * q, kPathTol) << l << " " << m;
      }
    inplace = c;
    RotateShZ(kLmax, alpha, inplace, inplace);
    EXPECT_EQ(MaxDiff(a, inplace), 0.0);
  }
}

TEST(RotateShYTest, EqualsGeneralPath) {
  constexpr int kLmax = 40;
  std::mt19937_64 rng(6);
  const std::vector<double> c = RandomCoeffs(kLmax, rng);
  std::vector<double> a(c.size()), b(c.size());
  for (double beta : {0.0, 0.2, 1.5, 3.0, -0.8}) {
    RotateShY(kLmax, beta, c, a);
    RotateSh(kLmax, RotationY(beta), c, b);  // zxzxz
    EXPECT_LT(MaxDiff(a, b), kChainTol) << beta;
    ShRotation::Create(kLmax, RotationY(beta)).Apply(c, b);
    EXPECT_LT(MaxDiff(a, b), kPathTol) << beta;
  }
}

TEST(ZxzxzRotationTest, EqualsExactRotation) {
  std::mt19937_64 rng(7);
  for (int lmax : {0, 1, 4, 9, 30, 64}) {
    const ZxzxzRotation z = *ZxzxzRotation::Create(lmax);
    for (int t = 0; t < 3; ++t) {
      const Mat3 r = RandomRotation(rng);
      const std::vector<double> c = RandomCoeffs(lmax, rng);
      std::vector<double> a(c.size()), b(c.size());
      z.Apply(r, c, a);
      ShRotation::Create(lmax, r).Apply(c, b);
      EXPECT_LT(MaxDiff(a, b), kChainTol) << "lmax=" << lmax;
    }
    // Gimbal point beta = pi.
    const std::vector<double> c = RandomCoeffs(lmax, rng);
    std::vector<double> a(c.size()), b(c.size());
    z.Apply(RotationZ(0.3) * RotationY(kPi), c, a);
    RotateSh(lmax, RotationZ(0.3) * RotationY(kPi), c, b);
    EXPECT_LT(MaxDiff(a, b), kChainTol);
  }
}

// ApplyMany (k vectors, each its own rotation, interleaved) against the exact rotation of each
// vector alone (ShRotation's Wigner-D blocks).
TEST(ZxzxzRotationTest, ManyRotationsAtOnceEqualTheExactOnes) {
  std::mt19937_64 rng(11);
  for (int lmax : {0, 1, 9, 24, 31}) {
    const ZxzxzRotation z = *ZxzxzRotation::Create(lmax);
    for (int k : {1, 3, 24}) {
      const int n = ShCount(lmax);
      std::vector<Mat3> rots;
      std::vector<ZyzCosSin> angles;
      std::vector<std::vector<double>> vecs;
      std::vector<double> in(static_cast<size_t>(n) * k), out(in.size());
      for (int j = 0; j < k; ++j) {
        // Every fourth rotation at the gimbal point beta = pi.
        rots.push_back(j % 4 == 3 ? RotationZ(0.1 * j) * RotationY(kPi) : RandomRotation(rng));
        angles.push_back(ZyzCosSinFromMatrix(rots.back()));
        vecs.push_back(RandomCoeffs(lmax, rng));
        for (int i = 0; i < n; ++i) in[static_cast<size_t>(i) * k + j] = vecs.back()[i];
      }
      z.ApplyMany(angles, in.data(), out.data());
      for (int j = 0; j < k; ++j) {
        std::vector<double> want(n), got(n);
        ShRotation::Create(lmax, rots[j]).Apply(vecs[j], want);
        for (int i = 0; i < n; ++i) got[i] = out[static_cast<size_t>(i) * k + j];
        EXPECT_LT(MaxDiff(got, want), kChainTol) << "lmax=" << lmax << " k=" << k << " j=" << j;
      }
    }
  }
}

TEST(ZxzxzRotationTest, XMatrixIsQuarterDense) {
  // Paper sec. 3.2: N_x(n) = n (n^2 + 2) / 3 nonzeros of x(pi/2) for order n.
  for (int lmax : {4, 9, 20}) {
    const int n = lmax + 1;
    EXPECT_EQ(ZxzxzRotation::Create(lmax)->NonZeros(), n * (n * n + 2) / 3) << lmax;
  }
}

TEST(ShRotationTest, ArgumentValidation) {
  std::vector<double> in(9, 0.0), out(9, 0.0);
  EXPECT_FALSE(RotateShChecked(-1, Mat3::Identity(), in, out).ok());
  EXPECT_FALSE(RotateShChecked(kMaxRotationLmax + 1, Mat3::Identity(), in, out).ok());
  EXPECT_FALSE(RotateShChecked(3, Mat3::Identity(), in, out).ok());  // needs 16 entries
  EXPECT_FALSE(RotateShChecked(2, Mat3::Identity(), in, in).ok());   // aliasing
  Mat3 scaled = Mat3::Identity();
  scaled.m[0][0] = 2;
  EXPECT_FALSE(RotateShChecked(2, scaled, in, out).ok());
  Mat3 mirror = Mat3::Identity();
  mirror.m[2][2] = -1;
  EXPECT_FALSE(RotateShChecked(2, mirror, in, out).ok());
  Mat3 nan = Mat3::Identity();
  nan.m[1][1] = std::nan("");
  EXPECT_FALSE(RotateShChecked(2, nan, in, out).ok());
  EXPECT_TRUE(RotateShChecked(2, RotationX(0.3), in, out).ok());
  EXPECT_FALSE(ShRotation::CreateChecked(-2, Mat3::Identity()).ok());
  EXPECT_FALSE(ShRotation::CreateChecked(2, scaled).ok());
  EXPECT_TRUE(ShRotation::CreateChecked(2, Mat3::Identity()).ok());
  EXPECT_FALSE(ZxzxzRotation::Create(-1).ok());
}

}  // namespace
}  // namespace shrm
