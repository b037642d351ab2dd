// BRDF coefficients rho_lpq (SHRM paper eq. 5.22, conventions of brdf_coefficients.h) and the
// order selection of eqs. 5.17/5.18 and sec. 5.6.2 (core/brdf/brdf_projection.h): brute-force 4D
// quadrature of the definition, Parseval on band-limited BRDFs, Phong's closed form and
// eqs. 5.27/5.28, and the paper's Table 5.5.
#include "core/brdf/brdf_coefficients.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_models.h"
#include "core/brdf/brdf_projection.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

// Smooth (entire) integrands: both quadratures converge geometrically; rounding only.
constexpr double kSmoothBruteForceTol = 1e-9;
// Microfacet sigma = 0.3: rho-hat jumps at the horizon N.w = 0 (to ~the peak for grazing views),
// so the brute-force product rule converges only like O(h); measured 2e-4 of the largest
// coefficient on the grid below, so 1e-3 leaves a margin.
constexpr double kMicrofacetBruteForceTol = 1e-3;
// The Fresnel table's Catmull-Rom interpolation between 129 float nodes uniform in N.R against
// Schlick's closed form, a quintic in N.R: the cubic's error ~h^3 |F'''| / 20 with h = 1 / 128
// and F''' <= 60 (1 - f0), 1.4e-6 of F >= f0 = 0.04 at most, plus float rounding (6e-8).
constexpr double kFresnelTableTol = 1e-5;
// GGX alpha 0.4 f0 0.04's energy over Schlick's factor in the view variable against the 4D
// product rule (48 x 64 view nodes, 96 x 192 incoming): the rule's own error near grazing, where
// rho-hat / w has GGX's 1 / (N.V) rise: 1.05e-5 measured.
constexpr double kViewFresnelEnergyTol = 1e-4;
// Band-limited rho-hat: every rule is exact; rounding only (the brief's 1e-10).
constexpr double kParsevalTol = 1e-10;
// Parseval in the normal variable at (40, 24) for the smooth test BRDF: the tail beyond P = 24 of
// the C^1-extended rho-hat (measured 3.8e-8; the even extension's kink at the equator left
// 1.2e-6) and the 4D quadrature's own error.
constexpr double kNormalParsevalTailTol = 1e-6;
// Phong closed form vs the 1D quadrature (composite Gauss-Legendre panels): the brief's 1e-8.
constexpr double kPhongClosedFormTol = 1e-8;

Mat3 RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return Quaternion{g(rng), g(rng), g(rng), g(rng)}.ToMatrix();
}

// A smooth, view-dependent, isotropic test BRDF without horizon (world-frame definition only):
// rho-hat = exp(0.8 R.w + 0.5 (R.V)(R.w) + 0.3 V.w).
class SmoothTestBrdf final : public Brdf {
 public:
  std::string spec() const override { return "smooth-test"; }
  BrdfBandwidthHint bandwidth_hint() const override { return {16, 8}; }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const override {
    const Vec3 r = n * (2 * n.Dot(v)) - v;
    return std::exp(0.8 * r.Dot(w) + 0.5 * r.Dot(v) * r.Dot(w) + 0.3 * v.Dot(w));
  }
};

// rho-hat = sum rho_lpq conj(Y_lq(w_i')) Y_pq(w_o') for given coefficients (q >= 0 stored).
class SeriesBrdf final : public Brdf {
 public:
  explicit SeriesBrdf(std::map<std::tuple<int, int, int>, double> coeffs)
      : coeffs_(std::move(coeffs)) {
    for (const auto& [key, value] : coeffs_) {
      lmax_ = std::max(lmax_, std::get<0>(key));
      lmax_ = std::max(lmax_, std::get<1>(key));
    }
    EXPECT_LE(lmax_, kMaxDegree);
  }
  std::string spec() const override { return "series-test"; }
  BrdfBandwidthHint bandwidth_hint() const override { return {lmax_ + 2, lmax_ + 2}; }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override {
    double ti, to, phi;
    ReparamAngles(ReparamKind::kReflection, n, v, w, &ti, &to, &phi);
    return ReparamTransfer(ti, to, phi, c);
  }
  double ReparamTransfer(double ti, double to, double phi, int) const override {
    double li[kMaxTable], lo[kMaxTable], cq[kMaxDegree + 1];
    NormalizedLegendre(lmax_, std::cos(ti), std::sin(ti), li);
    NormalizedLegendre(lmax_, std::cos(to), std::sin(to), lo);
    for (int q = 0; q <= lmax_; ++q) cq[q] = std::cos(q * phi);
    double sum = 0;
    for (const auto& [key, value] : coeffs_) {
      const auto [l, p, q] = key;
      // conj(Y_lq(w_i)) Y_pq(w_o) + (q -> -q) = 2 f_lq f_pq cos(q phi) for q > 0.
      sum +=
          (q == 0 ? 1.0 : 2.0) * value * li[LegendreIndex(l, q)] * lo[LegendreIndex(p, q)] * cq[q];
    }
    return sum;
  }

 private:
  static constexpr int kMaxDegree = 12;
  static constexpr int kMaxTable = LegendreCount(kMaxDegree);
  std::map<std::tuple<int, int, int>, double> coeffs_;
  int lmax_ = 0;
};

// Phong through the general (3D) path.
class PhongAs3D final : public Brdf {
 public:
  explicit PhongAs3D(double s) : phong_(s) {}
  std::string spec() const override { return "phong-3d"; }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override {
    return phong_.Transfer(n, v, w, c);
  }

 private:
  PhongBrdf phong_;
};

struct Lpq {
  int l, p, q;
};

