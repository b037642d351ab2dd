#include "jobs/report_html.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "core/base/geometry.h"
#include "jobs/report_visuals.h"

namespace shrm::jobs {
namespace {

using nlohmann::json;

std::string Esc(const std::string& s) {
  return absl::StrReplaceAll(
      s, {{"&", "&amp;"}, {"<", "&lt;"}, {">", "&gt;"}, {"\"", "&quot;"}, {"'", "&#39;"}});
}

// A number for people: 4 significant digits, no exponent between 1e-3 and 1e6.
std::string Num(double v) {
  if (!std::isfinite(v)) return "-";
  if (v != 0 && (std::abs(v) < 1e-3 || std::abs(v) >= 1e6)) return absl::StrFormat("%.3g", v);
  return absl::StrFormat("%.4g", v);
}
std::string Pct(double v) {
  return 100 * v < 1000 ? absl::StrFormat("%.3g%%", 100 * v) : absl::StrFormat("%.0f%%", 100 * v);
}
std::string Px(double v) { return absl::StrFormat("%.1f", v); }

double Get(const json& j, const char* key, double fallback = NAN) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return fallback;
  return j[key].get<double>();
}
std::string GetText(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key)) return "";
  if (j[key].is_string()) return j[key].get<std::string>();
  if (j[key].is_array()) {
    std::vector<std::string> parts;
    for (const json& e : j[key])
      if (e.is_string()) parts.push_back(e.get<std::string>());
    return absl::StrJoin(parts, ", ");
  }
  return j[key].dump();
}

// ---- SVG plots ------------------------------------------------------------------------------
// Line styles that differ in grey scale: dash pattern and marker shape.
struct LineStyle {
  const char* dash;    // stroke-dasharray ("" = solid)
  const char* marker;  // "circle", "square", "triangle", "diamond", "none"
  const char* colour;
};
constexpr LineStyle kStyles[] = {{"", "circle", "#1b1b1b"},
                                 {"6 3", "square", "#3b5b9a"},
                                 {"2 3", "triangle", "#9a3b3b"},
                                 {"8 3 2 3", "diamond", "#3b8a4a"},
                                 {"12 4", "none", "#7a5a1a"}};

std::string Marker(const LineStyle& s, double x, double y) {
  const std::string c = s.colour;
  if (std::string(s.marker) == "circle")
    return absl::StrCat("<circle cx='", Px(x), "' cy='", Px(y), "' r='3' fill='", c, "'/>");
  if (std::string(s.marker) == "square")
    return absl::StrCat("<rect x='", Px(x - 3), "' y='", Px(y - 3), "' width='6' height='6' fill='",
                        c, "'/>");
  if (std::string(s.marker) == "triangle")
    return absl::StrCat("<path d='M", Px(x), " ", Px(y - 4), "L", Px(x + 3.5), " ", Px(y + 3), "L",
                        Px(x - 3.5), " ", Px(y + 3), "Z' fill='", c, "'/>");
  if (std::string(s.marker) == "diamond")
    return absl::StrCat("<path d='M", Px(x), " ", Px(y - 4), "L", Px(x + 4), " ", Px(y), "L", Px(x),
                        " ", Px(y + 4), "L", Px(x - 4), " ", Px(y), "Z' fill='", c, "'/>");
  return "";
}

// An x-y plot: linear x, linear or log y.
class Plot {
 public:
  Plot(std::string title, std::string x_label, std::string y_label, bool log_y)
      : title_(std::move(title)),
        x_label_(std::move(x_label)),
        y_label_(std::move(y_label)),
        log_y_(log_y) {}
  void SetX(double lo, double hi) { x_lo_ = lo, x_hi_ = hi; }
  void SetY(double lo, double hi) { y_lo_ = lo, y_hi_ = hi; }
  // `marker_every`: a marker on every k-th point.
  void Line(const std::vector<double>& x, const std::vector<double>& y, const std::string& label,
            int style, int marker_every = 1) {
    series_.push_back({x, y, label, style, std::max(marker_every, 1)});
  }
  void VLine(double x, const std::string& label) { vlines_.push_back({x, label}); }
  void HLine(double y, const std::string& label) { hlines_.push_back({y, label}); }

