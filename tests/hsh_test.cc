// Tests for core/sh/hsh.h (HSH paper, Gautron et al. 2004: eqs. 5-9, 15, 18, sec. 4).
// References are independent of the code under test: textbook formulas (EvalHshSlow,
// EvalShSlow at the shifted angle), quadrature rules from core/sh/quadrature.h, and
// values computed with sympy/mpmath (30 digits) from eqs. 3-9 and 18.
#include "core/sh/hsh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include "core/sh/quadrature.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

constexpr double kSqrt2 = std::numbers::sqrt2;
// Recurrence vs textbook formulas at low degree: a few ulps times the size of the sums.
constexpr double kEvalTol = 1e-12;
// Quadratures exact for the integrand (polynomials), summed over a few hundred nodes.
constexpr double kExactQuadTol = 1e-13;
// The brief's Gram tolerance for the HSH up to degree 10 (exact Fejer rule, O(100) terms).
constexpr double kGramTol = 1e-10;
// 30-digit sympy/mpmath references vs double quadrature (geometric convergence, rounding).
constexpr double kKnownValueTol = 1e-14;
// Brute-force (non-exact but analytic-integrand) Gauss quadrature with 96 nodes.
constexpr double kBruteTol = 1e-12;

std::vector<double> RandomVector(int n, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> v(n);
  for (double& x : v) x = u(rng);
  return v;
}