// Direct 4D quadrature of the definition
//   rho_lpq = integral integral rho-hat(w_i', w_o') Y_lq(w_i') conj(Y_pq(w_o')) dw_i' dw_o'
// on product grids (Gauss-Legendre in cos theta x uniform phi) over both spheres, complex SH
// from sh.h, rho-hat from the world-frame Transfer of (N, V, w) built in a random frame Q:
// R = Q e_z, V = Q w_o', w = Q w_i', N = normalize(R + V). Returns the real parts and checks
// that the imaginary parts vanish.
// ViewVariable::kNormal: the outer grid is over the normal's hemisphere n' (Gauss-Legendre in
// cos theta_n' over [0, 1]), V = 2 (N.R) N - R, and each node also stands for its mirror below
// the equator with the C^1 extension's value (docs/shrm.md "The view variable"), made here from
// the node's own values and the equator's. energy (optional): the integral of the square of the
// function (and its extension) over both spheres.
std::vector<double> BruteForceRho(const Brdf& brdf, const std::vector<Lpq>& which, int n_i, int m_i,
                                  int n_o, int m_o, uint64_t seed, double imag_tol,
                                  ViewVariable view = ViewVariable::kView, double* energy = nullptr,
                                  const std::function<double(double)>& divisor = nullptr) {
  std::mt19937_64 rng(seed);
  const Mat3 q = RandomRotation(rng);
  const RingQuadrature gi = GaussLegendreRule(n_i), go = GaussLegendreRule(n_o);
  const auto dir = [](double t, double p) {
    return Vec3{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
  };
  std::vector<Vec3> wi_dirs;
  std::vector<double> wi_weights;
  std::vector<std::vector<std::complex<double>>> yi(which.size());
  for (int j = 0; j < n_i; ++j) {
    for (int k = 0; k < m_i; ++k) {
      const double phi = 2 * kPi * (k + 0.3) / m_i;
      wi_dirs.push_back(q * dir(gi.theta[j], phi));
      wi_weights.push_back(gi.weight[j] * 2 * kPi / m_i);
      for (size_t t = 0; t < which.size(); ++t) {
        yi[t].push_back(EvalComplexSh(which[t].l, which[t].q, gi.theta[j], phi));
      }
    }
  }
  const Vec3 pole = q * Vec3{0, 0, 1};
  std::vector<std::complex<double>> sums(which.size());
  const bool normal = view == ViewVariable::kNormal;
  // The world-frame (N, V) of a grid point, and the projections of the BRDF there onto Y_lq.
  const auto point = [&](double theta, double phi, Vec3* n, Vec3* v) {
    *v = q * dir(theta, phi);
    *n = (pole + *v).Normalized();
    if (normal) {
      *n = *v;  // the grid's direction is the normal
      *v = *n * (2 * n->Dot(pole)) - pole;
    }
  };
  // With a divisor (the Fresnel normalization, brdf_coefficients.h; either variable): f is
  // rho-hat over divisor(N.V).
  const auto scale_at = [&](const Vec3& n, const Vec3& v) {
    return divisor ? 1.0 / divisor(n.Dot(v)) : 1.0;
  };
  const auto project = [&](const Vec3& n, const Vec3& v, std::vector<std::complex<double>>& in) {
    in.assign(which.size(), 0.0);
    const double scale = scale_at(n, v);
    for (size_t d = 0; d < wi_dirs.size(); ++d) {
      const double rho = brdf.Transfer(n, v, wi_dirs[d], 0) * wi_weights[d] * scale;
      if (rho == 0) continue;
      for (size_t t = 0; t < which.size(); ++t) in[t] += rho * yi[t][d];
    }
  };
  // kNormal: the function on the whole sphere of n' is the extension of docs/shrm.md "The view
  // variable": at pi - theta below the equator, f(theta) (1 - 2 sin^2 theta) + 2 e sin^2 theta,
  // e the value at the equator (theta_n' just below pi/2: N.V -> 0) of the same azimuth.
  std::vector<std::vector<std::complex<double>>> equator(m_o);
  std::vector<std::vector<double>> equator_values(m_o);  // e at every w_i (for *energy)
  if (normal) {
    for (int k = 0; k < m_o; ++k) {
      Vec3 n, v;
      point(0.5 * kPi - 1e-9, 2 * kPi * (k + 0.6) / m_o, &n, &v);
      project(n, v, equator[k]);
      if (energy == nullptr) continue;
      for (const Vec3& wi : wi_dirs)
        equator_values[k].push_back(brdf.Transfer(n, v, wi, 0) * scale_at(n, v));
    }
  }
  if (energy != nullptr) *energy = 0;
  std::vector<std::complex<double>> inner;
  for (int j = 0; j < n_o; ++j) {
    // kNormal: the upper hemisphere, theta_n' from cos theta_n' = (1 + x_j) / 2 on [0, 1], weight
    // halved by the map; each node also stands for its mirror pi - theta_n' below the equator.
    const double theta_o = normal ? std::acos(0.5 * (1 + go.cos_theta[j])) : go.theta[j];
    const double weight_o = normal ? 0.5 * go.weight[j] : go.weight[j];
    const double s2 = std::sin(theta_o) * std::sin(theta_o);
    for (int k = 0; k < m_o; ++k) {
      const double phi_o = 2 * kPi * (k + 0.6) / m_o;
      Vec3 n, v;
      point(theta_o, phi_o, &n, &v);
      project(n, v, inner);
      const double w_o = weight_o * 2 * kPi / m_o;
      // The integral of g^2 over both spheres (kNormal: the node and its mirror).
      for (size_t d = 0; energy != nullptr && d < wi_dirs.size(); ++d) {
        const double f = brdf.Transfer(n, v, wi_dirs[d], 0) * scale_at(n, v);
        const double mirror = normal ? f * (1 - 2 * s2) + 2 * s2 * equator_values[k][d] : 0.0;
        *energy += w_o * wi_weights[d] * (f * f + mirror * mirror);
      }
      for (size_t t = 0; t < which.size(); ++t) {
        const std::complex<double> y =
            std::conj(EvalComplexSh(which[t].p, which[t].q, theta_o, phi_o));
        std::complex<double> value = inner[t];
        if (normal) {  // + the mirror's value, Y_pq(pi - theta) = (-1)^(p+q) Y_pq(theta)
          const double parity = (which[t].p + which[t].q) % 2 == 0 ? 1.0 : -1.0;
          value += parity * (inner[t] * (1 - 2 * s2) + 2.0 * s2 * equator[k][t]);
        }
        sums[t] += w_o * value * y;
      }
    }
  }
  std::vector<double> out;
  double largest = 0;
  for (const auto& s : sums) largest = std::max(largest, std::abs(s));
  for (const auto& s : sums) {
    EXPECT_LT(std::abs(s.imag()), imag_tol * largest);
    out.push_back(s.real());
  }
  return out;
}

const std::vector<Lpq> kTriples = {{0, 0, 0}, {1, 0, 0}, {3, 1, 0}, {2, 1, 1},  {4, 2, 1},
                                   {5, 2, 2}, {6, 3, 2}, {3, 3, 3}, {10, 2, 1}, {1, 2, -1}};

TEST(BrdfCoefficientsTest, SmoothBrdfMatchesBruteForce) {
  const SmoothTestBrdf brdf;
  auto coeffs = ComputeBrdfCoefficients(brdf, 12, 4);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  const std::vector<double> brute =
      BruteForceRho(brdf, kTriples, 40, 64, 32, 48, 1, kSmoothBruteForceTol);
  double scale = 0;
  for (double b : brute) scale = std::max(scale, std::abs(b));
  for (size_t t = 0; t < kTriples.size(); ++t) {
    const auto [l, p, q] = kTriples[t];
    EXPECT_NEAR(coeffs->at(l, p, q), brute[t], kSmoothBruteForceTol * scale)
        << "l=" << l << " p=" << p << " q=" << q;
  }
}

TEST(BrdfCoefficientsTest, MicrofacetMatchesBruteForce) {
  const MicrofacetBrdf brdf(0.3);
  auto coeffs = ComputeBrdfCoefficients(brdf, 12, 4);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  const std::vector<double> brute =
      BruteForceRho(brdf, kTriples, 96, 192, 32, 48, 2, kMicrofacetBruteForceTol);
  double scale = 0, worst = 0;
  for (double b : brute) scale = std::max(scale, std::abs(b));
  for (size_t t = 0; t < kTriples.size(); ++t) {
    const auto [l, p, q] = kTriples[t];
    worst = std::max(worst, std::abs(coeffs->at(l, p, q) - brute[t]) / scale);
    EXPECT_NEAR(coeffs->at(l, p, q), brute[t], kMicrofacetBruteForceTol * scale)
        << "l=" << l << " p=" << p << " q=" << q;
  }
  std::printf("microfacet sigma=0.3: max |separable - brute force| / max|rho| = %.3g\n", worst);
}

// The normal variable (brdf_coefficients.h ViewVariable::kNormal): the separable path (smooth
// model) and the split rule (microfacet, horizon-clipped; GGX with Schlick's Fresnel, whose
// theta_n' derivative at the equator the extension carries across it) against the 4D quadrature
// over the normal's hemisphere and its mirror, which evaluates the world-frame Transfer at
// (N, V = reflection of R about N) and the extension below the equator from its own values.
TEST(BrdfCoefficientsTest, NormalVariableMatchesBruteForce) {
  const std::vector<Lpq> triples = {{0, 0, 0}, {2, 0, 0}, {3, 1, 1}, {2, 2, 0},  {4, 2, 2},
                                    {5, 3, 1}, {6, 4, 2}, {3, 3, 3}, {10, 4, 0}, {1, 2, 1},
                                    {3, 1, 0}, {4, 3, 2}};  // the last two: p + q odd
  // The coefficients at (12, pmax) against the quadrature (n_i x m_i incoming nodes) within
  // tol x the largest; returns the largest difference over the largest, and the brute-force
  // values in *brute.
  auto check = [&](const Brdf& brdf, const char* label, int pmax, int n_i, int m_i, double tol,
                   std::vector<double>* brute,
                   const std::function<double(double)>& divisor = nullptr) {
    auto coeffs = ComputeBrdfCoefficients(brdf, 12, pmax, {}, ViewVariable::kNormal);
    EXPECT_TRUE(coeffs.ok()) << coeffs.status();
    if (!coeffs.ok()) return 0.0;
    EXPECT_EQ(coeffs->view, ViewVariable::kNormal);
    *brute = BruteForceRho(brdf, triples, n_i, m_i, 32, 48, pmax, tol, ViewVariable::kNormal,
                           nullptr, divisor);
    double scale = 0, worst = 0;
    for (double b : *brute) scale = std::max(scale, std::abs(b));
    for (size_t t = 0; t < triples.size(); ++t) {
      const auto [l, p, q] = triples[t];
      worst = std::max(worst, std::abs(coeffs->at(l, p, q) - (*brute)[t]) / scale);
      EXPECT_NEAR(coeffs->at(l, p, q), (*brute)[t], tol * scale)
          << label << " l=" << l << " p=" << p << " q=" << q;
    }
    std::printf("%s, normal variable: max |coefficient - brute force| / max|rho| = %.3g\n", label,
                worst);
    return scale;
  };
  std::vector<double> brute;
  check(SmoothTestBrdf(), "smooth", 4, 40, 64, kSmoothBruteForceTol, &brute);
  check(MicrofacetBrdf(0.3), "microfacet sigma=0.3", 4, 96, 192, kMicrofacetBruteForceTol, &brute);
  // GGX: rho-hat over Schlick's F(N.V) (the Fresnel normalization), the test's own closed form.
  const auto schlick = [](double f0) {
    return [f0](double cos_nv) { return f0 + (1 - f0) * std::pow(1 - cos_nv, 5); };
  };
  const double scale = check(GgxBrdf(0.4, 0.04), "ggx alpha=0.4 f0=0.04", 5, 96, 192,
                             kMicrofacetBruteForceTol, &brute, schlick(0.04));
  // The odd terms carry the extension's slope (the shadowing's fall towards grazing): not zero.
  EXPECT_GT(std::abs(brute[10]), 1e-3 * scale);
}

// The view variable with the Fresnel normalization (session 24): GGX f0 = 0.04's coefficients and
// their energy (eq. 5.18, what the epsilon rule divides by) against the 4D quadrature of
// rho-hat / Schlick's F(N.V), N = (R + V) / |R + V|, with the test's own closed form; negative
// control: the quadrature of rho-hat itself is far from them.
TEST(BrdfCoefficientsTest, ViewVariableFresnelMatchesBruteForce) {
  const GgxBrdf ggx(0.4, 0.04);
  const std::vector<Lpq> triples = {{0, 0, 0}, {2, 0, 0}, {3, 1, 1}, {2, 2, 0},  {4, 2, 2},
                                    {5, 3, 1}, {6, 4, 2}, {3, 3, 3}, {10, 4, 0}, {1, 2, 1}};
  auto coeffs = ComputeBrdfCoefficients(ggx, 12, 5);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  ASSERT_EQ(coeffs->view, ViewVariable::kView);
  ASSERT_EQ(coeffs->fresnel.size(), static_cast<size_t>(kFresnelIntervals + 1));
  const auto schlick = [](double cos_nv) { return 0.04 + 0.96 * std::pow(1 - cos_nv, 5); };
  double energy = 0;
  const std::vector<double> brute =
      BruteForceRho(ggx, triples, 96, 192, 48, 64, 5, kMicrofacetBruteForceTol, ViewVariable::kView,
                    &energy, schlick);
  const std::vector<double> plain =
      BruteForceRho(ggx, triples, 96, 192, 48, 64, 5, kMicrofacetBruteForceTol);
  double scale = 0, worst = 0, worst_plain = 0;
  for (double b : brute) scale = std::max(scale, std::abs(b));
  for (size_t t = 0; t < triples.size(); ++t) {
    const auto [l, p, q] = triples[t];
    worst = std::max(worst, std::abs(coeffs->at(l, p, q) - brute[t]) / scale);
    worst_plain = std::max(worst_plain, std::abs(coeffs->at(l, p, q) - plain[t]) / scale);
    EXPECT_NEAR(coeffs->at(l, p, q), brute[t], kMicrofacetBruteForceTol * scale)
        << "l=" << l << " p=" << p << " q=" << q;
  }
  const double energy_diff = coeffs->total_energy[0] / energy - 1;
  std::printf(
      "ggx alpha=0.4 f0=0.04, view variable over Schlick: max |coefficient - brute force| / "
      "max|rho| = %.3g (%.3g against rho-hat undivided); energy / quadrature - 1 = %.3g\n",
      worst, worst_plain, energy_diff);
  EXPECT_GT(worst_plain, 100 * kMicrofacetBruteForceTol);
  EXPECT_LT(std::abs(energy_diff), kViewFresnelEnergyTol);
}

// The Fresnel table (brdf_coefficients.h): GGX's interpolated table against Schlick's closed form
// at random N.V, in both view variables; none for models without a Fresnel factor (f0 = 1,
// microfacet).
TEST(BrdfCoefficientsTest, FresnelTableIsSchlicksFactor) {
  const GgxBrdf ggx(0.2, 0.04);
  auto coeffs = ComputeBrdfCoefficients(ggx, 8, 4, {}, ViewVariable::kNormal);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  ASSERT_EQ(coeffs->fresnel.size(), static_cast<size_t>(kFresnelIntervals + 1));
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  double worst = 0;
  for (int k = 0; k < 2000; ++k) {
    const double x = k < 2 ? k : u(rng);  // both ends, then random
    const double want = 0.04 + 0.96 * std::pow(1 - x, 5);
    worst = std::max(worst, std::abs(FresnelAt(coeffs->fresnel, 1, x, 0) / want - 1));
  }
  std::printf("Fresnel table vs Schlick: largest relative difference %.3g\n", worst);
  EXPECT_LT(worst, kFresnelTableTol);
  EXPECT_TRUE(
      ComputeBrdfCoefficients(GgxBrdf(0.2, 1.0), 8, 4, {}, ViewVariable::kNormal)->fresnel.empty());
  EXPECT_TRUE(ComputeBrdfCoefficients(MicrofacetBrdf(0.2), 8, 4, {}, ViewVariable::kNormal)
                  ->fresnel.empty());
  EXPECT_EQ(ComputeBrdfCoefficients(ggx, 8, 4)->fresnel, coeffs->fresnel);
  EXPECT_EQ(FresnelAt(std::span<const double>(), 1, 0.5, 0), 1.0);
}

// Parseval in the normal variable: sum rho_lpq^2 (q != 0 twice) at orders beyond the BRDF's
// band equals the integral of the extended function's square over both spheres (the test's own
// 4D quadrature: the hemisphere of n' and its mirror, the extension from its own values).
TEST(BrdfCoefficientsTest, NormalVariableEnergyIsParseval) {
  const SmoothTestBrdf brdf;
  auto coeffs = ComputeBrdfCoefficients(brdf, 40, 24, {}, ViewVariable::kNormal);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  double sum = 0;
  for (int l = 0; l <= 40; ++l)
    for (int p = 0; p <= 24; ++p)
      for (int q = 0; q <= std::min(l, p); ++q)
        sum += (q == 0 ? 1.0 : 2.0) * coeffs->at(l, p, q) * coeffs->at(l, p, q);
  double energy = 0;
  BruteForceRho(brdf, {{0, 0, 0}}, 40, 64, 32, 48, 3, 1.0, ViewVariable::kNormal, &energy);
  std::printf("normal variable, smooth BRDF: sum rho^2 at (40, 24) / integral = %.9f\n",
              sum / energy);
  EXPECT_NEAR(sum / energy, 1.0, kNormalParsevalTailTol);
}

TEST(BrdfCoefficientsTest, ParsevalOnBandLimitedBrdf) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  std::map<std::tuple<int, int, int>, double> chosen;
  for (int l = 0; l <= 6; ++l) {
    for (int p = 0; p <= 3; ++p) {
      for (int q = 0; q <= std::min(l, p); ++q) chosen[{l, p, q}] = u(rng);
    }
  }
  const SeriesBrdf brdf(chosen);
  auto coeffs = ComputeBrdfCoefficients(brdf, 8, 4);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  double sum_sq = 0;
  for (int l = 0; l <= 8; ++l) {
    for (int p = 0; p <= 4; ++p) {
      for (int q = 0; q <= std::min(l, p); ++q) {
        const auto it = chosen.find({l, p, q});
        const double want = it == chosen.end() ? 0.0 : it->second;
        EXPECT_NEAR(coeffs->at(l, p, q), want, kParsevalTol) << l << " " << p << " " << q;
        EXPECT_EQ(coeffs->at(l, p, -q), coeffs->at(l, p, q));
        sum_sq += (q == 0 ? 1 : 2) * want * want;
      }
    }
  }
  ASSERT_EQ(coeffs->total_energy.size(), 1u);
  EXPECT_NEAR(coeffs->total_energy[0], sum_sq, kParsevalTol * sum_sq);
  EXPECT_NEAR(CapturedFraction(*coeffs, 8, 4), 1.0, kParsevalTol);
  EXPECT_NEAR(CapturedFraction(*coeffs, 6, 3), 1.0, kParsevalTol);
  EXPECT_LT(CapturedFraction(*coeffs, 5, 3), 1.0 - 1e-3);
}

