// BRDF transfer functions rho-hat and their reparameterization by the central direction.
//
// SHRM paper (Ramamoorthi & Hanrahan, "Frequency Space Environment Map Rendering"):
//  - sec. 5.3.1: reparameterization by the reflection vector R = 2 (N.V) N - V (or by the
//    tangent T for Kajiya-Kay); in the frame with pole R the view is at (theta_o', phi_o'), the
//    light at (theta_i', phi_i'), N = normalize(R + V), and an isotropic rho-hat depends on
//    (theta_i', theta_o', phi = phi_i' - phi_o') only.
//  - eq. 5.26: normalized Phong, rho-hat = (s + 1)/(2 pi) max(R.w, 0)^s (radially symmetric).
//  - eq. 5.34: simplified microfacet, rho-hat = exp(-(theta_h / sigma)^2) / (4 pi sigma^2).
//  - sec. 5.7.1: Lafortune and Kajiya-Kay (rho-hat = cos^s(theta_i' - theta_o')).
// For every other model rho-hat = f_r(N, V, w) max(N.w, 0). Spec strings and the model list are
// documented in docs/brdf.md.
#ifndef SHRM_CORE_BRDF_BRDF_H_
#define SHRM_CORE_BRDF_BRDF_H_

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/base/geometry.h"
#include "core/brdf/brdf_coefficients.h"

namespace shrm {

// Rough band limits of a model, used to size the default sampling and the first (F_max, P_max)
// tried by SelectBrdfOrders. Not a correctness requirement.
struct BrdfBandwidthHint {
  int lmax = 32;
  int pmax = 6;
};

class Brdf {
 public:
  virtual ~Brdf() = default;

  // Canonical spec string (ParseBrdfSpec(spec()) gives the same model).
  virtual std::string spec() const = 0;
  // 1 for grey analytic models, 3 for RGB tables.
  virtual int channels() const { return 1; }
  virtual ReparamKind reparam() const { return ReparamKind::kReflection; }
  // rho-hat depends on theta_i' only (P = 0): Phong.
  virtual bool radially_symmetric() const { return false; }
  // rho-hat is zero where N.w <= 0 and smooth (in the azimuth) elsewhere. The coefficient
  // quadrature then integrates phi over the visible arc only (no jump inside the rule).
  virtual bool clipped_at_normal_horizon() const { return false; }
  // rho-hat does not depend on phi (Kajiya-Kay): only q = 0 terms, one azimuth sample.
  virtual bool azimuth_independent() const { return false; }
  virtual BrdfBandwidthHint bandwidth_hint() const { return {}; }

  // World-frame rho-hat for unit normal n, unit view v (towards the viewer) and unit light
  // direction w, channel c. For kTangent models `n` is the tangent T.
  virtual double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const = 0;

  // Transfer at the light directions w[0 .. w.size()) (unit) into out[k], channel c: the
  // reference sums' leaves (core/shrm/fast_reference.cc), equal to Transfer direction by direction
  // up to rounding. Default: Transfer per direction; microfacet computes its asin and exp in
  // vectors (core/brdf/vector_math.h), GGX and Lambert their whole arithmetic in vector lanes,
  // Phong and Kajiya-Kay their power.
  virtual void TransferMany(const Vec3& n, const Vec3& v, std::span<const Vec3> w, int c,
                            double* out) const;

  // rho-hat in the frame whose pole is R (or T): light at (theta_i, phi), view at (theta_o, 0).
  // Default: builds pole = +z, V, w (and N = normalize(R + V) for kReflection) and calls
  // Transfer. theta_o = pi (V = -R) is degenerate for kReflection; callers avoid it.
  virtual double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const;
  // All channels at once into out[0 .. channels()-1]; default loops over ReparamTransfer.
  virtual void ReparamTransferAll(double theta_i, double theta_o, double phi, double* out) const;
  // The azimuths of an arc of the coefficient quadrature with their cosines and sines (taken once
  // by the caller, which needs the cosines too).
  struct ArcAzimuths {
    std::span<const double> phi, cos_phi, sin_phi;
  };
  // All channels at (theta_i, theta_o) and the azimuths phi[0 .. n): out[k * channels() + c] (the
  // coefficient quadrature's inner loop). Default: ReparamTransferAll per azimuth; the analytic
  // models take Transfer on ReparamTransfer's geometry with the trigonometry of theta_i and
  // theta_o done once (TransferArc).
  virtual void ReparamTransferArc(double theta_i, double theta_o, const ArcAzimuths& phi,
                                  double* out) const;
  // A closed-form model (smooth in its angles away from the horizon), not a table of samples:
  // the coefficient quadrature may then take its faster rule for smooth integrands.
  virtual bool analytic() const { return true; }
  // A Fresnel factor the model multiplies by, and its value at the mirror configuration
  // (V.H = N.V = cos_nv, channel c): the view dependence the normal variable's expansion divides
  // out (brdf_coefficients.h "Fresnel normalization"). Default: none (1).
  virtual bool has_fresnel() const { return false; }
  virtual double MirrorFresnel(double cos_nv, int c) const { return 1.0; }

 protected:
  // ReparamTransferArc through Transfer on MakeReparamGeometry's frame.
  void TransferArc(double theta_i, double theta_o, const ArcAzimuths& phi, double* out) const;
};

// The local geometry of ReparamTransfer: pole +z, V = (sin t_o, 0, cos t_o),
// w = (sin t_i cos phi, sin t_i sin phi, cos t_i), and (kReflection) N = normalize(pole + V)
// = (sin(t_o/2), 0, cos(t_o/2)); for kTangent `n` is the pole.
struct ReparamGeometry {
  Vec3 n, v, w;
};
ReparamGeometry MakeReparamGeometry(ReparamKind kind, double theta_i, double theta_o, double phi);

// The inverse: reparameterized angles of a world-frame configuration. For kReflection the pole
// is R = 2 (n.v) n - v, for kTangent it is n (the tangent). phi = phi_i' - phi_o' in [0, pi]
// (isotropic models are even in phi); phi = 0 when V or w is along the pole.
void ReparamAngles(ReparamKind kind, const Vec3& n, const Vec3& v, const Vec3& w, double* theta_i,
                   double* theta_o, double* phi);

// Parses a spec string such as "phong:s=32" (docs/brdf.md). Errors are InvalidArgument naming
// the model, the parameter and its valid range (or the file problem).
absl::StatusOr<std::unique_ptr<Brdf>> ParseBrdfSpec(std::string_view spec);

// A spec split as ParseBrdfSpec reads it: the model name (surrounding whitespace stripped) and
// the text after the first ':' (as written; "" without a ':').
struct BrdfSpecParts {
  std::string model;
  std::string rest;
};
BrdfSpecParts SplitBrdfSpec(std::string_view spec);
// The file of a file-based spec ("table:PATH", "merl:PATH"; the path stripped of surrounding
// whitespace), or nullopt for analytic models. `model` gets "table" or "merl".
std::optional<std::string> BrdfSpecFile(std::string_view spec, std::string* model = nullptr);

struct BrdfParamInfo {
  std::string name;
  std::string default_value;
  std::string range;  // e.g. "(0, 1e5]"
  std::string description;
};
struct BrdfModelInfo {
  std::string name;
  std::string syntax;  // e.g. "phong:s=<exponent>"
  std::vector<BrdfParamInfo> params;
  std::string description;
};
// All models ParseBrdfSpec accepts, for the CLI and the service.
const std::vector<BrdfModelInfo>& ListBrdfModels();

// Shortest decimal form of x that parses back to the same double (canonical spec strings).
std::string FormatSpecNumber(double x);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_BRDF_H_
