#include "viewer/sh_lighting_cpu.h"

#include <cassert>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"

namespace shrm::viewer {
namespace {

// The world -> SH frame change of basis (x_s = X, y_s = -Z, z_s = Y).
constexpr Mat3 kShFromWorld{{{{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}}};

double Det(const Mat3& a) {
  const auto& m = a.m;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
         m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

// Splits / merges interleaved RGB coefficient vectors.
void Channel(std::span<const double> rgb, int count, int c, std::vector<double>* out) {
  out->resize(count);
  for (int k = 0; k < count; ++k) (*out)[k] = rgb[3 * k + c];
}

}  // namespace

std::string_view NormalMappingName(NormalMapping m) {
  switch (m) {
    case NormalMapping::kTaylor:
      return "taylor";
    case NormalMapping::kSimplified:
      return "simplified";
    case NormalMapping::kExact:
      return "exact";
  }
  return "?";
}

absl::StatusOr<NormalMapping> ParseNormalMapping(std::string_view name) {
  if (name == "taylor") return NormalMapping::kTaylor;
  if (name == "simplified") return NormalMapping::kSimplified;
  return absl::InvalidArgumentError(
      absl::StrCat("unknown normal mapping '", std::string(name), "'; valid: taylor, simplified"));
}

Mat3 TangentFrame(const Vec3& normal, const Vec3& tangent, double handedness) {
  const Vec3 n = normal.Normalized();
  const Vec3 t = (tangent - n * n.Dot(tangent)).Normalized();
  const Vec3 b = n.Cross(t) * (handedness < 0 ? -1.0 : 1.0);
  return Mat3{{{{t.x, b.x, n.x}, {t.y, b.y, n.y}, {t.z, b.z, n.z}}}};
}

absl::StatusOr<ShLightingCpu> ShLightingCpu::Create(std::span<const double> world_sh_rgb,
                                                    const Brdf& brdf,
                                                    const ShLightingOptions& options) {
  const int n = static_cast<int>(std::lround(std::sqrt(world_sh_rgb.size() / 3.0)));
  if (n < 1 || static_cast<size_t>(n) * n * 3 != world_sh_rgb.size()) {
    return absl::InvalidArgumentError(absl::StrCat("SH lighting: ", world_sh_rgb.size(),
                                                   " values is not a complete RGB SH vector"));
  }
  if (options.light_lmax < 0 || options.light_lmax > kMaxOutgoingTableLmax ||
      options.brdf_lmax < 0 || options.brdf_lmax > options.light_lmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("SH lighting: degrees light ", options.light_lmax, ", BRDF ",
                     options.brdf_lmax, "; need 0 <= BRDF <= light <= ", kMaxOutgoingTableLmax));
  }
  OutgoingBrdfTableOptions t;
  t.basis = options.basis;
  t.lmax = options.brdf_lmax;
  t.resolution = options.resolution;
  t.threads = options.threads;
  SHRM_ASSIGN_OR_RETURN(OutgoingBrdfTable table, ComputeOutgoingBrdfTable(brdf, t));
  SHRM_ASSIGN_OR_RETURN(TaylorYRotation taylor, TaylorYRotation::Create(options.light_lmax));
  ShLightingCpu s(options, std::move(table), std::move(taylor));
  if (options.basis == HemisphereBasis::kHsh) {
    SHRM_ASSIGN_OR_RETURN(ShHshConversion c,
                          ShHshConversion::Create(options.brdf_lmax, options.light_lmax));
    s.conversion_ = std::move(c);
  }
  s.world_.assign(static_cast<size_t>(s.light_count()) * 3, 0.0);
  const size_t copy = std::min(s.world_.size(), world_sh_rgb.size());
  std::copy(world_sh_rgb.begin(), world_sh_rgb.begin() + copy, s.world_.begin());
  return s;
}

void ShLightingCpu::LocalLighting(const Mat3& world_from_tangent, std::span<double> out) const {
  const int lmax = options_.light_lmax, count = light_count();
  Mat3 proper = world_from_tangent;
  const bool mirrored = Det(world_from_tangent) < 0;
  if (mirrored)
    for (int r = 0; r < 3; ++r) proper.m[r][1] = -proper.m[r][1];
  // L_loc(d) = L(Q d), Q = S M: coefficients D(Q^T) L (docs/conventions.md).
  const Mat3 rot = (kShFromWorld * proper).Transposed();
  std::vector<double> in, rotated(count);
  for (int c = 0; c < 3; ++c) {
    Channel(world_, count, c, &in);
    RotateSh(lmax, rot, in, rotated);
    for (int l = 0; l <= lmax; ++l)
      for (int m = -l; m <= l; ++m) {
        const int k = ShIndex(l, m);
        out[3 * k + c] = (mirrored && m < 0) ? -rotated[k] : rotated[k];
      }
  }
}

std::array<double, 3> ShLightingCpu::ShadeLocal(std::span<const double> local_rgb,
                                                const Vec3& view_local, const Vec3& tangent_normal,
                                                NormalMapping mapping) const {
  const int lmax = options_.light_lmax, count = light_count(), nb = brdf_count();
  // The perturbed frame: R_p = Rz(ph) Ry(th) Rz(-ph) takes +z to m.
  const Vec3 m = tangent_normal.Normalized();
  const double st = std::hypot(m.x, m.y), ct = m.z;
  const double cp = st > 0 ? m.x / st : 1.0, sp = st > 0 ? m.y / st : 0.0;
  const double theta = std::atan2(st, ct);
  const Mat3 rz{{{{cp, -sp, 0}, {sp, cp, 0}, {0, 0, 1}}}};
  const Mat3 rp = rz * RotationY(theta) * rz.Transposed();
  const Vec3 vp = rp.Transposed() * view_local;

  std::vector<double> in, a(count), b(count);
  std::vector<double> lp(static_cast<size_t>(count) * 3);
  for (int c = 0; c < 3; ++c) {
    Channel(local_rgb, count, c, &in);
    switch (mapping) {
      case NormalMapping::kSimplified:
        a = in;
        break;
      case NormalMapping::kExact:
        RotateSh(lmax, rp.Transposed(), in, a);
        break;
      case NormalMapping::kTaylor:
        // Zr(ph) Y'(-th) Zr(-ph), the z-rotations exact (paper sec. 3).
        RotateShZ(lmax, cp, -sp, in, a);
        taylor_.Apply15(-theta, a, b);
        RotateShZ(lmax, cp, sp, b, a);
        break;
    }
    for (int k = 0; k < count; ++k) lp[3 * k + c] = a[k];
  }
  // HSH: h = C L_p (eq. 18); SH: the first brdf_count() coefficients.
  std::vector<double> h(static_cast<size_t>(nb) * 3);
  if (conversion_.has_value()) {
    std::vector<double> hc(nb);
    for (int c = 0; c < 3; ++c) {
      Channel(lp, count, c, &in);
      // Can only fail on sizes, fixed by Create(): cols() = light_count(), rows() = brdf_count().
      [[maybe_unused]] const absl::Status converted = conversion_->ShToHsh(in, hc);
      assert(converted.ok());
      for (int k = 0; k < nb; ++k) h[3 * k + c] = hc[k];
    }
  } else {
    std::copy(lp.begin(), lp.begin() + static_cast<long>(nb) * 3, h.begin());
  }
  std::vector<double> coeffs(static_cast<size_t>(table_.channels) * nb);
  table_.Lookup(vp, coeffs);
  std::array<double, 3> out{};
  for (int c = 0; c < 3; ++c) {
    const double* g = &coeffs[static_cast<size_t>(std::min(c, table_.channels - 1)) * nb];
    double sum = 0;
    for (int k = 0; k < nb; ++k) sum += h[3 * k + c] * g[k];
    out[c] = sum;
  }
  return out;
}

std::array<double, 3> ShLightingCpu::Shade(const Mat3& world_from_tangent, const Vec3& view_world,
                                           const Vec3& tangent_normal,
                                           NormalMapping mapping) const {
  std::vector<double> local(static_cast<size_t>(light_count()) * 3);
  LocalLighting(world_from_tangent, local);
  const Mat3 to_local = world_from_tangent.Transposed();
  return ShadeLocal(local, to_local * view_world, tangent_normal, mapping);
}

}  // namespace shrm::viewer
