// The live session (core/live/live_session.h, issue 13): time from an update to its frame, one
// thread, the configuration: the bundled maps box-downsampled to 256 x 128, microfacet
// sigma 0.2 at epsilon 0.03, a global SHRM of 64 x 64 x 6 texels.
//
//   build/bench/live_bench [--benchmark_format=json]
//
// BM_LiveRotation        the lighting rotated (L_lm and rho_lpq cached: rotation, analysis,
//                        synthesis)
// BM_LiveNewMap          another map each update (two maps alternating; the session caches one:
//                        transform, analysis, synthesis)
// BM_LiveMaterialCached  the material switched between two specs the session has seen (rho_lpq
//                        and L_lm cached: analysis, synthesis)
// BM_LiveMaterialNew     a new material parameter each update (rho_lpq computed)
// BM_LiveMaterialNewOf/<model>  the same for each analytic model: its first parameter nudged
//                        each update (the "any analytic BRDF")
// BM_LiveSequence        an HDR sequence: a 1024 x 512 EXR decoded and prefiltered per frame
// BM_LiveView            the view of the frames' reflection map (eq. 5.35) changed: the cube
//                        reused, the 64 x 64 x 6 map of the view computed
// BM_LiveLatestWins      ten updates sent at once, then the frame of the last: what a producer
//                        ten times faster than the computation waits for
// BM_LiveSplitSumRotation  a session handing out the split-sum set alone (no BRDF): `shrm ibl`'s
//                          default chain (Filament preset, 256 x 256 down to 16 x 16, and the
//                          32 x 32 irradiance) of the full 1024 x 512 courtyard, turned about
//                          +Y each update (the cached coefficients rotated at degree 256)
// BM_LiveSplitSumSequence  the same set of a new 1024 x 512 map each update (decode included:
//                          the transform to degree 511 and the chain)
// BM_LiveSplitSumMaterial  SHRM and split-sum set together, the material changed (the set reused)
// BM_SynthesisGlobal/F/P   the synthesis stage alone: the 64 x 64 x 6 global SHRM of (F, P)
//                          from fixed coefficients (the orders of the material benchmarks: ggx
//                          (14, 5), microfacet sigma 0.1 (22, 2), Ward (21, 2)), the grid and
//                          the cube's storage reused as the live session reuses them
// BM_SynthesisZonal/F/P    the same for Kajiya-Kay's q = 0-only coefficients at (9, 8) (the
//                          zonal path), the storage reused as the live session reuses it
// Targets (issue 13): lighting and material changes <= 5 ms, the sequence >= 30 frames/s.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/ibl/split_sum.h"
#include "core/io/image.h"
#include "core/live/live_session.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm {
namespace {

constexpr int kMapWidth = 256;
constexpr int kFaceSize = 64;
constexpr absl::Duration kWait = absl::Seconds(60);

template <typename T>
T OrDie(absl::StatusOr<T> v, const char* what) {
  if (!v.ok()) {
    std::fprintf(stderr, "live_bench: %s: %s\n", what, std::string(v.status().message()).c_str());
    std::exit(1);
  }
  return *std::move(v);
}

std::string MapPath(const std::string& name) {
  return std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name;
}

// data/envmaps/<name> box-filtered to 256 x 128.
std::shared_ptr<const EnvMap> SmallMap(const std::string& name) {
  const Image full = OrDie(ReadImageRgb(MapPath(name)), "reading a map");
  Image out;
  out.width = kMapWidth;
  out.height = kMapWidth / 2;
  out.channels = 3;
  out.pixels.assign(static_cast<size_t>(out.width) * out.height * 3, 0.0f);
  const int fx = full.width / out.width, fy = full.height / out.height;
  for (int y = 0; y < full.height; ++y)
    for (int x = 0; x < full.width; ++x)
      for (int c = 0; c < 3; ++c)
        out.pixels[((y / fy) * out.width + x / fx) * 3 + c] += full.at(x, y, c) / (fx * fy);
  return std::make_shared<const EnvMap>(EnvMap::FromLatLong(std::move(out)));
}

std::shared_ptr<const Brdf> Parsed(const std::string& spec) {
  return std::shared_ptr<const Brdf>(OrDie(ParseBrdfSpec(spec), "BRDF spec"));
}

std::unique_ptr<LiveSession> Session() {
  PrefilterOptions o;
  o.epsilon = 0.03;
  o.face_size = kFaceSize;
  o.threads = 1;
  return OrDie(LiveSession::Create(o), "session");
}

// Waits for the frame of `update`; a failed frame stops the benchmark.
void Await(benchmark::State& state, const LiveSession& s, uint64_t update) {
  const auto f = OrDie(s.WaitFor(update, kWait), "frame");
  if (!f->status.ok()) state.SkipWithError(std::string(f->status.message()).c_str());
}

void Counters(benchmark::State& state, const LiveSession& s) {
  const LiveStats st = s.Stats();
  state.counters["frames"] = static_cast<double>(st.frames);
  state.counters["dropped"] = static_cast<double>(st.dropped);
  const auto f = s.Latest();
  if (f != nullptr) {
    state.counters["F_B"] = f->result.analysis.f_b;
    state.counters["P_B"] = f->result.analysis.p_b;
    for (const StageTiming& t : f->result.timings) state.counters[t.stage + "_ms"] = t.ms;
  }
}

void BM_LiveRotation(benchmark::State& state) {
  auto s = Session();
  s->SetMap(SmallMap("courtyard.exr"));
  Await(state, *s, s->SetBrdf(Parsed("microfacet:sigma=0.2")));
  double angle = 0;
  for (auto _ : state) Await(state, *s, s->SetRotation(RotationZ(angle += 0.01)));
  Counters(state, *s);
}
BENCHMARK(BM_LiveRotation)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LiveNewMap(benchmark::State& state) {
  auto s = Session();
  const std::shared_ptr<const EnvMap> maps[2] = {SmallMap("courtyard.exr"), SmallMap("city.exr")};
  s->SetMap(maps[0]);
  Await(state, *s, s->SetBrdf(Parsed("microfacet:sigma=0.2")));
  int k = 0;
  for (auto _ : state) Await(state, *s, s->SetMap(maps[++k % 2]));
  Counters(state, *s);
}
BENCHMARK(BM_LiveNewMap)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LiveMaterialCached(benchmark::State& state) {
  auto s = Session();
  const std::shared_ptr<const Brdf> brdfs[2] = {Parsed("microfacet:sigma=0.2"),
                                                Parsed("microfacet:sigma=0.25")};
  s->SetMap(SmallMap("courtyard.exr"));
  Await(state, *s, s->SetBrdf(brdfs[1]));
  Await(state, *s, s->SetBrdf(brdfs[0]));
  int k = 0;
  for (auto _ : state) Await(state, *s, s->SetBrdf(brdfs[++k % 2]));
  Counters(state, *s);
}
BENCHMARK(BM_LiveMaterialCached)->Unit(benchmark::kMillisecond)->UseRealTime();

// `format` holds one "%g": the model's first parameter, nudged from `base` each update.
std::shared_ptr<const Brdf> ParsedWith(const std::string& format, double v) {
  return Parsed(absl::StrReplaceAll(format, {{"%g", absl::StrCat(v)}}));
}

void BM_LiveMaterialNewOf(benchmark::State& state, const char* format, double base) {
  auto s = Session();
  s->SetMap(SmallMap("courtyard.exr"));
  Await(state, *s, s->SetBrdf(ParsedWith(format, base)));
  int k = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const auto brdf = ParsedWith(format, base * (1 + 1e-4 * (++k % 500)));
    state.ResumeTiming();
    Await(state, *s, s->SetBrdf(brdf));
  }
  Counters(state, *s);
}

