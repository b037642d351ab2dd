// BRDF models (core/brdf/brdf.h, brdf_models.h): spec strings, world-frame transfer functions
// against independent closed forms, reciprocity, white-furnace energy, and the reflection /
// tangent reparameterization of the SHRM paper's sec. 5.3.1.
#include "core/brdf/brdf.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/brdf/brdf_models.h"
#include "core/brdf/brdf_projection.h"
#include "core/sh/quadrature.h"

namespace shrm {
namespace {

// Closed forms evaluated with different algebra (angles, tangents) than the library: agreement
// to rounding, a little loosened by acos near 0.
constexpr double kClosedFormTol = 1e-9;
// Reciprocity is exact algebra; rounding only.
constexpr double kReciprocityTol = 1e-12;
// White furnace of polynomial integrands (Lambert, Phong) by Gauss-Legendre: exact up to rounding.
constexpr double kFurnaceExactTol = 1e-12;
// White furnace of GGX on a 256 x 512 product rule: the horizon cut and the alpha = 0.1 peak
// limit the rule to ~1e-4; albedo must not exceed 1 by more than that.
constexpr double kFurnaceQuadratureTol = 2e-4;

std::unique_ptr<Brdf> Parse(const std::string& spec) {
  auto brdf = ParseBrdfSpec(spec);
  EXPECT_TRUE(brdf.ok()) << spec << ": " << brdf.status();
  return brdf.ok() ? *std::move(brdf) : nullptr;
}

Vec3 RandomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  while (true) {
    const Vec3 v{g(rng), g(rng), g(rng)};
    if (v.Norm() > 1e-3) return v.Normalized();
  }
}

Mat3 RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return Quaternion{g(rng), g(rng), g(rng), g(rng)}.ToMatrix();
}

double AngleOf(const Vec3& a, const Vec3& b) { return std::acos(std::clamp(a.Dot(b), -1.0, 1.0)); }

// ---------------------------------------------------------------- spec strings

TEST(BrdfSpecTest, CanonicalSpecsRoundTrip) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"lambert", "lambert:albedo=1"},
      {"lambert:albedo=0.5", "lambert:albedo=0.5"},
      {"phong", "phong:s=32"},
      {" phong:s=100.5 ", "phong:s=100.5"},
      {"microfacet:sigma=0.2", "microfacet:sigma=0.2"},
      {"ward", "ward:alpha=0.2,rho_s=0.1,rho_d=0"},
      {"ward:rho_d=0.3,alpha=0.15", "ward:alpha=0.15,rho_s=0.1,rho_d=0.3"},
      {"ward:alpha_x=0.2,alpha_y=0.5,rho_s=1", "ward:alpha_x=0.2,alpha_y=0.5,rho_s=1,rho_d=0"},
      {"ward:alpha_y=0.4", "ward:alpha_x=0.2,alpha_y=0.4,rho_s=0.1,rho_d=0"},  // alpha_x = alpha
      {"ward:alpha_x=0.3,alpha_y=0.3", "ward:alpha=0.3,rho_s=0.1,rho_d=0"},
      {"ggx", "ggx:alpha=0.3,f0=0.04"},
      {"ggx:f0=1,alpha=0.1", "ggx:alpha=0.1,f0=1"},
      {"kajiya-kay:s=32", "kajiya-kay:s=32"},
      {"lafortune", "lafortune:cx=-1,cy=-1,cz=1,n=20,rho=1"},
      {"lafortune:cx=-0.8,cz=0.9,n=12,rho=2;cx=-1,cy=-1,cz=1,n=40,rho=0.5",
       "lafortune:cx=-0.8,cy=-0.8,cz=0.9,n=12,rho=2;cx=-1,cy=-1,cz=1,n=40,rho=0.5"},
      {"lafortune:rho_d=0.2;cx=-1,cz=1,n=20", "lafortune:rho_d=0.2;cx=-1,cy=-1,cz=1,n=20,rho=1"},
  };
  for (const auto& [in, canonical] : cases) {
    const std::unique_ptr<Brdf> brdf = Parse(in);
    ASSERT_NE(brdf, nullptr);
    EXPECT_EQ(brdf->spec(), canonical) << in;
    const std::unique_ptr<Brdf> again = Parse(brdf->spec());
    ASSERT_NE(again, nullptr);
    EXPECT_EQ(again->spec(), canonical);
  }
  EXPECT_EQ(FormatSpecNumber(0.1), "0.1");
  EXPECT_EQ(FormatSpecNumber(1.0 / 3.0), "0.3333333333333333");
  EXPECT_EQ(std::strtod(FormatSpecNumber(1.0 / 3.0).c_str(), nullptr), 1.0 / 3.0);
}

