#include "core/ibl/dfg.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/base/geometry.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/sh/quadrature.h"

namespace shrm::ibl {
namespace {

// Quadrature orders (docs/ibl_dfg.md "Accuracy": chosen against a 4x finer run of the same
// scheme and checked against brute force in tests/dfg_test.cc).
constexpr double kPanelLength = 3.5;    // panel width in the log-CDF variable
constexpr int kThetaNodes = 5;          // Gauss-Legendre nodes per theta panel
constexpr int kCutThetaNodes = 12;      // ... per panel with a singular (|.|^1.5) end
constexpr double kMaxThetaPanel = 0.5;  // widest theta panel (theta-space lobes)
constexpr int kHorizonGrading = 6;      // most halvings of the panel at a horizon end
// No grading where the feature's weight (u-density x width x integrand bound) is below this.
constexpr double kGradingWeightFloor = 1e-8;
constexpr int kFullPhiNodes = 12;    // midpoint nodes on [0, pi] (full circle, periodic)
constexpr int kMinFullPhiNodes = 4;  // fewest (exact for Fc, a quintic in cos(phi))
constexpr int kCutPhiNodes = 10;     // Gauss-Legendre nodes on [0, phi0] (cut circle)
constexpr int kMaxPhiNodes = std::max(kFullPhiNodes, kCutPhiNodes);
// Lobe tails whose whole u-measure times an integrand bound is below this are dropped.
constexpr double kTailCutoff = 1e-9;

// Gauss-Legendre nodes and weights on [0, 1].
struct UnitRule {
  std::vector<double> x, w;
};

UnitRule MakeUnitRule(int m) {
  const RingQuadrature q = GaussLegendreRule(m);
  UnitRule r;
  for (int k = 0; k < m; ++k) {
    r.x.push_back(0.5 * (1.0 + q.cos_theta[k]));
    r.w.push_back(0.5 * q.weight[k]);
  }
  return r;
}

const UnitRule& ThetaRule() {
  static const UnitRule* r = new UnitRule(MakeUnitRule(kThetaNodes));
  return *r;
}
const UnitRule& CutThetaRule() {
  static const UnitRule* r = new UnitRule(MakeUnitRule(kCutThetaNodes));
  return *r;
}
const UnitRule& CutPhiRule() {
  static const UnitRule* r = new UnitRule(MakeUnitRule(kCutPhiNodes));
  return *r;
}
// Full-circle azimuth rules: the midpoint rule in psi on [0, pi] (even, 2 pi periodic
// integrand), through the periodic map phi = psi + gamma sin(psi), which packs nodes towards
// phi = pi (density 1 + gamma cos(psi)), where l = reflect(v, h) comes nearest the horizon.
// Stored as cos(phi) and weights (sum 1) for m = 1..kFullPhiNodes nodes and each gamma.
constexpr std::array<double, 4> kPhiGammas = {0.0, 0.5, 0.75, 0.9};
struct PhiRule {
  std::vector<double> cos_phi, w;
};
const PhiRule& FullPhiRule(int m, int gamma_index) {
  static const auto* rules = [] {
    auto* t = new std::vector<PhiRule>(kFullPhiNodes * kPhiGammas.size());
    for (size_t g = 0; g < kPhiGammas.size(); ++g) {
      for (int n = 1; n <= kFullPhiNodes; ++n) {
        PhiRule& r = (*t)[g * kFullPhiNodes + n - 1];
        for (int k = 0; k < n; ++k) {
          const double psi = kPi * (k + 0.5) / n;
          r.cos_phi.push_back(std::cos(psi + kPhiGammas[g] * std::sin(psi)));
          r.w.push_back((1.0 + kPhiGammas[g] * std::cos(psi)) / n);
        }
      }
    }
    return t;
  }();
  return (*rules)[gamma_index * kFullPhiNodes + m - 1];
}

inline double Pow5(double x) { return (x * x) * (x * x) * x; }

// cos(x) for x in [0, pi] as -sin(x - pi/2) by its Taylor polynomial to degree 15 (error below
// 1e-11 on the interval; libm's cos was a third of the run time).
inline double CosOnZeroPi(double x) {
  const double y = x - 0.5 * kPi, y2 = y * y;
  double p = -1.0 / 1307674368000.0;
  p = p * y2 + 1.0 / 6227020800.0;
  p = p * y2 - 1.0 / 39916800.0;
  p = p * y2 + 1.0 / 362880.0;
  p = p * y2 - 1.0 / 5040.0;
  p = p * y2 + 1.0 / 120.0;
  p = p * y2 - 1.0 / 6.0;
  p = p * y2 + 1.0;
  return -y * p;
}

// The view v = (sv, 0, nv) and the half-vector polar angles where the horizon starts cutting the
// azimuth circle (theta1: l = reflect(v, h) reaches n.l = 0 at phi = pi) and where it has cut it
// all (theta2: at phi = 0). In the plane of incidence l makes the signed angle 2 theta_h -+
// theta_v.
struct View {
  double nv, sv, theta1, theta2;
};

View MakeView(double nv) {
  View v;
  v.nv = nv;
  v.sv = std::sqrt(std::max(0.0, (1.0 - nv) * (1.0 + nv)));
  const double theta_v = std::atan2(v.sv, nv);
  v.theta1 = 0.5 * (0.5 * kPi - theta_v);
  v.theta2 = 0.5 * (0.5 * kPi + theta_v);
  return v;
}

// The lobes. x is the log of the lobe's CDF variable u (u-measure e^x dx): panels of equal width
// in x follow the lobe at every roughness; inside a panel the nodes are placed in theta (where
// the integrand times du/dtheta is smooth up to the horizon), with weight du/dtheta.
//
// GGX: u = tan^2 / (tan^2 + alpha^2), the CDF of D(h) (n.h); x = log(1 - u), 0 at the pole and
// decreasing towards the horizon.
struct GgxLobe {
  static constexpr bool kThetaSpace = false;  // x-space: the lobe core is rational in theta
  double alpha, alpha2;
  double XOfTheta(double theta) const {
    const double t = std::tan(theta);
    return -std::log1p(t * t / alpha2);
  }
  double XAtPole() const { return 0.0; }
  double ThetaOfX(double x) const { return std::atan(alpha * std::sqrt(std::expm1(-x))); }
  // cos, sin of theta at x and the u-density e^x, from one expm1.
  void Angles(double x, double* ch, double* sh, double* ex) const {
    const double em1 = std::expm1(x);  // -u
    *ex = 1.0 + em1;
    const double t2 = -alpha2 * em1 / *ex;
    *ch = 1.0 / std::sqrt(1.0 + t2);
    *sh = std::sqrt(t2) * *ch;
  }
  // du/dtheta = 2 alpha^2 tan (1 + tan^2) / (tan^2 + alpha^2)^2.
  double Density(double ch, double sh) const {
    const double t = sh / ch;
    const double q = t * t + alpha2;
    return 2.0 * alpha2 * t * (1.0 + t * t) / (q * q);
  }
};

// Charlie: u = sin^k, k = 2 + 1/alpha, the CDF of D_c(h) (n.h); x = log(u), -inf at the pole
// and increasing towards the horizon.
struct CharlieLobe {
  static constexpr bool kThetaSpace = true;  // theta-space: du/dx ~ 1/cos near the horizon
  double k;
  double XOfTheta(double theta) const { return k * std::log(std::sin(theta)); }
  double XAtPole() const { return -std::numeric_limits<double>::infinity(); }
  double ThetaOfX(double x) const {
    return std::atan2(std::exp(x / k), std::sqrt(-std::expm1(2.0 * x / k)));
  }
  void Angles(double x, double* ch, double* sh, double* ex) const {
    *sh = std::exp(x / k);
    *ch = std::sqrt(-std::expm1(2.0 * x / k));
    *ex = std::exp(x);
  }
  // du/dtheta = k sin^(k-1) cos.
  double Density(double ch, double sh) const {
    return sh > 0 ? k * std::exp((k - 1.0) * std::log(sh)) * ch : 0.0;
  }
};

// Adds the azimuth integral at polar angle theta (weight w_theta, already including du/dtheta
// and the theta rule) to body(ch, sh, vh, nl, w), w the weight in integral du dphi / (2 pi).
// Azimuth nodes of one ring: vh[k], nl[k], w[k] for k < m, passed to body(ch, vh, nl, w, m) in one
// call so that the integrand loops have no branches and vectorise.
// `layer` is the n.l scale of the integrand's feature at the horizon (the complex singularity
// nearest n.l = 0): near phi = pi, n.l ~ nl_pi + ch s (phi - pi)^2, so the singularity sits at
// |phi - pi| ~ d = sqrt(max(layer, nl_pi) / (ch s)); the smaller d, the larger gamma.
template <typename Body>
void AzimuthAt(const View& v, double ch, double sh, double w_theta, bool full, double layer,
               Body& body) {
  const double s = v.sv * sh, c = v.nv * ch;
  if (full) {
    const double nl_pi = 2.0 * (c - s) * ch - v.nv;
    const double d2 = s > 0 ? std::max(layer, nl_pi) / (ch * s) : 1e300;
    const int g = d2 > 1.0 ? 0 : d2 > 0.25 ? 1 : d2 > 0.04 ? 2 : 3;
    // Few nodes when n.l varies little (2 ch s) against its distance to the feature.
    const double ratio = 2.0 * ch * s / (std::max(nl_pi, 0.0) + layer + 1e-300);
    const int m = g > 0 ? kFullPhiNodes
                        : std::clamp(static_cast<int>(std::ceil(kMinFullPhiNodes + 8.0 * ratio)),
                                     kMinFullPhiNodes, kFullPhiNodes);
    const PhiRule& rule = FullPhiRule(m, g);
    double vh[kMaxPhiNodes], nl[kMaxPhiNodes], w[kMaxPhiNodes];
    for (int k = 0; k < m; ++k) {
      vh[k] = s * rule.cos_phi[k] + c;
      nl[k] = std::max(2.0 * vh[k] * ch - v.nv, 0.0);  // >= 0 up to round-off for theta <= theta1
      w[k] = w_theta * rule.w[k];
    }
    body(ch, vh, nl, w, m);
    return;
  }
  if (s <= 0) return;
  // n.l > 0  <=>  cos(phi) > kk.
  const double kk = v.nv * (1.0 - 2.0 * ch * ch) / (2.0 * ch * s);
  if (kk >= 1.0) return;
  const double phi0 = kk <= -1.0 ? kPi : std::acos(kk);
  const UnitRule& rp = CutPhiRule();
  const double wc = w_theta * phi0 / kPi;
  double vh[kMaxPhiNodes], nl[kMaxPhiNodes], w[kMaxPhiNodes];
  for (int k = 0; k < kCutPhiNodes; ++k) {
    vh[k] = s * CosOnZeroPi(phi0 * rp.x[k]) + c;
    nl[k] = std::max(2.0 * vh[k] * ch - v.nv, 0.0);
    w[k] = wc * rp.w[k];
  }
  body(ch, vh, nl, w, kCutPhiNodes);
}

// Calls body(ch, vh, nl, w, m) for each ring of m azimuth nodes (n.l >= 0; where n.l = 0 the
// integrand vanishes, v.h > 0 wherever n.l > 0), w the weight of the node in
// integral du dphi / (2 pi) (so that integral f n.l dl = sum w * f n.l * 4 v.h / n.h, the D
// factor absorbed by the CDF). `bound` bounds f n.l 4 v.h / n.h (tail cut-off).
template <typename Lobe, typename Body>
void IntegrateHalfVector(const View& v, const Lobe& lobe, double bound, double layer, Body&& body) {
  const double x_cut = std::log(kTailCutoff / bound);
  // Segment [theta_a, theta_b]: full (the azimuth circle whole) or cut by the horizon, with
  // |theta - end|^(3/2) behaviour at both ends, smoothed by z = end + (other - end) tau^2 on the
  // end panels (z = x or theta), or by the cubic s(t) = 3t^2 - 2t^3 when one panel has both.
  auto segment = [&](double theta_a, double theta_b, bool full) {
    if (!(theta_b > theta_a)) return;
    const double xa = theta_a <= 0 ? lobe.XAtPole() : lobe.XOfTheta(theta_a);
    const double xb = lobe.XOfTheta(theta_b);
    // x runs from the light end (x_lo) to the heavy one; clip the light end at the cut-off.
    const bool increasing = xb > xa;
    double x_lo = std::min(xa, xb);
    const double x_hi = std::max(xa, xb);
    if (x_hi <= x_cut) return;
    const bool lo_clipped = x_lo < x_cut;
    if (lo_clipped) x_lo = x_cut;
    // Panel boundaries in x: uniform, graded geometrically (kHorizonGrading halvings) into the
    // ends where l = reflect(v, h) meets the horizon (theta1; theta2 of a cut segment), where the
    // visibility has a feature of width ~alpha (GGX) or ~n.v (Neubelt) in n.l.
    const int uniform = std::max(1, static_cast<int>(std::ceil((x_hi - x_lo) / kPanelLength)));
    std::vector<double> xs;
    for (int p = 0; p <= uniform; ++p) {
      xs.push_back(p == uniform ? x_hi : x_lo + p * (x_hi - x_lo) / uniform);
    }
    const bool horizon_lo = !lo_clipped && (!full || !increasing);
    const bool horizon_hi = !full || increasing;
    // Halvings needed for the smallest sub-panel to resolve the feature: it spans ~layer / 2 in
    // theta, so ~|dx/dtheta| layer / 2 in x; none where its weight is negligible.
    auto levels_at = [&](double x_end, double theta_end) {
      if (layer <= 0) return 0;
      const double eps = 1e-6;
      const double t2 = theta_end + (theta_end > 0.5 * kPi - 2 * eps ? -eps : eps);
      const double dxdt = std::abs((lobe.XOfTheta(t2) - x_end) / eps);
      const double width = dxdt * 0.5 * layer;
      if (std::exp(x_end) * width * bound < kGradingWeightFloor) return 0;
      const double h = (x_hi - x_lo) / uniform;
      if (!(width < h)) return 0;
      return std::min(kHorizonGrading, static_cast<int>(std::ceil(std::log2(h / width))));
    };
    auto grade = [&](bool at_lo, int levels) {
      std::vector<double> g;
      const double a = at_lo ? xs[0] : xs[xs.size() - 1];
      const double b = at_lo ? xs[1] : xs[xs.size() - 2];
      for (int k = levels; k >= 1; --k) g.push_back(a + (b - a) * std::ldexp(1.0, -k));
      if (at_lo) {
        xs.insert(xs.begin() + 1, g.begin(), g.end());
      } else {
        xs.insert(xs.end() - 1, g.rbegin(), g.rend());
      }
    };
    const double theta_at_lo = increasing ? theta_a : theta_b;
    const double theta_at_hi = increasing ? theta_b : theta_a;
    if (horizon_lo) grade(true, levels_at(x_lo, theta_at_lo));
    if (horizon_hi) grade(false, levels_at(x_hi, theta_at_hi));
    const int panels = static_cast<int>(xs.size()) - 1;
    auto theta_of = [&](double x, bool is_lo_end, bool is_hi_end) {
      if (is_lo_end && !lo_clipped) return increasing ? theta_a : theta_b;
      if (is_hi_end) return increasing ? theta_b : theta_a;
      return lobe.ThetaOfX(x);
    };
    for (int p = 0; p < panels; ++p) {
      const double xp0 = xs[p], xp1 = xs[p + 1];
      // Whether the panel's x_lo / x_hi side is a singular segment end.
      const bool end_xlo = !full && p == 0 && !lo_clipped;
      const bool end_xhi = !full && p + 1 == panels;
      double z0, z1;
      bool sing0, sing1;  // at z0 / z1
      int sub = 1;
      if (Lobe::kThetaSpace) {
        const double ta = theta_of(xp0, p == 0, false), tb = theta_of(xp1, false, p + 1 == panels);
        z0 = std::min(ta, tb);
        z1 = std::max(ta, tb);
        // theta increases with x iff the lobe's x does.
        sing0 = increasing ? end_xlo : end_xhi;
        sing1 = increasing ? end_xhi : end_xlo;
        sub = std::max(1, static_cast<int>(std::ceil((z1 - z0) / kMaxThetaPanel)));
      } else {
        z0 = xp0;
        z1 = xp1;
        sing0 = end_xlo;
        sing1 = end_xhi;
      }
      const double hz = (z1 - z0) / sub;
      if (!(hz > 0)) continue;
      for (int b = 0; b < sub; ++b) {
        const double lo = z0 + b * hz;
        const bool s_lo = sing0 && b == 0, s_hi = sing1 && b + 1 == sub;
        const UnitRule& r = s_lo || s_hi ? CutThetaRule() : ThetaRule();
        for (size_t q = 0; q < r.x.size(); ++q) {
          const double tq = r.x[q];
          double z, dz;
          if (s_lo && s_hi) {
            z = lo + hz * tq * tq * (3 - 2 * tq);
            dz = hz * 6 * tq * (1 - tq);
          } else if (s_lo) {
            z = lo + hz * tq * tq;
            dz = hz * 2 * tq;
          } else if (s_hi) {
            z = lo + hz - hz * (1 - tq) * (1 - tq);
            dz = hz * 2 * (1 - tq);
          } else {
            z = lo + hz * tq;
            dz = hz;
          }
          double ch, sh, w;
          if (Lobe::kThetaSpace) {
            ch = std::cos(z);
            sh = std::sin(z);
            w = r.w[q] * dz * lobe.Density(ch, sh);
          } else {
            double ez;
            lobe.Angles(z, &ch, &sh, &ez);
            w = r.w[q] * dz * ez;
          }
          if (w > 0) AzimuthAt(v, ch, sh, w, full, layer, body);
        }
      }
    }
  };
  segment(0.0, v.theta1, true);
  segment(v.theta1, v.theta2, false);
}

double ClampAlpha(double alpha) { return std::clamp(alpha, kDfgMinAlpha, 1.0); }
double ClampNv(double nv) { return std::clamp(nv, 1e-9, 1.0); }

// Estevez & Kulla 2017's fitted sheen lambda, as given by KHR_materials_sheen.
double SheenL(double x, double alpha) {
  const double t = (1.0 - alpha) * (1.0 - alpha);
  auto mix = [t](double p, double q) { return p + (q - p) * t; };
  const double a = mix(21.5473, 25.3245), b = mix(3.82987, 3.32435), c = mix(0.19823, 0.16801),
               d = mix(-1.97760, -1.27393), e = mix(-4.32054, -4.85967);
  return a / (1.0 + b * std::pow(x, c)) + d * x + e;
}
double SheenLambda(double cos_theta, double alpha) {
  return cos_theta < 0.5 ? std::exp(SheenL(cos_theta, alpha))
                         : std::exp(2.0 * SheenL(0.5, alpha) - SheenL(1.0 - cos_theta, alpha));
}

GgxDfg GgxAt(const View& v, double alpha) {
  const double a2 = alpha * alpha;
  const double one_minus_a2 = (1.0 - alpha) * (1.0 + alpha);
  const double av = std::sqrt(v.nv * v.nv * one_minus_a2 + a2);
  GgxDfg r;
  const double bound = 2.0 / (av * std::sin(std::max(v.theta1, 1e-300)));
  IntegrateHalfVector(v, GgxLobe{alpha, a2}, bound, alpha,
                      [&](double ch, const double* vh, const double* nl, const double* w, int m) {
                        double val[kMaxPhiNodes], fc[kMaxPhiNodes];
                        const double j =
                            2.0 / ch;  // 0.5 (V's numerator) * 4 v.h / n.h (Jacobian / pdf)
                        for (int k = 0; k < m; ++k) {
                          const double al = std::sqrt(nl[k] * nl[k] * one_minus_a2 + a2);
                          val[k] = w[k] * j * nl[k] * vh[k] / (v.nv * al + nl[k] * av);
                          fc[k] = Pow5(1.0 - vh[k]);
                        }
                        for (int k = 0; k < m; ++k) {
                          r.scale += val[k] * (1.0 - fc[k]);
                          r.bias += val[k] * fc[k];
                        }
                      });
  return r;
}

struct SheenPair {
  double charlie = 0, albedo = 0;
};

SheenPair SheenAt(const View& v, double alpha, bool want_charlie, bool want_albedo) {
  SheenPair r;
  const double lv = want_albedo ? SheenLambda(v.nv, alpha) : 0.0;
  const double bound = 4.0 / std::sin(std::max(v.theta1, 1e-300));
  IntegrateHalfVector(v, CharlieLobe{2.0 + 1.0 / alpha}, bound, v.nv,
                      [&](double ch, const double* vh, const double* nl, const double* w, int m) {
                        double jac[kMaxPhiNodes], val[kMaxPhiNodes];
                        for (int k = 0; k < m; ++k) jac[k] = w[k] * 4.0 * vh[k] / ch * nl[k];
                        if (want_charlie) {
                          for (int k = 0; k < m; ++k)
                            val[k] = jac[k] / (4.0 * (nl[k] + v.nv - nl[k] * v.nv));
                          for (int k = 0; k < m; ++k) r.charlie += val[k];
                        }
                        if (want_albedo) {
                          for (int k = 0; k < m; ++k) {
                            if (!(nl[k] > 0)) continue;
                            const double vis =
                                1.0 / ((1.0 + lv + SheenLambda(nl[k], alpha)) * 4.0 * v.nv * nl[k]);
                            r.albedo += jac[k] * std::min(vis, 1.0);
                          }
                        }
                      });
  return r;
}

bool IsGgx(DfgChannel c) {
  return c == DfgChannel::kGgxScale || c == DfgChannel::kGgxBias || c == DfgChannel::kGgxEnergy;
}

}  // namespace

GgxDfg IntegrateGgxDfg(double n_dot_v, double alpha) {
  return GgxAt(MakeView(ClampNv(n_dot_v)), ClampAlpha(alpha));
}

double IntegrateCharlieNeubelt(double n_dot_v, double alpha) {
  return SheenAt(MakeView(ClampNv(n_dot_v)), ClampAlpha(alpha), true, false).charlie;
}

double IntegrateSheenAlbedo(double n_dot_v, double alpha) {
  return SheenAt(MakeView(ClampNv(n_dot_v)), ClampAlpha(alpha), false, true).albedo;
}

double GgxSmoothLimitBias(double n_dot_v) { return Pow5(1.0 - n_dot_v); }

double GgxEnergyAtAlphaOne(double n_dot_v) { return 1.0 - n_dot_v * std::log1p(1.0 / n_dot_v); }

double CharlieNeubeltAtNormalIncidence(double alpha) {
  const double p = 0.5 / alpha;
  return (2.0 + 1.0 / alpha) / (4.0 * std::exp2(p) * (p + 1.0) * (p + 2.0));
}

DfgLutLayout LayoutFor(DfgConsumer consumer) {
  using C = DfgChannel;
  DfgLutLayout l;
  switch (consumer) {
    case DfgConsumer::kFilament:
      l.channels = {C::kGgxBias, C::kGgxEnergy, C::kCharlieNeubelt};
      break;
    case DfgConsumer::kFilamentCmgenExact:
      l.channels = {C::kGgxBias, C::kGgxEnergy, C::kCharlieNeubelt};
      l.roughness_texel_offset = 1.0;
      break;
    case DfgConsumer::kFilamentSingleScatter:
      l.channels = {C::kGgxScale, C::kGgxBias, C::kCharlieNeubelt};
      break;
    case DfgConsumer::kGltfLutGgx:
      l.channels = {C::kGgxScale, C::kGgxBias, C::kCharlieNeubelt};
      break;
    case DfgConsumer::kGltfLutCharlie:
      l.channels = {C::kZero, C::kZero, C::kCharlieNeubelt};
      break;
    case DfgConsumer::kGltfLutSheenE:
      l.channels = {C::kSheenAlbedo};
      break;
    case DfgConsumer::kBabylon:
      l.channels = {C::kGgxBias, C::kGgxEnergy, C::kCharlieNeubelt};
      break;
    case DfgConsumer::kKaris:
      l.channels = {C::kGgxScale, C::kGgxBias};
      break;
  }
  // Every consumer read stores the smooth row first (GL order / PNG top row = roughness 0) and
  // indexes rows by perceptual roughness (docs/ibl_dfg.md).
  l.roughness_axis = RoughnessAxis::kPerceptual;
  l.row_order = RowOrder::kSmoothFirst;
  return l;
}

const char* DfgConsumerName(DfgConsumer consumer) {
  switch (consumer) {
    case DfgConsumer::kFilament:
      return "filament";
    case DfgConsumer::kFilamentCmgenExact:
      return "filament-cmgen-exact";
    case DfgConsumer::kFilamentSingleScatter:
      return "filament-single-scatter";
    case DfgConsumer::kGltfLutGgx:
      return "gltf-lut-ggx";
    case DfgConsumer::kGltfLutCharlie:
      return "gltf-lut-charlie";
    case DfgConsumer::kGltfLutSheenE:
      return "gltf-lut-sheen-e";
    case DfgConsumer::kBabylon:
      return "babylon";
    case DfgConsumer::kKaris:
      return "karis";
  }
  return "unknown";
}

double DfgLut::RoughnessCoordinateOfRow(int row) const {
  const int j = layout.row_order == RowOrder::kSmoothFirst ? row : size - 1 - row;
  return std::min(1.0, (j + 0.5 + layout.roughness_texel_offset) / size);
}

double DfgLut::AlphaOfRow(int row) const {
  const double y = RoughnessCoordinateOfRow(row);
  return layout.roughness_axis == RoughnessAxis::kPerceptual ? y * y : y;
}

absl::Status ValidateDfgLut(int size, const DfgLutLayout& layout, int threads) {
  if (size < 1 || size > kMaxDfgLutSize) {
    return absl::InvalidArgumentError(absl::StrCat(
        "DFG LUT size ", size, " is out of range: it must be in [1, ", kMaxDfgLutSize, "]"));
  }
  if (layout.channels.empty() || layout.channels.size() > 4) {
    return absl::InvalidArgumentError(absl::StrCat("DFG LUT layout has ", layout.channels.size(),
                                                   " channels: it must have 1 to 4"));
  }
  if (!std::isfinite(layout.roughness_texel_offset) || layout.roughness_texel_offset < 0) {
    return absl::InvalidArgumentError(absl::StrCat("DFG LUT roughness texel offset ",
                                                   layout.roughness_texel_offset,
                                                   " must be finite and >= 0"));
  }
  if (threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("DFG LUT thread count ", threads, " must be >= 1"));
  }
  return absl::OkStatus();
}

