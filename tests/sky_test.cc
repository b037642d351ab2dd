// The procedural sky (core/envmap/sky.h) against independent references: the sun's position
// against closed forms of spherical astronomy (equinox noon elevation 90 deg - |latitude|, sunrise
// due east, the solstice sun over the tropic, polar night and midnight sun, the meridian and
// equation-of-time terms computed here), the Preetham model against the paper's tables and
// formulas retyped here as data (Appendix A.2 coefficients, zenith luminance and chromaticity
// matrices, the Perez function), xyY -> Rec.709 against a matrix derived here from the primaries
// and D65, the rendered map against the per-direction model and the map's own quadrature (ground,
// sun-disc integral), night, and bad input.
#include "core/envmap/sky.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/envmap/envmap.h"
#include "core/sh/quadrature.h"
#include "gtest/gtest.h"

namespace shrm::sky {
namespace {

constexpr double kDeg = kPi / 180;

// Closed forms in double: the same few trig calls on both sides, a few ulps of pi.
constexpr double kAngleTol = 1e-12;
// An angle read back through acos near 0 or pi (the sun at the zenith) keeps only
// sqrt(machine epsilon) ~ 1.5e-8 rad.
constexpr double kAcosNearZeroTol = 1e-7;
// The sun on the horizon: elevation asin of a sum of products that is 0 in exact arithmetic.
constexpr double kHorizonTol = 1e-12;
// Retyped formulas against the implementation: the same arithmetic in another order (relative).
constexpr double kFormulaRelTol = 1e-12;
// Pixels (float) against the per-direction model (double): float rounding (6e-8) plus the
// direction's dot product rounded differently before acos (gamma near 0 amplifies it).
constexpr double kPixelRelTol = 1e-6;
// ... and where a component is clamped to 0 (outside the gamut) on one side only by rounding.
constexpr double kPixelAbsTol = 1e-9;
// Integrals of a float image in double against the renderer's double sums: float rounding of
// each pixel, relative.
constexpr double kIntegralRelTol = 1e-5;
// The IEC 61966-2-1 matrix is published to 7 digits from a D65 white of (0.31271, 0.32902)
// (XYZ 0.95047, 1, 1.08883); from the 4-digit xy (0.3127, 0.3290) used here it differs by ~1e-4.
constexpr double kMatrixTol = 3e-4;

// ---- the paper's equation of time and declination, retyped (Appendix A.6) -------------------

double TestEquationOfTime(int j) {
  return 0.170 * std::sin(4 * kPi * (j - 80) / 373.0) - 0.129 * std::sin(2 * kPi * (j - 8) / 355.0);
}
double TestDeclination(int j) { return 0.4093 * std::sin(2 * kPi * (j - 81) / 368.0); }

// Standard time at which a place on its own meridian has solar time `solar_h`.
double StandardTimeFor(double solar_h, int j) { return solar_h - TestEquationOfTime(j); }

SunPosition MustSun(const SunInput& in) {
  absl::StatusOr<SunPosition> s = ComputeSunPosition(in);
  EXPECT_TRUE(s.ok()) << s.status();
  return s.ok() ? *s : SunPosition{};
}

double ElevationDeg(const SunPosition& s) { return 90 - s.zenith_rad / kDeg; }

// Angle difference wrapped to (-pi, pi].
double AngleDiff(double a, double b) {
  double d = std::fmod(a - b, 2 * kPi);
  if (d > kPi) d -= 2 * kPi;
  if (d <= -kPi) d += 2 * kPi;
  return d;
}

TEST(SunPosition, EquinoxNoonElevationIsNinetyMinusLatitude) {
  constexpr int kEquinox = 81;  // the paper's declination is exactly 0 (sin 0)
  ASSERT_EQ(SolarDeclination(kEquinox), 0.0);
  for (double lat : {-80.0, -51.5, -23.0, -5.0, 5.0, 23.0, 40.0, 51.5, 66.5, 80.0}) {
    SunInput in;
    in.day_of_year = kEquinox;
    in.standard_time_h = StandardTimeFor(12, kEquinox);
    in.latitude_deg = lat;
    const SunPosition s = MustSun(in);
    EXPECT_NEAR(s.solar_time_h, 12, kAngleTol) << lat;
    EXPECT_NEAR(ElevationDeg(s), 90 - std::abs(lat), 1e-10) << lat;
    // Due south in the north, due north in the south.
    const double want_az = lat > 0 ? kPi : 0;
    EXPECT_NEAR(AngleDiff(s.azimuth_rad, want_az), 0, kAngleTol) << lat;
  }
}

TEST(SunPosition, EquinoxSunriseDueEastSunsetDueWestAtEveryLatitude) {
  constexpr int kEquinox = 81;
  for (double lat : {-89.0, -60.0, -30.0, 0.0, 10.0, 45.0, 70.0, 89.0}) {
    SunInput in;
    in.day_of_year = kEquinox;
    in.latitude_deg = lat;
    in.standard_time_h = StandardTimeFor(6, kEquinox);
    SunPosition s = MustSun(in);
    EXPECT_NEAR(s.zenith_rad, kPi / 2, kHorizonTol) << lat;
    EXPECT_NEAR(s.azimuth_rad, kPi / 2, kAngleTol) << lat;
    const Vec3 d = SunDirection(s);  // east = +X
    EXPECT_NEAR(d.x, 1, kAngleTol);
    in.standard_time_h = StandardTimeFor(18, kEquinox);
    s = MustSun(in);
    EXPECT_NEAR(s.zenith_rad, kPi / 2, kHorizonTol) << lat;
    EXPECT_NEAR(s.azimuth_rad, 3 * kPi / 2, kAngleTol) << lat;
  }
}

TEST(SunPosition, NoonZenithIsLatitudeMinusDeclination) {
  // Any day: at solar noon zenith = |latitude - delta|, south of the observer when latitude >
  // delta (north of the sun's parallel), north otherwise.
  for (int j : {1, 45, 81, 120, 173, 200, 266, 355, 366}) {
    const double delta = TestDeclination(j);
    for (double lat : {-70.0, -35.0, -10.0, 10.0, 35.0, 70.0}) {
      SunInput in;
      in.day_of_year = j;
      in.latitude_deg = lat;
      in.standard_time_h = StandardTimeFor(12, j);
      const SunPosition s = MustSun(in);
      EXPECT_NEAR(s.declination_rad, delta, kAngleTol);
      EXPECT_NEAR(s.zenith_rad, std::abs(lat * kDeg - delta), 1e-10) << j << " " << lat;
      EXPECT_NEAR(AngleDiff(s.azimuth_rad, lat * kDeg > delta ? kPi : 0), 0, kAngleTol);
    }
  }
}

TEST(SunPosition, JuneSolsticeSunIsOverheadAtTheTropic) {
  constexpr int kSolstice = 173;  // 2 pi (173 - 81) / 368 = pi / 2
  const double delta = TestDeclination(kSolstice);
  EXPECT_NEAR(delta, 0.4093, 1e-15);
  SunInput in;
  in.day_of_year = kSolstice;
  in.latitude_deg = delta / kDeg;  // 23.45 N
  in.standard_time_h = StandardTimeFor(12, kSolstice);
  EXPECT_NEAR(MustSun(in).zenith_rad, 0, kAcosNearZeroTol);
  // ... and 90 - 50 + 23.45 deg high at 50 N.
  in.latitude_deg = 50;
  EXPECT_NEAR(ElevationDeg(MustSun(in)), 90 - 50 + delta / kDeg, 1e-10);
}

TEST(SunPosition, MeridianAndEquationOfTimeTerms) {
  for (int j : {10, 81, 150, 230, 300}) {
    SunInput in;
    in.day_of_year = j;
    in.standard_time_h = 9.25;
    in.latitude_deg = 30;
    in.longitude_deg = 0;
    in.standard_meridian_deg = 0;
    const SunPosition on_meridian = MustSun(in);
    EXPECT_NEAR(on_meridian.solar_time_h, 9.25 + TestEquationOfTime(j), kAngleTol);
    // 15 degrees east of its meridian: one hour ahead (and the meridian may be anywhere).
    in.longitude_deg = 15;
    EXPECT_NEAR(MustSun(in).solar_time_h, on_meridian.solar_time_h + 1, 1e-12);
    in.longitude_deg = -105;
    in.standard_meridian_deg = -120;
    EXPECT_NEAR(MustSun(in).solar_time_h, on_meridian.solar_time_h + 1, 1e-12);
    // 7.5 degrees west: half an hour behind.
    in.longitude_deg = 127.5;
    in.standard_meridian_deg = 135;
    EXPECT_NEAR(MustSun(in).solar_time_h, on_meridian.solar_time_h - 0.5, 1e-12);
  }
}

TEST(SunPosition, PolarNightAndMidnightSun) {
  constexpr int kJune = 173, kDecember = 357;
  const double d_june = TestDeclination(kJune), d_dec = TestDeclination(kDecember);
  ASSERT_LT(d_dec, -0.40);
  for (double t = 0; t < 24; t += 0.25) {
    SunInput in;
    in.latitude_deg = 80;
    in.standard_time_h = t;
    in.day_of_year = kDecember;  // polar night at 80 N
    EXPECT_GT(MustSun(in).zenith_rad, kPi / 2) << t;
    in.day_of_year = kJune;  // midnight sun at 80 N
    EXPECT_LT(MustSun(in).zenith_rad, kPi / 2) << t;
    in.latitude_deg = -80;  // and the reverse at 80 S
    EXPECT_GT(MustSun(in).zenith_rad, kPi / 2) << t;
  }
  // Closed forms: the highest December sun at 80 N is 90 - 80 + delta (below the horizon); the
  // lowest June sun (solar midnight, due north) is 80 + delta - 90.
  SunInput in;
  in.latitude_deg = 80;
  in.day_of_year = kDecember;
  in.standard_time_h = StandardTimeFor(12, kDecember);
  EXPECT_NEAR(ElevationDeg(MustSun(in)), 10 + d_dec / kDeg, 1e-10);
  in.day_of_year = kJune;
  in.standard_time_h = StandardTimeFor(24, kJune);
  if (in.standard_time_h >= 24) in.standard_time_h -= 24;
  const SunPosition midnight = MustSun(in);
  EXPECT_NEAR(ElevationDeg(midnight), 80 + d_june / kDeg - 90, 1e-10);
  EXPECT_NEAR(AngleDiff(midnight.azimuth_rad, 0), 0, 1e-12);
}

TEST(SunPosition, DirectionFollowsTheFrame) {
  // North = -Z, east = +X, up = +Y; the lat-long pixel of azimuth a is at u = a / (2 pi) + 0.5.
  auto dir = [](double zen, double az) { return SunDirection({zen, az, 0, 0}); };
  const auto near = [](const Vec3& a, const Vec3& b) {
    return std::abs(a.x - b.x) < 1e-15 && std::abs(a.y - b.y) < 1e-15 &&
           std::abs(a.z - b.z) < 1e-15;
  };
  EXPECT_TRUE(near(dir(0, 1.0), {0, 1, 0}));
  EXPECT_TRUE(near(dir(kPi / 2, 0), {0, 6.123233995736766e-17, -1}));
  EXPECT_TRUE(near(dir(kPi / 2, kPi / 2), {1, 6.123233995736766e-17, 0}));
  EXPECT_TRUE(near(dir(kPi / 2, kPi), {0, 6.123233995736766e-17, 1}));
  const Vec3 d = dir(1.1, 0.7);
  EXPECT_NEAR(d.Norm(), 1, 1e-15);
  // docs/conventions.md: d = (sin t sin p, cos t, -sin t cos p) with p = 2 pi (u - 0.5).
  const double u = 0.7 / (2 * kPi) + 0.5, p = 2 * kPi * (u - 0.5);
  EXPECT_NEAR(d.x, std::sin(1.1) * std::sin(p), 1e-15);
  EXPECT_NEAR(d.z, -std::sin(1.1) * std::cos(p), 1e-15);
}

TEST(SunPosition, BadInputNamesTheField) {
  struct Case {
    SunInput in;
    const char* field;
  };
  std::vector<Case> cases;
  auto add = [&](auto edit, const char* field) {
    SunInput in;
    edit(in);
    cases.push_back({in, field});
  };
  add([](SunInput& i) { i.day_of_year = 0; }, "day of year");
  add([](SunInput& i) { i.day_of_year = 367; }, "day of year");
  add([](SunInput& i) { i.standard_time_h = 24; }, "standard time");
  add([](SunInput& i) { i.standard_time_h = -0.5; }, "standard time");
  add([](SunInput& i) { i.standard_time_h = NAN; }, "standard time");
  add([](SunInput& i) { i.latitude_deg = 90.5; }, "latitude");
  add([](SunInput& i) { i.latitude_deg = NAN; }, "latitude");
  add([](SunInput& i) { i.longitude_deg = -181; }, "longitude");
  add([](SunInput& i) { i.standard_meridian_deg = 200; }, "standard meridian");
  for (const Case& c : cases) {
    const absl::StatusOr<SunPosition> s = ComputeSunPosition(c.in);
    ASSERT_FALSE(s.ok()) << c.field;
    EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(s.status().message().find(c.field), std::string::npos) << s.status();
  }
}

TEST(SunPosition, DayOfYear) {
  EXPECT_EQ(*DayOfYear(2023, 1, 1), 1);
  EXPECT_EQ(*DayOfYear(2023, 3, 22), 81);
  EXPECT_EQ(*DayOfYear(2024, 3, 21), 81);  // leap year
  EXPECT_EQ(*DayOfYear(2023, 12, 31), 365);
  EXPECT_EQ(*DayOfYear(2024, 12, 31), 366);
  EXPECT_EQ(*DayOfYear(2000, 2, 29), 60);     // divisible by 400: leap
  EXPECT_FALSE(DayOfYear(1900, 2, 29).ok());  // divisible by 100: not
  EXPECT_FALSE(DayOfYear(2023, 2, 29).ok());
  EXPECT_FALSE(DayOfYear(2023, 4, 31).ok());
  EXPECT_FALSE(DayOfYear(2023, 13, 1).ok());
  EXPECT_FALSE(DayOfYear(2023, 0, 1).ok());
}

// ---- the sky model -------------------------------------------------------------------------

// Appendix A.2, retyped: coefficient = a T + b for A, B, C, D, E.
struct Linear {
  double a, b;
};
constexpr Linear kTableY[5] = {
    {0.1787, -1.4630}, {-0.3554, 0.4275}, {-0.0227, 5.3251}, {0.1206, -2.5771}, {-0.0670, 0.3703}};
constexpr Linear kTableX[5] = {{-0.0193, -0.2592},
                               {-0.0665, 0.0008},
                               {-0.0004, 0.2125},
                               {-0.0641, -0.8989},
                               {-0.0033, 0.0452}};
constexpr Linear kTableYc[5] = {{-0.0167, -0.2608},
                                {-0.0950, 0.0092},
                                {-0.0079, 0.2102},
                                {-0.0441, -1.6537},
                                {-0.0109, 0.0529}};
// Zenith chromaticity matrices: rows T^2, T, 1; columns theta_s^3, theta_s^2, theta_s, 1.
constexpr double kMx[3][4] = {{0.00166, -0.00375, 0.00209, 0},
                              {-0.02903, 0.06377, -0.03202, 0.00394},
                              {0.11693, -0.21196, 0.06052, 0.25886}};
constexpr double kMy[3][4] = {{0.00275, -0.00610, 0.00317, 0},
                              {-0.04214, 0.08970, -0.04153, 0.00516},
                              {0.15346, -0.26756, 0.06670, 0.26688}};

std::array<double, 5> TableAt(const Linear (&t)[5], double turbidity) {
  std::array<double, 5> r;
  for (int k = 0; k < 5; ++k) r[k] = t[k].a * turbidity + t[k].b;
  return r;
}

double TestPerez(const std::array<double, 5>& c, double theta, double gamma) {
  return (1 + c[0] * std::exp(c[1] / std::cos(theta))) *
         (1 + c[2] * std::exp(c[3] * gamma) + c[4] * std::pow(std::cos(gamma), 2));
}

double TestZenithChroma(const double (&m)[3][4], double t, double ts) {
  const double tv[3] = {t * t, t, 1};
  const double sv[4] = {ts * ts * ts, ts * ts, ts, 1};
  double r = 0;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 4; ++k) r += tv[i] * m[i][k] * sv[k];
  return r;
}

double TestZenithLuminance(double t, double ts) {
  const double chi = (4.0 / 9 - t / 120) * (kPi - 2 * ts);
  return (4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192;
}

void ExpectRel(double got, double want, double tol, const std::string& what) {
  EXPECT_LE(std::abs(got - want), tol * std::max(1.0, std::abs(want)))
      << what << ": got " << got << ", want " << want;
}

std::array<double, 5> AsArray(const PerezCoefficients& c) { return {c.A, c.B, c.C, c.D, c.E}; }

TEST(SkyModel, PerezCoefficientsMatchThePublishedTable) {
  for (double t : {2.0, 3.0, 5.5, 10.0}) {
    const auto y = AsArray(PreethamPerezCoefficients(SkyChannel::kLuminanceY, t));
    const auto x = AsArray(PreethamPerezCoefficients(SkyChannel::kChromaX, t));
    const auto yc = AsArray(PreethamPerezCoefficients(SkyChannel::kChromaY, t));
    const auto wy = TableAt(kTableY, t), wx = TableAt(kTableX, t), wyc = TableAt(kTableYc, t);
    for (int k = 0; k < 5; ++k) {
      EXPECT_NEAR(y[k], wy[k], 1e-15) << "Y coefficient " << k << " at T " << t;
      EXPECT_NEAR(x[k], wx[k], 1e-15) << "x coefficient " << k << " at T " << t;
      EXPECT_NEAR(yc[k], wyc[k], 1e-15) << "y coefficient " << k << " at T " << t;
    }
  }
}

TEST(SkyModel, ZenithValuesMatchThePublishedFormulas) {
  for (double t : {2.0, 3.0, 6.0, 10.0}) {
    for (double ts : {0.0, 0.3, 0.8, 1.2, 1.5, kPi / 2}) {
      const ZenithValues z = PreethamZenith(t, ts);
      ExpectRel(z.Y_kcd, TestZenithLuminance(t, ts), kFormulaRelTol, "Y_z");
      ExpectRel(z.x, TestZenithChroma(kMx, t, ts), kFormulaRelTol, "x_z");
      ExpectRel(z.y, TestZenithChroma(kMy, t, ts), kFormulaRelTol, "y_z");
    }
  }
  // A value by hand: T = 2, sun at the zenith: chi = (4/9 - 1/60) pi = 77.0 deg, tan chi = 4.3315,
  // Y_z = 3.1196 x 4.3315 + 1.9882 = 15.5007 kcd/m^2 (4 decimals).
  EXPECT_NEAR(PreethamZenith(2, 0).Y_kcd, 15.5007, 5e-5);
}

TEST(SkyModel, PerezFunctionAtAnglesMatchesTheFormula) {
  for (double t : {2.0, 4.0, 9.0}) {
    const auto c = PreethamPerezCoefficients(SkyChannel::kLuminanceY, t);
    const auto w = TableAt(kTableY, t);
    for (double theta : {0.0, 0.4, 1.0, 1.4, 1.55})
      for (double gamma : {0.0, 0.1, 0.7, 1.6, 3.0})
        ExpectRel(PerezF(c, theta, gamma), TestPerez(w, theta, gamma), kFormulaRelTol, "F");
  }
}

// A direction at zenith angle theta and azimuth phi relative to the sun's azimuth.
Vec3 DirectionAt(double theta, double azimuth) {
  return {std::sin(theta) * std::sin(azimuth), std::cos(theta),
          -std::sin(theta) * std::cos(azimuth)};
}

TEST(SkyModel, SkyValueIsZenithTimesPerezRatio) {
  for (double t : {2.0, 3.0, 7.0, 10.0}) {
    for (double ts : {0.2, 0.9, 1.4}) {
      const double sun_az = 2.3;
      SkyOptions o;
      o.turbidity = t;
      const auto m = SkyModel::Create(DirectionAt(ts, sun_az), o);
      ASSERT_TRUE(m.ok()) << m.status();
      const double yz = TestZenithLuminance(t, ts);
      const double xz = TestZenithChroma(kMx, t, ts), yzc = TestZenithChroma(kMy, t, ts);
      // The zenith: F(0, theta_s) / F(0, theta_s) = 1, so exactly the zenith values.
      const Xyy zen = m->SkyXyy({0, 1, 0});
      ExpectRel(zen.Y, yz, kFormulaRelTol, "zenith Y");
      ExpectRel(zen.x, xz, kFormulaRelTol, "zenith x");
      ExpectRel(zen.y, yzc, kFormulaRelTol, "zenith y");
      // A few directions: value = zenith x F(theta, gamma) / F(0, theta_s), the paper's eq. 4.
      for (double theta : {0.3, 0.8, 1.3, 1.5})
        for (double dphi : {0.0, 0.5, 1.7, kPi}) {
          const double gamma = std::acos(std::cos(theta) * std::cos(ts) +
                                         std::sin(theta) * std::sin(ts) * std::cos(dphi));
          const Xyy v = m->SkyXyy(DirectionAt(theta, sun_az + dphi));
          const auto wy = TableAt(kTableY, t), wx = TableAt(kTableX, t), wyc = TableAt(kTableYc, t);
          // gamma through acos near 0 (dphi = 0, theta = ts +- small) keeps ~1e-8: relative 1e-9.
          ExpectRel(v.Y, yz * TestPerez(wy, theta, gamma) / TestPerez(wy, 0, ts), 1e-9, "Y");
          ExpectRel(v.x, xz * TestPerez(wx, theta, gamma) / TestPerez(wx, 0, ts), 1e-9, "x");
          ExpectRel(v.y, yzc * TestPerez(wyc, theta, gamma) / TestPerez(wyc, 0, ts), 1e-9, "y");
        }
    }
  }
}

TEST(SkyModel, SymmetricAboutTheSolarMeridian) {
  SkyOptions o;
  o.turbidity = 4;
  const double sun_az = 0.9;
  const auto m = SkyModel::Create(DirectionAt(1.0, sun_az), o);
  ASSERT_TRUE(m.ok());
  for (double theta : {0.2, 0.7, 1.2, 1.5})
    for (double dphi : {0.1, 0.8, 2.0, 3.0}) {
      const auto a = m->SkyRgb(DirectionAt(theta, sun_az + dphi));
      const auto b = m->SkyRgb(DirectionAt(theta, sun_az - dphi));
      for (int c = 0; c < 3; ++c) ExpectRel(a[c], b[c], 1e-12, "mirror");
    }
}

TEST(SkyModel, XyyToRec709AgainstPrimariesAndD65) {
  // D65 chromaticity -> equal R, G, B (= Y).
  const auto w = LinearRec709FromXyy(0.3127, 0.3290, 2.5);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(w[c], 2.5, 2.5 * kMatrixTol) << c;
  // The matrix derived here: columns = primaries' XYZ (x/y, 1, z/y) scaled so that they sum to
  // the white's XYZ; RGB = inverse of that. Compare RGB of a few XYZ triples.
  const double prim[3][2] = {{0.64, 0.33}, {0.30, 0.60}, {0.15, 0.06}};
  const double wx = 0.3127, wy = 0.3290;
  const double white[3] = {wx / wy, 1, (1 - wx - wy) / wy};
  double p[3][3];  // p[row][primary]
  for (int k = 0; k < 3; ++k) {
    p[0][k] = prim[k][0] / prim[k][1];
    p[1][k] = 1;
    p[2][k] = (1 - prim[k][0] - prim[k][1]) / prim[k][1];
  }
  auto solve = [](const double(&a)[3][3], const double(&b)[3], double(&x)[3]) {  // Cramer
    auto det = [](const double(&m)[3][3]) {
      return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
             m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det(a);
    for (int k = 0; k < 3; ++k) {
      double t[3][3];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) t[r][c] = c == k ? b[r] : a[r][c];
      x[k] = det(t) / d;
    }
  };
  double s[3];
  solve(p, white, s);
  double m[3][3];  // XYZ = m RGB
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) m[r][k] = p[r][k] * s[k];
  for (const auto& xyz : std::vector<std::array<double, 3>>{
           {0.95, 1.0, 1.09}, {0.3, 0.2, 0.9}, {0.4, 0.5, 0.1}, {0.2, 0.25, 0.35}}) {
    double rgb[3];
    const double b[3] = {xyz[0], xyz[1], xyz[2]};
    solve(m, b, rgb);
    const auto got = LinearRec709FromXyz(xyz[0], xyz[1], xyz[2]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], rgb[c], kMatrixTol) << c;
  }
}

