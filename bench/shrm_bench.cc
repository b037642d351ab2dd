// SHRM prefiltering speed, after Ramamoorthi & Hanrahan Tables 5.4 and 5.5 (sec. 5.7.4).
//
// Lighting: courtyard.exr box-downsampled 4x to a 256 x 128 lat-long map (S_L = 128: 128 rings),
// one thread for every timed path (the paper's single CPU). Every time is the best of several
// runs (the machine is shared), angular and frequency paths in the same run.
// Table 5.4: normalized Phong (eq. 5.26), s = 8 .. 512, F_B = 1 + sqrt(6 s) (paper, eps ~ .01),
//   output cube S_B = 128. Frequency path = L_lm (forward SHT to F_B) + rho_l (closed form,
//   PhongRhoExact; checked against a 128-node quadrature at startup) + SHRM synthesis (P = 0: a
//   plain reflection map, by the inverse-SHT path of BuildCube). Angular path = brute force over
//   the map's pixels for every texel, truncated to the lobe's cone with eps = .05 (eq. 5.30, as
//   the paper); it is timed on every 4th texel in x and y and extrapolated x16.
// Table 5.5: simplified microfacet (eq. 5.34), sigma = .1 .. .5, (F_B, P_B) from the paper's table
//   (eps < .03) plus our selection (23, 2) at sigma = .1, S_B = 128, T_B = 10. Times: SHRM creation
//   (L_lm + synthesis of the global cube), the 100 explicit maps (eq. 5.35 on a 10 x 10 view grid)
//   into reused output maps (ViewGridMapsInto) and into freshly allocated ones (ViewGridMaps:
//   adds the first-touch page faults of 118 MB), and one angular-space map (full sphere, every
//   8th texel, extrapolated x64). rho_lpq are computed here by direct quadrature of
//   docs/conventions.md's definition; their time is printed separately and not counted.
// Then the stages of the prefilter pipeline (core/shrm/prefilter.h, as the CLI runs it) on the
// full 1024 x 512 map, and the SHRM file write.
// Flags: --quick (no angular reference), --breakdown (per-stage synthesis times), --cli (the
// pipeline stages only), --json FILE (also write the Table 5.4 and 5.5 rows as JSON, the input of
// scripts/plots.py; times in the units of the printed columns).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/base/cubemap.h"
#include "core/brdf/brdf_models.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_analysis.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/transform/sht.h"
#include "nlohmann/json.hpp"

