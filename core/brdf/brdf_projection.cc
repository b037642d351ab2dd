#include "core/brdf/brdf_projection.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/brdf/brdf_models.h"
#include "core/brdf/vector_math.h"
#include "core/sh/quadrature.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

constexpr int kRadialPanelOrder = 10;

// Gauss-Legendre rules by node count, computed once per process (their Newton iterations took a
// quarter of a BRDF stage's time). Rules are immutable; the references stay valid.
const RingQuadrature& CachedGaussLegendre(int n) {
  static std::mutex mu;
  static auto* rules = new std::map<int, std::unique_ptr<const RingQuadrature>>();
  std::lock_guard<std::mutex> lock(mu);
  auto& rule = (*rules)[n];
  if (rule == nullptr) rule = std::make_unique<const RingQuadrature>(GaussLegendreRule(n));
  return *rule;
}
constexpr int kDefaultEnergyPanelOrder = 8;

struct Rule1D {
  std::vector<double> x, w;
};

// Gauss-Legendre on [a, b] (nodes increasing).
Rule1D GaussOn(const RingQuadrature& gl, double a, double b) {
  Rule1D r;
  const int n = static_cast<int>(gl.cos_theta.size());
  r.x.resize(n);
  r.w.resize(n);
  for (int j = 0; j < n; ++j) {
    // gl.cos_theta decreases with j; flip so x increases.
    const double t = gl.cos_theta[n - 1 - j];
    r.x[j] = a + (b - a) * 0.5 * (1.0 + t);
    r.w[j] = (b - a) * 0.5 * gl.weight[n - 1 - j];
  }
  return r;
}

// Composite Gauss-Legendre in theta over [0, pi] with the sin(theta) weight folded in:
// sum w_j g(theta_j) ~ integral_0^pi g(theta) sin(theta) dtheta; half_angle: sin(theta / 2)
// instead, the measure of the normal's sphere in theta_o' (ViewVariable::kNormal: theta_n' =
// theta_o' / 2 over the hemisphere, times 2: the weights W of AddViewNode).
Rule1D SinPanels(int panels, int order, bool half_angle = false) {
  const RingQuadrature gl = GaussLegendreRule(order);
  Rule1D r;
  for (int p = 0; p < panels; ++p) {
    const Rule1D panel = GaussOn(gl, kPi * p / panels, kPi * (p + 1) / panels);
    for (size_t j = 0; j < panel.x.size(); ++j) {
      r.x.push_back(panel.x[j]);
      r.w.push_back(panel.w[j] * std::sin(half_angle ? 0.5 * panel.x[j] : panel.x[j]));
    }
  }
  return r;
}

// End of the visible azimuth arc [0, phi*] where N.w > 0, N = (sin(t_o/2), 0, cos(t_o/2)):
// cos t_i cos(t_o/2) + sin t_i sin(t_o/2) cos phi > 0.
double VisibleArc(double cos_i, double sin_i, double theta_o) {
  const double a = cos_i * std::cos(0.5 * theta_o);
  const double b = sin_i * std::sin(0.5 * theta_o);
  if (b <= 1e-300) return a > 0 ? kPi : 0.0;
  const double c0 = -a / b;
  if (c0 <= -1.0) return kPi;
  if (c0 >= 1.0) return 0.0;
  return std::acos(c0);
}

// Azimuthal integrals of rho-hat (or rho-hat^2) at one (theta_i, theta_o).
class AzimuthRule {
 public:
  AzimuthRule(const Brdf& brdf, int n_phi, int qmax)
      : brdf_(brdf),
        channels_(brdf.channels()),
        qmax_(qmax),
        n_phi_(n_phi),
        clipped_(brdf.clipped_at_normal_horizon() && brdf.reparam() == ReparamKind::kReflection),
        flat_(brdf.azimuth_independent()),
        gl_(CachedGaussLegendre(n_phi)),
        values_(channels_),
        cosq_(qmax + 1) {
    if (!clipped_ && !flat_) {
      // Trapezoid on 2 n_phi nodes of the circle, folded onto k = 0..n_phi (even function).
      for (int k = 0; k <= n_phi; ++k) {
        uniform_phi_.push_back(kPi * k / n_phi);
        uniform_w_.push_back((k == 0 || k == n_phi ? 1.0 : 2.0) / (2.0 * n_phi));
      }
    }
  }

  // cq[q * channels + c] = (1/2pi) integral rho-hat cos(q phi) dphi, q = 0..qmax.
  void Cosines(double theta_i, double cos_i, double sin_i, double theta_o, double* cq) {
    std::fill(cq, cq + (qmax_ + 1) * channels_, 0.0);
    if (flat_) {
      brdf_.ReparamTransferAll(theta_i, theta_o, 0.0, values_.data());
      for (int c = 0; c < channels_; ++c) cq[c] = values_[c];
      return;
    }
    if (clipped_) {
      const double arc = VisibleArc(cos_i, sin_i, theta_o);
      if (arc <= 0) return;
      for (int m = 0; m < n_phi_; ++m) {
        const double t = gl_.cos_theta[m];
        const double phi = arc * 0.5 * (1.0 + t);
        // (1/2pi) * 2 (even) * arc/2 * w_m
        Accumulate(theta_i, theta_o, phi, arc * 0.5 * gl_.weight[m] / kPi, cq);
      }
      return;
    }
    for (size_t k = 0; k < uniform_phi_.size(); ++k) {
      Accumulate(theta_i, theta_o, uniform_phi_[k], uniform_w_[k], cq);
    }
  }

