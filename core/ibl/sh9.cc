#include "core/ibl/sh9.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/sh/sh.h"

namespace shrm::ibl {
namespace {

// Positive SH constants of the terms P_i (real SH with pole z): sqrt(1/4pi), sqrt(3/4pi) x 3,
// sqrt(15/4pi), sqrt(15/4pi), sqrt(5/16pi), sqrt(15/4pi), sqrt(15/16pi).
const std::array<double, kSh9Terms>& TermConstants() {
  static const std::array<double, kSh9Terms> k = [] {
    const double p = kPi;
    return std::array<double, kSh9Terms>{
        std::sqrt(1 / (4 * p)),  std::sqrt(3 / (4 * p)),  std::sqrt(3 / (4 * p)),
        std::sqrt(3 / (4 * p)),  std::sqrt(15 / (4 * p)), std::sqrt(15 / (4 * p)),
        std::sqrt(5 / (16 * p)), std::sqrt(15 / (4 * p)), std::sqrt(15 / (16 * p))};
  }();
  return k;
}
// Condon-Shortley signs of the terms (Y_1,-1 = -k y, Y_11 = -k x, Y_2,-1 = -k yz, Y_21 = -k xz).
constexpr std::array<double, kSh9Terms> kCsSign = {1, -1, 1, -1, 1, -1, 1, -1, 1};
constexpr std::array<int, kSh9Terms> kBand = {0, 1, 1, 1, 2, 2, 2, 2, 2};
constexpr std::array<double, 3> kBandFactor = {kPi, 2 * kPi / 3, kPi / 4};  // A_0, A_1, A_2

// A quadratic c0 + b.n + n^T A n of a direction n.
struct Quadratic {
  double c0 = 0;
  std::array<double, 3> b{};
  std::array<std::array<double, 3>, 3> a{};
};

// The irradiance of one channel as a quadratic in SH-frame coordinates s = (x_s, y_s, z_s), from
// E_lm (ShIndex order, 9 values) and the closed forms of docs/conventions.md:
// Y00 = k0, Y1-1 = -k1 y, Y10 = k1 z, Y11 = -k1 x, Y2-2 = k2 xy, Y2-1 = -k2 yz,
// Y20 = k20 (3z^2 - 1), Y21 = -k2 xz, Y22 = k22 (x^2 - y^2). The ShIndex order (l, m) is the
// term order P, so E_lm = E_i.
Quadratic QuadraticFromSh(const std::array<double, kSh9Terms>& e) {
  const auto& k = TermConstants();
  Quadratic q;
  q.c0 = k[0] * e[0] - k[6] * e[6];
  q.b = {-k[3] * e[3], -k[1] * e[1], k[2] * e[2]};
  q.a[0][0] = k[8] * e[8];
  q.a[1][1] = -k[8] * e[8];
  q.a[2][2] = 3 * k[6] * e[6];
  q.a[0][1] = q.a[1][0] = 0.5 * k[4] * e[4];
  q.a[1][2] = q.a[2][1] = -0.5 * k[5] * e[5];
  q.a[0][2] = q.a[2][0] = -0.5 * k[7] * e[7];
  return q;
}

// The same function in coordinates n = T s (T orthogonal): b' = T b, A' = T A T^T.
Quadratic Transform(const Quadratic& q, const Mat3& t) {
  Quadratic r;
  r.c0 = q.c0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.b[i] += t.m[i][j] * q.b[j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      double s = 0;
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) s += t.m[i][k] * q.a[k][l] * t.m[j][l];
      r.a[i][j] = s;
    }
  return r;
}

// Coefficients p_i of the quadratic on the unit sphere in the term basis P = {1, y, z, x, xy, yz,
// 3z^2 - 1, xz, x^2 - y^2}: with x^2 + y^2 + z^2 = 1,
// a x^2 + b y^2 + c z^2 = (a + b + c)/3 + (2c - a - b)/6 (3z^2 - 1) + (a - b)/2 (x^2 - y^2).
std::array<double, kSh9Terms> TermsFromQuadratic(const Quadratic& q) {
  const double axx = q.a[0][0], ayy = q.a[1][1], azz = q.a[2][2];
  return {q.c0 + (axx + ayy + azz) / 3,
          q.b[1],
          q.b[2],
          q.b[0],
          2 * q.a[0][1],
          2 * q.a[1][2],
          (2 * azz - axx - ayy) / 6,
          2 * q.a[0][2],
          (axx - ayy) / 2};
}

// S: world -> SH frame, (x, y, z) -> (x, -z, y) (docs/conventions.md).
constexpr Mat3 kShFromWorld{{{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}}};

absl::Status CheckRadiance(std::span<const double> radiance, int lmax) {
  if (lmax < 2) {
    return absl::InvalidArgumentError(
        absl::StrCat("irradiance SH9 needs radiance SH of degree >= 2, got lmax = ", lmax));
  }
  if (lmax > 1 << 12 || radiance.size() != static_cast<size_t>(ShCount(lmax)) * 3) {
    return absl::InvalidArgumentError(absl::StrCat("radiance SH of degree ", lmax, " needs ",
                                                   static_cast<size_t>(ShCount(lmax)) * 3,
                                                   " RGB values, got ", radiance.size()));
  }
  for (int i = 0; i < kSh9Values; ++i) {
    if (!std::isfinite(radiance[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat("radiance SH value ", i, " is not finite: ", radiance[i]));
    }
  }
  return absl::OkStatus();
}

// Irradiance terms E(n) = sum_i p_i P_i(n) per channel in the frame n = M d_world.
std::array<std::array<double, kSh9Terms>, 3> IrradianceTerms(std::span<const double> radiance,
                                                             const Mat3& m) {
  const Mat3 t = m * kShFromWorld.Transposed();  // n = M d = M S^T s
  std::array<std::array<double, kSh9Terms>, 3> out;
  for (int c = 0; c < 3; ++c) {
    std::array<double, kSh9Terms> e;
    for (int i = 0; i < kSh9Terms; ++i) e[i] = kBandFactor[kBand[i]] * radiance[i * 3 + c];
    out[c] = TermsFromQuadratic(Transform(QuadraticFromSh(e), t));
  }
  return out;
}

double EvalQuadratic(const Quadratic& q, const Vec3& n) {
  const double v[3] = {n.x, n.y, n.z};
  double s = q.c0;
  for (int i = 0; i < 3; ++i) {
    s += q.b[i] * v[i];
    for (int j = 0; j < 3; ++j) s += q.a[i][j] * v[i] * v[j];
  }
  return s;
}

std::array<Quadratic, 3> IrradianceQuadratics(std::span<const double> radiance9) {
  std::array<Quadratic, 3> q;
  for (int c = 0; c < 3; ++c) {
    std::array<double, kSh9Terms> e;
    for (int i = 0; i < kSh9Terms; ++i) e[i] = kBandFactor[kBand[i]] * radiance9[i * 3 + c];
    q[c] = QuadraticFromSh(e);
  }
  return q;
}

Vec3 FibonacciDirection(int k, int n) {
  const double golden = kPi * (3 - std::sqrt(5.0));
  const double z = 1 - (2 * k + 1) / static_cast<double>(n);
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  const double phi = golden * k;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace

const char* Sh9ConventionName(Sh9Convention convention) {
  switch (convention) {
    case Sh9Convention::kFilament:
      return "filament";
    case Sh9Convention::kGltf:
      return "gltf";
    case Sh9Convention::kGltfBabylon:
      return "gltf-babylon";
    case Sh9Convention::kThreeJs:
      return "three";
    case Sh9Convention::kUnity:
      return "unity";
  }
  return "?";
}

absl::StatusOr<Sh9Convention> ParseSh9Convention(std::string_view name) {
  std::string lower(name);
  for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  for (Sh9Convention c :
       {Sh9Convention::kFilament, Sh9Convention::kGltf, Sh9Convention::kGltfBabylon,
        Sh9Convention::kThreeJs, Sh9Convention::kUnity}) {
    if (lower == Sh9ConventionName(c)) return c;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown SH9 convention '", std::string(name),
                   "'; valid: filament, gltf, gltf-babylon, three, unity"));
}

Mat3 ConsumerFrameMatrix(Sh9Convention convention) {
  switch (convention) {
    case Sh9Convention::kFilament:  // (-x, y, -z)
      return Mat3{{{{-1, 0, 0}, {0, 1, 0}, {0, 0, -1}}}};
    case Sh9Convention::kGltf:
    case Sh9Convention::kGltfBabylon:
      return Mat3::Identity();
    case Sh9Convention::kThreeJs:  // (-z, y, x)
      return Mat3{{{{0, 0, -1}, {0, 1, 0}, {1, 0, 0}}}};
    case Sh9Convention::kUnity:  // (-z, y, -x)
      return Mat3{{{{0, 0, -1}, {0, 1, 0}, {-1, 0, 0}}}};
  }
  return Mat3::Identity();
}

Vec3 ConsumerFromWorld(Sh9Convention convention, const Vec3& world_dir) {
  return ConsumerFrameMatrix(convention) * world_dir;
}

Vec3 WorldFromConsumer(Sh9Convention convention, const Vec3& consumer_dir) {
  return ConsumerFrameMatrix(convention).Transposed() * consumer_dir;
}

absl::StatusOr<Sh9Rgb> ConvertRadianceSh9(std::span<const double> radiance, int lmax,
                                          Sh9Convention convention) {
  if (absl::Status s = CheckRadiance(radiance, lmax); !s.ok()) return s;
  const auto p = IrradianceTerms(radiance, ConsumerFrameMatrix(convention));
  const auto& k = TermConstants();
  Sh9Rgb out;
  for (int i = 0; i < kSh9Terms; ++i) {
    const double a = kBandFactor[kBand[i]];
    for (int c = 0; c < 3; ++c) {
      const double e = p[c][i];  // E(n) = sum_i p_i P_i(n)
      double v = 0;
      switch (convention) {
        case Sh9Convention::kFilament:
        case Sh9Convention::kUnity:
          v = e / kPi;  // sum c_i P_i = E / pi
          break;
        case Sh9Convention::kGltf:
          v = e / (kCsSign[i] * k[i]);  // E_i in the basis s_i k_i P_i
          break;
        case Sh9Convention::kGltfBabylon:
          v = kPi * e / (a * kCsSign[i] * k[i]);  // pi L_i
          break;
        case Sh9Convention::kThreeJs:
          v = e / (a * k[i]);  // L_i in the basis k_i P_i
          break;
      }
      out[i][c] = v;
    }
  }
  return out;
}

std::array<double, kSh9Values> UnityLayout(const Sh9Rgb& coeff) {
  std::array<double, kSh9Values> out;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < kSh9Terms; ++i) out[c * kSh9Terms + i] = coeff[i][c];
  return out;
}

std::array<double, 3> EvalConsumerSh9(Sh9Convention convention, const Sh9Rgb& coeff,
                                      const Vec3& n) {
  const double x = n.x, y = n.y, z = n.z;
  std::array<double, 3> out{};
  for (int ch = 0; ch < 3; ++ch) {
    std::array<double, kSh9Terms> c;
    for (int i = 0; i < kSh9Terms; ++i) c[i] = coeff[i][ch];
    double v = 0;
    switch (convention) {
      case Sh9Convention::kFilament:
        // Filament surface_light_indirect.fs, Irradiance_SphericalHarmonics (3 bands).
        v = std::max(c[0] + c[1] * y + c[2] * z + c[3] * x + c[4] * (y * x) + c[5] * (y * z) +
                         c[6] * (3 * z * z - 1) + c[7] * (z * x) + c[8] * (x * x - y * y),
                     0.0);
        break;
      case Sh9Convention::kGltf:
      case Sh9Convention::kGltfBabylon: {
        // Babylon.js EXT_lights_image_based.ts: SphericalHarmonics.FromArray, scaleInPlace(
        // intensity = 1), convertIrradianceToLambertianRadiance (1/pi); sphericalPolynomial.ts
        // updateFromHarmonics (constants as printed there), then the shader's polynomial form of
        // computeEnvironmentIrradiance (harmonicsFunctions.fx).
        std::array<double, kSh9Terms> h;
        for (int i = 0; i < kSh9Terms; ++i) h[i] = c[i] / kPi;
        // updateFromHarmonics, ending with scaleInPlace(1 / pi):
        const double s = 1 / kPi;
        const double px = -1.02333 * h[3] * s, py = -1.02333 * h[1] * s, pz = 1.02333 * h[2] * s;
        const double pxx = (0.886277 * h[0] - 0.247708 * h[6] + 0.429043 * h[8]) * s;
        const double pyy = (0.886277 * h[0] - 0.247708 * h[6] - 0.429043 * h[8]) * s;
        const double pzz = (0.886277 * h[0] + 0.495417 * h[6]) * s;
        const double pyz = -0.858086 * h[5] * s, pzx = -0.858086 * h[7] * s;
        const double pxy = 0.858086 * h[4] * s;
        // The shader: C1 = zz, Cxx_zz = xx - zz, Cyy_zz = yy - zz, then the Horner-like sums.
        const double cxx_zz = pxx - pzz, cyy_zz = pyy - pzz, c1 = pzz;
        const double a1 = cyy_zz * y + py;
        const double a2 = pyz * z + a1;
        const double b1 = pzx * z + px;
        const double b2 = pxy * y + b1;
        const double b3 = cxx_zz * x + b2;
        const double t1 = pz * z + c1;
        const double t2 = a2 * y + t1;
        v = b3 * x + t2;
        break;
      }
      case Sh9Convention::kThreeJs:
        // three.js lights_pars_begin.glsl shGetIrradianceAt.
        v = c[0] * 0.886227 + c[1] * 2.0 * 0.511664 * y + c[2] * 2.0 * 0.511664 * z +
            c[3] * 2.0 * 0.511664 * x + c[4] * 2.0 * 0.429043 * x * y +
            c[5] * 2.0 * 0.429043 * y * z + c[6] * (0.743125 * z * z - 0.247708) +
            c[7] * 2.0 * 0.429043 * x * z + c[8] * 0.429043 * (x * x - y * y);
        break;
      case Sh9Convention::kUnity: {
        // unity_SHA = (c3, c1, c2, c0 - c6), unity_SHB = (c4, c5, 3 c6, c7), unity_SHC = c8;
        // UnityCG.cginc SHEvalLinearL0L1: dot(SHA, float4(n, 1)); SHEvalLinearL2:
        // dot(SHB, n.xyzz * n.yzzx) + SHC * (n.x^2 - n.y^2).
        const double sha[4] = {c[3], c[1], c[2], c[0] - c[6]};
        const double shb[4] = {c[4], c[5], 3 * c[6], c[7]};
        const double x1 = sha[0] * x + sha[1] * y + sha[2] * z + sha[3];
        const double vb[4] = {x * y, y * z, z * z, z * x};
        const double x2 = shb[0] * vb[0] + shb[1] * vb[1] + shb[2] * vb[2] + shb[3] * vb[3];
        const double x3 = c[8] * (x * x - y * y);
        v = x1 + x2 + x3;
        break;
      }
    }
    out[ch] = v;
  }
  return out;
}

Sh9Output ConsumerOutput(Sh9Convention convention) {
  switch (convention) {
    case Sh9Convention::kThreeJs:
      return Sh9Output::kIrradiance;
    case Sh9Convention::kGltf:
      return Sh9Output::kBabylonDoubleConvolution;
    default:
      return Sh9Output::kIrradianceOverPi;
  }
}

double ShWindowFactor(ShWindow window, int l, double width) {
  if (window == ShWindow::kNone || l <= 0) return 1;
  if (l >= width) return 0;
  const double t = kPi * l / width;
  switch (window) {
    case ShWindow::kHanning:
      return 0.5 * (1 + std::cos(t));
    case ShWindow::kLanczos:
      return std::sin(t) / t;
    case ShWindow::kSinc4: {
      const double s = std::sin(t) / t;
      return s * s * s * s;
    }
    case ShWindow::kNone:
      break;
  }
  return 1;
}

absl::StatusOr<std::array<double, 3>> MinIrradianceOnSphere(std::span<const double> radiance,
                                                            int num_directions) {
  if (radiance.size() != static_cast<size_t>(kSh9Values)) {
    return absl::InvalidArgumentError(
        absl::StrCat("MinIrradianceOnSphere needs 27 values, got ", radiance.size()));
  }
  if (num_directions < 16) {
    return absl::InvalidArgumentError(
        absl::StrCat("MinIrradianceOnSphere needs >= 16 directions, got ", num_directions));
  }
  const std::array<Quadratic, 3> q = IrradianceQuadratics(radiance);
  std::array<double, 3> best;
  std::array<Vec3, 3> arg;
  best.fill(std::numeric_limits<double>::infinity());
  for (int k = 0; k < num_directions; ++k) {
    const Vec3 d = FibonacciDirection(k, num_directions);
    for (int c = 0; c < 3; ++c) {
      const double v = EvalQuadratic(q[c], d);
      if (v < best[c]) best[c] = v, arg[c] = d;
    }
  }
  // Shrinking pattern search in the tangent plane of the best sample (the sampling pitch is
  // ~sqrt(4 pi / N); E is smooth, so this converges to the local minimum).
  for (int c = 0; c < 3; ++c) {
    Vec3 d = arg[c];
    double step = 2 * std::sqrt(4 * kPi / num_directions);
    while (step > 1e-10) {
      const Vec3 helper = std::abs(d.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      const Vec3 t1 = d.Cross(helper).Normalized(), t2 = d.Cross(t1);
      bool moved = false;
      for (const Vec3& dir : {t1, t1 * -1.0, t2, t2 * -1.0}) {
        const Vec3 cand = (d + dir * step).Normalized();
        const double v = EvalQuadratic(q[c], cand);
        if (v < best[c]) {
          best[c] = v, d = cand, moved = true;
          break;
        }
      }
      if (!moved) step *= 0.5;
    }
  }
  return best;
}

absl::StatusOr<Sh9WindowReport> WindowSh9(std::span<double> radiance, int lmax,
                                          const Sh9WindowOptions& options) {
  if (absl::Status s = CheckRadiance(radiance, lmax); !s.ok()) return s;
  Sh9WindowReport report;
  std::array<double, kSh9Values> base;
  std::copy(radiance.begin(), radiance.begin() + kSh9Values, base.begin());
  auto windowed = [&](ShWindow w, double width) {
    std::array<double, kSh9Values> out = base;
    for (int i = 0; i < kSh9Terms; ++i)
      for (int c = 0; c < 3; ++c) out[i * 3 + c] *= ShWindowFactor(w, kBand[i], width);
    return out;
  };
  auto min_of = [&](const std::array<double, kSh9Values>& sh) {
    return MinIrradianceOnSphere(sh, options.num_directions);
  };
  auto all_non_negative = [](const std::array<double, 3>& m) {
    return m[0] >= 0 && m[1] >= 0 && m[2] >= 0;
  };
  auto min_before = min_of(base);
  if (!min_before.ok()) return min_before.status();
  report.min_before = report.min_after = *min_before;

  ShWindow kind = options.window;
  double width = options.width;
  if (options.automatic && options.cmgen_compatible) {
    kind = ShWindow::kSinc4;
    width = 13;  // cmgen: cutoff = numBands * 4 + 1
    for (int c = 0; c < 3; ++c) {
      double lo = 3, hi = 13;
      for (int it = 0; it < 16 && lo + 0.1 < hi; ++it) {
        const double mid = 0.5 * (lo + hi);
        auto m = min_of(windowed(kind, mid));
        if (!m.ok()) return m.status();
        ((*m)[c] < 0 ? hi : lo) = mid;
      }
      width = std::min(width, lo);
    }
  } else if (options.automatic) {
    if (kind == ShWindow::kNone) kind = ShWindow::kHanning;
    if (all_non_negative(*min_before)) return report;  // nothing to fix
    constexpr double kNarrowest = 1.0;                 // only band 0 survives
    constexpr double kWidest = 64.0;
    auto lo_min = min_of(windowed(kind, kNarrowest));
    if (!lo_min.ok()) return lo_min.status();
    if (!all_non_negative(*lo_min)) {
      return absl::InvalidArgumentError(
          "the mean irradiance is negative in some channel: no window makes it non-negative");
    }
    double lo = kNarrowest, hi = kWidest;
    auto hi_min = min_of(windowed(kind, hi));
    if (!hi_min.ok()) return hi_min.status();
    if (all_non_negative(*hi_min)) {
      lo = hi;
    } else {
      while (hi - lo > 1e-3) {
        const double mid = 0.5 * (lo + hi);
        auto m = min_of(windowed(kind, mid));
        if (!m.ok()) return m.status();
        (all_non_negative(*m) ? lo : hi) = mid;
      }
    }
    width = lo;
  } else {
    if (kind == ShWindow::kNone) return report;
    if (!(width > 0) || !std::isfinite(width)) {
      return absl::InvalidArgumentError(
          absl::StrCat("SH window width must be a positive number of bands, got ", width));
    }
  }
  const std::array<double, kSh9Values> out = windowed(kind, width);
  std::copy(out.begin(), out.end(), radiance.begin());
  std::fill(radiance.begin() + kSh9Values, radiance.end(), 0.0);
  auto min_after = min_of(out);
  if (!min_after.ok()) return min_after.status();
  report.window = kind;
  report.width = width;
  report.min_after = *min_after;
  for (int c = 0; c < 3; ++c) {
    double sq = 0;
    for (int i = 1; i < kSh9Terms; ++i) {
      const double a = kBandFactor[kBand[i]];
      const double d = (1 - ShWindowFactor(kind, kBand[i], width)) * a * base[i * 3 + c];
      sq += d * d;
    }
    const double mean = kBandFactor[0] * base[c] * TermConstants()[0];
    report.rms_change_relative[c] = std::sqrt(sq / (4 * kPi)) / mean;
  }
  return report;
}

}  // namespace shrm::ibl
