#include "core/brdf/brdf_models.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/brdf/vector_math.h"

namespace shrm {
namespace {

// The arc evaluations below take the azimuths in chunks of this many (stack buffers).
constexpr int kArcChunk = 64;

// ReparamTransfer's geometry along an arc (kReflection): N, V and the light's polar part fixed,
// w_k = (sin t_i cos phi_k, sin t_i sin phi_k, cos t_i). Calls chunk(first, count) for the
// azimuths in chunks of at most kArcChunk.
struct ArcFrame {
  Vec3 n, v;
  double si = 0, ci = 0;
  ArcFrame(double theta_i, double theta_o) {
    const ReparamGeometry g = MakeReparamGeometry(ReparamKind::kReflection, theta_i, theta_o, 0.0);
    n = g.n;
    v = g.v;
    si = std::sin(theta_i);
    ci = g.w.z;
  }
  Vec3 W(const Brdf::ArcAzimuths& phi, size_t k) const {
    return {si * phi.cos_phi[k], si * phi.sin_phi[k], ci};
  }
};

template <typename Chunk>
void ForArcChunks(const Brdf::ArcAzimuths& phi, Chunk&& chunk) {
  const int total = static_cast<int>(phi.phi.size());
  for (int first = 0; first < total; first += kArcChunk) {
    chunk(first, std::min(kArcChunk, total - first));
  }
}

// GGX's Smith Lambda for a direction at cos theta = c: (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2.
double SmithLambda(double a2, double c) {
  return 0.5 * (std::sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0);
}

// Angle between two unit vectors, accurate near 0: 2 asin(|a - b| / 2).
double AngleBetween(const Vec3& a, const Vec3& b) {
  return 2.0 * std::asin(std::min(1.0, (a - b).Norm() * 0.5));
}

int CeilInt(double x) { return static_cast<int>(std::ceil(x)); }

}  // namespace

// ----- Lambert -----

std::string LambertBrdf::spec() const {
  return absl::StrCat("lambert:albedo=", FormatSpecNumber(albedo_));
}

double LambertBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const {
  const double nw = n.Dot(w);
  if (nw <= 0 || n.Dot(v) <= 0) return 0.0;
  return albedo_ / kPi * nw;
}

void LambertBrdf::TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int,
                               double* out) const {
  if (!(n.Dot(v) > 0)) {
    std::fill(out, out + w.size(), 0.0);
    return;
  }
  // The frame in locals (`out` could alias n's members) and the directions by reference: the loop
  // runs in vectors.
  const double nx = n.x, ny = n.y, nz = n.z, scale = albedo_ / kPi;
  const Vec3* p = w.data();
  for (size_t k = 0; k < w.size(); ++k) {
    const Vec3& d = p[k];
    const double nw = nx * d.x + ny * d.y + nz * d.z;
    out[k] = nw > 0 ? scale * nw : 0.0;
  }
}

namespace {

// out[k] = scale x base(k)^exponent where base(k) > 0, else 0, for k < count: the lobes that are
// a power of a cosine (Phong, Kajiya-Kay), the power in vectors a chunk at a time.
template <class Base>
void PowerLobeMany(size_t count, double exponent, double scale, Base&& base, double* out) {
  for (size_t first = 0; first < count; first += kArcChunk) {
    const int n = static_cast<int>(std::min<size_t>(kArcChunk, count - first));
    double c[kArcChunk], keep[kArcChunk];
    for (int k = 0; k < n; ++k) {
      const double b = base(first + k);
      keep[k] = b > 0 ? scale : 0.0;
      c[k] = b > 0 ? b : 0.0;
    }
    internal::VectorPow(c, exponent, c, n);
    for (int k = 0; k < n; ++k) out[first + k] = keep[k] * c[k];
  }
}

}  // namespace

// ----- Phong (eq. 5.26) -----

std::string PhongBrdf::spec() const { return absl::StrCat("phong:s=", FormatSpecNumber(s_)); }

BrdfBandwidthHint PhongBrdf::bandwidth_hint() const {
  // Eq. 5.28 at epsilon = 1e-4 plus a margin.
  return {CeilInt(std::sqrt(9.3 * s_)) + 8, 0};
}

double PhongBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const {
  const Vec3 r = n * (2.0 * n.Dot(v)) - v;
  const double rw = r.Dot(w);
  if (rw <= 0) return 0.0;
  return (s_ + 1.0) / (2.0 * kPi) * std::pow(rw, s_);
}

void PhongBrdf::TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int,
                             double* out) const {
  const Vec3 r = n * (2.0 * n.Dot(v)) - v;
  PowerLobeMany(
      w.size(), s_, (s_ + 1.0) / (2.0 * kPi), [&r, p = w.data()](size_t k) { return r.Dot(p[k]); },
      out);
}

double PhongBrdf::ReparamTransfer(double theta_i, double, double, int) const {
  const double c = std::cos(theta_i);
  if (c <= 0) return 0.0;
  return (s_ + 1.0) / (2.0 * kPi) * std::pow(c, s_);
}

std::vector<double> PhongRhoExact(double s, int lmax) {
  std::vector<double> integral(lmax + 1);  // I_l = integral_0^1 x^s P_l(x) dx
  for (int l = 0; l <= lmax; ++l) {
    if (l == 0) {
      integral[l] = 1.0 / (s + 1.0);
    } else if (l == 1) {
      integral[l] = 1.0 / (s + 2.0);
    } else {
      integral[l] = (s - l + 2.0) / (s + l + 1.0) * integral[l - 2];
    }
  }
  std::vector<double> rho(lmax + 1);
  for (int l = 0; l <= lmax; ++l) {
    rho[l] = (s + 1.0) * std::sqrt((2.0 * l + 1.0) / (4.0 * kPi)) * integral[l];
  }
  return rho;
}

std::vector<double> PhongRhoEq527(double s, int lmax) {
  std::vector<double> rho(lmax + 1);
  for (int l = 0; l <= lmax; ++l) {
    rho[l] = std::sqrt((2.0 * l + 1.0) / (4.0 * kPi)) * std::exp(-l * l / (2.0 * s));
  }
  return rho;
}

double PhongOrderEq528(double s, double epsilon) { return std::sqrt(-s * std::log(epsilon)); }

int PhongOrderExact(double s, double epsilon) {
  const double total = (s + 1.0) * (s + 1.0) / (2.0 * kPi * (2.0 * s + 1.0));
  int lmax = 16;
  while (true) {
    const std::vector<double> rho = PhongRhoExact(s, lmax);
    double sum = 0;
    for (int l = 0; l <= lmax; ++l) {
      sum += rho[l] * rho[l];
      if (sum >= (1.0 - epsilon) * total) return l;
    }
    lmax *= 2;
  }
}

// ----- Simplified microfacet (eq. 5.34) -----

std::string MicrofacetBrdf::spec() const {
  return absl::StrCat("microfacet:sigma=", FormatSpecNumber(sigma_));
}

BrdfBandwidthHint MicrofacetBrdf::bandwidth_hint() const { return {CeilInt(3.5 / sigma_) + 8, 6}; }

double MicrofacetBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const {
  if (n.Dot(w) <= 0 || n.Dot(v) <= 0) return 0.0;
  const Vec3 h_sum = v + w;
  const double len = h_sum.Norm();
  if (len <= 0) return 0.0;
  const double theta_h = AngleBetween(n, h_sum * (1.0 / len)) / sigma_;
  return std::exp(-theta_h * theta_h) / (4.0 * kPi * sigma_ * sigma_);
}

