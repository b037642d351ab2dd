// Where the split-sum approximation fails and the SHRM does not: the error of both against the
// brute-force reflected radiance, over the angle between the view and the normal, for GGX on the
// bundled real maps (docs/results.md "Split-sum vs SHRM"; the plot: scripts/plots.py).
//
// For each map (box-filtered to --width x --width/2, the same pixels for every method) and each
// GGX alpha (f0 = 1, so the BRDF is D G / (4 N.L N.V) and the split-sum's second factor is the
// directional albedo E(N.V) = A + B of the DFG table):
//   truth      B(N, V) = sum over the map's pixels of L f_r (N.L) dOmega (ReferenceIntegrator);
//   SHRM       `shrm prefilter --brdf ggx:alpha=a,f0=1 --tolerance T` (global; the tolerance rule
//              picks F_B, P_B, the window and S_B), evaluated at (N, V) by ShrmEval;
//   equal-memory SHRM  the same F_B and window in the split-sum chain's memory: the largest
//              P_B <= the rule's for which S_B = floor(sqrt(budget / (18 (P_B + 1)^2))) >= 16,
//              budget = 6 S^2 4/3 RGB floats of a full chain of base S (--chain-face, 256);
//   split-sum  the GGX-prefiltered radiance (N = V = R, N.L weighted: Filament's and
//              glTF-IBL-Sampler's integral, core/ibl) at roughness sqrt(a) on S x S faces,
//              sampled bilinearly at R with the same cube interpolation as the SHRM, times E(N.V)
//              (IntegrateGgxDfg): the engines' split-sum without the mip interpolation, so what is
//              measured is the approximation itself.
// View angles: bins of 10 degrees from 0 to 90; in each, --samples pairs with N uniform on the
// sphere and V at a uniform angle in the bin and a uniform azimuth about N (seeded). Error per bin:
// relative RMS of the luminance, sqrt(sum (x - t)^2 / sum t^2), and the mean ratio sum x / sum t.
//
// Usage: split_sum_vs_shrm [--maps a.exr,b.exr] [--alphas 0.1,0.25,0.5] [--width 256]
//                          [--samples 200] [--tolerance 0.01] [--chain-face 256] [--threads N]
//                          [--json FILE]
// (maps relative to data/envmaps/). Prints a table; --json writes the figures for the plot.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_split.h"
#include "core/base/constants.h"
#include "core/base/parallel.h"
#include "core/brdf/brdf_models.h"
#include "core/envmap/envmap.h"
#include "core/ibl/dfg.h"
#include "core/ibl/split_sum.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_reference.h"
#include "nlohmann/json.hpp"

namespace shrm {
namespace {

constexpr int kBins = 9;      // 10-degree bins of the view angle
constexpr int kMinFace = 16;  // smallest S_B of the equal-memory SHRM
constexpr double kLuma[3] = {0.2126, 0.7152, 0.0722};

struct Args {
  std::vector<std::string> maps = {"courtyard.exr", "city.exr", "forest.exr", "interior.exr"};
  std::vector<double> alphas = {0.1, 0.25, 0.5};
  int width = 256;
  int samples = 200;
  double tolerance = 0.01;
  int chain_face = 256;  // the split-sum chain's base face (Filament's and cmgen's default)
  int threads = 0;
  std::string json;
};

[[noreturn]] void Usage(const std::string& why) {
  std::fprintf(stderr,
               "split_sum_vs_shrm: %s\nusage: split_sum_vs_shrm [--maps a.exr,b.exr] "
               "[--alphas 0.1,0.25] [--width 256] [--samples 200] [--tolerance 0.01] "
               "[--chain-face 256] [--threads N] [--json FILE]\n",
               why.c_str());
  std::exit(2);
}

Args Parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) Usage(flag + " needs a value");
    const std::string v = argv[++i];
    auto number = [&](double* out) {
      if (!absl::SimpleAtod(v, out)) Usage(flag + ": not a number: " + v);
    };
    if (flag == "--maps") {
      a.maps = absl::StrSplit(v, ',');
    } else if (flag == "--alphas") {
      a.alphas.clear();
      for (const auto& s : absl::StrSplit(v, ',')) {
        double x;
        if (!absl::SimpleAtod(s, &x) || !(x > 0 && x <= 1)) Usage("bad alpha " + std::string(s));
        a.alphas.push_back(x);
      }
    } else if (flag == "--width" || flag == "--samples" || flag == "--threads") {
      double x;
      number(&x);
      (flag == "--width"     ? a.width
       : flag == "--samples" ? a.samples
                             : a.threads) = static_cast<int>(x);
    } else if (flag == "--tolerance") {
      number(&a.tolerance);
    } else if (flag == "--json") {
      a.json = v;
    } else {
      Usage("unknown flag " + flag);
    }
  }
  if (a.width < 8 || a.width % 2 != 0 || a.samples < 1) Usage("bad --width or --samples");
  if (a.threads <= 0)
    a.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return a;
}

