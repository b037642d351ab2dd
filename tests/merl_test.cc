// MERL isotropic BRDF files (core/brdf/merl.h), read and looked up as MERL's BRDFRead.cpp. The
// real measurements are not available here: the tests generate MERL binaries from an analytic
// RGB GGX model and check that lookups reproduce the model within the table's quantization, and
// that the SHRM coefficients (paper eq. 5.22) of the table follow those of the model.
#include "core/brdf/merl.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_models.h"
#include "core/brdf/brdf_projection.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

// A bin-centre lookup returns exactly the stored model value (scale round trip: x / s * s).
constexpr double kBinCentreTol = 1e-12;
// Random lookups vs the model: the table is piecewise constant; for GGX alpha = 0.5 the
// measured RMS relative error (green, f_r > 0.05, both angles < 70 deg) is 1.1 %.
constexpr double kRandomLookupRmsTol = 0.03;

constexpr double kAlpha = 0.5;
constexpr double kF0[3] = {0.04, 0.5, 0.9};

std::array<double, 3> ModelRgb(const Vec3& in, const Vec3& out) {
  const Vec3 n{0, 0, 1};
  std::array<double, 3> f;
  for (int c = 0; c < 3; ++c) f[c] = GgxBrdf(kAlpha, kF0[c]).Evaluate(n, out, in);
  return f;
}

class MerlFileTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    path_ = new std::string(testing::UniqueTempPath("merl_ggx.binary"));
    ASSERT_TRUE(WriteMerlFile(*path_, {90, 90, 180}, GenerateMerlData(ModelRgb)).ok());
  }
  static void TearDownTestSuite() {
    std::remove(path_->c_str());
    delete path_;
  }
  static std::unique_ptr<Brdf> Load() {
    auto brdf = ParseBrdfSpec("merl:" + *path_);
    EXPECT_TRUE(brdf.ok()) << brdf.status();
    return brdf.ok() ? *std::move(brdf) : nullptr;
  }
  static std::string* path_;
};
std::string* MerlFileTest::path_ = nullptr;

Vec3 RotateZ(const Vec3& v, double a) {
  return {std::cos(a) * v.x - std::sin(a) * v.y, std::sin(a) * v.x + std::cos(a) * v.y, v.z};
}

TEST(MerlIndexTest, BRDFReadFormulas) {
  EXPECT_EQ(MerlThetaHalfIndex(0.0), 0);
  EXPECT_EQ(MerlThetaHalfIndex(-0.1), 0);
  EXPECT_EQ(MerlThetaHalfIndex(kPi / 2), 89);
  // sqrt mapping: bin i starts at theta_h = (i / 90)^2 pi / 2.
  for (int i : {1, 2, 10, 45, 89}) {
    const double start = (i / 90.0) * (i / 90.0) * kPi / 2;
    EXPECT_EQ(MerlThetaHalfIndex(start * (1 + 1e-9)), i);
    EXPECT_EQ(MerlThetaHalfIndex(start * (1 - 1e-9)), i - 1);
  }
  EXPECT_EQ(MerlThetaDiffIndex(kPi / 4 + 1e-9), 45);
  EXPECT_EQ(MerlThetaDiffIndex(kPi / 4 - 1e-9), 44);
  EXPECT_EQ(MerlThetaDiffIndex(kPi), 89);
  EXPECT_EQ(MerlThetaDiffIndex(-0.1), 0);
  EXPECT_EQ(MerlPhiDiffIndex(0.5 * kPi + 1e-9), 90);
  EXPECT_EQ(MerlPhiDiffIndex(-0.5 * kPi + 1e-9), 90);  // + pi (reciprocity fold)
  EXPECT_EQ(MerlPhiDiffIndex(kPi), 179);
  EXPECT_EQ(MerlIndex(0, 0, 0), 0);
  // Every bin centre maps to its own bin.
  for (int ih = 0; ih < kMerlThetaH; ++ih) {
    for (int id = 0; id < kMerlThetaD; id += 3) {
      for (int ip = 0; ip < kMerlPhiD; ip += 5) {
        const MerlHalfDiff c = MerlBinCentre(ih, id, ip);
        ASSERT_EQ(MerlIndex(c.theta_h, c.theta_d, c.phi_d), ip + id * 180 + ih * 180 * 90);
      }
    }
  }
}