namespace shrm {
namespace {

bool g_quick = false;  // --quick: skip the angular reference (its column prints 0)

// Repetitions per timed path (best of); the angular reference runs once (it takes seconds).
constexpr int kFreqReps = 5;       // Table 5.4 frequency path and Table 5.5 SHRM creation
constexpr int kMapsReps = 4;       // Table 5.5: 100 maps into reused storage
constexpr int kFreshMapsReps = 3;  // Table 5.5: 100 maps into fresh storage

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Best of `reps` runs of f, in seconds.
template <typename F>
double Time(int reps, F&& f) {
  double best = 1e30;
  for (int r = 0; r < reps; ++r) {
    const double t0 = Now();
    f();
    best = std::min(best, Now() - t0);
  }
  return best;
}

struct Light {
  ShtGrid grid{256, 128, ShtGridKind::kEquiangular};
  std::vector<float> map;
  std::vector<EnvSample> samples;
};

Light LoadLight() {
  Light L;
  auto full = ReadImageRgb(std::string(SHRM_SOURCE_DIR) + "/data/envmaps/courtyard.exr");
  if (!full.ok()) {
    std::fprintf(stderr, "%s\n", std::string(full.status().message()).c_str());
    std::exit(1);
  }
  const int fx = full->width / L.grid.width, fy = full->height / L.grid.height;
  L.map.assign(static_cast<size_t>(L.grid.width) * L.grid.height * 3, 0.0f);
  for (int y = 0; y < full->height; ++y)
    for (int x = 0; x < full->width; ++x)
      for (int c = 0; c < 3; ++c)
        L.map[((y / fy) * L.grid.width + x / fx) * 3 + c] += full->at(x, y, c) / (fx * fy);
  const RingQuadrature q = FejerFirstRule(L.grid.height);
  for (int j = 0; j < L.grid.height; ++j)
    for (int i = 0; i < L.grid.width; ++i) {
      EnvSample e;
      e.dir = ShtGridDirection(L.grid, i, j);
      e.solid_angle = q.weight[j] * 2 * kPi / L.grid.width;
      for (int c = 0; c < 3; ++c) e.rgb[c] = L.map[(j * L.grid.width + i) * 3 + c];
      L.samples.push_back(e);
    }
  return L;
}

BrdfCoefficients PhongCoefficients(double s, int lmax) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = 0;
  b.values.assign(lmax + 1, 0.0);
  const int n = 128;
  const RingQuadrature gl = GaussLegendreRule(n);
  std::vector<double> lambda(LegendreCount(lmax));
  for (int j = 0; j < n; ++j) {
    const double x = 0.5 * (gl.cos_theta[j] + 1), w = 0.5 * gl.weight[j];
    NormalizedLegendre(lmax, x, lambda);
    const double rho = (s + 1) / (2 * kPi) * std::pow(x, s);
    for (int l = 0; l <= lmax; ++l)
      b.values[l] += std::sqrt(4 * kPi) * 2 * kPi * w * rho * lambda[LegendreIndex(l, 0)];
  }
  return b;
}

// The same coefficients in closed form (core/brdf PhongRhoExact, the recurrence of Gradshteyn &
// Ryzhik 7.126.2): rho_l00 = sqrt(4 pi) rho_l (the Y_00 of the view dependence integrated over
// w_o'). O(F) instead of the 128-node quadrature (~1.4 ms); checked against it in main().
BrdfCoefficients PhongCoefficientsExact(double s, int lmax) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = 0;
  b.values = PhongRhoExact(s, lmax);
  for (double& v : b.values) v *= std::sqrt(4 * kPi);
  return b;
}

// Simplified microfacet rho-hat (eq. 5.34) in the local frame of R: w_o' at (theta_o, 0),
// w_i' at (theta_i, phi); N = normalize(R + V), H = normalize(w_i' + V).
double Microfacet(double sigma, const Vec3& wi, const Vec3& wo) {
  const Vec3 n = (Vec3{0, 0, 1} + wo).Normalized();
  const Vec3 h0 = wi + wo;
  if (h0.Norm() < 1e-12) return 0;
  const double th = std::acos(std::clamp(n.Dot(h0.Normalized()), -1.0, 1.0));
  return std::exp(-(th / sigma) * (th / sigma)) / (4 * kPi * sigma * sigma);
}

