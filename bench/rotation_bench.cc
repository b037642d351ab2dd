// Rotation of one real SH coefficient vector at n = 6 and n = 10 (lmax 5 and 9), after the
// comparison of Krivanek et al., "Fast Approximation to Spherical Harmonic Rotation", sec. 3.2
// (Taylor "1.5th" order measured 6x faster than the zxzxz-rotation at n = 10).
//
// Every "fresh" benchmark rotates by a different rotation each iteration (a pool of 1024 random
// rotations with zyz beta < 0.2 rad, as for per-pixel normal-map rotation), starting from the
// 3x3 matrix, so the zyz decomposition and all sin/cos are included:
//   BM_ExactPrecomputed  ShRotation::Apply with the band matrices built beforehand (one rotation)
//   BM_ZxzxzSameRotation zxzxz-rotation of many vectors by one rotation (angles precomputed)
//   BM_ExactFresh        ShRotation::Create + Apply (d(beta) recurrence, real blocks, product)
//   BM_ZxzxzFresh        zxzxz-rotation (fixed x(pi/2) sub-blocks, three z-rotations)
//   BM_RotateShFresh     the public RotateSh() (zxzxz with a per-thread cached operator)
//   BM_Taylor1Fresh / BM_Taylor15Fresh / BM_Taylor2Fresh  z exact + Taylor y + z exact
//   BM_LimitedFresh      the sec. 4.2 rotator (all pool rotations are below its beta_lim)
// After the runs a summary prints ns per rotation and the speed-up of Taylor 1.5th over each
// exact path, followed by the sec. 3.1 error table.
// Flags: Google Benchmark's (--benchmark_format=json / --benchmark_out=FILE for the timings) and
// --json FILE: also write the sec. 3.1 error table (the paper's Fig. 3) as JSON, the input of
// scripts/plots.py. --benchmark_filter=NONE prints only the error table.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/sh/quadrature.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/sh/taylor_rotation.h"
#include "nlohmann/json.hpp"