  // Horizon-clipped models: Cosines() and Squares() from the same evaluations (the visible arc's
  // Gauss-Legendre nodes), for the split rule.
  void CosinesAndSquares(double theta_i, double cos_i, double sin_i, double theta_o, double* cq,
                         double* sq) {
    std::fill(cq, cq + (qmax_ + 1) * channels_, 0.0);
    std::fill(sq, sq + channels_, 0.0);
    const double arc = VisibleArc(cos_i, sin_i, theta_o);
    if (arc <= 0) return;
    arc_phi_.resize(n_phi_);
    arc_cos_.resize(n_phi_);
    arc_sin_.resize(n_phi_);
    arc_values_.resize(static_cast<size_t>(n_phi_) * channels_);
    for (int m = 0; m < n_phi_; ++m) arc_phi_[m] = arc * 0.5 * (1.0 + gl_.cos_theta[m]);
    internal::VectorSinCos(arc_phi_.data(), arc_sin_.data(), arc_cos_.data(), n_phi_);
    brdf_.ReparamTransferArc(theta_i, theta_o, {arc_phi_, arc_cos_, arc_sin_}, arc_values_.data());
    // Weighted values per channel (wv[c * n + m]) and cos(q phi_m) by the Chebyshev recurrence
    // (cosq[q * n + m]), both with the azimuths side by side, then one dot product over the
    // azimuths per (q, c): accumulating node by node into cq chained every update through memory.
    const int n = n_phi_;
    arc_weighted_.resize(static_cast<size_t>(n) * channels_);
    arc_cosq_.resize(static_cast<size_t>(n) * (qmax_ + 1));
    for (int c = 0; c < channels_; ++c) {
      double squares = 0;  // in a register: accumulating into sq[c] chained through memory
      for (int m = 0; m < n; ++m) {
        const double v = arc_values_[static_cast<size_t>(m) * channels_ + c];
        const double wv = arc * 0.5 * gl_.weight[m] * v;
        arc_weighted_[c * n + m] = wv;
        squares += wv * v;
      }
      sq[c] += squares;
    }
    double* cosq = arc_cosq_.data();
    for (int m = 0; m < n; ++m) cosq[m] = 1.0;
    if (qmax_ >= 1) std::copy(arc_cos_.begin(), arc_cos_.begin() + n, cosq + n);
    for (int q = 2; q <= qmax_; ++q)
      for (int m = 0; m < n; ++m)
        cosq[q * n + m] = 2.0 * arc_cos_[m] * cosq[(q - 1) * n + m] - cosq[(q - 2) * n + m];
    for (int q = 0; q <= qmax_; ++q)
      for (int c = 0; c < channels_; ++c) {
        const double* wv = &arc_weighted_[c * n];
        const double* cs = cosq + q * n;
        double sum = 0;
        for (int m = 0; m < n; ++m) sum += cs[m] * wv[m];
        cq[q * channels_ + c] = sum / kPi;
      }
  }

  // out[c] = integral_0^pi rho-hat^2 dphi.
  void Squares(double theta_i, double cos_i, double sin_i, double theta_o, double* out) {
    std::fill(out, out + channels_, 0.0);
    if (flat_) {
      brdf_.ReparamTransferAll(theta_i, theta_o, 0.0, values_.data());
      for (int c = 0; c < channels_; ++c) out[c] = kPi * values_[c] * values_[c];
      return;
    }
    if (clipped_) {
      const double arc = VisibleArc(cos_i, sin_i, theta_o);
      if (arc <= 0) return;
      for (int m = 0; m < n_phi_; ++m) {
        const double phi = arc * 0.5 * (1.0 + gl_.cos_theta[m]);
        brdf_.ReparamTransferAll(theta_i, theta_o, phi, values_.data());
        const double w = arc * 0.5 * gl_.weight[m];
        for (int c = 0; c < channels_; ++c) out[c] += w * values_[c] * values_[c];
      }
      return;
    }
    for (size_t k = 0; k < uniform_phi_.size(); ++k) {
      brdf_.ReparamTransferAll(theta_i, theta_o, uniform_phi_[k], values_.data());
      const double w = uniform_w_[k] * 2.0 * kPi / 2.0;  // (2 pi)-normalized weights -> [0, pi]
      for (int c = 0; c < channels_; ++c) out[c] += w * values_[c] * values_[c];
    }
  }

 private:
  void Accumulate(double theta_i, double theta_o, double phi, double weight, double* cq) {
    brdf_.ReparamTransferAll(theta_i, theta_o, phi, values_.data());
    AddCosines(std::cos(phi), weight, values_.data(), cq);
  }
  // cq[q * channels + c] += weight cos(q phi) values[c], q = 0..qmax (c1 = cos phi).
  void AddCosines(double c1, double weight, const double* values, double* cq) {
    cosq_[0] = 1.0;
    if (qmax_ >= 1) cosq_[1] = c1;
    for (int q = 2; q <= qmax_; ++q) cosq_[q] = 2.0 * c1 * cosq_[q - 1] - cosq_[q - 2];
    for (int q = 0; q <= qmax_; ++q) {
      const double wq = weight * cosq_[q];
      for (int c = 0; c < channels_; ++c) cq[q * channels_ + c] += wq * values[c];
    }
  }

  const Brdf& brdf_;
  const int channels_, qmax_, n_phi_;
  const bool clipped_, flat_;
  const RingQuadrature& gl_;
  std::vector<double> uniform_phi_, uniform_w_;
  std::vector<double> values_, cosq_;
  std::vector<double> arc_phi_, arc_cos_, arc_sin_, arc_values_, arc_weighted_, arc_cosq_;
};

int Or(int value, int fallback) { return value > 0 ? value : fallback; }