// rho_lpq by the definition: (2pi)^2 double-integral c_q f_lq f_pq sin sin, c_q the cosine
// series of rho-hat in phi = phi_i' - phi_o'. Gauss-Legendre in cos theta_i' (n_i) and
// cos theta_o' (n_o), uniform phi (n_phi).
BrdfCoefficients MicrofacetCoefficients(double sigma, int lmax, int pmax) {
  BrdfCoefficients b;
  b.lmax = lmax;
  b.pmax = pmax;
  b.values.assign(static_cast<size_t>(lmax + 1) * (pmax + 1) * (pmax + 1), 0.0);
  const int ni = 160, no = 48, nphi = 96;
  const RingQuadrature gi = GaussLegendreRule(ni), go = GaussLegendreRule(no);
  std::vector<double> li(LegendreCount(lmax)), lo(LegendreCount(pmax));
  double total = 0;
  std::vector<double> cq(pmax + 1);
  for (int a = 0; a < no; ++a) {
    const double co = go.cos_theta[a], so = go.sin_theta[a];
    const Vec3 wo{so, 0, co};
    NormalizedLegendre(pmax, co, so, lo);
    for (int j = 0; j < ni; ++j) {
      const double ci = gi.cos_theta[j], si = gi.sin_theta[j];
      std::fill(cq.begin(), cq.end(), 0.0);
      for (int k = 0; k < nphi; ++k) {
        const double phi = 2 * kPi * (k + 0.5) / nphi;
        const double r = Microfacet(sigma, {si * std::cos(phi), si * std::sin(phi), ci}, wo);
        for (int q = 0; q <= pmax; ++q) cq[q] += r * std::cos(q * phi) / nphi;
        total += r * r * (2 * kPi / nphi) * gi.weight[j] * go.weight[a] * 2 * kPi;
      }
      NormalizedLegendre(lmax, ci, si, li);
      const double w = gi.weight[j] * go.weight[a] * 4 * kPi * kPi;
      for (int l = 0; l <= lmax; ++l)
        for (int p = 0; p <= pmax; ++p)
          for (int q = 0; q <= std::min(l, p); ++q)
            b.values[b.Index(l, p, q, 0)] +=
                w * cq[q] * li[LegendreIndex(l, q)] * lo[LegendreIndex(p, q)];
    }
  }
  b.total_energy = {total};
  return b;
}

nlohmann::ordered_json Table54(const Light& L, const ReferenceIntegrator& integ) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  std::printf("\nTable 5.4: Phong, S_L = 128 (256 x 128 lat-long), S_B = 128, one thread\n");
  std::printf("%6s %4s %12s %14s %10s %9s\n", "s", "F_B", "angular (s)", "frequency (ms)", "ratio",
              "W");
  for (int s : {8, 16, 32, 64, 128, 256, 512}) {
    const int f = static_cast<int>(1 + std::sqrt(6.0 * s));
    double t_freq = Time(kFreqReps, [&] {
      auto light = ForwardSht(L.grid, f, 3, L.map);
      const BrdfCoefficients rho = PhongCoefficientsExact(s, f);
      auto synth = ShrmSynthesizer::Create(f, 3, *light, rho);
      auto cube = synth->BuildCube(ShrmKind::kLocal, 128);
      if (!cube.ok()) std::exit(2);
    });
    const double sd = s;
    TransferFunction phong = [sd](const Vec3& n, const Vec3& v, const Vec3& w, int) {
      const Vec3 r = n * (2 * n.Dot(v)) - v;
      const double c = r.Dot(w);
      return c > 0 ? (sd + 1) / (2 * kPi) * std::pow(c, sd) : 0.0;
    };
    ReferenceOptions opt;
    opt.cone_angle = PhongConeAngle(s, 0.05);
    opt.grey = true;
    constexpr int kStride = 4;
    const double t_ang =
        g_quick ? 0.0
                : Time(1,
                       [&] {
                         (void)integ.ReflectionMap(phong, {0, 0, -1}, 128, opt, kStride);
                       }) *
                      kStride * kStride;
    const double w = 0.5 * (1 - std::pow(0.05, 1.0 / (s + 1)));
    std::printf("%6d %4d %12.2f %14.3f %10.1f %9.4f\n", s, f, t_ang, 1e3 * t_freq, t_ang / t_freq,
                w);
    rows.push_back({{"s", s},
                    {"f_b", f},
                    {"angular_s", t_ang},
                    {"frequency_ms", 1e3 * t_freq},
                    {"ratio", t_ang / t_freq},
                    {"w", w}});
  }
  return rows;
}

