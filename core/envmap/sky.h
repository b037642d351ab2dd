// A procedural daylight sky with a moving sun, as a lat-long environment map (docs/sky.md).
//
// Model: A. J. Preetham, P. Shirley, B. Smits, "A Practical Analytic Model for Daylight",
// SIGGRAPH 1999 (the paper below), from its formulas:
//  - Perez distribution (paper eq. 3): F(theta, gamma) = (1 + A e^{B / cos theta})
//    (1 + C e^{D gamma} + E cos^2 gamma), theta the view direction's angle from the zenith, gamma
//    its angle from the sun; one coefficient set (A..E) for each of Y, x and y, linear in the
//    turbidity T (Appendix A.2 table).
//  - Value of a direction (eq. 4): Y = Y_z F(theta, gamma) / F(0, theta_s), and the same for the
//    chromaticities x, y with x_z, y_z, theta_s the sun's zenith angle.
//  - Zenith luminance (A.2): Y_z = (4.0453 T - 4.9710) tan chi - 0.2155 T + 2.4192 in kcd/m^2,
//    chi = (4/9 - T/120) (pi - 2 theta_s); zenith chromaticities x_z, y_z (A.2):
//    [T^2 T 1] M [theta_s^3 theta_s^2 theta_s 1]^T with the paper's two 3 x 4 matrices.
//  - Sun position (A.6): solar time t = t_s + 0.170 sin(4 pi (J - 80) / 373)
//    - 0.129 sin(2 pi (J - 8) / 355) + 12 (SM - L) / pi (SM, L west-positive radians), declination
//    delta = 0.4093 sin(2 pi (J - 81) / 368), and the zenith angle and azimuth of the sun.
//  - Colour: xyY -> CIE XYZ -> linear Rec.709 (IEC 61966-2-1 matrix, D65 white): the working
//    space "lin_rec709" of core/io/colour.h.
//
// Frame (docs/conventions.md "Sky and sun"): the world frame, +Y up, NORTH = -Z, EAST = +X. Azimuth
// is measured from north towards east, so a direction of zenith angle z and azimuth a is
// (sin z sin a, cos z, -sin z cos a): the lat-long formula with theta = z and p = a. The image
// centre looks north, u = 0.75 east, u = 0.25 west, the image's left and right edges south.
//
// Decisions (docs/sky.md): turbidity in [kMinTurbidity, kMaxTurbidity] (refused outside); values
// are luminance in kcd/m^2 (the paper's unit) times SkyOptions::scale; below the horizon a
// Lambertian ground of SkyOptions::ground_albedo lit by the map's own upper half; the sun a
// uniform disc whose integral is the attenuated extraterrestrial sun, widened to a minimum size in
// pixels at equal integral; a sun below the horizon (night: outside the model) gives the sky of
// a sun on the horizon faded linearly to black at kTwilightDepthDeg below it.
#ifndef SHRM_CORE_ENVMAP_SKY_H_
#define SHRM_CORE_ENVMAP_SKY_H_

#include <array>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/io/image.h"

