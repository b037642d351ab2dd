// Writes the seed files that need the project's own writers (scripts/make-fuzz-seeds.sh):
// small SHRM files (global/local, float/half, P_B 0..2), SHRMBRDF tables (grey and RGB,
// reflection and tangent), a MERL header, and KTX2/KTX1 parameter seeds are left to the fuzzer.
// Usage: fuzz_seed_writer CORPUS_DIR (the folder holding one folder per harness).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/brdf/brdf.h"
#include "core/brdf/brdf_table.h"
#include "core/shrm/shrm_file.h"

namespace {

namespace fs = std::filesystem;

int Fail(const std::string& what, const absl::Status& s) {
  std::fprintf(stderr, "fuzz_seed_writer: %s: %s\n", what.c_str(),
               std::string(s.message()).c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_seed_writer CORPUS_DIR\n");
    return 2;
  }
  const fs::path corpus = argv[1];
  fs::create_directories(corpus / "shrm_file");
  fs::create_directories(corpus / "brdf_table");
  for (int pmax : {0, 1, 2}) {
    for (bool half : {false, true}) {
      shrm::ShrmCube cube;
      cube.kind = pmax == 1 ? shrm::ShrmKind::kLocal : shrm::ShrmKind::kGlobal;
      cube.face_size = 2;
      cube.pmax = pmax;
      cube.data.resize(cube.size());
      for (size_t i = 0; i < cube.data.size(); ++i)
        cube.data[i] = 0.25f * static_cast<float>(i % 7);
      const std::string name =
          "p" + std::to_string(pmax) + (half ? "_half" : "_float") + ".shrm.exr";
      absl::Status s = shrm::WriteShrmFile((corpus / "shrm_file" / name).string(), cube,
                                           {{"shrm:brdf", "phong:s=8"}}, half);
      if (!s.ok()) return Fail(name, s);
    }
  }
  const struct {
    const char* spec;
    int ni, no, np;
  } kTables[] = {{"lambert", 2, 2, 1},
                 {"phong:s=8", 4, 3, 1},
                 {"ggx:alpha=0.3", 3, 3, 2},
                 {"kajiya-kay:s=4", 2, 3, 1},
                 {"ward:alpha=0.2", 3, 2, 3}};
  for (const auto& t : kTables) {
    absl::StatusOr<std::unique_ptr<shrm::Brdf>> brdf = shrm::ParseBrdfSpec(t.spec);
    if (!brdf.ok()) return Fail(t.spec, brdf.status());
    absl::StatusOr<shrm::BrdfTableData> table = shrm::SampleBrdfTable(**brdf, t.ni, t.no, t.np);
    if (!table.ok()) return Fail(t.spec, table.status());
    std::string name = shrm::SplitBrdfSpec(t.spec).model + ".brdf";
    absl::Status s = shrm::WriteBrdfTable((corpus / "brdf_table" / name).string(), *table);
    if (!s.ok()) return Fail(name, s);
  }
  return 0;
}