// lambda_l^m(cos theta) for m <= mmax only, by the recurrences of NormalizedLegendre (core/sh/sh.h)
// with their coefficients computed once: out[m * (lmax + 1) + l], l >= m.
class LegendreColumns {
 public:
  LegendreColumns(int lmax, int mmax) : nl_(lmax + 1), mmax_(std::min(mmax, lmax)) {
    a_.assign(static_cast<size_t>(mmax_ + 1) * nl_, 0.0);
    b_.assign(a_.size(), 0.0);
    for (int m = 0; m <= mmax_; ++m) {
      for (int l = m + 2; l < nl_; ++l) {
        const double ll = static_cast<double>(l) * l, mm = static_cast<double>(m) * m;
        a_[m * nl_ + l] = std::sqrt((4.0 * ll - 1.0) / (ll - mm));
        b_[m * nl_ + l] =
            std::sqrt(((l - 1.0) * (l - 1.0) - mm) / (4.0 * (l - 1.0) * (l - 1.0) - 1.0));
      }
    }
  }
  size_t size() const { return static_cast<size_t>(mmax_ + 1) * nl_; }
  int mmax() const { return mmax_; }
  // kLanes nodes at once: out[(m * (lmax + 1) + l) * kLanes + lane], l >= m. The recurrence in l
  // is a chain of dependent multiplies; side by side, the lanes' chains run in one vector.
  static constexpr int kLanes = 8;
  void EvalLanes(const double* x, const double* s, double* out) const {
    alignas(64) double pmm[kLanes], p1[kLanes], p2[kLanes];
    for (int k = 0; k < kLanes; ++k) pmm[k] = std::sqrt(1.0 / (4.0 * kPi));
    for (int m = 0; m <= mmax_; ++m) {
      double* col = out + static_cast<size_t>(m) * nl_ * kLanes;
      if (m > 0) {
        const double f = -std::sqrt((2.0 * m + 1.0) / (2.0 * m));
        for (int k = 0; k < kLanes; ++k) pmm[k] *= f * s[k];
      }
      for (int k = 0; k < kLanes; ++k) col[m * kLanes + k] = pmm[k];
      if (m + 1 >= nl_) continue;
      const double c1 = std::sqrt(2.0 * m + 3.0);
      for (int k = 0; k < kLanes; ++k) {
        p2[k] = pmm[k];
        p1[k] = c1 * x[k] * pmm[k];
        col[(m + 1) * kLanes + k] = p1[k];
      }
      const double* a = &a_[m * nl_];
      const double* b = &b_[m * nl_];
      for (int l = m + 2; l < nl_; ++l) {
        double* dst = col + static_cast<size_t>(l) * kLanes;
        for (int k = 0; k < kLanes; ++k) {
          const double p = a[l] * (x[k] * p1[k] - b[l] * p2[k]);
          dst[k] = p;
          p2[k] = p1[k];
          p1[k] = p;
        }
      }
    }
  }
  // One node: EvalLanes with the node in every lane, lane 0 copied out (out[m * (lmax + 1) + l]).
  void Eval(double x, double s, double* out) {
    double xs[kLanes], ss[kLanes];
    std::fill_n(xs, kLanes, x);
    std::fill_n(ss, kLanes, s);
    lanes_.resize(size() * kLanes);
    EvalLanes(xs, ss, lanes_.data());
    for (int m = 0; m <= mmax_; ++m)
      for (int l = m; l < nl_; ++l)
        out[static_cast<size_t>(m) * nl_ + l] = lanes_[(m * nl_ + l) * kLanes];
  }

 private:
  int nl_, mmax_;
  std::vector<double> a_, b_;
  std::vector<double> lanes_;  // Eval's buffer
};

// The fewest Gauss-Legendre nodes of each piece of the split rule.
constexpr int kSplitMinNodes = 16;

bool UsesSplitRule(const Brdf& brdf, const BrdfSampling& s) {
  return brdf.analytic() && brdf.clipped_at_normal_horizon() &&
         brdf.reparam() == ReparamKind::kReflection && !brdf.azimuth_independent() &&
         !s.coefficients_uniform;
}

absl::Status CheckSampling(const BrdfSampling& s) {
  const int values[] = {s.theta_i,
                        s.theta_o,
                        s.phi,
                        s.radial_panels,
                        s.energy_panels_i,
                        s.energy_panels_o,
                        s.energy_panel_order,
                        s.energy_phi};
  for (int v : values) {
    if (v < 0 || v > 1 << 14) {
      return absl::InvalidArgumentError(
          absl::StrCat("BrdfSampling: sizes must be in [0, 16384] (0 = default), got ", v));
    }
  }
  return absl::OkStatus();
}

void RadialCoefficients(const Brdf& brdf, int lmax, const BrdfSampling& s, BrdfCoefficients* out) {
  const int channels = brdf.channels();
  const int sharp = brdf.bandwidth_hint().lmax;  // the lobe's own bandwidth
  int panels = Or(s.radial_panels, std::max({128, 2 * lmax, 2 * sharp}));
  panels += panels % 2;  // pi/2 (the horizon of a hemispherical lobe) on a panel edge
  const Rule1D rule = SinPanels(panels, kRadialPanelOrder);
  std::vector<double> rho((lmax + 1) * channels, 0.0);
  std::vector<double> values(channels);
  for (size_t j = 0; j < rule.x.size(); ++j) {
    brdf.ReparamTransferAll(rule.x[j], 0.0, 0.0, values.data());
    // lambda_l^0 = sqrt((2l + 1)/(4 pi)) P_l(x), P_l by Bonnet's recurrence (m = 0 only).
    const double x = std::cos(rule.x[j]);
    double p_prev = 1.0, p = x;
    for (int l = 0; l <= lmax; ++l) {
      double pl = 1.0;
      if (l == 1) {
        pl = x;
      } else if (l >= 2) {
        pl = ((2.0 * l - 1.0) * x * p - (l - 1.0) * p_prev) / l;
        p_prev = p;
        p = pl;
      }
      const double a = 2.0 * kPi * rule.w[j] * std::sqrt((2.0 * l + 1.0) / (4.0 * kPi)) * pl;
      for (int c = 0; c < channels; ++c) rho[l * channels + c] += a * values[c];
    }
  }
  for (int l = 0; l <= lmax; ++l) {
    for (int c = 0; c < channels; ++c) {
      out->values[out->Index(l, 0, 0, c)] = std::sqrt(4.0 * kPi) * rho[l * channels + c];
    }
  }
}

// ViewVariable::kNormal: rho-hat is known on the hemisphere of n' (theta_n' <= pi/2); below the
// equator the expansion takes the extension (docs/shrm.md "The view variable")
//   g(pi - theta, phi) = f(theta, phi) (1 - 2 sin^2 theta) + 2 e(phi) sin^2 theta,
// e(phi) = f(pi/2, phi) the values on the equator (V = -R). It is C^1 across the equator, where
// the even extension g = f has a kink wherever f's theta derivative is not zero there (Schlick's
// Fresnel, shadowing): coefficients decaying only algebraically in p. At the south pole it is f's
// north pole value, like the even one. With Y_pq(pi - theta, phi) = (-1)^(p+q) Y_pq(theta, phi),
// its coefficients are integrals over the upper hemisphere (W: the rule with the even
// extension's doubled weights):
//   p + q even: W[f cos^2 theta + e sin^2 theta],   p + q odd: W[sin^2 theta (f - e)].
// e is taken at theta_o' just below pi: the limit N.V -> 0 (N.V = 0 itself is 0/0 for models
// with 1/(N.V) factors).
constexpr double kEquatorThetaO = kPi * (1 - 1e-9);

