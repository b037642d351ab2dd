#include "core/brdf/brdf.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "absl/strings/strip.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf_models.h"
#include "core/brdf/brdf_table.h"
#include "core/brdf/merl.h"

namespace shrm {

ReparamGeometry MakeReparamGeometry(ReparamKind kind, double theta_i, double theta_o, double phi) {
  ReparamGeometry g;
  const double si = std::sin(theta_i), ci = std::cos(theta_i);
  g.w = {si * std::cos(phi), si * std::sin(phi), ci};
  if (kind == ReparamKind::kTangent) {
    g.v = {std::sin(theta_o), 0.0, std::cos(theta_o)};
    g.n = {0.0, 0.0, 1.0};
  } else {
    const double sh = std::sin(0.5 * theta_o), ch = std::cos(0.5 * theta_o);
    g.n = {sh, 0.0, ch};  // normalize(pole + V)
    g.v = {2.0 * sh * ch, 0.0, ch * ch - sh * sh};
  }
  return g;
}

void Brdf::TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int c,
                        double* out) const {
  for (size_t k = 0; k < w.size(); ++k) out[k] = Transfer(n, v, w[k], c);
}

double Brdf::ReparamTransfer(double theta_i, double theta_o, double phi, int c) const {
  const ReparamGeometry g = MakeReparamGeometry(reparam(), theta_i, theta_o, phi);
  return Transfer(g.n, g.v, g.w, c);
}

void Brdf::ReparamTransferAll(double theta_i, double theta_o, double phi, double* out) const {
  for (int c = 0; c < channels(); ++c) out[c] = ReparamTransfer(theta_i, theta_o, phi, c);
}

void Brdf::ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                              double* out) const {
  for (size_t k = 0; k < phi.phi.size(); ++k) {
    ReparamTransferAll(theta_i, theta_o, phi.phi[k], out + k * channels());
  }
}

void Brdf::TransferArc(double theta_i, double theta_o, const ArcAzimuths& phi, double* out) const {
  // MakeReparamGeometry with theta_i and theta_o's sines and cosines taken once.
  const ReparamGeometry g0 = MakeReparamGeometry(reparam(), theta_i, theta_o, 0.0);
  const double si = std::sin(theta_i);
  const int nc = channels();
  for (size_t k = 0; k < phi.phi.size(); ++k) {
    const Vec3 w{si * phi.cos_phi[k], si * phi.sin_phi[k], g0.w.z};
    for (int c = 0; c < nc; ++c) out[k * nc + c] = Transfer(g0.n, g0.v, w, c);
  }
}

void ReparamAngles(ReparamKind kind, const Vec3& n, const Vec3& v, const Vec3& w, double* theta_i,
                   double* theta_o, double* phi) {
  Vec3 pole = kind == ReparamKind::kTangent ? n : n * (2.0 * n.Dot(v)) - v;
  pole = pole.Normalized();
  const auto angle = [](const Vec3& a, const Vec3& b) {
    return std::atan2(a.Cross(b).Norm(), a.Dot(b));
  };
  *theta_i = angle(pole, w);
  *theta_o = angle(pole, v);
  const Vec3 vp = v - pole * pole.Dot(v);
  const Vec3 wp = w - pole * pole.Dot(w);
  if (vp.Norm() < 1e-14 || wp.Norm() < 1e-14) {
    *phi = 0.0;
  } else {
    *phi = angle(vp, wp);
  }
}