TEST(SkyModel, SunDiscFromTheTransmittanceFormulas) {
  const double omega = 2 * kPi * (1 - std::cos(0.2665 * kDeg));
  EXPECT_NEAR(SunSolidAngle(), omega, 1e-18);
  const double lambda[3] = {0.610, 0.550, 0.465};
  for (double t : {2.0, 5.0, 10.0})
    for (double zen_deg : {0.0, 30.0, 60.0, 85.0, 90.0}) {
      const double m = 1 / (std::cos(zen_deg * kDeg) + 0.15 * std::pow(93.885 - zen_deg, -1.253));
      EXPECT_NEAR(RelativeAirMass(zen_deg * kDeg), m, 1e-12 * m);
      const double beta = 0.04608 * t - 0.04586;
      const auto rgb = SunDiscRgb(t, zen_deg * kDeg);
      for (int c = 0; c < 3; ++c) {
        const double want = 127.5 / omega * std::exp(-m * 0.008735 * std::pow(lambda[c], -4.08)) *
                            std::exp(-m * beta * std::pow(lambda[c], -1.3));
        ExpectRel(rgb[c], want, kFormulaRelTol, "sun");
      }
    }
  // Kasten's (1966) air mass: 1 at the zenith to 0.06 %, 1 / (0.15 x 3.885^-1.253) = 36.51 at
  // the horizon.
  EXPECT_NEAR(RelativeAirMass(0), 1, 6e-4);
  EXPECT_NEAR(RelativeAirMass(kPi / 2), 36.51, 0.005);
}

