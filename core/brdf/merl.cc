#include "core/brdf/merl.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"

namespace shrm {
namespace {

// BRDFRead.cpp's rotate_vector: Rodrigues' rotation of `v` about unit `axis` by `angle`.
Vec3 RotateVector(const Vec3& v, const Vec3& axis, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  return v * c + axis * (axis.Dot(v) * (1.0 - c)) + axis.Cross(v) * s;
}

// Orthonormal tangent frame (t, b, n) of unit n (Duff et al. 2017).
void TangentFrame(const Vec3& n, Vec3* t, Vec3* b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double bb = n.x * n.y * a;
  *t = {1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x};
  *b = {bb, sign + n.y * n.y * a, -n.y};
}

}  // namespace

MerlHalfDiff MerlStdCoordsToHalfDiff(double theta_in, double phi_in, double theta_out,
                                     double phi_out) {
  const Vec3 in = Vec3{std::sin(theta_in) * std::cos(phi_in), std::sin(theta_in) * std::sin(phi_in),
                       std::cos(theta_in)}
                      .Normalized();
  const Vec3 out = Vec3{std::sin(theta_out) * std::cos(phi_out),
                        std::sin(theta_out) * std::sin(phi_out), std::cos(theta_out)}
                       .Normalized();
  const Vec3 half = ((in + out) * 0.5).Normalized();
  MerlHalfDiff hd;
  hd.theta_h = std::acos(std::clamp(half.z, -1.0, 1.0));
  hd.phi_h = std::atan2(half.y, half.x);
  const Vec3 bi_normal{0.0, 1.0, 0.0}, normal{0.0, 0.0, 1.0};
  const Vec3 temp = RotateVector(in, normal, -hd.phi_h);
  const Vec3 diff = RotateVector(temp, bi_normal, -hd.theta_h);
  hd.theta_d = std::acos(std::clamp(diff.z, -1.0, 1.0));
  hd.phi_d = std::atan2(diff.y, diff.x);
  return hd;
}

int MerlThetaHalfIndex(double theta_h) {
  if (theta_h <= 0.0) return 0;
  const double theta_half_deg = theta_h / (kPi / 2.0) * kMerlThetaH;
  const int ret = static_cast<int>(std::sqrt(theta_half_deg * kMerlThetaH));
  return std::clamp(ret, 0, kMerlThetaH - 1);
}

int MerlThetaDiffIndex(double theta_d) {
  const int tmp = static_cast<int>(theta_d / (kPi * 0.5) * kMerlThetaD);
  return std::clamp(tmp, 0, kMerlThetaD - 1);
}

int MerlPhiDiffIndex(double phi_d) {
  // Reciprocity: the BRDF is unchanged under phi_d -> phi_d + pi.
  if (phi_d < 0.0) phi_d += kPi;
  const int tmp = static_cast<int>(phi_d / kPi * kMerlPhiD);
  return std::clamp(tmp, 0, kMerlPhiD - 1);
}

int MerlIndex(double theta_h, double theta_d, double phi_d) {
  return MerlPhiDiffIndex(phi_d) + MerlThetaDiffIndex(theta_d) * kMerlPhiD +
         MerlThetaHalfIndex(theta_h) * kMerlPhiD * kMerlThetaD;
}

MerlHalfDiff MerlBinCentre(int ih, int id, int ip) {
  const double u = (ih + 0.5) / kMerlThetaH;
  return {u * u * kPi / 2.0, 0.0, (id + 0.5) * kPi / 2.0 / kMerlThetaD,
          (ip + 0.5) * kPi / kMerlPhiD};
}

void MerlHalfDiffToVectors(double theta_h, double theta_d, double phi_d, Vec3* in, Vec3* out) {
  const Vec3 diff{std::sin(theta_d) * std::cos(phi_d), std::sin(theta_d) * std::sin(phi_d),
                  std::cos(theta_d)};
  *in = RotateVector(diff, Vec3{0.0, 1.0, 0.0}, theta_h);
  const Vec3 half{std::sin(theta_h), 0.0, std::cos(theta_h)};
  *out = half * (2.0 * half.Dot(*in)) - *in;
}

std::vector<double> GenerateMerlData(
    const std::function<std::array<double, 3>(const Vec3& in, const Vec3& out)>& f_r) {
  std::vector<double> data(3 * static_cast<size_t>(kMerlSize));
  for (int ih = 0; ih < kMerlThetaH; ++ih) {
    for (int id = 0; id < kMerlThetaD; ++id) {
      for (int ip = 0; ip < kMerlPhiD; ++ip) {
        const MerlHalfDiff c = MerlBinCentre(ih, id, ip);
        Vec3 in, out;
        MerlHalfDiffToVectors(c.theta_h, c.theta_d, c.phi_d, &in, &out);
        const int index = ip + id * kMerlPhiD + ih * kMerlPhiD * kMerlThetaD;
        const bool below = in.z <= 0 || out.z <= 0;
        const std::array<double, 3> f = below ? std::array<double, 3>{} : f_r(in, out);
        for (int ch = 0; ch < 3; ++ch) {
          data[ch * static_cast<size_t>(kMerlSize) + index] = below ? -1.0 : f[ch] / kMerlScale[ch];
        }
      }
    }
  }
  return data;
}

absl::Status WriteMerlFile(const std::string& path, const std::array<int32_t, 3>& dims,
                           const std::vector<double>& data) {
  std::ofstream out(path, std::ios::binary);
  if (!out) return absl::InvalidArgumentError(absl::StrCat("cannot write MERL file '", path, "'"));
  out.write(reinterpret_cast<const char*>(dims.data()), sizeof(int32_t) * 3);
  out.write(reinterpret_cast<const char*>(data.data()),
            static_cast<std::streamsize>(data.size() * sizeof(double)));
  if (!out) return absl::InvalidArgumentError(absl::StrCat("error writing MERL file '", path, "'"));
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<MerlBrdf>> LoadMerlBrdf(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf 'merl': '", path, "' is a folder, not a MERL file"));
  }
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf 'merl': cannot open '", path, "' (missing or unreadable file)"));
  }
  const std::streamoff size = in.tellg();
  in.seekg(0);
  int32_t dims[3] = {};
  in.read(reinterpret_cast<char*>(dims), sizeof(dims));
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf 'merl': '", path, "' is too short for the 12-byte header"));
  }
  if (dims[0] != kMerlThetaH || dims[1] != kMerlThetaD || dims[2] != kMerlPhiD) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf 'merl': '", path, "' has dims ", dims[0], " x ", dims[1], " x ", dims[2],
                     "; MERL isotropic files must be 90 x 90 x 180 (theta_h, theta_d, phi_d)"));
  }
  const std::streamoff expected =
      12 + 3 * static_cast<std::streamoff>(kMerlSize) * static_cast<std::streamoff>(sizeof(double));
  if (size != expected) {
    return absl::InvalidArgumentError(absl::StrCat("brdf 'merl': '", path, "' has ", size,
                                                   " bytes; expected ", expected,
                                                   " (header + 3 x 90*90*180 doubles)"));
  }
  std::vector<double> data(3 * static_cast<size_t>(kMerlSize));
  in.read(reinterpret_cast<char*>(data.data()),
          static_cast<std::streamsize>(data.size() * sizeof(double)));
  if (!in)
    return absl::InvalidArgumentError(absl::StrCat("brdf 'merl': read error in '", path, "'"));
  return std::make_unique<MerlBrdf>(std::move(data), path);
}

