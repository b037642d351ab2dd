// SHRM file: round trip of a cube with its convention attributes, channel naming independent of
// the EXR channel order, and clear errors for files that are not SHRMs.
#include "core/shrm/shrm_file.h"

#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/io/cube_exr.h"
#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace fs = std::filesystem;

std::string Temp(const std::string& name) { return testing::UniqueTempPath("shrm_file_" + name); }

ShrmCube MakeCube(int pmax) {
  ShrmCube c;
  c.kind = ShrmKind::kLocal;
  c.face_size = 3;
  c.pmax = pmax;
  c.data.resize(c.size());
  for (size_t i = 0; i < c.data.size(); ++i) c.data[i] = std::cos(0.11 * i) * (i % 5 + 1);
  return c;
}

// Writes `c` as an SHRM file whose convention attributes `edit` changes first, and reads it back.
absl::StatusOr<ShrmFile> WriteEdited(
    const std::string& path, const ShrmCube& c,
    const std::function<void(std::map<std::string, std::string>&)>& edit) {
  CubeExr exr;
  exr.face_size = c.face_size;
  for (int p = 0; p <= c.pmax; ++p)
    for (int q = -p; q <= p; ++q) exr.group_names.push_back(ShrmChannelGroup(p, q));
  exr.attributes = ShrmConventionAttributes(c);
  edit(exr.attributes);
  exr.data = c.data;
  EXPECT_TRUE(WriteCubeExr(path, exr).ok());
  return ReadShrmFile(path);
}

TEST(ShrmFileTest, RoundTripKeepsEveryCoefficientInPlace) {
  // P = 11: channel names such as Y_2_-2 / Y_2_-1 and Y_10_* / Y_1_* sort differently from
  // ShIndex order, so this checks that readers map channels by name.
  const ShrmCube c = MakeCube(11);
  const std::string path = Temp("p11.shrm.exr");
  ASSERT_TRUE(WriteShrmFile(path, c, {{"shrm:brdf", "microfacet:sigma=0.2"}}).ok());
  auto back = ReadShrmFile(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->cube.kind, ShrmKind::kLocal);
  EXPECT_EQ(back->cube.pmax, 11);
  EXPECT_EQ(back->cube.face_size, 3);
  EXPECT_EQ(back->cube.data, c.data);
  EXPECT_EQ(back->attributes.at("shrm:brdf"), "microfacet:sigma=0.2");
  EXPECT_EQ(back->attributes.at("shrm:format"), kShrmFormatTag);
  fs::remove(path);
}

// shrm:view_variable: "normal" read back as the normal variable; a file without the attribute
// (written before it existed) is in the view; anything else, or "normal" on a tangent-indexed
// cube, is refused by name.
TEST(ShrmFileTest, ViewVariableRoundTripsAndOldFilesAreInTheView) {
  ShrmCube c = MakeCube(2);
  c.view = ViewVariable::kNormal;
  const std::string path = Temp("normal.shrm.exr");
  ASSERT_TRUE(WriteShrmFile(path, c, {}).ok());
  auto back = ReadShrmFile(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->cube.view, ViewVariable::kNormal);
  EXPECT_EQ(back->attributes.at("shrm:view_variable"), "normal");
  EXPECT_NE(back->attributes.at("shrm:eval").find("N = (R + V)/|R + V|"), std::string::npos);
  fs::remove(path);

  auto write_with = [&](const char* value, const char* index) {
    return WriteEdited(path, c, [&](std::map<std::string, std::string>& a) {
      a["shrm:index"] = index;
      if (value == nullptr) {
        a.erase("shrm:view_variable");
      } else {
        a["shrm:view_variable"] = value;
      }
    });
  };
  auto old = write_with(nullptr, "reflection");
  ASSERT_TRUE(old.ok()) << old.status();
  EXPECT_EQ(old->cube.view, ViewVariable::kView);
  for (const auto& [value, index] :
       {std::pair{"halfway", "reflection"}, std::pair{"normal", "tangent"}}) {
    auto bad = write_with(value, index);
    EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument) << value << " " << index;
    EXPECT_NE(bad.status().message().find("shrm:view_variable"), std::string::npos) << bad.status();
  }
  fs::remove(path);
}

