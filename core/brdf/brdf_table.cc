#include "core/brdf/brdf_table.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"

namespace shrm {
namespace {

constexpr char kMagic[8] = {'S', 'H', 'R', 'M', 'B', 'R', 'D', 'F'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 8 + 7 * 4;

absl::Status CheckDims(const BrdfTableData& t) {
  const auto bad = [](int n) { return n < 1 || n > kMaxBrdfTableDim; };
  if (t.channels < 1 || t.channels > 4) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table: channels = ", t.channels, " is out of range [1, 4]"));
  }
  if (bad(t.n_theta_i) || bad(t.n_theta_o) || bad(t.n_phi)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "brdf table: grid ", t.n_theta_i, " x ", t.n_theta_o, " x ", t.n_phi,
        " out of range: n_theta_i, n_theta_o, n_phi must be in [1, ", kMaxBrdfTableDim, "]"));
  }
  return absl::OkStatus();
}

size_t ValueCount(const BrdfTableData& t) {
  return static_cast<size_t>(t.n_theta_i) * t.n_theta_o * t.n_phi * t.channels;
}

// Cell-centred index and fraction of angle x in [0, pi] on n nodes: x = pi (j + 1/2) / n.
void Locate(double x, int n, int* j0, double* frac) {
  const double u = std::clamp(x, 0.0, kPi) * n / kPi - 0.5;
  const double f = std::floor(u);
  *j0 = std::min(static_cast<int>(f), n - 1);
  *frac = u - *j0;
}

// Continues a theta index through the poles: returns the index in [0, n) and flips `flip`.
int WrapTheta(int j, int n, bool* flip) {
  if (j < 0) {
    *flip = !*flip;
    return -1 - j;
  }
  if (j >= n) {
    *flip = !*flip;
    return 2 * n - 1 - j;
  }
  return j;
}

}  // namespace

absl::StatusOr<BrdfTableData> SampleBrdfTable(const Brdf& brdf, int n_theta_i, int n_theta_o,
                                              int n_phi) {
  BrdfTableData t;
  t.channels = brdf.channels();
  t.reparam = brdf.reparam();
  t.clipped_at_normal_horizon = brdf.clipped_at_normal_horizon();
  t.n_theta_i = n_theta_i;
  t.n_theta_o = n_theta_o;
  t.n_phi = n_phi;
  if (absl::Status s = CheckDims(t); !s.ok()) return s;
  t.values.resize(ValueCount(t));
  for (int i = 0; i < n_theta_i; ++i) {
    for (int o = 0; o < n_theta_o; ++o) {
      for (int k = 0; k < n_phi; ++k) {
        brdf.ReparamTransferAll(kPi * (i + 0.5) / n_theta_i, kPi * (o + 0.5) / n_theta_o,
                                kPi * (k + 0.5) / n_phi, &t.values[t.Index(i, o, k, 0)]);
      }
    }
  }
  return t;
}

absl::Status WriteBrdfTable(const std::string& path, const BrdfTableData& t) {
  if (absl::Status s = CheckDims(t); !s.ok()) return s;
  if (t.values.size() != ValueCount(t)) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table: ", t.values.size(), " values, the header needs ", ValueCount(t)));
  }
  std::ofstream out(path, std::ios::binary);
  if (!out) return absl::InvalidArgumentError(absl::StrCat("cannot write brdf table '", path, "'"));
  const uint32_t header[7] = {kVersion,
                              static_cast<uint32_t>(t.channels),
                              t.reparam == ReparamKind::kTangent ? 1u : 0u,
                              t.clipped_at_normal_horizon ? 1u : 0u,
                              static_cast<uint32_t>(t.n_theta_i),
                              static_cast<uint32_t>(t.n_theta_o),
                              static_cast<uint32_t>(t.n_phi)};
  out.write(kMagic, 8);
  out.write(reinterpret_cast<const char*>(header), sizeof(header));
  out.write(reinterpret_cast<const char*>(t.values.data()),
            static_cast<std::streamsize>(t.values.size() * sizeof(double)));
  if (!out)
    return absl::InvalidArgumentError(absl::StrCat("error writing brdf table '", path, "'"));
  return absl::OkStatus();
}