// Transfer at w[0 .. count), count <= kArcChunk: Transfer's arithmetic lane by lane, the asin
// and exp of the chunk in vectors (TransferMany and ReparamTransferArc).
void MicrofacetBrdf::TransferChunk(const Vec3& n, const Vec3& v, const Vec3* w, int count,
                                   double* out) const {
  if (count <= 0) return;
  const double nv = n.Dot(v);
  const double norm = nv > 0 ? 1.0 / (4.0 * kPi * sigma_ * sigma_) : 0.0;
  // Vec3's arithmetic written out on local copies (the directions by reference: a struct copy,
  // or `out` aliasing n and v, would keep the loop scalar), so it runs in vector lanes.
  const double nx = n.x, ny = n.y, nz = n.z, vx = v.x, vy = v.y, vz = v.z;
  double t[kArcChunk], keep[kArcChunk];
  for (int k = 0; k < count; ++k) {
    const Vec3& wk = w[k];
    const double sx = vx + wk.x, sy = vy + wk.y, sz = vz + wk.z;
    const double len = std::sqrt(sx * sx + sy * sy + sz * sz);
    const double inv = len > 0 ? 1.0 / len : 0.0;
    const double dx = nx - sx * inv, dy = ny - sy * inv, dz = nz - sz * inv;
    t[k] = std::min(
        1.0, std::sqrt(dx * dx + dy * dy + dz * dz) * 0.5);  // AngleBetween: 2 asin(|n - h| / 2)
    const double nw = nx * wk.x + ny * wk.y + nz * wk.z;
    keep[k] = nw > 0 && len > 0 ? norm : 0.0;
  }
  internal::VectorAsin(t, t, count);
  for (int k = 0; k < count; ++k) {
    const double theta_h = 2.0 * t[k] / sigma_;
    t[k] = -theta_h * theta_h;
  }
  internal::VectorExp(t, t, count);
  for (int k = 0; k < count; ++k) out[k] = keep[k] * t[k];
}

void MicrofacetBrdf::TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int,
                                  double* out) const {
  for (size_t first = 0; first < w.size(); first += kArcChunk) {
    const int count = static_cast<int>(std::min<size_t>(kArcChunk, w.size() - first));
    TransferChunk(n, v, w.data() + first, count, out + first);
  }
}

void MicrofacetBrdf::ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                                        double* out) const {
  const ArcFrame f(theta_i, theta_o);
  ForArcChunks(phi, [&](int first, int count) {
    Vec3 w[kArcChunk];
    for (int k = 0; k < count; ++k) w[k] = f.W(phi, first + k);
    TransferChunk(f.n, f.v, w, count, out + first);
  });
}

double MicrofacetBrdf::ReparamTransfer(double theta_i, double theta_o, double phi, int) const {
  // N = (sin(t_o/2), 0, cos(t_o/2)), V = (sin t_o, 0, cos t_o), w from (t_i, phi).
  const double ci = std::cos(theta_i), si = std::sin(theta_i);
  const double ch = std::cos(0.5 * theta_o), sh = std::sin(0.5 * theta_o);
  const double cp = std::cos(phi), sp = std::sin(phi);
  const Vec3 n{sh, 0.0, ch};
  const Vec3 w{si * cp, si * sp, ci};
  if (n.Dot(w) <= 0) return 0.0;
  const Vec3 v{2.0 * sh * ch, 0.0, ch * ch - sh * sh};
  const Vec3 h_sum = v + w;
  const double len = h_sum.Norm();
  if (len <= 0) return 0.0;
  const double theta_h = AngleBetween(n, h_sum * (1.0 / len)) / sigma_;
  return std::exp(-theta_h * theta_h) / (4.0 * kPi * sigma_ * sigma_);
}

// ----- Lafortune -----

std::string LafortuneBrdf::spec() const {
  std::string out = "lafortune:";
  bool first = true;
  if (rho_d_ != 0 || lobes_.empty()) {
    absl::StrAppend(&out, "rho_d=", FormatSpecNumber(rho_d_));
    first = false;
  }
  for (const LafortuneLobe& lobe : lobes_) {
    if (!first) out += ";";
    first = false;
    absl::StrAppend(&out, "cx=", FormatSpecNumber(lobe.cxy), ",cy=", FormatSpecNumber(lobe.cxy),
                    ",cz=", FormatSpecNumber(lobe.cz), ",n=", FormatSpecNumber(lobe.n),
                    ",rho=", FormatSpecNumber(lobe.rho));
  }
  return out;
}

BrdfBandwidthHint LafortuneBrdf::bandwidth_hint() const {
  double nmax = 1;
  for (const LafortuneLobe& lobe : lobes_) nmax = std::max(nmax, lobe.n);
  return {CeilInt(std::sqrt(9.3 * nmax)) + 8, 8};
}

double LafortuneBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const {
  const double nw = n.Dot(w), nv = n.Dot(v);
  if (nw <= 0 || nv <= 0) return 0.0;
  double f = rho_d_ / kPi;
  const double tangential = w.Dot(v) - nw * nv;  // u_x v_x + u_y v_y
  for (const LafortuneLobe& lobe : lobes_) {
    const double d = lobe.cxy * tangential + lobe.cz * nw * nv;
    if (d > 0) f += lobe.rho * std::pow(d, lobe.n);
  }
  return f * nw;
}

void LafortuneBrdf::ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                                       double* out) const {
  const ArcFrame f(theta_i, theta_o);
  const double nv = f.n.Dot(f.v);
  ForArcChunks(phi, [&](int first, int count) {
    double nw[kArcChunk], tangential[kArcChunk], sum[kArcChunk], d[kArcChunk];
    for (int k = 0; k < count; ++k) {
      const Vec3 w = f.W(phi, first + k);
      nw[k] = f.n.Dot(w);
      tangential[k] = w.Dot(f.v) - nw[k] * nv;
      sum[k] = rho_d_ / kPi;
    }
    for (const LafortuneLobe& lobe : lobes_) {
      for (int k = 0; k < count; ++k)
        d[k] = std::max(0.0, lobe.cxy * tangential[k] + lobe.cz * nw[k] * nv);
      internal::VectorPow(d, lobe.n, d, count);
      for (int k = 0; k < count; ++k) sum[k] += lobe.rho * d[k];  // d <= 0 gave 0^n = 0
    }
    for (int k = 0; k < count; ++k) out[first + k] = nw[k] > 0 && nv > 0 ? sum[k] * nw[k] : 0.0;
  });
}

// ----- Ward -----

std::string WardBrdf::spec() const {
  const std::string alpha = isotropic() ? absl::StrCat("alpha=", FormatSpecNumber(alpha_x_))
                                        : absl::StrCat("alpha_x=", FormatSpecNumber(alpha_x_),
                                                       ",alpha_y=", FormatSpecNumber(alpha_y_));
  return absl::StrCat("ward:", alpha, ",rho_s=", FormatSpecNumber(rho_s_),
                      ",rho_d=", FormatSpecNumber(rho_d_));
}

BrdfBandwidthHint WardBrdf::bandwidth_hint() const {
  return {CeilInt(3.5 / std::min(alpha_x_, alpha_y_)) + 8, 6};
}

double WardBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const {
  const double nw = n.Dot(w), nv = n.Dot(v);
  if (nw <= 0 || nv <= 0) return 0.0;
  const Vec3 h_sum = v + w;
  const double nh = n.Dot(h_sum);
  const double nh2 = nh * nh / h_sum.Dot(h_sum);
  double exponent;
  if (isotropic()) {
    exponent = (1.0 - nh2) / nh2 / (alpha_x_ * alpha_x_);
  } else {
    // tan^2 theta_h cos^2 phi_h = (h.t / h.n)^2, tan^2 theta_h sin^2 phi_h = (h.b / h.n)^2.
    const Vec3 axis = std::abs(n.x) < 1.0 - 1e-6 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    const Vec3 t = (axis - n * n.Dot(axis)).Normalized();
    const Vec3 b = n.Cross(t);
    const double ht = h_sum.Dot(t) / (nh * alpha_x_), hb = h_sum.Dot(b) / (nh * alpha_y_);
    exponent = ht * ht + hb * hb;
  }
  const double f = rho_d_ / kPi + rho_s_ * std::exp(-exponent) /
                                      (4.0 * kPi * alpha_x_ * alpha_y_ * std::sqrt(nw * nv));
  return f * nw;
}

