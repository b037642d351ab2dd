// SH transforms (core/transform/sht.h) against independent references: per-pixel / batched SH
// evaluation (core/sh), brute-force pixel sums with closed-form Fejer weights, constant maps.
#include "core/transform/sht.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "gtest/gtest.h"

namespace shrm {
namespace {

// Band-limited round trips are exact up to rounding of O(H + W + F) double operations.
constexpr double kRoundTripTol = 1e-10;
// A constant map has only L_00; the rest is rounding of the FFT and quadrature.
constexpr double kFurnaceRelTol = 1e-12;
// Brute-force pixel sums and the transform add the same terms in a different order.
constexpr double kBruteForceTol = 1e-12;
// Direction synthesis and the SH evaluator differ only in summation order.
constexpr double kDirectionTol = 1e-11;
// Synthesis into a float map: float rounding (2^-24 ~ 6e-8) of values, with margin.
constexpr double kFloatMapRelTol = 1e-6;

// Ring polar angle of row j, written out from the convention (not taken from sht.cc).
double RingTheta(const ShtGrid& g, int j) {
  if (g.kind == ShtGridKind::kEquiangular) return kPi * (j + 0.5) / g.height;
  return GaussLegendreRule(g.height).theta[j];
}

// World direction of pixel (i, j): p = 2 pi (u - 0.5), d = (sin t sin p, cos t, -sin t cos p).
Vec3 PixelDirection(const ShtGrid& g, int i, int j, double theta) {
  const double p = 2.0 * kPi * ((i + 0.5) / g.width - 0.5);
  return {std::sin(theta) * std::sin(p), std::cos(theta), -std::sin(theta) * std::cos(p)};
}

std::vector<double> RandomValues(size_t n, unsigned seed, double lo = -1.0, double hi = 1.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> v(n);
  for (double& x : v) x = u(rng);
  return v;
}

// Independent slow synthesis: EvalShBatch on each row's SH-frame directions.
std::vector<double> SlowSynthesis(const ShtGrid& g, int lmax, int ch,
                                  const std::vector<double>& coeffs) {
  const int w = g.width, h = g.height, n = ShCount(lmax);
  std::vector<double> map(static_cast<size_t>(w) * h * ch, 0.0);
  std::vector<Vec3> dirs(w);
  std::vector<double> y(static_cast<size_t>(n) * w);
  for (int j = 0; j < h; ++j) {
    const double theta = RingTheta(g, j);
    for (int i = 0; i < w; ++i) dirs[i] = ShFrameFromWorld(PixelDirection(g, i, j, theta));
    EvalShBatch(lmax, dirs, y);
    for (int k = 0; k < n; ++k) {
      for (int c = 0; c < ch; ++c) {
        const double a = coeffs[static_cast<size_t>(k) * ch + c];
        for (int i = 0; i < w; ++i)
          map[(static_cast<size_t>(j) * w + i) * ch + c] += a * y[static_cast<size_t>(k) * w + i];
      }
    }
  }
  return map;
}

double MaxAbsDiff(const std::vector<double>& a, const std::vector<double>& b) {
  EXPECT_EQ(a.size(), b.size());
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

double MaxAbs(const std::vector<double>& a) {
  double d = 0;
  for (double x : a) d = std::max(d, std::abs(x));
  return d;
}

// Random band-limited coefficients -> slow synthesis -> Forward -> compare; then Inverse.
void CheckRoundTrip(const ShtGrid& g, int lmax, int ch, unsigned seed, bool expect_resample) {
  SCOPED_TRACE(testing::Message() << g.width << "x" << g.height << " kind "
                                  << static_cast<int>(g.kind) << " lmax " << lmax);
  auto plan = ShtPlan::Create(g, lmax, ch);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_EQ((*plan)->resamples_theta(), expect_resample);
  const std::vector<double> coeffs = RandomValues(static_cast<size_t>(ShCount(lmax)) * ch, seed);
  const std::vector<double> map = SlowSynthesis(g, lmax, ch, coeffs);
  std::vector<double> got((*plan)->coeff_size());
  ASSERT_TRUE((*plan)->Forward(std::span<const double>(map), std::span<double>(got)).ok());
  EXPECT_LT(MaxAbsDiff(got, coeffs), kRoundTripTol);
  std::vector<double> back(map.size());
  ASSERT_TRUE((*plan)->Inverse(coeffs, std::span<double>(back)).ok());
  EXPECT_LT(MaxAbsDiff(back, map), kRoundTripTol * std::max(1.0, MaxAbs(map)));
}

TEST(ShtTest, RoundTripEquiangular512x256Degree64) {
  CheckRoundTrip({512, 256, ShtGridKind::kEquiangular}, 64, 2, 1, false);
}

TEST(ShtTest, RoundTripThreeChannelsOverSeveralBlocks) {
  // 64 ring pairs: Inverse's two blocks of pairs, the coefficients packed by m, and the
  // three-channel kernels of both directions, against the slow synthesis.
  CheckRoundTrip({256, 128, ShtGridKind::kEquiangular}, 40, 3, 6, false);
}

TEST(ShtTest, RoundTripEquiangularAtGridLimit) {
  // F = H - 1 needs the exact theta resampling (Fejer-1 alone is exact only for 2F < H).
  CheckRoundTrip({64, 32, ShtGridKind::kEquiangular}, 31, 3, 2, true);
  CheckRoundTrip({40, 19, ShtGridKind::kEquiangular}, 18, 1, 3, true);   // odd H: equator ring
  CheckRoundTrip({64, 33, ShtGridKind::kEquiangular}, 16, 2, 4, false);  // 2F + 1 = H
  CheckRoundTrip({64, 33, ShtGridKind::kEquiangular}, 17, 2, 5, true);
}

TEST(ShtTest, RoundTripGaussLegendre) {
  CheckRoundTrip({64, 32, ShtGridKind::kGaussLegendre}, 31, 3, 6, false);
  CheckRoundTrip({41, 21, ShtGridKind::kGaussLegendre}, 20, 1, 7, false);
  CheckRoundTrip({256, 128, ShtGridKind::kGaussLegendre}, 64, 1, 8, false);
}

TEST(ShtTest, RoundTripFloatMapMatchesDoubleToFloatPrecision) {
  // Float input: the map itself is rounded to ~6e-8 relative, so compare loosely.
  constexpr double kFloatTol = 1e-5;  // float rounding of O(10) map values, summed with weights
  const ShtGrid g{128, 64, ShtGridKind::kEquiangular};
  const int lmax = 20, ch = 3;
  const std::vector<double> coeffs = RandomValues(static_cast<size_t>(ShCount(lmax)) * ch, 9);
  const std::vector<double> map = SlowSynthesis(g, lmax, ch, coeffs);
  const std::vector<float> fmap(map.begin(), map.end());
  auto got = ForwardSht(g, lmax, ch, std::span<const float>(fmap));
  ASSERT_TRUE(got.ok()) << got.status();
  EXPECT_LT(MaxAbsDiff(*got, coeffs), kFloatTol);
}

TEST(ShtTest, WhiteFurnace) {
  for (ShtGridKind kind : {ShtGridKind::kEquiangular, ShtGridKind::kGaussLegendre}) {
    for (auto [w, h, lmax] :
         {std::tuple{1024, 512, 30}, std::tuple{64, 32, 31}, std::tuple{45, 23, 12}}) {
      const ShtGrid g{w, h, kind};
      const double c = 2.5;
      const std::vector<float> map(static_cast<size_t>(w) * h * 3, static_cast<float>(c));
      auto coeffs = ForwardSht(g, lmax, 3, std::span<const float>(map));
      ASSERT_TRUE(coeffs.ok()) << coeffs.status();
      const double l00 = c * std::sqrt(4.0 * kPi);
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR((*coeffs)[ch], l00, kFurnaceRelTol * l00) << w << "x" << h;
        for (int k = 1; k < ShCount(lmax); ++k)
          ASSERT_LT(std::abs((*coeffs)[k * 3 + ch]), kFurnaceRelTol * l00)
              << w << "x" << h << " k=" << k;
      }
    }
  }
}

// Closed-form Fejer-1 weights (Waldvogel 2006, eq. 2.4), written independently of quadrature.cc.
double FejerWeight(int n, int j) {
  const double t = kPi * (j + 0.5) / n;
  double s = 0;
  for (int k = 1; k <= n / 2; ++k) s += std::cos(2.0 * k * t) / (4.0 * k * k - 1.0);
  return 2.0 / n * (1.0 - 2.0 * s);
}

// L_lm ~= sum_ij f_ij Y_lm(d_ij) w_j 2 pi / W, per pixel with EvalSh (checks the azimuth sign).
std::vector<double> BruteForce(const ShtGrid& g, int lmax, int ch, const std::vector<double>& map) {
  const RingQuadrature gauss = GaussLegendreRule(g.height);
  std::vector<double> out(static_cast<size_t>(ShCount(lmax)) * ch, 0.0);
  std::vector<double> y(ShCount(lmax));
  for (int j = 0; j < g.height; ++j) {
    const double wj =
        g.kind == ShtGridKind::kEquiangular ? FejerWeight(g.height, j) : gauss.weight[j];
    for (int i = 0; i < g.width; ++i) {
      EvalSh(lmax, ShFrameFromWorld(PixelDirection(g, i, j, RingTheta(g, j))), y);
      for (int k = 0; k < ShCount(lmax); ++k)
        for (int c = 0; c < ch; ++c)
          out[static_cast<size_t>(k) * ch + c] +=
              map[(static_cast<size_t>(j) * g.width + i) * ch + c] * y[k] * wj * 2.0 * kPi /
              g.width;
    }
  }
  return out;
}

TEST(ShtTest, MatchesBruteForcePixelSum) {
  for (auto [g, lmax] : {std::pair{ShtGrid{32, 16, ShtGridKind::kEquiangular}, 7},
                         std::pair{ShtGrid{31, 15, ShtGridKind::kEquiangular}, 7},
                         std::pair{ShtGrid{32, 16, ShtGridKind::kGaussLegendre}, 8},
                         std::pair{ShtGrid{33, 17, ShtGridKind::kGaussLegendre}, 16}}) {
    const int ch = 3;
    const std::vector<double> map =
        RandomValues(static_cast<size_t>(g.width) * g.height * ch, 11, 0.0, 1.0);
    auto got = ForwardSht(g, lmax, ch, std::span<const double>(map));
    ASSERT_TRUE(got.ok()) << got.status();
    EXPECT_LT(MaxAbsDiff(*got, BruteForce(g, lmax, ch, map)), kBruteForceTol)
        << g.width << "x" << g.height;
  }
}

// The analysis's theta stage has kernels for 1, 3 and 4 channels (degrees four, two and one at
// a time, so every residue of lmax - m mod 4 is met over m) and a general path for the others.
TEST(ShtTest, EveryChannelCountMatchesBruteForcePixelSum) {
  for (int ch = 1; ch <= 5; ++ch) {
    for (auto [g, lmax] : {std::pair{ShtGrid{33, 17, ShtGridKind::kGaussLegendre}, 16},
                           std::pair{ShtGrid{64, 32, ShtGridKind::kEquiangular}, 13}}) {
      const std::vector<double> map =
          RandomValues(static_cast<size_t>(g.width) * g.height * ch, 13 + ch, 0.0, 1.0);
      auto got = ForwardSht(g, lmax, ch, std::span<const double>(map));
      ASSERT_TRUE(got.ok()) << got.status();
      EXPECT_LT(MaxAbsDiff(*got, BruteForce(g, lmax, ch, map)), kBruteForceTol)
          << ch << " channels, " << g.width << "x" << g.height << ", lmax " << lmax;
    }
  }
}

TEST(ShtTest, PixelSumQuadratureMatchesTheBruteForceSumAtEveryDegree) {
  // kPixelSum integrates with the grid's own Fejer rule up to lmax = H - 1 (no theta
  // resampling): the brute-force pixel sum, also where the exact path differs (H < 2 lmax + 1).
  for (auto [g, lmax] : {std::pair{ShtGrid{32, 16, ShtGridKind::kEquiangular}, 15},
                         std::pair{ShtGrid{31, 15, ShtGridKind::kEquiangular}, 12},
                         std::pair{ShtGrid{64, 32, ShtGridKind::kEquiangular}, 31}}) {
    const int ch = 3;
    const std::vector<double> map =
        RandomValues(static_cast<size_t>(g.width) * g.height * ch, 12, 0.0, 1.0);
    auto got = ForwardSht(g, lmax, ch, std::span<const double>(map), 2, ShtQuadrature::kPixelSum);
    ASSERT_TRUE(got.ok()) << got.status();
    EXPECT_LT(MaxAbsDiff(*got, BruteForce(g, lmax, ch, map)), kBruteForceTol)
        << g.width << "x" << g.height;
    auto exact = ForwardSht(g, lmax, ch, std::span<const double>(map));
    ASSERT_TRUE(exact.ok());
    EXPECT_GT(MaxAbsDiff(*got, *exact), 100 * kBruteForceTol) << "the paths should differ here";
  }
}

TEST(ShtTest, SingleHarmonicHasItsOwnCoefficientOnly) {
  // Map = Y_{3,-2} (real, evaluated with the textbook EvalShSlow in SH angles theta, phi_s).
  const ShtGrid g{64, 32, ShtGridKind::kEquiangular};
  std::vector<double> map(64 * 32);
  for (int j = 0; j < 32; ++j)
    for (int i = 0; i < 64; ++i)
      map[j * 64 + i] =
          EvalShSlow(3, -2, kPi * (j + 0.5) / 32, 1.5 * kPi - 2.0 * kPi * (i + 0.5) / 64);
  auto got = ForwardSht(g, 8, 1, std::span<const double>(map));
  ASSERT_TRUE(got.ok());
  for (int k = 0; k < ShCount(8); ++k)
    EXPECT_NEAR((*got)[k], k == ShIndex(3, -2) ? 1.0 : 0.0, kRoundTripTol) << k;
}

TEST(ShtTest, InverseOntoCoarseGridAliasesLikeSampling) {
  // Synthesis-only plan with W < 2F + 1 and H < F + 1: compare with direct evaluation.
  const ShtGrid g{16, 8, ShtGridKind::kEquiangular};
  const int lmax = 12, ch = 2;
  EXPECT_FALSE(ShtPlan::Create(g, lmax, ch).ok());
  auto plan = ShtPlan::CreateForSynthesis(g, lmax, ch);
  ASSERT_TRUE(plan.ok()) << plan.status();
  EXPECT_FALSE((*plan)->supports_forward());
  const std::vector<double> coeffs = RandomValues(static_cast<size_t>(ShCount(lmax)) * ch, 12);
  std::vector<double> map((*plan)->map_size());
  ASSERT_TRUE((*plan)->Inverse(coeffs, std::span<double>(map)).ok());
  const std::vector<double> ref = SlowSynthesis(g, lmax, ch, coeffs);
  EXPECT_LT(MaxAbsDiff(map, ref), kRoundTripTol);
  std::vector<double> c2(coeffs.size());
  const absl::Status s = (*plan)->Forward(std::span<const double>(map), std::span<double>(c2));
  EXPECT_EQ(s.code(), absl::StatusCode::kFailedPrecondition);
}

TEST(ShtTest, InverseToFloatMap) {
  const ShtGrid g{96, 48, ShtGridKind::kGaussLegendre};
  const int lmax = 20, ch = 3;
  const std::vector<double> coeffs = RandomValues(static_cast<size_t>(ShCount(lmax)) * ch, 13);
  const std::vector<double> ref = SlowSynthesis(g, lmax, ch, coeffs);
  auto plan = GetShtPlan(g, lmax, ch);
  ASSERT_TRUE(plan.ok());
  std::vector<float> map((*plan)->map_size());
  ASSERT_TRUE((*plan)->Inverse(coeffs, std::span<float>(map), 2).ok());
  for (size_t k = 0; k < map.size(); ++k)
    ASSERT_NEAR(map[k], ref[k], kFloatMapRelTol * std::max(1.0, std::abs(ref[k])));
}

TEST(ShtTest, SynthesizeAtDirectionsMatchesEvalSh) {
  const int lmax = 15, ch = 3, n = 300;
  const std::vector<double> coeffs = RandomValues(static_cast<size_t>(ShCount(lmax)) * ch, 14);
  const std::vector<double> xyz = RandomValues(3 * n, 15);
  std::vector<Vec3> dirs(n);
  for (int k = 0; k < n; ++k) dirs[k] = Vec3{xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]} * 3.0;
  std::vector<double> out(n * ch);
  ASSERT_TRUE(SynthesizeAtDirections(lmax, ch, coeffs, dirs, out, 2).ok());
  std::vector<double> y(ShCount(lmax));
  for (int k = 0; k < n; ++k) {
    EvalSh(lmax, ShFrameFromWorld(dirs[k].Normalized()), y);
    for (int c = 0; c < ch; ++c) {
      double ref = 0;
      for (int i = 0; i < ShCount(lmax); ++i) ref += coeffs[i * ch + c] * y[i];
      EXPECT_NEAR(out[k * ch + c], ref, kDirectionTol);
    }
  }
  // Agrees with grid synthesis at the pixel directions of a small grid.
  const ShtGrid g{40, 20, ShtGridKind::kEquiangular};
  auto grid_map = InverseSht(g, lmax, ch, coeffs);
  ASSERT_TRUE(grid_map.ok());
  std::vector<Vec3> pix;
  for (int j = 0; j < 20; ++j)
    for (int i = 0; i < 40; ++i) pix.push_back(ShtGridDirection(g, i, j));
  std::vector<double> at(pix.size() * ch);
  ASSERT_TRUE(SynthesizeAtDirections(lmax, ch, coeffs, pix, at).ok());
  EXPECT_LT(MaxAbsDiff(at, *grid_map), kDirectionTol);
}

TEST(ShtTest, MultiThreadedEqualsSingleThreaded) {
  const ShtGrid g{1024, 512, ShtGridKind::kEquiangular};
  const int lmax = 30, ch = 3;
  const std::vector<double> v = RandomValues(static_cast<size_t>(1024) * 512 * ch, 16, 0.0, 100.0);
  const std::vector<float> map(v.begin(), v.end());
  auto plan = GetShtPlan(g, lmax, ch);
  ASSERT_TRUE(plan.ok());
  std::vector<double> c1((*plan)->coeff_size()), c3(c1.size());
  ASSERT_TRUE((*plan)->Forward(std::span<const float>(map), std::span<double>(c1), 1).ok());
  ASSERT_TRUE((*plan)->Forward(std::span<const float>(map), std::span<double>(c3), 3).ok());
  EXPECT_EQ(c1, c3);  // same per-ring and per-m arithmetic whatever the thread count
  std::vector<double> m1(map.size()), m3(map.size());
  ASSERT_TRUE((*plan)->Inverse(c1, std::span<double>(m1), 1).ok());
  ASSERT_TRUE((*plan)->Inverse(c1, std::span<double>(m3), 3).ok());
  EXPECT_EQ(m1, m3);
  // Resampling path too.
  const ShtGrid small{64, 32, ShtGridKind::kEquiangular};
  const std::vector<double> sm = RandomValues(64 * 32 * ch, 17);
  auto a = ForwardSht(small, 31, ch, std::span<const double>(sm), 1);
  auto b = ForwardSht(small, 31, ch, std::span<const double>(sm), 4);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(*a, *b);
}

TEST(ShtTest, PlanCacheReturnsTheSamePlan) {
  const ShtGrid g{128, 64, ShtGridKind::kEquiangular};
  auto a = GetShtPlan(g, 10, 3);
  auto b = GetShtPlan(g, 10, 3);
  auto c = GetShtPlan(g, 10, 1);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(a->get(), b->get());
  EXPECT_NE(a->get(), c->get());
}

void ExpectInvalid(const absl::Status& s, const std::string& needle) {
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find(needle), std::string::npos) << s.message() << " lacks " << needle;
}

