// Image input: real bundled maps decode with the statistics documented in data/envmaps, and bad
// input (unknown signature, truncated file, absurd header, limits, NaN/Inf) gets a clear error.
#include "core/io/image.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "core/io/atomic_file.h"
#include "core/io/cube_exr.h"
#include "core/io/sha256.h"
#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace fs = std::filesystem;

constexpr double kMeanTol = 0.01;  // data/envmaps/README.md quotes means to 2 decimals
// Longer than the 1 s resolution of an EXR DateTime stamp.
constexpr int kClockTick = 1100;

std::string MapPath(const std::string& name) {
  return std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name;
}

std::string TempPath(const std::string& name) { return testing::UniqueTempPath("image_" + name); }

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST(ImageTest, ReadsBundledMapWithDocumentedStatistics) {
  auto img = ReadImageRgb(MapPath("courtyard.exr"));
  ASSERT_TRUE(img.ok()) << img.status();
  EXPECT_EQ(img->width, 1024);
  EXPECT_EQ(img->height, 512);
  double mean[3] = {0, 0, 0};
  for (size_t p = 0; p < img->pixels.size() / 3; ++p)
    for (int c = 0; c < 3; ++c) mean[c] += img->pixels[p * 3 + c];
  const double n = img->pixels.size() / 3.0;
  EXPECT_NEAR(mean[0] / n, 0.64, kMeanTol);
  EXPECT_NEAR(mean[1] / n, 0.51, kMeanTol);
  EXPECT_NEAR(mean[2] / n, 0.53, kMeanTol);
}

// Outputs carry no wall-clock stamp: the same pixels written a second apart give the same bytes
// (OpenImageIO would otherwise put the time into the EXR header).
TEST(ImageTest, WrittenExrIsAPureFunctionOfItsPixels) {
  Image img;
  img.width = 4;
  img.height = 2;
  img.channels = 3;
  img.pixels.assign(24, 0.5f);
  const std::string a = TempPath("same_a.exr"), b = TempPath("same_b.exr");
  ASSERT_TRUE(WriteExr(a, img).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(kClockTick));
  ASSERT_TRUE(WriteExr(b, img).ok());
  EXPECT_EQ(*Sha256OfFile(a), *Sha256OfFile(b));
  fs::remove(a);
  fs::remove(b);
}

TEST(ImageTest, FormatIsChosenByMagicBytesNotExtension) {
  const std::string path = TempPath("exr_named.png");
  fs::copy_file(MapPath("forest.exr"), path, fs::copy_options::overwrite_existing);
  auto fmt = DetectImageFormat(path);
  ASSERT_TRUE(fmt.ok());
  EXPECT_EQ(*fmt, "openexr");
  EXPECT_TRUE(ReadImageRgb(path).ok());
  fs::remove(path);
}

