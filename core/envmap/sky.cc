#include "core/envmap/sky.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/sh/quadrature.h"

namespace shrm::sky {
namespace {

constexpr double kDeg = kPi / 180;
constexpr int kMaxWidth = 16384;  // ImageLimits::max_width
constexpr double kMaxSunMinRadiusPx = 64;

absl::Status RangeError(const char* field, double value, double lo, double hi,
                        const char* unit = "") {
  return absl::InvalidArgumentError(
      absl::StrFormat("%s %g%s is outside [%g, %g]", field, value, unit, lo, hi));
}

bool InClosedRange(double v, double lo, double hi) {
  return std::isfinite(v) && v >= lo && v <= hi;
}

double Clamp1(double v) { return std::clamp(v, -1.0, 1.0); }

// Fejer-1 weights of H pixel-centre rings (the map's quadrature, docs/conventions.md), cached for
// the last H: a viewer re-renders the same size every frame.
std::shared_ptr<const RingQuadrature> CachedFejer(int rings) {
  static std::mutex mu;
  static std::shared_ptr<const RingQuadrature> last;
  std::lock_guard<std::mutex> lock(mu);
  if (!last || static_cast<int>(last->weight.size()) != rings) {
    last = std::make_shared<const RingQuadrature>(FejerFirstRule(rings));
  }
  return last;
}

}  // namespace

// ---- sun position --------------------------------------------------------------------------

double EquationOfTimeHours(int day_of_year) {
  const double j = day_of_year;
  return 0.170 * std::sin(4 * kPi * (j - 80) / 373) - 0.129 * std::sin(2 * kPi * (j - 8) / 355);
}

double SolarDeclination(int day_of_year) {
  return 0.4093 * std::sin(2 * kPi * (day_of_year - 81.0) / 368);
}

SunPosition SunFromSolarTime(double solar_time_h, double declination_rad, double latitude_rad) {
  SunPosition p;
  const double h = kPi * solar_time_h / 12 - kPi;  // hour angle, 0 at solar noon, west positive
  const double sl = std::sin(latitude_rad), cl = std::cos(latitude_rad);
  const double sd = std::sin(declination_rad), cd = std::cos(declination_rad);
  const double ch = std::cos(h), sh = std::sin(h);
  p.zenith_rad = std::acos(Clamp1(sl * sd + cl * cd * ch));
  const double east = -cd * sh;
  const double north = cl * sd - sl * cd * ch;
  double az = std::hypot(east, north) < 1e-12 ? 0.0 : std::atan2(east, north);
  if (az < 0) az += 2 * kPi;
  if (az >= 2 * kPi) az -= 2 * kPi;
  p.azimuth_rad = az;
  double t = std::fmod(solar_time_h, 24.0);
  if (t < 0) t += 24;
  p.solar_time_h = t;
  p.declination_rad = declination_rad;
  return p;
}

absl::StatusOr<SunPosition> ComputeSunPosition(const SunInput& in) {
  if (in.day_of_year < 1 || in.day_of_year > 366) {
    return absl::InvalidArgumentError(
        absl::StrCat("day of year ", in.day_of_year, " is outside 1..366"));
  }
  if (!std::isfinite(in.standard_time_h) || in.standard_time_h < 0 || in.standard_time_h >= 24) {
    return absl::InvalidArgumentError(
        absl::StrFormat("standard time %g h is outside [0, 24)", in.standard_time_h));
  }
  if (!InClosedRange(in.latitude_deg, -90, 90)) {
    return RangeError("latitude", in.latitude_deg, -90, 90, " deg");
  }
  if (!InClosedRange(in.longitude_deg, -180, 180)) {
    return RangeError("longitude", in.longitude_deg, -180, 180, " deg");
  }
  if (!InClosedRange(in.standard_meridian_deg, -180, 180)) {
    return RangeError("standard meridian", in.standard_meridian_deg, -180, 180, " deg");
  }
  // A.6: t = t_s + EoT + 12 (SM - L) / pi with west-positive radians = (L_east - SM_east) / 15 h.
  const double solar_time = in.standard_time_h + EquationOfTimeHours(in.day_of_year) +
                            (in.longitude_deg - in.standard_meridian_deg) / 15;
  return SunFromSolarTime(solar_time, SolarDeclination(in.day_of_year), in.latitude_deg * kDeg);
}

Vec3 SunDirection(const SunPosition& sun) {
  const double sz = std::sin(sun.zenith_rad);
  return {sz * std::sin(sun.azimuth_rad), std::cos(sun.zenith_rad),
          -sz * std::cos(sun.azimuth_rad)};
}

absl::StatusOr<int> DayOfYear(int year, int month, int day) {
  if (year < 1 || year > 9999) {
    return absl::InvalidArgumentError(absl::StrCat("year ", year, " is outside 1..9999"));
  }
  if (month < 1 || month > 12) {
    return absl::InvalidArgumentError(absl::StrCat("month ", month, " is outside 1..12"));
  }
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const int in_month = kDays[month - 1] + (month == 2 && leap ? 1 : 0);
  if (day < 1 || day > in_month) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%04d-%02d-%02d is not a date (that month has %d days)", year, month, day, in_month));
  }
  int doy = day;
  for (int m = 1; m < month; ++m) doy += kDays[m - 1] + (m == 2 && leap ? 1 : 0);
  return doy;
}

