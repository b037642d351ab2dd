// Shared pieces of the `shrm` subcommands: environment-map options (mapped onto the job layer's
// EnvironmentSpec), --server, progress lines, output transactions and radiance-cube files.
// docs/cli.md documents every option.
#ifndef SHRM_CLI_CLI_COMMON_H_
#define SHRM_CLI_CLI_COMMON_H_

#include <CLI/CLI.hpp>
#include <chrono>
#include <functional>
#include <initializer_list>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#if SHRM_CLI_HAS_CLIENT
#include "client/remote_jobs.h"
#include "client/shrm_client.h"
#endif
#include "core/base/geometry.h"
#include "core/envmap/envmap.h"
#include "core/shrm/radiance_cube.h"
#include "jobs/environment.h"

namespace shrm::cli {

// Exit codes (docs/cli.md).
inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;  // bad input, failed computation or output
inline constexpr int kExitUsage = 2;  // unknown option, missing or malformed argument

struct EnvArgs {
  std::vector<std::string> files;  // one map, or six cube faces (+X -X +Y -Y +Z -Z)
  std::string layout = "auto";
  std::string colour_space;  // "" = from the file's pixel type
  std::string working_space = jobs::kDefaultWorkingSpace;
  std::string ocio_config;
  std::vector<double> rotate;  // yaw, pitch, roll in degrees
  bool replace_non_finite = false;
};

// Adds --env (repeatable for six faces), --layout, --colour-space, --working-space,
// --ocio-config, --rotate, --replace-non-finite (help texts: jobs/job_options.h).
void AddEnvOptions(CLI::App* app, EnvArgs* args, bool required);
// The flags as the job layer's environment (InvalidArgument naming the flag).
absl::StatusOr<jobs::EnvironmentSpec> EnvSpecFromArgs(const EnvArgs& args);
// Decodes the map (a warning on stderr for replaced non-finite pixels).
absl::StatusOr<EnvMap> LoadEnv(const jobs::EnvironmentSpec& env);
// The warning for `count` NaN/Inf pixels replaced by 0 (nothing for 0).
void WarnReplacedNonFinite(int64_t count);

// --server host:port (or dns:///host:port): run the subcommand on an shrmd service; also the
// connection's security flags --token-file, --tls-ca, --tls-cert, --tls-key, --tls-server-name
// (they override SHRM_TOKEN_FILE, SHRM_TLS_CA, SHRM_TLS_CERT, SHRM_TLS_KEY; docs/server.md).
void AddServerOption(CLI::App* app, std::string* server);
#if SHRM_CLI_HAS_CLIENT
// A client for --server with the security flags given to this process.
absl::StatusOr<std::unique_ptr<client::ShrmClient>> ConnectServer(const std::string& server);
// Prints each retry of a remote job on stderr unless `quiet`.
client::RetryCallback RetryReporter(const std::string& server, bool quiet);
#else
// The `shrm` program has no service client: gRPC and Protobuf would cost every command their
// start-up time (docs/architecture.md "Start-up"). A command line with --server is run again,
// whole and as given, by the program that has the client (shrm-remote, found where the image
// module is: core/io/image_module.h). Replaces the process; returns only when that program
// cannot be run, with an error that names where it looked.
[[nodiscard]] absl::Status RunWithClient();
#endif
// The program that runs command lines with --server (installed to LIBDIR/shrm).
inline constexpr char kRemoteProgram[] = "shrm-remote";
// Keeps the command line of this process (for RunWithClient).
void SetCommandLine(int argc, char** argv);

// Parses "x,y,z" into a unit vector; errors name `what` (e.g. "--normal").
absl::StatusOr<Vec3> ParseDirection(const std::string& text, const char* what);

// Parses a subcommand's command line (without the program name, starting with `name`) into the
// arguments `add_options` registers (and a required -o), without running anything
// (tests/job_front_ends_test.cc); InvalidArgument with CLI11's message.
absl::Status ParseJobCommandLine(std::vector<std::string> args, const std::string& name,
                                 const std::function<void(CLI::App*)>& add_options);

// Worker threads: `requested` if > 0, else the hardware concurrency.
int ResolveThreads(int requested);

// Stage lines on stderr ("[shrm] decode ... 12.3 ms") when stderr is a terminal or `verbose`.
class Progress {
 public:
  // `quiet` disables the lines even on a terminal (concurrent batch jobs).
  explicit Progress(bool verbose, bool quiet = false);
  void Begin(const std::string& stage);
  // Ends the current stage; returns its duration in milliseconds.
  double End();

 private:
  bool enabled_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_;
};

// Stage lines of a remote run: each stage ends when the next one starts.
class StageLines {
 public:
  explicit StageLines(Progress* progress) : progress_(progress) {}
  void Begin(const std::string& stage) {
    End();
    progress_->Begin(stage);
    open_ = true;
  }
  double End() {
    if (!open_) return 0;
    open_ = false;
    return progress_->End();
  }

 private:
  Progress* progress_;
  bool open_ = false;
};

// A file of a command and the option that names it.
struct OptionPath {
  const char* option;
  std::string path;
};

// Checks before any work that an output can be created: its folder exists, is a folder, and a
// file can be created in it (probed with a temporary that is removed), and that it is none of
// `inputs` (the same file by any name: the output's rename would replace the user's input, e.g.
// `shrm prefilter --env map.exr -o map.exr`). Errors name the option and the path. Empty paths
// (optional outputs not asked for) pass.
absl::Status CheckOutputPath(const std::string& path, const char* option,
                             std::span<const OptionPath> inputs = {});

// An output written in one container is named for it: InvalidArgument "OPTION PATH: CONTENT:
// name it *.EXT" unless `path` ends with one of `extensions` (case-insensitive), e.g. "--output
// x.png: the SHRM is written as OpenEXR: name it *.exr" (a reader or viewer picks the format by
// the name). Empty paths pass.
absl::Status CheckOutputExtension(const std::string& path, const char* option,
                                  std::initializer_list<const char*> extensions,
                                  const char* content);

// Fails when two of a command's outputs name the same file (by any name, existing or not): the
// second would replace the first ("--report a.exr is also --output").
absl::Status CheckDistinctOutputs(std::span<const OptionPath> outputs);

// The input files of a job: its map's files (--env) and a BRDF's file (table:PATH, merl:PATH).
std::vector<OptionPath> JobInputFiles(const jobs::EnvironmentSpec& env, const std::string& brdf);

// The outputs of one command, committed together: each is written to a temporary path (Temp())
// and renamed into place by Commit(); if the command fails before Commit(), the destructor
// removes every temporary, so no output (and no old output) is touched.
class OutputTransaction {
 public:
  OutputTransaction() = default;
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;
  ~OutputTransaction();
  // The temporary path to write `final_path` to.
  std::string Temp(const std::string& final_path);
  absl::Status Commit();

 private:
  std::vector<std::pair<std::string, std::string>> files_;  // (temporary, final)
  bool committed_ = false;
};

// Writes a radiance cube as a horizontal-cross EXR (4S x 3S: [. +Y . .] [-X +Z +X -Z]
// [. -Y . .], GL face orientation, as core/envmap reads it back), atomically.
absl::Status WriteRadianceCross(const std::string& path, const RadianceCube& cube);

}  // namespace shrm::cli

#endif  // SHRM_CLI_CLI_COMMON_H_