double MaxAbsDiff(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

double Norm2(const std::vector<double>& a) {
  double s = 0;
  for (double x : a) s += x * x;
  return std::sqrt(s);
}

// Brute-force hemisphere integral through the shifted angle theta' (x = cos theta =
// (1 + cos theta') / 2, dx = sin theta' / 2 d theta'), Gauss-Legendre in theta' on [0, pi]
// (quadrature.h nodes, linearly mapped). Products of SH and HSH are analytic in theta'
// (sqrt(x) = cos(theta'/2)), so this converges geometrically, without using the polynomial
// structure that ShHshConversion relies on.
double BruteHemisphere(int num_nodes, int num_phi, const std::function<double(double, double)>& g) {
  const RingQuadrature q = GaussLegendreRule(num_nodes);
  double sum = 0;
  for (int j = 0; j < num_nodes; ++j) {
    const double tp = 0.5 * kPi * (1.0 + q.cos_theta[j]);
    const double wt = 0.5 * kPi * q.weight[j];
    const double x = 0.5 * (1.0 + std::cos(tp));
    const double theta = std::acos(x);
    for (int k = 0; k < num_phi; ++k) {
      sum += wt * 0.5 * std::sin(tp) * (2.0 * kPi / num_phi) * g(theta, 2.0 * kPi * k / num_phi);
    }
  }
  return sum;
}

double HshValue(int lmax, int index, double theta, double phi) {
  std::vector<double> h(HshCount(lmax));
  EXPECT_TRUE(EvalHsh(lmax, theta, phi, h).ok());
  return h[index];
}

TEST(HshEval, MatchesTextbookAndShiftedShIdentity) {
  constexpr int kLmax = 8;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ut(0.0, kPi / 2), up(-kPi, kPi);
  std::vector<double> h(HshCount(kLmax));
  for (int trial = 0; trial < 40; ++trial) {
    const double theta = trial == 0 ? 0.0 : (trial == 1 ? kPi / 2 : ut(rng));
    const double phi = up(rng);
    ASSERT_TRUE(EvalHsh(kLmax, theta, phi, h).ok());
    const double theta_shifted = std::acos(2.0 * std::cos(theta) - 1.0);
    for (int l = 0; l <= kLmax; ++l) {
      for (int m = -l; m <= l; ++m) {
        const double v = h[ShIndex(l, m)];
        EXPECT_NEAR(v, EvalHshSlow(l, m, theta, phi), kEvalTol) << l << " " << m;
        // At theta = pi/2 the reference's acos(2 cos theta - 1) is ill-conditioned (theta'
        // near pi loses ~8 digits), so the shifted-SH identity is checked inside only.
        if (trial != 1) {
          EXPECT_NEAR(v, kSqrt2 * EvalShSlow(l, m, theta_shifted, phi), kEvalTol) << l << m;
        }
      }
    }
  }
}

TEST(HshEval, LowDegreeClosedForms) {
  // Eqs. 8-9 written out: Ktilde_1^1 = sqrt(3 / 4pi), P_1^1(u) = -sqrt(1 - u^2) (CS phase),
  // u = 2z - 1.
  const double theta = 0.7, phi = 1.1, z = std::cos(theta);
  const double s1 = std::sqrt(1.0 - (2 * z - 1) * (2 * z - 1));
  EXPECT_NEAR(HshValue(1, ShIndex(0, 0), theta, phi), 1.0 / std::sqrt(2 * kPi), kEvalTol);
  EXPECT_NEAR(HshValue(1, ShIndex(1, 0), theta, phi), std::sqrt(3 / (2 * kPi)) * (2 * z - 1),
              kEvalTol);
  EXPECT_NEAR(HshValue(1, ShIndex(1, 1), theta, phi),
              -kSqrt2 * std::sqrt(3 / (4 * kPi)) * s1 * std::cos(phi), kEvalTol);
  EXPECT_NEAR(HshValue(1, ShIndex(1, -1), theta, phi),
              -kSqrt2 * std::sqrt(3 / (4 * kPi)) * s1 * std::sin(phi), kEvalTol);
}

TEST(HshEval, DirectionAndBatchAgreeWithAngles) {
  constexpr int kLmax = 12;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> ut(0.0, kPi / 2), up(-kPi, kPi);
  std::vector<Vec3> dirs;
  std::vector<std::pair<double, double>> angles;
  for (int k = 0; k < 25; ++k) {
    const double t = k == 0 ? 0.0 : (k == 1 ? kPi / 2 : ut(rng)), p = up(rng);
    angles.push_back({t, p});
    dirs.push_back(DirectionFromAngles(t, p) * (k == 3 ? 2.5 : 1.0));  // one non-unit direction
  }
  const int n = static_cast<int>(dirs.size());
  std::vector<double> batch(static_cast<size_t>(HshCount(kLmax)) * n);
  ASSERT_TRUE(EvalHshBatch(kLmax, dirs, batch).ok());
  std::vector<double> a(HshCount(kLmax)), d(HshCount(kLmax));
  for (int k = 0; k < n; ++k) {
    ASSERT_TRUE(EvalHsh(kLmax, angles[k].first, angles[k].second, a).ok());
    ASSERT_TRUE(EvalHsh(kLmax, dirs[k], d).ok());
    for (int i = 0; i < HshCount(kLmax); ++i) {
      EXPECT_NEAR(d[i], a[i], kEvalTol);
      EXPECT_NEAR(batch[static_cast<size_t>(i) * n + k], a[i], kEvalTol);
    }
  }
}

TEST(HshEval, RejectsBadInput) {
  std::vector<double> h(HshCount(2));
  EXPECT_EQ(EvalHsh(-1, 0.1, 0.0, h).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EvalHsh(2, kPi / 2 + 0.01, 0.0, h).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EvalHsh(2, Vec3{0, 0.1, -1}, h).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(EvalHsh(3, 0.1, 0.0, h).code(), absl::StatusCode::kInvalidArgument);  // too small
  EXPECT_FALSE(ShHshConversion::Create(-1, 3).ok());
  EXPECT_FALSE(ShHshConversion::Create(3, -2).ok());
  EXPECT_FALSE(MakeHemisphereRule(0, 4).ok());
  EXPECT_FALSE(CapturedEnergyFraction(h, 0.0).ok());
  EXPECT_FALSE(ProjectHsh(-1, *MakeHemisphereRule(2, 2), [](double, double) { return 1.0; }).ok());
}

TEST(HshBasis, GramIsIdentityOnHemisphere) {
  // H_l^m H_l'^m' is a polynomial of degree <= 20 in cos theta times a trigonometric
  // polynomial of degree <= 20 in phi: Fejer with 32 rings x 24 azimuths is exact.
  constexpr int kLmax = 10, kRings = 32, kPhi = 24;
  const int n = HshCount(kLmax);
  std::vector<double> gram(static_cast<size_t>(n) * n, 0.0);
  const RingQuadrature q = FejerFirstRule(kRings);
  std::vector<double> h(n);
  for (int j = 0; j < kRings; ++j) {
    const double theta = std::acos(0.5 * (1.0 + q.cos_theta[j]));
    for (int k = 0; k < kPhi; ++k) {
      ASSERT_TRUE(EvalHsh(kLmax, theta, 2.0 * kPi * k / kPhi, h).ok());
      const double w = 0.5 * q.weight[j] * 2.0 * kPi / kPhi;
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) gram[static_cast<size_t>(a) * n + b] += w * h[a] * h[b];
    }
  }
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b)
      EXPECT_NEAR(gram[static_cast<size_t>(a) * n + b], a == b ? 1.0 : 0.0, kGramTol)
          << a << " " << b;
}