std::string FormatSpecNumber(double x) {
  char buf[64];
  if (x == std::floor(x) && std::abs(x) < 1e15) {
    std::snprintf(buf, sizeof(buf), "%.0f", x);
    return buf;
  }
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof(buf), "%.*g", digits, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

namespace {

struct ParamSpec {
  const char* name;
  double default_value;
  double lo, hi;
  bool lo_open, hi_open;
  const char* description;
};

std::string RangeText(const ParamSpec& p) {
  return absl::StrCat(p.lo_open ? "(" : "[", FormatSpecNumber(p.lo), ", ", FormatSpecNumber(p.hi),
                      p.hi_open ? ")" : "]");
}

absl::StatusOr<double> ParseNumber(absl::string_view model, absl::string_view key,
                                   absl::string_view text) {
  const std::string s(absl::StripAsciiWhitespace(text));
  char* end = nullptr;
  const double x = s.empty() ? 0.0 : std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(x)) {
    return absl::InvalidArgumentError(absl::StrCat("brdf '", model, "': parameter '", key, "' = '",
                                                   text, "' is not a finite number"));
  }
  return x;
}

// Parses "k=v,k=v" against `params`; missing keys take their defaults. Values are range-checked.
absl::StatusOr<std::map<std::string, double>> ParseParams(absl::string_view model,
                                                          absl::string_view text,
                                                          const std::vector<ParamSpec>& params) {
  std::map<std::string, double> values;
  for (const ParamSpec& p : params) values[p.name] = p.default_value;
  std::map<std::string, bool> seen;
  const absl::string_view stripped = absl::StripAsciiWhitespace(text);
  if (!stripped.empty()) {
    for (absl::string_view item : absl::StrSplit(stripped, ',')) {
      const std::pair<absl::string_view, absl::string_view> kv = absl::StrSplit(item, '=');
      const std::string key(absl::StripAsciiWhitespace(kv.first));
      const auto it = std::find_if(params.begin(), params.end(),
                                   [&](const ParamSpec& p) { return key == p.name; });
      if (it == params.end() || item.find('=') == absl::string_view::npos) {
        std::vector<std::string> names;
        for (const ParamSpec& p : params) names.push_back(p.name);
        return absl::InvalidArgumentError(absl::StrCat(
            "brdf '", model, "': ",
            it == params.end() ? absl::StrCat("unknown parameter '", key, "'")
                               : absl::StrCat("parameter '", key, "' needs a value (", key, "=x)"),
            "; valid parameters: ", absl::StrJoin(names, ", "), " (syntax ", model, ":",
            names.empty() ? "" : names[0], "=x,...)"));
      }
      if (seen[key]) {
        return absl::InvalidArgumentError(
            absl::StrCat("brdf '", model, "': parameter '", key, "' given twice"));
      }
      seen[key] = true;
      SHRM_ASSIGN_OR_RETURN(const double x, ParseNumber(model, key, kv.second));
      const bool below = it->lo_open ? x <= it->lo : x < it->lo;
      const bool above = it->hi_open ? x >= it->hi : x > it->hi;
      if (below || above) {
        return absl::InvalidArgumentError(
            absl::StrCat("brdf '", model, "': parameter '", key, "' = ", FormatSpecNumber(x),
                         " is out of range; valid range ", RangeText(*it)));
      }
      values[key] = x;
    }
  }
  return values;
}

constexpr double kBig = 1e5;

const std::vector<ParamSpec>& LambertParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"albedo", 1.0, 0.0, 1.0, false, false, "diffuse albedo (white furnace value)"}};
  return *p;
}
const std::vector<ParamSpec>& PhongParams() {
  static const auto* p =
      new std::vector<ParamSpec>{{"s", 32.0, 0.0, kBig, true, false, "Phong exponent of (R.w)^s"}};
  return *p;
}
const std::vector<ParamSpec>& MicrofacetParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"sigma", 0.2, 0.0, 10.0, true, false, "roughness (radians) of exp(-(theta_h/sigma)^2)"}};
  return *p;
}
const std::vector<ParamSpec>& WardParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"alpha", 0.2, 0.0, 1.0, true, false, "roughness (RMS slope)"},
      {"alpha_x", 0.2, 0.0, 1.0, true, false, "roughness along the tangent (defaults to alpha)"},
      {"alpha_y", 0.2, 0.0, 1.0, true, false, "roughness along the bitangent (defaults to alpha)"},
      {"rho_s", 0.1, 0.0, 1.0, false, false, "specular albedo"},
      {"rho_d", 0.0, 0.0, 1.0, false, false, "diffuse albedo"}};
  return *p;
}
const std::vector<ParamSpec>& GgxParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"alpha", 0.3, 0.0, 1.0, true, false, "Trowbridge-Reitz roughness (alpha = r^2)"},
      {"f0", 0.04, 0.0, 1.0, false, false, "Schlick Fresnel reflectance at normal incidence"}};
  return *p;
}
const std::vector<ParamSpec>& KajiyaKayParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"s", 32.0, 0.0, kBig, true, false, "exponent of cos^s(theta_i' - theta_o')"}};
  return *p;
}
const std::vector<ParamSpec>& LafortuneLobeParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"cx", -1.0, -1e3, 1e3, false, false, "C_x (must equal C_y: isotropic)"},
      {"cy", -1.0, -1e3, 1e3, false, false, "C_y (defaults to C_x when omitted)"},
      {"cz", 1.0, -1e3, 1e3, false, false, "C_z"},
      {"n", 20.0, 0.0, kBig, true, false, "lobe exponent"},
      {"rho", 1.0, 0.0, 1e6, false, false, "lobe scale"}};
  return *p;
}
const std::vector<ParamSpec>& LafortuneDiffuseParams() {
  static const auto* p = new std::vector<ParamSpec>{
      {"rho_d", 0.0, 0.0, 1.0, false, false, "diffuse albedo (a group of its own)"}};
  return *p;
}

