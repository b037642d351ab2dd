#include "cli/cli_common.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/envmap/lighting.h"
#include "core/io/atomic_file.h"
#include "core/io/image.h"
#include "core/io/image_module.h"
#include "core/io/sha256.h"
#include "jobs/cli_validators.h"
#include "jobs/job_options.h"
#include "jobs/option_text.h"
#include "jobs/point_jobs.h"

namespace shrm::cli {

namespace {

std::string Help(std::string_view option) {
  const jobs::JobOption* o = jobs::FindPrefilterJobOption(option);
  return o != nullptr ? std::string(o->help) : std::string();
}

}  // namespace

void AddEnvOptions(CLI::App* app, EnvArgs* args, bool required) {
  auto* env = app->add_option("--env", args->files, Help("env"))->expected(1, 6)->take_all();
  if (required) env->required();
  app->add_option("--layout", args->layout, Help("layout"))->capture_default_str();
  app->add_option("--colour-space", args->colour_space, Help("colour_space"));
  app->add_option("--working-space", args->working_space, Help("working_space"))
      ->capture_default_str();
  app->add_option("--ocio-config", args->ocio_config, Help("ocio_config"));
  app->add_option("--rotate", args->rotate, Help("rotate"))->delimiter(',')->expected(3);
  app->add_flag("--replace-non-finite", args->replace_non_finite, Help("replace_non_finite"));
}

absl::StatusOr<jobs::EnvironmentSpec> EnvSpecFromArgs(const EnvArgs& args) {
  jobs::EnvironmentSpec env;
  env.files = args.files;
  SHRM_ASSIGN_OR_RETURN(env.layout, ParseEnvLayout(args.layout));
  env.input_colour_space = args.colour_space;
  env.working_colour_space = args.working_space;
  env.ocio_config = args.ocio_config;
  if (!args.rotate.empty()) {
    if (args.rotate.size() != 3) {
      return absl::InvalidArgumentError("--rotate takes yaw,pitch,roll (three numbers, degrees)");
    }
    for (double a : args.rotate) {
      if (!std::isfinite(a)) return absl::InvalidArgumentError("--rotate angles must be finite");
    }
    env.rotate_ypr_deg = std::array<double, 3>{args.rotate[0], args.rotate[1], args.rotate[2]};
  }
  env.replace_non_finite = args.replace_non_finite;
  return env;
}

absl::StatusOr<EnvMap> LoadEnv(const jobs::EnvironmentSpec& spec) {
  SHRM_ASSIGN_OR_RETURN(EnvMap env, EnvMap::Load(jobs::EnvMapOptionsFor(spec)));
  WarnReplacedNonFinite(env.replaced_non_finite());
  return env;
}

void WarnReplacedNonFinite(int64_t count) {
  if (count > 0) {
    std::fprintf(stderr, "shrm: warning: %lld non-finite values replaced by 0\n",
                 static_cast<long long>(count));
  }
}

namespace {

// The security flags of --server (one subcommand runs per process), as given.
struct ServerFlagValues {
  std::string token_file, tls_ca_file, tls_cert_file, tls_key_file, tls_server_name;
};
ServerFlagValues& ServerFlags() {
  static ServerFlagValues flags;
  return flags;
}

struct CommandLine {
  int argc = 0;
  char** argv = nullptr;
};
CommandLine& ThisCommandLine() {
  static CommandLine line;
  return line;
}

}  // namespace

void SetCommandLine(int argc, char** argv) { ThisCommandLine() = {argc, argv}; }

void AddServerOption(CLI::App* app, std::string* server) {
  app->add_option("--server", *server,
                  "run on an shrmd service at host:port (or dns:///host:port) instead of "
                  "in-process; the map files are uploaded when the server lacks them");
  ServerFlagValues& o = ServerFlags();
  app->add_option("--token-file", o.token_file,
                  "with --server: file whose first line is the bearer token (else "
                  "$SHRM_TOKEN_FILE)")
      ->check(CLI::ExistingFile);
  app->add_option(
         "--tls-ca", o.tls_ca_file,
         "with --server: PEM CA of the server certificate; enables TLS (else $SHRM_TLS_CA)")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-cert", o.tls_cert_file,
                  "with --server: PEM client certificate for mutual TLS (else $SHRM_TLS_CERT)")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-key", o.tls_key_file,
                  "with --server: PEM key of --tls-cert (else $SHRM_TLS_KEY)")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-server-name", o.tls_server_name,
                  "with --server: the name checked against the server certificate");
}