TEST(ImageTest, UnknownSignatureIsRejected) {
  const std::string path = TempPath("garbage.exr");
  WriteBytes(path, "hello, this is not an image");
  auto img = ReadImageRgb(path);
  EXPECT_EQ(img.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(img.status().message().find("unrecognized file signature"), std::string::npos);
  fs::remove(path);
}

TEST(ImageTest, MissingFileIsNotFound) {
  EXPECT_EQ(ReadImageRgb(TempPath("does_not_exist.exr")).status().code(),
            absl::StatusCode::kNotFound);
}

TEST(ImageTest, TruncatedExrFailsCleanly) {
  std::ifstream in(MapPath("courtyard.exr"), std::ios::binary);
  std::string bytes(4000, '\0');
  in.read(bytes.data(), bytes.size());
  const std::string path = TempPath("truncated.exr");
  WriteBytes(path, bytes);
  auto img = ReadImageRgb(path);
  EXPECT_FALSE(img.ok());
  EXPECT_NE(img.status().message().find(path), std::string::npos);
  fs::remove(path);
}

TEST(ImageTest, AbsurdHeaderIsRejectedBeforeDecoding) {
  const std::string path = TempPath("huge.hdr");
  WriteBytes(path, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n");
  auto header = ProbeImage(path);
  EXPECT_EQ(header.status().code(), absl::StatusCode::kResourceExhausted) << header.status();
  EXPECT_NE(header.status().message().find("100000 x 100000"), std::string::npos);
  fs::remove(path);
}

// A small valid EXR (EncodeImage) with the little-endian int32 `after` bytes past the end of
// `marker` set to `value`.
std::string PatchedExr(const std::string& marker, size_t after, uint32_t value) {
  Image img;
  img.width = 4;
  img.height = 2;
  img.channels = 3;
  img.pixels.assign(4 * 2 * 3, 0.5f);
  std::string bytes = *EncodeImage(img, ImageEncoding::kExrFloat);
  const size_t at = bytes.find(marker);
  EXPECT_NE(at, std::string::npos) << marker;
  if (at == std::string::npos) return bytes;
  for (int i = 0; i < 4; ++i)
    bytes[at + marker.size() + after + i] = char((value >> (8 * i)) & 255);
  return bytes;
}

absl::Status CheckPatchedExr(const std::string& name, const std::string& bytes) {
  const std::string path = TempPath(name);
  WriteBytes(path, bytes);
  const absl::Status probe = ProbeImage(path).status();
  EXPECT_EQ(CheckExrHeader(path, {}).code(), probe.code()) << probe;
  fs::remove(path);
  return probe;
}

TEST(ImageTest, ExrHeaderCheckPassesValidFiles) {
  EXPECT_TRUE(CheckExrHeader(MapPath("courtyard.exr"), {}).ok());
  const std::string path = TempPath("valid.exr");
  Image img;
  img.width = img.height = img.channels = 3;
  img.pixels.assign(27, 1.0f);
  WriteBytes(path, *EncodeImage(img, ImageEncoding::kExrFloat));
  EXPECT_TRUE(CheckExrHeader(path, {}).ok());
  fs::remove(path);
}

// Found by fuzzing (docs/fuzzing.md): OpenEXR 3.1.5 allocates a string attribute's declared size
// before reading it; a 7 KB file claiming 1.8 GB (its capDate) took the process past its memory
// limit. Here the string attribute of a small cube file (EncodeCubeExr) claims the same size.
TEST(ImageTest, ExrAttributeLargerThanTheFileIsRejectedBeforeOpenExr) {
  CubeExr cube;
  cube.face_size = 2;
  cube.group_names = {"c"};
  cube.data.assign(cube.size(), 0.5f);
  cube.attributes["shrm:note"] = "abc";
  std::string bytes = *EncodeCubeExr(cube, "attr");
  const std::string marker("shrm:note\0string\0", 17);
  const size_t at = bytes.find(marker);
  ASSERT_NE(at, std::string::npos);
  for (int i = 0; i < 4; ++i)
    bytes[at + marker.size() + i] = char((uint32_t{0x6d000000} >> (8 * i)) & 255);
  const std::string path = TempPath("attr.exr");
  WriteBytes(path, bytes);
  const absl::Status s = CheckExrHeader(path, {});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find("attribute 'shrm:note' claims 1828716544 bytes"), std::string::npos)
      << s;
  const absl::Status read = ReadCubeExr(path).status();
  EXPECT_EQ(read.code(), absl::StatusCode::kInvalidArgument) << read;
  fs::remove(path);
}

// Found by fuzzing: libpng allocates and clears a text chunk's declared size before reading it,
// so a 640-byte PNG claiming a 1.6 GB tEXt chunk touched 1.6 GB (a 70 s timeout under ASan). The
// chunk walk refuses a chunk running past the file's end, and an IHDR beyond the limits, before
// the image module (libpng through OpenImageIO) sees the file. Written here from the PNG
// specification's chunk layout; the CRCs are not what is checked.
TEST(ImageTest, PngChunkLongerThanTheFileIsRejectedBeforeLibpng) {
  auto be32 = [](uint32_t v) {
    return std::string{char(v >> 24), char((v >> 16) & 255), char((v >> 8) & 255), char(v & 255)};
  };
  auto chunk = [&](const std::string& type, const std::string& data, uint32_t length) {
    return be32(length) + type + data + be32(0);
  };
  auto ihdr = [&](uint32_t w, uint32_t h) {
    return chunk("IHDR", be32(w) + be32(h) + std::string("\x08\x02\x00\x00\x00", 5), 13);
  };
  const std::string signature("\x89PNG\r\n\x1a\n", 8);
  const std::string path = TempPath("long_chunk.png");
  WriteBytes(path, signature + ihdr(4, 24) + chunk("tEXt", "Comment", 1666122018));
  const absl::Status probe = ProbeImage(path).status();
  EXPECT_EQ(probe.code(), absl::StatusCode::kInvalidArgument) << probe;
  EXPECT_NE(probe.message().find("chunk 1 ('tEXt') claims 1666122018 bytes"), std::string::npos)
      << probe;
  EXPECT_EQ(ReadImageRgb(path).status().code(), absl::StatusCode::kInvalidArgument);
  // A header beyond the limits: ResourceExhausted naming the size, as for EXR.
  WriteBytes(path, signature + ihdr(100000, 100000) + chunk("IEND", "", 0));
  const absl::Status huge = CheckPngHeader(path, {});
  EXPECT_EQ(huge.code(), absl::StatusCode::kResourceExhausted) << huge;
  EXPECT_NE(huge.message().find("100000 x 100000"), std::string::npos) << huge;
  // IHDR must come first.
  WriteBytes(path, signature + chunk("IEND", "", 0));
  EXPECT_EQ(CheckPngHeader(path, {}).code(), absl::StatusCode::kInvalidArgument);
  fs::remove(path);
}

// Found by fuzzing: OpenEXR reads a channel list (and the fixed-size types) up to its own end,
// whatever the attribute's size says, then reads the next attribute out of step (a string size
// of 1.7 GB taken from text). The walker checks that such values fill exactly their size.
TEST(ImageTest, ExrValueDisagreeingWithItsSizeIsRejectedBeforeOpenExr) {
  const absl::Status chlist =
      CheckPatchedExr("chlist.exr", PatchedExr(std::string("channels\0chlist\0", 16), 0, 37));
  EXPECT_EQ(chlist.code(), absl::StatusCode::kInvalidArgument) << chlist;
  EXPECT_NE(chlist.message().find("attribute 'channels'"), std::string::npos) << chlist;
  const absl::Status fixed = CheckPatchedExr(
      "compression.exr", PatchedExr(std::string("compression\0compression\0", 24), 0, 5));
  EXPECT_EQ(fixed.code(), absl::StatusCode::kInvalidArgument) << fixed;
  EXPECT_NE(fixed.message().find("has 5 bytes, not 1"), std::string::npos) << fixed;
}

TEST(ImageTest, ExrDataWindowBeyondTheLimitsIsRejectedBeforeOpenExr) {
  // dataWindow = (xMin, yMin, xMax, yMax): xMax = 2^30.
  const absl::Status s = CheckPatchedExr(
      "window.exr", PatchedExr(std::string("dataWindow\0box2i\0", 17), 12, 1 << 30));
  EXPECT_EQ(s.code(), absl::StatusCode::kResourceExhausted) << s;
  EXPECT_NE(s.message().find("1073741825 x 2"), std::string::npos) << s;
  const absl::Status inverted = CheckPatchedExr(
      "inverted.exr", PatchedExr(std::string("dataWindow\0box2i\0", 17), 16, 0xFFFFFFF0u));
  EXPECT_EQ(inverted.code(), absl::StatusCode::kInvalidArgument) << inverted;
}

TEST(ImageTest, ExrDeepFlagIsRejectedBeforeOpenExr) {
  // The version field's flags (bytes 4-7): bit 11 marks deep (non-image) parts.
  const absl::Status s = CheckPatchedExr("deep.exr", PatchedExr("\x76\x2f\x31\x01", 0, 2 | 0x800));
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find("deep images are not supported"), std::string::npos) << s;
}