absl::StatusOr<std::unique_ptr<Brdf>> ParseLafortune(absl::string_view text) {
  std::vector<LafortuneLobe> lobes;
  double rho_d = 0;
  bool have_diffuse = false;
  const absl::string_view stripped = absl::StripAsciiWhitespace(text);
  std::vector<absl::string_view> groups;
  if (!stripped.empty()) groups = absl::StrSplit(stripped, ';');
  if (groups.empty()) groups.push_back("");
  for (absl::string_view group : groups) {
    if (absl::StrContains(group, "rho_d")) {
      if (have_diffuse) {
        return absl::InvalidArgumentError("brdf 'lafortune': rho_d given twice");
      }
      SHRM_ASSIGN_OR_RETURN(auto values, ParseParams("lafortune", group, LafortuneDiffuseParams()));
      rho_d = values["rho_d"];
      have_diffuse = true;
      continue;
    }
    SHRM_ASSIGN_OR_RETURN(auto values, ParseParams("lafortune", group, LafortuneLobeParams()));
    if (!absl::StrContains(group, "cy")) values["cy"] = values["cx"];
    if (!absl::StrContains(group, "cx") && absl::StrContains(group, "cy")) {
      values["cx"] = values["cy"];
    }
    if (values["cx"] != values["cy"]) {
      return absl::InvalidArgumentError(absl::StrCat(
          "brdf 'lafortune': parameters 'cx' = ", FormatSpecNumber(values["cx"]), " and 'cy' = ",
          FormatSpecNumber(values["cy"]), " differ; only isotropic lobes (cx = cy) are supported"));
    }
    lobes.push_back({values["cx"], values["cz"], values["n"], values["rho"]});
  }
  return std::unique_ptr<Brdf>(new LafortuneBrdf(std::move(lobes), rho_d));
}

}  // namespace

BrdfSpecParts SplitBrdfSpec(std::string_view spec_in) {
  const absl::string_view spec =
      absl::StripAsciiWhitespace(absl::string_view(spec_in.data(), spec_in.size()));
  const size_t colon = spec.find(':');
  BrdfSpecParts parts;
  parts.model = std::string(absl::StripAsciiWhitespace(spec.substr(0, colon)));
  if (colon != absl::string_view::npos) parts.rest = std::string(spec.substr(colon + 1));
  return parts;
}

std::optional<std::string> BrdfSpecFile(std::string_view spec, std::string* model) {
  BrdfSpecParts parts = SplitBrdfSpec(spec);
  if (parts.model != "table" && parts.model != "merl") return std::nullopt;
  if (model != nullptr) *model = parts.model;
  return std::string(absl::StripAsciiWhitespace(parts.rest));
}

absl::StatusOr<std::unique_ptr<Brdf>> ParseBrdfSpec(std::string_view spec_in) {
  const BrdfSpecParts parts = SplitBrdfSpec(spec_in);
  const std::string& name = parts.model;
  const absl::string_view rest = parts.rest;
  if (name == "table" || name == "merl") {
    const std::string path(absl::StripAsciiWhitespace(rest));
    if (path.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("brdf '", name, "': missing file path (syntax ", name, ":PATH)"));
    }
    if (name == "table") {
      SHRM_ASSIGN_OR_RETURN(auto table, LoadBrdfTable(path));
      return std::unique_ptr<Brdf>(std::move(table));
    }
    SHRM_ASSIGN_OR_RETURN(auto merl, LoadMerlBrdf(path));
    return std::unique_ptr<Brdf>(std::move(merl));
  }
  if (name == "lafortune") return ParseLafortune(rest);
  if (name == "lambert") {
    SHRM_ASSIGN_OR_RETURN(auto v, ParseParams(name, rest, LambertParams()));
    return std::unique_ptr<Brdf>(new LambertBrdf(v["albedo"]));
  }
  if (name == "phong") {
    SHRM_ASSIGN_OR_RETURN(auto v, ParseParams(name, rest, PhongParams()));
    return std::unique_ptr<Brdf>(new PhongBrdf(v["s"]));
  }
  if (name == "microfacet") {
    SHRM_ASSIGN_OR_RETURN(auto v, ParseParams(name, rest, MicrofacetParams()));
    return std::unique_ptr<Brdf>(new MicrofacetBrdf(v["sigma"]));
  }
  if (name == "ward") {
    SHRM_ASSIGN_OR_RETURN(auto v, ParseParams(name, rest, WardParams()));
    if (!absl::StrContains(rest, "alpha_x")) v["alpha_x"] = v["alpha"];
    if (!absl::StrContains(rest, "alpha_y")) v["alpha_y"] = v["alpha"];
    return std::unique_ptr<Brdf>(new WardBrdf(v["alpha_x"], v["alpha_y"], v["rho_s"], v["rho_d"]));
  }
  if (name == "ggx") {
    SHRM_ASSIGN_OR_RETURN(auto v, ParseParams(name, rest, GgxParams()));
    return std::unique_ptr<Brdf>(new GgxBrdf(v["alpha"], v["f0"]));
  }
  if (name == "kajiya-kay") {
    SHRM_ASSIGN_OR_RETURN(auto v, ParseParams(name, rest, KajiyaKayParams()));
    return std::unique_ptr<Brdf>(new KajiyaKayBrdf(v["s"]));
  }
  std::vector<std::string> names;
  for (const BrdfModelInfo& m : ListBrdfModels()) names.push_back(m.name);
  return absl::InvalidArgumentError(
      absl::StrCat("unknown brdf model '", name, "' in spec '",
                   absl::StripAsciiWhitespace(absl::string_view(spec_in.data(), spec_in.size())),
                   "'; valid models: ", absl::StrJoin(names, ", ")));
}

