// Analytic BRDF models of the SHRM paper (Ramamoorthi & Hanrahan) and common reference models.
//
//  - Lambert: rho-hat = (albedo / pi) max(N.w, 0).
//  - Phong, eq. 5.26: rho-hat = (s + 1)/(2 pi) max(R.w, 0)^s, radially symmetric about R, no
//    horizon cut; its exact coefficients rho_l (from integral_0^1 x^s P_l(x) dx) and the paper's
//    approximation eq. 5.27 rho_l ~ Lambda_l^-1 exp(-l^2 / 2s), Lambda_l = sqrt(4 pi/(2l + 1)),
//    and the order estimate eq. 5.28 F ~ sqrt(-s log epsilon).
//  - Simplified microfacet, eq. 5.34: rho-hat = exp(-(theta_h / sigma)^2) / (4 pi sigma^2),
//    zero where N.w <= 0.
//  - Lafortune et al. 1997 (isotropic, C_x = C_y), Ward 1992 (also anisotropic), GGX /
//    Trowbridge-Reitz with the height-correlated Smith G and Schlick's Fresnel: rho-hat = f_r
//    max(N.w, 0).
//  - Kajiya-Kay, sec. 5.3.1 / 5.7.1: reparameterized by the tangent T,
//    rho-hat = c_s max(cos(theta_i' - theta_o'), 0)^s, c_s normalizing the white furnace to 1
//    for a view perpendicular to T.
// Definitions and parameter ranges: docs/brdf.md.
#ifndef SHRM_CORE_BRDF_BRDF_MODELS_H_
#define SHRM_CORE_BRDF_BRDF_MODELS_H_

#include <string>
#include <vector>

#include "core/brdf/brdf.h"

namespace shrm {

class LambertBrdf final : public Brdf {
 public:
  explicit LambertBrdf(double albedo) : albedo_(albedo) {}
  double albedo() const { return albedo_; }
  std::string spec() const override;
  bool clipped_at_normal_horizon() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override { return {16, 8}; }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  void TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int c,
                    double* out) const override;
  void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                          double* out) const override {
    TransferArc(theta_i, theta_o, phi, out);
  }

 private:
  double albedo_;
};

class PhongBrdf final : public Brdf {
 public:
  explicit PhongBrdf(double s) : s_(s) {}
  double exponent() const { return s_; }
  std::string spec() const override;
  bool radially_symmetric() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  // The power of a batch in vectors (core/brdf/vector_math.h).
  void TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int c,
                    double* out) const override;
  double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const override;

 private:
  double s_;
};

class MicrofacetBrdf final : public Brdf {
 public:
  explicit MicrofacetBrdf(double sigma) : sigma_(sigma) {}
  double sigma() const { return sigma_; }
  std::string spec() const override;
  bool clipped_at_normal_horizon() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  void TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int c,
                    double* out) const override;
  // Transfer along the arc with the azimuths side by side (vector math, core/brdf/vector_math.h).
  void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                          double* out) const override;
  double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const override;

 private:
  // Transfer at w[0 .. count), count <= 64, the asin and exp in vectors.
  void TransferChunk(const Vec3& n, const Vec3& v, const Vec3* w, int count, double* out) const;
  double sigma_;
};

struct LafortuneLobe {
  double cxy = -1;  // C_x = C_y (isotropic)
  double cz = 1;
  double n = 20;
  double rho = 1;
};

// f_r = rho_d / pi + sum_k rho_k max(C_xy,k (u_x v_x + u_y v_y) + C_z,k u_z v_z, 0)^n_k in the
// local frame of N (u = w, v = V). The C's carry the lobe normalization as in the original paper.
class LafortuneBrdf final : public Brdf {
 public:
  LafortuneBrdf(std::vector<LafortuneLobe> lobes, double rho_d)
      : lobes_(std::move(lobes)), rho_d_(rho_d) {}
  const std::vector<LafortuneLobe>& lobes() const { return lobes_; }
  double rho_d() const { return rho_d_; }
  std::string spec() const override;
  bool clipped_at_normal_horizon() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  // Transfer along the arc with the azimuths side by side (vector math, core/brdf/vector_math.h).
  void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                          double* out) const override;

 private:
  std::vector<LafortuneLobe> lobes_;
  double rho_d_;
};