void WardBrdf::ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                                  double* out) const {
  if (!isotropic()) {
    TransferArc(theta_i, theta_o, phi, out);
    return;
  }
  const ArcFrame f(theta_i, theta_o);
  const double nv = f.n.Dot(f.v);
  const double a2 = alpha_x_ * alpha_x_;
  ForArcChunks(phi, [&](int first, int count) {
    double nw[kArcChunk], e[kArcChunk];
    for (int k = 0; k < count; ++k) {
      const Vec3 w = f.W(phi, first + k);
      nw[k] = f.n.Dot(w);
      const Vec3 h_sum = f.v + w;
      const double nh = f.n.Dot(h_sum);
      const double nh2 = nh * nh / h_sum.Dot(h_sum);
      e[k] = nh2 > 0 ? -((1.0 - nh2) / nh2 / a2) : -HUGE_VAL;
    }
    internal::VectorExp(e, e, count);
    for (int k = 0; k < count; ++k) {
      if (nw[k] <= 0 || nv <= 0) {
        out[first + k] = 0.0;
        continue;
      }
      const double fr =
          rho_d_ / kPi + rho_s_ * e[k] / (4.0 * kPi * alpha_x_ * alpha_y_ * std::sqrt(nw[k] * nv));
      out[first + k] = fr * nw[k];
    }
  });
}

// ----- GGX -----

std::string GgxBrdf::spec() const {
  return absl::StrCat("ggx:alpha=", FormatSpecNumber(alpha_), ",f0=", FormatSpecNumber(f0_));
}

BrdfBandwidthHint GgxBrdf::bandwidth_hint() const { return {CeilInt(5.0 / alpha_) + 8, 6}; }

double GgxBrdf::MirrorFresnel(double cos_nv, int /*c*/) const {
  const double x = 1.0 - std::clamp(cos_nv, 0.0, 1.0), x2 = x * x;
  return f0_ + (1.0 - f0_) * (x2 * x2 * x);
}

double GgxBrdf::Evaluate(const Vec3& n, const Vec3& v, const Vec3& w) const {
  const double nw = n.Dot(w), nv = n.Dot(v);
  if (nw <= 0 || nv <= 0) return 0.0;
  const Vec3 h = (v + w).Normalized();
  const double nh = n.Dot(h), vh = std::max(0.0, v.Dot(h));
  const double a2 = alpha_ * alpha_;
  const double den = nh * nh * (a2 - 1.0) + 1.0;
  const double d = a2 / (kPi * den * den);
  const double g = 1.0 / (1.0 + SmithLambda(a2, nv) + SmithLambda(a2, nw));
  const double x = 1.0 - vh, x2 = x * x;
  const double f = f0_ + (1.0 - f0_) * (x2 * x2 * x);
  return f * d * g / (4.0 * nw * nv);
}

double GgxBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int) const {
  const double nw = n.Dot(w);
  if (nw <= 0) return 0.0;
  return Evaluate(n, v, w) * nw;
}

namespace {

// GGX's Transfer at w_at(k), k in [0, count), into out[k]: Evaluate's value rewritten with one
// division instead of five (and the same two square roots), the horizon tests as selects, on
// local copies (`out` could alias the references' members), so the loop runs in vectors. With
// s = v + w (h = s / |s|) and v, w unit:
//   v.h = sqrt(v.s / 2)            (v.s = 1 + v.w = |s|^2 / 2),
//   D = a2 |s|^4 / (pi E^2),        E = (n.s)^2 (a2 - 1) + |s|^2 (= |s|^2 (1 + (n.h)^2 (a2 - 1))),
//   G = n.w / (n.w (1/2 + Lambda_v) + Q / 2),  Q = sqrt((n.w)^2 + a2 (1 - (n.w)^2))
//       (Smith: 1 + Lambda_v + Lambda_w with Lambda_w = (Q / n.w - 1) / 2),
//   Transfer = F D G / (4 n.w n.v) n.w = F a2 |s|^4 n.w / (4 pi n.v E^2 T),  T = n.w (1/2 +
//       Lambda_v) + Q / 2.
// Within 3.3e-14 (relative) of Evaluate on tests/brdf_test.cc TransferManyEqualsTransfer's random
// directions, which hold it to 1e-11; `w_at` is inlined, so an arc's directions are made in the
// loop.
template <class WAt>
void GgxLanes(const Vec3& n, const Vec3& v, double alpha, double f0, int count, WAt&& w_at,
              double* out) {
  const double nv = n.Dot(v);
  if (!(nv > 0)) {
    std::fill(out, out + count, 0.0);
    return;
  }
  const double nx = n.x, ny = n.y, nz = n.z, vx = v.x, vy = v.y, vz = v.z;
  const double a2 = alpha * alpha;
  const double half_v = 0.5 + SmithLambda(a2, nv);
  const double scale = a2 / (4.0 * kPi * nv);
  for (int k = 0; k < count; ++k) {
    const Vec3& w = w_at(k);  // a reference: a struct copy would keep the loop scalar
    const double nw = nx * w.x + ny * w.y + nz * w.z;
    const bool lit = nw > 0;
    const double nw_safe = lit ? nw : 1.0;
    const double sx = vx + w.x, sy = vy + w.y, sz = vz + w.z;
    const double ss = sx * sx + sy * sy + sz * sz;
    const double ns = nx * sx + ny * sy + nz * sz;
    const double vs = vx * sx + vy * sy + vz * sz;
    const double vh = std::sqrt(0.5 * std::max(0.0, vs));
    const double e = ns * ns * (a2 - 1.0) + ss;
    const double q = std::sqrt(nw_safe * nw_safe + a2 * (1.0 - nw_safe * nw_safe));
    const double t = nw_safe * half_v + 0.5 * q;
    const double x = 1.0 - vh, x2 = x * x;
    const double fresnel = f0 + (1.0 - f0) * (x2 * x2 * x);
    const double value = fresnel * scale * (ss * ss) * nw_safe / (e * e * t);
    out[k] = lit && ss > 0 ? value : 0.0;
  }
}

}  // namespace

