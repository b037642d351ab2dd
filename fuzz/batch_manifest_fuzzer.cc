// `shrm batch` manifests (cli/batch_manifest.h, docs/cli.md "batch"): ParseManifestText (the JSON
// text as `shrm batch` parses it; a parse error is the user's error), then ParseManifest: kinds,
// maps, BRDFs, every option with its range, output naming, IBL options. Maps named "map.exr",
// "sky.hdr" and "faces/px.exr" exist in the manifest's folder, so jobs get made.
//
// Input: the whole input is the manifest. Besides sanitizer reports, an exception escaping
// ParseManifest (e.g. nlohmann's type_error for a value of the wrong JSON type) is a finding.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/batch_manifest.h"
#include "fuzz/fuzz_util.h"

namespace {

const std::filesystem::path& ManifestDir() {
  static const std::filesystem::path dir = [] {
    std::filesystem::create_directories(shrm::fuzz::ScratchDir() + "/faces");
    for (const char* name : {"map.exr", "sky.hdr", "faces/px.exr"})
      shrm::fuzz::WriteScratchFile(name, "not decoded by ParseManifest");
    return std::filesystem::path(shrm::fuzz::ScratchDir());
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  absl::StatusOr<nlohmann::json> manifest =
      shrm::cli::ParseManifestText(shrm::fuzz::AsView(data, size));
  if (!manifest.ok()) return 0;
  shrm::cli::BatchOptions options;
  std::vector<shrm::cli::BatchJob> jobs;
  std::vector<std::string> errors;
  shrm::cli::ParseManifest(*manifest, ManifestDir(), &options, &jobs, &errors);
  shrm::fuzz::Check(errors.empty() || jobs.empty(), "no job is made from a manifest with errors");
  return 0;
}
