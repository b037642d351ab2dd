// The split of image I/O between OpenEXR / zlib (in every program) and the OpenImageIO /
// OpenColorIO module loaded on demand (core/io/image_module.h): each fast path gives what the
// third-party library gives, and a job on EXR files never loads the module.
//
// CTest runs every case in its own process (gtest_discover_tests), so a case that checks
// image_module::Loaded() sees only what it did itself.
#include "core/io/image_module.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "core/envmap/envmap.h"
#include "core/io/atomic_file.h"
#include "core/io/colour.h"
#include "core/io/image.h"
#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace fs = std::filesystem;

std::string SourcePath(const std::string& rel) { return std::string(SHRM_SOURCE_DIR) + "/" + rel; }

const image_module::Api& Module() {
  auto api = image_module::Get();
  EXPECT_TRUE(api.ok()) << api.status();
  return **api;
}

// The bundled maps and every EXR seed of the image fuzzer (scripts/make-fuzz-seeds.sh: each
// compression OpenEXR has, tiled, grey, RGBA, half and float, cube layouts).
std::vector<std::string> ExrFiles() {
  std::vector<std::string> files;
  for (const char* map : {"city", "courtyard", "forest", "interior"})
    files.push_back(SourcePath(std::string("data/envmaps/") + map + ".exr"));
  // A seed's first byte is the fuzzer's options; the file follows.
  for (const auto& e : fs::directory_iterator(SourcePath("fuzz/corpus/image"))) {
    if (e.path().extension() != ".exr") continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string path = testing::UniqueTempPath(e.path().filename().string());
    EXPECT_TRUE(WriteFileAtomically(path, std::string_view(bytes).substr(1)).ok());
    files.push_back(path);
  }
  return files;
}

// OpenEXR's reader (ReadImageRgb) gives the values OpenImageIO's reader gives, bit for bit,
// with the same header, channel choice and grey expansion.
TEST(ImageModuleTest, ExrReaderEqualsOpenImageIOOnEveryCompressionAndLayout) {
  const std::vector<std::string> files = ExrFiles();
  ASSERT_GE(files.size(), 20u);
  for (const std::string& path : files) {
    SCOPED_TRACE(path);
    auto ours = ReadImageRgb(path, {}, NonFinitePolicy::kReplaceZero);
    ASSERT_TRUE(ours.ok()) << ours.status();
    auto header = ProbeImage(path);
    ASSERT_TRUE(header.ok()) << header.status();
    ImageHeader theirs_header;
    theirs_header.format = "openexr";
    auto theirs = Module().read(path, {}, &theirs_header, /*unassociated_alpha=*/false);
    ASSERT_TRUE(theirs.ok()) << theirs.status();
    EXPECT_EQ(header->width, theirs_header.width);
    EXPECT_EQ(header->height, theirs_header.height);
    EXPECT_EQ(header->channels, theirs_header.channels);
    ASSERT_EQ(ours->width, theirs_header.width);
    ASSERT_EQ(ours->height, theirs_header.height);
    const int nc = theirs_header.channels;
    int64_t differ = 0;
    for (size_t p = 0; p < size_t{1} * ours->width * ours->height; ++p) {
      for (int c = 0; c < 3; ++c) {
        float v = (*theirs)[p * nc + (nc >= 3 ? c : 0)];
        if (!std::isfinite(v)) v = 0;
        differ += std::memcmp(&v, &ours->pixels[p * 3 + c], sizeof(float)) != 0;
      }
    }
    EXPECT_EQ(differ, 0);
    if (path.find("shrm_test_") != std::string::npos) fs::remove(path);  // a seed's copy
  }
}

// Our float EXR encodings (zip and uncompressed), read by OpenImageIO: the values and channel
// count come back exact; the uncompressed file holds every value's 4 bytes.
TEST(ImageModuleTest, EncodedExrReadsBackInOpenImageIO) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1e4f, 3.4e4f);
  for (ImageEncoding encoding : {ImageEncoding::kExrFloat, ImageEncoding::kExrFloatUncompressed}) {
    for (int channels = 1; channels <= 4; ++channels) {
      SCOPED_TRACE(::testing::Message()
                   << channels << " channels, encoding " << static_cast<int>(encoding));
      Image img;
      img.width = 13;
      img.height = 5;
      img.channels = channels;
      for (int i = 0; i < img.width * img.height * channels; ++i) img.pixels.push_back(u(rng));
      auto bytes = EncodeImage(img, encoding);
      ASSERT_TRUE(bytes.ok()) << bytes.status();
      if (encoding == ImageEncoding::kExrFloatUncompressed) {
        EXPECT_GT(bytes->size(), img.pixels.size() * sizeof(float));
      }
      const std::string path = testing::UniqueTempPath("encoded.exr");
      ASSERT_TRUE(WriteFileAtomically(path, *bytes).ok());
      ImageHeader header;
      header.format = "openexr";
      auto back = Module().read(path, {}, &header, /*unassociated_alpha=*/false);
      ASSERT_TRUE(back.ok()) << back.status();
      EXPECT_EQ(header.channels, channels);
      EXPECT_EQ(*back, img.pixels);
      fs::remove(path);
    }
  }
}