namespace {

BrdfModelInfo MakeInfo(std::string name, std::string syntax, const std::vector<ParamSpec>& params,
                       std::string description) {
  BrdfModelInfo info{std::move(name), std::move(syntax), {}, std::move(description)};
  for (const ParamSpec& p : params) {
    info.params.push_back({p.name, FormatSpecNumber(p.default_value), RangeText(p), p.description});
  }
  return info;
}

}  // namespace

const std::vector<BrdfModelInfo>& ListBrdfModels() {
  static const auto* models = [] {
    auto* m = new std::vector<BrdfModelInfo>;
    m->push_back(MakeInfo("lambert", "lambert:albedo=1", LambertParams(),
                          "Lambertian: rho-hat = albedo/pi max(N.w, 0)"));
    m->push_back(MakeInfo("phong", "phong:s=32", PhongParams(),
                          "normalized Phong (eq. 5.26): rho-hat = (s+1)/(2 pi) max(R.w, 0)^s, "
                          "radially symmetric about R (P = 0)"));
    m->push_back(MakeInfo("microfacet", "microfacet:sigma=0.2", MicrofacetParams(),
                          "simplified microfacet (eq. 5.34): rho-hat = exp(-(theta_h/sigma)^2) / "
                          "(4 pi sigma^2), zero where N.w <= 0"));
    BrdfModelInfo lafortune =
        MakeInfo("lafortune", "lafortune:[rho_d=0.1;]cx=-1,cy=-1,cz=1,n=20,rho=1[;cx=...]",
                 LafortuneLobeParams(),
                 "Lafortune et al. 1997, isotropic: f_r = rho_d/pi + sum over ';'-separated "
                 "lobes rho max(cx (u_x v_x + u_y v_y) + cz u_z v_z, 0)^n");
    lafortune.params.push_back({"rho_d", "0", "[0, 1]", "diffuse albedo (a group of its own)"});
    m->push_back(std::move(lafortune));
    m->push_back(MakeInfo("ward", "ward:alpha=0.2,rho_s=0.1,rho_d=0", WardParams(),
                          "Ward 1992: rho_d/pi + rho_s exp(-tan^2 theta_h/alpha^2) / "
                          "(4 pi alpha^2 sqrt(cos theta_i cos theta_o)); anisotropic with "
                          "alpha_x != alpha_y (tangent = +x projected; outgoing tables only)"));
    m->push_back(MakeInfo("ggx", "ggx:alpha=0.3,f0=0.04", GgxParams(),
                          "GGX / Trowbridge-Reitz D, height-correlated Smith G, Schlick F"));
    m->push_back(MakeInfo("kajiya-kay", "kajiya-kay:s=32", KajiyaKayParams(),
                          "Kajiya-Kay reparameterized by the tangent: rho-hat = c_s "
                          "max(cos(theta_i' - theta_o'), 0)^s, c_s = 1/(2 pi integral_0^pi "
                          "sin^(s+1)); q = 0 terms only"));
    m->push_back(BrdfModelInfo{"table",
                               "table:PATH",
                               {{"PATH", "", "file", "SHRMBRDF v1 table (docs/brdf.md)"}},
                               "tabulated rho-hat(theta_i', theta_o', phi), trilinear"});
    m->push_back(BrdfModelInfo{"merl",
                               "merl:PATH",
                               {{"PATH", "", "file", "MERL isotropic binary (90 x 90 x 180)"}},
                               "MERL measured isotropic BRDF, RGB, BRDFRead.cpp lookup"});
    return m;
  }();
  return *models;
}

}  // namespace shrm
