// Speed of the split-sum chain (core/ibl/split_sum.h) on a bundled 1024 x 512 map, one thread,
// against the 1024-sample importance-sampled estimate that cmgen and glTF-IBL-Sampler compute
// (the tests' second reference), in the same run: the full GGX chain of the Filament preset
// (256 x 256 down to 16 x 16), its stages (the map's coefficients, the chain from them), the
// irradiance cube, and the importance-sampled chain over the same texels. Counters: the largest
// relative RMS and largest relative error of any level against the brute-force pixel sum at 32
// seeded texel centres per level (|got - ref| / max(|ref|, 0.01 mean |ref|), luminance). Also the
// DFG table's time.
// Flags: --map=NAME (default courtyard.exr), --size=S (default 256).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>

#include "core/base/cubemap.h"
#include "core/envmap/envmap.h"
#include "core/ibl/dfg.h"
#include "core/ibl/split_sum.h"

namespace shrm::ibl {
namespace {

std::string g_map = "courtyard.exr";
int g_size = 256;

const EnvMap& Map() {
  static const EnvMap map = [] {
    auto m = EnvMap::Load({.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + g_map}});
    if (!m.ok()) std::abort();
    return *m;
  }();
  return map;
}

SpecularOptions Options() {
  SpecularOptions opt;
  opt.chain = *MakeMipChain(RoughnessPreset::kFilament, g_size, 0);
  opt.tolerance = 1e-3 / 30;  // the IBL job's default (jobs/ibl_job.h)
  return opt;
}

// Largest per-level RMS and largest error of `chain` against the pixel sum.
std::pair<double, double> Accuracy(const SpecularChain& chain) {
  double rms = 0, largest = 0;
  for (size_t k = 0; k < chain.levels.size(); ++k) {
    if (chain.levels[k].alpha == 0) continue;
    const LevelError e =
        MeasureLevelError(Map(), SpecularLobe::kGgx, chain.levels[k], Mat3::Identity(), 32, 17 + k);
    rms = std::max(rms, e.rms);
    largest = std::max(largest, e.max);
  }
  return {rms, largest};
}

void BM_GgxChain(benchmark::State& state) {
  const EnvMap& map = Map();
  SpecularChain chain;
  for (auto _ : state) {
    auto c = PrefilterSpecular(map, Options());
    if (!c.ok()) state.SkipWithError(std::string(c.status().message()).c_str());
    chain = std::move(c).value();
  }
  const auto [rms, largest] = Accuracy(chain);
  state.counters["worst_level_rms"] = rms;
  state.counters["worst_level_max"] = largest;
  state.counters["degree_level1"] = chain.levels.size() > 1 ? chain.levels[1].degree : 0;
}
BENCHMARK(BM_GgxChain)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

void BM_GgxChainLighting(benchmark::State& state) {
  for (auto _ : state) {
    auto l = ComputeSpecularLight(Map(), Mat3::Identity(), 0, 1);
    benchmark::DoNotOptimize(l);
  }
}
BENCHMARK(BM_GgxChainLighting)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

void BM_GgxChainFromLighting(benchmark::State& state) {
  auto light = ComputeSpecularLight(Map(), Mat3::Identity(), 0, 1);
  if (!light.ok()) std::abort();
  for (auto _ : state) {
    auto c = PrefilterSpecular(Map(), Options(), &*light);
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_GgxChainFromLighting)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

void BM_ImportanceSampled1024(benchmark::State& state) {
  const EnvMap& map = Map();
  const MipChain mc = Options().chain;
  SpecularChain chain;
  for (auto _ : state) {
    chain.levels.clear();
    for (int k = 0; k < mc.levels(); ++k) {
      SpecularLevel level;
      level.face_size = mc.face_size[k];
      level.roughness = mc.roughness[k];
      level.alpha = level.roughness * level.roughness;
      level.cube.face_size = level.face_size;
      level.cube.data.resize(level.cube.size());
      if (level.alpha > 0) {
        const int s = level.face_size;
        for (int f = 0; f < kCubeFaceCount; ++f)
          for (int y = 0; y < s; ++y)
            for (int x = 0; x < s; ++x) {
              const auto v =
                  ImportanceSampledGgx(map, level.alpha, CubeTexelDirection(f, x, y, s), 1024);
              for (int c = 0; c < 3; ++c) level.cube.data[level.cube.Index(f, x, y, c)] = v[c];
            }
      }
      chain.levels.push_back(std::move(level));
    }
  }
  const auto [rms, largest] = Accuracy(chain);
  state.counters["worst_level_rms"] = rms;
  state.counters["worst_level_max"] = largest;
}
BENCHMARK(BM_ImportanceSampled1024)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();

// The DFG table (core/ibl/dfg.h) by its deterministic quadrature, one thread: Filament's three
// channels and Karis' two, at 128 and 256.
void BM_DfgLut(benchmark::State& state) {
  const DfgConsumer consumer = state.range(1) == 0 ? DfgConsumer::kFilament : DfgConsumer::kKaris;
  for (auto _ : state) {
    auto lut = ComputeDfgLut(static_cast<int>(state.range(0)), consumer, 1);
    benchmark::DoNotOptimize(lut);
  }
  state.SetLabel(DfgConsumerName(consumer));
}
BENCHMARK(BM_DfgLut)
    ->Args({128, 0})
    ->Args({128, 1})
    ->Args({256, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

}  // namespace
}  // namespace shrm::ibl

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--map=", 6) == 0) shrm::ibl::g_map = argv[i] + 6;
    if (std::strncmp(argv[i], "--size=", 7) == 0) shrm::ibl::g_size = std::atoi(argv[i] + 7);
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