TEST(BrdfSpecTest, BadSpecsNameTheProblem) {
  // {spec, substrings every message must contain}
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"foo:s=1", {"unknown brdf model 'foo'", "phong", "microfacet"}},
      {"", {"unknown brdf model"}},
      {"phong:s=0", {"'s'", "(0, 100000]"}},
      {"phong:s=-3", {"'s'", "out of range"}},
      {"phong:s=abc", {"'s'", "not a finite number"}},
      {"phong:s=nan", {"'s'", "not a finite number"}},
      {"phong:s=1e999", {"'s'", "not a finite number"}},
      {"phong:s=", {"'s'", "not a finite number"}},
      {"phong:s", {"'s'", "needs a value"}},
      {"phong:q=3", {"unknown parameter 'q'", "valid parameters: s"}},
      {"phong:s=2,s=3", {"'s'", "twice"}},
      {"microfacet:sigma=0", {"'sigma'", "(0, 10]"}},
      {"microfacet:sigma=-0.1", {"'sigma'"}},
      {"ggx:alpha=0", {"'alpha'", "(0, 1]"}},
      {"ggx:alpha=1.5", {"'alpha'", "(0, 1]"}},
      {"ggx:f0=1.2", {"'f0'", "[0, 1]"}},
      {"ggx:f0=-0.1", {"'f0'", "[0, 1]"}},
      {"ward:alpha=0", {"'alpha'", "(0, 1]"}},
      {"ward:rho_s=2", {"'rho_s'", "[0, 1]"}},
      {"ward:alpha_x=0", {"'alpha_x'", "(0, 1]"}},
      {"ward:alpha_y=1.5", {"'alpha_y'", "(0, 1]"}},
      {"lambert:albedo=1.5", {"'albedo'", "[0, 1]"}},
      {"kajiya-kay:s=0", {"'s'", "(0, 100000]"}},
      {"lafortune:cx=-1,cy=-0.5,cz=1,n=10", {"'cx'", "'cy'", "isotropic"}},
      {"lafortune:cx=-1,cz=1,n=0", {"'n'", "(0, 100000]"}},
      {"lafortune:cx=-1,cz=1,n=10,k=2", {"unknown parameter 'k'"}},
      {"lafortune:rho_d=0.2,n=3", {"unknown parameter 'n'"}},
      {"table:", {"missing file path"}},
      {"table:/nonexistent/brdf.bin", {"cannot open", "/nonexistent/brdf.bin"}},
      {"merl:/nonexistent/x.binary", {"cannot open", "/nonexistent/x.binary"}},
      {"merl", {"missing file path"}},
  };
  for (const auto& [spec, needles] : cases) {
    const auto brdf = ParseBrdfSpec(spec);
    ASSERT_FALSE(brdf.ok()) << spec;
    EXPECT_EQ(brdf.status().code(), absl::StatusCode::kInvalidArgument) << spec;
    for (const std::string& needle : needles) {
      EXPECT_NE(brdf.status().message().find(needle), std::string::npos)
          << spec << " -> " << brdf.status().message() << " (missing '" << needle << "')";
    }
  }
}

TEST(BrdfSpecTest, ModelListMatchesParser) {
  const std::vector<BrdfModelInfo>& models = ListBrdfModels();
  std::vector<std::string> names;
  for (const BrdfModelInfo& m : models) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"lambert", "phong", "microfacet", "lafortune", "ward",
                                             "ggx", "kajiya-kay", "table", "merl"}));
  for (const BrdfModelInfo& m : models) {
    EXPECT_FALSE(m.description.empty()) << m.name;
    EXPECT_FALSE(m.params.empty()) << m.name;
    if (m.name == "table" || m.name == "merl") continue;
    // The documented example parses, and every default is in its range (parsing defaults).
    std::string example = m.syntax;
    if (m.name == "lafortune") example = "lafortune:rho_d=0.1;cx=-1,cy=-1,cz=1,n=20,rho=1";
    EXPECT_NE(Parse(example), nullptr) << example;
    EXPECT_NE(Parse(m.name), nullptr) << m.name;
  }
}