std::array<double, 3> MerlBrdf::Lookup(double theta_in, double phi_in, double theta_out,
                                       double phi_out) const {
  const MerlHalfDiff hd = MerlStdCoordsToHalfDiff(theta_in, phi_in, theta_out, phi_out);
  const int ind = MerlIndex(hd.theta_h, hd.theta_d, hd.phi_d);
  std::array<double, 3> rgb;
  for (int c = 0; c < 3; ++c) {
    rgb[c] = std::max(0.0, data_[c * static_cast<size_t>(kMerlSize) + ind] * kMerlScale[c]);
  }
  return rgb;
}

std::array<double, 3> MerlBrdf::LookupVectors(const Vec3& in, const Vec3& out) const {
  if (in.z <= 0 || out.z <= 0) return {0.0, 0.0, 0.0};
  return Lookup(std::acos(std::min(1.0, in.z)), std::atan2(in.y, in.x),
                std::acos(std::min(1.0, out.z)), std::atan2(out.y, out.x));
}

double MerlBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const {
  Vec3 t, b;
  TangentFrame(n, &t, &b);
  const Vec3 in{w.Dot(t), w.Dot(b), w.Dot(n)};
  const Vec3 out{v.Dot(t), v.Dot(b), v.Dot(n)};
  if (in.z <= 0) return 0.0;
  return LookupVectors(in, out)[c] * in.z;
}

void MerlBrdf::ReparamTransferAll(double theta_i, double theta_o, double phi, double* out) const {
  const ReparamGeometry g = MakeReparamGeometry(ReparamKind::kReflection, theta_i, theta_o, phi);
  // Tangent frame of n = (sin(t_o/2), 0, cos(t_o/2)): t = (cos, 0, -sin), b = +y.
  const Vec3 t{g.n.z, 0.0, -g.n.x};
  const Vec3 in{g.w.Dot(t), g.w.y, g.w.Dot(g.n)};
  const Vec3 o{g.v.Dot(t), g.v.y, g.v.Dot(g.n)};
  if (in.z <= 0) {
    out[0] = out[1] = out[2] = 0.0;
    return;
  }
  const std::array<double, 3> f = LookupVectors(in, o);
  for (int c = 0; c < 3; ++c) out[c] = f[c] * in.z;
}

double MerlBrdf::ReparamTransfer(double theta_i, double theta_o, double phi, int c) const {
  double rgb[3];
  ReparamTransferAll(theta_i, theta_o, phi, rgb);
  return rgb[c];
}

}  // namespace shrm
