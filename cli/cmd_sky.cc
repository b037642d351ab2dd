// `shrm sky` (docs/cli.md, docs/sky.md): the Preetham daylight sky for a date, time and place (or
// a sun direction given directly) as a float32 lat-long EXR, and the sun's position.
//
// Exit codes: malformed or conflicting options (not a number, a date not in YYYY-MM-DD form,
// --sun-elevation without --sun-azimuth, --meridian with --utc-offset) are usage errors (2);
// values the model or the sun position refuses (turbidity outside [2, 10], latitude outside
// [-90, 90], a date that does not exist, an odd width) and unwritable outputs are input errors
// (1), each checked before any work (core/envmap/sky.h states every range once).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "core/base/status_macros.h"
#include "core/envmap/sky.h"
#include "core/io/image.h"

namespace shrm::cli {
namespace {

constexpr double kDeg = kPi / 180;

struct SkyArgs {
  std::string date;  // YYYY-MM-DD
  std::optional<int> day;
  std::string time = "12:00";
  double lat = 0;
  double lon = 0;
  std::optional<double> meridian;
  std::optional<double> utc_offset;
  std::optional<double> sun_elevation;
  std::optional<double> sun_azimuth;
  double turbidity = sky::SkyOptions{}.turbidity;
  int width = 1024;
  bool no_sun = false;
  double sun_min_radius = sky::SkyOptions{}.sun_min_radius_px;
  double ground_albedo = sky::SkyOptions{}.ground_albedo;
  double scale = sky::SkyOptions{}.scale;
  std::string output;
  bool json = false;
};

struct Date {
  int year = 0, month = 0, day = 0;
};

// "YYYY-MM-DD" (digits only; whether the date exists is checked by sky::DayOfYear).
std::optional<Date> ParseDate(const std::string& s) {
  const std::vector<std::string> parts = absl::StrSplit(s, '-');
  if (parts.size() != 3 || parts[0].size() != 4 || parts[1].size() != 2 || parts[2].size() != 2) {
    return std::nullopt;
  }
  Date d;
  for (const std::string& p : parts)
    for (char c : p)
      if (!absl::ascii_isdigit(static_cast<unsigned char>(c))) return std::nullopt;
  if (!absl::SimpleAtoi(parts[0], &d.year) || !absl::SimpleAtoi(parts[1], &d.month) ||
      !absl::SimpleAtoi(parts[2], &d.day)) {
    return std::nullopt;
  }
  return d;
}

// "H:MM" or "H:MM:SS" (hours 1-2 digits, minutes and seconds 00-59) -> hours.
std::optional<double> ParseTime(const std::string& s) {
  const std::vector<std::string> parts = absl::StrSplit(s, ':');
  if (parts.size() < 2 || parts.size() > 3 || parts[0].empty() || parts[0].size() > 2) {
    return std::nullopt;
  }
  int v[3] = {0, 0, 0};
  for (size_t k = 0; k < parts.size(); ++k) {
    if (k > 0 && parts[k].size() != 2) return std::nullopt;
    for (char c : parts[k])
      if (!absl::ascii_isdigit(static_cast<unsigned char>(c))) return std::nullopt;
    if (!absl::SimpleAtoi(parts[k], &v[k])) return std::nullopt;
    if (k > 0 && v[k] > 59) return std::nullopt;
  }
  return v[0] + v[1] / 60.0 + v[2] / 3600.0;
}

const CLI::Validator kDateText(
    [](std::string& s) -> std::string {
      return ParseDate(s) ? "" : "'" + s + "' is not a date in the form YYYY-MM-DD";
    },
    "YYYY-MM-DD");
const CLI::Validator kTimeText(
    [](std::string& s) -> std::string {
      return ParseTime(s) ? "" : "'" + s + "' is not a time in the form HH:MM or HH:MM:SS";
    },
    "HH:MM");

std::string ClockText(double hours) {
  int minutes = static_cast<int>(std::lround(hours * 60)) % (24 * 60);
  if (minutes < 0) minutes += 24 * 60;
  return absl::StrFormat("%02d:%02d", minutes / 60, minutes % 60);
}

absl::Status RunSky(const SkyArgs& a) {
  // Everything is checked before any work: options, sun, then the output's folder.
  sky::SkyOptions options;
  options.turbidity = a.turbidity;
  options.sun_disc = !a.no_sun;
  options.sun_min_radius_px = a.sun_min_radius;
  options.ground_albedo = a.ground_albedo;
  options.scale = a.scale;
  SHRM_RETURN_IF_ERROR(sky::ValidateSkyOptions(options));
  if (a.width < 2 || a.width > 16384 || a.width % 2 != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("--width ", a.width, " must be even and in [2, 16384]"));
  }
  SHRM_RETURN_IF_ERROR(
      CheckOutputExtension(a.output, "--output", {".exr"}, "the sky is written as OpenEXR"));