TEST(SkyModel, FiniteAndNonNegativeOverTheValidRange) {
  for (double t = kMinTurbidity; t <= kMaxTurbidity; t += 0.5) {
    for (double elev_deg : {0.0, 0.5, 5.0, 20.0, 45.0, 70.0, 90.0}) {
      SkyOptions o;
      o.turbidity = t;
      const auto img = RenderSkyLatLong(DirectionAt((90 - elev_deg) * kDeg, 1.0), o, 64);
      ASSERT_TRUE(img.ok()) << img.status();
      for (float v : img->pixels) ASSERT_TRUE(std::isfinite(v) && v >= 0) << t << " " << elev_deg;
      // The raw model (before the gamut clamp) is positive too.
      const auto m = SkyModel::Create(DirectionAt((90 - elev_deg) * kDeg, 1.0), o);
      for (double theta : {0.0, 0.5, 1.0, 1.5, 1.57})
        for (double az : {0.0, 1.0, 2.5, 4.0}) {
          const Xyy v = m->SkyXyy(DirectionAt(theta, az));
          EXPECT_GT(v.Y, 0);
          EXPECT_GT(v.x, 0);
          EXPECT_GT(v.y, 0);
        }
    }
  }
}

// ---- the rendered map ------------------------------------------------------------------------

