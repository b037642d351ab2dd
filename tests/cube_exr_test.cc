// Multi-part cube EXR container: round trip (float and half), attributes, atomic writes, and
// rejection of files that are not six-part cubes.
#include "core/io/cube_exr.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace fs = std::filesystem;

constexpr double kHalfTol = 1e-3;  // half floats keep 11 significant bits (relative 4.9e-4)

CubeExr MakeCube(int size, int groups) {
  CubeExr c;
  c.face_size = size;
  for (int g = 0; g < groups; ++g) c.group_names.push_back("Y_" + std::to_string(g));
  c.data.resize(c.size());
  for (size_t i = 0; i < c.data.size(); ++i) c.data[i] = std::sin(0.37 * i) * (1 + i % 7);
  c.attributes["shrm:kind"] = "global";
  c.attributes["shrm:brdf"] = "phong:s=32";
  return c;
}

std::string Temp(const std::string& name) { return testing::UniqueTempPath("cube_exr_" + name); }

TEST(CubeExrTest, FloatRoundTripIsExact) {
  const CubeExr c = MakeCube(5, 4);
  const std::string path = Temp("float.exr");
  ASSERT_TRUE(WriteCubeExr(path, c).ok());
  auto back = ReadCubeExr(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->face_size, 5);
  EXPECT_EQ(back->group_names, c.group_names);
  EXPECT_EQ(back->data, c.data);
  EXPECT_EQ(back->attributes.at("shrm:kind"), "global");
  EXPECT_EQ(back->attributes.at("shrm:brdf"), "phong:s=32");
  fs::remove(path);
}

// A cube of several of the streamed writer's ~1 MB pieces (2.9 MB of values), given as a
// separate span: the file WriteCubeExr streams is EncodeCubeExr's bytes, and OpenEXR reads it
// back exactly.
TEST(CubeExrTest, StreamedFileIsTheEncodedBytesAndReadsBack) {
  CubeExr layout = MakeCube(64, 10);
  const std::vector<float> values = std::move(layout.data);
  layout.data.clear();
  const std::string path = Temp("streamed.exr");
  ASSERT_TRUE(WriteCubeExr(path, layout, values).ok());
  const absl::StatusOr<std::string> encoded = EncodeCubeExr(layout, path, values);
  ASSERT_TRUE(encoded.ok()) << encoded.status();
  std::ifstream in(path, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(file.size(), encoded->size());
  EXPECT_TRUE(file == *encoded);
  auto back = ReadCubeExr(path);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->data, values);
  size_t pieces = 0, total = 0, sunk = 0;
  ASSERT_TRUE(EncodeCubeExrTo(
                  layout, path, values,
                  [&](std::string_view piece) {
                    ++pieces;
                    sunk += piece.size();
                  },
                  &total)
                  .ok());
  EXPECT_GE(pieces, 4u);  // the header and at least three runs of lines
  EXPECT_EQ(sunk, total);
  EXPECT_EQ(total, encoded->size());
  fs::remove(path);
}

TEST(CubeExrTest, HalfRoundTripIsClose) {
  CubeExr c = MakeCube(3, 2);
  c.half = true;
  const std::string path = Temp("half.exr");
  const absl::Status written = WriteCubeExr(path, c);
  ASSERT_TRUE(written.ok()) << written;
  auto back = ReadCubeExr(path);
  ASSERT_TRUE(back.ok()) << back.status();
  for (size_t i = 0; i < c.data.size(); ++i)
    EXPECT_NEAR(back->data[i], c.data[i], kHalfTol * std::abs(c.data[i]) + 1e-7);
  fs::remove(path);
}

TEST(CubeExrTest, InconsistentCubeIsRejectedAndNothingIsWritten) {
  CubeExr c = MakeCube(4, 2);
  c.data.pop_back();
  const std::string path = Temp("bad.exr");
  EXPECT_EQ(WriteCubeExr(path, c).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(path));
}

TEST(CubeExrTest, UnwritableDestinationFailsCleanly) {
  const CubeExr c = MakeCube(2, 1);
  const absl::Status s = WriteCubeExr("/nonexistent-dir/out.exr", c);
  EXPECT_FALSE(s.ok());
  EXPECT_NE(s.message().find("/nonexistent-dir/out.exr"), std::string::npos);
}

TEST(CubeExrTest, OrdinaryImageIsNotACube) {
  Image img;
  img.width = 8;
  img.height = 4;
  img.channels = 3;
  img.pixels.assign(8 * 4 * 3, 1.0f);
  const std::string path = Temp("latlong.exr");
  ASSERT_TRUE(WriteExr(path, img).ok());
  const absl::Status s = ReadCubeExr(path).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  // It says what the file is not, and what it has (`shrm info map.exr`: "has fewer than 6 parts").
  EXPECT_NE(s.message().find("latlong.exr: not a cube file: it has 1 part, a cube file"),
            std::string::npos)
      << s;
  fs::remove(path);
}

TEST(CubeExrTest, TruncatedFileFailsCleanly) {
  const CubeExr c = MakeCube(16, 3);
  const std::string path = Temp("trunc.exr");
  ASSERT_TRUE(WriteCubeExr(path, c).ok());
  fs::resize_file(path, fs::file_size(path) / 2);
  EXPECT_FALSE(ReadCubeExr(path).ok());
  fs::remove(path);
}

TEST(CubeExrTest, AttributesTheWriterOwnsAreRefused) {
  CubeExr c = MakeCube(2, 1);
  c.attributes["name"] = "not a face";
  const absl::StatusOr<std::string> bytes = EncodeCubeExr(c, "cube.exr");
  EXPECT_EQ(bytes.status().code(), absl::StatusCode::kInvalidArgument) << bytes.status();
  EXPECT_NE(bytes.status().message().find("'name'"), absl::string_view::npos) << bytes.status();
}

}  // namespace
}  // namespace shrm