nlohmann::ordered_json Table55(const Light& L, const ReferenceIntegrator& integ) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  std::printf(
      "\nTable 5.5: microfacet, eps < .03 orders from the paper, S_B = 128, T_B = 10, one "
      "thread\n");
  std::printf("%5s %6s %8s %10s %11s %11s %11s %11s %12s %10s\n", "sigma", "F,P", "eps_rho",
              "rho (ms)", "SHRM (ms)", "100 maps", "(fresh)", "total (ms)", "ang/img (s)", "ratio");
  // The paper's (F, P) per sigma, plus our own eps < .03 selection (23, 2) at sigma = .1.
  const int fs[] = {24, 23, 12, 7, 5, 5}, ps[] = {3, 2, 2, 2, 2, 2};
  const double sigmas[] = {0.1, 0.1, 0.2, 0.3, 0.4, 0.5};
  for (int i = 0; i < 6; ++i) {
    const double sigma = sigmas[i];
    const int f = fs[i], p = ps[i];
    BrdfCoefficients rho;
    const double t_rho = Time(1, [&] { rho = MicrofacetCoefficients(sigma, f, p); });
    const double eps_rho = 1 - BrdfCapturedFraction(rho, f, p);
    ShrmCube cube;
    const double t_shrm = Time(kFreqReps, [&] {
      auto light = ForwardSht(L.grid, f, 3, L.map);
      auto synth = ShrmSynthesizer::Create(f, 3, *light, rho);
      auto c = synth->BuildCube(ShrmKind::kGlobal, 128);
      if (!c.ok()) std::exit(3);
      cube = std::move(*c);
    });
    const double t_maps_fresh = Time(kFreshMapsReps, [&] {
      auto maps = ViewGridMaps(cube, 10);
      if (!maps.ok()) std::exit(4);
    });
    std::vector<RadianceCube> reuse;
    const double t_maps = Time(kMapsReps, [&] {
      if (!ViewGridMapsInto(cube, 10, reuse).ok()) std::exit(4);
    });
    TransferFunction mf = [sigma](const Vec3& n, const Vec3& v, const Vec3& w, int) {
      const Vec3 h = w + v;
      if (h.Norm() < 1e-12) return 0.0;
      const double th = std::acos(std::clamp(n.Dot(h.Normalized()), -1.0, 1.0));
      return std::exp(-(th / sigma) * (th / sigma)) / (4 * kPi * sigma * sigma);
    };
    ReferenceOptions opt;
    opt.grey = true;
    constexpr int kStride = 8;
    const double t_ang = g_quick
                             ? 0.0
                             : Time(1,
                                    [&] {
                                      (void)integ.ReflectionMap(mf, {0, 0, -1}, 128, opt, kStride);
                                    }) *
                                   kStride * kStride;
    std::printf("%5.1f %3d,%-2d %8.4f %10.1f %11.2f %11.2f %11.2f %11.2f %12.2f %10.0f\n", sigma, f,
                p, eps_rho, 1e3 * t_rho, 1e3 * t_shrm, 1e3 * t_maps, 1e3 * t_maps_fresh,
                1e3 * (t_shrm + t_maps), t_ang, 100 * t_ang / (t_shrm + t_maps));
    rows.push_back({{"sigma", sigma},
                    {"f_b", f},
                    {"p_b", p},
                    {"eps_rho", eps_rho},
                    {"rho_ms", 1e3 * t_rho},
                    {"shrm_ms", 1e3 * t_shrm},
                    {"maps_ms", 1e3 * t_maps},
                    {"maps_fresh_ms", 1e3 * t_maps_fresh},
                    {"total_ms", 1e3 * (t_shrm + t_maps)},
                    {"angular_per_image_s", t_ang},
                    {"ratio", 100 * t_ang / (t_shrm + t_maps)}});
  }
  return rows;
}

