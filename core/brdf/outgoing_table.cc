#include "core/brdf/outgoing_table.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "core/base/constants.h"
#include "core/base/parallel.h"
#include "core/base/status_macros.h"
#include "core/sh/hsh.h"
#include "core/sh/sh.h"

namespace shrm {
namespace {

// Largest default / accepted incoming quadrature sizes.
constexpr int kMaxDefaultQuad = 256;
constexpr int kMaxQuad = 4096;
// Azimuthal grading: lobe width sigma ~ kLobeWidthScale / (h - kHintOffset) radians from the
// bandwidth hint h (the models' hints are ~3.5 / sigma + 8); near the horizon a lobe's azimuthal
// width is ~2 sigma cos(theta_o). Concentration k in [kMinConcentration, 1]; at most
// kMaxAzimuthNodes nodes per ring.
constexpr double kLobeWidthScale = 3.5;
constexpr int kHintOffset = 8;
constexpr double kMinConcentration = 1.0 / 32;
constexpr int kMaxAzimuthNodes = 16384;

// Moves (u, v) onto the closed disc of radius `radius` (nearest point).
void ClampToDisc(double radius, double* u, double* v) {
  const double r2 = *u * *u + *v * *v;
  if (r2 > radius * radius) {
    const double s = radius / std::sqrt(r2);
    *u *= s;
    *v *= s;
  }
}

// Validated options with the quadrature sizes resolved.
absl::StatusOr<OutgoingBrdfTableOptions> ResolveOptions(const Brdf& brdf,
                                                        const OutgoingBrdfTableOptions& o) {
  if (o.lmax < 0 || o.lmax > kMaxOutgoingTableLmax) {
    return absl::InvalidArgumentError(absl::StrCat("outgoing BRDF table: lmax = ", o.lmax,
                                                   " is out of range; valid range [0, ",
                                                   kMaxOutgoingTableLmax, "]"));
  }
  if (o.resolution < 1 || o.resolution > kMaxOutgoingTableResolution) {
    return absl::InvalidArgumentError(
        absl::StrCat("outgoing BRDF table: resolution = ", o.resolution,
                     " is out of range; valid range [1, ", kMaxOutgoingTableResolution, "]"));
  }
  if (o.quad_theta < 0 || o.quad_theta > kMaxQuad || o.quad_phi < 0 || o.quad_phi > kMaxQuad) {
    return absl::InvalidArgumentError(absl::StrCat(
        "outgoing BRDF table: quadrature sizes quad_theta = ", o.quad_theta, ", quad_phi = ",
        o.quad_phi, " are out of range; valid range [0, ", kMaxQuad, "] (0 = automatic)"));
  }
  if (o.threads < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("outgoing BRDF table: threads = ", o.threads, " must be >= 1"));
  }
  if (brdf.reparam() == ReparamKind::kTangent) {
    return absl::InvalidArgumentError(absl::StrCat(
        "outgoing BRDF table: brdf '", brdf.spec(),
        "' is reparameterized by the tangent (its Transfer takes a tangent, not a normal); "
        "per-outgoing-direction tables need a model defined relative to the normal"));
  }
  OutgoingBrdfTableOptions r = o;
  const int h = brdf.bandwidth_hint().lmax;
  if (r.quad_theta == 0) r.quad_theta = std::min(kMaxDefaultQuad, std::max({o.lmax + 8, h, 24}));
  if (r.quad_phi == 0) {
    r.quad_phi = std::min(kMaxDefaultQuad, std::max({2 * o.lmax + 2, h, 32}));
  }
  return r;
}

// Rings: Gauss-Legendre in t = sqrt(cos theta) on [0, 1] (x = cos theta = t^2, dx = 2 t dt), so
// that the sqrt(cos theta) of Ward's f_r cos(theta_i) and of the odd-m HSH
// (sin theta' = 2 sqrt(x (1 - x))) are smooth at the horizon. weight = 2 t w_j (sum 1).
struct Rings {
  std::vector<double> cos_theta, sin_theta, weight;
  std::vector<double> one_minus_cos;  // 1 - x, accurate
};

absl::StatusOr<Rings> MakeRings(int quad_theta) {
  SHRM_ASSIGN_OR_RETURN(const HemisphereRule rule, MakeHemisphereRule(quad_theta, 1));
  Rings r;
  for (int j = 0; j < quad_theta; ++j) {
    const double t = rule.cos_theta[j], st = rule.sin_theta[j];  // t and sqrt(1 - t^2)
    r.cos_theta.push_back(t * t);
    r.one_minus_cos.push_back(st * st);
    r.sin_theta.push_back(st * std::sqrt(1.0 + t * t));  // sqrt(1 - t^4)
    r.weight.push_back(2.0 * t * rule.weight[j]);
  }
  return r;
}

// Azimuth nodes for outgoing direction wo, graded towards the mirror azimuth phi_m = phi_o + pi
// by the Moebius (wrapped-Cauchy) map phi = phi_m + 2 atan(k tan(s / 2)), trapezoid in s with
// quad_phi / k nodes: near phi_m the spacing is k^2 times the uniform 2 pi / quad_phi, elsewhere
// at most the uniform spacing; the map is analytic, so smooth integrands keep spectral accuracy.
struct Azimuths {
  std::vector<double> cos_phi, sin_phi, weight;  // weights sum to 2 pi
};

void MakeAzimuths(int bandwidth_hint, int quad_phi, const Vec3& wo, Azimuths* a) {
  const double sigma = kLobeWidthScale /
                       std::max(static_cast<double>(bandwidth_hint - kHintOffset), kLobeWidthScale);
  const double k = std::clamp(std::sqrt(2.0 * sigma * std::max(wo.z, 0.0) * quad_phi / (6.0 * kPi)),
                              kMinConcentration, 1.0);
  const int n = std::min(kMaxAzimuthNodes, static_cast<int>(std::ceil(quad_phi / k)));
  const double phi_m = std::atan2(-wo.y, -wo.x), ds = 2.0 * kPi / n;
  a->cos_phi.resize(n);
  a->sin_phi.resize(n);
  a->weight.resize(n);
  for (int i = 0; i < n; ++i) {
    const double half = 0.5 * ((i + 0.5) * ds - kPi);  // s / 2 in (-pi/2, pi/2)
    const double c = std::cos(half), s = std::sin(half);
    const double phi = phi_m + 2.0 * std::atan2(k * s, c);
    a->cos_phi[i] = std::cos(phi);
    a->sin_phi[i] = std::sin(phi);
    a->weight[i] = ds * k / (c * c + k * k * s * s);
  }
}

}  // namespace