// Our PNG encoder, read by OpenImageIO (libpng): every byte comes back, for each channel count,
// on images whose rows make every filter type the best one somewhere (flat, ramps, noise).
TEST(ImageModuleTest, EncodedPngReadsBackInOpenImageIO) {
  std::mt19937 rng(11);
  for (int channels = 1; channels <= 4; ++channels) {
    for (auto [w, h] : {std::pair{1, 1}, std::pair{7, 3}, std::pair{64, 33}}) {
      SCOPED_TRACE(::testing::Message() << channels << " channels, " << w << " x " << h);
      Image img;
      img.width = w;
      img.height = h;
      img.channels = channels;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          for (int c = 0; c < channels; ++c) {
            int v = 0;
            switch (y % 4) {
              case 0:
                v = 200;
                break;  // flat
              case 1:
                v = (x * 9 + c * 40) % 256;
                break;  // ramp along x
              case 2:
                v = (y * 7 + x * 3) % 256;
                break;  // ramp along both
              default:
                v = static_cast<int>(rng() % 256);  // noise
            }
            img.pixels.push_back(v / 255.0f);
          }
        }
      }
      auto bytes = EncodeImage(img, ImageEncoding::kPng8);
      ASSERT_TRUE(bytes.ok()) << bytes.status();
      const std::string path = testing::UniqueTempPath("encoded.png");
      ASSERT_TRUE(WriteFileAtomically(path, *bytes).ok());
      ImageHeader header;
      header.format = "png";
      auto back = Module().read(path, {}, &header, /*unassociated_alpha=*/true);
      ASSERT_TRUE(back.ok()) << back.status();
      ASSERT_EQ(header.channels, channels);
      ASSERT_EQ(back->size(), img.pixels.size());
      int differ = 0;
      for (size_t i = 0; i < back->size(); ++i)
        differ += std::lround((*back)[i] * 255) != std::lround(img.pixels[i] * 255);
      EXPECT_EQ(differ, 0);
      fs::remove(path);
    }
  }
}

// The identity conversions answered without OpenColorIO (every name and alias of the built-in
// config, in other cases too, and names it lacks) give what OpenColorIO gives.
TEST(ImageModuleTest, BuiltinIdentityConversionsMatchOpenColorIO) {
  // Typed from data/ocio/config.ocio, not from the code's table.
  const std::vector<std::string> names = {
      "lin_rec709",   "linear_rec709", "lin_srgb",     "scene_linear_rec709",
      "LIN_REC709",   "lin_ap1",       "acescg",       "ACEScg",
      "lin_ap0",      "aces2065_1",    "ACES2065-1",   "lin_p3d65",
      "linear_p3d65", "cie_xyz_d65",   "srgb_texture", "srgb",
      "sRGB",         "srgb_tx",       "raw",          "none",
      "RAW",          "bogus"};
  const std::vector<float> sample = {0.25f, 0.5f, 2.0f, 0.0f, 1.0f, 34000.0f};
  for (const std::string& from : names) {
    for (const std::string& to : names) {
      SCOPED_TRACE(from + " -> " + to);
      std::vector<float> ours = sample, theirs = sample;
      const absl::Status a = ConvertColourSpace(std::span<float>(ours), from, to);
      const absl::Status b = Module().convert_colour_space(std::span<float>(theirs), from, to, "",
                                                           "<built-in>", BuiltinColourConfig());
      ASSERT_EQ(a.code(), b.code()) << a << " / " << b;
      EXPECT_EQ(ours, theirs);
    }
  }
}

// A job on EXR files (decode, colour, layout; EXR and PNG outputs) never loads the module; a
// PNG input does.
TEST(ImageModuleTest, AnExrJobNeverLoadsTheModule) {
  EnvMapOptions options;
  options.paths = {SourcePath("data/envmaps/courtyard.exr")};
  auto env = EnvMap::Load(options);
  ASSERT_TRUE(env.ok()) << env.status();
  Image small;
  small.width = 8;
  small.height = 4;
  small.channels = 3;
  small.pixels.assign(8 * 4 * 3, 0.25f);
  ASSERT_TRUE(EncodeImage(small, ImageEncoding::kExrFloat).ok());
  const std::string png = testing::UniqueTempPath("preview.png");
  ASSERT_TRUE(WritePreviewPng(png, small).ok());
  EXPECT_FALSE(image_module::Loaded());
  auto back = ReadImageRgb(png);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(image_module::Loaded());
  fs::remove(png);
}

}  // namespace
}  // namespace shrm
