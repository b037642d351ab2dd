// The subcommands of `shrm` (embedded mode). Each Register* adds one subcommand whose callback
// stores its outcome in *status; main() turns that into the exit code (docs/cli.md).
#ifndef SHRM_CLI_COMMANDS_H_
#define SHRM_CLI_COMMANDS_H_

#include <CLI/CLI.hpp>

#include "absl/status/status.h"

namespace shrm::cli {

void RegisterAnalyze(CLI::App& app, absl::Status* status);
void RegisterPrefilter(CLI::App& app, absl::Status* status);
void RegisterEval(CLI::App& app, absl::Status* status);
void RegisterReference(CLI::App& app, absl::Status* status);
void RegisterRender(CLI::App& app, absl::Status* status);
void RegisterExplicit(CLI::App& app, absl::Status* status);
void RegisterIrradiance(CLI::App& app, absl::Status* status);
void RegisterIbl(CLI::App& app, absl::Status* status);
void RegisterInfo(CLI::App& app, absl::Status* status);
void RegisterBatch(CLI::App& app, absl::Status* status);
void RegisterLive(CLI::App& app, absl::Status* status);
void RegisterSky(CLI::App& app, absl::Status* status);

}  // namespace shrm::cli

#endif  // SHRM_CLI_COMMANDS_H_
