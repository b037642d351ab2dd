// The viewer's per-frame CPU work in mode 1 (viewer/reflection_sum.h): the reflection map of one
// view from a global SHRM (SHRM paper eq. 5.35), B~(R) = sum_pq B^_pq(R) Y_pq(V), for a
// 64 x 64 x 6 cube at P = 3 (the target: <= 1 ms per frame), against core's
// ReflectionMapForView (the slow twin the tests compare it with) and at other sizes.
// The SHRM: courtyard.exr, microfacet sigma = 0.2, explicit orders (F, P) = (20, P), global.
// The view turns by 1 degree per iteration (Y_pq(V) is evaluated every frame, as in the viewer).
// Items processed = texels.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <utility>

#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_explicit.h"
#include "viewer/reflection_sum.h"

namespace shrm::viewer {
namespace {

// The global SHRM of (face size, P), computed once per process.
const ShrmCube& Cube(int face_size, int pmax) {
  static std::map<std::pair<int, int>, ShrmCube> cache;
  auto it = cache.find({face_size, pmax});
  if (it != cache.end()) return it->second;
  static const EnvMap env = [] {
    EnvMapOptions o;
    o.paths = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/courtyard.exr"};
    return EnvMap::Load(o).value();
  }();
  const std::unique_ptr<Brdf> brdf = ParseBrdfSpec("microfacet:sigma=0.2").value();
  PrefilterOptions opt;
  opt.f = 20;
  opt.p = pmax;
  opt.face_size = face_size;
  opt.kind = ShrmKind::kGlobal;
  opt.threads = 2;
  return cache.emplace(std::pair{face_size, pmax}, Prefilter(env, *brdf, opt).value().cube)
      .first->second;
}

Vec3 ViewAt(int64_t i) {
  const double a = 0.0174533 * static_cast<double>(i % 360);
  return Vec3{std::sin(a) * 0.9, 0.4359, std::cos(a) * 0.9}.Normalized();
}

// Args: face size, P, threads.
void BM_GlobalReflectionSum(benchmark::State& state) {
  const ShrmCube& cube = Cube(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const GlobalReflectionSum sum = GlobalReflectionSum::Create(cube).value();
  RadianceCube out;
  const int threads = static_cast<int>(state.range(2));
  sum.Compute(ViewAt(0), &out, threads);
  int64_t i = 0;
  for (auto _ : state) {
    sum.Compute(ViewAt(++i), &out, threads);
    benchmark::DoNotOptimize(out.data.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * 6 * cube.face_size * cube.face_size);
}
BENCHMARK(BM_GlobalReflectionSum)
    ->Args({64, 3, 1})
    ->Args({64, 3, 2})
    ->Args({32, 3, 1})
    ->Args({128, 3, 1})
    ->Args({128, 3, 2})
    ->Args({64, 6, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The slow twin: core's eq. 5.35 (allocates the output map each call).
void BM_CoreReflectionMapForView(benchmark::State& state) {
  const ShrmCube& cube = Cube(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  int64_t i = 0;
  for (auto _ : state) {
    absl::StatusOr<RadianceCube> map = ReflectionMapForView(cube, ViewAt(++i), 1);
    benchmark::DoNotOptimize(map->data.data());
  }
  state.SetItemsProcessed(state.iterations() * 6 * cube.face_size * cube.face_size);
}
BENCHMARK(BM_CoreReflectionMapForView)->Args({64, 3})->Unit(benchmark::kMillisecond)->UseRealTime();

// The per-cube setup of mode 1 (coefficient planes), paid once per new SHRM.
void BM_GlobalReflectionSumCreate(benchmark::State& state) {
  const ShrmCube& cube = Cube(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  for (auto _ : state) {
    absl::StatusOr<GlobalReflectionSum> s = GlobalReflectionSum::Create(cube);
    benchmark::DoNotOptimize(&s);
  }
}
BENCHMARK(BM_GlobalReflectionSumCreate)->Args({64, 3})->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shrm::viewer

BENCHMARK_MAIN();