// ---------------------------------------------------------------- closed forms

struct Config {
  Vec3 n, v, w;
};

// Random (N, V, w) with N.V > 0.02; w anywhere (about half below the horizon).
std::vector<Config> RandomConfigs(int count, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Config> out;
  while (static_cast<int>(out.size()) < count) {
    const Vec3 n = RandomDirection(rng), v = RandomDirection(rng), w = RandomDirection(rng);
    if (n.Dot(v) > 0.02) out.push_back({n, v, w});
  }
  return out;
}

// Independent twins of the model formulas, in angles.
double LambertTwin(double albedo, const Config& c) {
  const double ti = AngleOf(c.n, c.w);
  return ti < kPi / 2 ? albedo / kPi * std::cos(ti) : 0.0;
}

double PhongTwin(double s, const Config& c) {
  // Householder reflection of V about N, row by row.
  const double nn[3] = {c.n.x, c.n.y, c.n.z}, vv[3] = {c.v.x, c.v.y, c.v.z};
  double r[3];
  for (int i = 0; i < 3; ++i) {
    r[i] = 0;
    for (int j = 0; j < 3; ++j) r[i] += (2 * nn[i] * nn[j] - (i == j ? 1.0 : 0.0)) * vv[j];
  }
  const double angle = AngleOf(Vec3{r[0], r[1], r[2]}, c.w);
  return angle < kPi / 2 ? (s + 1) / (2 * kPi) * std::pow(std::cos(angle), s) : 0.0;
}

double MicrofacetTwin(double sigma, const Config& c) {
  if (AngleOf(c.n, c.w) >= kPi / 2 || AngleOf(c.n, c.v) >= kPi / 2) return 0.0;
  const Vec3 h = (c.v + c.w).Normalized();
  const double th = AngleOf(c.n, h);
  return std::exp(-(th / sigma) * (th / sigma)) / (4 * kPi * sigma * sigma);
}

double GgxTwin(double alpha, double f0, const Config& c) {
  const double ti = AngleOf(c.n, c.w), to = AngleOf(c.n, c.v);
  if (ti >= kPi / 2 || to >= kPi / 2) return 0.0;
  const Vec3 h = (c.v + c.w).Normalized();
  const double th = AngleOf(c.n, h), td = AngleOf(c.w, h);
  const double t2 = std::tan(th) * std::tan(th);
  const double d = 1.0 / (kPi * alpha * alpha * std::pow(std::cos(th), 4) *
                          std::pow(1.0 + t2 / (alpha * alpha), 2));
  const auto lambda = [alpha](double t) {
    return (-1.0 + std::sqrt(1.0 + alpha * alpha * std::tan(t) * std::tan(t))) / 2.0;
  };
  const double g = 1.0 / (1.0 + lambda(ti) + lambda(to));
  const double f = f0 + (1 - f0) * std::pow(1 - std::cos(td), 5);
  return f * d * g / (4 * std::cos(ti) * std::cos(to)) * std::cos(ti);
}

double WardTwin(double alpha, double rho_s, double rho_d, const Config& c) {
  const double ti = AngleOf(c.n, c.w), to = AngleOf(c.n, c.v);
  if (ti >= kPi / 2 || to >= kPi / 2) return 0.0;
  const double th = AngleOf(c.n, (c.v + c.w).Normalized());
  const double f =
      rho_d / kPi + rho_s * std::exp(-std::pow(std::tan(th) / alpha, 2)) /
                        (4 * kPi * alpha * alpha * std::sqrt(std::cos(ti) * std::cos(to)));
  return f * std::cos(ti);
}

