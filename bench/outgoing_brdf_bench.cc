// Per-outgoing-direction BRDF tables (core/brdf/outgoing_table.h): HSH vs SH at equal
// coefficient counts (HSH paper, Gautron et al. 2004, Figs. 4-5), and the cost of
// ComputeOutgoingBrdfTable (docs/results.md).
//
//  1. Relative L2 error of the reconstructed g(w_o, w_i) = f_r cos(theta_i) (Transfer with n = +z)
//     over (outgoing x incoming) upper-hemisphere pairs, counts 1, 4, 9, 16, 25, 36 (lmax 0..5):
//     outgoing = the unclamped texels of a 32 x 32 parabolic table (the paper's 32 x 32 outgoing
//     samples), weighted by their solid angle 4 / (1 + u^2 + v^2)^2 du dv; incoming = the
//     table's own rule for that texel at twice its default sizes (OutgoingIncomingQuadrature).
//     The lmax-L expansion is the truncation of the lmax-5 one (orthonormal projections).
//  2. Time of ComputeOutgoingBrdfTable (32 x 32 texels, 2 threads), median of 5.
//
// Usage: outgoing_brdf_bench [--out=FILE] [--bench] [--benchmark_...]
//   Prints the markdown tables; --out also writes them to FILE; --bench (or any --benchmark_
//   flag) then runs the registered BM_ timings.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/brdf/outgoing_table.h"
#include "core/sh/hsh.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

constexpr int kLmax = 5;
constexpr int kResolution = 32;

template <typename T>
T Must(absl::StatusOr<T> v) {
  if (!v.ok()) {
    std::fprintf(stderr, "error: %s\n", std::string(v.status().message()).c_str());
    std::exit(1);
  }
  return *std::move(v);
}