#if SHRM_CLI_HAS_CLIENT

absl::StatusOr<std::unique_ptr<client::ShrmClient>> ConnectServer(const std::string& server) {
  const ServerFlagValues& f = ServerFlags();
  if (!f.tls_cert_file.empty() != !f.tls_key_file.empty()) {
    return absl::InvalidArgumentError("--tls-cert and --tls-key go together");
  }
  client::ClientOptions o;
  o.token_file = f.token_file;
  o.tls_ca_file = f.tls_ca_file;
  o.tls_cert_file = f.tls_cert_file;
  o.tls_key_file = f.tls_key_file;
  o.tls_server_name = f.tls_server_name;
  absl::StatusOr<std::unique_ptr<client::ShrmClient>> c = client::ShrmClient::Connect(server, o);
  if (!c.ok()) return WithMessage(c.status(), absl::StrCat("--server: ", c.status().message()));
  return c;
}

client::RetryCallback RetryReporter(const std::string& server, bool quiet) {
  if (quiet) return nullptr;
  return [server](const absl::Status& s, int attempt, int max_attempts) {
    std::fprintf(stderr, "shrm: %s: %s; retrying (attempt %d of %d)\n", server.c_str(),
                 std::string(s.message()).c_str(), attempt, max_attempts);
  };
}

#else

absl::Status RunWithClient() {
  const CommandLine& line = ThisCommandLine();
  if (line.argv == nullptr) {
    return absl::InternalError("--server: the command line was not kept (SetCommandLine)");
  }
  std::vector<std::string> tried;
  for (const std::string& dir : image_module::SearchDirs()) {
    const std::string path = absl::StrCat(dir, "/", kRemoteProgram);
    if (::access(path.c_str(), X_OK) != 0) {
      tried.push_back(absl::StrCat(path, " (", std::strerror(errno), ")"));
      continue;
    }
    std::fflush(nullptr);
    ::execv(path.c_str(), line.argv);  // returns only on failure
    tried.push_back(absl::StrCat(path, " (", std::strerror(errno), ")"));
  }
  return absl::FailedPreconditionError(absl::StrCat(
      "--server needs shrm's service client (", kRemoteProgram, "), which cannot be run; tried: ",
      absl::StrJoin(tried, "; "), ". Reinstall shrm or set SHRM_MODULE_DIR"));
}

#endif

absl::StatusOr<Vec3> ParseDirection(const std::string& text, const char* what) {
  return jobs::ParseDirectionText(text, what);
}

absl::Status ParseJobCommandLine(std::vector<std::string> args, const std::string& name,
                                 const std::function<void(CLI::App*)>& add_options) {
  CLI::App app;
  std::string output;
  CLI::App* sub = app.add_subcommand(name);
  add_options(sub);
  sub->add_option("-o,--output", output)->required();
  jobs::RefuseEmptyValues(sub);
  std::reverse(args.begin(), args.end());  // CLI11 parses a reversed vector
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    return absl::InvalidArgumentError(e.what());
  }
  return absl::OkStatus();
}