// Stage breakdown of the frequency path (best of reps each).
void Breakdown(const Light& L, int f, int p, const BrdfCoefficients& rho, ShrmKind kind) {
  std::vector<double> light;
  const double t_sht = Time(7, [&] { light = *ForwardSht(L.grid, f, 3, L.map); });
  std::optional<ShrmSynthesizer> synth;
  const double t_create =
      Time(7, [&] { synth.emplace(*ShrmSynthesizer::Create(f, 3, light, rho, f, p)); });
  int na = std::max(32, 4 * (f + p + 1));
  na = (na + 7) / 8 * 8;
  auto smooth = [](int v) {
    for (int q : {2, 3, 5, 7})
      while (v % q == 0) v /= q;
    return v == 1;
  };
  while (!smooth(na)) na += 8;  // as BuildCube's automatic choice
  const double t_grid = Time(7, [&] { (void)synth->BuildGrid(kind, na); });
  const double t_cube = Time(7, [&] { (void)synth->BuildCube(kind, 128); });
  if (p == 0) {
    ShrmGridOptions general;
    general.p0_sht_path = false;
    const double t_general = Time(7, [&] { (void)synth->BuildCube(kind, 128, general); });
    std::printf(
        "  F=%d P=0: L_lm %.3f ms, create %.3f ms, cube by the inverse-SHT grid %.3f ms; "
        "general path: Wigner/FFT grid (na=%d) %.3f ms, cube %.3f ms\n",
        f, 1e3 * t_sht, 1e3 * t_create, 1e3 * t_cube, na, 1e3 * t_grid, 1e3 * t_general);
    return;
  }
  std::printf(
      "  F=%d P=%d %s: L_lm %.3f ms, create %.3f ms, grid(na=%d) %.3f ms, cube %.3f ms "
      "(resample + cube allocation ~%.3f ms)\n",
      f, p, kind == ShrmKind::kLocal ? "local" : "global", 1e3 * t_sht, 1e3 * t_create, na,
      1e3 * t_grid, 1e3 * t_cube, 1e3 * (t_cube - t_grid));
}