// The configuration (microfacet sigma 0.2).
void BM_LiveMaterialNew(benchmark::State& state) {
  BM_LiveMaterialNewOf(state, "microfacet:sigma=%g", 0.2);
}
BENCHMARK(BM_LiveMaterialNew)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, microfacet_0_1, "microfacet:sigma=%g", 0.1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, microfacet_0_3, "microfacet:sigma=%g", 0.3)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, phong_32, "phong:s=%g", 32.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, phong_128, "phong:s=%g", 128.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, ggx_0_3_f0_1, "ggx:alpha=%g,f0=1", 0.3)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, ward_0_2, "ward:alpha=%g,rho_s=0.1,rho_d=0", 0.2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, lafortune_20, "lafortune:cx=-1,cy=-1,cz=1,n=%g,rho=1", 20.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, ggx_0_3_f0_0_04, "ggx:alpha=%g,f0=0.04", 0.3)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, ggx_0_1_f0_0_04, "ggx:alpha=%g,f0=0.04", 0.1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, lambert, "lambert:albedo=%g", 0.8)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_LiveMaterialNewOf, kajiya_kay_32, "kajiya-kay:s=%g", 32.0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_LiveSequence(benchmark::State& state) {
  auto s = Session();
  const std::string names[4] = {"courtyard.exr", "city.exr", "forest.exr", "interior.exr"};
  s->SetMap(std::make_shared<const EnvMap>(
      EnvMap::FromLatLong(OrDie(ReadImageRgb(MapPath(names[3])), "decode"))));
  Await(state, *s, s->SetBrdf(Parsed("microfacet:sigma=0.2")));
  int k = 0;
  for (auto _ : state) {
    auto map = std::make_shared<const EnvMap>(
        EnvMap::FromLatLong(OrDie(ReadImageRgb(MapPath(names[k++ % 4])), "decode")));
    Await(state, *s, s->SetMap(std::move(map)));
  }
  Counters(state, *s);
}
BENCHMARK(BM_LiveSequence)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LiveView(benchmark::State& state) {
  auto s = Session();
  s->SetMap(SmallMap("courtyard.exr"));
  Await(state, *s, s->SetBrdf(Parsed("microfacet:sigma=0.2")));
  double angle = 0;
  for (auto _ : state) {
    angle += 0.01;
    Await(state, *s, s->SetView(Vec3{std::cos(angle), 0.3, std::sin(angle)}));
  }
  Counters(state, *s);
}
BENCHMARK(BM_LiveView)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LiveLatestWins(benchmark::State& state) {
  auto s = Session();
  s->SetMap(SmallMap("courtyard.exr"));
  Await(state, *s, s->SetBrdf(Parsed("microfacet:sigma=0.2")));
  double angle = 0;
  for (auto _ : state) {
    uint64_t last = 0;
    for (int i = 0; i < 10; ++i) last = s->SetRotation(RotationZ(angle += 0.01));
    Await(state, *s, last);
  }
  Counters(state, *s);
}
BENCHMARK(BM_LiveLatestWins)->Unit(benchmark::kMillisecond)->UseRealTime();