TEST(HshProjection, ReproducesExpansionExactly) {
  constexpr int kDegree = 6, kLmax = 8;
  const std::vector<double> c = RandomVector(HshCount(kDegree), 21);
  auto f = [&](double theta, double phi) {
    std::vector<double> h(HshCount(kDegree));
    EXPECT_TRUE(EvalHsh(kDegree, theta, phi, h).ok());
    double s = 0;
    for (int i = 0; i < HshCount(kDegree); ++i) s += c[i] * h[i];
    return s;
  };
  // Minimal exact rule: num_theta >= (8 + 6) / 2 + 1, num_phi > 14.
  auto rule = MakeHemisphereRule(8, 15);
  ASSERT_TRUE(rule.ok());
  auto p = ProjectHsh(kLmax, *rule, f);
  ASSERT_TRUE(p.ok());
  for (int i = 0; i < HshCount(kLmax); ++i)
    EXPECT_NEAR((*p)[i], i < HshCount(kDegree) ? c[i] : 0.0, kExactQuadTol) << i;
  // Same from samples.
  std::vector<double> samples;
  for (int j = 0; j < rule->num_theta(); ++j)
    for (int k = 0; k < rule->num_phi(); ++k) samples.push_back(f(rule->theta[j], rule->phi[k]));
  auto ps = ProjectHshSamples(kLmax, *rule, samples);
  ASSERT_TRUE(ps.ok());
  EXPECT_LT(MaxAbsDiff(*ps, *p), kExactQuadTol);
  EXPECT_FALSE(ProjectHshSamples(kLmax, *rule, std::span(samples).subspan(1)).ok());
  // Energy of the expansion is the sum of squares (Parseval, eq. 15 with all coefficients).
  const double energy = HemisphereEnergy(*rule, f);
  double sum2 = 0;
  for (double x : c) sum2 += x * x;
  EXPECT_NEAR(energy, sum2, kExactQuadTol * sum2);
}

TEST(HshConversion, KnownValuesFromEq18) {
  auto conv = ShHshConversion::Create(5, 6);
  ASSERT_TRUE(conv.ok());
  EXPECT_EQ(conv->rows(), 36);
  EXPECT_EQ(conv->cols(), 49);
  // /work papers README "known pitfall": eq. 18 gives C[(0,0),(1,0)] = sqrt(3) / (2 sqrt2) =
  // 0.612; the paper's printed 9x9 matrix shows 0.41, which does not follow from eqs. 3-9.
  EXPECT_NEAR((*conv)(ShIndex(0, 0), ShIndex(1, 0)), std::sqrt(3.0) / (2.0 * kSqrt2),
              kKnownValueTol);
  EXPECT_NEAR((*conv)(ShIndex(0, 0), ShIndex(0, 0)), 1.0 / kSqrt2, kKnownValueTol);
  EXPECT_NEAR((*conv)(ShIndex(1, 0), ShIndex(1, 0)), kSqrt2 / 4.0, kKnownValueTol);
  // Odd m (non-polynomial in cos theta): sympy + mpmath.quad at 30 digits.
  struct Known {
    int l, lp, m;
    double value;
  };
  const Known known[] = {
      {1, 1, 1, 0.673871604842240672431727409718}, {2, 1, 1, -0.157790022779710799276098629409},
      {1, 2, 1, 0.674516346877207895039149930348}, {3, 2, 1, -0.0129654300536871100028790570578},
      {3, 4, 3, 0.706233584876485852068709226301}, {2, 2, 2, 0.618718433538229083850738816842},
      {2, 3, 2, 0.701560760020114009796952887309}, {5, 6, 5, 0.676513245568534028965555600703},
  };
  for (const Known& k : known) {
    EXPECT_NEAR((*conv)(ShIndex(k.l, k.m), ShIndex(k.lp, k.m)), k.value, kKnownValueTol)
        << k.l << " " << k.lp << " " << k.m;
    // The block for -m equals the block for m (sin vs cos azimuthal factor).
    EXPECT_NEAR((*conv)(ShIndex(k.l, -k.m), ShIndex(k.lp, -k.m)), k.value, kKnownValueTol);
  }
  // Block sparsity: nothing couples m != m'.
  for (int r = 0; r < conv->rows(); ++r) {
    for (int c = 0; c < conv->cols(); ++c) {
      const int l = static_cast<int>(std::sqrt(r)), lp = static_cast<int>(std::sqrt(c));
      if (r - l * (l + 1) != c - lp * (lp + 1)) {
        EXPECT_EQ((*conv)(r, c), 0.0);
      }
    }
  }
}