namespace shrm::sky {

// ------------------------------------------------------------------------------------------------
// Sun position (paper Appendix A.6).

struct SunInput {                    // Preetham Appendix A.6 inputs
  int day_of_year = 80;              // J, 1..366 (1 = January 1)
  double standard_time_h = 12;       // local standard time, hours [0, 24)
  double latitude_deg = 0;           // north positive, [-90, 90]
  double longitude_deg = 0;          // EAST positive, [-180, 180] (the paper's L is west-positive)
  double standard_meridian_deg = 0;  // east positive, [-180, 180]: 15 x the UTC offset in hours
};

struct SunPosition {
  double zenith_rad = 0;       // angle from the zenith, [0, pi]; > pi/2: below the horizon
  double azimuth_rad = 0;      // from north towards east, [0, 2 pi)
  double solar_time_h = 0;     // local apparent solar time, wrapped to [0, 24)
  double declination_rad = 0;  // delta
};

// The paper's equation-of-time terms, in hours: 0.170 sin(4 pi (J - 80) / 373)
// - 0.129 sin(2 pi (J - 8) / 355). Solar time = standard time + this + (L_east - SM_east) / 15.
double EquationOfTimeHours(int day_of_year);
// delta = 0.4093 sin(2 pi (J - 81) / 368) (radians; 0 at J = 81, 0.4093 at J = 173).
double SolarDeclination(int day_of_year);
// The sun's zenith angle and azimuth for a solar time (hours), declination and latitude
// (radians), by spherical astronomy with the hour angle H = pi t / 12 - pi:
//   cos zenith = sin l sin delta + cos l cos delta cos H   (the paper's A.6 zenith formula)
//   azimuth = atan2(east, north), east = -cos delta sin H, north = cos l sin delta
//             - sin l cos delta cos H   (the paper's atan, with its quadrant resolved)
// No validation (ComputeSunPosition validates). solar_time_h is stored wrapped to [0, 24).
SunPosition SunFromSolarTime(double solar_time_h, double declination_rad, double latitude_rad);
// The sun position for a date, time and place. InvalidArgument naming the field for a value out
// of its range or not finite.
absl::StatusOr<SunPosition> ComputeSunPosition(const SunInput& in);
// World direction of the sun (unit): (sin z sin a, cos z, -sin z cos a).
Vec3 SunDirection(const SunPosition& sun);
// Day of the year (1..366) of a Gregorian date; InvalidArgument for a date that does not exist
// (e.g. 2023-02-29) or a year outside 1..9999.
absl::StatusOr<int> DayOfYear(int year, int month, int day);

// ------------------------------------------------------------------------------------------------
// Sky model (paper Appendix A.2).

// The turbidity range accepted. Below T = 1.64 the luminance factor 1 + A_Y e^{B_Y / cos theta}
// turns negative near the zenith (it is 0.17 there at T = 2), so the sky changes sign; above 10 the
// zenith luminance at a low sun approaches 0 and turns negative at T = 11.2 (Y_z = 2.4192 - 0.2155
// T at theta_s = 90 deg). Zotti et al. 2007 (WSCG) review where the model misbehaves.
inline constexpr double kMinTurbidity = 2;
inline constexpr double kMaxTurbidity = 10;

// Angular radius of the sun's disc (0.2665 deg, the mean semi-diameter as seen from the Earth).
inline constexpr double kSunAngularRadiusRad = 0.2665 * kPi / 180;
// Extraterrestrial solar illuminance at normal incidence (IES value), klx = kcd sr / m^2.
inline constexpr double kExtraterrestrialIlluminanceKlx = 127.5;
// Depth below the horizon (degrees of solar elevation) over which a set sun's sky fades to black.
inline constexpr double kTwilightDepthDeg = 6;
// Wavelengths (micrometres) at which the sun's transmittance is evaluated for R, G, B: near the
// dominant wavelengths of the Rec.709 primaries.
inline constexpr std::array<double, 3> kSunWavelengthsUm = {0.610, 0.550, 0.465};

enum class SkyChannel { kLuminanceY, kChromaX, kChromaY };  // CIE Y, x, y

struct PerezCoefficients {
  double A = 0, B = 0, C = 0, D = 0, E = 0;
};

// The paper's Appendix A.2 table: each coefficient = a T + b. No validation of T.
PerezCoefficients PreethamPerezCoefficients(SkyChannel channel, double turbidity);
// F(theta, gamma) (eq. 3). cos theta <= 0 (the horizon and below) is taken as the horizon limit,
// where e^{B / cos theta} -> 0 (B < 0 for every channel over the accepted turbidities).
double PerezF(const PerezCoefficients& c, double theta, double gamma);

// Zenith values (A.2): luminance Y_z in kcd/m^2 and CIE chromaticities x_z, y_z, for a sun at
// zenith angle theta_s (radians, [0, pi/2]). No validation.
struct ZenithValues {
  double Y_kcd = 0, x = 0, y = 0;
};
ZenithValues PreethamZenith(double turbidity, double sun_zenith_rad);

// CIE xyY (Y in any unit) -> XYZ -> linear Rec.709 RGB (IEC 61966-2-1, D65). y must be > 0.
std::array<double, 3> LinearRec709FromXyz(double X, double Y, double Z);
std::array<double, 3> LinearRec709FromXyy(double x, double y, double Y);

// Kasten's relative optical air mass (as the paper's Appendix A.1 uses it):
// m = 1 / (cos theta_s + 0.15 (93.885 - theta_s[deg])^-1.253), theta_s clamped to [0, 90 deg].
double RelativeAirMass(double sun_zenith_rad);
// Luminance (kcd/m^2, linear Rec.709 RGB) of the sun's true disc seen from the ground: the
// extraterrestrial sun (kExtraterrestrialIlluminanceKlx over the disc's solid angle, white: equal
// RGB) times, per channel, the Rayleigh and aerosol transmittances of the paper's Appendix A.1 at
// kSunWavelengthsUm: exp(-m (0.008735 lambda^-4.08 + beta lambda^-1.3)),
// beta = 0.04608 T - 0.04586 (Angstrom; ozone, water vapour and mixed gases are left out).
std::array<double, 3> SunDiscRgb(double turbidity, double sun_zenith_rad);
// Solid angle of the true sun disc: 2 pi (1 - cos kSunAngularRadiusRad).
double SunSolidAngle();

struct SkyOptions {
  double turbidity = 3;  // [kMinTurbidity, kMaxTurbidity]
  bool sun_disc = true;  // draw the sun
  // The disc is drawn with an angular radius of at least this many pixels (of the polar pitch
  // pi / H) and its luminance lowered so that its integral over the map (the map's own
  // quadrature, docs/conventions.md) is SunDiscRgb x SunSolidAngle exactly. The true disc
  // (0.2665 deg) is sub-pixel below W = 1350; 1.5 pixels covers about 7 pixel centres. [0, 64].
  double sun_min_radius_px = 1.5;
  // Below the horizon: a Lambertian ground of this albedo ([0, 1]; 0 = black) lit by the map's
  // upper half (sky and drawn sun): L = albedo / pi x sum over upper pixels of L cos theta dw.
  double ground_albedo = 0.2;
  // Output = luminance in kcd/m^2 x scale (finite, > 0).
  double scale = 1;
};

// Checks the options (InvalidArgument naming the field).
[[nodiscard]] absl::Status ValidateSkyOptions(const SkyOptions& options);

// CIE xyY of the sky (Y in kcd/m^2, no scale, no fade).
struct Xyy {
  double x = 0, y = 0, Y = 0;
};

// The sky for one sun direction and turbidity: the per-direction evaluation the renderer is
// tested against (its slow twin). Immutable, cheap to copy.
class SkyModel {
 public:
  // sun_dir: world direction towards the sun (nonzero, finite; normalized here).
  static absl::StatusOr<SkyModel> Create(const Vec3& sun_dir, const SkyOptions& options);