namespace shrm {
namespace {

constexpr int kPool = 1024;
constexpr double kMaxPoolBeta = 0.2;

struct Fixture {
  explicit Fixture(int degree) : lmax(degree) {
    std::mt19937_64 rng(42 + lmax);
    std::uniform_real_distribution<double> ang(-kPi, kPi), small(0, kMaxPoolBeta), u(-1, 1);
    for (int i = 0; i < kPool; ++i) {
      rotations.push_back(MatrixFromEuler({ang(rng), small(rng), ang(rng)}));
    }
    in.resize(ShCount(lmax));
    for (double& x : in) x = u(rng);
    out.resize(in.size());
  }
  int lmax;
  std::vector<Mat3> rotations;
  std::vector<double> in, out;
};

template <typename F>
void RunFresh(benchmark::State& state, F&& rotate) {
  Fixture f(static_cast<int>(state.range(0)));
  int i = 0;
  for (auto _ : state) {
    rotate(f, f.rotations[i]);
    benchmark::DoNotOptimize(f.out.data());
    benchmark::ClobberMemory();
    i = (i + 1) & (kPool - 1);
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_ExactPrecomputed(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  const ShRotation r = ShRotation::Create(f.lmax, f.rotations[0]);
  for (auto _ : state) {
    r.Apply(f.in, f.out);
    benchmark::DoNotOptimize(f.out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_ExactFresh(benchmark::State& state) {
  RunFresh(state,
           [](Fixture& f, const Mat3& r) { ShRotation::Create(f.lmax, r).Apply(f.in, f.out); });
}

// zxzxz applying many vectors by one rotation (angles decomposed once): the alternative to
// ShRotation::Apply that the issue asks to measure.
void BM_ZxzxzSameRotation(benchmark::State& state) {
  Fixture f(static_cast<int>(state.range(0)));
  const ZxzxzRotation z = *ZxzxzRotation::Create(f.lmax);
  const ZyzCosSin angles = ZyzCosSinFromMatrix(f.rotations[0]);
  for (auto _ : state) {
    z.Apply(angles, f.in, f.out);
    benchmark::DoNotOptimize(f.out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_RotateShFresh(benchmark::State& state) {
  RunFresh(state, [](Fixture& f, const Mat3& r) { RotateSh(f.lmax, r, f.in, f.out); });
}

void BM_ZxzxzFresh(benchmark::State& state) {
  const ZxzxzRotation z = *ZxzxzRotation::Create(static_cast<int>(state.range(0)));
  RunFresh(state, [&z](Fixture& f, const Mat3& r) { z.Apply(r, f.in, f.out); });
}

template <TaylorOrder kOrder>
void BM_TaylorFresh(benchmark::State& state) {
  const TaylorYRotation t = *TaylorYRotation::Create(static_cast<int>(state.range(0)));
  RunFresh(state, [&t](Fixture& f, const Mat3& r) { RotateShTaylor(t, kOrder, r, f.in, f.out); });
}

void BM_LimitedFresh(benchmark::State& state) {
  const LimitedAngleRotation lim =
      *LimitedAngleRotation::Create(static_cast<int>(state.range(0)), kMaxPoolBeta + 0.01);
  RunFresh(state, [&lim](Fixture& f, const Mat3& r) { lim.Apply(r, f.in, f.out); });
}

BENCHMARK(BM_ExactPrecomputed)->Arg(5)->Arg(9);
BENCHMARK(BM_ZxzxzSameRotation)->Arg(5)->Arg(9);
BENCHMARK(BM_ExactFresh)->Arg(5)->Arg(9);
BENCHMARK(BM_ZxzxzFresh)->Arg(5)->Arg(9);
BENCHMARK(BM_RotateShFresh)->Arg(5)->Arg(9);
BENCHMARK(BM_TaylorFresh<TaylorOrder::kFirst>)->Name("BM_Taylor1Fresh")->Arg(5)->Arg(9);
BENCHMARK(BM_TaylorFresh<TaylorOrder::kOneAndHalf>)->Name("BM_Taylor15Fresh")->Arg(5)->Arg(9);
BENCHMARK(BM_TaylorFresh<TaylorOrder::kSecond>)->Name("BM_Taylor2Fresh")->Arg(5)->Arg(9);
BENCHMARK(BM_LimitedFresh)->Arg(5)->Arg(9);

// Captures ns per iteration of each run for the summary.
class SummaryReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    // With --benchmark_repetitions the median is kept, otherwise the single run.
    for (const Run& r : runs) {
      const std::string name = r.run_name.str();
      if (r.run_type == Run::RT_Aggregate && r.aggregate_name == "median") {
        ns_[name] = r.GetAdjustedRealTime();
        medians_[name] = true;
      } else if (r.run_type == Run::RT_Iteration && !medians_[name]) {
        ns_[name] = r.GetAdjustedRealTime();
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
  double Ns(const std::string& name) const {
    auto it = ns_.find(name);
    return it == ns_.end() ? std::nan("") : it->second;
  }

 private:
  std::map<std::string, double> ns_;
  std::map<std::string, bool> medians_;
};

std::vector<double> PhongLobe(int lmax) {
  const RingQuadrature q = GaussLegendreRule(32);
  std::vector<double> c(ShCount(lmax), 0.0);
  for (size_t j = 0; j < q.theta.size(); ++j) {
    const double x = 0.5 * (q.cos_theta[j] + 1);
    const std::vector<double> y = EvalSh(lmax, DirectionFromAngles(std::acos(x), 0.0));
    for (int l = 0; l <= lmax; ++l)
      c[ShIndex(l, 0)] += kPi * q.weight[j] * std::pow(x, 7) * y[ShIndex(l, 0)];
  }
  double n = 0;
  for (double v : c) n += v * v;
  for (double& v : c) v /= std::sqrt(n);
  return c;
}

// The sec. 3.1 table: one row per (n, beta); also returned as JSON rows.
nlohmann::ordered_json PrintErrorTable() {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  std::printf(
      "\nSec. 3.1 error of R'_y(beta) (orders 1 / 1.5 / 2): max and mean singular value of\n"
      "R_y - R'_y over all n^2 singular values, and ||(R_y - R'_y) c|| for the unit cos^7 lobe\n");
  std::printf("%3s %5s | %-23s | %-23s | %-23s\n", "n", "deg", "max sv", "mean sv", "cos^7 lobe");
  for (int n : {5, 8, 10}) {
    const TaylorYRotation t = *TaylorYRotation::Create(n - 1);
    const std::vector<double> lobe = PhongLobe(n - 1);
    for (double deg : {2.0, 5.0, 7.16, 10.0, 14.3, 20.0, 25.0, 30.0, 40.0}) {
      const double b = deg * kPi / 180;
      double mx[3], mean[3], ph[3];
      int k = 0;
      for (TaylorOrder o : {TaylorOrder::kFirst, TaylorOrder::kOneAndHalf, TaylorOrder::kSecond}) {
        const TaylorErrorStats s = TaylorYErrorStats(t, o, b);
        mx[k] = s.max, mean[k] = s.mean, ph[k] = TaylorYErrorForVector(t, o, b, lobe);
        ++k;
      }
      std::printf("%3d %5.2f | %7.4f %7.4f %7.4f | %7.4f %7.4f %7.4f | %7.4f %7.4f %7.4f\n", n, deg,
                  mx[0], mx[1], mx[2], mean[0], mean[1], mean[2], ph[0], ph[1], ph[2]);
      // Orders 1 / 1.5 / 2 in this order in every array.
      rows.push_back({{"n", n},
                      {"beta_deg", deg},
                      {"max_sv", {mx[0], mx[1], mx[2]}},
                      {"mean_sv", {mean[0], mean[1], mean[2]}},
                      {"cos7_lobe", {ph[0], ph[1], ph[2]}}});
    }
  }
  return rows;
}

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) {
  // --json FILE is ours; everything else goes to Google Benchmark.
  std::string json_path;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0 && i + 1 < argc) {
      json_path = argv[++i];
    } else {
      args.push_back(argv[i]);
    }
  }
  argc = static_cast<int>(args.size());
  argv = args.data();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  shrm::SummaryReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  std::printf("\nSummary: ns per rotation of one vector (fresh = new rotation every call)\n");
  std::printf("%-22s %12s %12s\n", "method", "n=6", "n=10");
  const char* names[] = {"BM_ExactPrecomputed", "BM_ZxzxzSameRotation", "BM_ExactFresh",
                         "BM_ZxzxzFresh",       "BM_RotateShFresh",     "BM_Taylor1Fresh",
                         "BM_Taylor15Fresh",    "BM_Taylor2Fresh",      "BM_LimitedFresh"};
  for (const char* name : names) {
    std::printf("%-22s %12.1f %12.1f\n", name, reporter.Ns(std::string(name) + "/5"),
                reporter.Ns(std::string(name) + "/9"));
  }
  std::printf("\nSpeed-up of Taylor 1.5th (fresh) over:\n");
  for (const char* name :
       {"BM_ExactFresh", "BM_ZxzxzFresh", "BM_RotateShFresh", "BM_ExactPrecomputed"}) {
    std::printf("%-22s %11.2fx %11.2fx\n", name,
                reporter.Ns(std::string(name) + "/5") / reporter.Ns("BM_Taylor15Fresh/5"),
                reporter.Ns(std::string(name) + "/9") / reporter.Ns("BM_Taylor15Fresh/9"));
  }
  nlohmann::ordered_json doc;
  doc["bench"] = "rotation_bench";
  doc["orders"] = {"1", "1.5", "2"};
  doc["lobe"] = "unit-length zonal max(cos theta, 0)^7";
  doc["error_table"] = shrm::PrintErrorTable();
  benchmark::Shutdown();
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