// The Fresnel table (brdf_coefficients.h) of a normal-variable cube: bit for bit through the
// file (its values are floats printed with 9 digits), the evaluation's factor with it; a table
// of the wrong size, a non-positive value or a table on a view-variable cube is refused by name.
TEST(ShrmFileTest, FresnelTableRoundTripsAndBadTablesAreRefused) {
  ShrmCube c = MakeCube(2);
  c.view = ViewVariable::kNormal;
  for (int k = 0; k <= kFresnelIntervals; ++k)
    c.fresnel.push_back(static_cast<float>(0.04 + 0.96 * std::pow(k / 128.0, 5)));
  const std::string path = Temp("fresnel.shrm.exr");
  ASSERT_TRUE(WriteShrmFile(path, c, {}).ok());
  auto back = ReadShrmFile(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->cube.fresnel, c.fresnel);
  EXPECT_NE(back->attributes.at("shrm:eval").find("shrm:fresnel"), std::string::npos);
  EXPECT_EQ(ShrmFresnel(back->cube, 1.0, 2), c.fresnel[0]);
  EXPECT_EQ(ShrmFresnel(back->cube, 0.0, 0), c.fresnel[kFresnelIntervals]);
  ShrmCube plain = MakeCube(2);
  EXPECT_EQ(ShrmFresnel(plain, 0.3, 0), 1.0);

  // Conventions 4: the view variable carries the table too (its argument N.V = |R + V| / 2).
  ShrmCube v = c;
  v.view = ViewVariable::kView;
  ASSERT_TRUE(WriteShrmFile(path, v, {}).ok());
  back = ReadShrmFile(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->cube.view, ViewVariable::kView);
  EXPECT_EQ(back->cube.fresnel, c.fresnel);
  EXPECT_NE(back->attributes.at("shrm:eval").find("|R + V| / 2 (view)"), std::string::npos);

  auto write_with = [&](const std::string& table, const char* view, bool tangent = false) {
    return WriteEdited(path, c, [&](std::map<std::string, std::string>& a) {
      a["shrm:fresnel"] = table;
      a["shrm:view_variable"] = view;
      if (tangent) a["shrm:index"] = "tangent";
    });
  };
  std::string ones = absl::StrCat(kFresnelIntervals, " 1");
  for (int k = 0; k <= kFresnelIntervals; ++k) ones += " 1";
  ASSERT_TRUE(write_with(ones, "normal").ok());
  ASSERT_TRUE(write_with(ones, "view").ok());
  // A tangent-indexed SHRM (Kajiya-Kay) has no mirror configuration: no table.
  auto tangent = write_with(ones, "view", true);
  EXPECT_EQ(tangent.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(tangent.status().message().find("shrm:fresnel"), std::string::npos) << tangent.status();
  for (const auto& [table, view] :
       {std::pair{ones + " 1", "normal"},
        std::pair{absl::StrCat(kFresnelIntervals, " 2", ones.substr(5)), "normal"},
        std::pair{absl::StrCat(ones.substr(0, ones.size() - 1), "0"), "normal"},
        std::pair{absl::StrCat(ones.substr(0, ones.size() - 1), "x"), "normal"},
        std::pair{std::string("64 1 1 1"), "normal"}}) {
    auto bad = write_with(table, view);
    EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument) << table;
    EXPECT_NE(bad.status().message().find("shrm:fresnel"), std::string::npos) << bad.status();
  }
  fs::remove(path);
}

TEST(ShrmFileTest, PlainCubeIsNotAnShrm) {
  CubeExr exr;
  exr.face_size = 2;
  exr.group_names = {"Y_0_0"};
  exr.data.assign(exr.size(), 1.0f);
  const std::string path = Temp("plain.exr");
  ASSERT_TRUE(WriteCubeExr(path, exr).ok());
  auto back = ReadShrmFile(path);
  EXPECT_EQ(back.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(back.status().message().find("shrm:format"), std::string::npos);
  fs::remove(path);
}

TEST(ShrmFileTest, AttributesNeedThePrefix) {
  EXPECT_EQ(WriteShrmFile(Temp("x.exr"), MakeCube(1), {{"brdf", "x"}}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(Temp("x.exr")));
}

}  // namespace
}  // namespace shrm