// One theta_o' node's terms: out(l, p, q, c) += w lam[q * (P + 1) + p] x (acc, or for kNormal
// the extension above of acc and acc_eq, the equator's), acc[(c * (P + 1) + q) * (F + 1) + l];
// sin_n = sin theta_n' of the node (kNormal).
// Models with a Fresnel table divide f by it at the node's N.V (both variables) and, for kNormal,
// e by it at the equator (brdf_coefficients.h): inv_f[c] and inv_e[c], their inverses per channel.
// qmax: the largest q whose terms can be nonzero (pmax, or 0 for azimuth-independent models);
// lam and acc hold q = 0 .. qmax.
void AddViewNode(double w, const double* lam, const std::vector<double>& acc,
                 const std::vector<double>& acc_eq, double sin_n, const double* inv_f,
                 const double* inv_e, int qmax, BrdfCoefficients* out) {
  const int lmax = out->lmax, pmax = out->pmax;
  const int nl = lmax + 1, np = pmax + 1, nq = qmax + 1;
  const bool normal = out->view == ViewVariable::kNormal;
  const double s2 = sin_n * sin_n, c2 = 1 - s2;
  for (int q = 0; q <= qmax; ++q) {
    for (int p = q; p <= pmax; ++p) {
      const double b = w * lam[static_cast<size_t>(q) * np + p];
      // f's weight and e's: 1 and 0 (view), c2 and s2 (normal, p + q even), s2 and -s2 (odd).
      const bool even = (p + q) % 2 == 0;
      const double wf = !normal ? b : even ? b * c2 : b * s2;
      const double we = !normal ? 0.0 : even ? b * s2 : -b * s2;
      for (int c = 0; c < out->channels; ++c) {
        const size_t base = static_cast<size_t>(c * nq + q) * nl;
        const double* src = &acc[base];
        if (we == 0) {
          const double wfc = wf * inv_f[c];
          for (int l = q; l <= lmax; ++l) out->values[out->Index(l, p, q, c)] += wfc * src[l];
          continue;
        }
        const double* eq = &acc_eq[base];
        const double wfc = wf * inv_f[c], wec = we * inv_e[c];
        for (int l = q; l <= lmax; ++l)
          out->values[out->Index(l, p, q, c)] += wfc * src[l] + wec * eq[l];
      }
    }
  }
}

// 1 / w(cos theta_n') per channel of the coefficients' Fresnel table.
void InverseFresnel(const BrdfCoefficients& c, double cos_n, double* inv) {
  for (int ch = 0; ch < c.channels; ++ch)
    inv[ch] = 1.0 / FresnelAt(c.fresnel, c.channels, cos_n, ch);
}

}  // namespace

std::vector<double> FresnelTable(const Brdf& brdf) {
  constexpr int K = kFresnelIntervals;
  if (!brdf.has_fresnel() || brdf.reparam() != ReparamKind::kReflection) return {};
  const int channels = brdf.channels();
  std::vector<double> table(static_cast<size_t>(K + 1) * channels);
  for (int k = 0; k <= K; ++k)
    for (int c = 0; c < channels; ++c)
      table[static_cast<size_t>(k) * channels + c] =
          brdf.MirrorFresnel(1.0 - static_cast<double>(k) / K, c);
  for (int c = 0; c < channels; ++c) {
    double top = 0;
    for (int k = 0; k <= K; ++k) top = std::max(top, table[static_cast<size_t>(k) * channels + c]);
    for (int k = 0; k <= K; ++k) {
      double& v = table[static_cast<size_t>(k) * channels + c];
      v = top > 0 ? std::max(v, kFresnelFloor * top) : 1.0;
      v = static_cast<double>(static_cast<float>(v));
    }
  }
  return table;
}