  std::string Svg(const std::string& id) const {
    std::string s = absl::StrCat(
        "<svg id='", id, "' class='plot' viewBox='0 0 ", kW, " ", kH, "' width='", kW, "' height='",
        kH, "' xmlns='http://www.w3.org/2000/svg' role='img'><title>", Esc(title_), "</title>");
    absl::StrAppend(&s, "<rect x='", kL, "' y='", kT, "' width='", kW - kL - kR, "' height='",
                    kH - kT - kB, "' fill='white' stroke='#444'/>");
    absl::StrAppend(&s, "<text x='", kW / 2, "' y='16' class='ptitle'>", Esc(title_), "</text>");
    // x ticks: about 8, at a 1-2-5 step.
    const double step = NiceStep((x_hi_ - x_lo_) / 8);
    for (double x = std::ceil(x_lo_ / step) * step; x <= x_hi_ + 1e-9; x += step) {
      const double px = X(x);
      absl::StrAppend(&s, "<line x1='", Px(px), "' y1='", kT, "' x2='", Px(px), "' y2='", kH - kB,
                      "' class='grid'/><text x='", Px(px), "' y='", kH - kB + 16, "' class='tick'>",
                      Num(x), "</text>");
    }
    if (log_y_) {
      for (int e = static_cast<int>(std::floor(std::log10(y_lo_)));
           e <= static_cast<int>(std::ceil(std::log10(y_hi_))); ++e) {
        const double v = std::pow(10.0, e);
        if (v < y_lo_ * 0.999 || v > y_hi_ * 1.001) continue;
        const double py = Y(v);
        absl::StrAppend(&s, "<line x1='", kL, "' y1='", Px(py), "' x2='", kW - kR, "' y2='", Px(py),
                        "' class='grid'/><text x='", kL - 6, "' y='", Px(py + 4),
                        "' class='ytick'>1e", e, "</text>");
      }
    } else {
      const double ystep = NiceStep((y_hi_ - y_lo_) / 6);
      for (double y = std::ceil(y_lo_ / ystep) * ystep; y <= y_hi_ + 1e-12; y += ystep) {
        const double py = Y(y);
        absl::StrAppend(&s, "<line x1='", kL, "' y1='", Px(py), "' x2='", kW - kR, "' y2='", Px(py),
                        "' class='grid'/><text x='", kL - 6, "' y='", Px(py + 4),
                        "' class='ytick'>", Num(y), "</text>");
      }
    }
    absl::StrAppend(&s, "<text x='", (kL + kW - kR) / 2, "' y='", kH - 8, "' class='axis'>",
                    Esc(x_label_), "</text><text transform='translate(14 ", (kT + kH - kB) / 2,
                    ") rotate(-90)' class='axis'>", Esc(y_label_), "</text>");
    for (const auto& [x, label] : vlines_) {
      const bool right = X(x) > kL + 0.75 * (kW - kL - kR);  // label on the left of the line
      absl::StrAppend(&s, "<line x1='", Px(X(x)), "' y1='", kT, "' x2='", Px(X(x)), "' y2='",
                      kH - kB, "' class='mark'/><text x='", Px(X(x) + (right ? -4 : 4)), "' y='",
                      kT + 12, "' class='marklabel' text-anchor='", right ? "end" : "start", "'>",
                      Esc(label), "</text>");
    }
    for (const auto& [y, label] : hlines_) {
      absl::StrAppend(&s, "<line x1='", kL, "' y1='", Px(Y(y)), "' x2='", kW - kR, "' y2='",
                      Px(Y(y)), "' class='mark'/><text x='", kW - kR - 4, "' y='", Px(Y(y) - 4),
                      "' class='marklabel' text-anchor='end'>", Esc(label), "</text>");
    }
    // Clip the curves to the plot area.
    absl::StrAppend(&s, "<clipPath id='", id, "-clip'><rect x='", kL, "' y='", kT, "' width='",
                    kW - kL - kR, "' height='", kH - kT - kB, "'/></clipPath><g clip-path='url(#",
                    id, "-clip)'>");
    for (const Series& ser : series_) {
      const LineStyle& st = kStyles[ser.style % std::size(kStyles)];
      std::string pts;
      std::string markers;
      for (size_t i = 0; i < ser.x.size(); ++i) {
        const double y = log_y_ ? std::max(ser.y[i], y_lo_ * 0.5) : ser.y[i];
        if (!std::isfinite(y)) continue;
        absl::StrAppend(&pts, Px(X(ser.x[i])), ",", Px(Y(y)), " ");
        if (i % ser.marker_every == 0) absl::StrAppend(&markers, Marker(st, X(ser.x[i]), Y(y)));
      }
      absl::StrAppend(&s, "<polyline points='", pts, "' fill='none' stroke='", st.colour,
                      "' stroke-width='1.6' stroke-dasharray='", st.dash, "'/>", markers);
    }
    absl::StrAppend(&s, "</g>");
    // Legend, bottom left inside the plot (errors fall with the order: that corner is free),
    // on a translucent white box.
    double ly = kH - kB - 15.0 * series_.size() + 8;
    absl::StrAppend(&s, "<rect x='", kL + 4, "' y='", Px(ly - 13), "' width='250' height='",
                    15 * series_.size() + 4, "' fill='white' fill-opacity='0.85'/>");
    for (const Series& ser : series_) {
      const LineStyle& st = kStyles[ser.style % std::size(kStyles)];
      const double lx = kL + 8;
      absl::StrAppend(&s, "<line x1='", Px(lx), "' y1='", Px(ly - 4), "' x2='", Px(lx + 30),
                      "' y2='", Px(ly - 4), "' stroke='", st.colour,
                      "' stroke-width='1.6' stroke-dasharray='", st.dash, "'/>",
                      Marker(st, lx + 15, ly - 4), "<text x='", Px(lx + 36), "' y='", Px(ly),
                      "' class='legend'>", Esc(ser.label), "</text>");
      ly += 15;
    }
    absl::StrAppend(&s, "</svg>");
    return s;
  }

