// Tabulated BRDF transfer functions rho-hat(theta_i', theta_o', phi) (SHRM paper sec. 5.5: the
// 3D isotropic rho-hat "represented on a grid of size S x T x T"), reparameterized as in
// sec. 5.3.1. File format "SHRMBRDF" version 1 (docs/brdf.md), little-endian:
//
//   char[8]  magic "SHRMBRDF"
//   uint32   version = 1
//   uint32   channels (1..4)
//   uint32   reparam (0 = reflection vector R, 1 = tangent T)
//   uint32   flags (bit 0: rho-hat is zero where N.w <= 0, N = normalize(R + V))
//   uint32   n_theta_i, n_theta_o, n_phi (each 1..4096)
//   float64  values[n_theta_i][n_theta_o][n_phi][channels]
//
// Cell-centred grid: theta_i' = pi (i + 1/2) / n_theta_i, theta_o' = pi (o + 1/2) / n_theta_o,
// phi = pi (k + 1/2) / n_phi (phi in [0, pi]: isotropic rho-hat is even in phi). Lookups are
// trilinear; beyond the outer nodes the grid is continued by the sphere's symmetries (through a
// pole theta -> -theta with phi -> phi + pi; phi -> -phi and 2 pi - phi), so the poles need no
// special case and never sit on a node (theta_o' = pi is degenerate for R).
#ifndef SHRM_CORE_BRDF_BRDF_TABLE_H_
#define SHRM_CORE_BRDF_BRDF_TABLE_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"

namespace shrm {

struct BrdfTableData {
  int channels = 1;
  ReparamKind reparam = ReparamKind::kReflection;
  bool clipped_at_normal_horizon = false;
  int n_theta_i = 0, n_theta_o = 0, n_phi = 0;
  std::vector<double> values;  // at Index(i, o, k, c)

  size_t Index(int i, int o, int k, int c) const {
    return ((static_cast<size_t>(i) * n_theta_o + o) * n_phi + k) * channels + c;
  }
};

inline constexpr int kMaxBrdfTableDim = 4096;

// Samples brdf.ReparamTransferAll at the grid's cell centres.
absl::StatusOr<BrdfTableData> SampleBrdfTable(const Brdf& brdf, int n_theta_i, int n_theta_o,
                                              int n_phi);
absl::Status WriteBrdfTable(const std::string& path, const BrdfTableData& table);
// Errors (InvalidArgument): missing/unreadable file, bad magic or version, out-of-range header
// fields, file size not matching the header, non-finite values.
absl::StatusOr<BrdfTableData> ReadBrdfTable(const std::string& path);

class TableBrdf final : public Brdf {
 public:
  TableBrdf(BrdfTableData table, std::string path)
      : table_(std::move(table)), path_(std::move(path)) {}
  std::string spec() const override { return "table:" + path_; }
  int channels() const override { return table_.channels; }
  ReparamKind reparam() const override { return table_.reparam; }
  bool analytic() const override { return false; }
  bool clipped_at_normal_horizon() const override { return table_.clipped_at_normal_horizon; }
  bool azimuth_independent() const override { return table_.n_phi == 1; }
  BrdfBandwidthHint bandwidth_hint() const override;
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override;
  double ReparamTransfer(double theta_i, double theta_o, double phi, int c) const override;
  const BrdfTableData& data() const { return table_; }

 private:
  BrdfTableData table_;
  std::string path_;
};

absl::StatusOr<std::unique_ptr<TableBrdf>> LoadBrdfTable(const std::string& path);

}  // namespace shrm

#endif  // SHRM_CORE_BRDF_BRDF_TABLE_H_