// The pixel direction of docs/conventions.md.
Vec3 PixelDir(int i, int j, int w, int h) {
  const double t = kPi * (j + 0.5) / h, p = 2 * kPi * ((i + 0.5) / w - 0.5);
  return {std::sin(t) * std::sin(p), std::cos(t), -std::sin(t) * std::cos(p)};
}

TEST(SkyRender, PixelsEqualThePerDirectionSky) {
  for (double t : {2.0, 3.0, 8.0}) {
    SkyOptions o;
    o.turbidity = t;
    o.sun_disc = false;
    o.ground_albedo = 0;
    const Vec3 sun = DirectionAt(0.8, 4.0);
    const auto img = RenderSkyLatLong(sun, o, 96);
    ASSERT_TRUE(img.ok()) << img.status();
    ASSERT_EQ(img->width, 96);
    ASSERT_EQ(img->height, 48);
    ASSERT_EQ(img->channels, 3);
    const auto m = SkyModel::Create(sun, o);
    for (int j = 0; j < 48; ++j)
      for (int i = 0; i < 96; ++i) {
        const std::array<double, 3> want =
            j < 24 ? m->SkyRgb(PixelDir(i, j, 96, 48)) : std::array<double, 3>{0, 0, 0};
        for (int c = 0; c < 3; ++c) {
          ASSERT_LE(std::abs(img->at(i, j, c) - want[c]),
                    kPixelRelTol * std::abs(want[c]) + kPixelAbsTol)
              << i << "," << j << "," << c;
        }
      }
  }
}