namespace {

// Horizon-clipped models (the split rule, docs/brdf.md "Sampling"): for each theta_o' node the
// theta_i' integral is split where the visible azimuth arc starts to shrink (a = pi/2 - t_o/2)
// and where it closes (b = pi/2 + t_o/2; nothing is visible beyond). On [0, a] the integrand is
// smooth: Gauss-Legendre in cos theta_i'. On [a, b] it has square-root ends: the substitution
// theta = a + (b - a)(3u^2 - 2u^3), whose derivative vanishes at both ends, makes it smooth in u.
// Both rules then converge fast, where one Gauss-Legendre rule over the whole [-1, 1] converges
// only algebraically across the kinks. The same evaluations give the energy (the integral of
// rho-hat^2, eq. 5.18), so the coefficients and their denominator come from one pass.
// ViewVariable::kNormal: the theta_o' nodes are the same, each the normal n' at theta_o' / 2;
// its Legendre values are taken there, the measure sin(theta_o' / 2) replaces sin(theta_o')
// (the hemisphere's integral doubled, d theta_n' = d theta_o' / 2), and the extension of
// AddViewNode takes the equator's integrals too.
void SplitCoefficients(const Brdf& brdf, int lmax, int pmax, const BrdfSampling& s,
                       BrdfCoefficients* out) {
  const bool normal = out->view == ViewVariable::kNormal;
  const int channels = brdf.channels();
  const int qmax = pmax;
  const int sharp = brdf.bandwidth_hint().lmax;
  // Nodes: the fully visible piece (width <= pi/2) resolves degree lmax times the lobe; the
  // shrinking piece (width theta_o' <= pi, its nodes gathered at both ends by the substitution)
  // takes as many per radian at its widest, fewer as it narrows.
  const int n_full = Or(s.theta_i, std::max(kSplitMinNodes, (lmax + sharp) / 2 + 8));
  const int n_shrink_max = std::max(kSplitMinNodes, (lmax + sharp) / 2 + lmax / 2 + 12);
  const int n_o = Or(s.theta_o, std::max(4 * pmax + 16, 40));
  const int n_phi = Or(s.phi, std::max(2 * pmax + 8, 16));
  const RingQuadrature& ro = CachedGaussLegendre(n_o);
  const RingQuadrature& g_full = CachedGaussLegendre(n_full);
  const int nl = lmax + 1, nq = qmax + 1;
  const LegendreColumns legendre_i(lmax, qmax);
  LegendreColumns legendre_o(pmax, qmax);
  std::vector<double> lam_o(legendre_o.size());
  AzimuthRule azimuth(brdf, n_phi, qmax);
  std::vector<double> cq(nq * channels), sq(channels);
  std::vector<double> acc(static_cast<size_t>(channels) * nq * nl);  // [(c * nq + q) * nl + l]
  std::vector<double> energy(channels, 0.0), energy_k(channels);
  const double scale = 4.0 * kPi * kPi;
  // theta_i' nodes go in batches of kLanes: their azimuthal integrals times the weight
  // (lane_a[(c * nq + q) * kLanes + lane]), their Legendre values side by side, and the weighted
  // sums per lane (lane_acc[((c * nq + q) * nl + l) * kLanes + lane]), added over the lanes once
  // per theta_o' node.
  constexpr int kLanes = LegendreColumns::kLanes;
  const int qi = legendre_i.mmax();  // rho_lpq needs l >= q (lam_i: m <= lmax)
  std::vector<double> lam_lanes(legendre_i.size() * kLanes);
  std::vector<double> lane_a(static_cast<size_t>(channels) * nq * kLanes, 0.0);
  std::vector<double> lane_acc(acc.size() * kLanes, 0.0);
  alignas(64) double lane_x[kLanes], lane_s[kLanes];
  int lanes = 0;
  auto flush = [&] {
    if (lanes == 0) return;
    for (int k = lanes; k < kLanes; ++k) {  // idle lanes: a point on the sphere, weight 0
      lane_x[k] = 1.0;
      lane_s[k] = 0.0;
      for (int i = 0; i < channels * nq; ++i) lane_a[i * kLanes + k] = 0.0;
    }
    legendre_i.EvalLanes(lane_x, lane_s, lam_lanes.data());
    for (int q = 0; q <= qi; ++q) {
      const double* lam = &lam_lanes[static_cast<size_t>(q) * nl * kLanes];
      for (int c = 0; c < channels; ++c) {
        const double* av = &lane_a[(c * nq + q) * kLanes];
        double* dst = &lane_acc[static_cast<size_t>(c * nq + q) * nl * kLanes];
        for (int l = q; l <= lmax; ++l)
          for (int k = 0; k < kLanes; ++k) dst[l * kLanes + k] += av[k] * lam[l * kLanes + k];
      }
    }
    lanes = 0;
  };
  // One theta_i' node: its azimuthal integrals into the batch.
  auto node = [&](double theta_i, double cos_i, double sin_i, double theta_o, double w) {
    azimuth.CosinesAndSquares(theta_i, cos_i, sin_i, theta_o, cq.data(), sq.data());
    for (int c = 0; c < channels; ++c) energy_k[c] += w * sq[c];
    lane_x[lanes] = cos_i;
    lane_s[lanes] = sin_i;
    for (int q = 0; q <= qmax; ++q)
      for (int c = 0; c < channels; ++c)
        lane_a[(c * nq + q) * kLanes + lanes] = w * cq[q * channels + c];
    if (++lanes == kLanes) flush();
  };
  // acc (and energy_k) at one theta_o': the theta_i' integrals of the split rule.
  auto accumulate = [&](double theta_o) {
    std::fill(lane_acc.begin(), lane_acc.end(), 0.0);
    std::fill(energy_k.begin(), energy_k.end(), 0.0);
    const double a = 0.5 * kPi - 0.5 * theta_o, b = 0.5 * kPi + 0.5 * theta_o;
    // [0, a] in x = cos theta_i' over [cos a, 1] (dx = sin theta dtheta).
    const double xa = std::cos(a);
    for (int j = 0; j < n_full; ++j) {
      const double x = xa + (1.0 - xa) * 0.5 * (1.0 + g_full.cos_theta[j]);
      const double w = (1.0 - xa) * 0.5 * g_full.weight[j];
      const double sin_i = std::sqrt(std::max(0.0, 1.0 - x * x));
      node(std::acos(x), x, sin_i, theta_o, w);
    }
    // [a, b], smoothed.
    if (b - a > 0) {
      const int n =
          std::max(kSplitMinNodes, static_cast<int>(std::ceil(n_shrink_max * (b - a) / kPi)));
      const RingQuadrature& g = CachedGaussLegendre(n);
      for (int j = 0; j < n; ++j) {
        const double u = 0.5 * (1.0 + g.cos_theta[j]);
        const double t = a + (b - a) * u * u * (3.0 - 2.0 * u);
        const double dt = (b - a) * 6.0 * u * (1.0 - u);
        const double sin_i = std::sin(t);
        node(t, std::cos(t), sin_i, theta_o, 0.5 * g.weight[j] * dt * sin_i);
      }
    }
    flush();
    for (size_t i = 0; i < acc.size(); ++i) {
      double sum = 0;
      for (int lane = 0; lane < kLanes; ++lane) sum += lane_acc[i * kLanes + lane];
      acc[i] = sum;
    }
  };
  std::vector<double> acc_eq;  // kNormal: e of AddViewNode, at the equator of n'
  std::vector<double> inv_f(channels, 1.0), inv_e(channels, 1.0);
  out->fresnel = FresnelTable(brdf);
  if (normal) {
    InverseFresnel(*out, std::cos(0.5 * kEquatorThetaO), inv_e.data());
    accumulate(kEquatorThetaO);
    acc_eq = acc;
  }
  for (int k = 0; k < n_o; ++k) {
    // theta_o' = pi (3u^2 - 2u^3): at the grazing end (theta_o' -> pi, N.V = cos(theta_o'/2) -> 0)
    // models with 1/(N.V) factors (GGX, Ward) have square-root and 1/x behaviour that this
    // substitution turns smooth; the weight carries sin theta_o'.
    const double u_o = 0.5 * (1.0 + ro.cos_theta[k]);
    const double theta_o = kPi * u_o * u_o * (3.0 - 2.0 * u_o);
    const double cos_o = std::cos(theta_o), sin_o = std::sin(theta_o);
    const double half_c = std::cos(0.5 * theta_o), half_s = std::sin(0.5 * theta_o);
    const double w_o =
        0.5 * ro.weight[k] * kPi * 6.0 * u_o * (1.0 - u_o) * (normal ? half_s : sin_o);
    accumulate(theta_o);
    // N.V = cos(theta_o' / 2) in both variables: the Fresnel table's argument.
    InverseFresnel(*out, half_c, inv_f.data());
    // The energy of what is expanded: rho-hat / w (kView; kNormal's is replaced below).
    for (int c = 0; c < channels; ++c) energy[c] += w_o * energy_k[c] * inv_f[c] * inv_f[c];
    if (normal) {
      legendre_o.Eval(half_c, half_s, lam_o.data());
    } else {
      legendre_o.Eval(cos_o, sin_o, lam_o.data());
    }
    AddViewNode(scale * w_o, lam_o.data(), acc, acc_eq, half_s, inv_f.data(), inv_e.data(), qmax,
                out);
  }
  // 2 pi (phi_o') * 2 (phi over [0, pi] only, rho-hat even) = 4 pi (eq. 5.18).
  out->total_energy.assign(channels, 0.0);
  for (int c = 0; c < channels; ++c) out->total_energy[c] = 4.0 * kPi * energy[c];
}

// ViewVariable::kNormal: the theta_o' rule is Gauss-Legendre in cos theta_n' over [0, 1] (the
// hemisphere; its weights doubled are those of [-1, 1]), theta_o' = 2 theta_n', and the
// extension of AddViewNode takes the equator's integrals too.
void SeparableCoefficients(const Brdf& brdf, int lmax, int pmax, const BrdfSampling& s,
                           BrdfCoefficients* out) {
  const bool normal = out->view == ViewVariable::kNormal;
  const int channels = brdf.channels();
  // Azimuth-independent models (Kajiya-Kay) have rho_lpq = 0 for q != 0: q = 0 only.
  const int qmax = brdf.azimuth_independent() ? 0 : pmax;
  const int sharp = brdf.bandwidth_hint().lmax;  // the lobe's own bandwidth
  const int n_i = Or(s.theta_i, std::max({4 * lmax, 64, 3 * sharp}));
  const int n_o = Or(s.theta_o, std::max(4 * pmax + 16, 48));
  const int n_phi = Or(s.phi, std::max(2 * pmax + 24, 32));
  const RingQuadrature& ri = CachedGaussLegendre(n_i);
  RingQuadrature ro = CachedGaussLegendre(n_o);
  if (normal) {
    for (int k = 0; k < n_o; ++k) {
      const double x = 0.5 * (1.0 + ro.cos_theta[k]);  // cos theta_n'
      ro.cos_theta[k] = x;
      ro.sin_theta[k] = std::sqrt(std::max(0.0, 1.0 - x * x));
      ro.theta[k] = 2.0 * std::acos(x);  // theta_o', for the BRDF
    }
  }
  const int nl = lmax + 1, np = pmax + 1, nq = qmax + 1;

  // lambda_l^q(cos theta) for q <= qmax only: lam_i[(j * nq + q) * nl + l] (LegendreColumns,
  // kLanes nodes at a time; entries l < q stay 0).
  auto legendre_table = [&](int degree, int nodes, const RingQuadrature& rule) {
    const LegendreColumns columns(degree, qmax);
    const int n = degree + 1;
    constexpr int kLanes = LegendreColumns::kLanes;
    std::vector<double> table(static_cast<size_t>(nodes) * nq * n, 0.0);
    std::vector<double> lanes(columns.size() * kLanes);
    alignas(64) double x[kLanes], sn[kLanes];
    for (int j0 = 0; j0 < nodes; j0 += kLanes) {
      const int count = std::min(kLanes, nodes - j0);
      for (int k = 0; k < kLanes; ++k) {
        x[k] = k < count ? rule.cos_theta[j0 + k] : 1.0;
        sn[k] = k < count ? rule.sin_theta[j0 + k] : 0.0;
      }
      columns.EvalLanes(x, sn, lanes.data());
      for (int k = 0; k < count; ++k)
        for (int q = 0; q <= std::min(qmax, degree); ++q)
          for (int l = q; l <= degree; ++l)
            table[((j0 + k) * nq + q) * n + l] = lanes[(q * n + l) * kLanes + k];
    }
    return table;
  };
  const std::vector<double> lam_i = legendre_table(lmax, n_i, ri);
  const std::vector<double> lam_o = legendre_table(pmax, n_o, ro);

  AzimuthRule azimuth(brdf, n_phi, qmax);
  std::vector<double> cq(nq * channels);
  std::vector<double> acc(static_cast<size_t>(channels) * nq * nl);  // [(c * nq + q) * nl + l]
  const double scale = 4.0 * kPi * kPi;
  // Azimuth-independent models in the view variable: cq[c] is rho-hat itself, so the energy
  // (BrdfEnergy's double integral of rho-hat^2 over theta_i', theta_o', with the even azimuth
  // integral over [0, pi] a factor pi) comes from the same evaluations on the same rule
  // (energy_k: the theta_i' integral at one theta_o').
  const bool flat_energy = brdf.azimuth_independent() && !normal;
  std::vector<double> energy(channels, 0.0), energy_k(channels, 0.0);
  // acc at one theta_o': the theta_i' integrals.
  auto accumulate = [&](double theta_o) {
    std::fill(acc.begin(), acc.end(), 0.0);
    std::fill(energy_k.begin(), energy_k.end(), 0.0);
    for (int j = 0; j < n_i; ++j) {
      azimuth.Cosines(ri.theta[j], ri.cos_theta[j], ri.sin_theta[j], theta_o, cq.data());
      if (flat_energy)
        for (int c = 0; c < channels; ++c) energy_k[c] += ri.weight[j] * kPi * cq[c] * cq[c];
      for (int q = 0; q <= qmax; ++q) {
        const double* lam = &lam_i[(j * nq + q) * nl];
        for (int c = 0; c < channels; ++c) {
          const double a = ri.weight[j] * cq[q * channels + c];
          if (a == 0) continue;
          double* dst = &acc[(c * nq + q) * nl];
          for (int l = q; l <= lmax; ++l) dst[l] += a * lam[l];
        }
      }
    }
  };
  std::vector<double> acc_eq;  // kNormal: e of AddViewNode, at the equator of n'
  std::vector<double> inv_f(channels, 1.0), inv_e(channels, 1.0);
  out->fresnel = FresnelTable(brdf);
  if (normal) {
    InverseFresnel(*out, std::cos(0.5 * kEquatorThetaO), inv_e.data());
    accumulate(kEquatorThetaO);
    acc_eq = acc;
  }
  for (int k = 0; k < n_o; ++k) {
    accumulate(ro.theta[k]);
    // N.V: cos theta_n' (kNormal), cos(theta_o' / 2) (kView).
    InverseFresnel(*out, normal ? ro.cos_theta[k] : std::cos(0.5 * ro.theta[k]), inv_f.data());
    if (flat_energy)
      for (int c = 0; c < channels; ++c)
        energy[c] += ro.weight[k] * energy_k[c] * inv_f[c] * inv_f[c];
    // kNormal: the rule's weights are those of [-1, 1] on [0, 1], W of AddViewNode.
    AddViewNode(scale * ro.weight[k], &lam_o[static_cast<size_t>(k) * nq * np], acc, acc_eq,
                ro.sin_theta[k], inv_f.data(), inv_e.data(), qmax, out);
  }
  // 2 pi (phi_o') * 2 (phi over [0, pi] only, rho-hat even) = 4 pi (eq. 5.18), as BrdfEnergy.
  if (flat_energy) {
    out->total_energy.assign(channels, 0.0);
    for (int c = 0; c < channels; ++c) out->total_energy[c] = 4.0 * kPi * energy[c];
  }
}

}  // namespace

