// Speed of the split-sum chain (core/ibl/split_sum.h) on a bundled 1024 x 512 map, one thread,
// against the 1024-sample importance-sampled estimate that cmgen and glTF-IBL-Sampler compute
// (the tests' second reference), in the same run: the full GGX chain of the Filament preset
// (256 x 256 down to 16 x 16), its stages (the map's coefficients to the degree the set needs,
// and to the map's 511 as before; the chain from them), the
// irradiance cube, and the importance-sampled chain over the same texels. Counters: the largest
// relative RMS and largest relative error of any level against the brute-force pixel sum at 32
// seeded texel centres per level (|got - ref| / max(|ref|, 0.01 mean |ref|), luminance). Also the
// DFG table's time, and the time and size of each container and format.
// Flags: --map=NAME (default courtyard.exr), --size=S (default 256).
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>

#include "core/base/cubemap.h"
#include "core/envmap/envmap.h"
#include "core/export/ktx1.h"
#include "core/export/ktx2.h"
#include "core/ibl/dfg.h"
#include "core/ibl/light_peaks.h"
#include "core/ibl/split_sum.h"

namespace shrm::ibl {
namespace {

std::string g_map = "courtyard.exr";
int g_size = 256;

const EnvMap& Map() {
  static const EnvMap map = [] {
    EnvMapOptions options;
    options.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + g_map};
    auto m = EnvMap::Load(options);
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

// The split-sum set's options of the job's defaults (chain, tolerance, irradiance).
SplitSumSetOptions SetOptions() {
  SplitSumSetOptions opt;
  opt.chain = Options().chain;
  opt.tolerance = Options().tolerance;
  return opt;
}

// The map's coefficients to the degree the set needs (ComputeSplitSumLight), then the chain: what
// `shrm ibl` computes for its GGX chain.
void BM_GgxChain(benchmark::State& state) {
  const EnvMap& map = Map();
  SpecularChain chain;
  for (auto _ : state) {
    auto light = ComputeSplitSumLight(map, Mat3::Identity(), SetOptions(), 1);
    if (!light.ok()) state.SkipWithError(std::string(light.status().message()).c_str());
    auto c = PrefilterSpecular(map, Options(), &*light);
    if (!c.ok()) state.SkipWithError(std::string(c.status().message()).c_str());
    chain = std::move(c).value();
  }
  const auto [rms, largest] = Accuracy(chain);
  state.counters["worst_level_rms"] = rms;
  state.counters["worst_level_max"] = largest;
  state.counters["degree_level1"] = chain.levels.size() > 1 ? chain.levels[1].degree : 0;
}
BENCHMARK(BM_GgxChain)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The map's coefficients to the largest degree it resolves (511), as before session 26.
void BM_GgxChainLighting(benchmark::State& state) {
  for (auto _ : state) {
    auto l = ComputeSpecularLight(Map(), Mat3::Identity(), 0, 1);
    benchmark::DoNotOptimize(l);
  }
}
BENCHMARK(BM_GgxChainLighting)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The same to the degree the set needs (SplitSumLightDegree).
void BM_SplitSumLighting(benchmark::State& state) {
  int degree = 0;
  for (auto _ : state) {
    auto l = ComputeSplitSumLight(Map(), Mat3::Identity(), SetOptions(), 1);
    degree = l.ok() ? l->degree : -1;
    benchmark::DoNotOptimize(l);
  }
  state.counters["degree"] = degree;
}
BENCHMARK(BM_SplitSumLighting)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

void BM_GgxChainFromLighting(benchmark::State& state) {
  auto light = ComputeSplitSumLight(Map(), Mat3::Identity(), SetOptions(), 1);
  if (!light.ok()) std::abort();
  for (auto _ : state) {
    auto c = PrefilterSpecular(Map(), Options(), &*light);
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_GgxChainFromLighting)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The job's irradiance cube (jobs/ibl_job.cc): one Lambert level of 32 x 32 from the lighting.
// The base level alone (roughness 0: the map resampled at every texel centre of 6 x S^2).
void BM_BaseLevel(benchmark::State& state) {
  SpecularOptions opt;
  const double zero[] = {0.0};
  opt.chain = *MakeMipChain(RoughnessPreset::kExplicit, g_size, 1, zero);
  // state.range(0) = 1: the caches flushed before each run (the map read from memory, as in a
  // job, where the transform has passed through tens of MB since the map was decoded).
  std::vector<char> flush(state.range(0) ? size_t{64} << 20 : 0);
  for (auto _ : state) {
    if (!flush.empty()) {
      state.PauseTiming();
      for (size_t i = 0; i < flush.size(); i += 64) flush[i] = static_cast<char>(flush[i] + 1);
      benchmark::ClobberMemory();
      state.ResumeTiming();
    }
    auto chain = PrefilterSpecular(Map(), opt);
    if (!chain.ok()) std::abort();
    benchmark::DoNotOptimize(chain->levels[0].cube.data.data());
  }
}
BENCHMARK(BM_BaseLevel)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_IrradianceCubeFromLighting(benchmark::State& state) {
  auto light = ComputeSplitSumLight(Map(), Mat3::Identity(), SetOptions(), 1);
  if (!light.ok()) std::abort();
  SpecularOptions opt = Options();
  opt.lobe = SpecularLobe::kLambert;
  const double one[] = {1.0};
  opt.chain = *MakeMipChain(RoughnessPreset::kExplicit, 32, 1, one);
  for (auto _ : state) {
    auto c = PrefilterSpecular(Map(), opt, &*light);
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_IrradianceCubeFromLighting)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();

// The map's peaks split off (core/ibl/light_peaks.h; none on courtyard: run with
// --map=interior.exr, 128 peaks, or city.exr, 29), and their direct sums at every texel of the
// Filament chain's sharpest level (128 x 128 faces, alpha = 0.134^2).
void BM_SplitLightPeaks(benchmark::State& state) {
  size_t peaks = 0;
  for (auto _ : state) {
    const PeakSplit split = SplitLightPeaks(Map());
    peaks = split.peaks.size();
    benchmark::DoNotOptimize(split);
  }
  state.counters["peaks"] = static_cast<double>(peaks);
}
BENCHMARK(BM_SplitLightPeaks)->Unit(benchmark::kMillisecond);

void BM_PeakSums(benchmark::State& state) {
  const PeakSplit split = SplitLightPeaks(Map());
  const double r = 1 - std::sqrt(0.75);  // level 1 of 5 (Filament: 1 - sqrt(1 - t))
  const PeakKernel kernel = SplitSumPeakKernel(SpecularLobe::kGgx, r * r);
  RadianceCube cube;
  cube.face_size = g_size / 2;
  cube.data.assign(cube.size(), 0.0f);
  for (auto _ : state) {
    AddPeakSums(split.peaks, kernel, cube, 1);
    benchmark::ClobberMemory();
  }
  state.counters["peaks"] = static_cast<double>(split.peaks.size());
}
BENCHMARK(BM_PeakSums)->Unit(benchmark::kMillisecond);

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

// Writing the chain (computed once) into each container and format, in memory: KTX2 (RGBA, the
// alpha channel 1 as the job writes it) and KTX1 (RGB, Filament's frame). Counter: the file's
// bytes.
const SpecularChain& Chain() {
  static const SpecularChain chain = *PrefilterSpecular(Map(), Options());
  return chain;
}

void BM_EncodeKtx2(benchmark::State& state) {
  const ktx2::Format format = static_cast<ktx2::Format>(state.range(0));
  const int channels = ktx2::ChannelCount(format);
  ktx2::Ktx2Image image;
  image.format = format;
  image.faces = 6;
  image.width = image.height = Chain().levels.front().face_size;
  for (const SpecularLevel& l : Chain().levels) {
    ktx2::Level level;
    level.width = level.height = l.face_size;
    const size_t texels = l.cube.data.size() / 3;
    level.pixels.assign(texels * channels, 1.0f);
    for (size_t t = 0; t < texels; ++t)
      for (int c = 0; c < 3; ++c)
        level.pixels[t * channels + c] = std::max(0.0f, l.cube.data[t * 3 + c]);
    image.levels.push_back(std::move(level));
  }
  size_t bytes = 0;
  for (auto _ : state) {
    auto b = ktx2::EncodeKtx2(image);
    if (!b.ok()) state.SkipWithError(std::string(b.status().message()).c_str());
    bytes = b->size();
  }
  state.counters["bytes"] = static_cast<double>(bytes);
  state.SetLabel(std::string(ktx2::FormatName(format)));
}
BENCHMARK(BM_EncodeKtx2)
    ->Arg(static_cast<int>(ktx2::Format::kR16G16B16A16Sfloat))
    ->Arg(static_cast<int>(ktx2::Format::kR32G32B32A32Sfloat))
    ->Arg(static_cast<int>(ktx2::Format::kB10G11R11UfloatPack32))
    ->Arg(static_cast<int>(ktx2::Format::kE5B9G9R9UfloatPack32))
    ->Unit(benchmark::kMillisecond);

void BM_EncodeKtx1Filament(benchmark::State& state) {
  const ktx1::Format format = static_cast<ktx1::Format>(state.range(0));
  const Mat3 frame{{{{-1, 0, 0}, {0, 1, 0}, {0, 0, -1}}}};  // Filament's (docs/ibl.md)
  size_t bytes = 0;
  for (auto _ : state) {
    ktx1::Ktx1Cube cube;
    cube.format = format;
    for (const SpecularLevel& l : Chain().levels) {
      ktx1::CubeLevel level;
      level.size = l.face_size;
      level.pixels.resize(l.cube.data.size());
      CubeInFrame(frame, l.face_size, 3, l.cube.data.data(), level.pixels.data());
      for (float& v : level.pixels) v = std::max(0.0f, v);
      cube.levels.push_back(std::move(level));
    }
    auto b = ktx1::EncodeKtx1Cube(cube, "bench");
    if (!b.ok()) state.SkipWithError(std::string(b.status().message()).c_str());
    bytes = b->size();
  }
  state.counters["bytes"] = static_cast<double>(bytes);
  state.SetLabel(ktx1::FormatName(format));
}
BENCHMARK(BM_EncodeKtx1Filament)
    ->Arg(static_cast<int>(ktx1::Format::kRgb16f))
    ->Arg(static_cast<int>(ktx1::Format::kRgb32f))
    ->Arg(static_cast<int>(ktx1::Format::kR11fG11fB10f))
    ->Unit(benchmark::kMillisecond);

// The DFG table (core/ibl/dfg.h) by its deterministic quadrature, one thread: Filament's three
// channels and Karis' two, at 128 and 256.
void BM_DfgLut(benchmark::State& state) {
  const DfgConsumer consumer = state.range(1) == 0 ? DfgConsumer::kFilament : DfgConsumer::kKaris;
  for (auto _ : state) {
    auto lut = ComputeDfgLutByQuadrature(static_cast<int>(state.range(0)), LayoutFor(consumer), 1);
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

// What a job pays for the default 128^2 table: the copy out of the build's precomputed table.
void BM_DfgLutPrecomputed(benchmark::State& state) {
  for (auto _ : state) {
    auto lut = ComputeDfgLut(kPrecomputedDfgSize, DfgConsumer::kFilament, 1);
    benchmark::DoNotOptimize(lut);
  }
}
BENCHMARK(BM_DfgLutPrecomputed)->Unit(benchmark::kMicrosecond);

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