  sky::SunPosition sun;
  std::optional<int> day;
  sky::SunInput in;
  const bool direct = a.sun_elevation.has_value();
  if (direct) {
    if (!std::isfinite(*a.sun_elevation) || std::abs(*a.sun_elevation) > 90) {
      return absl::InvalidArgumentError(
          absl::StrFormat("--sun-elevation %g is outside [-90, 90] deg", *a.sun_elevation));
    }
    if (!std::isfinite(*a.sun_azimuth)) {
      return absl::InvalidArgumentError("--sun-azimuth must be a finite number of degrees");
    }
    sun.zenith_rad = (90 - *a.sun_elevation) * kDeg;
    double az = std::fmod(*a.sun_azimuth, 360.0);
    if (az < 0) az += 360;
    sun.azimuth_rad = az * kDeg;
  } else {
    if (!a.date.empty()) {
      const std::optional<Date> d = ParseDate(a.date);  // the validator accepted the form
      absl::StatusOr<int> j = sky::DayOfYear(d->year, d->month, d->day);
      if (!j.ok())
        return absl::InvalidArgumentError(absl::StrCat("--date: ", j.status().message()));
      day = *j;
    } else {
      day = a.day.value_or(sky::SunInput{}.day_of_year);
    }
    in.day_of_year = *day;
    in.standard_time_h = *ParseTime(a.time);
    in.latitude_deg = a.lat;
    in.longitude_deg = a.lon;
    if (a.meridian) {
      in.standard_meridian_deg = *a.meridian;
    } else if (a.utc_offset) {
      if (!std::isfinite(*a.utc_offset) || std::abs(*a.utc_offset) > 12) {
        return absl::InvalidArgumentError(
            absl::StrFormat("--utc-offset %g is outside [-12, 12] h", *a.utc_offset));
      }
      in.standard_meridian_deg = 15 * *a.utc_offset;
    } else if (std::isfinite(a.lon)) {
      // The nominal time zone of the longitude.
      in.standard_meridian_deg = 15 * std::round(a.lon / 15);
    }
    absl::StatusOr<sky::SunPosition> s = sky::ComputeSunPosition(in);
    if (!s.ok()) return absl::InvalidArgumentError(absl::StrCat("sun: ", s.status().message()));
    sun = *s;
  }
  const Vec3 dir = sky::SunDirection(sun);
  SHRM_ASSIGN_OR_RETURN(const sky::SkyModel model, sky::SkyModel::Create(dir, options));
  SHRM_RETURN_IF_ERROR(CheckOutputPath(a.output, "--output"));

  double render_ms = 0;
  if (!a.output.empty()) {
    const auto start = std::chrono::steady_clock::now();
    SHRM_ASSIGN_OR_RETURN(const Image image, sky::RenderSkyLatLong(dir, options, a.width));
    render_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    SHRM_RETURN_IF_ERROR(WriteExr(a.output, image));  // atomic: temporary + rename
  }