TEST(HshConversion, EqualsBruteForceProjectionOfRestriction) {
  // For an SH expansion s, C s is the HSH projection of s restricted to z >= 0: here every
  // entry of eq. 18 and the projection itself are integrated by brute force, in another
  // variable (theta') and with other nodes than the implementation.
  constexpr int kHsh = 6, kSh = 9;
  auto conv = ShHshConversion::Create(kHsh, kSh);
  ASSERT_TRUE(conv.ok());
  const std::vector<double> s = RandomVector(ShCount(kSh), 31);
  std::vector<double> cs(HshCount(kHsh));
  ASSERT_TRUE(conv->ShToHsh(s, cs).ok());
  for (int i = 0; i < HshCount(kHsh); ++i) {
    const double brute = BruteHemisphere(96, 2 * (kHsh + kSh) + 2, [&](double t, double p) {
      return HshValue(kHsh, i, t, p) * EvalShSeries(kSh, s, DirectionFromAngles(t, p));
    });
    EXPECT_NEAR(cs[i], brute, kBruteTol) << i;
  }
  // Dense() agrees with the block accessor and C^T is the adjoint: <C s, h> = <s, C^T h>.
  const std::vector<double> dense = conv->Dense();
  EXPECT_EQ(dense[static_cast<size_t>(ShIndex(2, 1)) * conv->cols() + ShIndex(3, 1)],
            (*conv)(ShIndex(2, 1), ShIndex(3, 1)));
  const std::vector<double> h = RandomVector(HshCount(kHsh), 32);
  std::vector<double> cth(ShCount(kSh));
  ASSERT_TRUE(conv->HshToSh(h, cth).ok());
  double lhs = 0, rhs = 0;
  for (int i = 0; i < HshCount(kHsh); ++i) lhs += cs[i] * h[i];
  for (int i = 0; i < ShCount(kSh); ++i) rhs += s[i] * cth[i];
  EXPECT_NEAR(lhs, rhs, kExactQuadTol * 10);
  EXPECT_FALSE(conv->ShToHsh(h, cs).ok());  // wrong SH size
}

TEST(HshConversion, TransposeIsShProjectionOfZeroExtension) {
  // C^T h = SH coefficients of the HSH expansion extended by zero below the horizon.
  constexpr int kHsh = 3, kSh = 7;
  auto conv = ShHshConversion::Create(kHsh, kSh);
  ASSERT_TRUE(conv.ok());
  const std::vector<double> h = RandomVector(HshCount(kHsh), 41);
  std::vector<double> sh(ShCount(kSh));
  ASSERT_TRUE(conv->HshToSh(h, sh).ok());
  std::vector<double> y(ShCount(kSh));
  for (int i = 0; i < ShCount(kSh); ++i) {
    const double brute = BruteHemisphere(96, 2 * (kHsh + kSh) + 2, [&](double t, double p) {
      std::vector<double> hv(HshCount(kHsh));
      EXPECT_TRUE(EvalHsh(kHsh, t, p, hv).ok());
      double f = 0;
      for (int k = 0; k < HshCount(kHsh); ++k) f += h[k] * hv[k];
      EvalSh(kSh, t, p, y);
      return f * y[i];
    });
    EXPECT_NEAR(sh[i], brute, kBruteTol) << i;
  }
}

