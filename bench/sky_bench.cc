// Speed of the procedural sky (core/envmap/sky.h), one thread: a lat-long map re-rendered for a
// moving sun, as shrm-view --live does per frame (RenderSkyLatLongInto, storage reused), at the
// viewer's 256 x 128 and at 1024 x 512, with and without the sun disc; and, for scale, the
// per-direction model (SkyModel::SkyRgb, the tests' slow twin) over the same pixels. The sun
// moves along an equinox day at 45 N, one step per iteration. Counter: pixels per second.
#include <benchmark/benchmark.h>

#include <cmath>

#include "core/envmap/sky.h"

namespace shrm::sky {
namespace {

// The sun of step k: an equinox day at 45 N, from 7:00 to 17:00 solar time in 64 steps.
Vec3 SunAt(int64_t k) {
  const double t = 7 + 10.0 * static_cast<double>(k % 64) / 63;
  return SunDirection(SunFromSolarTime(t, 0, 45 * kPi / 180));
}

void BM_RenderSky(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0));
  SkyOptions options;
  options.sun_disc = state.range(1) != 0;
  Image image;
  int64_t k = 0;
  for (auto _ : state) {
    const absl::Status s = RenderSkyLatLongInto(SunAt(k++), options, width, &image);
    if (!s.ok()) state.SkipWithError(std::string(s.message()).c_str());
    benchmark::DoNotOptimize(image.pixels.data());
  }
  state.SetItemsProcessed(state.iterations() * width * (width / 2));
  state.SetLabel(options.sun_disc ? "sky + sun + ground" : "sky + ground");
}
BENCHMARK(BM_RenderSky)
    ->ArgsProduct({{256, 1024}, {0, 1}})
    ->ArgNames({"width", "sun"})
    ->Unit(benchmark::kMillisecond);

// The per-direction evaluation over the upper half of the same grid (the slow twin).
void BM_PerDirectionSky(benchmark::State& state) {
  const int width = static_cast<int>(state.range(0)), height = width / 2;
  SkyOptions options;
  int64_t k = 0;
  for (auto _ : state) {
    const absl::StatusOr<SkyModel> model = SkyModel::Create(SunAt(k++), options);
    double sum = 0;
    for (int j = 0; j < height / 2; ++j) {
      const double t = kPi * (j + 0.5) / height;
      for (int i = 0; i < width; ++i) {
        const double p = 2 * kPi * ((i + 0.5) / width - 0.5);
        const Vec3 d{std::sin(t) * std::sin(p), std::cos(t), -std::sin(t) * std::cos(p)};
        sum += model->SkyRgb(d)[1];
      }
    }
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * width * (height / 2));
}
BENCHMARK(BM_PerDirectionSky)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shrm::sky

BENCHMARK_MAIN();
