// SHRM prefiltering speed, after Ramamoorthi & Hanrahan Tables 5.4 and 5.5 (sec. 5.7.4).
//
// Lighting: courtyard.exr box-downsampled 4x to a 256 x 128 lat-long map (S_L = 128: 128 rings),
// one thread for every timed path (the paper's single CPU).
// Table 5.4: normalized Phong (eq. 5.26), s = 8 .. 512, F_B = 1 + sqrt(6 s) (paper, eps = .01),
//   output cube S_B = 128. Frequency path = L_lm (forward SHT to F_B) + rho_l + SHRM synthesis
//   (P = 0: a plain reflection map). Angular path = brute force over the map's pixels for every
//   texel, truncated to the lobe's cone with eps = .05 (eq. 5.30, as the paper); it is timed on
//   every 4th texel in x and y and extrapolated x16 (printed as such).
// Table 5.5: simplified microfacet (eq. 5.34), sigma = .1 .. .5, (F_B, P_B) from the paper's table
//   (eps < .03), S_B = 128, T_B = 10. Times: SHRM creation (L_lm + synthesis of the global cube),
//   the 100 explicit maps (eq. 5.35 on a 10 x 10 view grid), and one angular-space map (full
//   sphere, every 8th texel, extrapolated x64). rho_lpq are computed here by direct quadrature of
//   docs/conventions.md's definition (core/brdf was not available when this was written); their
//   time is printed separately.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/io/image.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_analysis.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/transform/sht.h"

namespace shrm {
namespace {

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

void Table54(const Light& L, const ReferenceIntegrator& integ) {
  std::printf("\nTable 5.4: Phong, S_L = 128 (256 x 128 lat-long), S_B = 128, one thread\n");
  std::printf("%6s %4s %12s %14s %10s %9s\n", "s", "F_B", "angular (s)", "frequency (ms)", "ratio",
              "W");
  for (int s : {8, 16, 32, 64, 128, 256, 512}) {
    const int f = static_cast<int>(1 + std::sqrt(6.0 * s));
    double t_freq = Time(5, [&] {
      auto light = ForwardSht(L.grid, f, 3, L.map);
      const BrdfCoefficients rho = PhongCoefficients(s, f);
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
    const double t_ang = Time(1,
                              [&] {
                                (void)integ.ReflectionMap(phong, {0, 0, -1}, 128, opt, kStride);
                              }) *
                         kStride * kStride;
    const double w = 0.5 * (1 - std::pow(0.05, 1.0 / (s + 1)));
    std::printf("%6d %4d %12.2f %14.3f %10.1f %9.4f\n", s, f, t_ang, 1e3 * t_freq, t_ang / t_freq,
                w);
  }
}

void Table55(const Light& L, const ReferenceIntegrator& integ) {
  std::printf(
      "\nTable 5.5: microfacet, eps < .03 orders from the paper, S_B = 128, T_B = 10, one "
      "thread\n");
  std::printf("%5s %6s %8s %10s %11s %11s %11s %12s %10s\n", "sigma", "F,P", "eps_rho", "rho (ms)",
              "SHRM (ms)", "100 maps", "total (ms)", "ang/img (s)", "ratio");
  const int fs[] = {24, 12, 7, 5, 5}, ps[] = {3, 2, 2, 2, 2};
  for (int i = 0; i < 5; ++i) {
    const double sigma = 0.1 * (i + 1);
    const int f = fs[i], p = ps[i];
    BrdfCoefficients rho;
    const double t_rho = Time(1, [&] { rho = MicrofacetCoefficients(sigma, f, p); });
    const double eps_rho = 1 - BrdfCapturedFraction(rho, f, p);
    ShrmCube cube;
    const double t_shrm = Time(5, [&] {
      auto light = ForwardSht(L.grid, f, 3, L.map);
      auto synth = ShrmSynthesizer::Create(f, 3, *light, rho);
      auto c = synth->BuildCube(ShrmKind::kGlobal, 128);
      if (!c.ok()) std::exit(3);
      cube = std::move(*c);
    });
    const double t_maps = Time(3, [&] {
      auto maps = ViewGridMaps(cube, 10);
      if (!maps.ok()) std::exit(4);
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
    const double t_ang = Time(1,
                              [&] {
                                (void)integ.ReflectionMap(mf, {0, 0, -1}, 128, opt, kStride);
                              }) *
                         kStride * kStride;
    std::printf("%5.1f %3d,%-2d %8.4f %10.1f %11.2f %11.2f %11.2f %12.2f %10.0f\n", sigma, f, p,
                eps_rho, 1e3 * t_rho, 1e3 * t_shrm, 1e3 * t_maps, 1e3 * (t_shrm + t_maps), t_ang,
                100 * t_ang / (t_shrm + t_maps));
  }
}

}  // namespace
}  // namespace shrm

int main() {
  const shrm::Light light = shrm::LoadLight();
  auto integ = shrm::ReferenceIntegrator::Create(light.samples);
  if (!integ.ok()) return 1;
  shrm::Table54(light, *integ);
  shrm::Table55(light, *integ);
  return 0;
}