TEST(HshAccuracy, Eq15IsOneInSpanAndIncreasesWithOrder) {
  constexpr double kSpanTol = 1e-12;  // exact quadrature, ratio of O(1) sums
  const std::vector<double> c = RandomVector(HshCount(3), 51);
  auto rule = MakeHemisphereRule(12, 24);
  ASSERT_TRUE(rule.ok());
  auto in_span = [&](double t, double p) {
    std::vector<double> h(HshCount(3));
    EXPECT_TRUE(EvalHsh(3, t, p, h).ok());
    double s = 0;
    for (int i = 0; i < HshCount(3); ++i) s += c[i] * h[i];
    return s;
  };
  auto coeffs = ProjectHsh(3, *rule, in_span);
  ASSERT_TRUE(coeffs.ok());
  auto acc = CapturedEnergyFraction(*coeffs, HemisphereEnergy(*rule, in_span));
  ASSERT_TRUE(acc.ok());
  EXPECT_NEAR(*acc, 1.0, kSpanTol);

  // A tilted Phong lobe max(0, r . w)^5: accuracy grows with n and stays <= 1.
  const Vec3 r = DirectionFromAngles(0.5, 0.3);
  auto lobe = [&](double t, double p) {
    return std::pow(std::max(0.0, r.Dot(DirectionFromAngles(t, p))), 5);
  };
  auto fine = MakeHemisphereRule(160, 320);
  ASSERT_TRUE(fine.ok());
  const double energy = HemisphereEnergy(*fine, lobe);
  auto all = ProjectHsh(9, *fine, lobe);
  ASSERT_TRUE(all.ok());
  double prev = 0;
  for (int n = 1; n <= 10; ++n) {
    auto a = CapturedEnergyFraction(std::span(*all).first(n * n), energy);
    ASSERT_TRUE(a.ok());
    EXPECT_GE(*a, prev);
    EXPECT_LE(*a, 1.0 + kSpanTol);
    prev = *a;
  }
  EXPECT_GT(prev, 0.99);
}

TEST(HshRotation, ZRotationIsShZRotationAndExact) {
  constexpr int kLmax = 6;
  constexpr double kAngle = 0.83;
  const std::vector<double> h = RandomVector(HshCount(kLmax), 61);
  std::vector<double> out(HshCount(kLmax));
  ASSERT_TRUE(RotateHshZ(kLmax, kAngle, h, out).ok());
  // Reference: the HSH projection of f(theta, phi - angle), by an exact rule.
  auto rule = MakeHemisphereRule(kLmax + 1, 2 * kLmax + 1);
  ASSERT_TRUE(rule.ok());
  auto proj = ProjectHsh(kLmax, *rule, [&](double t, double p) {
    std::vector<double> hv(HshCount(kLmax));
    EXPECT_TRUE(EvalHsh(kLmax, t, p - kAngle, hv).ok());
    double s = 0;
    for (int i = 0; i < HshCount(kLmax); ++i) s += h[i] * hv[i];
    return s;
  });
  ASSERT_TRUE(proj.ok());
  EXPECT_LT(MaxAbsDiff(out, *proj), kExactQuadTol);
  // Sec. 4: "The rotation of HSH functions around the Z axis is the same as that of SH".
  constexpr double kRotTol = 1e-12;  // a different (Wigner-based) z rotation in double
  std::vector<double> sh_rot(ShCount(kLmax));
  RotateSh(kLmax, RotationZ(kAngle), h, sh_rot);
  EXPECT_LT(MaxAbsDiff(out, sh_rot), kRotTol);
  // The SH round trip commutes with z rotations: C Rz C^T h = Rz (C C^T h).
  auto conv = ShHshConversion::Create(kLmax, 3 * kLmax);
  ASSERT_TRUE(conv.ok());
  std::vector<double> cth(conv->cols()), cct(HshCount(kLmax)), rz(HshCount(kLmax)),
      round(HshCount(kLmax));
  ASSERT_TRUE(conv->HshToSh(h, cth).ok());
  ASSERT_TRUE(conv->ShToHsh(cth, cct).ok());
  ASSERT_TRUE(RotateHshZ(kLmax, kAngle, cct, rz).ok());
  ASSERT_TRUE(RotateHsh(*conv, RotationZ(kAngle), h, round).ok());
  EXPECT_LT(MaxAbsDiff(round, rz), kRotTol);
}