void GgxBrdf::TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int,
                           double* out) const {
  GgxLanes(
      n, v, alpha_, f0_, static_cast<int>(w.size()),
      [p = w.data()](int k) -> const Vec3& { return p[k]; }, out);
}

void GgxBrdf::ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                                 double* out) const {
  const ArcFrame f(theta_i, theta_o);
  GgxLanes(
      f.n, f.v, alpha_, f0_, static_cast<int>(phi.phi.size()),
      [&f, &phi](int k) { return f.W(phi, k); }, out);
}

// ----- Kajiya-Kay -----

KajiyaKayBrdf::KajiyaKayBrdf(double s) : s_(s) {
  // 1 / (2 pi integral_0^pi sin^{s+1} t dt), integral = sqrt(pi) Gamma(s/2 + 1) / Gamma(s/2 + 3/2).
  norm_ = std::exp(std::lgamma(0.5 * s + 1.5) - std::lgamma(0.5 * s + 1.0)) /
          (2.0 * kPi * std::sqrt(kPi));
}

std::string KajiyaKayBrdf::spec() const {
  return absl::StrCat("kajiya-kay:s=", FormatSpecNumber(s_));
}

BrdfBandwidthHint KajiyaKayBrdf::bandwidth_hint() const {
  const int l = CeilInt(std::sqrt(9.3 * s_)) + 8;
  return {l, l};
}

double KajiyaKayBrdf::Transfer(const Vec3& t, const Vec3& v, const Vec3& w, int) const {
  const double ci = t.Dot(w), co = t.Dot(v);
  const double si = std::sqrt(std::max(0.0, 1.0 - ci * ci));
  const double so = std::sqrt(std::max(0.0, 1.0 - co * co));
  const double c = ci * co + si * so;  // cos(theta_i' - theta_o')
  if (c <= 0) return 0.0;
  return norm_ * std::pow(c, s_);
}

void KajiyaKayBrdf::TransferMany(const Vec3& t, const Vec3& v, std::span<const Vec3> w, int,
                                 double* out) const {
  const double co = t.Dot(v);
  const double so = std::sqrt(std::max(0.0, 1.0 - co * co));
  PowerLobeMany(
      w.size(), s_, norm_,
      [&t, co, so, p = w.data()](size_t k) {
        const double ci = t.Dot(p[k]);
        const double si = std::sqrt(std::max(0.0, 1.0 - ci * ci));
        return ci * co + si * so;  // cos(theta_i' - theta_o')
      },
      out);
}

double KajiyaKayBrdf::ReparamTransfer(double theta_i, double theta_o, double, int) const {
  const double c = std::cos(theta_i - theta_o);
  if (c <= 0) return 0.0;
  return norm_ * std::pow(c, s_);
}

}  // namespace shrm
