// The `shrm` command: frequency-space prefiltering of HDR environment maps, embedded
// (in-process). Subcommands: analyze, prefilter, eval, reference, render, explicit, irradiance,
// ibl, info, batch, live, sky. docs/cli.md documents every option and the exit codes.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include "absl/status/status.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "shrm/version.h"

int main(int argc, char** argv) {
  CLI::App app{"shrm: frequency-space prefiltering of HDR environment maps (SHRMs)", "shrm"};
  app.set_version_flag("--version", shrm::VersionText("shrm"),
                       "print the version, git revision and conventions version and exit");
  app.require_subcommand(1);
  absl::Status status;
  shrm::cli::RegisterAnalyze(app, &status);
  shrm::cli::RegisterPrefilter(app, &status);
  shrm::cli::RegisterEval(app, &status);
  shrm::cli::RegisterReference(app, &status);
  shrm::cli::RegisterRender(app, &status);
  shrm::cli::RegisterExplicit(app, &status);
  shrm::cli::RegisterIrradiance(app, &status);
  shrm::cli::RegisterIbl(app, &status);
  shrm::cli::RegisterInfo(app, &status);
  shrm::cli::RegisterBatch(app, &status);
  shrm::cli::RegisterLive(app, &status);
  shrm::cli::RegisterSky(app, &status);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? shrm::cli::kExitOk : shrm::cli::kExitUsage;
  }
  if (!status.ok()) {
    std::fprintf(stderr, "shrm: error: %s\n", std::string(status.message()).c_str());
    return shrm::cli::kExitError;
  }
  return shrm::cli::kExitOk;
}