// `shrm ibl`'s defaults (jobs/ibl_job.h: 256 x 256 Filament chain, tolerance 1e-3 / 30, a
// 32 x 32 irradiance cube).
std::unique_ptr<LiveSession> SplitSumSession() {
  PrefilterOptions o;
  o.epsilon = 0.03;
  o.face_size = kFaceSize;
  o.threads = 1;
  ibl::SplitSumSetOptions ss;
  ss.chain = OrDie(ibl::MakeMipChain(ibl::RoughnessPreset::kFilament, 256, 0), "chain");
  ss.tolerance = 1e-3 / 30;
  ss.irradiance_size = 32;
  return OrDie(LiveSession::Create(o, nullptr, ss), "session");
}

std::shared_ptr<const EnvMap> FullMap(const std::string& name) {
  return std::make_shared<const EnvMap>(
      EnvMap::FromLatLong(OrDie(ReadImageRgb(MapPath(name)), "decode")));
}

void BM_LiveSplitSumRotation(benchmark::State& state) {
  auto s = SplitSumSession();
  Await(state, *s, s->SetMap(FullMap("courtyard.exr"), RotationY(0.01)));
  double yaw = 0.01;
  for (auto _ : state) Await(state, *s, s->SetRotation(RotationY(yaw += 0.01)));
  Counters(state, *s);
}
BENCHMARK(BM_LiveSplitSumRotation)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LiveSplitSumSequence(benchmark::State& state) {
  auto s = SplitSumSession();
  const std::string names[4] = {"courtyard.exr", "city.exr", "forest.exr", "interior.exr"};
  Await(state, *s, s->SetMap(FullMap(names[3])));
  int k = 0;
  for (auto _ : state) Await(state, *s, s->SetMap(FullMap(names[k++ % 4])));
  Counters(state, *s);
}
BENCHMARK(BM_LiveSplitSumSequence)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LiveSplitSumMaterial(benchmark::State& state) {
  auto s = SplitSumSession();
  const std::shared_ptr<const Brdf> brdfs[2] = {Parsed("microfacet:sigma=0.2"),
                                                Parsed("microfacet:sigma=0.25")};
  s->SetMap(FullMap("courtyard.exr"));
  Await(state, *s, s->SetBrdf(brdfs[1]));
  Await(state, *s, s->SetBrdf(brdfs[0]));
  int k = 0;
  for (auto _ : state) Await(state, *s, s->SetBrdf(brdfs[++k % 2]));
  Counters(state, *s);
}
BENCHMARK(BM_LiveSplitSumMaterial)->Unit(benchmark::kMillisecond)->UseRealTime();

