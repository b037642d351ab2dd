// BRDF coefficients (SHRM paper eq. 5.22) and order selection (eqs. 5.17/5.18, sec. 5.6.2):
// the orders chosen for the microfacet model of eq. 5.34 (Table 5.5, epsilon = 0.03) and for
// normalized Phong (eq. 5.26; exact order and eq. 5.28's estimate), with timings.
//
// Prints a table to stdout, then runs the Google Benchmark timings
// (ComputeBrdfCoefficients at the selected orders' (F_max, P_max), SelectBrdfOrders).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_models.h"
#include "core/brdf/brdf_projection.h"

namespace shrm {
namespace {

constexpr double kEpsilon = 0.03;

double Ms(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double, std::milli>(d).count();
}

void PrintTable() {
  std::printf("SHRM BRDF orders at epsilon = %.2f (captured fraction >= 1 - epsilon)\n", kEpsilon);
  std::printf("%-22s %5s %4s %10s %6s %6s %12s %12s\n", "brdf", "F", "P", "captured", "Fmax",
              "Pmax", "select(ms)", "coeffs(ms)");
  const auto row = [](const std::string& spec, const char* extra) {
    auto brdf = ParseBrdfSpec(spec);
    if (!brdf.ok()) {
      std::printf("%s: %s\n", spec.c_str(), brdf.status().ToString().c_str());
      return;
    }
    const auto t0 = std::chrono::steady_clock::now();
    auto orders = SelectBrdfOrders(**brdf, kEpsilon);
    const auto t1 = std::chrono::steady_clock::now();
    if (!orders.ok()) {
      std::printf("%s: %s\n", spec.c_str(), orders.status().ToString().c_str());
      return;
    }
    auto coeffs = ComputeBrdfCoefficients(**brdf, orders->fmax, orders->pmax);
    const auto t2 = std::chrono::steady_clock::now();
    std::printf("%-22s %5d %4d %10.5f %6d %6d %12.1f %12.1f %s\n", spec.c_str(), orders->F,
                orders->P, orders->captured, orders->fmax, orders->pmax, Ms(t1 - t0), Ms(t2 - t1),
                extra);
  };
  const char* paper[] = {"paper (24,3)", "paper (12,2)", "paper (7,2)", "paper (5,2)",
                         "paper (5,2)"};
  for (int i = 1; i <= 5; ++i) {
    row("microfacet:sigma=0." + std::to_string(i), paper[i - 1]);
  }
  for (int s = 8; s <= 512; s *= 2) {
    char extra[96];
    std::snprintf(extra, sizeof(extra), "exact F %d, eq. 5.28 F %.2f", PhongOrderExact(s, kEpsilon),
                  PhongOrderEq528(s, kEpsilon));
    row("phong:s=" + std::to_string(s), extra);
  }
  std::fflush(stdout);
}

void BM_SelectMicrofacet(benchmark::State& state) {
  const MicrofacetBrdf brdf(state.range(0) / 10.0);
  for (auto _ : state) {
    auto orders = SelectBrdfOrders(brdf, kEpsilon);
    benchmark::DoNotOptimize(orders);
  }
}
BENCHMARK(BM_SelectMicrofacet)->DenseRange(1, 5)->Unit(benchmark::kMillisecond);

void BM_CoefficientsMicrofacet(benchmark::State& state) {
  const MicrofacetBrdf brdf(state.range(0) / 10.0);
  const BrdfBandwidthHint hint = brdf.bandwidth_hint();
  for (auto _ : state) {
    auto coeffs = ComputeBrdfCoefficients(brdf, hint.lmax, hint.pmax);
    benchmark::DoNotOptimize(coeffs);
  }
}
BENCHMARK(BM_CoefficientsMicrofacet)->DenseRange(1, 5)->Unit(benchmark::kMillisecond);

void BM_SelectPhong(benchmark::State& state) {
  const PhongBrdf brdf(static_cast<double>(state.range(0)));
  for (auto _ : state) {
    auto orders = SelectBrdfOrders(brdf, kEpsilon);
    benchmark::DoNotOptimize(orders);
  }
}
BENCHMARK(BM_SelectPhong)->RangeMultiplier(2)->Range(8, 512)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) {
  shrm::PrintTable();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