TEST(SkyRender, MirrorSymmetricWithTheSunDueNorth) {
  SkyOptions o;
  const auto img = RenderSkyLatLong(DirectionAt(0.9, 0), o, 128);
  ASSERT_TRUE(img.ok());
  for (int j = 0; j < 64; ++j)
    for (int i = 0; i < 64; ++i)
      for (int c = 0; c < 3; ++c) {
        const double a = img->at(i, j, c), b = img->at(127 - i, j, c);
        ASSERT_LE(std::abs(a - b), kPixelRelTol * std::abs(a)) << i << "," << j;
      }
}

// The map's quadrature (docs/conventions.md): Fejer-1 ring weight x 2 pi / W per pixel, the
// solid angles EnvMap's samples and the SH transform use.
std::array<double, 3> Integrate(const Image& img, bool upper_only, bool cosine) {
  const RingQuadrature q = FejerFirstRule(img.height);
  std::array<double, 3> sum{};
  for (int j = 0; j < img.height; ++j) {
    if (upper_only && q.cos_theta[j] <= 0) continue;
    const double w = q.weight[j] * 2 * kPi / img.width * (cosine ? q.cos_theta[j] : 1.0);
    for (int i = 0; i < img.width; ++i)
      for (int c = 0; c < 3; ++c) sum[c] += img.at(i, j, c) * w;
  }
  return sum;
}