absl::StatusOr<DfgLut> ComputeDfgLutByQuadrature(int size, const DfgLutLayout& layout,
                                                 int threads) {
  SHRM_RETURN_IF_ERROR(ValidateDfgLut(size, layout, threads));
  DfgLut lut;
  lut.size = size;
  lut.channels = static_cast<int>(layout.channels.size());
  lut.layout = layout;
  lut.data.assign(static_cast<size_t>(size) * size * lut.channels, 0.0f);

  bool want_ggx = false, want_charlie = false, want_albedo = false;
  for (DfgChannel c : layout.channels) {
    want_ggx |= IsGgx(c);
    want_charlie |= c == DfgChannel::kCharlieNeubelt;
    want_albedo |= c == DfgChannel::kSheenAlbedo;
  }
  std::vector<View> views(size);
  for (int i = 0; i < size; ++i) views[i] = MakeView(lut.NDotVOfColumn(i));

  ParallelChunks(size, threads, [&](int row_begin, int row_end) {
    for (int row = row_begin; row < row_end; ++row) {
      const double alpha = ClampAlpha(lut.AlphaOfRow(row));
      for (int col = 0; col < size; ++col) {
        const View& v = views[col];
        const GgxDfg g = want_ggx ? GgxAt(v, alpha) : GgxDfg{};
        const SheenPair s = want_charlie || want_albedo
                                ? SheenAt(v, alpha, want_charlie, want_albedo)
                                : SheenPair{};
        float* out = &lut.data[(static_cast<size_t>(row) * size + col) * lut.channels];
        for (int c = 0; c < lut.channels; ++c) {
          double value = 0;
          switch (layout.channels[c]) {
            case DfgChannel::kGgxScale:
              value = g.scale;
              break;
            case DfgChannel::kGgxBias:
              value = g.bias;
              break;
            case DfgChannel::kGgxEnergy:
              value = g.Energy();
              break;
            case DfgChannel::kCharlieNeubelt:
              value = s.charlie;
              break;
            case DfgChannel::kSheenAlbedo:
              value = s.albedo;
              break;
            case DfgChannel::kZero:
              break;
          }
          out[c] = static_cast<float>(value);
        }
      }
    }
  });
  return lut;
}

}  // namespace shrm::ibl
