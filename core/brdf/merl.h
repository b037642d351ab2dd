// MERL isotropic measured BRDFs (Matusik et al. 2003), read and looked up exactly as MERL's
// published BRDFRead.cpp; used as rho-hat = f_r max(N.w, 0) in the SHRM paper's
// reparameterization (sec. 5.3.1; coefficients by eq. 5.22).
//
// File: int32 dims[3] = {90, 90, 180} (theta_h, theta_d, phi_d), then 3 x 90*90*180 float64
// (all red, then all green, then all blue) in the order
// index = phi_d_index + theta_d_index * 180 + theta_h_index * 180 * 90. Stored values are
// scaled: f_r = stored * (1/1500, 1.15/1500, 1.66/1500) for (R, G, B); negative stored values
// mark missing data (treated as 0). Indexing (BRDFRead.cpp):
//   theta_h_index = (int) sqrt(theta_h / (pi/2) * 90 * 90), clamped to [0, 89] (0 if theta_h <= 0)
//   theta_d_index = (int) (theta_d / (pi/2) * 90), clamped to [0, 89]
//   phi_d_index   = (int) (phi_d' / pi * 180), phi_d' = phi_d + pi if phi_d < 0, clamped [0, 179]
// with (theta_h, phi_h, theta_d, phi_d) from std_coords_to_half_diff_coords.
#ifndef SHRM_CORE_BRDF_MERL_H_
#define SHRM_CORE_BRDF_MERL_H_

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"

namespace shrm {

inline constexpr int kMerlThetaH = 90;
inline constexpr int kMerlThetaD = 90;
inline constexpr int kMerlPhiD = 180;  // BRDF_SAMPLING_RES_PHI_D / 2
inline constexpr int kMerlSize = kMerlThetaH * kMerlThetaD * kMerlPhiD;
inline constexpr std::array<double, 3> kMerlScale = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

struct MerlHalfDiff {
  double theta_h, phi_h, theta_d, phi_d;
};
// BRDFRead.cpp's std_coords_to_half_diff_coords (local frame, +z the normal).
MerlHalfDiff MerlStdCoordsToHalfDiff(double theta_in, double phi_in, double theta_out,
                                     double phi_out);
int MerlThetaHalfIndex(double theta_h);
int MerlThetaDiffIndex(double theta_d);
int MerlPhiDiffIndex(double phi_d);
// Index of a lookup in one channel's block.
int MerlIndex(double theta_h, double theta_d, double phi_d);

// The centre of bin (ih, id, ip) in (theta_h, theta_d, phi_d): the sqrt mapping's mid-bin
// theta_h = ((ih + 1/2)/90)^2 pi/2, theta_d = (id + 1/2) pi/180, phi_d = (ip + 1/2) pi/180.
MerlHalfDiff MerlBinCentre(int ih, int id, int ip);
// In/out unit vectors (local frame) of half/difference angles, phi_h = 0: the inverse of
// std_coords_to_half_diff_coords.
void MerlHalfDiffToVectors(double theta_h, double theta_d, double phi_d, Vec3* in, Vec3* out);

// Raw file contents (stored, i.e. scaled, values) generated from an RGB f_r(in, out) in the
// local frame (+z normal), sampled at each bin's centre; directions below the horizon store -1.
std::vector<double> GenerateMerlData(
    const std::function<std::array<double, 3>(const Vec3& in, const Vec3& out)>& f_r);
// Writes dims then data (no checks on either: tests write malformed files with it).
absl::Status WriteMerlFile(const std::string& path, const std::array<int32_t, 3>& dims,
                           const std::vector<double>& data);

class MerlBrdf final : public Brdf {
 public:
  MerlBrdf(std::vector<double> data, std::string path)
      : data_(std::move(data)), path_(std::move(path)) {}
  std::string spec() const override { return "merl:" + path_; }
  int channels() const override { return 3; }
  bool analytic() const override { return false; }
  bool clipped_at_normal_horizon() const override { return true; }
  BrdfBandwidthHint bandwidth_hint() const override { return {48, 6}; }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const override;
  void ReparamTransferAll(double theta_i, double theta_o, double phi, double* out) const override;

  // BRDFRead.cpp's lookup_brdf_val: f_r (not times the cosine) in RGB; negative -> 0.
  std::array<double, 3> Lookup(double theta_in, double phi_in, double theta_out,
                               double phi_out) const;
  // f_r for local unit vectors (+z the normal); 0 below either horizon.
  std::array<double, 3> LookupVectors(const Vec3& in, const Vec3& out) const;

 private:
  std::vector<double> data_;
  std::string path_;
};

// Errors (InvalidArgument): missing file, dims other than (90, 90, 180), size mismatch.
absl::StatusOr<std::unique_ptr<MerlBrdf>> LoadMerlBrdf(const std::string& path);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_MERL_H_