std::string_view HemisphereBasisName(HemisphereBasis basis) {
  return basis == HemisphereBasis::kHsh ? "hsh" : "sh";
}

Vec3 ParabolicToDirection(double u, double v) {
  return Vec3{u, v, 0.5 * (1.0 - u * u - v * v)}.Normalized();
}

void DirectionToParabolic(const Vec3& w, double* u, double* v) {
  const Vec3 d = w.Normalized();
  const double s = 1.0 / (1.0 + d.z);
  *u = d.x * s;
  *v = d.y * s;
}

void OutgoingTexelCentre(int resolution, int x, int y, double* u, double* v) {
  *u = -1.0 + (x + 0.5) * 2.0 / resolution;
  *v = -1.0 + (y + 0.5) * 2.0 / resolution;
}

double OutgoingTexelRadius(int resolution) { return 1.0 - 1.0 / resolution; }

Vec3 OutgoingTexelDirection(int resolution, int x, int y) {
  double u = 0, v = 0;
  OutgoingTexelCentre(resolution, x, y, &u, &v);
  ClampToDisc(OutgoingTexelRadius(resolution), &u, &v);
  return ParabolicToDirection(u, v);
}

std::span<const float> OutgoingBrdfTable::Texel(int x, int y, int c) const {
  const size_t offset =
      (static_cast<size_t>(y * options.resolution + x) * channels + c) * static_cast<size_t>(count);
  return std::span<const float>(coeffs).subspan(offset, count);
}

