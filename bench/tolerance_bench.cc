// The tolerance rule's estimate and the SHRM cube's two synthesis paths, on the bundled
// courtyard.exr at full resolution (1024 x 512, its lighting to the degree each case needs), one
// thread, both variants of each measurement in the same run:
//
// BM_BandEvaluation/{batched,point}   the band contributions of 256 seeded pairs (what
//     BandTable::Compute and EstimateInterpolation evaluate) for microfacet sigma = 0.1 in the
//     normal variable at (F, P) = (128, 12): BandContributionsAtArguments (eight points per Wigner
//     pass, no column storage) against BandContributionsAtArgument one point at a time (its full
//     Wigner columns per point). Session 22: the orders stage of the default job on city.exr went
//     from 48.5 s to 2.9 s with this change.
// BM_CubePath/{grid,direct}/<case>    BuildCube of a global cube by the grid and by the direct
//     path (ShrmGridOptions::CubePath), for the configurations the default job chooses:
//     (36, 31) S 40 (GGX alpha 0.3 f0 0.04, normal variable: direct chosen), (56, 24) S 72
//     (microfacet sigma 0.2: about equal), (14, 5) S 64 (the live issue's configuration: grid).
//     DirectCubeIsCheaper's constants were fitted to such measurements.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_projection.h"
#include "core/envmap/envmap.h"
#include "core/envmap/lighting.h"
#include "core/io/image.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_synthesis.h"
#include "core/shrm/tolerance.h"

namespace shrm {
namespace {

template <class T>
T OrDie(absl::StatusOr<T> v, const char* what) {
  if (!v.ok()) {
    std::fprintf(stderr, "tolerance_bench: %s: %s\n", what,
                 std::string(v.status().message()).c_str());
    std::exit(1);
  }
  return *std::move(v);
}

const EnvMap& Courtyard() {
  static const EnvMap* env = new EnvMap(EnvMap::FromLatLong(OrDie(
      ReadImageRgb(std::string(SHRM_SOURCE_DIR) + "/data/envmaps/courtyard.exr"), "reading")));
  return *env;
}

// The synthesizer of a BRDF spec at (f, p) in a view variable, lighting of degree f.
ShrmSynthesizer MakeSynth(const std::string& spec, int f, int p, ViewVariable view) {
  const std::unique_ptr<Brdf> brdf = OrDie(ParseBrdfSpec(spec), "brdf");
  const BrdfCoefficients coeffs =
      OrDie(ComputeBrdfCoefficients(*brdf, f, p, {}, view), "coefficients");
  const std::vector<double> light =
      OrDie(LightingCoefficients(Courtyard(), f, Mat3::Identity(), 1), "lighting");
  return OrDie(ShrmSynthesizer::Create(f, 3, light, coeffs, f, p), "synthesizer");
}

void BM_BandEvaluation(benchmark::State& state) {
  const bool batched = state.range(0) == 1;
  static const ShrmSynthesizer* synth =
      new ShrmSynthesizer(MakeSynth("microfacet:sigma=0.1", 128, 12, ViewVariable::kNormal));
  const std::vector<DirectionPair> pairs =
      SeededDirectionPairs(kSelectionSeed, 256, ReparamKind::kReflection);
  std::vector<Vec3> index, argument;
  for (const DirectionPair& pair : pairs) {
    index.push_back(IndexDirection(pair, ReparamKind::kReflection));
    argument.push_back(ShrmViewArgument(synth->view(), index.back(), pair.view));
  }
  std::vector<double> out(synth->BandCount() * (batched ? pairs.size() : 1));
  for (auto _ : state) {
    if (batched) {
      synth->BandContributionsAtArguments(index, argument, out);
    } else {
      for (size_t k = 0; k < pairs.size(); ++k)
        synth->BandContributionsAtArgument(index[k], argument[k], out);
    }
    benchmark::DoNotOptimize(out.data());
  }
  state.SetLabel(batched ? "batched" : "one point at a time");
}
BENCHMARK(BM_BandEvaluation)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(2);

struct CubeCase {
  const char* spec;
  int f, p, size;
  ViewVariable view;
};
constexpr CubeCase kCubeCases[] = {
    {"ggx:alpha=0.3,f0=0.04", 36, 31, 40, ViewVariable::kNormal},
    {"microfacet:sigma=0.2", 56, 24, 72, ViewVariable::kNormal},
    {"microfacet:sigma=0.2", 14, 5, 64, ViewVariable::kView},
};

void BM_CubePath(benchmark::State& state) {
  const bool direct = state.range(0) == 1;
  const CubeCase& cs = kCubeCases[state.range(1)];
  const ShrmSynthesizer synth = MakeSynth(cs.spec, cs.f, cs.p, cs.view);
  ShrmGridOptions options;
  options.path = direct ? ShrmGridOptions::CubePath::kDirect : ShrmGridOptions::CubePath::kGrid;
  for (auto _ : state) {
    ShrmCube cube = OrDie(synth.BuildCube(ShrmKind::kGlobal, cs.size, options), "cube");
    benchmark::DoNotOptimize(cube.data.data());
  }
  state.SetLabel(std::string(direct ? "direct " : "grid ") + cs.spec + " (" + std::to_string(cs.f) +
                 ", " + std::to_string(cs.p) + ") S " + std::to_string(cs.size));
}
BENCHMARK(BM_CubePath)
    ->ArgsProduct({{0, 1}, {0, 1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace shrm

BENCHMARK_MAIN();
