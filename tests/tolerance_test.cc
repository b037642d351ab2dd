// The per-direction tolerance rule (core/shrm/tolerance.h) against independent references:
//   - the band decomposition sums to the direct evaluation of core/shrm/shrm_synthesis.h
//     (RadianceAt: the full Wigner table, a different code path) at every truncation;
//   - the seeded pairs have the distribution of the visible points of a sphere (moments);
//   - the error measure on a hand-computed case;
//   - on the four bundled maps (downsampled: the job and the reference see the same map), the
//     job chosen for the default tolerance, evaluated from its cube (ShrmEval) at pairs it did
//     not use, against a double sum over every pixel of the map (testing::LatLongSamples, solid
//     angles from the test's own quadrature), meets the tolerance in front and its estimate
//     predicts the measured error.
#include "core/shrm/tolerance.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/io/image.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_synthesis.h"
#include "gtest/gtest.h"
#include "tests/test_maps.h"

namespace shrm {
namespace {

// Partial sums of the band table against RadianceAt: double rounding over O(F^2 P) terms of
// values O(1).
constexpr double kBandSumTol = 1e-9;
// The default tolerance of the job layer (per-direction relative RMS in front).
constexpr double kTolerance = 0.01;
// Lat-long width of the downsampled maps (256 x 128: 32k pixels per reference sum; the lighting
// resolves degree 127, above every order chosen here).
constexpr int kMapWidth = 256;
// Pairs of the measured check (kVerifySeed, never the selection's).
constexpr int kPairs = 256;
// The estimate against the measurement: the measured front RMS may exceed the estimated total
// (truncation and interpolation in quadrature) by this factor plus kEstimateSlack (float
// storage, the BRDF coefficients' quadrature, and the sampling of 256 pairs).
constexpr double kEstimateFactor = 2.0;
constexpr double kEstimateSlack = 2e-3;
// The job's own check (FastReference, within 1e-3 of the full sum per direction) against this
// test's full sum at the same pairs: the relative errors differ by at most about 1e-3 each.
constexpr double kVerifyAgreement = 2e-3;

using testing::LatLongSamples;
using testing::LoadBundledMap;

std::unique_ptr<Brdf> ParseOrDie(const std::string& spec) {
  auto b = ParseBrdfSpec(spec);
  EXPECT_TRUE(b.ok()) << b.status();
  return b.ok() ? *std::move(b) : nullptr;
}

// sum_k L_k dOmega_k rho-hat(N, V, w_k), grey transfer evaluated once per sample.
Rgb BruteForce(const std::vector<EnvSample>& samples, const Brdf& brdf, const Vec3& n,
               const Vec3& v) {
  Rgb out{0, 0, 0};
  for (const EnvSample& s : samples) {
    for (int c = 0; c < 3; ++c) {
      const double t = brdf.Transfer(n, v, s.dir, brdf.channels() == 1 ? 0 : c);
      out[c] += static_cast<double>(s.rgb[c]) * s.solid_angle * t;
      if (brdf.channels() == 1) {
        out[1] += static_cast<double>(s.rgb[1]) * s.solid_angle * t;
        out[2] += static_cast<double>(s.rgb[2]) * s.solid_angle * t;
        break;
      }
    }
  }
  return out;
}

// `brdf` on `env` at explicit orders (F, P): the job's lighting and BRDF coefficients (its stages
// without the synthesis) and the synthesizer made from them.
struct Expansion {
  PrefilterResult stages;
  std::optional<ShrmSynthesizer> synth;
};
absl::StatusOr<Expansion> ExpansionAt(const EnvMap& env, const Brdf& brdf, int f, int p,
                                      ViewVariable view = PrefilterOptions{}.view) {
  PrefilterOptions opt;
  opt.f = f;
  opt.p = p;
  opt.view = view;
  opt.synthesize = false;
  absl::StatusOr<PrefilterResult> r = Prefilter(env, brdf, opt);
  if (!r.ok()) return r.status();
  absl::StatusOr<ShrmSynthesizer> synth =
      ShrmSynthesizer::Create(r->light_lmax, 3, r->light, r->brdf, f, p);
  if (!synth.ok()) return synth.status();
  Expansion e{*std::move(r), std::nullopt};
  e.synth.emplace(*std::move(synth));
  return e;
}

TEST(ToleranceTest, BandContributionsSumToTheDirectValueAtEveryTruncation) {
  const Image img = LoadBundledMap("courtyard.exr", 64);
  const EnvMap env = EnvMap::FromLatLong(img);
  auto brdf = ParseOrDie("microfacet:sigma=0.3");
  ASSERT_NE(brdf, nullptr);
  auto e = ExpansionAt(env, *brdf, 12, 4);
  ASSERT_TRUE(e.ok()) << e.status();
  const PrefilterResult* r = &e->stages;
  const std::vector<DirectionPair> pairs = SeededDirectionPairs(7, 12, ReparamKind::kReflection);
  const BandTable table = BandTable::Compute(*e->synth, pairs, 2);
  const std::vector<double> ones(13, 1.0);
  for (const auto& [f, p] : {std::pair{12, 4}, std::pair{7, 2}, std::pair{3, 0}}) {
    auto part = ShrmSynthesizer::Create(r->light_lmax, 3, r->light, r->brdf, f, p);
    ASSERT_TRUE(part.ok()) << part.status();
    for (size_t k = 0; k < pairs.size(); ++k) {
      const Vec3 index = IndexDirection(pairs[k], ReparamKind::kReflection);
      for (ShrmKind kind : {ShrmKind::kGlobal, ShrmKind::kLocal}) {
        const Rgb direct = part->RadianceAt(kind, index, pairs[k].view);
        const Rgb bands = table.Value(static_cast<int>(k), f, p, ones);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(bands[c], direct[c], kBandSumTol * (1 + std::abs(direct[c])))
              << "pair " << k << " (F, P) = (" << f << ", " << p << ") channel " << c;
      }
    }
  }
}

// The batched evaluation (BandContributionsAtArguments: kWignerBlock points per Wigner pass, the
// columns m and -m together) against the one-point path, band by band, and its band sums against
// the direct value (RadianceAtArgument, the full Wigner table): every view variable, both
// reparameterizations (Kajiya-Kay's tangent keeps q = 0 only), P above F (q <= F), and point
// counts that fill no block, one block and part of a second.
TEST(ToleranceTest, BatchedBandContributionsEqualThePointByPointOnes) {
  const Image img = LoadBundledMap("city.exr", 64);
  const EnvMap env = EnvMap::FromLatLong(img);
  struct Case {
    std::string spec;
    int f, p;
    ViewVariable view;
  };
  const std::vector<Case> cases = {
      {"microfacet:sigma=0.2", 20, 6, ViewVariable::kView},
      {"microfacet:sigma=0.2", 20, 6, ViewVariable::kNormal},
      {"ggx:alpha=0.3,f0=0.04", 3, 5, ViewVariable::kNormal},
      {"kajiya-kay:s=32", 12, 4, ViewVariable::kView},
  };
  for (const Case& cs : cases) {
    auto brdf = ParseOrDie(cs.spec);
    ASSERT_NE(brdf, nullptr);
    PrefilterOptions opt;
    opt.f = cs.f;
    opt.p = cs.p;
    opt.view = cs.view;
    opt.synthesize = false;
    auto r = Prefilter(env, *brdf, opt);
    ASSERT_TRUE(r.ok()) << r.status();
    auto synth = ShrmSynthesizer::Create(r->light_lmax, 3, r->light, r->brdf, cs.f, cs.p);
    ASSERT_TRUE(synth.ok()) << synth.status();
    for (const int count : {1, 8, 13}) {
      const std::vector<DirectionPair> pairs = SeededDirectionPairs(11, count, brdf->reparam());
      std::vector<Vec3> index, argument;
      for (const DirectionPair& pair : pairs) {
        index.push_back(IndexDirection(pair, brdf->reparam()));
        argument.push_back(ShrmViewArgument(synth->view(), index.back(), pair.view));
      }
      const size_t n = synth->BandCount();
      std::vector<double> batched(n * count), one(n);
      synth->BandContributionsAtArguments(index, argument, batched);
      for (int k = 0; k < count; ++k) {
        synth->BandContributionsAtArgument(index[k], argument[k], one);
        const Rgb direct = synth->RadianceAtArgument(ShrmKind::kLocal, index[k], argument[k]);
        Rgb sum{0, 0, 0};
        for (size_t i = 0; i < n; ++i) {
          EXPECT_NEAR(batched[k * n + i], one[i], kBandSumTol * (1 + std::abs(one[i])))
              << cs.spec << " " << ViewVariableName(cs.view) << " point " << k << " of " << count
              << " term " << i;
          sum[i % 3] += batched[k * n + i];
        }
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(sum[c], direct[c], kBandSumTol * (1 + std::abs(direct[c])))
              << cs.spec << " point " << k << " channel " << c;
      }
    }
  }
}

TEST(ToleranceTest, SeededPairsAreTheVisiblePointsOfASphere) {
  constexpr int kCount = 20000;
  const std::vector<DirectionPair> pairs =
      SeededDirectionPairs(kSelectionSeed, kCount, ReparamKind::kReflection);
  ASSERT_EQ(pairs.size(), static_cast<size_t>(kCount));
  // Density N.V on the hemisphere about V: E[N.V] = 2/3, P(N.V < 0.3) = 0.09; V uniform: E[V] = 0.
  double mean_cos = 0, grazing = 0;
  Vec3 mean_v{0, 0, 0};
  for (const DirectionPair& p : pairs) {
    EXPECT_NEAR(p.index.Norm(), 1, 1e-12);
    const double c = p.index.Dot(p.view);
    EXPECT_GE(c, 0);
    EXPECT_EQ(p.grazing, c < kGrazingCosine);
    mean_cos += c / kCount;
    grazing += p.grazing ? 1.0 / kCount : 0.0;
    mean_v = mean_v + p.view * (1.0 / kCount);
  }
  // 5 standard errors of the sample means (sd of N.V 0.236, of the grazing indicator 0.286, of
  // a component of V 0.577).
  EXPECT_NEAR(mean_cos, 2.0 / 3, 5 * 0.236 / std::sqrt(kCount));
  EXPECT_NEAR(grazing, kGrazingCosine * kGrazingCosine, 5 * 0.286 / std::sqrt(kCount));
  EXPECT_LT(mean_v.Norm(), 5 * 0.577 / std::sqrt(kCount));
  // The same seed gives the same pairs; the verification seed other pairs.
  const auto again = SeededDirectionPairs(kSelectionSeed, 3, ReparamKind::kReflection);
  const auto other = SeededDirectionPairs(kVerifySeed, 3, ReparamKind::kReflection);
  EXPECT_EQ(again[2].view.x, pairs[2].view.x);
  EXPECT_NE(other[0].view.x, pairs[0].view.x);
}

// The job's check's pairs: the same distribution, a quarter drawn from the grazing band. Each
// band's pairs follow the band's own law (N.V^2 uniform over its part of [0, 1): under density
// N.V, E[N.V | N.V < 0.3] = 0.2 and E[N.V | N.V >= 0.3] = (2/3)(1 - 0.3^3) / (1 - 0.3^2)), and the
// weights make the set's weighted means those of the whole distribution (E[N.V] = 2/3).
TEST(ToleranceTest, StratifiedPairsHaveEachBandsLawAndTheWholeWeightedMean) {
  constexpr int kCount = 20000;
  const std::vector<DirectionPair> pairs =
      StratifiedDirectionPairs(kVerifySeed, kCount, ReparamKind::kReflection);
  ASSERT_EQ(pairs.size(), static_cast<size_t>(kCount));
  const double p_graze = kGrazingCosine * kGrazingCosine;
  const double mean_graze = 2.0 / 3 * kGrazingCosine;
  const double mean_front = 2.0 / 3 * (1 - std::pow(kGrazingCosine, 3)) / (1 - p_graze);
  double sum_graze = 0, sum_front = 0, weighted = 0, total_weight = 0;
  int n_graze = 0, n_front = 0;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const DirectionPair& p = pairs[k];
    const double c = p.index.Dot(p.view);
    EXPECT_EQ(p.grazing, k % kGrazingStride == kGrazingStride - 1) << k;
    if (p.grazing) {
      EXPECT_LT(c, kGrazingCosine + 1e-12) << k;
      sum_graze += c;
      ++n_graze;
    } else {
      EXPECT_GE(c, kGrazingCosine - 1e-12) << k;
      sum_front += c;
      ++n_front;
    }
    weighted += p.weight * c;
    total_weight += p.weight;
  }
  EXPECT_EQ(n_graze, kCount / kGrazingStride);
  // 5 standard errors (sd of N.V within the grazing band 0.071, within the front 0.19; of the
  // weighted mean ~0.19 / sqrt(n)).
  EXPECT_NEAR(sum_graze / n_graze, mean_graze, 5 * 0.071 / std::sqrt(n_graze));
  EXPECT_NEAR(sum_front / n_front, mean_front, 5 * 0.19 / std::sqrt(n_front));
  EXPECT_NEAR(weighted / total_weight, 2.0 / 3, 5 * 0.19 / std::sqrt(kCount));
  // The first n pairs are the set of n (the job's check and the report's error map).
  const std::vector<DirectionPair> first =
      StratifiedDirectionPairs(kVerifySeed, 64, ReparamKind::kReflection);
  for (size_t k = 0; k < first.size(); ++k) {
    EXPECT_EQ(first[k].index.x, pairs[k].index.x);
    EXPECT_EQ(first[k].view.y, pairs[k].view.y);
  }
  // The floor's mean is the distribution's: a value that is 1 in front and 0 grazing has the
  // weighted mean 1 - 0.09, not the set's 3/4.
  std::vector<Rgb> ref(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    const double v = pairs[k].grazing ? 0.0 : 1.0;
    ref[k] = {v, v, v};
  }
  EXPECT_NEAR(RelativeFloor(pairs, ref)[0], kRelativeFloor * (1 - p_graze), 1e-12);
}

TEST(ToleranceTest, ErrorMeasureDividesByTheFloorWhereThereIsNoLight) {
  std::vector<DirectionPair> pairs(3);
  pairs[2].grazing = true;
  // Means of |ref|: (100 + 0 + 50) / 3 = 50 per channel, floor 0.5.
  const std::vector<Rgb> ref = {{100, 100, 100}, {0, 0, 0}, {50, 50, 50}};
  const std::vector<Rgb> got = {{101, 99, 100}, {0.25, -1, 0}, {55, 50, 50}};
  const DirectionalError e = MeasureDirectionalError(pairs, got, ref);
  EXPECT_EQ(e.front.count, 6);
  EXPECT_EQ(e.grazing.count, 3);
  // Front: 0.01, 0.01, 0, 0.25 / 0.5, 1 / 0.5, 0.
  EXPECT_NEAR(e.front.max, 2.0, 1e-12);
  EXPECT_NEAR(e.front.rms, std::sqrt((1e-4 + 1e-4 + 0.25 + 4) / 6), 1e-12);
  EXPECT_NEAR(e.grazing.max, 0.1, 1e-12);
  EXPECT_NEAR(e.grazing.rms, std::sqrt(0.01 / 3), 1e-12);
  EXPECT_EQ(e.negative, 1);  // -1 < -0.5 where the reference is 0
}

TEST(ToleranceTest, LanczosWindowWeightsAndTheirBiasInTheEstimate) {
  const std::vector<double> w = WindowWeights(RingingWindow::kLanczos, 3);
  ASSERT_EQ(w.size(), 4u);
  EXPECT_EQ(w[0], 1.0);
  EXPECT_NEAR(w[2], std::sin(kPi / 2) / (kPi / 2), 1e-15);
  for (double x : WindowWeights(RingingWindow::kNone, 5)) EXPECT_EQ(x, 1.0);
  EXPECT_FALSE(ParseRingingWindow("hann").ok());
}

// The size budget (ChooseWithinBudget) on a real map with a view-dependent BRDF: the cube
// fits the budget, the estimate still predicts the brute-force measurement, and the choice beats
// the two obvious cubes of the same budget (all of it spent on the view order at the smallest
// face, or none of it: P = 0 at the largest face), each measured against the same brute force.
TEST(ToleranceTest, BudgetLimitedChoiceFitsAndBeatsTheObviousSplitsOfTheBudget) {
  const Image img = LoadBundledMap("courtyard.exr", kMapWidth);
  const EnvMap env = EnvMap::FromLatLong(img);
  const std::vector<EnvSample> samples = LatLongSamples(img);
  auto brdf = ParseOrDie("microfacet:sigma=0.2");
  ASSERT_NE(brdf, nullptr);
  PrefilterOptions opt;
  opt.tolerance = kTolerance;
  opt.threads = 2;
  opt.synthesize = false;
  auto free_choice = Prefilter(env, *brdf, opt);
  ASSERT_TRUE(free_choice.ok()) << free_choice.status();
  const ToleranceChoice& c0 = free_choice->choice;
  const double need = CubeValues(c0.face_size, c0.p);
  EXPECT_FALSE(c0.budget_limited);

  // A budget above the need changes nothing.
  opt.size_budget_values = 2 * need;
  auto roomy = Prefilter(env, *brdf, opt);
  ASSERT_TRUE(roomy.ok()) << roomy.status();
  EXPECT_FALSE(roomy->choice.budget_limited);
  EXPECT_EQ(roomy->choice.f, c0.f);
  EXPECT_EQ(roomy->choice.p, c0.p);
  EXPECT_EQ(roomy->choice.face_size, c0.face_size);

  // A quarter of it.
  const double budget = need / 4;
  opt.size_budget_values = budget;
  opt.synthesize = true;
  auto r = Prefilter(env, *brdf, opt);
  ASSERT_TRUE(r.ok()) << r.status();
  const ToleranceChoice& ch = r->choice;
  EXPECT_TRUE(ch.budget_limited);
  EXPECT_EQ(ch.unlimited_values, need);
  EXPECT_EQ(r->cube.face_size, ch.face_size);
  EXPECT_EQ(r->analysis.p_b, ch.p);
  EXPECT_LE(CubeValues(r->cube.face_size, r->analysis.p_b), budget);

  const std::vector<DirectionPair> pairs =
      StratifiedDirectionPairs(kVerifySeed, kPairs, brdf->reparam());
  std::vector<Rgb> ref;
  for (const DirectionPair& p : pairs) ref.push_back(BruteForce(samples, *brdf, p.index, p.view));
  auto measure = [&](const ShrmCube& cube) {
    std::vector<Rgb> got;
    for (const DirectionPair& p : pairs) got.push_back(ShrmEval(cube, p.index, p.view));
    return MeasureDirectionalError(pairs, got, ref);
  };
  const DirectionalError e = measure(r->cube);
  const double estimate = std::hypot(ch.truncation.front.rms, ch.interpolation.front.rms);
  EXPECT_LE(e.front.rms, kEstimateFactor * estimate + kEstimateSlack);

  // The obvious splits, at explicit orders within the same budget.
  auto largest_face = [&](int p) {
    return 8 * static_cast<int>(std::floor(std::sqrt(budget / CubeValues(1, p)) / 8));
  };
  int p_all = 0;  // the largest P that fits at S = 16
  while (p_all < 31 && CubeValues(16, p_all + 1) <= budget) ++p_all;
  const int s0 = std::min(largest_face(0), 512);
  for (const auto& [f, p, size] :
       {std::tuple{std::min(s0 / 2 - 1, (kMapWidth - 1) / 2), 0, s0}, std::tuple{7, p_all, 16}}) {
    PrefilterOptions alt;
    alt.f = f;
    alt.p = p;
    alt.face_size = size;
    alt.threads = 2;
    ASSERT_LE(CubeValues(size, p), budget);
    auto a = Prefilter(env, *brdf, alt);
    ASSERT_TRUE(a.ok()) << a.status();
    const DirectionalError ea = measure(a->cube);
    std::printf("budget %.3g values: chosen (%d, %d) S %d front rms %.4f; (%d, %d) S %d: %.4f\n",
                budget, ch.f, ch.p, ch.face_size, e.front.rms, f, p, size, ea.front.rms);
    EXPECT_LT(e.front.rms, ea.front.rms) << "(F, P) = (" << f << ", " << p << "), S " << size;
  }
}

// The job layer's auto view variable (PrefilterOptions::try_other_view): a choice in the normal
// variable that misses the front RMS (here: a 4 MB budget) makes the rule choose in the view
// variable too and keep the smaller RMS score (front and grazing); the cube, the coefficients and
// the report's trials say which (RmsScore). Without try_other_view only the normal is tried.
TEST(ToleranceTest, AutoViewTriesTheViewWhenTheNormalMissesAndKeepsTheBetterEstimate) {
  const Image img = LoadBundledMap("courtyard.exr", kMapWidth);
  const EnvMap env = EnvMap::FromLatLong(img);
  auto brdf = ParseOrDie("microfacet:sigma=0.2");
  ASSERT_NE(brdf, nullptr);
  PrefilterOptions opt;
  opt.tolerance = kTolerance;
  opt.threads = 2;
  opt.view = ViewVariable::kNormal;
  opt.size_budget_values = 4e6 / 4;
  auto only = Prefilter(env, *brdf, opt);
  ASSERT_TRUE(only.ok()) << only.status();
  EXPECT_TRUE(only->view_trials.empty());
  EXPECT_EQ(only->brdf.view, ViewVariable::kNormal);
  EXPECT_GT(FrontScore(only->choice, kTolerance), 1.0);
  const double normal_score = RmsScore(only->choice, kTolerance);
  opt.try_other_view = true;
  auto r = Prefilter(env, *brdf, opt);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_EQ(r->view_trials.size(), 2u);
  EXPECT_EQ(r->view_trials[0].first, ViewVariable::kNormal);
  EXPECT_EQ(r->view_trials[0].second, normal_score);
  EXPECT_EQ(r->view_trials[1].first, ViewVariable::kView);
  const ViewVariable kept =
      r->view_trials[1].second < normal_score ? ViewVariable::kView : ViewVariable::kNormal;
  std::printf("4 MB: normal RMS score %.3f, view %.3f: kept %s\n", normal_score,
              r->view_trials[1].second, ViewVariableName(kept));
  EXPECT_EQ(r->brdf.view, kept);
  EXPECT_EQ(r->cube.view, kept);
  EXPECT_EQ(RmsScore(r->choice, kTolerance), std::min(normal_score, r->view_trials[1].second));
}

// Phong s = 128 on the full 1024 x 512 forest.exr: its sun's ringing is a few degrees wide, and
// the rule's largest-error estimate must see it. With 256 selection directions (about 13 degrees
// apart) the rule took F = 39, whose largest error over 2048 independent pairs was 7.5%; a radially
// symmetric BRDF's error depends on R alone, and the rule samples it at four times the pairs
// (prefilter.cc SelectionPairs; 1024 directions: F = 41, 3.6%). Measured against the job's own
// check at 2048 pairs (kVerifySeed, never the selection's): FastReference, the full pixel sum
// within 1e-3 per direction (tests/fast_reference_test.cc), which the parameterized test below
// holds to this test file's brute force. The full map: downsampled to 256 x 128, the sun spreads
// and the case no longer tests the rule's sampling.
constexpr int kWidePairs = 2048;
constexpr int kFullMapWidth = 1024;
TEST(ToleranceTest, RadialLobesMeetTheLargestErrorOverManyIndependentPairs) {
  const EnvMap map = EnvMap::FromLatLong(LoadBundledMap("forest.exr", kFullMapWidth));
  auto brdf = ParseOrDie("phong:s=128");
  ASSERT_NE(brdf, nullptr);
  PrefilterOptions opt;
  opt.tolerance = kTolerance;
  opt.threads = 2;
  opt.verify = kWidePairs;
  auto r = Prefilter(map, *brdf, opt);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(r->tolerance_rule);
  std::printf(
      "forest phong:s=128: (F, P) = (%d, %d), S = %d; measured at %d pairs: front rms %.4f "
      "max %.4f, grazing rms %.4f\n",
      r->choice.f, r->choice.p, r->choice.face_size, kWidePairs, r->measured.front.rms,
      r->measured.front.max, r->measured.grazing.rms);
  EXPECT_TRUE(r->choice.met);
  EXPECT_LE(r->measured.front.rms, kTolerance);
  EXPECT_LE(r->measured.front.max, kMaxErrorFactor * kTolerance);
  EXPECT_LE(r->measured.grazing.rms, kGrazingFactor * kTolerance);
  EXPECT_EQ(r->measured.negative, 0);
}

// The interpolation estimate of a P = 0 job (the cube BuildCube makes, read as ShrmEval reads
// it) against an independent one: the exact expansion at the four texel centres (RadianceAt, the
// full Wigner table) with the weights of ShrmBilinearTaps, against the exact value at the pair.
// With BuildCube's automatic grid the two agree to the grid's own error (kAutoGridAgreement);
// with the job's grid (kSynthesisGridShare of the tolerance) within that share; and without
// exact values (the taps one by one) to rounding.
TEST(ToleranceTest, RadialInterpolationEstimateIsTheCubesErrorAtThePairs) {
  // The automatic grid (4 (F + 1) rows): its cubic interpolation error is ~1e-5 of the values
  // (docs/shrm.md), against interpolation errors of 3e-3 to 7e-2 here (measured agreement
  // 0.1-0.5% of the estimate).
  constexpr double kAutoGridAgreement = 0.02;
  // The taps one by one against RadianceAt: the same sums by another code path.
  constexpr double kTapsAgreement = 1e-9;
  constexpr int kF = 40, kInterpPairs = 256;
  const EnvMap env = EnvMap::FromLatLong(LoadBundledMap("forest.exr", kMapWidth));
  auto brdf = ParseOrDie("phong:s=128");
  ASSERT_NE(brdf, nullptr);
  auto e = ExpansionAt(env, *brdf, kF, 0);
  ASSERT_TRUE(e.ok()) << e.status();
  const std::optional<ShrmSynthesizer>& synth = e->synth;
  const std::vector<DirectionPair> pairs =
      SeededDirectionPairs(11, kInterpPairs, ReparamKind::kReflection);
  std::vector<Rgb> exact(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    exact[k] = synth->RadianceAt(ShrmKind::kGlobal,
                                 IndexDirection(pairs[k], ReparamKind::kReflection), pairs[k].view);
  }
  const int job_rows =
      synth->InterpolationRows(ShrmKind::kGlobal, kSynthesisGridShare * kTolerance);
  for (int size : {48, 88}) {
    std::vector<Rgb> taps(pairs.size(), Rgb{0, 0, 0});
    for (size_t k = 0; k < pairs.size(); ++k) {
      const Vec3 index = IndexDirection(pairs[k], ReparamKind::kReflection);
      for (const CubeTap& tap : ShrmBilinearTaps(size, index)) {
        if (tap.weight == 0) continue;
        const Rgb v = synth->RadianceAt(
            ShrmKind::kGlobal, CubeTexelDirection(tap.face, tap.x, tap.y, size), pairs[k].view);
        for (int c = 0; c < 3; ++c) taps[k][c] += tap.weight * v[c];
      }
    }
    const DirectionalError ref = MeasureDirectionalError(pairs, taps, exact);
    const DirectionalError automatic = EstimateInterpolation(*synth, pairs, size, 2, exact);
    const DirectionalError job = EstimateInterpolation(*synth, pairs, size, 2, exact, job_rows);
    const DirectionalError one_by_one = EstimateInterpolation(*synth, pairs, size, 2);
    std::printf(
        "S = %d: reference front rms %.3e max %.3e; automatic grid %.3e %.3e; job grid "
        "(%d rows) %.3e %.3e\n",
        size, ref.front.rms, ref.front.max, automatic.front.rms, automatic.front.max, job_rows,
        job.front.rms, job.front.max);
    ASSERT_GT(ref.front.rms, 0);
    EXPECT_NEAR(automatic.front.rms, ref.front.rms, kAutoGridAgreement * ref.front.rms) << size;
    EXPECT_NEAR(automatic.front.max, ref.front.max, kAutoGridAgreement * ref.front.max) << size;
    EXPECT_NEAR(automatic.grazing.rms, ref.grazing.rms, kAutoGridAgreement * ref.grazing.rms)
        << size;
    EXPECT_NEAR(job.front.rms, ref.front.rms, kSynthesisGridShare * kTolerance) << size;
    EXPECT_NEAR(one_by_one.front.rms, ref.front.rms, kTapsAgreement) << size;
    EXPECT_NEAR(one_by_one.front.max, ref.front.max, kTapsAgreement) << size;
  }
}

// The budget step's estimates of several view orders at once (EstimateInterpolationAtViewOrders,
// one evaluation at the largest P) against the taps summed from RadianceAtArgument of a
// synthesizer made at each P (the argument held at the pair's, as ShrmEvalAt holds it), and bit
// for bit against EstimateInterpolation of that synthesizer: both view variables, GGX's Fresnel
// table, face sizes whose taps cross face seams.
TEST(ToleranceTest, InterpolationAtSeveralViewOrdersIsEachOnesEstimate) {
  // The taps one by one against RadianceAtArgument: the same sums by another code path.
  constexpr double kTapsAgreement = 1e-9;
  constexpr int kF = 16, kP = 7, kFewPairs = 40;
  const EnvMap env = EnvMap::FromLatLong(LoadBundledMap("city.exr", 64));
  for (const auto& [spec, view] : {std::pair{"microfacet:sigma=0.3", ViewVariable::kNormal},
                                   std::pair{"ggx:alpha=0.3,f0=0.04", ViewVariable::kView}}) {
    auto brdf = ParseOrDie(spec);
    ASSERT_NE(brdf, nullptr);
    auto top = ExpansionAt(env, *brdf, kF, kP, view);
    ASSERT_TRUE(top.ok()) << top.status();
    const PrefilterResult& r = top->stages;
    const std::vector<DirectionPair> pairs = SeededDirectionPairs(5, kFewPairs, brdf->reparam());
    const std::vector<int> orders = {1, 4, kP};
    for (int size : {12, 20}) {
      std::vector<std::vector<Rgb>> exact;
      std::vector<ShrmSynthesizer> synths;
      for (int p : orders) {
        auto synth = ShrmSynthesizer::Create(r.light_lmax, 3, r.light, r.brdf, kF, p);
        ASSERT_TRUE(synth.ok()) << synth.status();
        std::vector<Rgb> e;
        for (const DirectionPair& pair : pairs) {
          const Vec3 index = IndexDirection(pair, brdf->reparam());
          e.push_back(synth->RadianceAtArgument(ShrmKind::kGlobal, index,
                                                ShrmViewArgument(view, index, pair.view)));
        }
        exact.push_back(e);
        synths.push_back(*std::move(synth));
      }
      const std::vector<DirectionalError> together =
          EstimateInterpolationAtViewOrders(*top->synth, pairs, size, 2, orders, exact);
      ASSERT_EQ(together.size(), orders.size());
      for (size_t j = 0; j < orders.size(); ++j) {
        std::vector<Rgb> taps(pairs.size(), Rgb{0, 0, 0});
        for (size_t k = 0; k < pairs.size(); ++k) {
          const Vec3 index = IndexDirection(pairs[k], brdf->reparam());
          const Vec3 arg = ShrmViewArgument(view, index, pairs[k].view);
          for (const CubeTap& tap : ShrmBilinearTaps(size, index)) {
            if (tap.weight == 0) continue;
            const Rgb v = synths[j].RadianceAtArgument(
                ShrmKind::kGlobal, CubeTexelDirection(tap.face, tap.x, tap.y, size), arg);
            for (int c = 0; c < 3; ++c) taps[k][c] += tap.weight * v[c];
          }
        }
        const DirectionalError ref = MeasureDirectionalError(pairs, taps, exact[j]);
        const DirectionalError alone = EstimateInterpolation(synths[j], pairs, size, 2, exact[j]);
        const DirectionalError& t = together[j];
        const std::string where =
            absl::StrCat(spec, " S ", size, " P ", orders[j], ": front rms ", t.front.rms);
        ASSERT_GT(ref.front.rms, 0) << where;
        EXPECT_NEAR(t.front.rms, ref.front.rms, kTapsAgreement) << where;
        EXPECT_NEAR(t.front.max, ref.front.max, kTapsAgreement) << where;
        EXPECT_NEAR(t.grazing.rms, ref.grazing.rms, kTapsAgreement) << where;
        EXPECT_EQ(t.front.rms, alone.front.rms) << where;
        EXPECT_EQ(t.front.max, alone.front.max) << where;
        EXPECT_EQ(t.grazing.rms, alone.grazing.rms) << where;
        EXPECT_EQ(t.grazing.max, alone.grazing.max) << where;
        EXPECT_EQ(t.negative, alone.negative) << where;
      }
    }
  }
}

// The memo of interpolation estimates (InterpolationMemo) is transparent: the face-size search
// and the budget step make exactly the choice with it that they make without it, and the budget
// step's repeats of the search's estimates come from it.
TEST(ToleranceTest, InterpolationMemoChangesNoChoice) {
  constexpr int kF = 40, kP = 12;
  const EnvMap env = EnvMap::FromLatLong(LoadBundledMap("courtyard.exr", kMapWidth));
  auto brdf = ParseOrDie("ggx:alpha=0.1,f0=0.04");
  ASSERT_NE(brdf, nullptr);
  auto e = ExpansionAt(env, *brdf, kF, kP, ViewVariable::kNormal);
  ASSERT_TRUE(e.ok()) << e.status();
  const PrefilterResult* r = &e->stages;
  const std::vector<DirectionPair> pairs =
      SeededDirectionPairs(kSelectionSeed, 64, ReparamKind::kReflection);
  const BandTable table = BandTable::Compute(*e->synth, pairs, 2);
  ToleranceOptions topt;
  topt.tolerance = kTolerance;
  topt.threads = 2;
  const ToleranceChoice first = ChooseOrders(table, topt);
  auto choose = [&](InterpolationMemo* memo) {
    ToleranceChoice c = first;
    ToleranceOptions o = topt;
    EXPECT_TRUE(ChooseFaceSize(pairs, r->light_lmax, 3, r->light, r->brdf, o, &c,
                               table.Values(c.f, c.p, c.window), memo)
                    .ok());
    // A budget of a quarter of what the choice needs: the budget step runs.
    o.max_cube_values = CubeValues(c.face_size, c.p) / 4;
    EXPECT_TRUE(
        ChooseWithinBudget(table, pairs, r->light_lmax, 3, r->light, r->brdf, o, &c, memo).ok());
    return c;
  };
  InterpolationMemo memo;
  const ToleranceChoice with = choose(&memo), without = choose(nullptr);
  EXPECT_TRUE(with.budget_limited);
  EXPECT_EQ(with.f, without.f);
  EXPECT_EQ(with.p, without.p);
  EXPECT_EQ(with.window, without.window);
  EXPECT_EQ(with.face_size, without.face_size);
  EXPECT_EQ(with.interpolation.front.rms, without.interpolation.front.rms);
  EXPECT_EQ(with.interpolation.front.max, without.interpolation.front.max);
  EXPECT_EQ(with.unlimited_values, without.unlimited_values);
  // The winner's estimate at its S was made once and is in the memo.
  const DirectionalError* kept = memo.Find(with.f, with.p, with.window, with.face_size);
  ASSERT_NE(kept, nullptr);
  EXPECT_EQ(kept->front.rms, with.interpolation.front.rms);
}

enum class Expect {
  kAll,  // front RMS, front largest, no negatives; and grazing RMS in the normal variable
  // The paper's view variable and a BRDF whose rho-hat jumps to 0 at the normal's horizon (the
  // simplified microfacet of eq. 5.34): the view expansion converges slowly where the horizon
  // cuts the lobe, the largest front error (N.V just above kGrazingCosine) is beyond the estimate
  // (measured 0.08-0.10 at P ~ 20), grazing values can be negative. The RMS and the estimate
  // only: the reason the normal variable is the default (docs/shrm.md "The view variable").
  kFrontRms,
  // The normal variable, a sharp lobe (microfacet sigma 0.1) within the job's default size
  // budget of 256 MB: the tolerance's choice does not fit; the most accurate one within it
  // (session 22: (127, 12), Lanczos, S 64) meets the front targets as measured, and its grazing
  // RMS (measured 0.197 against 0.05; 0.062 with session 21's even extension at (127, 12), S 72:
  // the budget step weighs the front RMS only) is reported. The grazing estimate rests on the
  // ~9% of 256 selection pairs that graze (about 23): it is coarse (here 0.097), docs/shrm.md.
  kFront,
  // Both RMS targets and no negatives; the largest front error printed only. For a row whose
  // largest error rests on single pairs the choice cannot see: courtyard's GGX alpha 0.3 f0 =
  // 0.04 measured 4.6% here at (37, 25) and 5.8% at session 46's (37, 28) (a partial sum at one
  // pair need not fall as the orders rise), and misses the 5% at the full map's 1024 check pairs
  // either way (10.1%, 7.6%: docs/results.md "Session 46").
  kRms,
};

struct RealCase {
  const char* map;
  const char* brdf;
  Expect expect = Expect::kAll;
  // The window asked for (kAuto: the rule's choice; kLanczos: forced, F searched with its bias).
  // A forced Lanczos window blurs too much for 1% (w_l = 0.64 at l = F / 2): the rule must say
  // so (met = false at the map's highest order) and its estimate still predict the measurement.
  RingingWindow window = RingingWindow::kAuto;
  // kNormal: the default of the job layer's tolerance rule (auto: the normal first, the view
  // too when the normal misses the front RMS; jobs::AutoViewVariable); kView: the view only.
  // Radially symmetric models take the view whatever is asked (P = 0).
  ViewVariable view = ViewVariable::kNormal;
  // The size budget (PrefilterOptions::size_budget_values) in MB of float32 values; 0 = none.
  double budget_mb = 0;
};

class ToleranceRealMapTest : public ::testing::TestWithParam<RealCase> {};

TEST_P(ToleranceRealMapTest, ToleranceIsMetOrReportedAndTheEstimateHolds) {
  const RealCase& rc = GetParam();
  const Image img = LoadBundledMap(rc.map, kMapWidth);
  const EnvMap env = EnvMap::FromLatLong(img);
  const std::vector<EnvSample> samples = LatLongSamples(img);
  auto brdf = ParseOrDie(rc.brdf);
  ASSERT_NE(brdf, nullptr);
  PrefilterOptions opt;
  opt.tolerance = kTolerance;
  opt.window = rc.window;
  opt.threads = 2;
  opt.verify = kPairs;
  opt.view = rc.view;
  opt.try_other_view = rc.view == ViewVariable::kNormal;  // the job layer's auto
  opt.size_budget_values = rc.budget_mb * 1e6 / 4;
  auto r = Prefilter(env, *brdf, opt);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_TRUE(r->tolerance_rule);
  const ToleranceChoice& ch = r->choice;
  const std::vector<DirectionPair> pairs =
      StratifiedDirectionPairs(kVerifySeed, kPairs, brdf->reparam());
  std::vector<Rgb> got, ref;
  for (const DirectionPair& p : pairs) {
    got.push_back(ShrmEval(r->cube, p.index, p.view));
    ref.push_back(BruteForce(samples, *brdf, p.index, p.view));
  }
  const DirectionalError e = MeasureDirectionalError(pairs, got, ref);
  ASSERT_EQ(r->verified_pairs, kPairs);
  EXPECT_NEAR(r->measured.front.rms, e.front.rms, kVerifyAgreement);
  EXPECT_NEAR(r->measured.front.max, e.front.max, kVerifyAgreement * (1 + e.front.max));
  EXPECT_NEAR(r->measured.grazing.rms, e.grazing.rms, kVerifyAgreement * (1 + e.grazing.rms));
  const double estimate = std::hypot(ch.truncation.front.rms, ch.interpolation.front.rms);
  std::printf(
      "%s %s: view %s (F, P) = (%d, %d) window %s S = %d (reference (%d, %d)); estimate front rms "
      "%.4f (trunc %.4f max %.3f, interp %.4f), grazing rms %.4f; measured front rms %.4f max "
      "%.3f, grazing rms %.4f max %.3f, negative %d\n",
      rc.map, rc.brdf, ViewVariableName(r->brdf.view), ch.f, ch.p, RingingWindowName(ch.window),
      ch.face_size, ch.f_ref, ch.p_ref, estimate, ch.truncation.front.rms, ch.truncation.front.max,
      ch.interpolation.front.rms, ch.truncation.grazing.rms, e.front.rms, e.front.max,
      e.grazing.rms, e.grazing.max, e.negative);
  EXPECT_LE(e.front.rms, kEstimateFactor * estimate + kEstimateSlack);
  if (rc.window == RingingWindow::kLanczos) {
    EXPECT_EQ(ch.window, RingingWindow::kLanczos);
    EXPECT_FALSE(ch.met);
    EXPECT_GE(e.front.rms, estimate / kEstimateFactor);
    return;
  }
  // Within a size budget the rule may have to take less than the tolerance needs; it says so.
  EXPECT_TRUE(ch.met || (rc.budget_mb > 0 && ch.budget_limited));
  EXPECT_LE(e.front.rms, kTolerance);
  if (rc.expect != Expect::kFrontRms) {
    if (rc.expect != Expect::kRms) {
      EXPECT_LE(e.front.max, kMaxErrorFactor * kTolerance);
    }
    EXPECT_EQ(e.negative, 0);
  }
  if (rc.expect == Expect::kAll && r->brdf.view == ViewVariable::kNormal) {
    EXPECT_LE(e.grazing.rms, kGrazingFactor * kTolerance);
  }
}

INSTANTIATE_TEST_SUITE_P(
    BundledMaps, ToleranceRealMapTest,
    ::testing::Values(
        RealCase{"courtyard.exr", "phong:s=32"}, RealCase{"courtyard.exr", "phong:s=512"},
        RealCase{"courtyard.exr", "phong:s=128", Expect::kAll, RingingWindow::kLanczos},
        RealCase{"courtyard.exr", "microfacet:sigma=0.2"},
        RealCase{"courtyard.exr", "microfacet:sigma=0.2", Expect::kFrontRms, RingingWindow::kAuto,
                 ViewVariable::kView},
        RealCase{"city.exr", "microfacet:sigma=0.1", Expect::kFront, RingingWindow::kAuto,
                 ViewVariable::kNormal, 256},
        RealCase{"forest.exr", "ggx:alpha=0.3,f0=1"},
        // Schlick's rise to grazing at f0 = 0.04: both RMS targets since the normal variable's
        // C^1 extension (the even extension's kink left 1.8% front RMS at P = 31 on the full
        // map); its largest error is asserted on the full city map with its lights
        // (peak_lights_test.cc LargestErrorHoldsAtPairsTheSelectionNeverSaw).
        RealCase{"courtyard.exr", "ggx:alpha=0.3,f0=0.04", Expect::kRms},
        RealCase{"interior.exr", "phong:s=8"},
        // A sharp lobe with Schlick's rise, within a budget that binds (192 MB: (127, 30) at S 48;
        // measured 0.56% / 4.7% / 4.65%, 64 MB gives 1.2% / 8.6% / 5.7%): the Fresnel
        // normalization and the budget step's P scan with the whole estimate (session 23; before
        // them 5.9% front RMS and 20% grazing on the full map at 252 MB).
        RealCase{"city.exr", "ggx:alpha=0.1,f0=0.04", Expect::kAll, RingingWindow::kAuto,
                 ViewVariable::kNormal, 192}),
    [](const ::testing::TestParamInfo<RealCase>& param_info) {
      std::string name = std::string(param_info.param.map) + "_" + param_info.param.brdf +
                         (param_info.param.window == RingingWindow::kLanczos ? "_lanczos" : "") +
                         (param_info.param.view == ViewVariable::kView ? "_view" : "");
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

}  // namespace
}  // namespace shrm