TEST(BrdfCoefficientsTest, PhongMatchesClosedForm) {
  for (double s : {1.0, 8.0, 32.0, 100.5, 512.0}) {
    const PhongBrdf brdf(s);
    const int lmax = static_cast<int>(3 * std::sqrt(s)) + 10;
    auto coeffs = ComputeBrdfCoefficients(brdf, lmax, 2);
    ASSERT_TRUE(coeffs.ok()) << coeffs.status();
    const std::vector<double> exact = PhongRhoExact(s, lmax);
    for (int l = 0; l <= lmax; ++l) {
      // rho_{l00} = sqrt(4 pi) rho_l; p, q > 0 vanish.
      EXPECT_NEAR(coeffs->at(l, 0, 0) / std::sqrt(4 * kPi), exact[l],
                  kPhongClosedFormTol * exact[0])
          << "s=" << s << " l=" << l;
      for (int p = 1; p <= 2; ++p) EXPECT_EQ(coeffs->at(l, p, 0), 0.0);
    }
    // Energy (eq. 5.17 x 4 pi): (s + 1)^2 / (2 pi (2 s + 1)) * 4 pi.
    const double energy = 4 * kPi * (s + 1) * (s + 1) / (2 * kPi * (2 * s + 1));
    EXPECT_NEAR(coeffs->total_energy[0], energy, 1e-10 * energy) << s;
    // rho_0 = 1/sqrt(4 pi) (normalized lobe) = Lambda_0^-1.
    EXPECT_NEAR(exact[0], 1 / std::sqrt(4 * kPi), 1e-15);
  }
}