void OutgoingBrdfTable::Lookup(const Vec3& wo, std::span<double> out) const {
  const int n = channels * count;
  assert(out.size() >= static_cast<size_t>(n));
  const int res = options.resolution;
  double u = 0, v = 0;
  const double rho = std::hypot(wo.x, wo.y);
  if (wo.z <= 0.0) {
    // Clamped to the horizon: (u, v) = the azimuth's unit vector (straight down: +x).
    if (rho > 0) {
      u = wo.x / rho;
      v = wo.y / rho;
    } else {
      u = 1.0;
    }
  } else {
    DirectionToParabolic(wo, &u, &v);
    ClampToDisc(1.0, &u, &v);
  }
  // Continuous texel coordinates (texel centres at integers), clamped to the map.
  const double fx = std::clamp((u + 1.0) * 0.5 * res - 0.5, 0.0, res - 1.0);
  const double fy = std::clamp((v + 1.0) * 0.5 * res - 0.5, 0.0, res - 1.0);
  const int x0 = std::min(static_cast<int>(fx), std::max(res - 2, 0));
  const int y0 = std::min(static_cast<int>(fy), std::max(res - 2, 0));
  const int x1 = std::min(x0 + 1, res - 1), y1 = std::min(y0 + 1, res - 1);
  const double ax = fx - x0, ay = fy - y0;
  const double w00 = (1 - ax) * (1 - ay), w10 = ax * (1 - ay), w01 = (1 - ax) * ay, w11 = ax * ay;
  const float* t00 = coeffs.data() + static_cast<size_t>(y0 * res + x0) * n;
  const float* t10 = coeffs.data() + static_cast<size_t>(y0 * res + x1) * n;
  const float* t01 = coeffs.data() + static_cast<size_t>(y1 * res + x0) * n;
  const float* t11 = coeffs.data() + static_cast<size_t>(y1 * res + x1) * n;
  for (int i = 0; i < n; ++i) {
    out[i] = w00 * t00[i] + w10 * t10[i] + w01 * t01[i] + w11 * t11[i];
  }
}

absl::StatusOr<IncomingQuadrature> OutgoingIncomingQuadrature(
    const Brdf& brdf, const OutgoingBrdfTableOptions& options, const Vec3& wo) {
  SHRM_ASSIGN_OR_RETURN(const OutgoingBrdfTableOptions o, ResolveOptions(brdf, options));
  if (!(wo.z > 0.0) || std::abs(wo.Norm() - 1.0) > 1e-9) {
    return absl::InvalidArgumentError(
        absl::StrCat("outgoing BRDF quadrature: wo = (", wo.x, ", ", wo.y, ", ", wo.z,
                     ") must be a unit vector above the horizon (z > 0)"));
  }
  SHRM_ASSIGN_OR_RETURN(const Rings rings, MakeRings(o.quad_theta));
  Azimuths az;
  MakeAzimuths(brdf.bandwidth_hint().lmax, o.quad_phi, wo, &az);
  IncomingQuadrature q;
  for (int j = 0; j < o.quad_theta; ++j) {
    for (size_t i = 0; i < az.weight.size(); ++i) {
      q.dirs.push_back({rings.sin_theta[j] * az.cos_phi[i], rings.sin_theta[j] * az.sin_phi[i],
                        rings.cos_theta[j]});
      q.weights.push_back(rings.weight[j] * az.weight[i]);
    }
  }
  return q;
}