TEST(ShtTest, BadArgumentsReturnClearErrors) {
  const ShtGrid g{64, 32, ShtGridKind::kEquiangular};
  ExpectInvalid(ShtPlan::Create(g, -1, 3).status(), "negative degree");
  ExpectInvalid(ShtPlan::Create(g, 32, 3).status(), "exceeds the limit");       // F > H - 1
  ExpectInvalid(ShtPlan::Create({40, 32}, 20, 3).status(), "W >= 2 lmax + 1");  // W < 2F + 1
  ExpectInvalid(ShtPlan::Create({0, 32}, 4, 3).status(), "empty grid");
  ExpectInvalid(ShtPlan::Create({64, 0}, 4, 3).status(), "empty grid");
  ExpectInvalid(ShtPlan::Create(g, 4, 0).status(), "channels");
  ExpectInvalid(ShtPlan::CreateForSynthesis(g, -2, 1).status(), "negative degree");
  auto plan = ShtPlan::Create(g, 8, 3);
  ASSERT_TRUE(plan.ok());
  std::vector<float> map(64 * 32 * 3);
  std::vector<double> coeffs(ShCount(8) * 3);
  ExpectInvalid((*plan)->Forward(std::span<const float>(map).first(100), std::span<double>(coeffs)),
                "map has 100 values");
  ExpectInvalid((*plan)->Forward(std::span<const float>(map), std::span<double>(coeffs).first(5)),
                "coefficient array has 5 values");
  ExpectInvalid((*plan)->Forward(std::span<const float>(map), std::span<double>(coeffs), 0),
                "num_threads");
  ExpectInvalid((*plan)->Inverse(coeffs, std::span<float>(map).first(7)), "map has 7 values");
  ExpectInvalid((*plan)->Inverse(std::span<const double>(coeffs).first(3), std::span<float>(map)),
                "coefficient array has 3 values");
  ExpectInvalid((*plan)->Inverse(coeffs, std::span<float>(map), -1), "num_threads");
  ExpectInvalid(ForwardSht(g, 40, 3, std::span<const float>(map)).status(), "exceeds the limit");
  std::vector<Vec3> dirs = {{0, 1, 0}, {0, 0, 0}};
  std::vector<double> out(6);
  ExpectInvalid(SynthesizeAtDirections(8, 3, coeffs, dirs, out), "direction 1 is zero");
  ExpectInvalid(SynthesizeAtDirections(8, 3, coeffs, dirs, std::span<double>(out).first(4)),
                "output has 4 values");
  ExpectInvalid(SynthesizeAtDirections(-1, 3, coeffs, dirs, out), "negative degree");
  ExpectInvalid(SynthesizeAtDirections(8, 0, coeffs, dirs, out), "channels");
}

}  // namespace
}  // namespace shrm