TEST(BrdfCoefficientsTest, RadialRelationThroughTheGeneralPath) {
  // The 3D path knows nothing of radial symmetry: rho_{l00} = sqrt(4 pi) rho_l and all p > 0
  // terms vanish.
  const double s = 20;
  const PhongAs3D brdf(s);
  auto coeffs = ComputeBrdfCoefficients(brdf, 16, 3);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  const std::vector<double> exact = PhongRhoExact(s, 16);
  for (int l = 0; l <= 16; ++l) {
    EXPECT_NEAR(coeffs->at(l, 0, 0), std::sqrt(4 * kPi) * exact[l], 1e-8) << l;
    for (int p = 1; p <= 3; ++p) {
      for (int q = 0; q <= std::min(l, p); ++q) EXPECT_NEAR(coeffs->at(l, p, q), 0, 1e-10);
    }
  }
}

TEST(BrdfCoefficientsTest, PhongEq527And528Accuracy) {
  // Eq. 5.27: rho_l ~ Lambda_l^-1 exp(-l^2 / 2s). Measured (printed below) for s = 8..512 and
  // l <= 3 sqrt(s): the error relative to rho_0 stays below 0.14 (0.135 at s = 16, 32); relative
  // to rho_l itself it is <= 8.1 % for l <= sqrt(s) and grows in the tail (27 % at l = 3 sqrt(s),
  // s = 32; 74 % at s = 8). Eq. 5.28's F is within 1 of the exact order at epsilon = 0.03, 0.01.
  constexpr double kEq527PeakRelTol = 0.14;
  constexpr double kEq527CoreRelTol = 0.09;
  for (double s = 8; s <= 512; s *= 2) {
    const int lmax = static_cast<int>(3 * std::sqrt(s));
    const std::vector<double> exact = PhongRhoExact(s, lmax), approx = PhongRhoEq527(s, lmax);
    double peak_err = 0, core_err = 0, tail_err = 0;
    for (int l = 0; l <= lmax; ++l) {
      peak_err = std::max(peak_err, std::abs(approx[l] - exact[l]) / exact[0]);
      const double rel = std::abs(approx[l] / exact[l] - 1);
      if (l <= std::sqrt(s)) core_err = std::max(core_err, rel);
      tail_err = std::max(tail_err, rel);
    }
    EXPECT_LT(peak_err, kEq527PeakRelTol) << s;
    EXPECT_LT(core_err, kEq527CoreRelTol) << s;
    for (double eps : {0.03, 0.01}) {
      EXPECT_LT(std::abs(PhongOrderEq528(s, eps) - PhongOrderExact(s, eps)), 1.0)
          << s << " " << eps;
    }
    std::printf(
        "phong s=%4.0f: eq.5.27 max err/rho_0 %.3f, rel l<=sqrt(s) %.3f, rel l<=3sqrt(s) %.3f; "
        "F(0.03) exact %d eq.5.28 %.2f\n",
        s, peak_err, core_err, tail_err, PhongOrderExact(s, 0.03), PhongOrderEq528(s, 0.03));
  }
}