// The bundled map box-filtered by an integer factor to `width` x `width` / 2.
EnvMap LoadMap(const std::string& name, int width) {
  EnvMapOptions options;
  options.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name};
  auto m = EnvMap::Load(options);
  if (!m.ok() || m->lat_long_image() == nullptr) {
    std::fprintf(stderr, "split_sum_vs_shrm: %s: %s\n", name.c_str(),
                 m.ok() ? "not lat-long" : std::string(m.status().message()).c_str());
    std::exit(1);
  }
  const Image& in = *m->lat_long_image();
  const int f = in.width / width;
  if (f < 1 || in.width % width != 0) {
    std::fprintf(stderr, "split_sum_vs_shrm: --width must divide %d\n", in.width);
    std::exit(2);
  }
  Image out;
  out.width = width;
  out.height = width / 2;
  out.channels = 3;
  out.pixels.assign(static_cast<size_t>(out.width) * out.height * 3, 0.0f);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < 3; ++c) {
        double sum = 0;
        for (int j = 0; j < f; ++j)
          for (int i = 0; i < f; ++i)
            sum += in.pixels[((static_cast<size_t>(y) * f + j) * in.width + x * f + i) * 3 + c];
        out.pixels[(static_cast<size_t>(y) * out.width + x) * 3 + c] =
            static_cast<float>(sum / (f * f));
      }
  return EnvMap::FromLatLong(std::move(out));
}

// A unit vector perpendicular to n.
Vec3 Perpendicular(const Vec3& n) {
  const Vec3 a = std::abs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  return n.Cross(a).Normalized();
}

struct BinError {
  double sq_err = 0, sq_truth = 0, sum = 0, sum_truth = 0;
  double Rms() const { return std::sqrt(sq_err / std::max(sq_truth, 1e-300)); }
  double Ratio() const { return sum / std::max(sum_truth, 1e-300); }
};

