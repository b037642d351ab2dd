// shrmd's config file (`shrmd --config FILE`, server/config_file.h): ReadConfigFile ->
// ParseConfigText (lines, keys, quotes, duplicates) -> ConfigToArgs (known keys, boolean flags,
// keys the command line already gave), then the arguments are parsed by CLI11 as shrmd parses
// them. The arguments must be equivalent to the file: every value given in the file is the
// value CLI11 reads for its flag (a value that CLI11 would take for another flag, or lose,
// is a finding).
//
// Input: the whole input is the file. The flag names are shrmd's (server/shrmd_main.cc), all
// read as strings here (the types' own checks are CLI11's); "listen" counts as given on the
// command line, so the file's value for it must be skipped.
#include <CLI/CLI.hpp>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "fuzz/fuzz_util.h"
#include "server/config_file.h"

namespace {

constexpr const char* kValueFlags[] = {
    "spool-dir", "spool-mib",    "max-blob-mib", "max-jobs",        "job-threads",
    "cache-mib", "grace-period", "metrics-port", "metrics-address", "token-file",
    "tls-cert",  "tls-key",      "tls-client-ca"};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path =
      shrm::fuzz::WriteScratchFile("shrmd.conf", shrm::fuzz::AsView(data, size));
  absl::StatusOr<std::vector<shrm::server::ConfigEntry>> entries =
      shrm::server::ReadConfigFile(path);
  if (!entries.ok()) return 0;

  CLI::App app{"shrmd (fuzz)", "shrmd"};
  std::map<std::string, std::string> values;
  for (const char* name : kValueFlags) app.add_option(std::string("--") + name, values[name]);
  std::string listen;
  app.add_option("--listen", listen);
  bool reflection = false;
  app.add_flag("--reflection", reflection);
  const auto known = [&](const std::string& key) {
    return app.get_option_no_throw("--" + key) != nullptr;
  };
  const auto given = [](const std::string& key) { return key == "listen"; };
  absl::StatusOr<std::vector<std::string>> args =
      shrm::server::ConfigToArgs(*entries, {"reflection"}, known, given);
  if (!args.ok()) return 0;

  std::vector<std::string> argv_strings = {"shrmd"};
  argv_strings.insert(argv_strings.end(), args->begin(), args->end());
  std::vector<char*> argv;
  for (std::string& a : argv_strings) argv.push_back(a.data());
  try {
    app.parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError&) {
    shrm::fuzz::Check(false, "the arguments made from an accepted config file parse");
  }
  for (const shrm::server::ConfigEntry& e : *entries) {
    if (e.key == "listen") continue;
    if (e.key == "reflection") {
      shrm::fuzz::Check(reflection == (absl::AsciiStrToLower(e.value) == "true"),
                        "reflection = true/false is the flag");
      continue;
    }
    shrm::fuzz::Check(values[e.key] == e.value, "CLI11 reads the file's value for its flag");
  }
  shrm::fuzz::Check(listen.empty(), "a key given on the command line is skipped");
  return 0;
}