TEST(BrdfCoefficientsTest, DefaultSamplingHasConverged) {
  const MicrofacetBrdf brdf(0.2);
  auto base = ComputeBrdfCoefficients(brdf, 30, 4);
  BrdfSampling fine;  // the single rules (not the split one of the default), refined
  fine.coefficients_uniform = true;
  fine.theta_i = 240;
  fine.theta_o = 96;
  fine.phi = 64;
  fine.energy_panels_i = 128;
  fine.energy_panels_o = 32;
  fine.energy_phi = 96;
  auto ref = ComputeBrdfCoefficients(brdf, 30, 4, fine);
  ASSERT_TRUE(base.ok() && ref.ok());
  double scale = 0, diff = 0;
  for (size_t i = 0; i < ref->values.size(); ++i) {
    scale = std::max(scale, std::abs(ref->values[i]));
    diff = std::max(diff, std::abs(ref->values[i] - base->values[i]));
  }
  EXPECT_LT(diff, 1e-4 * scale);
  EXPECT_NEAR(base->total_energy[0], ref->total_energy[0], 1e-4 * ref->total_energy[0]);
  for (int P = 0; P <= 4; ++P) {
    EXPECT_NEAR(CapturedFraction(*base, 30, P), CapturedFraction(*ref, 30, P), 1e-4);
  }
}