std::vector<double> BrdfEnergy(const Brdf& brdf, int lmax_hint, const BrdfSampling& s,
                               ViewVariable view) {
  const bool half = EffectiveViewVariable(brdf, view) == ViewVariable::kNormal;
  const int channels = brdf.channels();
  std::vector<double> energy(channels, 0.0);
  std::vector<double> values(channels);
  const int order = Or(s.energy_panel_order, kDefaultEnergyPanelOrder);
  if (brdf.radially_symmetric()) {
    int panels =
        Or(s.energy_panels_i, std::max({256, 4 * lmax_hint, 4 * brdf.bandwidth_hint().lmax}));
    panels += panels % 2;
    const Rule1D rule = SinPanels(panels, order);
    for (size_t j = 0; j < rule.x.size(); ++j) {
      brdf.ReparamTransferAll(rule.x[j], 0.0, 0.0, values.data());
      for (int c = 0; c < channels; ++c) energy[c] += rule.w[j] * values[c] * values[c];
    }
    // integral over w_o' (4 pi) times 2 pi integral rho-hat^2 sin t dt (eq. 5.17).
    for (double& e : energy) e *= 8.0 * kPi * kPi;
    return energy;
  }
  std::vector<double> sq(channels);
  // Models with a Fresnel table: the energy of rho-hat / w(N.V), what the coefficients expand.
  const std::vector<double> fresnel = FresnelTable(brdf);
  std::vector<double> inv2(channels, 1.0);
  auto set_fresnel = [&](double theta_o) {
    if (fresnel.empty()) return;
    for (int c = 0; c < channels; ++c) {
      const double w = FresnelAt(fresnel, channels, std::cos(0.5 * theta_o), c);
      inv2[c] = 1.0 / (w * w);
    }
  };
  const bool clipped =
      brdf.clipped_at_normal_horizon() && brdf.reparam() == ReparamKind::kReflection;
  if (clipped && !s.energy_uniform_panels) {
    // Horizon-clipped models: the azimuth integral of rho-hat^2 is smooth in theta_i' except
    // where the visible arc starts to shrink (theta_i' = pi/2 - theta_o'/2) and where it closes
    // (pi/2 + theta_o'/2; nothing is visible beyond), with square-root behaviour at both. Panels
    // split there, and on [a, b] the substitution theta = a + (b - a)(3u^2 - 2u^3), whose
    // derivative vanishes at both ends, make the integrand smooth in u: Gauss-Legendre converges
    // fast again (docs/brdf.md "Sampling"; tests/brdf_coefficients_test.cc compares this rule
    // with the uniform panels refined far beyond their default).
    const int panels_i =
        Or(s.energy_panels_i, std::max({24, lmax_hint, brdf.bandwidth_hint().lmax}));
    const RingQuadrature gl = GaussLegendreRule(order);
    const int sharp = brdf.bandwidth_hint().lmax;  // the lobe's own bandwidth
    const Rule1D ro = SinPanels(Or(s.energy_panels_o, std::max(6, sharp / 12)), order, half);
    AzimuthRule azimuth(brdf, Or(s.energy_phi, std::max(16, sharp / 3)), 0);
    for (size_t k = 0; k < ro.x.size(); ++k) {
      set_fresnel(ro.x[k]);
      const double a = 0.5 * kPi - 0.5 * ro.x[k], b = 0.5 * kPi + 0.5 * ro.x[k];
      // [0, a]: the whole arc is visible.
      const int na = std::max(1, static_cast<int>(std::ceil(panels_i * a / kPi)));
      for (int p = 0; p < na; ++p) {
        const Rule1D panel = GaussOn(gl, a * p / na, a * (p + 1) / na);
        for (size_t j = 0; j < panel.x.size(); ++j) {
          const double t = panel.x[j], st = std::sin(t);
          azimuth.Squares(t, std::cos(t), st, ro.x[k], sq.data());
          const double w = ro.w[k] * panel.w[j] * st;
          for (int c = 0; c < channels; ++c) energy[c] += w * sq[c] * inv2[c];
        }
      }
      // [a, b]: the arc shrinks from pi to 0.
      const int nb = std::max(2, static_cast<int>(std::ceil(2.0 * panels_i * (b - a) / kPi)));
      for (int p = 0; p < nb; ++p) {
        const Rule1D panel = GaussOn(gl, static_cast<double>(p) / nb, (p + 1.0) / nb);
        for (size_t j = 0; j < panel.x.size(); ++j) {
          const double u = panel.x[j];
          const double t = a + (b - a) * u * u * (3.0 - 2.0 * u);
          const double dt = (b - a) * 6.0 * u * (1.0 - u);
          const double st = std::sin(t);
          azimuth.Squares(t, std::cos(t), st, ro.x[k], sq.data());
          const double w = ro.w[k] * panel.w[j] * dt * st;
          for (int c = 0; c < channels; ++c) energy[c] += w * sq[c] * inv2[c];
        }
      }
    }
  } else {
    int panels_i = Or(s.energy_panels_i, std::max({48, lmax_hint, brdf.bandwidth_hint().lmax}));
    panels_i += panels_i % 2;
    const Rule1D ri = SinPanels(panels_i, order);
    const Rule1D ro = SinPanels(Or(s.energy_panels_o, 12), order, half);
    AzimuthRule azimuth(brdf, Or(s.energy_phi, 32), 0);
    for (size_t k = 0; k < ro.x.size(); ++k) {
      set_fresnel(ro.x[k]);
      for (size_t j = 0; j < ri.x.size(); ++j) {
        azimuth.Squares(ri.x[j], std::cos(ri.x[j]), std::sin(ri.x[j]), ro.x[k], sq.data());
        const double w = ro.w[k] * ri.w[j];
        for (int c = 0; c < channels; ++c) energy[c] += w * sq[c] * inv2[c];
      }
    }
  }
  // 2 pi (phi_o') * 2 (phi over [0, pi] only, rho-hat even) = 4 pi (eq. 5.18).
  for (double& e : energy) e *= 4.0 * kPi;
  return energy;
}