 private:
  static constexpr int kW = 600, kH = 340, kL = 64, kR = 16, kT = 26, kB = 44;
  struct Series {
    std::vector<double> x, y;
    std::string label;
    int style;
    int marker_every;
  };
  static double NiceStep(double raw) {
    if (!(raw > 0)) return 1;
    const double p = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0})
      if (m * p >= raw) return m * p;
    return 10 * p;
  }
  double X(double x) const {
    return kL + (x - x_lo_) / std::max(x_hi_ - x_lo_, 1e-12) * (kW - kL - kR);
  }
  double Y(double y) const {
    const double t = log_y_ ? (std::log10(y) - std::log10(y_lo_)) /
                                  std::max(std::log10(y_hi_) - std::log10(y_lo_), 1e-12)
                            : (y - y_lo_) / std::max(y_hi_ - y_lo_, 1e-300);
    return kH - kB - t * (kH - kT - kB);
  }

  std::string title_, x_label_, y_label_;
  bool log_y_;
  double x_lo_ = 0, x_hi_ = 1, y_lo_ = 0, y_hi_ = 1;
  std::vector<Series> series_;
  std::vector<std::pair<double, std::string>> vlines_, hlines_;
};

// Fig. 5.5 of the SHRM paper for this map and BRDF, as errors (1 - accuracy) on a log axis.
std::string AccuracyPlot(const json& report) {
  const json& curves = report.value("curves", json::array());
  if (!curves.is_array() || curves.empty()) return "<p>No accuracy curves in the report.</p>";
  // Series: key of the curve point, label.
  const std::pair<const char*, const char*> kCurves[] = {
      {"light", "lighting: 1 - captured energy (eq. 5.16)"},
      {"brdf", "BRDF at P_B: 1 - captured energy"},
      {"B", "B: 1 - E_B(F) / E_B(reference)"},
      {"min_estimate", "estimate: min(eps_L, eps_rho)"},
      {"bound", "bound (eq. 5.19)"}};
  constexpr double kFloor = 1e-8;  // errors below are drawn at the axis' bottom
  std::string map = GetText(report, "source");
  map = map.substr(map.find_last_of('/') + 1);  // the file name (the whole path is above)
  Plot plot(absl::StrCat("Fig. 5.5 (as error): ", map, " x ", GetText(report, "brdf")), "order F",
            "error = 1 - captured energy (log)", /*log_y=*/true);
  double lo = 1, hi = kFloor;
  std::vector<double> x;
  for (const json& p : curves) x.push_back(Get(p, "F", 0));
  int style = 0;
  for (const auto& [key, label] : kCurves) {
    std::vector<double> y;
    for (const json& p : curves) {
      const double e = 1 - Get(p, key, 1);
      y.push_back(std::max(e, kFloor));
      if (e > kFloor) lo = std::min(lo, e), hi = std::max(hi, e);
    }
    plot.Line(x, y, label, style++, std::max<int>(1, static_cast<int>(x.size()) / 16));
  }
  const double eps = Get(report, "epsilon");
  if (std::isfinite(eps) && eps > 0) {
    plot.HLine(eps, absl::StrCat("epsilon ", Num(eps)));
    lo = std::min(lo, eps), hi = std::max(hi, eps);
  }
  plot.SetX(x.front(), std::max(x.back(), Get(report, "F_B", 0)) + 1);
  plot.SetY(std::max(kFloor, std::pow(10.0, std::floor(std::log10(lo)))),
            std::min(1.0, std::pow(10.0, std::ceil(std::log10(hi)))));
  plot.VLine(Get(report, "F_B", 0), absl::StrCat("F_B = ", report.value("F_B", 0)));
  return plot.Svg("accuracy-plot");
}