// The energy of a horizon-clipped BRDF (BrdfEnergy's default rule: theta_i' panels split where
// the visible azimuth arc starts and stops shrinking, both ends smoothed by a substitution)
// against the uniform composite panels refined twice beyond their own default (a different rule,
// blind to where the horizon is), and against itself refined (convergence).
TEST(BrdfEnergyTest, HorizonSplitRuleAgreesWithRefinedUniformPanels) {
  // The uniform rule at twice its default panels still carries the O(h^1.5) error of the
  // horizon's square-root kink: measured up to 1.5e-5 against converged values.
  constexpr double kUniformRuleTol = 3e-5;
  // The split rule at its defaults against itself at 4x the theta_i' panels, 24 theta_o'
  // panels and 64 azimuth nodes: measured up to 9e-6 (GGX alpha 0.1), 1e-6 for sigma >= 0.2.
  constexpr double kConvergedTol = 2e-5;
  for (const char* spec : {"microfacet:sigma=0.1", "microfacet:sigma=0.2", "microfacet:sigma=0.5",
                           "ggx:alpha=0.1", "ggx:alpha=0.3,f0=1", "ward:alpha=0.15"}) {
    SCOPED_TRACE(spec);
    auto brdf = ParseBrdfSpec(spec);
    ASSERT_TRUE(brdf.ok()) << brdf.status();
    ASSERT_TRUE((*brdf)->clipped_at_normal_horizon());
    const int h = (*brdf)->bandwidth_hint().lmax;
    const std::vector<double> split = BrdfEnergy(**brdf, h);
    BrdfSampling uniform;
    uniform.energy_uniform_panels = true;
    uniform.energy_panels_i = 2 * std::max(48, h);
    uniform.energy_panels_o = 24;
    uniform.energy_phi = 64;
    const std::vector<double> other = BrdfEnergy(**brdf, h, uniform);
    BrdfSampling refined;
    refined.energy_panels_i = 4 * h;
    refined.energy_panels_o = 24;
    refined.energy_phi = 64;
    const std::vector<double> converged = BrdfEnergy(**brdf, h, refined);
    for (size_t c = 0; c < split.size(); ++c) {
      EXPECT_NEAR(split[c], other[c], kUniformRuleTol * other[c]) << c;
      EXPECT_NEAR(split[c], converged[c], kConvergedTol * converged[c]) << c;
    }
  }
}

// The split rule of the analytic horizon-clipped models (the default: theta_i' split where the
// visible arc shrinks, theta_o' smoothed at the grazing end, the energy from the same
// evaluations) against the single Gauss-Legendre rules and BrdfEnergy's panels, refined far
// beyond their defaults (a different rule: blind to the kinks, converging algebraically there).
TEST(BrdfCoefficientsTest, SplitRuleAgreesWithTheRefinedSingleRules) {
  // The refined single rules themselves carry the kinks' algebraic error: measured differences
  // 5e-6..2e-5 of the largest coefficient for sigma >= 0.1, Ward, Lafortune, Lambert and GGX
  // alpha 0.3; 3e-4 for GGX alpha 0.1, whose sharp peak and heavy tail the single rules resolve
  // least (1.5e-4 against them refined to 600 x 200 x 120: the reference's own error).
  constexpr double kCoefficientTol = 5e-5;
  constexpr double kSharpGgxTol = 6e-4;
  // Energy: measured within 1e-6 relative (both rules converge there).
  constexpr double kEnergyTol = 5e-6;
  BrdfSampling refined;
  refined.coefficients_uniform = true;
  refined.theta_i = 400;
  refined.theta_o = 160;
  refined.phi = 96;
  refined.energy_panels_i = 160;  // BrdfEnergy's split panels at ~3x their default (1e-6 there)
  refined.energy_panels_o = 12;
  refined.energy_phi = 48;
  for (const char* spec :
       {"microfacet:sigma=0.1", "microfacet:sigma=0.3", "ggx:alpha=0.1", "ggx:alpha=0.3,f0=1",
        "ward:alpha=0.2", "lafortune:rho_d=0.1;cx=-1,cy=-1,cz=1,n=20,rho=0.9", "lambert"}) {
    SCOPED_TRACE(spec);
    auto brdf = ParseBrdfSpec(spec);
    ASSERT_TRUE(brdf.ok()) << brdf.status();
    const BrdfBandwidthHint h = (*brdf)->bandwidth_hint();
    auto split = ComputeBrdfCoefficients(**brdf, h.lmax, h.pmax);
    auto ref = ComputeBrdfCoefficients(**brdf, h.lmax, h.pmax, refined);
    ASSERT_TRUE(split.ok() && ref.ok());
    double scale = 0, diff = 0;
    for (size_t i = 0; i < ref->values.size(); ++i) {
      scale = std::max(scale, std::abs(ref->values[i]));
      diff = std::max(diff, std::abs(ref->values[i] - split->values[i]));
    }
    const double tol = std::string(spec) == "ggx:alpha=0.1" ? kSharpGgxTol : kCoefficientTol;
    EXPECT_LT(diff, tol * scale);
    for (size_t c = 0; c < ref->total_energy.size(); ++c) {
      EXPECT_NEAR(split->total_energy[c], ref->total_energy[c], kEnergyTol * ref->total_energy[c]);
    }
    std::printf("%s: split rule vs refined single rules: coefficients %.2g, energy %.2g\n", spec,
                diff / scale, std::abs(split->total_energy[0] / ref->total_energy[0] - 1));
  }
  // Orders with P above F (explicit orders may ask for them): q runs to min(F, P) only.
  const MicrofacetBrdf low(0.3);
  auto split = ComputeBrdfCoefficients(low, 2, 6);
  auto ref = ComputeBrdfCoefficients(low, 2, 6, refined);
  ASSERT_TRUE(split.ok() && ref.ok());
  double scale = 0, diff = 0;
  for (size_t i = 0; i < ref->values.size(); ++i) {
    scale = std::max(scale, std::abs(ref->values[i]));
    diff = std::max(diff, std::abs(ref->values[i] - split->values[i]));
  }
  EXPECT_LT(diff, kCoefficientTol * scale);
}

// ---------------------------------------------------------------- order selection