TEST(SkyRender, QuadratureIsEnvMapsSolidAngles) {
  // The weights above are the ones EnvMap gives its samples (what the SH transform integrates).
  SkyOptions o;
  const auto img = RenderSkyLatLong(DirectionAt(0.6, 1.0), o, 64);
  ASSERT_TRUE(img.ok());
  const EnvMap env = EnvMap::FromLatLong(*img);
  std::array<double, 3> sum{};
  for (const EnvSample& s : env.samples())
    for (int c = 0; c < 3; ++c) sum[c] += s.rgb[c] * s.solid_angle;
  const auto mine = Integrate(*img, false, false);
  for (int c = 0; c < 3; ++c) ExpectRel(mine[c], sum[c], 1e-12, "quadrature");
}

TEST(SkyRender, GroundIsLambertianLitByTheUpperHalf) {
  for (bool disc : {false, true}) {
    SkyOptions o;
    o.ground_albedo = 0.3;
    o.sun_disc = disc;
    const auto img = RenderSkyLatLong(DirectionAt(0.6, 1.0), o, 128);
    ASSERT_TRUE(img.ok());
    const auto e = Integrate(*img, /*upper_only=*/true, /*cosine=*/true);
    for (int j = 32; j < 64; ++j)
      for (int i = 0; i < 128; i += 7)
        for (int c = 0; c < 3; ++c)
          ExpectRel(img->at(i, j, c), 0.3 / kPi * e[c],
                    kIntegralRelTol * std::max(1.0, 1 / std::abs(0.3 / kPi * e[c])), "ground");
  }
}