// The BRDF's transfer (BRDF x cos) in the plane of incidence, one curve per view angle, as a
// polar plot (normal up), each normalized to the largest value of all three.
std::string LobePlot(const json& lobe, const std::string& brdf) {
  const json& thetas = lobe.value("theta_deg", json::array());
  const json& values = lobe.value("values", json::array());
  const json& views = lobe.value("views_deg", json::array());
  constexpr int kW = 440, kH = 240, kR = 180, kCx = kW / 2, kCy = kH - 24;
  double peak = 0;
  for (const json& row : values)
    for (const json& v : row) peak = std::max(peak, std::abs(v.get<double>()));
  std::string s = absl::StrCat(
      "<svg id='lobe-plot' class='plot' viewBox='0 0 ", kW, " ", kH + 30, "' width='", kW,
      "' height='", kH + 30,
      "' xmlns='http://www.w3.org/2000/svg' role='img'><title>BRDF lobe</title>", "<text x='",
      kW / 2, "' y='14' class='ptitle'>BRDF lobe: ", Esc(brdf), "</text>");
  for (double r : {0.5, 1.0})
    absl::StrAppend(&s, "<path d='M", kCx - r * kR, " ", kCy, " A", r * kR, " ", r * kR, " 0 0 1 ",
                    kCx + r * kR, " ", kCy, "' class='grid' fill='none'/>");
  absl::StrAppend(&s, "<line x1='", kCx - kR - 8, "' y1='", kCy, "' x2='", kCx + kR + 8, "' y2='",
                  kCy, "' stroke='#444'/><line x1='", kCx, "' y1='", kCy, "' x2='", kCx, "' y2='",
                  kCy - kR - 4, "' class='grid'/><text x='", kCx + 4, "' y='", kCy - kR + 8,
                  "' class='marklabel'>", lobe.value("index", "normal"), "</text>");
  for (size_t k = 0; k < values.size() && peak > 0; ++k) {
    const LineStyle& st = kStyles[k % std::size(kStyles)];
    std::string pts;
    for (size_t i = 0; i < thetas.size() && i < values[k].size(); ++i) {
      const double t = thetas[i].get<double>() * kPi / 180;
      const double r = std::max(0.0, values[k][i].get<double>()) / peak * kR;
      absl::StrAppend(&pts, Px(kCx + r * std::sin(t)), ",", Px(kCy - r * std::cos(t)), " ");
    }
    const double tv = views[k].get<double>() * kPi / 180;
    absl::StrAppend(&s, "<polyline points='", pts, "' fill='none' stroke='", st.colour,
                    "' stroke-width='1.6' stroke-dasharray='", st.dash, "'/>");
    // The view direction, on the other side of the normal from the mirror direction.
    absl::StrAppend(&s, "<line x1='", kCx, "' y1='", kCy, "' x2='", Px(kCx + kR * std::sin(tv)),
                    "' y2='", Px(kCy - kR * std::cos(tv)), "' stroke='", st.colour,
                    "' stroke-width='0.8' stroke-dasharray='1 3'/>",
                    Marker(st, kCx + kR * std::sin(tv), kCy - kR * std::cos(tv)));
  }
  double ly = kH + 4;
  for (size_t k = 0; k < views.size(); ++k) {
    const LineStyle& st = kStyles[k % std::size(kStyles)];
    const double lx = 10 + 125 * k;
    absl::StrAppend(&s, "<line x1='", lx, "' y1='", ly, "' x2='", lx + 26, "' y2='", ly,
                    "' stroke='", st.colour, "' stroke-width='1.6' stroke-dasharray='", st.dash,
                    "'/>", Marker(st, lx + 13, ly), "<text x='", lx + 32, "' y='", ly + 4,
                    "' class='legend'>view ", Num(views[k].get<double>()), " deg</text>");
  }
  absl::StrAppend(
      &s, "<text x='", kW / 2, "' y='", kH + 24,
      "' class='tick'>radius: BRDF x cos / its largest value; dotted: the views</text>");
  absl::StrAppend(&s, "</svg>");
  return s;
}

// Stage timings as horizontal bars.
std::string TimingsPlot(const json& timings) {
  // The pipeline's order; other stages (a front end's own) after them.
  static constexpr const char* kOrder[] = {"upload", "decode",   "lights",    "brdf",   "lighting",
                                           "orders", "analysis", "synthesis", "verify", "report",
                                           "write",  "ktx2",     "preview"};
  auto rank = [](const std::string& name) {
    for (size_t i = 0; i < std::size(kOrder); ++i)
      if (absl::StartsWith(name, kOrder[i])) return static_cast<int>(i);
    return static_cast<int>(std::size(kOrder));
  };
  std::vector<std::pair<std::string, double>> rows;
  for (const auto& [k, v] : timings.items()) {
    if (!v.is_number()) continue;
    std::string name = k;
    if (absl::EndsWith(name, "_ms")) name.resize(name.size() - 3);
    rows.push_back({name, v.get<double>()});
  }
  std::stable_sort(rows.begin(), rows.end(),
                   [&](const auto& a, const auto& b) { return rank(a.first) < rank(b.first); });
  if (rows.empty()) return "<p>No timings.</p>";
  double peak = 0, total = 0;
  for (const auto& [n, ms] : rows) peak = std::max(peak, ms), total += ms;
  constexpr int kW = 600, kRow = 20, kL = 130, kR = 90;
  const int h = kRow * static_cast<int>(rows.size()) + 40;
  std::string s = absl::StrCat(
      "<svg id='timings-plot' class='plot' viewBox='0 0 ", kW, " ", h, "' width='", kW,
      "' height='", h,
      "' xmlns='http://www.w3.org/2000/svg' role='img'><title>Stage timings</title><text x='",
      kW / 2, "' y='14' class='ptitle'>Stage timings (ms, wall clock; total ", Num(total),
      " ms)</text>");
  for (size_t i = 0; i < rows.size(); ++i) {
    const double y = 24 + kRow * i;
    const double w = peak > 0 ? rows[i].second / peak * (kW - kL - kR) : 0;
    absl::StrAppend(&s, "<text x='", kL - 6, "' y='", y + 13, "' class='ytick'>",
                    Esc(rows[i].first), "</text><rect x='", kL, "' y='", y + 2, "' width='",
                    Px(std::max(w, 0.5)), "' height='", kRow - 6, "' fill='#5a6a8a'/><text x='",
                    Px(kL + w + 4), "' y='", y + 13, "' class='legend'>", Num(rows[i].second),
                    " ms</text>");
  }
  absl::StrAppend(&s, "</svg>");
  return s;
}