TEST(BrdfOrdersTest, Table55Microfacet) {
  // SHRM paper Table 5.5: (F_B, P_B) for epsilon < 0.03. Ours (printed): (23,2) (11,2) (7,2)
  // (5,2) (4,2), all within +-1 of the paper's; captured fractions at P = 2 for sigma = 0.1 are
  // 0.977 (the paper chose P = 3 there).
  const double sigmas[] = {0.1, 0.2, 0.3, 0.4, 0.5};
  const int paper_f[] = {24, 12, 7, 5, 5}, paper_p[] = {3, 2, 2, 2, 2};
  const int ours_f[] = {23, 11, 7, 5, 4}, ours_p[] = {2, 2, 2, 2, 2};
  for (int i = 0; i < 5; ++i) {
    const MicrofacetBrdf brdf(sigmas[i]);
    auto orders = SelectBrdfOrders(brdf, 0.03);
    ASSERT_TRUE(orders.ok()) << orders.status();
    std::printf("Table 5.5 sigma=%.1f: F=%d P=%d captured=%.5f (paper %d,%d)\n", sigmas[i],
                orders->F, orders->P, orders->captured, paper_f[i], paper_p[i]);
    EXPECT_LE(std::abs(orders->F - paper_f[i]), 1) << sigmas[i];
    EXPECT_LE(std::abs(orders->P - paper_p[i]), 1) << sigmas[i];
    EXPECT_EQ(orders->F, ours_f[i]) << sigmas[i];
    EXPECT_EQ(orders->P, ours_p[i]) << sigmas[i];
    // Minimality: (F - 1, P) and (F_max, P - 1) miss the tolerance.
    EXPECT_GE(orders->captured, 0.97);
    EXPECT_LT(CapturedFraction(orders->coefficients, orders->F - 1, orders->P), 0.97);
    if (orders->P > 0) {
      EXPECT_LT(CapturedFraction(orders->coefficients, orders->fmax, orders->P - 1), 0.97);
    }
  }
}

TEST(BrdfOrdersTest, SelectionProcedureOnKnownSpectrum) {
  // Energies: rho_000^2 = 0.5, rho_{8,0,0}^2 = 0.1, rho_{3,2,1}^2 (x2 for +-q) = 0.2,
  // rho_{2,3,0}^2 = 0.15, rho_{9,1,1}^2 (x2) = 0.05. Total 1.
  std::map<std::tuple<int, int, int>, double> chosen = {{{0, 0, 0}, std::sqrt(0.5)},
                                                        {{8, 0, 0}, std::sqrt(0.1)},
                                                        {{3, 2, 1}, std::sqrt(0.1)},
                                                        {{2, 3, 0}, std::sqrt(0.15)},
                                                        {{9, 1, 1}, std::sqrt(0.025)}};
  const SeriesBrdf brdf(chosen);
  BrdfOrderOptions options;
  options.initial_fmax = 12;
  options.initial_pmax = 4;
  // Band-limited: small energy rules are exact.
  options.sampling.energy_panels_i = 8;
  options.sampling.energy_panels_o = 4;
  options.sampling.energy_phi = 16;
  // epsilon = 0.19: P = 0, 1 reach at most 0.6, 0.65; P = 2 reaches 0.85 at F = 9 but only 0.8
  // at F = 8.
  auto orders = SelectBrdfOrders(brdf, 0.19, options);
  ASSERT_TRUE(orders.ok()) << orders.status();
  EXPECT_EQ(orders->P, 2);
  EXPECT_EQ(orders->F, 9);
  EXPECT_NEAR(orders->captured, 0.85, 1e-9);
  // epsilon = 0.1: needs p = 3 (0.95 at P = 3, F = 8); P = 1, 2 reach at most 0.85.
  orders = SelectBrdfOrders(brdf, 0.1, options);
  ASSERT_TRUE(orders.ok());
  EXPECT_EQ(orders->P, 3);
  EXPECT_EQ(orders->F, 8);
  // epsilon = 0.45: P = 0 with F = 8 gives 0.6 >= 0.55.
  orders = SelectBrdfOrders(brdf, 0.45, options);
  ASSERT_TRUE(orders.ok());
  EXPECT_EQ(orders->P, 0);
  EXPECT_EQ(orders->F, 8);
}

TEST(BrdfOrdersTest, KajiyaKayNeedsOnlyQZeroAndPaperP) {
  // Sec. 5.7.1: "we found P = 8 for s = 32 and epsilon < .03"; no azimuthal dependence.
  const KajiyaKayBrdf brdf(32);
  auto orders = SelectBrdfOrders(brdf, 0.03);
  ASSERT_TRUE(orders.ok()) << orders.status();
  std::printf("Kajiya-Kay s=32: F=%d P=%d captured=%.4f\n", orders->F, orders->P, orders->captured);
  EXPECT_LE(std::abs(orders->P - 8), 1);
  const BrdfCoefficients& c = orders->coefficients;
  EXPECT_EQ(c.reparam, ReparamKind::kTangent);
  for (int l = 0; l <= c.lmax; ++l) {
    for (int p = 0; p <= c.pmax; ++p) {
      for (int q = 1; q <= std::min(l, p); ++q) EXPECT_EQ(c.at(l, p, q), 0.0);
    }
  }
}

// The 2D midpoint rule on n x n cells of (t_i, t_o) in [0, pi]^2 of g(i, o, cos(t_i - t_o))
// sin t_i sin t_o over Kajiya-Kay's support (the cosine positive), cells i, o.
template <typename G>
double KajiyaKayMidpoint(int n, G g) {
  const double h = kPi / n;
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const double ti = kPi * (i + 0.5) / n;
    for (int o = 0; o < n; ++o) {
      const double to = kPi * (o + 0.5) / n, c = std::cos(ti - to);
      if (c > 0) sum += g(i, o, c) * std::sin(ti) * std::sin(to);
    }
  }
  return sum * h * h;
}

// Kajiya-Kay's rho_lp0 (the q = 0-only path of the separable rule for azimuth-independent
// models) against the test's own 2D midpoint rule of the definition: rho-hat depends on
// (theta_i', theta_o') only, so rho_lp0 = (2 pi)^2 double-integral rho-hat lambda_l^0(cos t_i)
// lambda_p^0(cos t_o) sin t_i sin t_o, with the model's closed form
// norm max(cos(t_i - t_o), 0)^s (norm from KajiyaKayBrdf::normalization()).
TEST(BrdfCoefficientsTest, KajiyaKayMatchesMidpointRule) {
  constexpr double kS = 32;
  constexpr int kN = 1600;  // midpoint rule: 1600 and 3200 agree with the coefficients alike
  // The separable rule's own error (78 x 48 Gauss-Legendre nodes in cos theta for a lobe of width
  // ~ 1 / sqrt(s) = 0.18 rad): 1.3e-5 of the largest coefficient, measured.
  constexpr double kKajiyaKayMidpointTol = 5e-5;
  const KajiyaKayBrdf brdf(kS);
  auto coeffs = ComputeBrdfCoefficients(brdf, 12, 8);
  ASSERT_TRUE(coeffs.ok()) << coeffs.status();
  std::vector<std::vector<double>> lam(kN, std::vector<double>(LegendreCount(12)));
  for (int j = 0; j < kN; ++j) NormalizedLegendre(12, std::cos(kPi * (j + 0.5) / kN), lam[j]);
  double scale = 0, worst = 0;
  std::vector<std::pair<int, int>> lp = {{0, 0}, {2, 0}, {1, 1}, {4, 2}, {6, 6}, {9, 8}, {12, 5}};
  std::vector<double> brute;
  for (const auto& [l, p] : lp) {
    const double sum = KajiyaKayMidpoint(kN, [&](int i, int o, double c) {
      return std::pow(c, kS) * lam[i][LegendreIndex(l, 0)] * lam[o][LegendreIndex(p, 0)];
    });
    brute.push_back(4 * kPi * kPi * brdf.normalization() * sum);
    scale = std::max(scale, std::abs(brute.back()));
  }
  for (size_t k = 0; k < lp.size(); ++k) {
    const auto [l, p] = lp[k];
    worst = std::max(worst, std::abs(coeffs->at(l, p, 0) - brute[k]) / scale);
    EXPECT_NEAR(coeffs->at(l, p, 0), brute[k], kKajiyaKayMidpointTol * scale) << l << " " << p;
  }
  std::printf("Kajiya-Kay s=32: max |coefficient - midpoint rule| / max = %.3g\n", worst);
}

