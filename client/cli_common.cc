#include "client/cli_common.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/io/atomic_file.h"
#include "core/io/image.h"
#include "core/io/sha256.h"

namespace shrm::cli {

void AddEnvOptions(CLI::App* app, EnvArgs* args, bool required) {
  auto* env = app->add_option("--env", args->files,
                              "environment map file; give six files (+X -X +Y -Y +Z -Z) for a "
                              "cube stored as faces")
                  ->expected(1, 6)
                  ->take_all();
  if (required) env->required();
  app->add_option("--layout", args->layout,
                  "auto, latlong, cube, hcross, vcross, hstrip, vstrip, angular")
      ->capture_default_str();
  app->add_option("--colour-space", args->colour_space,
                  "input colour space (default: lin_rec709 for float files, srgb_texture for "
                  "8/16-bit)");
  app->add_option("--working-space", args->working_space, "linear working colour space")
      ->capture_default_str();
  app->add_option("--ocio-config", args->ocio_config,
                  "OpenColorIO config (default: $OCIO, then the built-in config)");
  app->add_option("--rotate", args->rotate,
                  "rotate the lighting by yaw,pitch,roll degrees (exactly, in SH space)")
      ->delimiter(',')
      ->expected(3);
  app->add_flag("--replace-non-finite", args->replace_non_finite,
                "replace NaN/Inf pixels by 0 with a warning (default: reject the map)");
}

absl::StatusOr<EnvMap> LoadEnv(const EnvArgs& args) {
  EnvMapOptions opt;
  opt.paths = args.files;
  SHRM_ASSIGN_OR_RETURN(opt.layout, ParseEnvLayout(args.layout));
  opt.input_colour_space = args.colour_space;
  opt.working_colour_space = args.working_space;
  opt.colour_config = args.ocio_config;
  opt.non_finite =
      args.replace_non_finite ? NonFinitePolicy::kReplaceZero : NonFinitePolicy::kReject;
  SHRM_ASSIGN_OR_RETURN(EnvMap env, EnvMap::Load(opt));
  if (env.replaced_non_finite() > 0) {
    std::fprintf(stderr, "shrm: warning: %lld non-finite values replaced by 0\n",
                 static_cast<long long>(env.replaced_non_finite()));
  }
  return env;
}

absl::StatusOr<Mat3> EnvRotation(const EnvArgs& args) {
  if (args.rotate.empty()) return Mat3::Identity();
  if (args.rotate.size() != 3) {
    return absl::InvalidArgumentError("--rotate takes yaw,pitch,roll (three numbers, degrees)");
  }
  for (double a : args.rotate) {
    if (!std::isfinite(a)) return absl::InvalidArgumentError("--rotate angles must be finite");
  }
  return RotationFromYawPitchRoll(args.rotate[0], args.rotate[1], args.rotate[2]);
}

absl::StatusOr<std::string> EnvSourceHash(const EnvArgs& args) {
  std::vector<std::string> hashes;
  for (const std::string& f : args.files) {
    SHRM_ASSIGN_OR_RETURN(std::string h, Sha256OfFile(f));
    hashes.push_back(std::move(h));
  }
  if (hashes.size() == 1) return hashes[0];
  return Sha256Hex(absl::StrJoin(hashes, ","));
}

namespace {
// The security flags of --server (one subcommand runs per process).
client::ClientOptions& ServerFlags() {
  static client::ClientOptions options;
  return options;
}
}  // namespace

void AddServerOption(CLI::App* app, std::string* server) {
  app->add_option("--server", *server,
                  "run on an shrmd service at host:port (or dns:///host:port) instead of "
                  "in-process; the map files are uploaded when the server lacks them");
  client::ClientOptions& o = ServerFlags();
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

absl::StatusOr<std::unique_ptr<client::ShrmClient>> ConnectServer(const std::string& server) {
  const client::ClientOptions& o = ServerFlags();
  if (!o.tls_cert_file.empty() != !o.tls_key_file.empty()) {
    return absl::InvalidArgumentError("--tls-cert and --tls-key go together");
  }
  return client::ShrmClient::Connect(server, o);
}

absl::Status RemoteEnvironment(const EnvArgs& args, client::ShrmClient* client,
                               shrm::v1::Environment* env) {
  if (!args.ocio_config.empty()) {
    return absl::InvalidArgumentError("--ocio-config is not available with --server");
  }
  SHRM_ASSIGN_OR_RETURN(EnvLayout layout, ParseEnvLayout(args.layout));
  static constexpr std::pair<EnvLayout, shrm::v1::Layout> kLayouts[] = {
      {EnvLayout::kAuto, shrm::v1::LAYOUT_UNSPECIFIED},
      {EnvLayout::kLatLong, shrm::v1::LAYOUT_LATLONG},
      {EnvLayout::kCubeFaces, shrm::v1::LAYOUT_CUBE_FACES},
      {EnvLayout::kHorizontalCross, shrm::v1::LAYOUT_HCROSS},
      {EnvLayout::kVerticalCross, shrm::v1::LAYOUT_VCROSS},
      {EnvLayout::kHorizontalStrip, shrm::v1::LAYOUT_HSTRIP},
      {EnvLayout::kVerticalStrip, shrm::v1::LAYOUT_VSTRIP},
      {EnvLayout::kAngular, shrm::v1::LAYOUT_ANGULAR}};
  for (const auto& [core, proto] : kLayouts)
    if (core == layout) env->set_layout(proto);
  if (!args.rotate.empty()) {
    SHRM_RETURN_IF_ERROR(EnvRotation(args).status());
    env->mutable_rotation()->set_yaw_deg(args.rotate[0]);
    env->mutable_rotation()->set_pitch_deg(args.rotate[1]);
    env->mutable_rotation()->set_roll_deg(args.rotate[2]);
  }
  env->set_input_colour_space(args.colour_space);
  env->set_working_colour_space(args.working_space);
  env->set_non_finite(args.replace_non_finite ? shrm::v1::NON_FINITE_POLICY_REPLACE_ZERO
                                              : shrm::v1::NON_FINITE_POLICY_REJECT);
  env->clear_sha256();
  env->clear_source_names();
  for (const std::string& f : args.files) {
    absl::StatusOr<std::string> sha = client->UploadIfMissing(f);
    if (!sha.ok()) {
      return absl::Status(sha.status().code(), absl::StrCat(f, ": ", sha.status().message()));
    }
    env->add_sha256(*sha);
    env->add_source_names(f);
  }
  return absl::OkStatus();
}

absl::Status RunRemoteJob(client::ShrmClient* client, const EnvArgs& env, const std::string& server,
                          bool quiet, const std::function<absl::Status()>& attempt, int* retries) {
  const int max_attempts = client->options().max_attempts;
  if (env.files.size() == 1) {
    absl::StatusOr<std::string> key = client->FileSha256(env.files[0]);
    if (key.ok()) client->set_affinity_key(*key);
  }
  int retried = 0, missing_blob_answers = 0;
  absl::Status s;
  for (int i = 0;; ++i) {
    if (i > 0) absl::SleepFor(client::RetryBackoff(client->options(), i));
    client->set_upload_copies(missing_blob_answers > 0 ? missing_blob_answers + 1 : 0);
    s = attempt();
    const bool missing_blob = absl::IsNotFound(s) && absl::StrContains(s.message(), "blob ");
    // A full server (every job slot busy) says when to come back; an oversized input does not.
    const int64_t retry_after_ms =
        absl::IsResourceExhausted(s) ? client->last_retry_after_ms() : int64_t{0};
    if (s.ok() || i + 1 >= max_attempts ||
        !(client::IsTransient(s) || missing_blob || retry_after_ms > 0)) {
      break;
    }
    if (retry_after_ms > 0) absl::SleepFor(absl::Milliseconds(retry_after_ms));
    ++retried;
    missing_blob_answers += missing_blob;
    if (!quiet) {
      std::fprintf(stderr, "shrm: %s: %s; retrying (attempt %d of %d)\n", server.c_str(),
                   std::string(s.message()).c_str(), i + 2, max_attempts);
    }
  }
  if (retries != nullptr) *retries = retried;
  if (s.ok()) return s;
  return absl::Status(
      s.code(),
      absl::StrCat(server, ": ", s.message(),
                   retried > 0 ? absl::StrCat(" (after ", retried, " retries)") : std::string()));
}

absl::StatusOr<Vec3> ParseDirection(const std::string& text, const char* what) {
  std::vector<std::string> parts = absl::StrSplit(text, ',');
  double v[3];
  if (parts.size() != 3 || !absl::SimpleAtod(parts[0], &v[0]) ||
      !absl::SimpleAtod(parts[1], &v[1]) || !absl::SimpleAtod(parts[2], &v[2])) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " must be three numbers x,y,z, got '", text, "'"));
  }
  const Vec3 d{v[0], v[1], v[2]};
  const double n = d.Norm();
  if (!std::isfinite(n) || n < 1e-12) {
    return absl::InvalidArgumentError(absl::StrCat(what, " must be a nonzero finite vector"));
  }
  return d * (1.0 / n);
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

absl::Status CheckOutputPath(const std::string& path, const char* option) {
  if (path.empty()) return absl::OkStatus();
  namespace fs = std::filesystem;
  const fs::path p(path);
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
  const int s = cube.face_size;
  Image img;
  img.width = 4 * s;
  img.height = 3 * s;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(img.width) * img.height * 3, 0.0f);
  // (column, row) cell of each GL face in the horizontal cross.
  constexpr int kCell[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
  for (int f = 0; f < kCubeFaceCount; ++f)
    for (int y = 0; y < s; ++y)
      for (int x = 0; x < s; ++x)
        for (int c = 0; c < 3; ++c)
          img.pixels[((static_cast<size_t>(kCell[f][1]) * s + y) * img.width + kCell[f][0] * s +
                      x) *
                         3 +
                     c] = cube.data[cube.Index(f, x, y, std::min(c, cube.channels - 1))];
  return WriteExr(path, img);
}

}  // namespace shrm::cli