// A synthesizer of fixed RGB coefficients at (F, P): every rho_lpq set, or (tangent) q = 0 only,
// as Kajiya-Kay's.
ShrmSynthesizer FixedSynthesizer(int f, int p, bool tangent) {
  std::vector<double> light(static_cast<size_t>(ShCount(f)) * 3);
  for (size_t i = 0; i < light.size(); ++i) light[i] = std::cos(0.37 * static_cast<double>(i));
  BrdfCoefficients rho;
  rho.lmax = f;
  rho.pmax = p;
  rho.channels = 1;
  rho.values.assign(static_cast<size_t>(f + 1) * (p + 1) * (p + 1), 0.0);
  if (tangent) {
    rho.reparam = ReparamKind::kTangent;
    for (int l = 0; l <= f; ++l)
      for (int pp = 0; pp <= p; ++pp) rho.values[rho.Index(l, pp, 0, 0)] = 1.0 / (1.0 + l + pp);
  } else {
    for (size_t i = 0; i < rho.values.size(); ++i) rho.values[i] = 1.0 / (1.0 + 0.1 * i);
  }
  return OrDie(ShrmSynthesizer::Create(f, 3, light, rho), "creating the synthesizer");
}

// The global cube of FixedSynthesizer(F, P, tangent) per iteration, the grid and the cube's
// storage reused as in a live session (SynthesisScratch with the previous cube's buffer).
void TimeGlobalCubes(benchmark::State& state, bool tangent) {
  const ShrmSynthesizer synth =
      FixedSynthesizer(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), tangent);
  SynthesisScratch scratch;
  ShrmGridOptions options;
  options.scratch = &scratch;
  for (auto _ : state) {
    ShrmCube cube = OrDie(synth.BuildCube(ShrmKind::kGlobal, kFaceSize, options), "synthesis");
    benchmark::DoNotOptimize(cube.data.data());
    scratch.cube = std::move(cube.data);
  }
}

void BM_SynthesisGlobal(benchmark::State& state) { TimeGlobalCubes(state, false); }
BENCHMARK(BM_SynthesisGlobal)
    ->Args({14, 5})
    ->Args({22, 2})
    ->Args({21, 2})
    ->Args({70, 9})   // GGX alpha 0.1 f0 0.04 at epsilon 0.03 (the automatic 4 (F + P + 1) rows)
    ->Args({56, 24})  // courtyard microfacet sigma 0.2, the tolerance rule's default orders
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Kajiya-Kay's synthesis alone: a global SHRM of tangent-reparameterized coefficients (q = 0
// only: the zonal path, BuildZonalGlobalCube) at its analysed (9, 8), its storage reused as the
// live session reuses it.
void BM_SynthesisZonal(benchmark::State& state) { TimeGlobalCubes(state, true); }
BENCHMARK(BM_SynthesisZonal)->Args({9, 8})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace shrm

BENCHMARK_MAIN();