TEST(SkyRender, SunDiscIntegralIsTheAttenuatedSun) {
  // Disc integral = SunDiscRgb x the true disc's solid angle, at any size and position: widened
  // (64, 256), resolved (2048: 1.5 px = 0.264 deg < 0.2665 deg), sub-pixel without widening,
  // next to the pole.
  struct Case {
    int width;
    double min_px;
    double zenith;
    double azimuth;
  };
  for (const Case& k : std::vector<Case>{{64, 1.5, 0.7, 2.0},
                                         {256, 1.5, 0.3, 5.5},
                                         {256, 4.0, 1.2, 0.01},
                                         {2048, 1.5, 0.9, 1.0},
                                         {64, 0.0, 0.8, 0.3},
                                         {128, 1.5, 0.004, 1.0}}) {
    SkyOptions with;
    with.ground_albedo = 0;
    with.sun_min_radius_px = k.min_px;
    SkyOptions without = with;
    without.sun_disc = false;
    const Vec3 sun = DirectionAt(k.zenith, k.azimuth);
    const auto a = RenderSkyLatLong(sun, with, k.width);
    const auto b = RenderSkyLatLong(sun, without, k.width);
    ASSERT_TRUE(a.ok() && b.ok());
    Image diff = *a;
    for (size_t n = 0; n < diff.pixels.size(); ++n) diff.pixels[n] -= b->pixels[n];
    const auto got = Integrate(diff, false, false);
    const auto m = SkyModel::Create(sun, with);
    const auto want = m->SunIntegralRgb();
    for (int c = 0; c < 3; ++c) {
      EXPECT_GT(want[c], 0);
      ExpectRel(got[c], want[c], kIntegralRelTol * std::max(1.0, 1 / want[c]), "sun integral");
    }
  }
}