// The error scale as a bar with labels (decades).
std::string ErrorScaleSvg() {
  constexpr int kW = 360, kH = 44, kL = 10, kBar = 340;
  std::string s = absl::StrCat("<svg class='scale' viewBox='0 0 ", kW, " ", kH, "' width='", kW,
                               "' height='", kH, "' xmlns='http://www.w3.org/2000/svg'>");
  for (int i = 0; i < kBar; ++i) {
    const auto c = ErrorColour((i + 0.5) / kBar);
    absl::StrAppend(&s, "<rect x='", kL + i, "' y='2' width='1.2' height='16' fill='rgb(", c[0],
                    ",", c[1], ",", c[2], ")'/>");
  }
  for (int e = static_cast<int>(kErrorScaleLow); e <= static_cast<int>(kErrorScaleHigh); ++e) {
    const double x = kL + (e - kErrorScaleLow) / (kErrorScaleHigh - kErrorScaleLow) * kBar;
    absl::StrAppend(&s, "<line x1='", Px(x), "' y1='18' x2='", Px(x), "' y2='22' stroke='#333'/>",
                    "<text x='", Px(x), "' y='34' class='tick'>",
                    e == 0 ? std::string("1") : absl::StrCat("1e", e), "</text>");
  }
  absl::StrAppend(&s, "</svg>");
  return s;
}

// The seeded pairs over the source map (lat-long of where each reflection looks), coloured by
// their error; grazing pairs drawn as squares.
std::string ErrorMapSvg(const json& visuals) {
  const json& map = visuals.value("map", json::object());
  const json& points = visuals["pairs"].value("points", json::array());
  constexpr int kW = 640, kH = 320;
  std::string s =
      absl::StrCat("<svg id='error-map' class='plot' viewBox='0 0 ", kW, " ", kH + 16, "' width='",
                   kW, "' height='", kH + 16, "' xmlns='http://www.w3.org/2000/svg' role='img'>",
                   "<title>Relative error at the seeded pairs</title>");
  if (map.contains("png")) {
    absl::StrAppend(&s, "<image x='0' y='0' width='", kW, "' height='", kH,
                    "' preserveAspectRatio='none' opacity='0.45' href='data:image/png;base64,",
                    map["png"].get<std::string>(), "'/>");
  }
  absl::StrAppend(&s, "<rect x='0' y='0' width='", kW, "' height='", kH,
                  "' fill='none' stroke='#444'/>");
  for (const json& p : points) {
    const json& d = p.value("map_direction", p.value("address", json::array()));
    if (!d.is_array() || d.size() != 3) continue;
    const double x = d[0].get<double>(), y = d[1].get<double>(), z = d[2].get<double>();
    // docs/conventions.md: u = p / (2 pi) + 1/2 with p = atan2(x, -z); v = theta / pi.
    const double u = std::atan2(x, -z) / (2 * kPi) + 0.5;
    const double v = std::acos(std::clamp(y, -1.0, 1.0)) / kPi;
    const auto c = ErrorColour(ErrorScalePosition(Get(p, "error", 0)));
    const std::string fill = absl::StrCat("rgb(", c[0], ",", c[1], ",", c[2], ")");
    if (p.value("grazing", false)) {
      absl::StrAppend(&s, "<rect x='", Px(u * kW - 4), "' y='", Px(v * kH - 4),
                      "' width='8' height='8' fill='", fill,
                      "' stroke='#000' stroke-width='0.6'/>");
    } else {
      absl::StrAppend(&s, "<circle cx='", Px(u * kW), "' cy='", Px(v * kH), "' r='4.5' fill='",
                      fill, "' stroke='#000' stroke-width='0.6'/>");
    }
  }
  absl::StrAppend(&s, "<text x='4' y='", kH + 13,
                  "' class='legend' text-anchor='start'>lat-long of the source map: centre -Z, "
                  "right +X, top +Y; circles N.V &gt;= 0.3, squares grazing</text></svg>");
  return s;
}

std::string Img(const std::string& base64, const std::string& alt, const std::string& cls,
                int width) {
  return absl::StrCat("<img class='", cls, "' alt='", Esc(alt), "' width='", width,
                      "' src='data:image/png;base64,", base64, "'>");
}

std::string Row(const std::string& k, const std::string& v) {
  return absl::StrCat("<tr><th>", Esc(k), "</th><td>", v, "</td></tr>");
}