TEST(MerlIndexTest, HalfDiffRoundTrip) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  for (int trial = 0; trial < 500; ++trial) {
    const double th = 0.5 * kPi * u(rng), td = 0.5 * kPi * u(rng);
    const double pd = kPi * (2 * u(rng) - 1), ph = kPi * (2 * u(rng) - 1);
    Vec3 in, out;
    MerlHalfDiffToVectors(th, td, pd, &in, &out);
    in = RotateZ(in, ph);
    out = RotateZ(out, ph);
    const MerlHalfDiff hd = MerlStdCoordsToHalfDiff(std::acos(in.z), std::atan2(in.y, in.x),
                                                    std::acos(out.z), std::atan2(out.y, out.x));
    EXPECT_NEAR(hd.theta_h, th, 1e-7);
    EXPECT_NEAR(hd.theta_d, td, 1e-7);
    if (th > 1e-6) {
      EXPECT_NEAR(std::remainder(hd.phi_h - ph, 2 * kPi), 0, 1e-7);
    }
    if (td > 1e-6 && th > 1e-6) {
      EXPECT_NEAR(std::remainder(hd.phi_d - pd, 2 * kPi), 0, 1e-7);
    }
  }
}

TEST_F(MerlFileTest, FileLayoutAndScales) {
  // Bin (ih, id, ip) = (3, 5, 7) of each channel, read straight from the file.
  std::ifstream in(*path_, std::ios::binary);
  int32_t dims[3];
  in.read(reinterpret_cast<char*>(dims), sizeof(dims));
  EXPECT_EQ(dims[0], 90);
  EXPECT_EQ(dims[1], 90);
  EXPECT_EQ(dims[2], 180);
  const int index = 7 + 5 * 180 + 3 * 180 * 90;
  const MerlHalfDiff c = MerlBinCentre(3, 5, 7);
  Vec3 vin, vout;
  MerlHalfDiffToVectors(c.theta_h, c.theta_d, c.phi_d, &vin, &vout);
  const std::array<double, 3> f = ModelRgb(vin, vout);
  const double scales[3] = {1.0 / 1500, 1.15 / 1500, 1.66 / 1500};
  for (int ch = 0; ch < 3; ++ch) {
    double stored;
    in.seekg(12 + (static_cast<std::streamoff>(ch) * kMerlSize + index) * 8);
    in.read(reinterpret_cast<char*>(&stored), 8);
    EXPECT_NEAR(stored * scales[ch], f[ch], 1e-12 * f[ch]) << ch;
  }
}