// Anisotropic Ward in angles, in the documented frame: t = +x projected onto the plane normal
// to n, b = n x t, phi_h the half vector's azimuth from t towards b.
double AnisoWardTwin(double ax, double ay, double rho_s, double rho_d, const Config& c) {
  const double ti = AngleOf(c.n, c.w), to = AngleOf(c.n, c.v);
  if (ti >= kPi / 2 || to >= kPi / 2) return 0.0;
  const Vec3 x{1, 0, 0};
  const Vec3 t = (x - c.n * c.n.Dot(x)).Normalized();
  const Vec3 b = c.n.Cross(t);
  const Vec3 h = (c.v + c.w).Normalized();
  const double th = AngleOf(c.n, h), ph = std::atan2(h.Dot(b), h.Dot(t));
  const double e =
      std::pow(std::tan(th), 2) * (std::pow(std::cos(ph) / ax, 2) + std::pow(std::sin(ph) / ay, 2));
  const double f = rho_d / kPi + rho_s * std::exp(-e) /
                                     (4 * kPi * ax * ay * std::sqrt(std::cos(ti) * std::cos(to)));
  return f * std::cos(ti);
}

double LafortuneTwin(const std::vector<LafortuneLobe>& lobes, double rho_d, const Config& c) {
  if (c.n.Dot(c.w) <= 0 || c.n.Dot(c.v) <= 0) return 0.0;
  // Explicit tangent frame by Gram-Schmidt.
  const Vec3 a = std::abs(c.n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t = (a - c.n * c.n.Dot(a)).Normalized();
  const Vec3 b = c.n.Cross(t);
  const Vec3 u{c.w.Dot(t), c.w.Dot(b), c.w.Dot(c.n)}, v{c.v.Dot(t), c.v.Dot(b), c.v.Dot(c.n)};
  double f = rho_d / kPi;
  for (const LafortuneLobe& lobe : lobes) {
    const double d = lobe.cxy * u.x * v.x + lobe.cxy * u.y * v.y + lobe.cz * u.z * v.z;
    if (d > 0) f += lobe.rho * std::pow(d, lobe.n);
  }
  return f * u.z;
}

double KajiyaKayTwin(double s, const Vec3& t, const Vec3& v, const Vec3& w) {
  // Normalization by quadrature: 1 / (2 pi integral_0^pi sin^{s+1}).
  static const RingQuadrature gl = GaussLegendreRule(200);
  double integral = 0;
  for (size_t j = 0; j < gl.theta.size(); ++j) {
    integral += gl.weight[j] * std::pow(gl.sin_theta[j], s);  // weight carries one sin
  }
  const double c = std::cos(AngleOf(t, w) - AngleOf(t, v));
  return c > 0 ? std::pow(c, s) / (2 * kPi * integral) : 0.0;
}

TEST(BrdfModelTest, TransferMatchesClosedForms) {
  const std::vector<Config> configs = RandomConfigs(400, 7);
  const LambertBrdf lambert(0.7);
  const PhongBrdf phong(23.5);
  const MicrofacetBrdf microfacet(0.25);
  const GgxBrdf ggx(0.35, 0.2);
  const WardBrdf ward(0.18, 0.4, 0.3);
  const std::vector<LafortuneLobe> lobes = {{-0.9, 0.8, 15, 1.5}, {-1.0, 1.0, 40, 0.7}};
  const LafortuneBrdf lafortune(lobes, 0.2);
  const KajiyaKayBrdf kk(17);
  int above = 0;
  for (const Config& c : configs) {
    if (c.n.Dot(c.w) > 0) ++above;
    const auto check = [&](const Brdf& brdf, double expected) {
      const double got = brdf.Transfer(c.n, c.v, c.w, 0);
      EXPECT_NEAR(got, expected, kClosedFormTol * std::max(1.0, std::abs(expected))) << brdf.spec();
    };
    check(lambert, LambertTwin(0.7, c));
    check(phong, PhongTwin(23.5, c));
    check(microfacet, MicrofacetTwin(0.25, c));
    check(ggx, GgxTwin(0.35, 0.2, c));
    check(ward, WardTwin(0.18, 0.4, 0.3, c));
    check(lafortune, LafortuneTwin(lobes, 0.2, c));
    check(kk, KajiyaKayTwin(17, c.n, c.v, c.w));
  }
  EXPECT_GT(above, 100);  // both sides of the horizon were exercised
}

TEST(BrdfModelTest, AnisotropicWardMatchesClosedFormAndIsRejectedBySHRM) {
  const std::vector<Config> configs = RandomConfigs(400, 13);
  const std::unique_ptr<Brdf> aniso = Parse("ward:alpha_x=0.15,alpha_y=0.45,rho_s=0.8,rho_d=0.1");
  const std::unique_ptr<Brdf> iso = Parse("ward:alpha_x=0.25,alpha_y=0.25,rho_s=0.8,rho_d=0.1");
  for (const Config& c : configs) {
    const double want = AnisoWardTwin(0.15, 0.45, 0.8, 0.1, c);
    EXPECT_NEAR(aniso->Transfer(c.n, c.v, c.w, 0), want, kClosedFormTol * std::max(1.0, want));
    // alpha_x = alpha_y is the isotropic model.
    const double want_iso = WardTwin(0.25, 0.8, 0.1, c);
    EXPECT_NEAR(iso->Transfer(c.n, c.v, c.w, 0), want_iso,
                kClosedFormTol * std::max(1.0, want_iso));
    // Reciprocity: f_r is symmetric in (v, w).
    if (c.n.Dot(c.w) > 0.02) {
      const double a = aniso->Transfer(c.n, c.v, c.w, 0) / c.n.Dot(c.w);
      const double b = aniso->Transfer(c.n, c.w, c.v, 0) / c.n.Dot(c.v);
      EXPECT_NEAR(a, b, kReciprocityTol * std::max(1.0, std::abs(a)));
    }
  }
  // Local frame n = +z: swapping alpha_x and alpha_y equals turning (v, w) by 90 deg about n.
  const std::unique_ptr<Brdf> swapped = Parse("ward:alpha_x=0.45,alpha_y=0.15,rho_s=0.8,rho_d=0.1");
  const Mat3 quarter = RotationZ(kPi / 2);
  for (const Config& c : RandomConfigs(100, 17)) {
    const Vec3 n{0, 0, 1};
    const Vec3 v{c.v.x, c.v.y, std::abs(c.v.z) + 0.05}, w = c.w;
    const Vec3 vn = v.Normalized();
    EXPECT_NEAR(aniso->Transfer(n, quarter * vn, quarter * w, 0), swapped->Transfer(n, vn, w, 0),
                kClosedFormTol * std::max(1.0, swapped->Transfer(n, vn, w, 0)));
  }
  // The SHRM reparameterization assumes isotropy: anisotropic Ward is refused there.
  const auto coeffs = ComputeBrdfCoefficients(*aniso, 8, 2);
  ASSERT_FALSE(coeffs.ok());
  EXPECT_EQ(coeffs.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(coeffs.status().message().find("anisotropic"), std::string::npos) << coeffs.status();
  EXPECT_TRUE(ComputeBrdfCoefficients(*iso, 8, 2).ok());
}

TEST(BrdfModelTest, Reciprocity) {
  const std::vector<Config> configs = RandomConfigs(300, 11);
  const std::vector<std::string> specs = {
      "lambert:albedo=0.8", "ggx:alpha=0.2,f0=0.3", "ward:alpha=0.3,rho_s=0.5,rho_d=0.2",
      "lafortune:rho_d=0.1;cx=-0.9,cz=0.8,n=15,rho=1.5", "microfacet:sigma=0.3"};
  for (const std::string& spec : specs) {
    const std::unique_ptr<Brdf> brdf = Parse(spec);
    const bool transfer_symmetric = spec.rfind("microfacet", 0) == 0;  // rho-hat itself
    for (const Config& c : configs) {
      const double nw = c.n.Dot(c.w), nv = c.n.Dot(c.v);
      if (nw <= 0.02) continue;
      double a = brdf->Transfer(c.n, c.v, c.w, 0), b = brdf->Transfer(c.n, c.w, c.v, 0);
      if (!transfer_symmetric) {
        a /= nw;  // f_r(V, w)
        b /= nv;  // f_r(w, V)
      }
      EXPECT_NEAR(a, b, kReciprocityTol * std::max(1.0, std::abs(a))) << spec;
    }
  }
}

// integral over the hemisphere around `pole` of f(w) dw: Gauss-Legendre in cos theta on [0, 1]
// times the uniform rule in phi.
template <typename F>
double HemisphereIntegral(const Vec3& pole, int n_theta, int n_phi, F f) {
  const Vec3 a = std::abs(pole.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  const Vec3 t = (a - pole * pole.Dot(a)).Normalized();
  const Vec3 b = pole.Cross(t);
  const RingQuadrature gl = GaussLegendreRule(n_theta);
  double sum = 0;
  for (int j = 0; j < n_theta; ++j) {
    const double x = 0.5 * (1 + gl.cos_theta[j]), s = std::sqrt(1 - x * x);
    for (int k = 0; k < n_phi; ++k) {
      const double phi = 2 * kPi * (k + 0.5) / n_phi;
      const Vec3 w = pole * x + t * (s * std::cos(phi)) + b * (s * std::sin(phi));
      sum += 0.5 * gl.weight[j] * (2 * kPi / n_phi) * f(w);
    }
  }
  return sum;
}

TEST(BrdfModelTest, WhiteFurnace) {
  std::mt19937_64 rng(3);
  const LambertBrdf lambert(0.6);
  for (int trial = 0; trial < 5; ++trial) {
    const Vec3 n = RandomDirection(rng);
    Vec3 v = RandomDirection(rng);
    if (n.Dot(v) < 0) v = v * -1.0;
    // Lambert: albedo exactly (cos is a polynomial of degree 1).
    EXPECT_NEAR(
        HemisphereIntegral(n, 8, 8, [&](const Vec3& w) { return lambert.Transfer(n, v, w, 0); }),
        0.6, kFurnaceExactTol);
    // Normalized Phong: 1 exactly, integrating over the hemisphere around R (no horizon cut).
    for (double s : {1.0, 8.0, 64.0, 300.0}) {
      const PhongBrdf phong(s);
      const Vec3 r = n * (2 * n.Dot(v)) - v;
      EXPECT_NEAR(
          HemisphereIntegral(r, 200, 4, [&](const Vec3& w) { return phong.Transfer(n, v, w, 0); }),
          1.0, kFurnaceExactTol)
          << s;
    }
  }
  // GGX with f0 = 1 (no Fresnel loss) and the height-correlated G: albedo <= 1 at every view, and
  // close to 1 for smooth surfaces at normal incidence.
  const Vec3 n{0, 1, 0};
  for (double alpha : {0.1, 0.3, 0.7, 1.0}) {
    const GgxBrdf ggx(alpha, 1.0);
    for (double view_deg : {0.0, 30.0, 60.0, 80.0, 88.0}) {
      const double a = view_deg * kPi / 180;
      const Vec3 v{std::sin(a), std::cos(a), 0};
      const double albedo =
          HemisphereIntegral(n, 256, 512, [&](const Vec3& w) { return ggx.Transfer(n, v, w, 0); });
      EXPECT_LE(albedo, 1.0 + kFurnaceQuadratureTol) << alpha << " " << view_deg;
      // Single scattering loses about alpha^2 / (1 + alpha^2) at normal incidence (the part of
      // D reflected below the horizon); at alpha = 0.1 the albedo stays above 0.98.
      if (alpha <= 0.1 && view_deg <= 30) {
        EXPECT_GT(albedo, 0.98) << alpha << " " << view_deg;
      }
    }
  }
  // Kajiya-Kay: normalized so that a view perpendicular to the tangent integrates to 1.
  for (double s : {4.0, 32.0, 200.0}) {
    const KajiyaKayBrdf kk(s);
    const Vec3 t{0, 0, 1}, v{1, 0, 0};
    // integral over the whole sphere (no horizon): two hemispheres about +-t.
    const auto f = [&](const Vec3& w) { return kk.Transfer(t, v, w, 0); };
    const double total = HemisphereIntegral(t, 300, 8, f) + HemisphereIntegral(t * -1.0, 300, 8, f);
    EXPECT_NEAR(total, 1.0, 1e-10) << s;
  }
  // Simplified microfacet (eq. 5.34) is normalized for small sigma at normal incidence:
  // integral ~ 1 + O(sigma^2).
  const MicrofacetBrdf micro(0.05);
  const double e =
      HemisphereIntegral(n, 400, 64, [&](const Vec3& w) { return micro.Transfer(n, n, w, 0); });
  EXPECT_NEAR(e, 1.0, 0.01);
}

// ---------------------------------------------------------------- reparameterization

// Builds (N, V, w) for reparameterized angles in a random frame with its own geometry: pole
// P = Q e_z, V = Q dir(theta_o, phi_o), w = Q dir(theta_i, phi_o + phi), N = (P + V)/|P + V|
// (reflection) or the tangent T = P.
Config ReconstructWorld(bool tangent, const Mat3& q, double theta_i, double theta_o, double phi,
                        double phi_o) {
  const auto dir = [](double t, double p) {
    return Vec3{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
  };
  const Vec3 pole = q * Vec3{0, 0, 1};
  const Vec3 v = q * dir(theta_o, phi_o);
  const Vec3 w = q * dir(theta_i, phi_o + phi);
  const Vec3 n = tangent ? pole : (pole + v).Normalized();
  return {n, v, w};
}

TEST(BrdfReparamTest, ReparamTransferEqualsTransferOfReconstructedGeometry) {
  const std::vector<std::string> specs = {"lambert",
                                          "phong:s=20",
                                          "microfacet:sigma=0.2",
                                          "ggx:alpha=0.3,f0=0.5",
                                          "ward:alpha=0.2,rho_s=0.5,rho_d=0.1",
                                          "lafortune:rho_d=0.1;cx=-0.9,cz=0.8,n=15,rho=1.5",
                                          "kajiya-kay:s=12"};
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  for (const std::string& spec : specs) {
    const std::unique_ptr<Brdf> brdf = Parse(spec);
    const bool tangent = brdf->reparam() == ReparamKind::kTangent;
    double max_value = 0;
    for (int trial = 0; trial < 300; ++trial) {
      const double ti = kPi * u(rng), to = 0.98 * kPi * u(rng), phi = 2 * kPi * u(rng);
      const Config c =
          ReconstructWorld(tangent, RandomRotation(rng), ti, to, phi, 2 * kPi * u(rng));
      const double want = brdf->Transfer(c.n, c.v, c.w, 0);
      const double got = brdf->ReparamTransfer(ti, to, phi, 0);
      max_value = std::max(max_value, want);
      EXPECT_NEAR(got, want, 1e-10 * std::max(1.0, want)) << spec << " " << ti << " " << to;
      // The inverse map recovers the angles (phi folded to [0, pi]).
      double ti2, to2, phi2;
      ReparamAngles(brdf->reparam(), c.n, c.v, c.w, &ti2, &to2, &phi2);
      EXPECT_NEAR(ti2, ti, 1e-9);
      EXPECT_NEAR(to2, to, 1e-9);
      const double folded = std::acos(std::cos(phi));
      if (std::sin(ti) > 1e-6 && std::sin(to) > 1e-6) {
        EXPECT_NEAR(phi2, folded, 1e-7);
      }
    }
    EXPECT_GT(max_value, 0) << spec;
  }
}

// The arc evaluation (ReparamTransferArc: the models' vector loops, libmvec's exp / asin / pow
// within 4 ulp on AVX-512 builds) against Transfer at the same angles. The exponent of the
// microfacet and Ward lobes reaches ~(pi / sigma)^2 ~ 1e3, which scales the vector functions'
// few-ulp error (~1e-15 relative) to ~1e-12 of the value; far below any quadrature error.
constexpr double kArcRelTol = 1e-11;

TEST(BrdfReparamTest, ArcEvaluationEqualsTransfer) {
  const std::vector<std::string> specs = {
      "lambert",
      "microfacet:sigma=0.1",
      "microfacet:sigma=0.3",
      "ggx:alpha=0.3,f0=1",
      "ggx:alpha=0.1,f0=0.04",
      "ward:alpha=0.2,rho_s=0.5,rho_d=0.1",
      "ward:alpha_x=0.2,alpha_y=0.3,rho_s=0.5,rho_d=0.1",
      "lafortune:rho_d=0.1;cx=-0.9,cz=0.8,n=15,rho=1.5;cx=-0.5,cz=0.5,n=3.5,rho=0.4"};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  for (const std::string& spec : specs) {
    const std::unique_ptr<Brdf> brdf = Parse(spec);
    double max_value = 0;
    int lit = 0;
    for (int trial = 0; trial < 200; ++trial) {
      const double ti = kPi * u(rng), to = 0.98 * kPi * u(rng);
      // 71 azimuths: 8 full vectors and a partial one, over the whole half circle (the horizon
      // cut lies inside it for many (ti, to)).
      std::vector<double> phi(71), cos_phi(71), sin_phi(71), got(71);
      for (size_t k = 0; k < phi.size(); ++k) {
        phi[k] = kPi * u(rng);
        cos_phi[k] = std::cos(phi[k]);
        sin_phi[k] = std::sin(phi[k]);
      }
      brdf->ReparamTransferArc(ti, to, {phi, cos_phi, sin_phi}, got.data());
      for (size_t k = 0; k < phi.size(); ++k) {
        const ReparamGeometry g = MakeReparamGeometry(brdf->reparam(), ti, to, phi[k]);
        const double want = brdf->Transfer(g.n, g.v, g.w, 0);
        max_value = std::max(max_value, want);
        lit += want > 0;
        ASSERT_TRUE(std::isfinite(got[k])) << spec << " " << ti << " " << to << " " << phi[k];
        EXPECT_NEAR(got[k], want, kArcRelTol * std::abs(want) + 1e-300)
            << spec << " " << ti << " " << to << " " << phi[k];
      }
    }
    EXPECT_GT(max_value, 0) << spec;
    EXPECT_GT(lit, 1000) << spec;  // the lit part of the arcs was exercised
  }
}

// The batched world-frame evaluation (TransferMany: the reference sums' leaves) against Transfer
// direction by direction, for every model: the default loop, microfacet's vector asin and exp,
// GGX's selects. Random (N, V, w) with N.V and N.w of both signs (the horizon tests) and 37
// directions per call (two full chunks of 16 and a partial one).
TEST(BrdfTransferTest, TransferManyEqualsTransfer) {
  const std::vector<std::string> specs = {"lambert",
                                          "phong:s=32",
                                          "microfacet:sigma=0.1",
                                          "microfacet:sigma=0.3",
                                          "ggx:alpha=0.3,f0=1",
                                          "ggx:alpha=0.1,f0=0.04",
                                          "ward:alpha=0.2,rho_s=0.5,rho_d=0.1",
                                          "lafortune:rho_d=0.1;cx=-0.9,cz=0.8,n=15,rho=1.5",
                                          "kajiya-kay:s=32"};
  std::mt19937_64 rng(23);
  std::normal_distribution<double> g(0, 1);
  const auto unit = [&] { return Vec3{g(rng), g(rng), g(rng)}.Normalized(); };
  for (const std::string& spec : specs) {
    const std::unique_ptr<Brdf> brdf = Parse(spec);
    int lit = 0;
    for (int trial = 0; trial < 100; ++trial) {
      const Vec3 n = unit(), v = unit();
      std::vector<Vec3> w(37);
      for (Vec3& d : w) d = unit();
      std::vector<double> got(w.size());
      brdf->TransferMany(n, v, w, 0, got.data());
      for (size_t k = 0; k < w.size(); ++k) {
        const double want = brdf->Transfer(n, v, w[k], 0);
        lit += want > 0;
        ASSERT_TRUE(std::isfinite(got[k])) << spec << " " << trial << " " << k;
        EXPECT_NEAR(got[k], want, kArcRelTol * std::abs(want) + 1e-300) << spec << " " << trial;
      }
    }
    EXPECT_GT(lit, 300) << spec;  // the lit configurations were exercised
  }
}

TEST(BrdfReparamTest, ReflectionPoleIsR) {
  // N = normalize(R + V) reflects V into the pole: 2 (N.V) N - V = R.
  for (double to : {0.1, 1.0, 2.0, 3.0}) {
    const ReparamGeometry g = MakeReparamGeometry(ReparamKind::kReflection, 0.3, to, 0.7);
    const Vec3 r = g.n * (2 * g.n.Dot(g.v)) - g.v;
    EXPECT_NEAR(r.x, 0, 1e-15);
    EXPECT_NEAR(r.y, 0, 1e-15);
    EXPECT_NEAR(r.z, 1, 1e-15);
    EXPECT_NEAR(g.n.Dot(g.v), std::cos(to / 2), 1e-15);  // view angle theta_o'/2
  }
  EXPECT_TRUE(PhongBrdf(10).radially_symmetric());
  EXPECT_FALSE(MicrofacetBrdf(0.1).radially_symmetric());
  EXPECT_TRUE(KajiyaKayBrdf(10).azimuth_independent());
}

}  // namespace
}  // namespace shrm