// Why these orders: the rule that chose them, in words.
std::string WhyOrders(const json& r) {
  const int f = r.value("F_B", 0), p = r.value("P_B", 0);
  if (r.contains("tolerance")) {
    const json& t = r["tolerance"];
    const json& ro = t.value("reference_orders", json::array());
    return absl::StrCat(
        "The per-direction tolerance rule (docs/shrm.md) chose (F_B, P_B) = (", f, ", ", p,
        "): the smallest (P + 1)<sup>2</sup> (F + P + 1)<sup>2</sup> whose estimated error, "
        "measured against reference orders (",
        ro.size() == 2 ? absl::StrCat(ro[0].get<int>(), ", ", ro[1].get<int>()) : "?",
        ") at seeded pairs, meets the targets (front RMS ", Pct(Get(t["targets"], "front_rms", 0)),
        ", largest ", Pct(Get(t["targets"], "front_max", 0)),
        "), then the smallest face size whose "
        "interpolation error fits; ringing window: ",
        Esc(GetText(r, "window")), ". The paper's energy analysis below is shown for reference.");
  }
  if (GetText(r, "order_rule") == "explicit") {
    return absl::StrCat("(F_B, P_B) = (", f, ", ", p,
                        ") were given (--orders); the estimates below are at those orders.");
  }
  const std::string eps = Num(Get(r, "epsilon", 0));
  const std::string brdf = absl::StrCat("the BRDF by (F_rho, P_rho) = (", r.value("F_rho", 0), ", ",
                                        r.value("P_rho", 0), ") (eqs. 5.17-5.18)");
  const bool light_reached = r.contains("F_L") && r["F_L"].is_number_integer();
  return absl::StrCat(
      "The paper's rule (sec. 5.5) at epsilon ", eps, ": ",
      light_reached ? absl::StrCat("the lighting captures 1 - ", eps,
                                   " of its energy by F_L = ", r["F_L"].get<int>(), " (eq. 5.16), ")
                    : absl::StrCat("the lighting does not capture 1 - ", eps,
                                   " of its energy within the orders computed (eq. 5.16; F_L "
                                   "not reached), "),
      brdf, "; F_B = ", light_reached ? "min(F_L, F_rho)" : "F_rho", " = ", f,
      ", P_B = P_rho = ", p,
      ". This energy fraction is over all views and directions; the errors per direction "
      "are in the sections below.");
}

std::string Css() {
  return "body{font:14px/1.45 system-ui,sans-serif;margin:24px auto;max-width:1240px;color:#111;"
         "background:#fafafa}h1{font-size:22px;margin:0 0 4px}h2{font-size:17px;margin:26px 0 "
         "8px;border-bottom:1px solid #ccc}table{border-collapse:collapse;margin:6px 0}th,td{"
         "border:1px solid #ccc;padding:3px 8px;text-align:left;vertical-align:top}th{background:"
         "#eee;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}.row{"
         "display:flex;flex-wrap:wrap;gap:18px;align-items:flex-start}.plot text{font:11px "
         "sans-serif;fill:#222}.plot .ptitle{font-size:13px;text-anchor:middle;font-weight:600}"
         ".plot .tick{text-anchor:middle}.plot .ytick{text-anchor:end}.plot .axis{text-anchor:"
         "middle;font-size:12px}.plot .grid{stroke:#ddd;stroke-width:1}.plot .mark{stroke:#000;"
         "stroke-dasharray:4 3}.plot .legend{text-anchor:start}.scale text{font:11px sans-serif;"
         "text-anchor:middle}img.sphere{image-rendering:pixelated;background:#000}figure{margin:0}"
         "figcaption{font-size:12px;color:#333}.bad{color:#a00;font-weight:600}.ok{color:#060;"
         "font-weight:600}.muted{color:#555;font-size:12px}";
}

// `icon`: base64 PNG of the page's icon ("" = none).
std::string Head(const std::string& title, const std::string& icon = "") {
  // No network, no scripts, no external styles: images only from data: URIs.
  return absl::StrCat(
      "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
      "<meta http-equiv='Content-Security-Policy' content=\"default-src 'none'; img-src data:; "
      "style-src 'unsafe-inline'\">"
      "<meta name='viewport' content='width=device-width'><title>",
      Esc(title), "</title>",
      icon.empty() ? "" : absl::StrCat("<link rel='icon' href='data:image/png;base64,", icon, "'>"),
      "<style>", Css(), "</style></head><body>\n");
}

// The JSON block, safe inside <script> whatever the strings hold (a map path with "</script>"
// or "<!--"): no '<' appears in it, each is the JSON escape \u003c.
std::string DataBlock(const json& data) {
  return absl::StrCat("<script type='application/json' id='shrm-report-data'>",
                      absl::StrReplaceAll(data.dump(), {{"<", "\\u003c"}}), "</script>\n");
}

std::string MeasuredCell(const json& stats) {
  return absl::StrCat("RMS ", Pct(Get(stats, "rms", 0)), ", largest ", Pct(Get(stats, "max", 0)));
}

}  // namespace

std::string ReportThumbnail(const json& visuals) {
  if (!visuals.is_object() || !visuals.contains("spheres")) return "";
  return visuals["spheres"].value("thumbnail_png", "");
}

std::string ReportThumbnailFromPage(const std::string& html) {
  static constexpr char kIcon[] = "<link rel='icon' href='data:image/png;base64,";
  const size_t at = html.find(kIcon);
  if (at == std::string::npos) return "";
  const size_t start = at + sizeof(kIcon) - 1;
  const size_t end = html.find('\'', start);
  if (end == std::string::npos) return "";
  std::string b64 = html.substr(start, end - start);
  // Only base64 characters (a page edited by hand cannot inject markup into the index).
  for (char c : b64)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '+' || c == '/' || c == '='))
      return "";
  return b64;
}

