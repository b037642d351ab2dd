// The subcommands of `shrm`. Each Define* gives one subcommand its options and a callback that
// stores its outcome in *status; main() turns that into the exit code (docs/cli.md). The table
// (Commands()) names and describes them, so that `shrm --help` lists every subcommand while only
// the one a command line runs is defined (docs/architecture.md "Start-up").
#ifndef SHRM_CLI_COMMANDS_H_
#define SHRM_CLI_COMMANDS_H_

#include <CLI/CLI.hpp>
#include <span>
#include <string_view>

#include "absl/status/status.h"

namespace shrm::cli {

void DefineAnalyze(CLI::App* sub, absl::Status* status);
void DefinePrefilter(CLI::App* sub, absl::Status* status);
void DefineEval(CLI::App* sub, absl::Status* status);
void DefineReference(CLI::App* sub, absl::Status* status);
void DefineRender(CLI::App* sub, absl::Status* status);
void DefineExplicit(CLI::App* sub, absl::Status* status);
void DefineIrradiance(CLI::App* sub, absl::Status* status);
void DefineIbl(CLI::App* sub, absl::Status* status);
void DefineInfo(CLI::App* sub, absl::Status* status);
void DefineBatch(CLI::App* sub, absl::Status* status);
void DefineLive(CLI::App* sub, absl::Status* status);
void DefineSky(CLI::App* sub, absl::Status* status);
void DefineBrdfTable(CLI::App* sub, absl::Status* status);

struct Command {
  std::string_view name;
  std::string_view description;  // the line of `shrm --help`
  void (*define)(CLI::App* sub, absl::Status* status);
};

// Every subcommand, in the order `shrm --help` lists them.
std::span<const Command> Commands();

// The subcommand a command line runs: its first argument that is not an option, if that names
// one (the program's own options, --help and --version, take no values). Null otherwise.
const Command* ChosenCommand(int argc, const char* const* argv);

// The `shrm` program: every subcommand listed, the chosen one defined, the command line parsed
// and run; returns the exit code.
int RunShrm(int argc, char** argv);

}  // namespace shrm::cli

#endif  // SHRM_CLI_COMMANDS_H_