TEST_F(MerlFileTest, BinCentreLookupsReproduceTheModel) {
  const std::unique_ptr<Brdf> brdf = Load();
  ASSERT_NE(brdf, nullptr);
  EXPECT_EQ(brdf->channels(), 3);
  const auto* merl = dynamic_cast<const MerlBrdf*>(brdf.get());
  ASSERT_NE(merl, nullptr);
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(0, 1);
  int checked = 0;
  for (int ih = 0; ih < kMerlThetaH; ih += 4) {
    for (int id = 0; id < kMerlThetaD; id += 4) {
      for (int ip = 0; ip < kMerlPhiD; ip += 11) {
        const MerlHalfDiff c = MerlBinCentre(ih, id, ip);
        Vec3 in, out;
        MerlHalfDiffToVectors(c.theta_h, c.theta_d, c.phi_d, &in, &out);
        if (in.z <= 1e-3 || out.z <= 1e-3) continue;
        // Any phi_h: isotropic lookups ignore it.
        const double ph = 2 * kPi * u(rng);
        const std::array<double, 3> got = merl->LookupVectors(RotateZ(in, ph), RotateZ(out, ph));
        const std::array<double, 3> want = ModelRgb(in, out);
        for (int ch = 0; ch < 3; ++ch) {
          EXPECT_NEAR(got[ch], want[ch], kBinCentreTol * std::max(1.0, want[ch]));
        }
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST_F(MerlFileTest, RandomLookupsWithinQuantization) {
  const std::unique_ptr<Brdf> brdf = Load();
  ASSERT_NE(brdf, nullptr);
  const auto* merl = dynamic_cast<const MerlBrdf*>(brdf.get());
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  double sum_sq = 0;
  int count = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const auto dir = [&](double max_theta) {
      const double t = std::acos(1 - u(rng) * (1 - std::cos(max_theta))), p = 2 * kPi * u(rng);
      return Vec3{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
    };
    const Vec3 in = dir(70 * kPi / 180), out = dir(70 * kPi / 180);
    const std::array<double, 3> got = merl->LookupVectors(in, out);
    // Exactly the model at the centre of the query's bin.
    const MerlHalfDiff hd = MerlStdCoordsToHalfDiff(std::acos(in.z), std::atan2(in.y, in.x),
                                                    std::acos(out.z), std::atan2(out.y, out.x));
    const int index = MerlIndex(hd.theta_h, hd.theta_d, hd.phi_d);
    const int ih = index / (180 * 90), id = (index / 180) % 90, ip = index % 180;
    const MerlHalfDiff c = MerlBinCentre(ih, id, ip);
    Vec3 cin, cout;
    MerlHalfDiffToVectors(c.theta_h, c.theta_d, c.phi_d, &cin, &cout);
    if (cin.z > 0 && cout.z > 0) {
      const std::array<double, 3> centre = ModelRgb(cin, cout);
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(got[ch], centre[ch], kBinCentreTol * std::max(1.0, centre[ch]));
      }
    }
    // And close to the model at the query itself.
    const double want = ModelRgb(in, out)[1];
    if (want > 0.05) {
      sum_sq += (got[1] / want - 1) * (got[1] / want - 1);
      ++count;
    }
  }
  ASSERT_GT(count, 1000);
  const double rms = std::sqrt(sum_sq / count);
  std::printf("MERL(GGX alpha=0.5) random lookups: RMS relative error %.4f over %d queries\n", rms,
              count);
  EXPECT_LT(rms, kRandomLookupRmsTol);
}

TEST_F(MerlFileTest, TransferIsReciprocalAndClipped) {
  const std::unique_ptr<Brdf> brdf = Load();
  ASSERT_NE(brdf, nullptr);
  EXPECT_TRUE(brdf->clipped_at_normal_horizon());
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g;
  int same = 0, total = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Vec3 n = Vec3{g(rng), g(rng), g(rng)}.Normalized();
    const Vec3 v = Vec3{g(rng), g(rng), g(rng)}.Normalized();
    const Vec3 w = Vec3{g(rng), g(rng), g(rng)}.Normalized();
    if (n.Dot(w) <= 0 || n.Dot(v) <= 0) {
      if (n.Dot(w) <= 0) {
        EXPECT_EQ(brdf->Transfer(n, v, w, 0), 0.0);
      }
      continue;
    }
    ++total;
    // f_r(v, w) = f_r(w, v): the (theta_h, theta_d) bin is shared and phi_d folds by pi.
    const double a = brdf->Transfer(n, v, w, 2) / n.Dot(w);
    const double b = brdf->Transfer(n, w, v, 2) / n.Dot(v);
    if (std::abs(a - b) <= 1e-12 * std::max(1.0, a)) ++same;
  }
  // Rare mismatches: queries on a bin boundary can round to either side.
  EXPECT_GE(same, total - total / 100);
}

TEST_F(MerlFileTest, ReparamTransferEqualsTransferOfReconstructedGeometry) {
  const std::unique_ptr<Brdf> brdf = Load();
  ASSERT_NE(brdf, nullptr);
  std::mt19937_64 rng(6);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g;
  int same = 0, total = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const double ti = kPi * u(rng), to = 0.98 * kPi * u(rng), phi = 2 * kPi * u(rng);
    // Independent geometry: a random frame Q, pole R = Q e_z, N = normalize(R + V).
    const Mat3 q = Quaternion{g(rng), g(rng), g(rng), g(rng)}.ToMatrix();
    const double po = 2 * kPi * u(rng);
    const auto dir = [](double t, double p) {
      return Vec3{std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
    };
    const Vec3 r = q * Vec3{0, 0, 1}, v = q * dir(to, po), w = q * dir(ti, po + phi);
    const Vec3 n = (r + v).Normalized();
    double rgb[3];
    brdf->ReparamTransferAll(ti, to, phi, rgb);
    for (int c = 0; c < 3; ++c) {
      const double want = brdf->Transfer(n, v, w, c);
      ++total;
      if (std::abs(rgb[c] - want) <= 1e-12 * std::max(1.0, want)) ++same;
      EXPECT_EQ(brdf->ReparamTransfer(ti, to, phi, c), rgb[c]);
    }
  }
  // Different tangent frames: only lookups on a bin boundary may round differently.
  EXPECT_GE(same, total - total / 100);
}

// The model without the Fresnel normalization (brdf_coefficients.h): a table of samples has no
// Fresnel factor to divide out, so the model's coefficients are compared as rho-hat's own.
class WithoutFresnel final : public Brdf {
 public:
  explicit WithoutFresnel(const Brdf& b) : b_(b) {}
  std::string spec() const override { return b_.spec(); }
  int channels() const override { return b_.channels(); }
  ReparamKind reparam() const override { return b_.reparam(); }
  bool radially_symmetric() const override { return b_.radially_symmetric(); }
  bool clipped_at_normal_horizon() const override { return b_.clipped_at_normal_horizon(); }
  bool azimuth_independent() const override { return b_.azimuth_independent(); }
  BrdfBandwidthHint bandwidth_hint() const override { return b_.bandwidth_hint(); }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override {
    return b_.Transfer(n, v, w, c);
  }
  double ReparamTransfer(double ti, double to, double phi, int c) const override {
    return b_.ReparamTransfer(ti, to, phi, c);
  }
  void ReparamTransferAll(double ti, double to, double phi, double* out) const override {
    b_.ReparamTransferAll(ti, to, phi, out);
  }
  void ReparamTransferArc(double ti, double to, const ArcAzimuths& phi,
                          double* out) const override {
    b_.ReparamTransferArc(ti, to, phi, out);
  }

 private:
  const Brdf& b_;
};

TEST_F(MerlFileTest, CoefficientsFollowTheModel) {
  const std::unique_ptr<Brdf> brdf = Load();
  ASSERT_NE(brdf, nullptr);
  auto table = ComputeBrdfCoefficients(*brdf, 8, 2);
  ASSERT_TRUE(table.ok()) << table.status();
  ASSERT_EQ(table->channels, 3);
  for (int ch = 0; ch < 3; ++ch) {
    const GgxBrdf ggx(kAlpha, kF0[ch]);
    const WithoutFresnel model(ggx);
    auto exact = ComputeBrdfCoefficients(model, 8, 2);
    ASSERT_TRUE(exact.ok());
    ASSERT_TRUE(exact->fresnel.empty());
    ASSERT_TRUE(exact.ok());
    double scale = 0, diff = 0;
    for (int l = 0; l <= 8; ++l) {
      for (int p = 0; p <= 2; ++p) {
        for (int q = 0; q <= std::min(l, p); ++q) {
          scale = std::max(scale, std::abs(exact->at(l, p, q)));
          diff = std::max(diff, std::abs(exact->at(l, p, q) - table->at(l, p, q, ch)));
        }
      }
    }
    std::printf("MERL(GGX f0=%.2f) vs GGX: max coefficient difference / max = %.4f, energy %.4f\n",
                kF0[ch], diff / scale, table->total_energy[ch] / exact->total_energy[0]);
    // Piecewise-constant table, averaged by the integrals: measured <= 0.1 % of the largest
    // coefficient and <= 0.5 % in energy (grazing bins, f0 = 0.04).
    EXPECT_LT(diff, 0.01 * scale) << ch;
    EXPECT_NEAR(table->total_energy[ch] / exact->total_energy[0], 1.0, 0.02) << ch;
  }
}

TEST(MerlErrorsTest, BadFilesAreInvalidArgument) {
  const std::vector<double> data(3 * static_cast<size_t>(kMerlSize), 1.0);
  struct Case {
    std::string name;
    std::array<int32_t, 3> dims;
    size_t values;
    std::string needle;
  };
  const std::vector<Case> cases = {
      {"dims.binary", {90, 90, 360}, data.size(), "dims 90 x 90 x 360"},
      {"dims2.binary", {180, 90, 90}, data.size(), "must be 90 x 90 x 180"},
      {"short.binary", {90, 90, 180}, data.size() - 5, "bytes"},
      {"long.binary", {90, 90, 180}, data.size() + 1, "bytes"},
  };
  for (const Case& c : cases) {
    const std::string path = testing::UniqueTempPath("merl_" + c.name);
    ASSERT_TRUE(WriteMerlFile(path, c.dims,
                              std::vector<double>(data.begin(),
                                                  data.begin() + std::min(c.values, data.size())))
                    .ok());
    if (c.values > data.size()) {
      std::ofstream(path, std::ios::binary | std::ios::app).write("12345678", 8);
    }
    const auto brdf = ParseBrdfSpec("merl:" + path);
    ASSERT_FALSE(brdf.ok()) << c.name;
    EXPECT_EQ(brdf.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(brdf.status().message().find(c.needle), std::string::npos) << brdf.status();
    std::remove(path.c_str());
  }
  const auto missing = ParseBrdfSpec("merl:" + testing::UniqueTempPath("no_such_file.binary"));
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(missing.status().message().find("cannot open"), std::string::npos);
}

}  // namespace
}  // namespace shrm
