// The IBL job (jobs/ibl_job.h, jobs/ibl_outputs.h): validation of every option, the embedded run
// on a real map (its cubes against the brute-force pixel sum at texels the job did not check
// itself), the stored values equal to what the format stores, the report's verdict, and the
// files: their names, order and KTX2 sizes; the KTX1 container's texels in Filament's frame.
#include "jobs/ibl_job.h"

#include <cmath>
#include <cstring>
#include <random>
#include <sstream>

#include "core/base/cubemap.h"
#include "core/export/ktx2.h"
#include "core/io/atomic_file.h"
#include "core/io/image.h"
#include "gtest/gtest.h"
#include "jobs/ibl_outputs.h"
#include "tests/float_decoders.h"
#include "tests/test_maps.h"
#include "tests/test_paths.h"

namespace shrm::jobs {
namespace {

IblJob SmallJob(const std::string& map) {
  IblJob job;
  job.env.files = {map};
  job.preset = ibl::RoughnessPreset::kGltf;
  job.face_size = 32;
  job.irradiance_size = 8;
  job.dfg_size = 16;
  job.verify = 8;
  return job;
}

TEST(IblJobTest, EveryOptionIsValidated) {
  const IblJob ok = SmallJob("x.exr");
  EXPECT_TRUE(ValidateIblJob(ok).ok()) << ValidateIblJob(ok);
  auto bad = [&](auto edit, const char* word) {
    IblJob j = ok;
    edit(j);
    const absl::Status st = ValidateIblJob(j);
    EXPECT_EQ(st.code(), absl::StatusCode::kInvalidArgument) << word;
    EXPECT_NE(std::string(st.message()).find(word), std::string::npos) << st;
  };
  bad([](IblJob& j) { j.tolerance = 0; }, "tolerance");
  bad([](IblJob& j) { j.tolerance = 1; }, "tolerance");
  bad([](IblJob& j) { j.verify = -1; }, "verify");
  bad([](IblJob& j) { j.verify = kMaxIblVerify + 1; }, "verify");
  bad([](IblJob& j) { j.irradiance_size = 0; }, "irradiance");
  bad([](IblJob& j) { j.dfg_size = kMaxDfgSize + 1; }, "DFG");
  bad([](IblJob& j) { j.face_size = 100; }, "power of two");
  bad([](IblJob& j) { j.levels = 7; }, "levels");
  bad([](IblJob& j) { j.roughness = {0, 0.5}; }, "explicit");
  bad([](IblJob& j) { j.env.files.clear(); }, "");
  bad([](IblJob& j) { j.containers.clear(); }, "at least one");
  bad([](IblJob& j) { j.containers = {IblContainer::kKtx1, IblContainer::kKtx2}; }, "sorted");
  bad(
      [](IblJob& j) {
        j.containers = {IblContainer::kKtx1};
        j.format = IblFormat::kE5b9g9r9;
      },
      "rgb9e5");
  EXPECT_FALSE(ParseIblFormat("rgb8").ok());
  EXPECT_FALSE(ParseIblContainers("").ok());
  EXPECT_FALSE(ParseIblContainers("ktx2,ktx2").ok());
  EXPECT_FALSE(ParseIblContainers("KTX2").ok());
  auto all = ParseIblContainers("all");
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(IblContainersText(*all), "ktx2,ktx1,gltf");
  auto sorted = ParseIblContainers("gltf,ktx2");
  ASSERT_TRUE(sorted.ok());
  EXPECT_EQ(IblContainersText(*sorted), "ktx2,gltf");
  for (IblFormat f :
       {IblFormat::kRgba16f, IblFormat::kRgba32f, IblFormat::kB10g11r11, IblFormat::kE5b9g9r9}) {
    auto back = ParseIblFormat(IblFormatName(f));
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(*back, f);
  }
}

// Targets of the default tolerance (1e-3 RMS, 5e-3 largest) at texels the job did not check.
constexpr double kRmsTol = kDefaultIblTolerance;
constexpr double kMaxTol = kIblMaxErrorFactor * kDefaultIblTolerance;

// Each cube of `run` against the pixel sum at 24 texels per level drawn with a seed of its own:
// relative RMS at most rms_tol and the largest relative error at most max_tol on every level.
void ExpectWithinTolerance(const std::string& path, const IblRun& run, double rms_tol = kRmsTol,
                           double max_tol = kMaxTol) {
  EnvMapOptions options;
  options.paths = {path};
  auto map = EnvMap::Load(options);
  ASSERT_TRUE(map.ok());
  std::mt19937 rng(99);  // not the job's seeds
  for (const IblCube* cube : {&run.specular, &run.sheen, &run.irradiance}) {
    for (const ibl::SpecularLevel& level : cube->chain.levels) {
      if (level.alpha == 0) continue;
      const int s = level.face_size;
      std::uniform_int_distribution<int> pick(0, 6 * s * s - 1);
      std::vector<double> got, ref;
      for (int i = 0; i < 24; ++i) {
        const int t = pick(rng), face = t / (s * s), y = (t / s) % s, x = t % s;
        const std::array<double, 3> want = ibl::SplitSumReference(
            *map, cube->chain.lobe, level.alpha, CubeTexelDirection(face, x, y, s));
        double a = 0, b = 0;
        const double w[3] = {0.2126, 0.7152, 0.0722};
        for (int c = 0; c < 3; ++c) {
          const float v = level.cube.data[level.cube.Index(face, x, y, c)];
          // Stored as half floats: the value reads back unchanged.
          EXPECT_EQ(v, ktx2::HalfToFloat(ktx2::FloatToHalf(v)));
          a += w[c] * v;
          b += w[c] * want[c];
        }
        got.push_back(a);
        ref.push_back(b);
      }
      double mean = 0, rms = 0, largest = 0;
      for (double v : ref) mean += std::abs(v) / ref.size();
      for (size_t i = 0; i < ref.size(); ++i) {
        const double d = std::abs(got[i] - ref[i]) / std::max(std::abs(ref[i]), 0.01 * mean);
        rms += d * d / ref.size();
        largest = std::max(largest, d);
      }
      EXPECT_LE(std::sqrt(rms), rms_tol) << cube->name << " r " << level.roughness;
      EXPECT_LE(largest, max_tol) << cube->name << " r " << level.roughness;
    }
  }
}

TEST(IblJobTest, SheenAtFullResolutionIsWithinItsTolerance) {
  // The Charlie lobe at N = V = R is a ring next to 90 degrees from R: its low-roughness levels
  // need the degrees of the full 1024 x 512 map.
  IblJob job = SmallJob(std::string(SHRM_SOURCE_DIR) + "/data/envmaps/city.exr");
  job.face_size = 16;
  job.irradiance_size = 4;
  job.sheen = true;
  job.verify = 4;
  auto run = RunIblJob(job, 2);
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_TRUE(run->report["met"].get<bool>()) << run->report["sheen"].dump(1);
  ExpectWithinTolerance(job.env.files[0], *run);
}

// The engine-outputs issue's speed benchmark (bench/startup_bench.cc BM_Process/ibl_1pct): the
// default chain (Filament, 256 down to 16) from a whole bundled 1024 x 512 map, at the accuracy
// that benchmark states, 1% relative RMS and 5% largest relative error on every level, asked for
// with --tolerance 0.01. Checked here at texels the job did not check, on courtyard (the
// benchmark's map) and city (the bundled map that needs the highest degrees).
TEST(IblJobTest, TheBenchmarkAccuracyHoldsOnWholeRealMaps) {
  constexpr double kBenchRms = 0.01;  // the accuracy for its speed targets
  constexpr double kBenchMax = 0.05;
  for (const char* name : {"courtyard.exr", "city.exr"}) {
    IblJob job;
    job.env.files = {std::string(SHRM_SOURCE_DIR) + "/data/envmaps/" + name};
    job.tolerance = kBenchRms;
    auto run = RunIblJob(job, 2);
    ASSERT_TRUE(run.ok()) << run.status();
    EXPECT_TRUE(run->report["met"].get<bool>()) << name << run->report.dump(1);
    ASSERT_EQ(run->specular.chain.levels.size(), 5u) << name;
    EXPECT_EQ(run->specular.chain.levels[0].face_size, 256) << name;
    ExpectWithinTolerance(job.env.files[0], *run, kBenchRms, kBenchMax);
  }
}

TEST(IblJobTest, RunsOnARealMapWithinItsTolerance) {
  const std::string path = testing::UniqueTempPath("ibl_job_city.exr");
  ASSERT_TRUE(WriteExr(path, testing::LoadBundledMap("city.exr", 256)).ok());
  IblJob job = SmallJob(path);
  auto run = RunIblJob(job, 2);
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_TRUE(run->report["met"].get<bool>()) << run->report.dump(1);
  EXPECT_TRUE(IblOutcome(job, run->report).ok());
  ASSERT_EQ(run->specular.chain.levels.size(), 5u);  // gltf: floor(log2(32)) levels
  EXPECT_TRUE(run->sheen.chain.levels.empty());
  ASSERT_EQ(run->irradiance.chain.levels.size(), 1u);
  EXPECT_EQ(run->report["specular"]["levels"].size(), 5u);
  EXPECT_EQ(run->report["specular"]["levels"][1]["measured"]["count"].get<int>(), 8);

  ExpectWithinTolerance(path, *run);

  auto files = EncodeIblOutputs(job, *run);
  ASSERT_TRUE(files.ok()) << files.status();
  std::vector<std::string> names;
  for (const IblFile& f : *files) names.push_back(f.name);
  const std::vector<std::string> want = {"specular.ktx2", "irradiance.ktx2", "dfg.ktx2", "dfg.exr",
                                         "dfg.png",       "sh9.json",        "ibl.json"};
  EXPECT_EQ(names, want);
  // RGBA16F cube, 5 levels 32..2: 6 faces x 8 bytes per texel, plus headers (< 4 KiB).
  size_t texels = 0;
  for (int s = 32; s >= 2; s /= 2) texels += 6 * s * s;
  EXPECT_GE((*files)[0].bytes.size(), texels * 8);
  EXPECT_LT((*files)[0].bytes.size(), texels * 8 + 4096);
  EXPECT_EQ((*files)[0].bytes.substr(1, 6), "KTX 20");
  const nlohmann::json sidecar = nlohmann::json::parse(files->back().bytes);
  EXPECT_EQ(sidecar["files"].size(), 6u);
  // gltf preset: the glTF sample viewer's lut_ggx, (A, B, C); the images read back (OpenImageIO)
  // equal the table.
  ASSERT_TRUE(run->dfg.has_value());
  EXPECT_EQ(sidecar["dfg"]["consumer"], "gltf-lut-ggx");
  constexpr double kExrTol = 0;                 // float EXR
  constexpr double kPngTol = 0.5 / 255 + 1e-6;  // 8-bit rounding
  for (auto [index, tol] : {std::pair{3, kExrTol}, std::pair{4, kPngTol}}) {
    const std::string tmp = testing::UniqueTempPath((*files)[index].name);
    ASSERT_TRUE(WriteFileAtomically(tmp, (*files)[index].bytes).ok());
    auto img = ReadImageRgb(tmp);
    ASSERT_TRUE(img.ok()) << img.status();
    ASSERT_EQ(img->width, job.dfg_size);
    for (int y = 0; y < img->height; ++y)
      for (int x = 0; x < img->width; ++x)
        for (int c = 0; c < 3; ++c)
          ASSERT_NEAR(img->at(x, y, c),
                      index == 4 ? std::min(1.0f, run->dfg->At(y, x, c)) : run->dfg->At(y, x, c),
                      tol)
              << (*files)[index].name;  // the PNG clamps to [0, 1] (C exceeds 1 at grazing)
    std::remove(tmp.c_str());
  }
  const nlohmann::json sh9 = nlohmann::json::parse((*files)[5].bytes);
  for (const char* conv : {"filament", "gltf", "gltf-babylon", "three", "unity"}) {
    ASSERT_TRUE(sh9["conventions"].contains(conv)) << conv;
  }
  EXPECT_EQ(sh9["conventions"]["unity"]["coefficients"].size(), 27u);
  EXPECT_EQ(sh9["conventions"]["three"]["coefficients"].size(), 9u);
  // The l <= 2 truncation is measured and reported (a few percent on real maps).
  EXPECT_GT(run->report["sh9_measured"]["rms"].get<double>(), 0.0);
  EXPECT_EQ(sidecar["format"], "rgba16f");
  std::remove(path.c_str());
}

// A black map (a night sky's render, a placeholder): every reference is 0, so there is no scale
// for a relative error; the set is all zeros and each measured error 0, as the prefilter's check
// counts it (0 / 0 made the RMS NaN, written as null in ibl.json).
TEST(IblJobTest, ABlackMapMeasuresNoErrorRatherThanNaN) {
  const std::string path = testing::UniqueTempPath("ibl_job_black.exr");
  Image black;
  black.width = 64;
  black.height = 32;
  black.channels = 3;
  black.pixels.assign(64 * 32 * 3, 0.0f);
  ASSERT_TRUE(WriteExr(path, black).ok());
  IblJob job = SmallJob(path);
  auto run = RunIblJob(job, 2);
  ASSERT_TRUE(run.ok()) << run.status();
  EXPECT_TRUE(run->report["met"].get<bool>()) << run->report.dump(1);
  for (const IblCube* cube : {&run->specular, &run->irradiance}) {
    for (float v : cube->chain.levels.front().cube.data) ASSERT_EQ(v, 0.0f);
    ASSERT_FALSE(cube->measured.empty());
    for (const ibl::LevelError& e : cube->measured) {
      EXPECT_GT(e.count, 0);
      EXPECT_EQ(e.rms, 0.0);
      EXPECT_EQ(e.max, 0.0);
    }
  }
  EXPECT_EQ(run->report["sh9_measured"]["rms"], 0.0) << run->report.dump(1);
  EXPECT_EQ(run->report["specular"]["levels"][1]["measured"]["rms"], 0.0);
  std::remove(path.c_str());
}

// --containers ktx1: Filament's files (cmgen's names), no KTX2 file; ibl.ktx's texel at Filament
// direction n is the stored chain's texel at world direction (-n.x, n.y, -n.z) (the frame of
// docs/ibl.md, read here from the file with the KTX 1.1 layout and the specification's
// R11F_G11F_B10F decoder), and its "sh" key and sh.txt hold sh9.json's `filament` coefficients.
TEST(IblJobTest, Ktx1ContainerHoldsTheChainInFilamentsFrame) {
  const std::string path = testing::UniqueTempPath("ibl_job_ktx1.exr");
  ASSERT_TRUE(WriteExr(path, testing::LoadBundledMap("courtyard.exr", 256)).ok());
  IblJob job = SmallJob(path);
  job.preset = ibl::RoughnessPreset::kFilament;
  job.levels = 2;
  job.verify = 0;
  job.format = IblFormat::kB10g11r11;
  job.containers = {IblContainer::kKtx1};
  auto run = RunIblJob(job, 2);
  ASSERT_TRUE(run.ok()) << run.status();
  auto files = EncodeIblOutputs(job, *run);
  ASSERT_TRUE(files.ok()) << files.status();
  std::map<std::string, std::string> by_name;
  std::vector<std::string> names;
  for (const IblFile& f : *files) {
    names.push_back(f.name);
    by_name[f.name] = f.bytes;
  }
  const std::vector<std::string> want = {"ibl.ktx", "skybox.ktx", "sh.txt",  "dfg.exr",
                                         "dfg.png", "sh9.json",   "ibl.json"};
  EXPECT_EQ(names, want);

  const std::string& b = by_name["ibl.ktx"];
  auto u32 = [&](size_t at) {
    uint32_t v;
    std::memcpy(&v, b.data() + at, 4);  // little endian (endianness 0x04030201 checked)
    return v;
  };
  ASSERT_EQ(b.substr(1, 6), "KTX 11");
  ASSERT_EQ(u32(12), 0x04030201u);
  ASSERT_EQ(u32(28), 0x8C3Au);  // glInternalFormat GL_R11F_G11F_B10F
  ASSERT_EQ(u32(52), 6u);       // numberOfFaces
  ASSERT_EQ(u32(56), 2u);       // numberOfMipmapLevels
  // Key/value data: find "sh".
  std::string sh_value;
  size_t at = 64;
  for (const size_t end = at + u32(60); at < end;) {
    const uint32_t size = u32(at);
    const std::string entry = b.substr(at + 4, size);
    const size_t nul = entry.find('\0');
    if (entry.substr(0, nul) == "sh") sh_value = entry.substr(nul + 1, size - nul - 2);
    at += 4 + size + (3 - ((size + 3) % 4));
  }
  const nlohmann::json sh9 = nlohmann::json::parse(by_name["sh9.json"]);
  const auto& filament = sh9["conventions"]["filament"]["coefficients"];
  std::istringstream sh_numbers(sh_value);
  std::istringstream txt(by_name["sh.txt"]);
  constexpr double kNineDigits = 1e-8;  // %.9g in the key; sh.txt has 15 decimals
  for (int i = 0; i < 9; ++i) {
    std::string line;
    std::getline(txt, line);
    double r, g, bl;
    ASSERT_EQ(std::sscanf(line.c_str(), "(%lf, %lf, %lf);", &r, &g, &bl), 3) << line;
    const double from_txt[3] = {r, g, bl};
    for (int c = 0; c < 3; ++c) {
      double v = 0;
      ASSERT_TRUE(sh_numbers >> v);
      const double want_c = filament[i][c].get<double>();
      EXPECT_NEAR(v, want_c, kNineDigits * std::abs(want_c) + 1e-12) << i << " " << c;
      EXPECT_NEAR(from_txt[c], want_c, 1e-14 + 1e-15 * std::abs(want_c)) << line;
    }
  }
  // Texels: level by level, six faces of imageSize bytes each.
  for (size_t k = 0; k < 2; ++k) {
    const ibl::SpecularLevel& level = run->specular.chain.levels[k];
    const int n = level.face_size;
    ASSERT_EQ(u32(at), static_cast<uint32_t>(n * n * 4)) << "imageSize = one face";
    at += 4;
    for (int face = 0; face < kCubeFaceCount; ++face)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
          const std::array<double, 3> got = testing::DecodeB10G11R11(u32(at));
          at += 4;
          const Vec3 d = CubeTexelDirection(face, x, y, n);
          int wf = 0;
          double s = 0, t = 0;
          CubeFaceCoordinates(Vec3{-d.x, d.y, -d.z}, &wf, &s, &t);
          const int wx = static_cast<int>(s * n), wy = static_cast<int>(t * n);
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(got[c], level.cube.data[level.cube.Index(wf, wx, wy, c)])
                << "level " << k << " face " << face << " (" << x << ", " << y << ")";
        }
  }
  EXPECT_EQ(at, b.size());
  std::remove(path.c_str());
}

// --preview: preview.png read back with OpenImageIO. A constant map gives one grey on every tile
// pixel (the median luminance is exposed to 0.18: Reinhard then sRGB, 0.1525 -> 0.4286 ->
// 109/255) and black gaps; on the patches map (red at world +X) the +X face of level 0 is the
// reddest face and the mirror sphere is red on its right (+X) half.
TEST(IblJobTest, PreviewIsAContactSheetOfTheChain) {
  constexpr double kPng8Tol = 1.0 / 255;  // one 8-bit step
  Image white;
  white.width = 64;
  white.height = 32;
  white.channels = 3;
  white.pixels.assign(64 * 32 * 3, 1.0f);
  Image patches = white;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x)
      for (int c = 0; c < 3; ++c) {
        // Red (8, 0, 0) around u = 0.75 (world +X) near the horizon, grey 0.05 elsewhere.
        const bool red = x >= 44 && x < 52 && y >= 12 && y < 20;
        patches.pixels[(y * 64 + x) * 3 + c] = red ? (c == 0 ? 8.0f : 0.0f) : 0.05f;
      }
  for (int which = 0; which < 2; ++which) {
    const std::string path = testing::UniqueTempPath(which == 0 ? "white.exr" : "patches.exr");
    ASSERT_TRUE(WriteExr(path, which == 0 ? white : patches).ok());
    IblJob job = SmallJob(path);
    job.face_size = 16;
    job.verify = 0;
    job.preview = true;
    auto run = RunIblJob(job, 2);
    ASSERT_TRUE(run.ok()) << run.status();
    auto files = EncodeIblOutputs(job, *run);
    ASSERT_TRUE(files.ok()) << files.status();
    const IblFile* png = nullptr;
    for (const IblFile& f : *files)
      if (f.name == "preview.png") png = &f;
    ASSERT_NE(png, nullptr);
    EXPECT_EQ(png->type, "image");
    const std::string tmp = testing::UniqueTempPath("preview.png");
    ASSERT_TRUE(WriteFileAtomically(tmp, png->bytes).ok());
    auto img = ReadImageRgb(tmp);
    ASSERT_TRUE(img.ok()) << img.status();
    const int rows = static_cast<int>(run->specular.chain.levels.size()) + 1;
    const int t = kPreviewTile, g = kPreviewGap;
    ASSERT_EQ(img->width, 7 * t + 8 * g);
    ASSERT_EQ(img->height, rows * (t + g) + g);
    auto tile_mean = [&](int row, int col, int c, bool right_half = false) {
      double sum = 0;
      int n = 0;
      for (int v = 0; v < t; ++v)
        for (int u = right_half ? t / 2 : 0; u < (right_half ? t : t / 2); ++u) {
          sum += img->at(g + col * (t + g) + u, g + row * (t + g) + v, c);
          ++n;
        }
      return sum / n;
    };
    if (which == 0) {
      const double grey = 0.15254237288135594;  // 0.18 / 1.18
      const double want = 1.055 * std::pow(grey, 1 / 2.4) - 0.055;
      for (int row = 0; row < rows; ++row)
        for (int col = 0; col < 6; ++col)
          for (int v = 0; v < t; v += 7)
            for (int u = 0; u < t; u += 7)
              ASSERT_NEAR(img->at(g + col * (t + g) + u, g + row * (t + g) + v, 1), want, kPng8Tol)
                  << "row " << row << " tile " << col;
      EXPECT_NEAR(img->at(g + 6 * (t + g) + t / 2, g + t / 2, 0), want, kPng8Tol);  // sphere
      EXPECT_EQ(img->at(0, 0, 0), 0.0f);                                            // border
      EXPECT_EQ(img->at(g + t + g / 2, g + t / 2, 0), 0.0f);                        // gap
    } else {
      int reddest = -1;
      double best = -1;
      for (int col = 0; col < 6; ++col) {
        const double red = (tile_mean(0, col, 0) + tile_mean(0, col, 0, true)) -
                           (tile_mean(0, col, 1) + tile_mean(0, col, 1, true));
        if (red > best) best = red, reddest = col;
      }
      EXPECT_EQ(reddest, kPosX);
      EXPECT_GT(tile_mean(0, 6, 0, true) - tile_mean(0, 6, 1, true),
                tile_mean(0, 6, 0) - tile_mean(0, 6, 1))
          << "the mirror sphere's red is on its +X (right) half";
    }
    std::remove(tmp.c_str());
    std::remove(path.c_str());
  }
}

TEST(IblJobTest, AMissedTargetIsReportedWithTheLevel) {
  IblJob job = SmallJob("x.exr");
  nlohmann::json report = {{"tolerance", {{"rms", 1e-3}, {"max", 5e-3}}},
                           {"specular",
                            {{"levels",
                              {{{"level", 0},
                                {"roughness", 0.0},
                                {"measured", {{"count", 8}, {"rms", 1e-4}, {"max", 2e-4}}}},
                               {{"level", 1},
                                {"roughness", 0.25},
                                {"measured", {{"count", 8}, {"rms", 2e-3}, {"max", 4e-3}}}}}}}}};
  const absl::Status st = IblOutcome(job, report);
  EXPECT_EQ(st.code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(std::string(st.message()).find("specular level 1"), std::string::npos) << st;
}

}  // namespace
}  // namespace shrm::jobs