// Ward 1992: f_r = rho_d / pi + rho_s exp(-tan^2 theta_h (cos^2 phi_h / alpha_x^2 +
// sin^2 phi_h / alpha_y^2)) / (4 pi alpha_x alpha_y sqrt(cos theta_i cos theta_o)); isotropic
// when alpha_x = alpha_y = alpha. The anisotropic axes: t = the projection of the frame's +x
// axis onto the plane normal to n (of +y if n is within 1e-6 of +-x), b = n x t; phi_h is the
// azimuth of the half vector from t towards b. The SHRM pipeline (reparameterization by R,
// sec. 5.3.1) assumes isotropy: ComputeBrdfCoefficients rejects alpha_x != alpha_y; the
// per-outgoing-direction tables (outgoing_table.h, normal = +z, t = +x) support both.
class WardBrdf final : public Brdf {
 public:
  WardBrdf(double alpha, double rho_s, double rho_d) : WardBrdf(alpha, alpha, rho_s, rho_d) {}
  WardBrdf(double alpha_x, double alpha_y, double rho_s, double rho_d)
      : alpha_x_(alpha_x), alpha_y_(alpha_y), rho_s_(rho_s), rho_d_(rho_d) {}
  bool isotropic() const { return alpha_x_ == alpha_y_; }
  double alpha_x() const { return alpha_x_; }
  double alpha_y() const { return alpha_y_; }
  double rho_s() const { return rho_s_; }
  double rho_d() const { return rho_d_; }
  // "ward:alpha=..,rho_s=..,rho_d=.." when isotropic, else "ward:alpha_x=..,alpha_y=..,...".
  std::string spec() const override;
  bool clipped_at_normal_horizon() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  // Transfer along the arc with the azimuths side by side (vector math, core/brdf/vector_math.h).
  void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                          double* out) const override;

 private:
  double alpha_x_, alpha_y_, rho_s_, rho_d_;
};

// GGX (Trowbridge-Reitz): f_r = F(V.H) D(N.H) G2 / (4 (N.w)(N.V)) with
// D = alpha^2 / (pi ((N.H)^2 (alpha^2 - 1) + 1)^2), the height-correlated Smith
// G2 = 1 / (1 + Lambda(V) + Lambda(w)), Lambda = (sqrt(1 + alpha^2 tan^2 theta) - 1) / 2, and
// Schlick's F = f0 + (1 - f0)(1 - V.H)^5.
class GgxBrdf final : public Brdf {
 public:
  GgxBrdf(double alpha, double f0) : alpha_(alpha), f0_(f0) {}
  std::string spec() const override;
  bool clipped_at_normal_horizon() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  void TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int c,
                    double* out) const override;
  // Transfer along the arc with the azimuths side by side (vector math, core/brdf/vector_math.h).
  void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                          double* out) const override;
  // f_r itself (no cosine), for MERL generation and tests.
  double Evaluate(const Vec3& n, const Vec3& v, const Vec3& w) const;
  double alpha() const { return alpha_; }
  double f0() const { return f0_; }
  // Schlick's F at V.H = N.V (f0 < 1: F = 1 everywhere for f0 = 1).
  bool has_fresnel() const override { return f0_ < 1; }
  double MirrorFresnel(double cos_nv, int c) const override;

 private:
  double alpha_, f0_;
};

// Kajiya-Kay reparameterized by the tangent: Transfer's first argument is the tangent T.
class KajiyaKayBrdf final : public Brdf {
 public:
  explicit KajiyaKayBrdf(double s);
  double exponent() const { return s_; }
  std::string spec() const override;
  ReparamKind reparam() const override { return ReparamKind::kTangent; }
  bool azimuth_independent() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& t, const Vec3& v, const Vec3& w, int c) const override;
  // The power of a batch in vectors (core/brdf/vector_math.h).
  void TransferMany(const Vec3& t, const Vec3& v, std::span<const Vec3> w, int c,
                    double* out) const override;
  double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const override;
  double normalization() const { return norm_; }

 private:
  double s_, norm_;
};

// Phong (eq. 5.26) coefficients rho_l = 2 pi integral rho-hat(t) lambda_l^0(cos t) sin t dt,
// l = 0..lmax, exactly: rho_l = (s + 1) sqrt((2l + 1)/(4 pi)) I_l with
// I_l = integral_0^1 x^s P_l(x) dx, I_0 = 1/(s + 1), I_1 = 1/(s + 2),
// I_l = (s - l + 2)/(s + l + 1) I_{l-2} (Gradshteyn & Ryzhik 7.126.2; Ramamoorthi & Hanrahan 2001).
std::vector<double> PhongRhoExact(double s, int lmax);
// Eq. 5.27: rho_l ~ sqrt((2l + 1)/(4 pi)) exp(-l^2 / (2 s)).
std::vector<double> PhongRhoEq527(double s, int lmax);
// Eq. 5.28: F ~ sqrt(-s log epsilon).
double PhongOrderEq528(double s, double epsilon);
// Exact order: the smallest F with sum_{l<=F} rho_l^2 >= (1 - epsilon) 2 pi integral rho-hat^2
// (eq. 5.17, total (s + 1)^2 / (2 pi (2 s + 1))).
int PhongOrderExact(double s, double epsilon);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_BRDF_MODELS_H_
