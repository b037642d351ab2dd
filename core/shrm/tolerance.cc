#include "core/shrm/tolerance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_eval.h"

namespace shrm {
namespace {

// Uniform double in [0, 1) from 53 bits of the standard's fixed mt19937_64 sequence (the
// distributions of <random> are implementation-defined; this is not).
double Uniform(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

Vec3 UniformSphere(std::mt19937_64& rng) {
  const double z = 2 * Uniform(rng) - 1, phi = 2 * kPi * Uniform(rng);
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Rounds up to a multiple of 8.
int RoundUp8(double s) { return 8 * static_cast<int>(std::ceil(s / 8 - 1e-9)); }

// Smallest face size tried, and the first trial as a multiple of F (measured on the bundled maps:
// S ~ 1.6-3 F meets a 1% share; docs/shrm.md).
constexpr int kMinFaceSize = 16;
constexpr double kFirstFaceSizePerOrder = 2.0;
// The F tried under a size budget, as multiples of ChooseOrdersWithinBudget's (S_max / 2 - 1).
// Growth of S when the scaled size still misses its share (the h^2 law is asymptotic).
constexpr double kFaceSizeGrowth = 1.25;
constexpr int kFaceSizeRounds = 4;

}  // namespace

double CubeValues(int face_size, int p) {
  return 6.0 * face_size * face_size * (p + 1.0) * (p + 1.0) * 3;
}

namespace {

// The window of a choice at its orders: none unless asked, or (auto) Lanczos when it lowers the
// estimated largest error without raising the RMS; the estimate and `met` follow it.
void ChooseWindow(const BandTable& table, const ToleranceOptions& options, ToleranceChoice* c) {
  c->window =
      options.window == RingingWindow::kLanczos ? RingingWindow::kLanczos : RingingWindow::kNone;
  c->truncation = table.Estimate(c->f, c->p, c->window);
  if (options.window == RingingWindow::kAuto) {
    const DirectionalError windowed = table.Estimate(c->f, c->p, RingingWindow::kLanczos);
    if (windowed.front.max < c->truncation.front.max &&
        windowed.front.rms <= c->truncation.front.rms) {
      c->window = RingingWindow::kLanczos;
      c->truncation = windowed;
    }
  }
  c->met = MeetsTargets(c->truncation, TargetsForTolerance(options.tolerance, table.view()),
                        kTruncationShare);
}

// The rows of the grid the job's synthesis will use (prefilter.cc InterpolationTolerance), so that
// a P = 0 interpolation estimate is its cube's.
int JobGridRows(const ShrmSynthesizer& synth, double tolerance) {
  return synth.InterpolationRows(ShrmKind::kGlobal, kSynthesisGridShare * tolerance);
}

// `count` pairs; pair k's N.V squared (u, uniform under density N.V) drawn from [0, 1) or, when
// `stratified`, from its band's part of it.
std::vector<DirectionPair> DrawPairs(uint64_t seed, int count, ReparamKind reparam,
                                     bool stratified) {
  std::mt19937_64 rng(seed);
  std::vector<DirectionPair> pairs;
  pairs.reserve(std::max(count, 0));
  constexpr double kGrazingU = kGrazingCosine * kGrazingCosine;  // P(N.V < kGrazingCosine)
  int grazing = 0;
  for (int k = 0; k < count; ++k) {
    DirectionPair pr;
    pr.view = UniformSphere(rng);
    if (reparam == ReparamKind::kTangent) {
      pr.index = UniformSphere(rng);
    } else {
      // N about V with density N.V: cos = sqrt(u) (Malley), azimuth uniform.
      const Vec3& v = pr.view;
      const Vec3 a = std::abs(v.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      const Vec3 t = a.Cross(v).Normalized();
      const Vec3 b = v.Cross(t);
      double u = Uniform(rng);
      const double phi = 2 * kPi * Uniform(rng);
      const bool band_grazing = k % kGrazingStride == kGrazingStride - 1;
      if (stratified) u = band_grazing ? kGrazingU * u : kGrazingU + (1 - kGrazingU) * u;
      const double ct = std::sqrt(u), st = std::sqrt(1 - u);
      pr.index = (t * (st * std::cos(phi)) + b * (st * std::sin(phi)) + v * ct).Normalized();
      // (Stratified: the band as drawn, not as rounding may place N.V at the boundary.)
      pr.grazing = stratified ? band_grazing : pr.index.Dot(v) < kGrazingCosine;
      if (pr.grazing) ++grazing;
    }
    pairs.push_back(pr);
  }
  if (stratified && grazing > 0) {
    const int front = count - grazing;
    for (DirectionPair& pr : pairs)
      pr.weight = pr.grazing ? kGrazingU * count / grazing
                             : (front > 0 ? (1 - kGrazingU) * count / front : 0.0);
  }
  return pairs;
}

}  // namespace

std::vector<DirectionPair> SeededDirectionPairs(uint64_t seed, int count, ReparamKind reparam) {
  return DrawPairs(seed, count, reparam, false);
}

std::vector<DirectionPair> StratifiedDirectionPairs(uint64_t seed, int count, ReparamKind reparam) {
  return DrawPairs(seed, count, reparam, true);
}

Vec3 IndexDirection(const DirectionPair& pair, ReparamKind reparam) {
  if (reparam == ReparamKind::kTangent) return pair.index;
  return pair.index * (2 * pair.index.Dot(pair.view)) - pair.view;
}

Rgb RelativeFloor(std::span<const DirectionPair> pairs, std::span<const Rgb> ref) {
  // Weights of 1 (a plain sample): the plain mean, as it was before the weights.
  Rgb floor{0, 0, 0};
  const size_t n = std::min(pairs.size(), ref.size());
  if (n == 0) return floor;
  double total = 0;
  for (size_t k = 0; k < n; ++k) {
    total += pairs[k].weight;
    for (int c = 0; c < 3; ++c) floor[c] += pairs[k].weight * std::abs(ref[k][c]);
  }
  for (int c = 0; c < 3; ++c) floor[c] *= kRelativeFloor / total;
  return floor;
}

DirectionalError MeasureDirectionalError(std::span<const DirectionPair> pairs,
                                         std::span<const Rgb> got, std::span<const Rgb> ref) {
  DirectionalError e;
  const size_t n = std::min({pairs.size(), got.size(), ref.size()});
  if (n == 0) return e;
  const Rgb floor = RelativeFloor(pairs.first(n), ref.first(n));
  double sum_front = 0, sum_grazing = 0;
  for (size_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) {
      const double scale = std::max(std::abs(ref[k][c]), floor[c]);
      const double rel = scale > 0 ? std::abs(got[k][c] - ref[k][c]) / scale : 0.0;
      ErrorStats& s = pairs[k].grazing ? e.grazing : e.front;
      (pairs[k].grazing ? sum_grazing : sum_front) += rel * rel;
      ++s.count;
      s.max = std::max(s.max, rel);
      if (ref[k][c] >= 0 && got[k][c] < -floor[c]) ++e.negative;
    }
  if (e.front.count > 0) e.front.rms = std::sqrt(sum_front / e.front.count);
  if (e.grazing.count > 0) e.grazing.rms = std::sqrt(sum_grazing / e.grazing.count);
  return e;
}

ToleranceTargets TargetsForTolerance(double tolerance, ViewVariable view) {
  return {tolerance, kMaxErrorFactor * tolerance, kGrazingFactor * tolerance,
          view == ViewVariable::kNormal};
}

ToleranceTargets TruncationTargets(double tolerance, ViewVariable view, bool view_dependent) {
  ToleranceTargets t = TargetsForTolerance(tolerance, view);
  if (view_dependent) t.max *= kViewLargestShare;
  return t;
}

bool MeetsTargets(const DirectionalError& e, const ToleranceTargets& t, double share) {
  return e.front.rms <= share * t.rms && e.front.max <= share * t.max &&
         (!t.grazing || e.grazing.count == 0 || e.grazing.rms <= share * t.grazing_rms);
}

const char* RingingWindowName(RingingWindow w) {
  switch (w) {
    case RingingWindow::kNone:
      return "none";
    case RingingWindow::kLanczos:
      return "lanczos";
    case RingingWindow::kAuto:
      return "auto";
  }
  return "none";
}

absl::StatusOr<RingingWindow> ParseRingingWindow(std::string_view name) {
  if (name == "none") return RingingWindow::kNone;
  if (name == "lanczos") return RingingWindow::kLanczos;
  if (name == "auto") return RingingWindow::kAuto;
  return absl::InvalidArgumentError(
      absl::StrCat("window must be none, lanczos or auto, got '", std::string(name), "'"));
}

std::vector<double> WindowWeights(RingingWindow window, int f) {
  std::vector<double> w(std::max(f, 0) + 1, 1.0);
  if (window != RingingWindow::kLanczos) return w;
  for (int l = 1; l <= f; ++l) {
    const double x = kPi * l / (f + 1);
    w[l] = std::sin(x) / x;
  }
  return w;
}

std::vector<double> ApplyWindow(RingingWindow window, int f, int lmax, int channels,
                                std::span<const double> light) {
  std::vector<double> out(light.begin(), light.end());
  const std::vector<double> w = WindowWeights(window, f);
  for (int l = 0; l <= lmax; ++l) {
    const double wl = l <= f ? w[l] : 0.0;
    for (int m = -l; m <= l; ++m)
      for (int c = 0; c < channels; ++c)
        out[static_cast<size_t>(ShIndex(l, m)) * channels + c] *= wl;
  }
  return out;
}

BandTable BandTable::Compute(const ShrmSynthesizer& reference, std::span<const DirectionPair> pairs,
                             int threads) {
  BandTable t;
  t.f_ = reference.lmax();
  t.p_ = reference.pmax();
  t.ch_ = std::min(reference.channels(), 3);
  t.view_ = reference.view();
  t.pairs_.assign(pairs.begin(), pairs.end());
  const int ch = reference.channels();
  const size_t per_pair = static_cast<size_t>(t.f_ + 1) * (t.p_ + 1) * t.ch_;
  t.prefix_.assign(per_pair * pairs.size(), 0.0);
  t.ref_.assign(pairs.size(), Rgb{0, 0, 0});
  // Blocks of the synthesizer's batch width (its Wigner recurrence runs on that many points).
  constexpr int kBlock = WignerColumnTables::kWignerBlock;
  const int blocks = (static_cast<int>(pairs.size()) + kBlock - 1) / kBlock;
  ParallelChunks(blocks, threads, [&](int begin, int end) {
    std::vector<double> c(reference.BandCount() * kBlock);
    std::vector<Vec3> index(kBlock), view(kBlock);
    for (int b = begin; b < end; ++b) {
      const int k0 = b * kBlock;
      const int nb = std::min<int>(kBlock, static_cast<int>(pairs.size()) - k0);
      for (int r = 0; r < nb; ++r) {
        index[r] = IndexDirection(pairs[k0 + r], reference.reparam());
        view[r] = ShrmViewArgument(reference.view(), index[r], pairs[k0 + r].view);
      }
      reference.BandContributionsAtArguments(std::span(index).first(nb), std::span(view).first(nb),
                                             c);
      for (int r = 0; r < nb; ++r) {
        const int k = k0 + r;
        const double* ck = c.data() + reference.BandCount() * r;
        double* pre = t.prefix_.data() + per_pair * k;
        for (int l = 0; l <= t.f_; ++l)
          for (int cc = 0; cc < t.ch_; ++cc) {
            double run = 0;
            for (int p = 0; p <= t.p_; ++p) {
              run += ck[(static_cast<size_t>(l) * (t.p_ + 1) + p) * ch + cc];
              pre[(static_cast<size_t>(l) * (t.p_ + 1) + p) * t.ch_ + cc] = run;
            }
            t.ref_[k][cc] += run;
          }
        if (t.ch_ == 1) t.ref_[k][1] = t.ref_[k][2] = t.ref_[k][0];
      }
    }
  });
  return t;
}

Rgb BandTable::Value(int k, int f, int p, std::span<const double> w) const {
  Rgb v{0, 0, 0};
  const double* pre = prefix_.data() + static_cast<size_t>(k) * (f_ + 1) * (p_ + 1) * ch_;
  for (int l = 0; l <= std::min(f, f_); ++l)
    for (int c = 0; c < ch_; ++c)
      v[c] += w[l] * pre[(static_cast<size_t>(l) * (p_ + 1) + std::min(p, p_)) * ch_ + c];
  if (ch_ == 1) v[1] = v[2] = v[0];
  return v;
}

std::vector<Rgb> BandTable::Values(int f, int p, RingingWindow window) const {
  const std::vector<double> w = WindowWeights(window, f);
  std::vector<Rgb> got(pairs_.size());
  for (size_t k = 0; k < pairs_.size(); ++k) got[k] = Value(static_cast<int>(k), f, p, w);
  return got;
}

DirectionalError BandTable::Estimate(int f, int p, RingingWindow window) const {
  return MeasureDirectionalError(pairs_, Values(f, p, window), ref_);
}

int BandTable::SmallestF(int p, const ToleranceTargets& t, double share,
                         RingingWindow window) const {
  if (window == RingingWindow::kLanczos) {  // the weights depend on f: each f summed anew
    for (int f = 0; f <= f_; ++f)
      if (MeetsTargets(Estimate(f, p, window), t, share)) return f;
    return -1;
  }
  // Running partial sums over l for every pair at once: one pass per view order.
  const size_t n = pairs_.size();
  std::vector<Rgb> got(n, Rgb{0, 0, 0});
  for (int f = 0; f <= f_; ++f) {
    for (size_t k = 0; k < n; ++k) {
      const double* pre = prefix_.data() + k * (f_ + 1) * (p_ + 1) * ch_;
      for (int c = 0; c < ch_; ++c)
        got[k][c] += pre[(static_cast<size_t>(f) * (p_ + 1) + std::min(p, p_)) * ch_ + c];
      if (ch_ == 1) got[k][1] = got[k][2] = got[k][0];
    }
    if (MeetsTargets(MeasureDirectionalError(pairs_, got, ref_), t, share)) return f;
  }
  return -1;
}

namespace {

// The points EstimateInterpolation evaluates: per pair its own (R, argument) when `own` (its
// exact value not given), and its texel centres on faces of `face_size` with the argument (V,
// or N for kNormal) held fixed, as ShrmEvalAt holds it.
struct InterpolationPoints {
  std::vector<Vec3> index, argument;
  std::vector<double> weight;  // 0 for a pair's own point, the tap's weight for a texel centre
  std::vector<int> owner;
};
InterpolationPoints MakeInterpolationPoints(const ShrmSynthesizer& synth,
                                            std::span<const DirectionPair> pairs, int face_size,
                                            bool own) {
  InterpolationPoints t;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const Vec3 r = IndexDirection(pairs[k], synth.reparam());
    const Vec3 arg = ShrmViewArgument(synth.view(), r, pairs[k].view);
    if (own) {
      t.index.push_back(r);
      t.argument.push_back(arg);
      t.weight.push_back(0);
      t.owner.push_back(static_cast<int>(k));
    }
    for (const CubeTap& tap : ShrmBilinearTaps(face_size, r)) {
      if (tap.weight == 0) continue;
      t.index.push_back(CubeTexelDirection(tap.face, tap.x, tap.y, face_size));
      t.argument.push_back(arg);
      t.weight.push_back(tap.weight);
      t.owner.push_back(static_cast<int>(k));
    }
  }
  return t;
}

// values[j][i]: the value of `synth` at point i summed over its bands l <= F and p <=
// view_orders[j] (each <= synth.pmax()), in the order of the bands (l, then p, a channel's terms
// every ch values): the sums a synthesizer made with view order view_orders[j] gives, bit for
// bit (a band's value does not depend on the synthesizer's P). Evaluated in blocks of the
// synthesizer's batch width.
std::vector<std::vector<Rgb>> InterpolationPointValues(const ShrmSynthesizer& synth,
                                                       const InterpolationPoints& t,
                                                       std::span<const int> view_orders,
                                                       int threads) {
  const int ch = synth.channels();
  const int pm = synth.pmax();
  const size_t count = synth.BandCount();
  constexpr int kBlock = WignerColumnTables::kWignerBlock;
  const int n = static_cast<int>(t.index.size());
  std::vector<std::vector<Rgb>> values(view_orders.size(), std::vector<Rgb>(n));
  ParallelChunks((n + kBlock - 1) / kBlock, threads, [&](int begin, int end) {
    std::vector<double> c(count * kBlock);
    for (int b = begin; b < end; ++b) {
      const int k0 = b * kBlock, nb = std::min(kBlock, n - k0);
      synth.BandContributionsAtArguments(std::span(t.index).subspan(k0, nb),
                                         std::span(t.argument).subspan(k0, nb), c);
      for (size_t j = 0; j < view_orders.size(); ++j) {
        const int p_top = std::min(view_orders[j], pm);
        for (int r = 0; r < nb; ++r) {
          Rgb v{0, 0, 0};
          const double* cr = c.data() + count * r;
          for (int l = 0; l <= synth.lmax(); ++l)
            for (int p = 0; p <= p_top; ++p) {
              const double* band = cr + (static_cast<size_t>(l) * (pm + 1) + p) * ch;
              for (int k = 0; k < ch; ++k) v[std::min(k, 2)] += band[k];
            }
          if (ch == 1) v[1] = v[2] = v[0];
          values[j][k0 + r] = v;
        }
      }
    }
  });
  return values;
}

// The bilinear combination of each pair's texel values against its exact value (`exact_given`,
// or the pair's own point).
DirectionalError InterpolationError(const InterpolationPoints& t, std::span<const Rgb> values,
                                    std::span<const DirectionPair> pairs,
                                    std::span<const Rgb> exact_given) {
  std::vector<Rgb> got(pairs.size(), Rgb{0, 0, 0}), exact(pairs.size());
  if (exact_given.size() == pairs.size()) exact.assign(exact_given.begin(), exact_given.end());
  for (size_t i = 0; i < t.index.size(); ++i) {
    if (t.weight[i] == 0) {
      exact[t.owner[i]] = values[i];
      continue;
    }
    for (int cc = 0; cc < 3; ++cc) got[t.owner[i]][cc] += t.weight[i] * values[i][cc];
  }
  return MeasureDirectionalError(pairs, got, exact);
}

}  // namespace

DirectionalError EstimateInterpolation(const ShrmSynthesizer& synth,
                                       std::span<const DirectionPair> pairs, int face_size,
                                       int threads, std::span<const Rgb> exact_given,
                                       int grid_rows) {
  const bool have_exact = exact_given.size() == pairs.size();
  if (synth.pmax() == 0 && have_exact) {
    ShrmGridOptions grid;
    grid.threads = threads;
    grid.alpha_samples = grid_rows;
    const absl::StatusOr<ShrmCube> cube = synth.BuildCube(ShrmKind::kGlobal, face_size, grid);
    if (cube.ok()) {
      std::vector<Rgb> got(pairs.size());
      for (size_t k = 0; k < pairs.size(); ++k)
        got[k] = ShrmEval(*cube, pairs[k].index, pairs[k].view);
      return MeasureDirectionalError(pairs, got, exact_given);
    }
    // (A cube it cannot make, e.g. a grid below its rows' minimum: the taps one by one below.)
  }
  const InterpolationPoints t = MakeInterpolationPoints(synth, pairs, face_size, !have_exact);
  const int p[] = {synth.pmax()};
  return InterpolationError(t, InterpolationPointValues(synth, t, p, threads)[0], pairs,
                            exact_given);
}

std::vector<DirectionalError> EstimateInterpolationAtViewOrders(
    const ShrmSynthesizer& synth, std::span<const DirectionPair> pairs, int face_size, int threads,
    std::span<const int> view_orders, std::span<const std::vector<Rgb>> exact) {
  const InterpolationPoints t = MakeInterpolationPoints(synth, pairs, face_size, /*own=*/false);
  const std::vector<std::vector<Rgb>> values =
      InterpolationPointValues(synth, t, view_orders, threads);
  std::vector<DirectionalError> out;
  for (size_t j = 0; j < view_orders.size(); ++j)
    out.push_back(InterpolationError(t, values[j], pairs, exact[j]));
  return out;
}

DirectionalError TotalEstimate(const ToleranceChoice& c) {
  DirectionalError e;
  e.front.rms = std::hypot(c.truncation.front.rms, c.interpolation.front.rms);
  e.front.max = c.truncation.front.max + c.interpolation.front.max;
  e.grazing.rms = std::hypot(c.truncation.grazing.rms, c.interpolation.grazing.rms);
  e.grazing.max = c.truncation.grazing.max + c.interpolation.grazing.max;
  return e;
}

double FrontScore(const ToleranceChoice& c, double tolerance) {
  return TotalEstimate(c).front.rms / tolerance;
}

double RmsScore(const ToleranceChoice& c, double tolerance) {
  const DirectionalError e = TotalEstimate(c);
  return std::max(e.front.rms / tolerance, e.grazing.rms / (kGrazingFactor * tolerance));
}

namespace {

// The smallest (P + 1)^2 (F + P + 1)^2 over p in [p_min, P_ref] of (F, p), F the smallest whose
// truncation meets `targets` at p and at least f_min: false when no p has one.
bool CheapestOrders(const BandTable& table, const ToleranceTargets& targets, RingingWindow window,
                    int f_min, int p_min, int* f_out, int* p_out) {
  double best_cost = -1;
  for (int p = p_min; p <= table.p_ref(); ++p) {
    int f = table.SmallestF(p, targets, kTruncationShare, window);
    if (f < 0) continue;
    f = std::max(f, f_min);
    const double cost = (p + 1.0) * (p + 1.0) * (f + p + 1.0) * (f + p + 1.0);
    if (best_cost < 0 || cost < best_cost) {
      best_cost = cost;
      *f_out = f;
      *p_out = p;
    }
  }
  return best_cost >= 0;
}

// F at view order p in the budget steps: the smallest whose truncation meets the targets with
// the margin on the largest error (TruncationTargets), else the smallest meeting the targets
// (a margin, not a target), else -1.
int BudgetStepF(const BandTable& table, int p, const ToleranceOptions& options) {
  const bool view_dependent = table.p_ref() > 0;
  int f = table.SmallestF(p, TruncationTargets(options.tolerance, table.view(), view_dependent),
                          kTruncationShare, options.window);
  if (f < 0 && view_dependent) {
    f = table.SmallestF(p, TargetsForTolerance(options.tolerance, table.view()), kTruncationShare,
                        options.window);
  }
  return f;
}

}  // namespace

ToleranceChoice ChooseOrders(const BandTable& table, const ToleranceOptions& options) {
  ToleranceChoice best;
  best.f_ref = table.f_ref();
  best.p_ref = table.p_ref();
  // (F, P): the smallest (P + 1)^2 (F + P + 1)^2 among the feasible view orders.
  best.met = CheapestOrders(table, TargetsForTolerance(options.tolerance, table.view()),
                            options.window, 0, 0, &best.f, &best.p);
  if (!best.met) {  // not reachable below the reference orders: the most accurate there is
    best.f = table.f_ref();
    best.p = table.p_ref();
  } else if (table.p_ref() > 0) {
    // The margin on the largest error (kViewLargestShare), by orders at least those: a cheaper
    // F at a larger P would trade the view order's needles for the lighting's ringing. Where no
    // orders below the reference's meet it, the choice above stands (a margin, not a target).
    (void)CheapestOrders(table, TruncationTargets(options.tolerance, table.view(), true),
                         options.window, best.f, best.p, &best.f, &best.p);
  }
  ChooseWindow(table, options, &best);
  return best;
}

absl::StatusOr<ToleranceChoice> ChooseOrdersWithinBudget(const BandTable& table,
                                                         const ToleranceOptions& options,
                                                         int* max_face_size) {
  ToleranceChoice best;
  best.f_ref = table.f_ref();
  best.p_ref = table.p_ref();
  best.budget_limited = true;
  bool found = false;
  for (int p = 0; p <= table.p_ref(); ++p) {
    // The largest S (a multiple of 8) with 6 S^2 (p + 1)^2 3 within the budget.
    int s = 8 * static_cast<int>(
                    std::floor(std::sqrt(options.max_cube_values / CubeValues(1, p)) / 8 + 1e-9));
    s = std::min(s, std::max(kMinFaceSize, options.max_face_size));
    if (options.face_size > 0) {
      if (s < options.face_size) break;  // larger p only shrinks it
      s = options.face_size;
    }
    if (s < kMinFaceSize) break;
    const int f_cap =
        std::clamp(static_cast<int>(s / kFirstFaceSizePerOrder) - 1, 0, table.f_ref());
    int f = BudgetStepF(table, p, options);
    if (f < 0 || f > f_cap) f = f_cap;
    const DirectionalError e = table.Estimate(f, p, RingingWindow::kNone);
    if (!found || e.front.rms < best.truncation.front.rms ||
        (e.front.rms == best.truncation.front.rms && e.front.max < best.truncation.front.max)) {
      found = true;
      best.f = f;
      best.p = p;
      best.truncation = e;
      *max_face_size = s;
    }
  }
  if (!found) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the size budget of ", options.max_cube_values, " values is below the smallest cube (",
        CubeValues(std::max(kMinFaceSize, options.face_size), 0), " values: face size ",
        std::max(kMinFaceSize, options.face_size), ", P = 0)"));
  }
  ChooseWindow(table, options, &best);
  return best;
}

const DirectionalError* InterpolationMemo::Find(int f, int p, RingingWindow window,
                                                int face_size) const {
  for (const Entry& e : entries_)
    if (e.f == f && e.p == p && e.window == window && e.face_size == face_size) return &e.estimate;
  return nullptr;
}

void InterpolationMemo::Add(int f, int p, RingingWindow window, int face_size,
                            const DirectionalError& e) {
  if (Find(f, p, window, face_size) == nullptr) entries_.push_back({f, p, face_size, window, e});
}

absl::Status ChooseFaceSize(std::span<const DirectionPair> pairs, int light_lmax, int channels,
                            std::span<const double> light, const BrdfCoefficients& brdf,
                            const ToleranceOptions& options, ToleranceChoice* choice,
                            std::span<const Rgb> exact, InterpolationMemo* memo) {
  const ToleranceTargets targets = TargetsForTolerance(options.tolerance, brdf.view);
  ToleranceChoice& best = *choice;

  // S: first trial ~2 F, then scaled by the h^2 law, grown while it still misses its share.
  const std::vector<double> windowed =
      ApplyWindow(best.window, best.f, light_lmax, channels, light);
  SHRM_ASSIGN_OR_RETURN(
      ShrmSynthesizer synth,
      ShrmSynthesizer::Create(light_lmax, channels, windowed, brdf, best.f, best.p));
  const int max_size = std::max(kMinFaceSize, options.max_face_size);
  const int rows = JobGridRows(synth, options.tolerance);
  auto estimate = [&](int s) {
    if (memo != nullptr) {
      if (const DirectionalError* known = memo->Find(best.f, best.p, best.window, s)) return *known;
    }
    const DirectionalError e = EstimateInterpolation(synth, pairs, s, options.threads, exact, rows);
    if (memo != nullptr) memo->Add(best.f, best.p, best.window, s, e);
    return e;
  };
  int size = std::clamp(RoundUp8(kFirstFaceSizePerOrder * (best.f + 1)), kMinFaceSize, max_size);
  DirectionalError interp = estimate(size);
  const double ratio = std::max(interp.front.rms / (kInterpolationShare * targets.rms),
                                interp.front.max / (kInterpolationShare * targets.max));
  if (ratio > 0) {
    const int scaled = std::clamp(RoundUp8(size * std::sqrt(ratio)), kMinFaceSize, max_size);
    if (scaled != size) {
      size = scaled;
      interp = estimate(size);
    }
  }
  for (int round = 0; round < kFaceSizeRounds && size < max_size &&
                      !MeetsTargets(interp, targets, kInterpolationShare);
       ++round) {
    size = std::min(max_size, RoundUp8(size * kFaceSizeGrowth));
    interp = estimate(size);
  }
  best.face_size = size;
  best.interpolation = interp;
  best.met = best.met && MeetsTargets(interp, targets, kInterpolationShare);
  return absl::OkStatus();
}

namespace {

// How far a whole estimate is from the targets: the largest of front RMS, front largest and
// (where it is a target) grazing RMS, each over its target. <= 1: all within them.
double BudgetScore(const DirectionalError& e, const ToleranceTargets& t) {
  double score = std::max(e.front.rms / t.rms, e.front.max / t.max);
  if (t.grazing && e.grazing.count > 0) score = std::max(score, e.grazing.rms / t.grazing_rms);
  return score;
}

}  // namespace

absl::Status ChooseWithinBudget(const BandTable& table, std::span<const DirectionPair> pairs,
                                int light_lmax, int channels, std::span<const double> light,
                                const BrdfCoefficients& brdf, const ToleranceOptions& options,
                                ToleranceChoice* choice, InterpolationMemo* memo) {
  const double needed = CubeValues(choice->face_size, choice->p);
  int max_face_size = 0;
  SHRM_ASSIGN_OR_RETURN(ToleranceChoice within,
                        ChooseOrdersWithinBudget(table, options, &max_face_size));
  within.unlimited_values = needed;
  if (options.face_size > 0) {
    within.face_size = options.face_size;
    *choice = within;
    return absl::OkStatus();
  }
  const ToleranceTargets targets = TargetsForTolerance(options.tolerance, brdf.view);
  // Per view order P: S_max(P), the largest face size the budget allows, and F the smallest that
  // meets the targets at P (else the reference's). Texel interpolation at S_max is estimated for
  // the candidates in the order of their truncation scores until the next one's truncation
  // alone is worse than the best total (each total is at least its truncation).
  struct Candidate {
    ToleranceChoice c;
    int s_max = 0;
    double score = 0;
  };
  std::vector<Candidate> candidates;
  for (int p = 0; p <= table.p_ref(); ++p) {
    int s = 8 * static_cast<int>(
                    std::floor(std::sqrt(options.max_cube_values / CubeValues(1, p)) / 8 + 1e-9));
    s = std::min(s, std::max(kMinFaceSize, options.max_face_size));
    if (s < kMinFaceSize) break;  // larger p only shrinks it
    Candidate k;
    k.c = within;
    k.c.p = p;
    k.c.f = BudgetStepF(table, p, options);
    if (k.c.f < 0) k.c.f = table.f_ref();
    ChooseWindow(table, options, &k.c);
    k.s_max = s;
    k.score = BudgetScore(k.c.truncation, targets);
    candidates.push_back(k);
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
  // Candidates of one F, window and S_max with P > 0 evaluate the same texel centres, and the
  // l-sums there (most of an estimate's cost) do not depend on P: such a group is estimated at
  // all its view orders at once (EstimateInterpolationAtViewOrders, bit for bit the estimates one
  // by one) when its first candidate is reached (forest.exr microfacet sigma 0.1 at 256 MB: 13
  // estimates in 7 groups, the step 9.4 -> 6.6 s on one thread).
  struct TapGroup {
    int f = 0, s = 0;
    RingingWindow window = RingingWindow::kNone;
    std::vector<int> view_orders;
    std::vector<DirectionalError> estimates;  // per view order, once made
  };
  std::vector<TapGroup> groups;
  const auto group_of = [&](const ToleranceChoice& c, int s) -> TapGroup* {
    for (TapGroup& g : groups)
      if (g.f == c.f && g.s == s && g.window == c.window) return &g;
    return nullptr;
  };
  for (const Candidate& k : candidates) {
    if (k.c.p == 0) continue;  // (P = 0: EstimateInterpolation's cube)
    TapGroup* g = group_of(k.c, k.s_max);
    if (g == nullptr) {
      groups.push_back({k.c.f, k.s_max, k.c.window, {}, {}});
      g = &groups.back();
    }
    g->view_orders.push_back(k.c.p);
  }
  const Candidate* best = nullptr;
  double best_score = 0;
  for (size_t i = 0; i < candidates.size(); ++i) {
    const Candidate& k = candidates[i];
    if (best != nullptr && k.score >= best_score) break;
    ToleranceChoice trial = k.c;
    trial.face_size = k.s_max;
    const DirectionalError* known =
        memo != nullptr ? memo->Find(trial.f, trial.p, trial.window, k.s_max) : nullptr;
    TapGroup* group = trial.p > 0 ? group_of(trial, k.s_max) : nullptr;
    if (known != nullptr) {
      trial.interpolation = *known;
    } else {
      if (group == nullptr || group->estimates.empty()) {
        const int p = group == nullptr
                          ? trial.p
                          : *std::max_element(group->view_orders.begin(), group->view_orders.end());
        const std::vector<double> windowed =
            ApplyWindow(trial.window, trial.f, light_lmax, channels, light);
        SHRM_ASSIGN_OR_RETURN(
            ShrmSynthesizer synth,
            ShrmSynthesizer::Create(light_lmax, channels, windowed, brdf, trial.f, p));
        if (group == nullptr) {
          trial.interpolation = EstimateInterpolation(synth, pairs, k.s_max, options.threads,
                                                      table.Values(trial.f, trial.p, trial.window),
                                                      JobGridRows(synth, options.tolerance));
        } else {
          std::vector<std::vector<Rgb>> exact;
          for (int q : group->view_orders) exact.push_back(table.Values(trial.f, q, trial.window));
          group->estimates = EstimateInterpolationAtViewOrders(
              synth, pairs, k.s_max, options.threads, group->view_orders, exact);
        }
      }
      if (group != nullptr) {
        const auto at = std::find(group->view_orders.begin(), group->view_orders.end(), trial.p);
        trial.interpolation = group->estimates[at - group->view_orders.begin()];
      }
      if (memo != nullptr) memo->Add(trial.f, trial.p, trial.window, k.s_max, trial.interpolation);
    }
    const double score = BudgetScore(TotalEstimate(trial), targets);
    if (best == nullptr || score < best_score) {
      best = &k;
      best_score = score;
    }
  }
  // The winner's S: ChooseFaceSize up to S_max (smaller where interpolation allows).
  ToleranceChoice chosen = best->c;
  ToleranceOptions sized = options;
  sized.max_face_size = best->s_max;
  SHRM_RETURN_IF_ERROR(ChooseFaceSize(pairs, light_lmax, channels, light, brdf, sized, &chosen,
                                      table.Values(chosen.f, chosen.p, chosen.window), memo));
  chosen.budget_limited = true;
  chosen.unlimited_values = needed;
  *choice = chosen;
  return absl::OkStatus();
}

}  // namespace shrm