std::string RenderPrefilterReportHtml(const json& report, const json& visuals) {
  const std::string source = GetText(report, "source");
  const std::string brdf = GetText(report, "brdf");
  std::string h =
      Head(absl::StrCat("shrm report: ", source, " x ", brdf), ReportThumbnail(visuals));
  absl::StrAppend(&h, "<h1>SHRM prefilter report</h1><p class='muted'>", Esc(source), " &times; ",
                  Esc(brdf), " &rarr; ", Esc(GetText(report, "output")), " (shrm ",
                  Esc(GetText(report, "shrm_version")), ")</p>\n");

  // Summary.
  absl::StrAppend(&h, "<h2 id='summary'>Summary</h2><table>");
  absl::StrAppend(
      &h, Row("map", Esc(source)),
      Row("map SHA-256", absl::StrCat("<code>", Esc(GetText(report, "source_sha256")), "</code>")),
      Row("layout", Esc(GetText(report, "layout"))), Row("BRDF", Esc(brdf)),
      Row("SHRM", absl::StrCat(Esc(GetText(report, "kind")), ", (F_B, P_B) = (",
                               report.value("F_B", 0), ", ", report.value("P_B", 0), "), faces ",
                               report.value("face_size", 0), " x ", report.value("face_size", 0))),
      Row("ringing window", Esc(GetText(report, "window"))));
  if (report.contains("measured")) {
    const json& m = report["measured"];
    std::string verdict;
    if (report.contains("tolerance")) {
      const json& tg = report["tolerance"]["targets"];
      const bool ok = Get(m["front"], "rms", 0) <= Get(tg, "front_rms", 0) &&
                      Get(m["front"], "max", 0) <= Get(tg, "front_max", 0);
      verdict = ok ? " <span class='ok'>meets the tolerance</span>"
                   : " <span class='bad'>exceeds the tolerance</span>";
    }
    absl::StrAppend(&h, Row("measured error (the job's check)",
                            absl::StrCat(m.value("pairs", 0), " pairs: front (N.V &gt;= 0.3) ",
                                         MeasuredCell(m["front"]), "; grazing ",
                                         MeasuredCell(m["grazing"]), verdict)));
  }
  if (report.contains("tolerance")) {
    const json& t = report["tolerance"];
    absl::StrAppend(
        &h,
        Row("tolerance", absl::StrCat(Num(Get(t, "tolerance", 0)), " (targets: front RMS ",
                                      Pct(Get(t["targets"], "front_rms", 0)), ", largest ",
                                      Pct(Get(t["targets"], "front_max", 0)), ")")),
        Row("estimated error",
            absl::StrCat("front ", MeasuredCell(t["estimate"]["front"]), "; grazing ",
                         MeasuredCell(t["estimate"]["grazing"]),
                         t.value("met", true) ? "" : " <span class='bad'>NOT MET</span>")));
  }
  absl::StrAppend(
      &h, Row("energy estimates",
              absl::StrCat("eps_light ", Num(Get(report, "eps_light")), ", eps_brdf ",
                           Num(Get(report, "eps_brdf")), ", eq. 5.19 bound ",
                           Num(Get(report, "eps_bound")),
                           " <span class='muted'>(fractions of squared energy over all views; the "
                           "per-direction errors above are what a viewer sees)</span>")));
  if (visuals.contains("pairs")) {
    const json& p = visuals["pairs"];
    absl::StrAppend(
        &h, Row("this report's pairs",
                absl::StrCat(p.value("count", 0), " pairs: front ", MeasuredCell(p["front"]),
                             "; grazing ", MeasuredCell(p["grazing"]))));
  }
  absl::StrAppend(&h, "</table>\n");

  // Inputs.
  absl::StrAppend(&h, "<h2 id='inputs'>Inputs</h2><div class='row'>");
  if (visuals.contains("map")) {
    absl::StrAppend(&h, "<figure>",
                    Img(visuals["map"].value("png", ""), "environment map", "map",
                        visuals["map"].value("width", kThumbnailWidth)),
                    "<figcaption>", Esc(source),
                    " (lat-long, centre -Z, right +X, top +Y; tone-mapped, exposure to mid-grey)"
                    "</figcaption></figure>");
  }
  if (visuals.contains("lobe")) absl::StrAppend(&h, LobePlot(visuals["lobe"], brdf));
  absl::StrAppend(&h, "</div>\n");

  // Orders.
  absl::StrAppend(&h, "<h2 id='orders'>Orders and why</h2><p>", WhyOrders(report), "</p>",
                  AccuracyPlot(report), "\n");

  // Spheres.
  if (visuals.contains("spheres")) {
    const json& sp = visuals["spheres"];
    const int size = sp.value("size", kSpherePixels);
    const int width = size * kSphereViews;
    absl::StrAppend(
        &h, "<h2 id='spheres'>Spheres: SHRM beside the brute-force sum</h2>",
        "<p>Orthographic spheres seen from the front (+Z), the side (+X) and above, one exposure "
        "for all. The brute-force sum over every pixel of the map (to a relative ",
        Num(visuals["reference"].value("relative_tolerance", 1e-3)), ") is taken at ",
        sp.value("cells", kReferenceCells), " x ", sp.value("cells", kReferenceCells),
        " cells per sphere; the error is per cell. Cells where N.V &lt; 0.3 (the rim) are grazing: "
        "the horizon cuts the lobe there, and they are counted apart as the job's check "
        "does.</p><div class='row'>",
        "<figure>", Img(sp.value("shrm_png", ""), "SHRM spheres", "sphere", width),
        "<figcaption>SHRM (every pixel)</figcaption></figure>", "<figure>",
        Img(sp.value("reference_png", ""), "brute-force spheres", "sphere", width),
        "<figcaption>brute force (one value per cell)</figcaption></figure>", "<figure>",
        Img(sp.value("error_png", ""), "relative error per cell", "sphere", width),
        "<figcaption>relative error per cell</figcaption>", ErrorScaleSvg(),
        "</figure></div><table><tr><th>view</th><th>cells front / grazing</th><th>front "
        "RMS</th><th>front largest</th><th>grazing RMS</th><th>grazing largest</th><th>largest "
        "at (N; V)</th><th>SHRM</th><th>brute force</th></tr>");
    for (const json& v : sp.value("views", json::array())) {
      const json& samples = v.value("samples", json::array());
      const json* worst = nullptr;
      for (const json& s : samples)
        if (worst == nullptr || Get(s, "error", 0) > Get(*worst, "error", 0)) worst = &s;
      auto vec = [](const json& a) {
        return absl::StrFormat("%.4f, %.4f, %.4f", a[0].get<double>(), a[1].get<double>(),
                               a[2].get<double>());
      };
      const json& fr = v.value("front", json::object());
      const json& gr = v.value("grazing", json::object());
      absl::StrAppend(&h, "<tr><td>", Esc(v.value("name", "")), "</td><td class='num'>",
                      fr.value("cells", 0), " / ", gr.value("cells", 0), "</td><td class='num'>",
                      Pct(Get(fr, "rms", 0)), "</td><td class='num'>", Pct(Get(fr, "max", 0)),
                      "</td><td class='num'>", Pct(Get(gr, "rms", 0)), "</td><td class='num'>",
                      Pct(Get(gr, "max", 0)), "</td>");
      if (worst != nullptr) {
        absl::StrAppend(&h, "<td><code>", vec((*worst)["index"]), "; ", vec((*worst)["view"]),
                        "</code></td><td><code>", vec((*worst)["shrm"]), "</code></td><td><code>",
                        vec((*worst)["reference"]), "</code></td>");
      }
      absl::StrAppend(&h, "</tr>");
    }
    absl::StrAppend(&h, "</table>\n");
  }

  // Error map.
  if (visuals.contains("pairs")) {
    absl::StrAppend(&h,
                    "<h2 id='errors'>Error over (N, V)</h2><p>The SHRM against the "
                    "brute-force sum at ",
                    visuals["pairs"].value("count", 0),
                    " seeded pairs (V uniform, N over the visible hemisphere with density N.V; "
                    "the job's own check uses the first of them), placed where the reflection "
                    "looks in the map. Relative error per direction: |got - ref| / max(|ref|, 1% "
                    "of the mean |ref|), largest channel.</p>",
                    ErrorMapSvg(visuals), ErrorScaleSvg(), "\n");
  }

  // Timings.
  absl::StrAppend(&h, "<h2 id='timings'>Stage timings</h2>",
                  TimingsPlot(report.value("timings", json::object())), "\n");

  // Data: the report and the visuals without their images.
  json data = {{"report", report}, {"visuals", visuals}};
  if (data["visuals"].contains("map")) data["visuals"]["map"].erase("png");
  if (data["visuals"].contains("spheres")) {
    for (const char* k : {"shrm_png", "reference_png", "error_png", "thumbnail_png"})
      data["visuals"]["spheres"].erase(k);
  }
  absl::StrAppend(&h, DataBlock(data), "</body></html>\n");
  return h;
}