// Full-CLI-like stages on the full-size courtyard map (1024 x 512), with the Prefilter pipeline
// the `shrm prefilter` command runs (decode timed here too, but it is not the SHRM code), then the
// file write (float, to /tmp).
void CliStages() {
  std::printf("\nCLI-like stages, courtyard.exr 1024 x 512, S_B = 128, one thread (best of 3)\n");
  struct Case {
    const char* name;
    std::unique_ptr<Brdf> brdf;
    int f, p;
    ShrmKind kind;
  };
  std::vector<Case> cases;
  cases.push_back({"Phong s=64, (F,P)=(20,0) local", std::make_unique<PhongBrdf>(64.0), 20, 0,
                   ShrmKind::kLocal});
  cases.push_back({"microfacet 0.1, (F,P)=(24,3) global", std::make_unique<MicrofacetBrdf>(0.1), 24,
                   3, ShrmKind::kGlobal});
  cases.push_back({"microfacet 0.1, (F,P)=(23,2) global", std::make_unique<MicrofacetBrdf>(0.1), 23,
                   2, ShrmKind::kGlobal});
  EnvMapOptions eo;
  eo.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/courtyard.exr"};
  std::optional<EnvMap> env;
  const double t_decode = Time(3, [&] { env.emplace(*EnvMap::Load(eo)); });
  for (const Case& c : cases) {
    std::map<std::string, double> best;
    double t_write = 1e30;
    for (int rep = 0; rep < 3; ++rep) {
      PrefilterOptions po;
      po.f = c.f;
      po.p = c.p;
      po.kind = c.kind;
      po.face_size = 128;
      auto r = Prefilter(*env, *c.brdf, po);
      if (!r.ok()) {
        std::printf("  %s: %s\n", c.name, std::string(r.status().message()).c_str());
        break;
      }
      for (const StageTiming& t : r->timings)
        best[t.stage] = best.count(t.stage) ? std::min(best[t.stage], t.ms) : t.ms;
      t_write = std::min(
          t_write, Time(1, [&] { (void)WriteShrmFile("/tmp/shrm_bench_out.exr", r->cube, {}); }));
    }
    std::printf("  %s: decode %.1f ms (not SHRM code)", c.name, 1e3 * t_decode);
    for (const auto& [stage, ms] : best) std::printf(", %s %.2f ms", stage.c_str(), ms);
    std::printf(", write %.1f ms\n", 1e3 * t_write);
  }
}

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) {
  std::string mode, json_path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--json" && i + 1 < argc) {
      json_path = argv[++i];
    } else if (arg == "--quick" || arg == "--breakdown" || arg == "--cli") {
      mode = arg;
    } else {
      std::fprintf(stderr, "usage: shrm_bench [--quick | --breakdown | --cli] [--json FILE]\n");
      return 2;
    }
  }
  if (mode == "--quick") shrm::g_quick = true;
  if (mode == "--breakdown") {
    const shrm::Light light = shrm::LoadLight();
    for (int s : {8, 32, 128, 512}) {
      const int f = static_cast<int>(1 + std::sqrt(6.0 * s));
      const double t_rho = shrm::Time(7, [&] { (void)shrm::PhongCoefficients(s, f); });
      std::printf("  s=%d rho_l (quadrature) %.3f ms\n", s, 1e3 * t_rho);
      shrm::Breakdown(light, f, 0, shrm::PhongCoefficients(s, f), shrm::ShrmKind::kLocal);
    }
    // P = 0 alternative: direct SH synthesis at the 6 x 128^2 texel directions (no grid).
    std::vector<shrm::Vec3> dirs;
    for (int face = 0; face < 6; ++face)
      for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) dirs.push_back(shrm::CubeTexelDirection(face, x, y, 128));
    for (int f : {7, 14, 28, 56}) {
      const std::vector<double> c = *shrm::ForwardSht(light.grid, f, 3, light.map);
      std::vector<double> out(dirs.size() * 3);
      const double t =
          shrm::Time(3, [&] { (void)shrm::SynthesizeAtDirections(f, 3, c, dirs, out); });
      std::printf("  P=0 direct synthesis at the %zu texel centres, F=%d: %.3f ms\n", dirs.size(),
                  f, 1e3 * t);
    }
    const shrm::BrdfCoefficients mf = shrm::MicrofacetCoefficients(0.1, 24, 3);
    shrm::Breakdown(light, 24, 3, mf, shrm::ShrmKind::kGlobal);
    shrm::Breakdown(light, 23, 2, mf, shrm::ShrmKind::kGlobal);
    return 0;
  }
  const shrm::Light light = shrm::LoadLight();
  {
    double worst = 0;
    for (int s : {8, 64, 512}) {
      const int f = static_cast<int>(1 + std::sqrt(6.0 * s));
      const auto a = shrm::PhongCoefficients(s, f), b = shrm::PhongCoefficientsExact(s, f);
      for (int l = 0; l <= f; ++l)
        worst = std::max(worst, std::abs(a.values[l] - b.values[l]) / std::abs(b.values[0]));
    }
    std::printf("Phong rho_l: closed form vs 128-node quadrature, max rel. difference %.2g\n",
                worst);
  }
  auto integ = shrm::ReferenceIntegrator::Create(light.samples);
  if (!integ.ok()) return 1;
  if (mode == "--cli") {
    shrm::CliStages();
    return 0;
  }
  nlohmann::ordered_json doc;
  doc["bench"] = "shrm_bench";
  doc["map"] = "courtyard.exr, box-downsampled to 256 x 128";
  doc["face_size"] = 128;
  doc["threads"] = 1;
  doc["quick"] = shrm::g_quick;
  doc["table_5_4"] = shrm::Table54(light, *integ);
  doc["table_5_5"] = shrm::Table55(light, *integ);
  shrm::CliStages();
  if (!json_path.empty()) {
    std::ofstream f(json_path);
    f << doc.dump(1) << "\n";
    if (!f) {
      std::fprintf(stderr, "error: cannot write %s\n", json_path.c_str());
      return 1;
    }
  }
  return 0;
}
