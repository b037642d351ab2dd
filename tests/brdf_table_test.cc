// Tabulated rho-hat(theta_i', theta_o', phi) (core/brdf/brdf_table.h, "SHRMBRDF" v1): writer /
// reader round trip, trilinear lookups with the pole and azimuth continuations, errors on bad
// files, and SHRM coefficients (paper eq. 5.22) of a table vs the model it samples.
#include "core/brdf/brdf_table.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
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

std::string TempPath(const std::string& name) {
  return testing::UniqueTempPath("brdf_table_" + name);
}

// A smooth isotropic rho-hat without horizon, defined in reparameterized angles.
class SmoothReparamBrdf final : public Brdf {
 public:
  std::string spec() const override { return "smooth-reparam"; }
  double Transfer(const Vec3& n, const Vec3& v, const Vec3& w, int c) const override {
    double ti, to, phi;
    ReparamAngles(ReparamKind::kReflection, n, v, w, &ti, &to, &phi);
    return ReparamTransfer(ti, to, phi, c);
  }
  double ReparamTransfer(double ti, double to, double phi, int) const override {
    // A function on the sphere pair: exp(cos t_i) (1 + 0.3 cos t_o) + 0.2 (w_i'.w_o').
    const double dot = std::cos(ti) * std::cos(to) + std::sin(ti) * std::sin(to) * std::cos(phi);
    return std::exp(std::cos(ti)) * (1 + 0.3 * std::cos(to)) + 0.2 * dot;
  }
};

TEST(BrdfTableTest, WriteReadRoundTrip) {
  const GgxBrdf ggx(0.4, 0.3);
  auto table = SampleBrdfTable(ggx, 24, 12, 10);
  ASSERT_TRUE(table.ok()) << table.status();
  EXPECT_TRUE(table->clipped_at_normal_horizon);
  const std::string path = TempPath("table_ggx.bin");
  ASSERT_TRUE(WriteBrdfTable(path, *table).ok());
  auto brdf = ParseBrdfSpec("table:" + path);
  ASSERT_TRUE(brdf.ok()) << brdf.status();
  EXPECT_EQ((*brdf)->spec(), "table:" + path);
  EXPECT_EQ((*brdf)->channels(), 1);
  EXPECT_EQ((*brdf)->reparam(), ReparamKind::kReflection);
  EXPECT_TRUE((*brdf)->clipped_at_normal_horizon());
  const auto* t = dynamic_cast<const TableBrdf*>(brdf->get());
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->data().n_theta_i, 24);
  EXPECT_EQ(t->data().n_theta_o, 12);
  EXPECT_EQ(t->data().n_phi, 10);
  EXPECT_EQ(t->data().values, table->values);  // bit-exact
  // Lookups at the nodes return the nodes' values (and so the model there).
  for (int i = 0; i < 24; ++i) {
    for (int o = 0; o < 12; ++o) {
      for (int k = 0; k < 10; ++k) {
        const double ti = kPi * (i + 0.5) / 24, to = kPi * (o + 0.5) / 12,
                     phi = kPi * (k + 0.5) / 10;
        EXPECT_NEAR((*brdf)->ReparamTransfer(ti, to, phi, 0), ggx.ReparamTransfer(ti, to, phi, 0),
                    1e-12 * std::max(1.0, table->values[table->Index(i, o, k, 0)]));
      }
    }
  }
  std::remove(path.c_str());
}

TEST(BrdfTableTest, TrilinearLookupsAndContinuations) {
  const SmoothReparamBrdf smooth;
  auto data = SampleBrdfTable(smooth, 96, 48, 48);
  ASSERT_TRUE(data.ok());
  const TableBrdf table(*data, "memory");
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  double worst = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    // Anywhere, including within half a cell of the poles and of phi = 0, pi, and phi outside
    // [0, pi] (even, 2 pi periodic).
    const double ti = kPi * u(rng), to = kPi * u(rng), phi = 4 * kPi * (u(rng) - 0.5);
    worst = std::max(worst, std::abs(table.ReparamTransfer(ti, to, phi, 0) -
                                     smooth.ReparamTransfer(ti, to, phi, 0)));
  }
  // Trilinear error ~ h^2 / 8 max|f''| with h = pi / 48: ~1e-3 for this function.
  EXPECT_LT(worst, 2e-3);
  // At a pole the value does not depend on phi (the continuation through the pole cancels the
  // first-order term).
  for (double phi : {0.0, 0.7, 1.9, kPi}) {
    EXPECT_NEAR(table.ReparamTransfer(0.0, 1.0, phi, 0), smooth.ReparamTransfer(0.0, 1.0, 0, 0),
                2e-3);
    EXPECT_NEAR(table.ReparamTransfer(0.0, 1.0, phi, 0), table.ReparamTransfer(0.0, 1.0, 0.3, 0),
                1e-12);
  }
  // World-frame Transfer goes through ReparamAngles.
  const ReparamGeometry g = MakeReparamGeometry(ReparamKind::kReflection, 0.4, 1.1, 2.0);
  EXPECT_NEAR(table.Transfer(g.n, g.v, g.w, 0), table.ReparamTransfer(0.4, 1.1, 2.0, 0), 1e-12);
}