std::string RenderReportIndexHtml(const std::string& title,
                                  const std::vector<ReportIndexEntry>& entries) {
  std::string h = Head(title);
  absl::StrAppend(&h, "<h1>", Esc(title),
                  "</h1><table><tr><th>job</th><th>spheres</th>"
                  "<th>result</th><th>status</th></tr>");
  json data = json::array();
  for (const ReportIndexEntry& e : entries) {
    const std::string name = e.report_href.empty() ? Esc(e.name)
                                                   : absl::StrCat("<a href='", Esc(e.report_href),
                                                                  "'>", Esc(e.name), "</a>");
    const std::string thumb =
        e.thumbnail_png_base64.empty()
            ? std::string()
            : Img(e.thumbnail_png_base64, e.name, "sphere", kSphereViews * kThumbnailSpherePixels);
    absl::StrAppend(&h, "<tr><td>", name, "</td><td>", thumb, "</td><td>", Esc(e.summary),
                    "</td><td class='", absl::StartsWith(e.status, "failed") ? "bad" : "ok", "'>",
                    Esc(e.status), "</td></tr>");
    data.push_back({{"name", e.name}, {"report", e.report_href}, {"status", e.status}});
  }
  absl::StrAppend(&h, "</table>", DataBlock(data), "</body></html>\n");
  return h;
}

}  // namespace shrm::jobs