std::string Fmt(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

struct Case {
  const char* spec;
  const char* note;
};
const std::vector<Case>& Cases() {
  static const auto* cases = new std::vector<Case>{
      {"phong:s=5", "normalized Phong, Fig. 4's exponent"},
      {"phong:s=20", "normalized Phong"},
      {"phong:s=100", "normalized Phong"},
      {"ward:alpha_x=0.2,alpha_y=0.5,rho_s=1,rho_d=0", "anisotropic Ward, Fig. 5's parameters"},
  };
  return *cases;
}

OutgoingBrdfTable Table(const Brdf& brdf, HemisphereBasis basis, int lmax, int threads) {
  OutgoingBrdfTableOptions o;
  o.basis = basis;
  o.lmax = lmax;
  o.resolution = kResolution;
  o.threads = threads;
  return Must(ComputeOutgoingBrdfTable(brdf, o));
}

// err[b][L] = relative L2 error of the degree-L truncation, b = 0 SH, 1 HSH.
struct Errors {
  double err[2][kLmax + 1];
};

Errors MeasureErrors(const Brdf& brdf) {
  const OutgoingBrdfTable sh = Table(brdf, HemisphereBasis::kSh, kLmax, 2);
  const OutgoingBrdfTable hsh = Table(brdf, HemisphereBasis::kHsh, kLmax, 2);
  OutgoingBrdfTableOptions dense = sh.options;  // resolved sizes, doubled
  dense.quad_theta *= 2;
  dense.quad_phi *= 2;
  double err2[2][kLmax + 1] = {}, norm2 = 0;
  std::vector<double> ysh(ShCount(kLmax)), yhsh(ShCount(kLmax));
  const double du = 2.0 / kResolution;
  for (int y = 0; y < kResolution; ++y) {
    for (int x = 0; x < kResolution; ++x) {
      double u = 0, v = 0;
      OutgoingTexelCentre(kResolution, x, y, &u, &v);
      const double r2 = u * u + v * v;
      if (std::sqrt(r2) > OutgoingTexelRadius(kResolution)) continue;  // clamped texels
      const double w_o = 4.0 / ((1.0 + r2) * (1.0 + r2)) * du * du;
      const Vec3 wo = OutgoingTexelDirection(kResolution, x, y);
      const IncomingQuadrature q = Must(OutgoingIncomingQuadrature(brdf, dense, wo));
      const std::span<const float> csh = sh.Texel(x, y, 0), chsh = hsh.Texel(x, y, 0);
      for (size_t i = 0; i < q.dirs.size(); ++i) {
        const double g = brdf.Transfer({0, 0, 1}, wo, q.dirs[i], 0);
        const double w = w_o * q.weights[i];
        norm2 += w * g * g;
        EvalSh(kLmax, q.dirs[i], ysh);
        if (!EvalHsh(kLmax, q.dirs[i], yhsh).ok()) std::exit(1);
        double a_sh = 0, a_hsh = 0;
        for (int l = 0; l <= kLmax; ++l) {
          for (int m = -l; m <= l; ++m) {
            a_sh += csh[ShIndex(l, m)] * ysh[ShIndex(l, m)];
            a_hsh += chsh[ShIndex(l, m)] * yhsh[ShIndex(l, m)];
          }
          err2[0][l] += w * (a_sh - g) * (a_sh - g);
          err2[1][l] += w * (a_hsh - g) * (a_hsh - g);
        }
      }
    }
  }
  Errors e;
  for (int b = 0; b < 2; ++b)
    for (int l = 0; l <= kLmax; ++l) e.err[b][l] = std::sqrt(err2[b][l] / norm2);
  return e;
}

std::string AccuracyTable() {
  std::ostringstream s;
  s << "| BRDF | count (lmax) | SH error | HSH error | HSH / SH |\n|---|---|---|---|---|\n";
  for (const Case& c : Cases()) {
    const std::unique_ptr<Brdf> brdf = Must(ParseBrdfSpec(c.spec));
    const Errors e = MeasureErrors(*brdf);
    for (int l = 0; l <= kLmax; ++l) {
      s << "| `" << c.spec << "` | " << ShCount(l) << " (" << l << ") | "
        << Fmt("%.4f", e.err[0][l]) << " | " << Fmt("%.4f", e.err[1][l]) << " | "
        << Fmt("%.3f", e.err[1][l] / e.err[0][l]) << " |\n";
    }
  }
  s << "\n";
  return s.str();
}

double MedianMs(const Brdf& brdf, HemisphereBasis basis, int lmax) {
  std::vector<double> ms;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    const OutgoingBrdfTable t = Table(brdf, basis, lmax, 2);
    benchmark::DoNotOptimize(t.coeffs.data());
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

std::string TimingTable() {
  std::ostringstream s;
  s << "| BRDF | quadrature (rings x base azimuths) | SH lmax 3 | SH lmax 5 | HSH lmax 3 | "
       "HSH lmax 5 |\n|---|---|---|---|---|---|\n";
  for (const char* spec :
       {"lambert", "phong:s=20", "ggx:alpha=0.3,f0=0.04",
        "ward:alpha_x=0.2,alpha_y=0.5,rho_s=1,rho_d=0", "ggx:alpha=0.1,f0=0.04"}) {
    const std::unique_ptr<Brdf> brdf = Must(ParseBrdfSpec(spec));
    const OutgoingBrdfTable t = Table(*brdf, HemisphereBasis::kSh, 5, 2);
    s << "| `" << spec << "` | " << t.options.quad_theta << " x " << t.options.quad_phi;
    for (HemisphereBasis b : {HemisphereBasis::kSh, HemisphereBasis::kHsh}) {
      for (int lmax : {3, 5}) s << " | " << Fmt("%.0f ms", MedianMs(*brdf, b, lmax));
    }
    s << " |\n";
  }
  s << "\n";
  return s.str();
}

void BM_ComputeOutgoingBrdfTable(benchmark::State& state) {
  const std::unique_ptr<Brdf> brdf = Must(ParseBrdfSpec("ggx:alpha=0.3,f0=0.04"));
  const HemisphereBasis basis = state.range(0) ? HemisphereBasis::kHsh : HemisphereBasis::kSh;
  for (auto _ : state) {
    const OutgoingBrdfTable t = Table(*brdf, basis, static_cast<int>(state.range(1)), 2);
    benchmark::DoNotOptimize(t.coeffs.data());
  }
  state.SetItemsProcessed(state.iterations() * kResolution * kResolution);
}
BENCHMARK(BM_ComputeOutgoingBrdfTable)
    ->Args({0, 3})
    ->Args({1, 3})
    ->Args({0, 5})
    ->Args({1, 5})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_Lookup(benchmark::State& state) {
  const std::unique_ptr<Brdf> brdf = Must(ParseBrdfSpec("ggx:alpha=0.3,f0=0.04"));
  const OutgoingBrdfTable t = Table(*brdf, HemisphereBasis::kHsh, 5, 2);
  std::vector<double> out(t.count);
  double a = 0;
  for (auto _ : state) {
    a += 0.001;
    t.Lookup({0.6 * std::cos(a), 0.6 * std::sin(a), 0.8}, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Lookup);

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) {
  std::string out_path;
  bool run_bench = false;
  std::vector<char*> bench_args = {argv[0]};
  std::string command = "outgoing_brdf_bench";
  for (int i = 1; i < argc; ++i) {
    command += std::string(" ") + argv[i];
    if (std::strncmp(argv[i], "--out=", 6) == 0) {
      out_path = argv[i] + 6;
    } else if (std::strcmp(argv[i], "--bench") == 0) {
      run_bench = true;
    } else {
      if (std::strncmp(argv[i], "--benchmark_", 12) == 0) run_bench = true;
      bench_args.push_back(argv[i]);
    }
  }
  std::ostringstream doc;
  doc << "Generated by `" << command << "` (bench/outgoing_brdf_bench.cc, Release build).\n\n"
      << "Relative L2 error of g = f_r cos(theta_i) reconstructed from its per-outgoing-direction "
         "coefficients, over (outgoing x incoming) upper-hemisphere pairs; outgoing = the "
      << shrm::kResolution << " x " << shrm::kResolution
      << " parabolic table's unclamped texels (theta_o <= 88.2 deg) weighted by solid angle; "
         "incoming = the table's rule at twice its default size.\n\n"
      << shrm::AccuracyTable() << "ComputeOutgoingBrdfTable, " << shrm::kResolution << " x "
      << shrm::kResolution << " texels, 2 threads, median of 5 runs:\n\n"
      << shrm::TimingTable();
  std::fputs(doc.str().c_str(), stdout);
  if (!out_path.empty()) {
    std::ofstream f(out_path);
    f << doc.str();
    if (!f) {
      std::fprintf(stderr, "error: cannot write %s\n", out_path.c_str());
      return 1;
    }
  }
  if (run_bench) {
    int bargc = static_cast<int>(bench_args.size());
    benchmark::Initialize(&bargc, bench_args.data());
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
  }
  return 0;
}