// ---- sky model -----------------------------------------------------------------------------

PerezCoefficients PreethamPerezCoefficients(SkyChannel channel, double t) {
  // Appendix A.2: the distribution coefficients as linear functions of T.
  switch (channel) {
    case SkyChannel::kLuminanceY:
      return {0.1787 * t - 1.4630, -0.3554 * t + 0.4275, -0.0227 * t + 5.3251, 0.1206 * t - 2.5771,
              -0.0670 * t + 0.3703};
    case SkyChannel::kChromaX:
      return {-0.0193 * t - 0.2592, -0.0665 * t + 0.0008, -0.0004 * t + 0.2125,
              -0.0641 * t - 0.8989, -0.0033 * t + 0.0452};
    case SkyChannel::kChromaY:
      return {-0.0167 * t - 0.2608, -0.0950 * t + 0.0092, -0.0079 * t + 0.2102,
              -0.0441 * t - 1.6537, -0.0109 * t + 0.0529};
  }
  return {};
}

double PerezF(const PerezCoefficients& c, double theta, double gamma) {
  const double ct = std::cos(theta);
  const double first = ct > 0 ? 1 + c.A * std::exp(c.B / ct) : 1.0;
  const double cg = std::cos(gamma);
  return first * (1 + c.C * std::exp(c.D * gamma) + c.E * cg * cg);
}

ZenithValues PreethamZenith(double t, double ts) {
  // Appendix A.2.
  ZenithValues z;
  const double chi = (4.0 / 9.0 - t / 120) * (kPi - 2 * ts);
  z.Y_kcd = (4.0453 * t - 4.9710) * std::tan(chi) - 0.2155 * t + 2.4192;
  const double t2 = t * t, s2 = ts * ts, s3 = s2 * ts;
  z.x = t2 * (0.00166 * s3 - 0.00375 * s2 + 0.00209 * ts) +
        t * (-0.02903 * s3 + 0.06377 * s2 - 0.03202 * ts + 0.00394) +
        (0.11693 * s3 - 0.21196 * s2 + 0.06052 * ts + 0.25886);
  z.y = t2 * (0.00275 * s3 - 0.00610 * s2 + 0.00317 * ts) +
        t * (-0.04214 * s3 + 0.08970 * s2 - 0.04153 * ts + 0.00516) +
        (0.15346 * s3 - 0.26756 * s2 + 0.06670 * ts + 0.26688);
  return z;
}

std::array<double, 3> LinearRec709FromXyz(double x, double y, double z) {
  // IEC 61966-2-1 (sRGB) XYZ -> linear RGB, D65, to 7 digits.
  return {3.2404542 * x - 1.5371385 * y - 0.4985314 * z,
          -0.9692660 * x + 1.8760108 * y + 0.0415560 * z,
          0.0556434 * x - 0.2040259 * y + 1.0572252 * z};
}

std::array<double, 3> LinearRec709FromXyy(double x, double y, double luminance) {
  const double k = luminance / y;
  return LinearRec709FromXyz(k * x, luminance, k * (1 - x - y));
}