ViewVariable EffectiveViewVariable(const Brdf& brdf, ViewVariable requested) {
  if (brdf.radially_symmetric() || brdf.reparam() != ReparamKind::kReflection)
    return ViewVariable::kView;
  return requested;
}

absl::StatusOr<BrdfCoefficients> ComputeBrdfCoefficients(const Brdf& brdf, int lmax, int pmax,
                                                         const BrdfSampling& sampling,
                                                         ViewVariable view) {
  if (lmax < 0 || lmax > kMaxBrdfLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf coefficients: lmax = ", lmax, " out of range [0, ", kMaxBrdfLmax, "]"));
  }
  if (pmax < 0 || pmax > kMaxBrdfPmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf coefficients: pmax = ", pmax, " out of range [0, ", kMaxBrdfPmax, "]"));
  }
  if (absl::Status st = CheckSampling(sampling); !st.ok()) return st;
  if (const auto* ward = dynamic_cast<const WardBrdf*>(&brdf); ward && !ward->isotropic()) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf '", brdf.spec(),
                     "' is anisotropic; SHRM coefficients (sec. 5.3.1) need an "
                     "isotropic BRDF (use alpha, or equal alpha_x and alpha_y)"));
  }
  BrdfCoefficients out;
  out.lmax = lmax;
  out.pmax = pmax;
  out.channels = brdf.channels();
  out.reparam = brdf.reparam();
  out.view = EffectiveViewVariable(brdf, view);
  out.values.assign(static_cast<size_t>(lmax + 1) * (pmax + 1) * (pmax + 1) * out.channels, 0.0);
  if (!brdf.radially_symmetric() && UsesSplitRule(brdf, sampling)) {
    SplitCoefficients(brdf, lmax, pmax, sampling, &out);  // the energy from the same evaluations
  } else {
    if (brdf.radially_symmetric()) {
      RadialCoefficients(brdf, lmax, sampling, &out);
    } else {
      SeparableCoefficients(brdf, lmax, pmax, sampling, &out);  // azimuth-independent: energy
    }
    if (out.total_energy.empty()) out.total_energy = BrdfEnergy(brdf, lmax, sampling, out.view);
  }
  if (out.view == ViewVariable::kNormal) {
    // The extension's energy over the whole sphere has a cross term of f and its equator values
    // that the angular rules do not give: the energy of the coefficients computed stands for it.
    out.total_energy.assign(out.channels, 0.0);
    for (int l = 0; l <= lmax; ++l)
      for (int p = 0; p <= pmax; ++p)
        for (int q = 0; q <= std::min(l, p); ++q)
          for (int c = 0; c < out.channels; ++c) {
            const double v = out.values[out.Index(l, p, q, c)];
            out.total_energy[c] += (q == 0 ? 1.0 : 2.0) * v * v;
          }
  }
  return out;
}