int ResolveThreads(int requested) {
  return requested > 0 ? requested
                       : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

Progress::Progress(bool verbose, bool quiet) : enabled_(!quiet && (verbose || ::isatty(2))) {}

void Progress::Begin(const std::string& stage) {
  stage_ = stage;
  start_ = std::chrono::steady_clock::now();
  if (enabled_) std::fprintf(stderr, "[shrm] %-28s ...", stage.c_str());
}

double Progress::End() {
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
  if (enabled_) std::fprintf(stderr, " %9.1f ms\n", ms);
  return ms;
}

absl::Status CheckOutputExtension(const std::string& path, const char* option,
                                  std::initializer_list<const char*> extensions,
                                  const char* content) {
  if (path.empty()) return absl::OkStatus();
  std::vector<std::string> names;
  for (const char* e : extensions) {
    if (absl::EndsWithIgnoreCase(path, e)) return absl::OkStatus();
    names.push_back(absl::StrCat("*", e));
  }
  return absl::InvalidArgumentError(
      absl::StrCat(option, " ", path, ": ", content, ": name it ", absl::StrJoin(names, " or ")));
}

absl::Status CheckOutputPath(const std::string& path, const char* option,
                             std::span<const OptionPath> inputs) {
  if (path.empty()) return absl::OkStatus();
  namespace fs = std::filesystem;
  const fs::path p(path);
  for (const OptionPath& in : inputs) {
    std::error_code ec;
    if (!in.path.empty() && fs::equivalent(p, fs::path(in.path), ec) && !ec) {
      return absl::InvalidArgumentError(
          absl::StrCat(option, " ", path, " is the input file of ", in.option, " (", in.path,
                       "): writing it would replace that input; choose another output path"));
    }
  }
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat(option, " ", path, ": folder ", dir.string(), " does not exist"));
  }
  if (!fs::is_directory(dir, ec)) {
    return absl::InvalidArgumentError(
        absl::StrCat(option, " ", path, ": ", dir.string(), " is not a folder"));
  }
  if (fs::is_directory(p, ec)) {
    return absl::InvalidArgumentError(absl::StrCat(option, " ", path, " is a folder"));
  }
  const std::string probe = TempPathFor(path);
  std::FILE* f = std::fopen(probe.c_str(), "wb");
  if (f == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat(option, " ", path, ": cannot create files in ", dir.string()));
  }
  std::fclose(f);
  DiscardTempFile(probe);
  return absl::OkStatus();
}

absl::Status CheckDistinctOutputs(std::span<const OptionPath> outputs) {
  namespace fs = std::filesystem;
  std::vector<fs::path> canonical;
  for (const OptionPath& o : outputs) {
    std::error_code ec;
    // Absolute first: weakly_canonical leaves a relative path whose file does not exist yet
    // relative ("a.exr"), and makes "./a.exr" absolute.
    const fs::path absolute = o.path.empty() ? fs::path() : fs::absolute(fs::path(o.path), ec);
    fs::path c = ec ? fs::path() : fs::weakly_canonical(absolute, ec);
    canonical.push_back(ec ? absolute.lexically_normal() : c);
  }
  for (size_t i = 0; i < outputs.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (outputs[i].path.empty() || outputs[j].path.empty() || canonical[i] != canonical[j]) {
        continue;
      }
      return absl::InvalidArgumentError(absl::StrCat(outputs[i].option, " ", outputs[i].path,
                                                     " is also the path of ", outputs[j].option,
                                                     ": each output needs a path of its own"));
    }
  }
  return absl::OkStatus();
}

std::vector<OptionPath> JobInputFiles(const jobs::EnvironmentSpec& env, const std::string& brdf) {
  std::vector<OptionPath> out;
  for (const std::string& f : env.files) out.push_back({"--env", f});
  if (const std::optional<std::string> file = BrdfSpecFile(brdf)) out.push_back({"--brdf", *file});
  return out;
}

OutputTransaction::~OutputTransaction() {
  if (committed_) return;
  for (const auto& [tmp, final_path] : files_) DiscardTempFile(tmp);
}

std::string OutputTransaction::Temp(const std::string& final_path) {
  files_.emplace_back(TempPathFor(final_path), final_path);
  return files_.back().first;
}

absl::Status OutputTransaction::Commit() {
  for (const auto& [tmp, final_path] : files_) {
    absl::Status s = CommitTempFile(tmp, final_path);
    if (!s.ok()) return s;  // the destructor removes the temporaries not yet renamed
  }
  committed_ = true;
  return absl::OkStatus();
}

absl::Status WriteRadianceCross(const std::string& path, const RadianceCube& cube) {
  return WriteExr(path, jobs::RadianceCrossImage(cube));
}

}  // namespace shrm::cli