TEST(BrdfTableTest, AzimuthIndependentAndTangentTables) {
  const KajiyaKayBrdf kk(8);
  auto data = SampleBrdfTable(kk, 64, 64, 1);
  ASSERT_TRUE(data.ok());
  EXPECT_EQ(data->reparam, ReparamKind::kTangent);
  const std::string path = TempPath("table_kk.bin");
  ASSERT_TRUE(WriteBrdfTable(path, *data).ok());
  auto brdf = ParseBrdfSpec("table:" + path);
  ASSERT_TRUE(brdf.ok()) << brdf.status();
  EXPECT_EQ((*brdf)->reparam(), ReparamKind::kTangent);
  EXPECT_TRUE((*brdf)->azimuth_independent());
  auto a = ComputeBrdfCoefficients(kk, 12, 12);
  auto b = ComputeBrdfCoefficients(**brdf, 12, 12);
  ASSERT_TRUE(a.ok() && b.ok());
  double scale = 0, diff = 0;
  for (size_t i = 0; i < a->values.size(); ++i) {
    scale = std::max(scale, std::abs(a->values[i]));
    diff = std::max(diff, std::abs(a->values[i] - b->values[i]));
  }
  EXPECT_LT(diff, 5e-3 * scale);
  std::remove(path.c_str());
}

TEST(BrdfTableTest, CoefficientsFollowTheModel) {
  const MicrofacetBrdf model(0.3);
  auto data = SampleBrdfTable(model, 128, 48, 48);
  ASSERT_TRUE(data.ok());
  const TableBrdf table(*data, "memory");
  // Both view variables: the normal variable's extension takes the values at theta_o' -> pi
  // (V -> -R), where the lookup extrapolates from the last nodes (continuing through that end as
  // through a pole averaged them over phi: 10x the model's error in a prefilter, session 24).
  for (const ViewVariable view : {ViewVariable::kView, ViewVariable::kNormal}) {
    auto a = ComputeBrdfCoefficients(model, 12, 3, {}, view);
    auto b = ComputeBrdfCoefficients(table, 12, 3, {}, view);
    ASSERT_TRUE(a.ok() && b.ok());
    double scale = 0, diff = 0;
    for (size_t i = 0; i < a->values.size(); ++i) {
      scale = std::max(scale, std::abs(a->values[i]));
      diff = std::max(diff, std::abs(a->values[i] - b->values[i]));
    }
    std::printf(
        "microfacet table 128x48x48, %s variable: max coefficient difference / max = %.2e\n",
        ViewVariableName(view), diff / scale);
    // Trilinear interpolation of a lobe of width ~2 sigma on cells of pi/128: ~1e-3 (view,
    // 6.8e-4 measured). The normal variable adds the extrapolation over the last half cell of
    // theta_o' (pi/96) in its equator values: 5.4e-3 measured (8.1e-2 with the lookup continued
    // through theta_o' = pi as through a pole).
    EXPECT_LT(diff, (view == ViewVariable::kView ? 5e-3 : 1e-2) * scale) << ViewVariableName(view);
    if (view == ViewVariable::kView)
      EXPECT_NEAR(b->total_energy[0], a->total_energy[0], 5e-3 * a->total_energy[0]);
  }
}

TEST(BrdfTableTest, BadFilesAndTables) {
  const PhongBrdf phong(4);
  auto data = SampleBrdfTable(phong, 8, 4, 2);
  ASSERT_TRUE(data.ok());
  const std::string good = TempPath("table_good.bin");
  ASSERT_TRUE(WriteBrdfTable(good, *data).ok());
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const auto expect_error = [](const std::string& path, const std::string& needle) {
    const auto brdf = ParseBrdfSpec("table:" + path);
    ASSERT_FALSE(brdf.ok()) << needle;
    EXPECT_EQ(brdf.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(brdf.status().message().find(needle), std::string::npos) << brdf.status();
  };
  const auto write = [](const std::string& path, const std::string& contents) {
    std::ofstream(path, std::ios::binary).write(contents.data(), contents.size());
  };
  const std::string bad = TempPath("table_bad.bin");
  std::string b = bytes;
  b[0] = 'X';
  write(bad, b);
  expect_error(bad, "bad magic");
  b = bytes;
  b[8] = 2;  // version
  write(bad, b);
  expect_error(bad, "version 2");
  write(bad, bytes.substr(0, bytes.size() - 8));
  expect_error(bad, "bytes");
  b = bytes;
  std::memset(&b[8 + 4 * 4], 0, 4);  // n_theta_i = 0
  write(bad, b);
  expect_error(bad, "n_theta_i");
  b = bytes;
  const double nan = std::nan("");
  std::memcpy(&b[b.size() - 8], &nan, 8);
  write(bad, b);
  expect_error(bad, "non-finite");
  expect_error(TempPath("table_missing.bin"), "cannot open");
  // Writer checks.
  BrdfTableData wrong = *data;
  wrong.values.pop_back();
  EXPECT_EQ(WriteBrdfTable(bad, wrong).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(SampleBrdfTable(phong, 0, 4, 4).status().code(), absl::StatusCode::kInvalidArgument);
  std::remove(good.c_str());
  std::remove(bad.c_str());
}

}  // namespace
}  // namespace shrm
