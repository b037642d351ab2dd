// Speed and accuracy of FastReference (core/shrm/fast_reference.h) against the brute-force
// BrdfReferenceRadiance on the bundled 1024 x 512 maps, one thread, per BRDF: the CPU time per
// direction of both paths (thread CPU time, best of 2 passes; the machine is shared), the mean
// number of rho-hat evaluations of the fast path and its largest relative error,
//   |fast - full| / max(|full|, 0.01 x mean over the directions of |full|)   (per channel).
// Directions: V uniform on the sphere, N over V's hemisphere with density N.V (the visible points
// of a sphere seen from V); Kajiya-Kay's T uniform on the sphere.
// Flags: --maps=all (all four maps; default courtyard.exr), --map=NAME, --brdf=SPEC (one of the
// list below only), --brute=M (directions timed and checked
// against the brute force, default 16), --fast=N (directions timed on the fast path, default 256),
// --tol=x (relative tolerance, default kFastReferenceTolerance), --hierarchy=cube (the cube faces'
// quadtrees of the map's sample list, Create(samples); default: the lat-long map's own quadtree,
// Create(EnvMap), what a job's check builds).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/shrm/fast_reference.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/tolerance.h"

namespace shrm {
namespace {

// CPU time of the calling thread (s): the machine is shared, so wall time would count the
// other jobs' time slices.
double Now() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// N (or T) and V pairs as in the file comment (SeededDirectionPairs).
void Directions(bool tangent, int count, uint64_t seed, std::vector<Vec3>* index,
                std::vector<Vec3>* view) {
  for (const DirectionPair& p : SeededDirectionPairs(
           seed, count, tangent ? ReparamKind::kTangent : ReparamKind::kReflection)) {
    index->push_back(p.index);
    view->push_back(p.view);
  }
}

const char* const kSpecs[] = {
    "phong:s=8",
    "phong:s=32",
    "phong:s=128",
    "phong:s=512",
    "microfacet:sigma=0.1",
    "microfacet:sigma=0.2",
    "microfacet:sigma=0.3",
    "ggx:alpha=0.1,f0=0.04",
    "ggx:alpha=0.1,f0=1",
    "ggx:alpha=0.3,f0=0.04",
    "ggx:alpha=0.3,f0=1",
    "lambert",
    "kajiya-kay:s=32",
};

int Run(int argc, char** argv) {
  std::vector<std::string> maps = {"courtyard.exr"};
  int brute = 16, fast = 256;
  double tol = kFastReferenceTolerance;
  std::string only;   // --brdf=SPEC: that model only
  bool cube = false;  // --hierarchy=cube
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--map=", 0) == 0) {
      maps = {a.substr(6)};
    } else if (a.rfind("--brdf=", 0) == 0) {
      only = a.substr(7);
    } else if (a == "--hierarchy=cube" || a == "--hierarchy=latlong") {
      cube = a == "--hierarchy=cube";
    } else if (a == "--maps=all") {
      maps = {"city.exr", "courtyard.exr", "forest.exr", "interior.exr"};
    } else if (a.rfind("--brute=", 0) == 0) {
      brute = std::atoi(a.c_str() + 8);
    } else if (a.rfind("--fast=", 0) == 0) {
      fast = std::atoi(a.c_str() + 7);
    } else if (a.rfind("--tol=", 0) == 0) {
      tol = std::atof(a.c_str() + 6);
    } else {
      std::fprintf(stderr, "unknown flag %s\n", a.c_str());
      return 2;
    }
  }
  std::printf("%-14s %-24s %10s %10s %8s %9s %10s\n", "map", "brdf", "full ms", "fast ms",
              "speedup", "evals", "max err");
  for (const std::string& name : maps) {
    auto img = ReadImageRgb(std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name);
    if (!img.ok()) {
      std::fprintf(stderr, "%s\n", std::string(img.status().message()).c_str());
      return 1;
    }
    const EnvMap env = EnvMap::FromLatLong(*std::move(img));
    const double t0 = Now();
    auto ref = cube ? FastReference::Create(env.samples()) : FastReference::Create(env);
    if (!ref.ok()) {
      std::fprintf(stderr, "%s\n", std::string(ref.status().message()).c_str());
      return 1;
    }
    std::printf("%s: %zu samples, hierarchy built in %.0f ms\n", name.c_str(), ref->sample_count(),
                1e3 * (Now() - t0));
    for (const char* spec : kSpecs) {
      if (!only.empty() && only != spec) continue;
      auto brdf = ParseBrdfSpec(spec);
      if (!brdf.ok()) {
        std::fprintf(stderr, "%s\n", std::string(brdf.status().message()).c_str());
        return 1;
      }
      const bool tangent = (*brdf)->reparam() == ReparamKind::kTangent;
      std::vector<Vec3> index, view;
      Directions(tangent, std::max(brute, fast), 1234, &index, &view);
      const Mat3 id = Mat3::Identity();
      std::vector<std::array<double, 3>> full(brute), approx(brute);
      double t_full = 1e30, t_fast = 1e30;
      for (int pass = 0; pass < 2; ++pass) {
        double t = Now();
        if (pass == 0 || brute <= 16) {
          for (int i = 0; i < brute; ++i)
            full[i] = BrdfReferenceRadiance(env.samples(), **brdf, id, index[i], view[i]);
          t_full = std::min(t_full, (Now() - t) / std::max(brute, 1));
        }
        t = Now();
        for (int i = 0; i < fast; ++i) {
          const auto b = ref->Radiance(**brdf, id, index[i], view[i], tol);
          if (i < brute) approx[i] = b;
        }
        t_fast = std::min(t_fast, (Now() - t) / std::max(fast, 1));
      }
      double evals = 0;
      for (int i = 0; i < fast; ++i)
        evals += ref->EvaluationCount(**brdf, id, index[i], view[i], tol);
      evals /= std::max(fast, 1);
      double max_err = 0;
      for (int c = 0; c < 3; ++c) {
        double mean = 0;
        for (int i = 0; i < brute; ++i) mean += std::abs(full[i][c]) / brute;
        for (int i = 0; i < brute; ++i) {
          const double den = std::max(std::abs(full[i][c]), 0.01 * mean);
          if (den > 0) max_err = std::max(max_err, std::abs(approx[i][c] - full[i][c]) / den);
        }
      }
      std::printf("%-14s %-24s %10.3f %10.4f %8.0f %9.0f %10.2e\n", name.c_str(), spec,
                  1e3 * t_full, 1e3 * t_fast, t_full / t_fast, evals, max_err);
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace
}  // namespace shrm

int main(int argc, char** argv) { return shrm::Run(argc, argv); }