double RelativeAirMass(double sun_zenith_rad) {
  const double z = std::clamp(sun_zenith_rad, 0.0, kPi / 2);
  return 1 / (std::cos(z) + 0.15 * std::pow(93.885 - z / kDeg, -1.253));
}

double SunSolidAngle() { return 2 * kPi * (1 - std::cos(kSunAngularRadiusRad)); }

std::array<double, 3> SunDiscRgb(double turbidity, double sun_zenith_rad) {
  const double m = RelativeAirMass(sun_zenith_rad);
  const double beta = 0.04608 * turbidity - 0.04586;
  const double l0 = kExtraterrestrialIlluminanceKlx / SunSolidAngle();
  std::array<double, 3> rgb{};
  for (int c = 0; c < 3; ++c) {
    const double lambda = kSunWavelengthsUm[c];
    const double tau = 0.008735 * std::pow(lambda, -4.08) + beta * std::pow(lambda, -1.3);
    rgb[c] = l0 * std::exp(-m * tau);
  }
  return rgb;
}

absl::Status ValidateSkyOptions(const SkyOptions& o) {
  if (!InClosedRange(o.turbidity, kMinTurbidity, kMaxTurbidity)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "turbidity %g is outside the Preetham model's valid range [%g, %g] (docs/sky.md)",
        o.turbidity, kMinTurbidity, kMaxTurbidity));
  }
  if (!InClosedRange(o.sun_min_radius_px, 0, kMaxSunMinRadiusPx)) {
    return RangeError("sun minimum radius", o.sun_min_radius_px, 0, kMaxSunMinRadiusPx, " px");
  }
  if (!InClosedRange(o.ground_albedo, 0, 1)) {
    return RangeError("ground albedo", o.ground_albedo, 0, 1);
  }
  if (!std::isfinite(o.scale) || o.scale <= 0) {
    return absl::InvalidArgumentError(absl::StrFormat("scale %g must be finite and > 0", o.scale));
  }
  return absl::OkStatus();
}

absl::StatusOr<SkyModel> SkyModel::Create(const Vec3& sun_dir, const SkyOptions& options) {
  SHRM_RETURN_IF_ERROR(ValidateSkyOptions(options));
  const double n = sun_dir.Norm();
  if (!std::isfinite(n) || n == 0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "sun direction (%g, %g, %g) must be finite and nonzero", sun_dir.x, sun_dir.y, sun_dir.z));
  }
  SkyModel m;
  m.options_ = options;
  m.sun_dir_ = sun_dir * (1 / n);
  m.sun_zenith_ = std::acos(Clamp1(m.sun_dir_.y));
  m.model_zenith_ = std::min(m.sun_zenith_, kPi / 2);
  const double elevation_deg = (kPi / 2 - m.sun_zenith_) / kDeg;
  m.fade_ = elevation_deg >= 0 ? 1.0 : std::max(0.0, 1 + elevation_deg / kTwilightDepthDeg);
  const double t = options.turbidity;
  for (int c = 0; c < 3; ++c) {
    m.perez_[c] = PreethamPerezCoefficients(static_cast<SkyChannel>(c), t);
    m.f0_[c] = PerezF(m.perez_[c], 0, m.model_zenith_);
  }
  m.zenith_ = PreethamZenith(t, m.model_zenith_);
  if (options.sun_disc) {
    m.sun_rgb_ = SunDiscRgb(t, m.model_zenith_);
    for (double& v : m.sun_rgb_) v *= options.scale;
  }
  return m;
}

namespace {

// The sun direction the formulas use: the sun, or below the horizon the horizon point at its
// azimuth (north for a sun at the nadir).
Vec3 ModelSunDir(const Vec3& s) {
  if (s.y >= 0) return s;
  const double h = std::hypot(s.x, s.z);
  return h > 0 ? Vec3{s.x / h, 0, s.z / h} : Vec3{0, 0, -1};
}

}  // namespace

Xyy SkyModel::SkyXyy(const Vec3& dir) const {
  const Vec3 d = dir.Normalized();
  const double theta = std::acos(Clamp1(d.y));
  const double gamma = std::acos(Clamp1(d.Dot(ModelSunDir(sun_dir_))));
  Xyy v;
  v.Y = zenith_.Y_kcd * PerezF(perez_[0], theta, gamma) / f0_[0];
  v.x = zenith_.x * PerezF(perez_[1], theta, gamma) / f0_[1];
  v.y = zenith_.y * PerezF(perez_[2], theta, gamma) / f0_[2];
  return v;
}