  const SkyOptions& options() const { return options_; }
  const Vec3& sun_dir() const { return sun_dir_; }
  // The sun's elevation (radians; negative below the horizon).
  double sun_elevation_rad() const { return kPi / 2 - sun_zenith_; }
  // theta_s used in the formulas: the sun's zenith angle, clamped to pi/2 below the horizon.
  double model_sun_zenith_rad() const { return model_zenith_; }
  // 1 with the sun above the horizon; then linear to 0 at kTwilightDepthDeg below it.
  double twilight_factor() const { return fade_; }
  const ZenithValues& zenith() const { return zenith_; }
  const PerezCoefficients& perez(SkyChannel channel) const {
    return perez_[static_cast<int>(channel)];
  }

  // Eq. 4 for a direction (nonzero; below the horizon it gives the horizon's value at that
  // azimuth): Y = Y_z F_Y(theta, gamma) / F_Y(0, theta_s), likewise x, y.
  Xyy SkyXyy(const Vec3& dir) const;
  // The sky's linear Rec.709 value for a direction: LinearRec709FromXyy(SkyXyy) x twilight
  // factor x scale, negative components (outside the Rec.709 gamut) clamped to 0. No sun disc,
  // no ground.
  std::array<double, 3> SkyRgb(const Vec3& dir) const;
  // The true sun disc's luminance (SunDiscRgb at the clamped zenith) x scale; 0 without a disc.
  // The renderer draws the (widened) disc while part of the true disc is above the horizon, and
  // only its pixels above the horizon.
  std::array<double, 3> SunRgb() const;
  // The disc's integral over the sphere, SunRgb() x SunSolidAngle(): what the drawn disc of a
  // rendered map integrates to (the part of it above the horizon).
  std::array<double, 3> SunIntegralRgb() const;

 private:
  SkyModel() = default;
  SkyOptions options_;
  Vec3 sun_dir_;
  double sun_zenith_ = 0, model_zenith_ = 0, fade_ = 1;
  std::array<PerezCoefficients, 3> perez_{};
  std::array<double, 3> f0_{};  // F(0, theta_s) per channel
  ZenithValues zenith_;
  std::array<double, 3> sun_rgb_{};
};

// The sky as a W x W/2 lat-long map (3 channels, linear Rec.709, docs/conventions.md layout):
// above the horizon SkyModel::SkyRgb at each pixel centre, plus the sun disc; below it the
// ground. InvalidArgument for a bad width (odd, < 2 or > 16384), sun direction or option.
// About 0.5 ms at 256 x 128 and 8.5 ms at 1024 x 512 on one core (docs/sky.md "Speed").
absl::StatusOr<Image> RenderSkyLatLong(const Vec3& sun_dir, const SkyOptions& options, int width);
// The same into `image`, reusing its storage (a viewer re-rendering per frame).
[[nodiscard]] absl::Status RenderSkyLatLongInto(const Vec3& sun_dir, const SkyOptions& options,
                                                int width, Image* image);

}  // namespace shrm::sky

#endif  // SHRM_CORE_ENVMAP_SKY_H_