// Reference for RotateHsh about y by beta: the HSH projection of
// w -> [R^-1 w in upper hemisphere] f(R^-1 w). The integrand lives on the lune
// {z > 0, (R e_z) . w > 0}; with the pole on +y, w = (sin t cos p, cos t, sin t sin p), the lune
// is p in (0, pi - beta). Both t and p are integrated with Gauss after the substitution
// u -> L (1 - cos(pi u)) / 2, which removes the sqrt endpoint singularities of the HSH.
std::vector<double> LuneReference(int lmax, const std::vector<double>& h, double beta, int nodes) {
  const Mat3 rot = RotationY(beta);
  const Mat3 inv = rot.Transposed();
  const RingQuadrature q = GaussLegendreRule(nodes);
  std::vector<double> out(HshCount(lmax), 0.0), hv(HshCount(lmax)), hr(HshCount(lmax));
  const double lp = kPi - beta;
  for (int a = 0; a < nodes; ++a) {
    const double ua = 0.5 * (1.0 + q.cos_theta[a]);
    const double t = kPi * (1.0 - std::cos(kPi * ua)) / 2.0;
    const double wt = 0.5 * q.weight[a] * kPi * kPi / 2.0 * std::sin(kPi * ua) * std::sin(t);
    for (int b = 0; b < nodes; ++b) {
      const double ub = 0.5 * (1.0 + q.cos_theta[b]);
      const double p = lp * (1.0 - std::cos(kPi * ub)) / 2.0;
      const double wp = 0.5 * q.weight[b] * lp * kPi / 2.0 * std::sin(kPi * ub);
      const Vec3 w{std::sin(t) * std::cos(p), std::cos(t), std::sin(t) * std::sin(p)};
      EXPECT_TRUE(EvalHsh(lmax, w, hv).ok());
      EXPECT_TRUE(EvalHsh(lmax, inv * w, hr).ok());
      double f = 0;
      for (int i = 0; i < HshCount(lmax); ++i) f += h[i] * hr[i];
      for (int i = 0; i < HshCount(lmax); ++i) out[i] += wt * wp * f * hv[i];
    }
  }
  return out;
}

TEST(HshRotation, ShRoundTripConvergesWithIntermediateDegree) {
  constexpr int kLmax = 4;
  constexpr double kBeta = 0.6;
  // Final relative error at intermediate degree 64 (measured 5.5e-5, docs/results.md).
  constexpr double kFinalRelTol = 2e-4;
  const std::vector<double> h = RandomVector(HshCount(kLmax), 71);
  const std::vector<double> ref = LuneReference(kLmax, h, kBeta, 120);
  // The reference is converged: a coarser lune rule agrees far below the errors measured.
  EXPECT_LT(MaxAbsDiff(ref, LuneReference(kLmax, h, kBeta, 80)), 1e-9);
  double prev = 1e300;
  for (int sh_lmax : {8, 16, 32, 64}) {
    auto conv = ShHshConversion::Create(kLmax, sh_lmax);
    ASSERT_TRUE(conv.ok());
    std::vector<double> out(HshCount(kLmax));
    ASSERT_TRUE(RotateHsh(*conv, RotationY(kBeta), h, out).ok());
    std::vector<double> diff(out.size());
    for (size_t i = 0; i < out.size(); ++i) diff[i] = out[i] - ref[i];
    const double err = Norm2(diff) / Norm2(ref);
    EXPECT_LT(err, prev) << "sh_lmax " << sh_lmax;
    prev = err;
  }
  EXPECT_LT(prev, kFinalRelTol);
}

TEST(HshRotation, CompactLobeStaysInHemisphere) {
  // A bump supported within 25 deg of the pole, rotated by 40 deg about y, stays in the upper
  // hemisphere: the SH round trip approaches the HSH projection of the rotated bump, up to the
  // HSH truncation of the input (degree 8).
  constexpr int kLmax = 8;
  constexpr double kBeta = 40.0 * kPi / 180.0;
  const double cap = std::cos(25.0 * kPi / 180.0);
  auto bump = [&](const Vec3& w) { return std::pow(std::max(0.0, w.z - cap), 3); };
  auto fine = MakeHemisphereRule(200, 400);
  ASSERT_TRUE(fine.ok());
  auto h =
      ProjectHsh(kLmax, *fine, [&](double t, double p) { return bump(DirectionFromAngles(t, p)); });
  ASSERT_TRUE(h.ok());
  const Mat3 inv = RotationY(kBeta).Transposed();
  auto ref = ProjectHsh(kLmax, *fine,
                        [&](double t, double p) { return bump(inv * DirectionFromAngles(t, p)); });
  ASSERT_TRUE(ref.ok());
  std::vector<double> errs;
  for (int sh_lmax : {8, 16, 32}) {
    auto conv = ShHshConversion::Create(kLmax, sh_lmax);
    ASSERT_TRUE(conv.ok());
    std::vector<double> out(HshCount(kLmax));
    ASSERT_TRUE(RotateHsh(*conv, RotationY(kBeta), *h, out).ok());
    std::vector<double> diff(out.size());
    for (size_t i = 0; i < out.size(); ++i) diff[i] = out[i] - (*ref)[i];
    errs.push_back(Norm2(diff) / Norm2(*ref));
  }
  EXPECT_LT(errs[1], errs[0]);
  EXPECT_LE(errs[2], errs[1] * 1.05);  // may plateau at the HSH truncation error
  EXPECT_LT(errs[2], 0.1);
}

}  // namespace
}  // namespace shrm