TEST(ImageTest, LimitsAreConfigurable) {
  ImageLimits limits;
  limits.max_width = 512;
  auto img = ReadImageRgb(MapPath("courtyard.exr"), limits);
  EXPECT_EQ(img.status().code(), absl::StatusCode::kResourceExhausted);
}

TEST(ImageTest, NonFinitePixelsAreRejectedOrReplaced) {
  Image img;
  img.width = 4;
  img.height = 3;
  img.channels = 3;
  img.pixels.assign(4 * 3 * 3, 1.0f);
  img.pixels[(1 * 4 + 2) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();
  img.pixels[(2 * 4 + 3) * 3 + 0] = std::numeric_limits<float>::infinity();
  const std::string path = TempPath("nan.exr");
  ASSERT_TRUE(WriteExr(path, img).ok());
  auto rejected = ReadImageRgb(path);
  EXPECT_EQ(rejected.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(rejected.status().message().find("2 non-finite"), std::string::npos);
  EXPECT_NE(rejected.status().message().find("(x=2, y=1)"), std::string::npos);
  auto replaced = ReadImageRgb(path, {}, NonFinitePolicy::kReplaceZero);
  ASSERT_TRUE(replaced.ok());
  EXPECT_EQ(replaced->replaced_non_finite, 2);
  EXPECT_EQ(replaced->at(2, 1, 1), 0.0f);
  EXPECT_EQ(replaced->at(0, 0, 0), 1.0f);
  fs::remove(path);
}

TEST(ImageTest, WriteLeavesNoTemporaryAndRoundTrips) {
  Image img;
  img.width = 3;
  img.height = 2;
  img.channels = 3;
  for (int i = 0; i < 18; ++i) img.pixels.push_back(0.25f * i);
  const std::string path = TempPath("roundtrip.exr");
  ASSERT_TRUE(WriteExr(path, img).ok());
  auto back = ReadImageRgb(path);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->pixels, img.pixels);
  for (const auto& e : fs::directory_iterator(fs::temp_directory_path()))
    EXPECT_EQ(e.path().string().find("roundtrip.tmp-"), std::string::npos);
  fs::remove(path);
  Image bad = img;
  bad.pixels.pop_back();
  EXPECT_EQ(WriteExr(path, bad).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(path));
}

// RemoveTempFilesOnSignal: a process ended by SIGTERM (or SIGINT, Ctrl-C) while its outputs are
// being written leaves no temporary beside them, and still ends by the signal; a committed output
// stays, and an untouched old output keeps its bytes. (A child process: the signal ends it.)
TEST(ImageTest, SignalWhileWritingRemovesTheTemporaries) {
  for (int sig : {SIGTERM, SIGINT}) {
    const std::string dir = TempPath("signal_dir");
    fs::create_directories(dir);
    WriteBytes(dir + "/old.exr", "the old output");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      ::signal(sig, SIG_DFL);  // as a shell starts a command (gtest may have changed nothing)
      RemoveTempFilesOnSignal();
      if (!WriteFileAtomically(dir + "/done.json", "{}").ok()) ::_exit(3);
      // Two outputs in progress: a writer's own temporary, and a transaction's (a temporary
      // name whose file a writer fills through its own temporary, then renames).
      AtomicFileWriter writer(dir + "/old.exr");
      writer.Append("half of a new output");
      const std::string outer = TempPathFor(dir + "/cube.shrm.exr");
      if (!WriteFileAtomically(outer, "a whole temporary").ok()) ::_exit(4);
      ::raise(sig);
      ::_exit(5);  // not reached
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status)) << "exit status " << status;
    EXPECT_EQ(WTERMSIG(status), sig);
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"done.json", "old.exr"})) << sig;
    std::ifstream old(dir + "/old.exr", std::ios::binary);
    EXPECT_EQ(std::string(std::istreambuf_iterator<char>(old), {}), "the old output");
    fs::remove_all(dir);
  }
}

TEST(ImageTest, PreviewPngIsToneMappedSrgb) {
  Image img;
  img.width = 2;
  img.height = 1;
  img.channels = 3;
  img.pixels = {0.0f, 1.0f, 3.0f, 1e6f, -1.0f, 0.25f};
  const std::string path = TempPath("preview.png");
  ASSERT_TRUE(WritePreviewPng(path, img, /*exposure=*/1.0).ok());
  auto back = ReadImageRgb(path);
  ASSERT_TRUE(back.ok()) << back.status();
  // Closed form: x = v 2^1, y = x / (1 + x), sRGB OETF, 8-bit.
  auto expected = [](double v) {
    const double x = std::max(0.0, v) * 2, y = x / (1 + x);
    const double e = y <= 0.0031308 ? 12.92 * y : 1.055 * std::pow(y, 1 / 2.4) - 0.055;
    return std::round(e * 255) / 255;
  };
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(back->pixels[i], expected(img.pixels[i]), 1e-6) << i;
  fs::remove(path);
}

}  // namespace
}  // namespace shrm