TEST(SkyRender, ScaleMultipliesEverything) {
  SkyOptions one, two;
  two.scale = 2;
  const auto a = RenderSkyLatLong(DirectionAt(1.0, 1.0), one, 64);
  const auto b = RenderSkyLatLong(DirectionAt(1.0, 1.0), two, 64);
  ASSERT_TRUE(a.ok() && b.ok());
  for (size_t n = 0; n < a->pixels.size(); ++n) ASSERT_EQ(2 * a->pixels[n], b->pixels[n]) << n;
}

TEST(SkyRender, NightFadesTheHorizonSkyToBlack) {
  SkyOptions o;
  o.sun_disc = false;
  const double az = 1.3;
  const auto horizon = RenderSkyLatLong(DirectionAt(kPi / 2, az), o, 64);
  // 3 degrees below: the horizon sun's sky at half strength (linear fade over 6 degrees).
  const auto dusk = RenderSkyLatLong(DirectionAt(kPi / 2 + 3 * kDeg, az), o, 64);
  ASSERT_TRUE(horizon.ok() && dusk.ok());
  for (size_t n = 0; n < dusk->pixels.size(); ++n)
    ASSERT_NEAR(dusk->pixels[n], 0.5 * horizon->pixels[n], 1e-6 * horizon->pixels[n] + 1e-30);
  // Deeper than 6 degrees, with the disc on: black.
  o.sun_disc = true;
  const auto night = RenderSkyLatLong(DirectionAt(kPi / 2 + 7 * kDeg, az), o, 64);
  ASSERT_TRUE(night.ok());
  for (float v : night->pixels) ASSERT_EQ(v, 0.0f);
  // The sun at the nadir: black, no error.
  const auto nadir = RenderSkyLatLong({0, -1, 0}, o, 64);
  ASSERT_TRUE(nadir.ok());
  for (float v : nadir->pixels) ASSERT_EQ(v, 0.0f);
}

TEST(SkyRender, RenderIntoReusesTheImage) {
  Image img;
  SkyOptions o;
  ASSERT_TRUE(RenderSkyLatLongInto(DirectionAt(0.5, 0.5), o, 64, &img).ok());
  const float* data = img.pixels.data();
  ASSERT_TRUE(RenderSkyLatLongInto(DirectionAt(0.6, 0.7), o, 64, &img).ok());
  EXPECT_EQ(img.pixels.data(), data);
  const auto fresh = RenderSkyLatLong(DirectionAt(0.6, 0.7), o, 64);
  EXPECT_EQ(fresh->pixels, img.pixels);
}

TEST(SkyRender, BadInputNamesTheProblem) {
  const Vec3 sun = DirectionAt(0.5, 0.5);
  auto expect_error = [](const absl::Status& s, const std::string& part) {
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
    EXPECT_NE(s.message().find(part), std::string::npos) << s;
  };
  for (double t : {1.9, 10.1, std::nan("")}) {
    SkyOptions o;
    o.turbidity = t;
    expect_error(RenderSkyLatLong(sun, o, 64).status(), "turbidity");
  }
  SkyOptions o;
  for (int w : {0, 1, 63, 16386}) expect_error(RenderSkyLatLong(sun, o, w).status(), "width");
  expect_error(RenderSkyLatLong({0, 0, 0}, o, 64).status(), "sun direction");
  expect_error(RenderSkyLatLong({NAN, 1, 0}, o, 64).status(), "sun direction");
  o.ground_albedo = 1.5;
  expect_error(RenderSkyLatLong(sun, o, 64).status(), "ground albedo");
  o = {};
  o.scale = 0;
  expect_error(RenderSkyLatLong(sun, o, 64).status(), "scale");
  o = {};
  o.sun_min_radius_px = -1;
  expect_error(RenderSkyLatLong(sun, o, 64).status(), "sun minimum radius");
  // A finite scale that takes the sun (and, with a black ground, 0 x inf there) beyond single
  // precision: refused, not a map of infinities that every reader rejects. The largest scale
  // that keeps the brightest value finite still renders.
  for (double ground : {0.0, 0.2}) {
    o = {};
    o.ground_albedo = ground;
    const auto unit = RenderSkyLatLong(sun, o, 64);
    ASSERT_TRUE(unit.ok());
    float brightest = 0;
    for (float v : unit->pixels) brightest = std::max(brightest, v);
    o.scale = 1e38;
    expect_error(RenderSkyLatLong(sun, o, 64).status(), "beyond single precision");
    o.scale = 0.5 * std::numeric_limits<float>::max() / brightest;
    EXPECT_TRUE(RenderSkyLatLong(sun, o, 64).ok()) << o.scale;
  }
}

}  // namespace
}  // namespace shrm::sky