absl::StatusOr<OutgoingBrdfTable> ComputeOutgoingBrdfTable(
    const Brdf& brdf, const OutgoingBrdfTableOptions& options) {
  SHRM_ASSIGN_OR_RETURN(const OutgoingBrdfTableOptions o, ResolveOptions(brdf, options));
  SHRM_ASSIGN_OR_RETURN(const Rings rings, MakeRings(o.quad_theta));
  OutgoingBrdfTable table;
  table.options = o;
  table.channels = brdf.channels();
  table.count = ShCount(o.lmax);
  const int lmax = o.lmax, count = table.count, channels = table.channels, res = o.resolution;
  const int quad_theta = o.quad_theta, hint = brdf.bandwidth_hint().lmax;

  // Normalized Legendre values per ring times the ring weight; for the HSH the shifted ones
  // times sqrt2 (eq. 8: H_l^m = sqrt2 Y_l^m(theta'), cos theta' = 2x - 1, sin theta' = 2 t st).
  const int lcount = LegendreCount(lmax);
  std::vector<double> lambda(static_cast<size_t>(quad_theta) * lcount);
  for (int j = 0; j < quad_theta; ++j) {
    const std::span<double> out(lambda.data() + static_cast<size_t>(j) * lcount, lcount);
    const double x = rings.cos_theta[j], one_minus_x = rings.one_minus_cos[j];
    double scale = rings.weight[j];
    if (o.basis == HemisphereBasis::kHsh) {
      NormalizedLegendre(lmax, x - one_minus_x, 2.0 * std::sqrt(x * one_minus_x), out);
      scale *= kSqrt2;
    } else {
      NormalizedLegendre(lmax, x, rings.sin_theta[j], out);
    }
    for (double& v : out) v *= scale;
  }

  table.coeffs.assign(static_cast<size_t>(res) * res * channels * count, 0.0f);
  const Vec3 normal{0.0, 0.0, 1.0};
  const int trig_stride = 2 * (lmax + 1);
  ParallelChunks(res, o.threads, [&](int row_begin, int row_end) {
    Azimuths az;
    std::vector<double> trig, g, sums;
    std::vector<double> acc(static_cast<size_t>(channels) * count);
    for (int y = row_begin; y < row_end; ++y) {
      for (int x = 0; x < res; ++x) {
        const Vec3 wo = OutgoingTexelDirection(res, x, y);
        MakeAzimuths(hint, o.quad_phi, wo, &az);
        const int n_phi = static_cast<int>(az.weight.size());
        // cos(m phi_i), sin(m phi_i), m = 0..lmax, node-major, by the angle-addition recurrence.
        trig.resize(static_cast<size_t>(n_phi) * trig_stride);
        for (int i = 0; i < n_phi; ++i) {
          double* t = trig.data() + static_cast<size_t>(i) * trig_stride;
          double cm = 1.0, sm = 0.0;
          for (int m = 0; m <= lmax; ++m) {
            t[2 * m] = cm;
            t[2 * m + 1] = sm;
            const double cn = cm * az.cos_phi[i] - sm * az.sin_phi[i];
            sm = sm * az.cos_phi[i] + cm * az.sin_phi[i];
            cm = cn;
          }
        }
        g.resize(static_cast<size_t>(n_phi) * channels);
        sums.resize(static_cast<size_t>(channels) * trig_stride);
        std::fill(acc.begin(), acc.end(), 0.0);
        for (int j = 0; j < quad_theta; ++j) {
          const double ct = rings.cos_theta[j], st = rings.sin_theta[j];
          bool any = false;
          for (int i = 0; i < n_phi; ++i) {
            const Vec3 wi{st * az.cos_phi[i], st * az.sin_phi[i], ct};
            for (int c = 0; c < channels; ++c) {
              const double v = brdf.Transfer(normal, wo, wi, c);
              g[static_cast<size_t>(i) * channels + c] = az.weight[i] * v;
              any = any || v != 0.0;
            }
          }
          if (!any) continue;
          // Azimuthal sums A_m = sum_i w_i g_i cos(m phi_i), B_m = sum_i w_i g_i sin(m phi_i).
          std::fill(sums.begin(), sums.end(), 0.0);
          for (int i = 0; i < n_phi; ++i) {
            const double* t = trig.data() + static_cast<size_t>(i) * trig_stride;
            for (int c = 0; c < channels; ++c) {
              const double gi = g[static_cast<size_t>(i) * channels + c];
              double* a = sums.data() + static_cast<size_t>(c) * trig_stride;
              for (int q = 0; q < trig_stride; ++q) a[q] += gi * t[q];
            }
          }
          // Real SH / HSH layout (sh.h): m = 0 lambda, m > 0 sqrt2 lambda cos, m < 0 sqrt2
          // lambda sin.
          const double* lam = lambda.data() + static_cast<size_t>(j) * lcount;
          for (int c = 0; c < channels; ++c) {
            const double* a = sums.data() + static_cast<size_t>(c) * trig_stride;
            double* out = acc.data() + static_cast<size_t>(c) * count;
            for (int l = 0; l <= lmax; ++l) out[ShIndex(l, 0)] += lam[LegendreIndex(l, 0)] * a[0];
            for (int m = 1; m <= lmax; ++m) {
              for (int l = m; l <= lmax; ++l) {
                const double p = kSqrt2 * lam[LegendreIndex(l, m)];
                out[ShIndex(l, m)] += p * a[2 * m];
                out[ShIndex(l, -m)] += p * a[2 * m + 1];
              }
            }
          }
        }
        float* dst = table.coeffs.data() + static_cast<size_t>(y * res + x) * channels * count;
        for (size_t q = 0; q < acc.size(); ++q) dst[q] = static_cast<float>(acc[q]);
      }
    }
  });
  return table;
}

}  // namespace shrm