  const double elevation = 90 - sun.zenith_rad / kDeg;
  const double azimuth = sun.azimuth_rad / kDeg;
  const sky::ZenithValues& z = model.zenith();
  const std::array<double, 3> sun_rgb = model.SunRgb();
  if (a.json) {
    nlohmann::json j;
    nlohmann::json js = {{"elevation_deg", elevation},
                         {"azimuth_deg", azimuth},
                         {"zenith_deg", sun.zenith_rad / kDeg},
                         {"direction", {dir.x, dir.y, dir.z}}};
    if (!direct) {
      js["day_of_year"] = *day;
      js["standard_time_h"] = in.standard_time_h;
      js["standard_meridian_deg"] = in.standard_meridian_deg;
      js["solar_time_h"] = sun.solar_time_h;
      js["declination_deg"] = sun.declination_rad / kDeg;
    }
    j["sun"] = js;
    j["sky"] = {{"model", "Preetham 1999"},
                {"turbidity", options.turbidity},
                {"zenith_luminance_kcd_m2", z.Y_kcd * model.twilight_factor()},
                {"zenith_chromaticity", {z.x, z.y}},
                {"twilight_factor", model.twilight_factor()},
                {"sun_disc_rgb", {sun_rgb[0], sun_rgb[1], sun_rgb[2]}},
                {"ground_albedo", options.ground_albedo},
                {"scale", options.scale}};
    if (!a.output.empty()) {
      j["output"] = a.output;
      j["width"] = a.width;
      j["height"] = a.width / 2;
      j["render_ms"] = render_ms;
    }
    std::printf("%s\n", j.dump(2).c_str());
    return absl::OkStatus();
  }
  std::printf("sun: elevation %.2f deg, azimuth %.2f deg (from north towards east)", elevation,
              azimuth);
  if (!direct) {
    std::printf(", day %d, solar time %s, declination %.2f deg", *day,
                ClockText(sun.solar_time_h).c_str(), sun.declination_rad / kDeg);
  }
  std::printf("\n  direction (%.6f, %.6f, %.6f) (x east, y up, -z north)\n", dir.x, dir.y, dir.z);
  if (elevation < 0) {
    std::printf(
        "  below the horizon: the sky of a sun on the horizon x %.3f (twilight fade to "
        "%g deg below; docs/sky.md)\n",
        model.twilight_factor(), sky::kTwilightDepthDeg);
  }
  std::printf("sky: Preetham, turbidity %g, zenith luminance %.4g kcd/m^2\n", options.turbidity,
              z.Y_kcd * model.twilight_factor());
  if (!a.output.empty()) {
    std::printf("wrote %s: %d x %d lat-long, linear Rec.709, luminance in kcd/m^2 x %g (%.1f ms)\n",
                a.output.c_str(), a.width, a.width / 2, options.scale, render_ms);
  }
  return absl::OkStatus();
}

}  // namespace

void DefineSky(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<SkyArgs>();
  CLI::Option* date =
      sub->add_option("--date", args->date, "date YYYY-MM-DD (default: day 80, about March 21)")
          ->check(kDateText);
  CLI::Option* day =
      sub->add_option("--day", args->day, "day of the year 1..366 instead of --date");
  CLI::Option* time = sub->add_option("--time", args->time, "local standard time HH:MM[:SS]")
                          ->capture_default_str()
                          ->check(kTimeText);
  CLI::Option* lat =
      sub->add_option("--lat", args->lat, "latitude, degrees north")->capture_default_str();
  CLI::Option* lon =
      sub->add_option("--lon", args->lon, "longitude, degrees EAST")->capture_default_str();
  CLI::Option* meridian = sub->add_option(
      "--meridian", args->meridian,
      "standard meridian of the time zone, degrees east (default: 15 x round(lon / 15))");
  CLI::Option* utc = sub->add_option("--utc-offset", args->utc_offset,
                                     "time zone as hours from UTC instead of --meridian");
  CLI::Option* elev = sub->add_option("--sun-elevation", args->sun_elevation,
                                      "the sun's elevation in degrees, instead of date/time/place");
  CLI::Option* azim = sub->add_option("--sun-azimuth", args->sun_azimuth,
                                      "the sun's azimuth in degrees from north towards east");
  date->excludes(day);
  meridian->excludes(utc);
  elev->needs(azim);
  azim->needs(elev);
  for (CLI::Option* o : {date, day, time, lat, lon, meridian, utc}) elev->excludes(o);
  sub->add_option("--turbidity", args->turbidity, "atmospheric turbidity T, 2..10")
      ->capture_default_str();
  sub->add_option("--width", args->width, "map width W (even; the map is W x W/2)")
      ->capture_default_str();
  sub->add_flag("--no-sun", args->no_sun, "no sun disc (the sky only)");
  sub->add_option("--sun-min-radius", args->sun_min_radius,
                  "the sun disc's minimum radius in pixels (its integral is kept)")
      ->capture_default_str();
  sub->add_option("--ground-albedo", args->ground_albedo,
                  "albedo of the Lambertian ground below the horizon (0 = black)")
      ->capture_default_str();
  sub->add_option("--scale", args->scale, "multiply the values (kcd/m^2) by this")
      ->capture_default_str();
  sub->add_option("-o,--output", args->output,
                  "output float32 lat-long EXR (without it, only the sun's position is printed)");
  sub->add_flag("--json", args->json, "machine-readable output");
  sub->callback([args, status] { *status = RunSky(*args); });
}

}  // namespace shrm::cli