absl::StatusOr<BrdfTableData> ReadBrdfTable(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table '", path, "': is a folder, not an SHRMBRDF file"));
  }
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table: cannot open '", path, "' (missing or unreadable file)"));
  }
  const std::streamoff size = in.tellg();
  in.seekg(0);
  char magic[8] = {};
  uint32_t header[7] = {};
  in.read(magic, 8);
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  if (!in || std::memcmp(magic, kMagic, 8) != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table '", path, "': not an SHRMBRDF file (bad magic or short header)"));
  }
  if (header[0] != kVersion) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table '", path, "': version ", header[0], " unsupported (expected 1)"));
  }
  if (header[2] > 1 || header[3] > 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table '", path, "': reparam must be 0 or 1 and flags 0 or 1, got ",
                     header[2], " and ", header[3]));
  }
  BrdfTableData t;
  const auto to_int = [](uint32_t x) { return x > 1u << 30 ? -1 : static_cast<int>(x); };
  t.channels = to_int(header[1]);
  t.reparam = header[2] == 1 ? ReparamKind::kTangent : ReparamKind::kReflection;
  t.clipped_at_normal_horizon = header[3] == 1;
  t.n_theta_i = to_int(header[4]);
  t.n_theta_o = to_int(header[5]);
  t.n_phi = to_int(header[6]);
  if (absl::Status s = CheckDims(t); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("'", path, "': ", s.message()));
  }
  const size_t count = ValueCount(t);
  if (static_cast<size_t>(size) != kHeaderBytes + count * sizeof(double)) {
    return absl::InvalidArgumentError(
        absl::StrCat("brdf table '", path, "': file has ", size, " bytes, the header (",
                     t.n_theta_i, " x ", t.n_theta_o, " x ", t.n_phi, " x ", t.channels, ") needs ",
                     kHeaderBytes + count * sizeof(double)));
  }
  t.values.resize(count);
  in.read(reinterpret_cast<char*>(t.values.data()),
          static_cast<std::streamsize>(count * sizeof(double)));
  if (!in) return absl::InvalidArgumentError(absl::StrCat("brdf table '", path, "': read error"));
  for (double x : t.values) {
    if (!std::isfinite(x)) {
      return absl::InvalidArgumentError(
          absl::StrCat("brdf table '", path, "': contains a non-finite value"));
    }
  }
  return t;
}

absl::StatusOr<std::unique_ptr<TableBrdf>> LoadBrdfTable(const std::string& path) {
  absl::StatusOr<BrdfTableData> t = ReadBrdfTable(path);
  if (!t.ok()) return t.status();
  return std::make_unique<TableBrdf>(*std::move(t), path);
}

BrdfBandwidthHint TableBrdf::bandwidth_hint() const {
  return {std::clamp(table_.n_theta_i / 3, 16, 96), std::clamp(table_.n_theta_o / 4, 4, 12)};
}

double TableBrdf::ReparamTransfer(double theta_i, double theta_o, double phi, int c) const {
  if (table_.clipped_at_normal_horizon && table_.reparam == ReparamKind::kReflection) {
    const double nw = std::cos(theta_i) * std::cos(0.5 * theta_o) +
                      std::sin(theta_i) * std::sin(0.5 * theta_o) * std::cos(phi);
    if (nw <= 0) return 0.0;
  }
  phi = std::fmod(std::abs(phi), 2.0 * kPi);
  if (phi > kPi) phi = 2.0 * kPi - phi;
  int i0, o0;
  double fi, fo;
  Locate(theta_i, table_.n_theta_i, &i0, &fi);
  Locate(theta_o, table_.n_theta_o, &o0, &fo);
  // kReflection: theta_o' = pi (V = -R) is no pole of the table's function (its limit depends on
  // the direction of approach, i.e. on phi), so beyond the last node the values are extrapolated
  // linearly from the last two nodes of the same (theta_i', phi) instead of continued through it
  // (which averaged over phi: the normal variable's equator values, taken there, were wrong).
  const bool extrapolate = table_.reparam == ReparamKind::kReflection &&
                           o0 == table_.n_theta_o - 1 && table_.n_theta_o >= 2;
  if (extrapolate) {
    o0 = table_.n_theta_o - 2;
    fo += 1.0;  // weights 1 - fo < 0 and fo > 1 on the last two nodes
  }
  double sum = 0;
  for (int a = 0; a < 2; ++a) {
    for (int b = 0; b < 2; ++b) {
      const double weight = (a ? fi : 1.0 - fi) * (b ? fo : 1.0 - fo);
      if (weight == 0) continue;
      bool flip = false;
      const int i = WrapTheta(i0 + a, table_.n_theta_i, &flip);
      const int o = WrapTheta(o0 + b, table_.n_theta_o, &flip);
      int k0;
      double fk;
      Locate(flip ? kPi - phi : phi, table_.n_phi, &k0, &fk);
      bool unused = false;
      const int k_lo = WrapTheta(k0, table_.n_phi, &unused);
      const int k_hi = WrapTheta(k0 + 1, table_.n_phi, &unused);
      sum += weight * ((1.0 - fk) * table_.values[table_.Index(i, o, k_lo, c)] +
                       fk * table_.values[table_.Index(i, o, k_hi, c)]);
    }
  }
  return extrapolate ? std::max(sum, 0.0) : sum;
}

double TableBrdf::Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const {
  if (table_.clipped_at_normal_horizon && table_.reparam == ReparamKind::kReflection &&
      (n.Dot(w) <= 0 || n.Dot(v) <= 0)) {
    return 0.0;
  }
  double ti, to, phi;
  ReparamAngles(table_.reparam, n, v, w, &ti, &to, &phi);
  return ReparamTransfer(ti, to, phi, c);
}

}  // namespace shrm