double Luma(const std::array<double, 3>& v) {
  return kLuma[0] * v[0] + kLuma[1] * v[1] + kLuma[2] * v[2];
}

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) {
  using namespace shrm;
  const Args args = Parse(argc, argv);
  nlohmann::json out = nlohmann::json::array();
  std::printf("%-14s %5s | %s\n", "map", "alpha",
              "SHRM (F,P) S_B values | equal-memory SHRM | split-sum face values | rel. RMS per "
              "view-angle bin (0-10 ... 80-90 deg): SHRM / equal-memory SHRM / split-sum");
  for (const std::string& name : args.maps) {
    const EnvMap map = LoadMap(name, args.width);
    absl::StatusOr<ReferenceIntegrator> ref = ReferenceIntegrator::Create(map.samples());
    if (!ref.ok()) return 1;
    for (const double alpha : args.alphas) {
      const GgxBrdf brdf(alpha, 1.0);
      // The SHRM the tolerance rule picks (F_B, P_B, window, S_B).
      PrefilterOptions po;
      po.tolerance = args.tolerance;
      po.threads = args.threads;
      absl::StatusOr<PrefilterResult> rule = Prefilter(map, brdf, po);
      if (!rule.ok()) {
        std::fprintf(stderr, "prefilter: %s\n", std::string(rule.status().message()).c_str());
        return 1;
      }
      // The SHRM in the split-sum chain's memory: the rule's F_B and window, the largest P_B <=
      // the rule's whose S_B = floor(sqrt(budget / (18 (P_B + 1)^2))) is at least kMinFace.
      const double ss_values = 6.0 * args.chain_face * args.chain_face * 4 / 3 * 3;
      int p = rule->analysis.p_b, face = 0;
      for (; p >= 0; --p) {
        face = static_cast<int>(std::sqrt(ss_values / (18.0 * (p + 1) * (p + 1))));
        if (face >= kMinFace) break;
      }
      PrefilterOptions eq;
      eq.f = rule->analysis.f_b;
      eq.p = std::max(p, 0);
      eq.face_size = std::max(face, kMinFace);
      eq.window = rule->window;
      eq.threads = args.threads;
      absl::StatusOr<PrefilterResult> equal = Prefilter(map, brdf, eq);
      if (!equal.ok()) {
        std::fprintf(stderr, "prefilter: %s\n", std::string(equal.status().message()).c_str());
        return 1;
      }
      const ShrmCube& cube = rule->cube;
      const ShrmCube& cube_eq = equal->cube;
      auto values = [](const ShrmCube& c) {
        return 6.0 * c.face_size * c.face_size * c.coeff_count() * 3;
      };
      const int s_ss = args.chain_face;
      ibl::SpecularOptions so;
      const double roughness[] = {std::sqrt(alpha)};
      so.chain = *ibl::MakeMipChain(ibl::RoughnessPreset::kExplicit, s_ss, 1, roughness);
      so.tolerance = 1e-3;
      so.threads = args.threads;
      absl::StatusOr<ibl::SpecularChain> chain = ibl::PrefilterSpecular(map, so);
      if (!chain.ok()) return 1;
      // The level as a P = 0 global SHRM: ShrmEvalAt interpolates it as it does the SHRM.
      const RadianceCube& level = chain->levels[0].cube;
      ShrmCube ss;
      ss.kind = ShrmKind::kGlobal;
      ss.face_size = level.face_size;
      ss.pmax = 0;
      ss.data.resize(ss.size());
      const double to_c00 = 2.0 * std::sqrt(kPi);  // B = c00 Y00, Y00 = 1 / (2 sqrt(pi))
      for (size_t i = 0; i < ss.data.size(); ++i)
        ss.data[i] = static_cast<float>(level.data[i] * to_c00);

      std::vector<BinError> e_shrm(kBins), e_eq(kBins), e_ss(kBins);
      for (int b = 0; b < kBins; ++b) {
        std::vector<std::array<double, 3>> t(args.samples), x(args.samples), xe(args.samples),
            y(args.samples);
        std::mt19937_64 rng(1000 * b + 7);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::vector<Vec3> ns(args.samples), vs(args.samples);
        for (int i = 0; i < args.samples; ++i) {
          const double z = 2 * u(rng) - 1, phi = 2 * kPi * u(rng);
          const double r = std::sqrt(std::max(0.0, 1 - z * z));
          const Vec3 n{r * std::cos(phi), r * std::sin(phi), z};
          const double theta = (b + u(rng)) * (kPi / 2) / kBins;
          const double psi = 2 * kPi * u(rng);
          const Vec3 t1 = Perpendicular(n), t2 = n.Cross(t1);
          ns[i] = n;
          vs[i] =
              (n * std::cos(theta) + (t1 * std::cos(psi) + t2 * std::sin(psi)) * std::sin(theta))
                  .Normalized();
        }
        const TransferFunction transfer = [&](const Vec3& n, const Vec3& v, const Vec3& w, int c) {
          return brdf.Transfer(n, v, w, c);
        };
        ParallelChunks(args.samples, args.threads, [&](int begin, int end) {
          for (int i = begin; i < end; ++i) {
            const Vec3 &n = ns[i], &v = vs[i];
            ReferenceOptions ro;
            ro.grey = true;
            t[i] = ref->Radiance(transfer, n, v, ro);
            x[i] = ShrmEval(cube, n, v);
            xe[i] = ShrmEval(cube_eq, n, v);
            const std::array<double, 3> pre = ShrmEval(ss, n, v);
            const double e = ibl::IntegrateGgxDfg(std::max(1e-4, n.Dot(v)), alpha).Energy();
            for (int c = 0; c < 3; ++c) y[i][c] = pre[c] * e;
          }
        });
        for (int i = 0; i < args.samples; ++i) {
          const double lt = Luma(t[i]);
          const std::pair<BinError*, double> got[] = {
              {&e_shrm[b], Luma(x[i])}, {&e_eq[b], Luma(xe[i])}, {&e_ss[b], Luma(y[i])}};
          for (const auto& [e, l] : got) {
            e->sq_err += (l - lt) * (l - lt);
            e->sq_truth += lt * lt;
            e->sum += l;
            e->sum_truth += lt;
          }
        }
      }
      char desc[160];
      std::snprintf(desc, sizeof(desc), "(%d,%d) %d %.2fM | (%d,%d) %d %.2fM | %d %.2fM",
                    rule->analysis.f_b, rule->analysis.p_b, cube.face_size, values(cube) / 1e6,
                    equal->analysis.f_b, equal->analysis.p_b, cube_eq.face_size,
                    values(cube_eq) / 1e6, s_ss, ss_values / 1e6);
      std::printf("%-14s %5.2f | %s |", name.c_str(), alpha, desc);
      nlohmann::json row = {{"map", name},
                            {"alpha", alpha},
                            {"shrm",
                             {{"f_b", rule->analysis.f_b},
                              {"p_b", rule->analysis.p_b},
                              {"s_b", cube.face_size},
                              {"values", values(cube)}}},
                            {"shrm_equal_memory",
                             {{"f_b", equal->analysis.f_b},
                              {"p_b", equal->analysis.p_b},
                              {"s_b", cube_eq.face_size},
                              {"values", values(cube_eq)}}},
                            {"split_sum", {{"face", s_ss}, {"values", ss_values}}}};
      for (int b = 0; b < kBins; ++b) {
        std::printf(" %.3f/%.3f/%.3f", e_shrm[b].Rms(), e_eq[b].Rms(), e_ss[b].Rms());
        row["angle_deg"].push_back(10 * b + 5);
        row["shrm_rms"].push_back(e_shrm[b].Rms());
        row["shrm_equal_memory_rms"].push_back(e_eq[b].Rms());
        row["split_sum_rms"].push_back(e_ss[b].Rms());
        row["shrm_ratio"].push_back(e_shrm[b].Ratio());
        row["shrm_equal_memory_ratio"].push_back(e_eq[b].Ratio());
        row["split_sum_ratio"].push_back(e_ss[b].Ratio());
      }
      std::printf("\n");
      std::fflush(stdout);
      out.push_back(row);
    }
  }
  if (!args.json.empty()) {
    std::ofstream f(args.json);
    f << nlohmann::json{{"width", args.width},
                        {"samples_per_bin", args.samples},
                        {"tolerance", args.tolerance},
                        {"rows", out}}
             .dump(1)
      << "\n";
    if (!f) return 1;
  }
  return 0;
}
