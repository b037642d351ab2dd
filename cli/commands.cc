#include "cli/commands.h"

#include <cstdio>
#include <string>
#include <vector>

#include "cli/cli_common.h"
#include "jobs/cli_validators.h"
#include "shrm/version.h"

namespace shrm::cli {

std::span<const Command> Commands() {
  static constexpr Command kCommands[] = {
      {"analyze", "orders and error estimates (sec. 5.5) of a map, a BRDF, or both", DefineAnalyze},
      {"prefilter", "compute the SHRM of a map and a BRDF", DefinePrefilter},
      {"eval", "reflected radiance from an SHRM file at one (N, V)", DefineEval},
      {"reference", "brute-force reflected radiance over the map's pixels at one (N, V)",
       DefineReference},
      {"render", "the reflection map of an SHRM for one view (eq. 5.35)", DefineRender},
      {"explicit", "explicit reflection maps from an SHRM: Cabral, Kautz-McCool or a view grid",
       DefineExplicit},
      {"irradiance", "Lambertian irradiance: 9 SH coefficients and an irradiance cube map",
       DefineIrradiance},
      {"ibl",
       "the split-sum IBL set: GGX (and sheen) radiance mips, irradiance cube and SH, DFG LUT",
       DefineIbl},
      {"info", "print an SHRM file's header and sizes", DefineInfo},
      {"batch", "prefilter every map of a manifest with every BRDF (resumable)", DefineBatch},
      {"live", "prefilter a sequence of lighting states with one live session (docs/live.md)",
       DefineLive},
      {"sky",
       "a procedural daylight sky (Preetham 1999) with the sun of a date, time and place, as a "
       "lat-long EXR (docs/sky.md)",
       DefineSky},
      {"brdf-table",
       "sample a BRDF model into the table that --brdf table:PATH reads (docs/cli.md)",
       DefineBrdfTable},
  };
  return kCommands;
}

const Command* ChosenCommand(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (!arg.empty() && arg[0] == '-') continue;
    for (const Command& c : Commands()) {
      if (c.name == arg) return &c;
    }
    return nullptr;
  }
  return nullptr;
}

namespace {

// -h or --help before any "--" (CLI11's rule for its help flag).
bool WantsHelp(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--") return false;
    if (arg == "-h" || arg == "--help") return true;
  }
  return false;
}

}  // namespace

int RunShrm(int argc, char** argv) {
  SetCommandLine(argc, argv);
  CLI::App app{"shrm: frequency-space prefiltering of HDR environment maps (SHRMs)", "shrm"};
  app.set_version_flag("--version", VersionText("shrm"),
                       "print the version, git revision and conventions version and exit");
  app.require_subcommand(1);
  absl::Status status;
  // Defining a subcommand's options costs start-up time (CLI11 builds every option and its
  // validators); the others are only listed.
  const Command* chosen = ChosenCommand(argc, argv);
  CLI::App* chosen_sub = nullptr;
  for (const Command& c : Commands()) {
    CLI::App* sub = app.add_subcommand(std::string(c.name), std::string(c.description));
    if (&c == chosen) {
      c.define(sub, &status);
      jobs::RefuseEmptyValues(sub);
      chosen_sub = sub;
    }
  }
  // --help is answered here: CLI11 signals it with an exception, and a process's first exception
  // costs ~1 ms (the unwinder's first search of every loaded object). The text is CLI11's own.
  if (WantsHelp(argc, argv)) {
    const std::string text = chosen_sub != nullptr ? chosen_sub->help(app.get_name()) : app.help();
    std::fputs(text.c_str(), stdout);
    return kExitOk;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // An unknown option: named, with the nearest known one (CLI11 lists the extras in reverse).
    if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
      const std::string msg =
          jobs::UnknownOptionMessage(chosen_sub != nullptr ? *chosen_sub : app,
                                     std::vector<std::string>(argv + 1, argv + argc));
      if (!msg.empty()) {
        std::fprintf(stderr, "%s\nRun with --help for more information.\n", msg.c_str());
        return kExitUsage;
      }
    }
    const int rc = app.exit(e);
    return rc == 0 ? kExitOk : kExitUsage;
  }
  if (!status.ok()) {
    std::fprintf(stderr, "shrm: error: %s\n", std::string(status.message()).c_str());
    return kExitError;
  }
  return kExitOk;
}

}  // namespace shrm::cli