std::array<double, 3> SkyModel::SkyRgb(const Vec3& dir) const {
  const Xyy v = SkyXyy(dir);
  std::array<double, 3> rgb = LinearRec709FromXyy(v.x, v.y, v.Y);
  const double k = fade_ * options_.scale;
  for (double& c : rgb) c = std::max(0.0, c) * k;
  return rgb;
}

std::array<double, 3> SkyModel::SunRgb() const { return sun_rgb_; }

std::array<double, 3> SkyModel::SunIntegralRgb() const {
  const double omega = SunSolidAngle();
  return {sun_rgb_[0] * omega, sun_rgb_[1] * omega, sun_rgb_[2] * omega};
}

// ---- rendering -----------------------------------------------------------------------------

absl::Status RenderSkyLatLongInto(const Vec3& sun_dir, const SkyOptions& options, int width,
                                  Image* image) {
  if (width < 2 || width > kMaxWidth || width % 2 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("sky width ", width, " must be even and in [2, ", kMaxWidth, "]"));
  }
  SHRM_ASSIGN_OR_RETURN(const SkyModel model, SkyModel::Create(sun_dir, options));
  const int w = width, h = width / 2, upper = h / 2;
  image->width = w;
  image->height = h;
  image->channels = 3;
  image->replaced_non_finite = 0;
  image->pixels.resize(static_cast<size_t>(w) * h * 3);
  float* px = image->pixels.data();

  std::vector<double> sin_p(w), cos_p(w);
  for (int i = 0; i < w; ++i) {
    const double p = 2 * kPi * ((i + 0.5) / w - 0.5);
    sin_p[i] = std::sin(p);
    cos_p[i] = std::cos(p);
  }
  const bool need_weights = options.sun_disc || options.ground_albedo > 0;
  std::shared_ptr<const RingQuadrature> fejer;
  if (need_weights) fejer = CachedFejer(h);
  const double column_omega = 2 * kPi / w;

  // The sky, row by row: the theta factor 1 + A e^{B / cos theta} once per row and channel.
  const Vec3 s = ModelSunDir(model.sun_dir());
  const std::array<PerezCoefficients, 3> pc = {model.perez(SkyChannel::kLuminanceY),
                                               model.perez(SkyChannel::kChromaX),
                                               model.perez(SkyChannel::kChromaY)};
  const ZenithValues& z = model.zenith();
  const double th0 = model.model_sun_zenith_rad();
  const std::array<double, 3> scale0 = {z.Y_kcd / PerezF(pc[0], 0, th0),
                                        z.x / PerezF(pc[1], 0, th0), z.y / PerezF(pc[2], 0, th0)};
  const double k_out = model.twilight_factor() * options.scale;
  std::array<double, 3> ground_sum{};  // sum over upper pixels of L cos theta dw
  for (int j = 0; j < upper; ++j) {
    const double theta = kPi * (j + 0.5) / h;
    const double st = std::sin(theta), ct = std::cos(theta);
    std::array<double, 3> row;
    for (int c = 0; c < 3; ++c) row[c] = (1 + pc[c].A * std::exp(pc[c].B / ct)) * scale0[c];
    std::array<double, 3> row_sum{};
    float* out = px + static_cast<size_t>(j) * w * 3;
    for (int i = 0; i < w; ++i) {
      const double cg = Clamp1(st * sin_p[i] * s.x + ct * s.y - st * cos_p[i] * s.z);
      const double gamma = std::acos(cg);
      const double cg2 = cg * cg;
      const double lum = row[0] * (1 + pc[0].C * std::exp(pc[0].D * gamma) + pc[0].E * cg2);
      const double x = row[1] * (1 + pc[1].C * std::exp(pc[1].D * gamma) + pc[1].E * cg2);
      const double y = row[2] * (1 + pc[2].C * std::exp(pc[2].D * gamma) + pc[2].E * cg2);
      const std::array<double, 3> rgb = LinearRec709FromXyy(x, y, lum);
      for (int c = 0; c < 3; ++c) {
        const double v = std::max(0.0, rgb[c]) * k_out;
        out[i * 3 + c] = static_cast<float>(v);
        row_sum[c] += v;
      }
    }
    if (need_weights) {
      const double wr = fejer->weight[j] * column_omega * ct;
      for (int c = 0; c < 3; ++c) ground_sum[c] += row_sum[c] * wr;
    }
  }

  // The sun: a uniform disc of angular radius max(true, sun_min_radius_px polar pixels) whose
  // pixels' quadrature weights sum to the disc's; the part below the horizon is hidden by the
  // ground (its share of the integral with it). Drawn while part of the true disc is up.
  if (options.sun_disc && model.sun_elevation_rad() > -kSunAngularRadiusRad) {
    const Vec3& sd = model.sun_dir();
    const double theta_s = std::acos(Clamp1(sd.y));
    const double radius = std::max(kSunAngularRadiusRad, options.sun_min_radius_px * kPi / h);
    const double cos_r = std::cos(radius);
    const int j_lo = std::max(0, static_cast<int>(std::ceil(h * (theta_s - radius) / kPi - 0.5)));
    const int j_hi =
        std::min(h - 1, static_cast<int>(std::floor(h * (theta_s + radius) / kPi - 0.5)));
    std::vector<std::pair<int, int>> covered;
    double total_omega = 0;
    for (int j = j_lo; j <= j_hi; ++j) {
      const double theta = kPi * (j + 0.5) / h;
      const double st = std::sin(theta), ct = std::cos(theta);
      for (int i = 0; i < w; ++i) {
        if (st * sin_p[i] * sd.x + ct * sd.y - st * cos_p[i] * sd.z >= cos_r) {
          covered.emplace_back(i, j);
          total_omega += fejer->weight[j] * column_omega;
        }
      }
    }
    if (covered.empty()) {
      // A disc narrower than the pixel pitch between centres: the pixel holding the sun.
      const int j = std::clamp(static_cast<int>(theta_s / kPi * h), 0, h - 1);
      const double u = std::atan2(sd.x, -sd.z) / (2 * kPi) + 0.5;
      const int i = std::clamp(static_cast<int>(u * w), 0, w - 1);
      covered.emplace_back(i, j);
      total_omega = fejer->weight[j] * column_omega;
    }
    const std::array<double, 3> integral = model.SunIntegralRgb();
    for (const auto& [i, j] : covered) {
      if (j >= upper) continue;
      const double ct = std::cos(kPi * (j + 0.5) / h);
      const double wr = fejer->weight[j] * column_omega * ct;
      float* p = px + (static_cast<size_t>(j) * w + i) * 3;
      for (int c = 0; c < 3; ++c) {
        const double v = integral[c] / total_omega;
        p[c] = static_cast<float>(p[c] + v);
        ground_sum[c] += v * wr;
      }
    }
  }

  // The ground: a Lambertian plane lit by the upper half.
  std::array<float, 3> ground{};
  for (int c = 0; c < 3; ++c) {
    ground[c] = static_cast<float>(options.ground_albedo / kPi * ground_sum[c]);
  }
  for (size_t k = static_cast<size_t>(upper) * w; k < static_cast<size_t>(h) * w; ++k) {
    px[k * 3 + 0] = ground[0];
    px[k * 3 + 1] = ground[1];
    px[k * 3 + 2] = ground[2];
  }
  // A scale that takes the brightest values (the sun's pixels, ~1e6 kcd/m^2 in the model's
  // units) beyond single precision would give a map of infinities, which every reader rejects.
  const size_t values = image->pixels.size();
  bool finite = true;
  for (size_t k = 0; k < values; ++k) finite &= std::isfinite(px[k]);
  if (!finite) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "scale %g takes the sky's brightest values beyond single precision's range (%g): give "
        "a smaller scale",
        options.scale, static_cast<double>(std::numeric_limits<float>::max())));
  }
  return absl::OkStatus();
}

absl::StatusOr<Image> RenderSkyLatLong(const Vec3& sun_dir, const SkyOptions& options, int width) {
  Image image;
  SHRM_RETURN_IF_ERROR(RenderSkyLatLongInto(sun_dir, options, width, &image));
  return image;
}

}  // namespace shrm::sky