// The total energy of an azimuth-independent model (eq. 5.17; since session 25 from the separable
// rule's own evaluations, not BrdfEnergy's panels) against the test's midpoint rule of its
// definition: rho-hat depends on (theta_i', theta_o') only, so the energy over both spheres is
// (2 pi)^2 x double-integral rho-hat^2 sin t_i sin t_o (the two azimuth integrals), with
// rho-hat = norm max(cos(t_i - t_o), 0)^s.
TEST(BrdfCoefficientsTest, KajiyaKayEnergyMatchesMidpointRule) {
  constexpr int kN = 2000;
  // The midpoint rule agrees with BrdfEnergy's panels to 2e-8 here. The separable rule is
  // Gauss-Legendre in cos theta, where sin theta's square-root behaviour at the poles limits it:
  // 2.4e-6 to 3.2e-6 measured, the same rule (and size) as the coefficients' own 1.3e-5 above;
  // the orders need the captured fraction to about 1e-3.
  constexpr double kEnergyTol = 1e-5;
  for (double s : {8.0, 32.0, 300.0}) {
    const KajiyaKayBrdf brdf(s);
    auto coeffs = ComputeBrdfCoefficients(brdf, 12, 8);
    ASSERT_TRUE(coeffs.ok()) << coeffs.status();
    ASSERT_EQ(coeffs->total_energy.size(), 1u);
    const double sum = KajiyaKayMidpoint(kN, [&](int, int, double c) {
      const double v = brdf.normalization() * std::pow(c, s);
      return v * v;
    });
    const double energy = 4 * kPi * kPi * sum;
    EXPECT_NEAR(coeffs->total_energy[0], energy, kEnergyTol * energy) << s;
    std::printf("Kajiya-Kay s=%g: energy %.10g, midpoint rule %.10g (relative %.2g)\n", s,
                coeffs->total_energy[0], energy, coeffs->total_energy[0] / energy - 1);
  }
}

TEST(BrdfOrdersTest, PhongOrdersEqualExactOrder) {
  for (double s : {8.0, 64.0, 512.0}) {
    const PhongBrdf brdf(s);
    auto orders = SelectBrdfOrders(brdf, 0.03);
    ASSERT_TRUE(orders.ok()) << orders.status();
    EXPECT_EQ(orders->P, 0);
    EXPECT_EQ(orders->F, PhongOrderExact(s, 0.03)) << s;
  }
}

TEST(BrdfOrdersTest, Errors) {
  const PhongBrdf phong(512);
  EXPECT_EQ(SelectBrdfOrders(phong, 0).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(SelectBrdfOrders(phong, 1).status().code(), absl::StatusCode::kInvalidArgument);
  BrdfOrderOptions small;
  small.initial_fmax = 4;
  small.max_fmax = 10;
  const auto limited = SelectBrdfOrders(phong, 0.03, small);
  EXPECT_EQ(limited.status().code(), absl::StatusCode::kOutOfRange);
  EXPECT_NE(limited.status().message().find("phong:s=512"), std::string::npos);
  EXPECT_EQ(ComputeBrdfCoefficients(phong, -1, 0).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeBrdfCoefficients(phong, 8, kMaxBrdfPmax + 1).status().code(),
            absl::StatusCode::kInvalidArgument);
  BrdfSampling bad;
  bad.theta_i = -3;
  EXPECT_EQ(ComputeBrdfCoefficients(phong, 8, 0, bad).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(BrdfOrdersTest, CapturedFractionCountsNegativeQTwiceAndTruncates) {
  BrdfCoefficients c;
  c.lmax = 2;
  c.pmax = 1;
  c.channels = 2;
  c.values.assign(3 * 2 * 2 * 2, 0.0);
  c.values[c.Index(0, 0, 0, 0)] = 1;  // energy 1
  c.values[c.Index(1, 1, 1, 0)] = 1;  // energy 2 (q = +-1)
  c.values[c.Index(2, 0, 0, 1)] = 2;  // channel 1: energy 4
  c.total_energy = {4, 8};
  EXPECT_DOUBLE_EQ(CapturedFraction(c, 2, 1, 0), 0.75);
  EXPECT_DOUBLE_EQ(CapturedFraction(c, 0, 0, 0), 0.25);
  EXPECT_DOUBLE_EQ(CapturedFraction(c, 1, 0, 0), 0.25);
  EXPECT_DOUBLE_EQ(CapturedFraction(c, 2, 1, 1), 0.5);
  EXPECT_DOUBLE_EQ(CapturedFraction(c, 2, 1), 0.5);      // worst channel
  EXPECT_DOUBLE_EQ(CapturedFraction(c, 9, 9, 0), 0.75);  // clamped to (lmax, pmax)
  const BrdfCoefficients t = TruncateBrdfCoefficients(c, 1, 1);
  EXPECT_EQ(t.lmax, 1);
  EXPECT_EQ(t.at(1, 1, -1, 0), 1.0);
  EXPECT_DOUBLE_EQ(CapturedFraction(t, 1, 1, 0), 0.75);
  EXPECT_DOUBLE_EQ(CapturedFraction(t, 1, 1, 1), 0.0);
}

}  // namespace
}  // namespace shrm