absl::StatusOr<BrdfOrders> SelectBrdfOrders(const Brdf& brdf, double epsilon,
                                            const BrdfOrderOptions& options) {
  if (!(epsilon > 0 && epsilon < 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("SelectBrdfOrders: epsilon = ", epsilon, " must be in (0, 1)"));
  }
  const int max_f = std::min(options.max_fmax, kMaxBrdfLmax);
  const int max_p = brdf.radially_symmetric() ? 0 : std::min(options.max_pmax, kMaxBrdfPmax);
  if (max_f < 1 || max_p < 0) {
    return absl::InvalidArgumentError("SelectBrdfOrders: max_fmax must be >= 1, max_pmax >= 0");
  }
  const BrdfBandwidthHint hint = brdf.bandwidth_hint();
  int fmax = std::clamp(options.initial_fmax > 0 ? options.initial_fmax : hint.lmax, 1, max_f);
  int pmax = std::clamp(options.initial_pmax >= 0 ? options.initial_pmax : hint.pmax, 0, max_p);
  const double target = 1.0 - epsilon;
  BrdfOrders result;
  result.epsilon = epsilon;
  while (true) {
    absl::StatusOr<BrdfCoefficients> coeffs =
        ComputeBrdfCoefficients(brdf, fmax, pmax, options.sampling);
    if (!coeffs.ok()) return coeffs.status();
    const double captured = CapturedFraction(*coeffs, fmax, pmax);
    if (captured >= target) {
      result.coefficients = *std::move(coeffs);
      break;
    }
    if (fmax >= max_f && pmax >= max_p) {
      return absl::OutOfRangeError(absl::StrCat(
          "SelectBrdfOrders: ", brdf.spec(), " captures only ", captured,
          " < 1 - epsilon = ", target, " at F = ", fmax, ", P = ", pmax, " (the limits)"));
    }
    fmax = std::min(2 * fmax, max_f);
    pmax = std::min(pmax + std::max(4, pmax / 2), max_p);
  }
  result.fmax = fmax;
  result.pmax = pmax;
  const BrdfCoefficients& c = result.coefficients;
  int P = 0;
  while (P < pmax && CapturedFraction(c, fmax, P) < target) ++P;
  int F = 0;
  while (F < fmax && CapturedFraction(c, F, P) < target) ++F;
  result.F = F;
  result.P = P;
  result.captured = CapturedFraction(c, F, P);
  return result;
}

}  // namespace shrm
