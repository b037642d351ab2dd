// shrmd: the shrm prefilter service (gRPC, shrm.v1.Shrm). docs/server.md documents every flag.
#include <grpcpp/grpcpp.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "jobs/cli_validators.h"
#include "server/config_file.h"
#include "server/decoder_sandbox.h"
#include "server/memory_budget.h"
#include "server/request_log.h"
#include "server/server.h"
#include "shrm/version.h"

namespace {

// Defaults (docs/server.md).
constexpr int kDefaultPort = 50051;
constexpr double kDefaultGraceSeconds = 30;
constexpr uint64_t kMiB = 1ull << 20;
// Exit codes: 0 a clean stop (or --help, --version), 1 a start-up error, 2 a usage error.
constexpr int kExitOk = 0;
constexpr int kExitUsage = 2;

std::string DefaultSpoolDir() {
  const char* tmp = std::getenv("TMPDIR");
  return (std::filesystem::path(tmp && *tmp ? tmp : "/tmp") / "shrmd-spool").string();
}

}  // namespace

int main(int argc, char** argv) {
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  shrm::server::ServerOptions opt;
  opt.listen = "[::]:" + std::to_string(kDefaultPort);
  opt.service.spool_dir = DefaultSpoolDir();
  opt.service.max_jobs = cores;
  uint64_t spool_mib = opt.service.spool_bytes / kMiB;
  uint64_t max_blob_mib = opt.service.max_blob_bytes / kMiB;
  uint64_t cache_mib = opt.service.cache_bytes / kMiB;
  uint64_t memory_mib = 0;  // 0: from the system (SystemMemoryLimit)
  int job_threads = 0;
  double grace_s = kDefaultGraceSeconds;
  std::string decode_isolation = "process";
  uint64_t decode_memory_mib = opt.service.decode_limits.memory_bytes / kMiB;
  double decode_timeout_s = absl::ToDoubleSeconds(opt.service.decode_limits.timeout);
  double idle_timeout_s = absl::ToDoubleSeconds(opt.service.idle_timeout);

  CLI::App app{"shrmd: the shrm prefilter service (gRPC shrm.v1.Shrm; docs/server.md)", "shrmd"};
  app.set_version_flag("--version", shrm::VersionText("shrmd"),
                       "print the version, git revision and conventions version and exit");
  app.add_option("--listen", opt.listen, "address to listen on, host:port (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--spool-dir", opt.service.spool_dir,
                 "blob store directory (uploaded maps, files named by SHA-256)")
      ->capture_default_str();
  app.add_option("--spool-mib", spool_mib, "blob store bound in MiB (LRU eviction)")
      ->capture_default_str()
      ->check(shrm::jobs::kPositive);
  app.add_option("--max-blob-mib", max_blob_mib, "largest accepted upload in MiB")
      ->capture_default_str()
      ->check(shrm::jobs::kPositive);
  app.add_option("--max-jobs", opt.service.max_jobs,
                 "concurrent Prefilter/Analyze jobs; more are refused with RESOURCE_EXHAUSTED "
                 "(default: the number of cores)")
      ->capture_default_str()
      ->check(shrm::jobs::kPositive);
  app.add_option("--job-threads", job_threads,
                 "worker threads per job (0: cores / max-jobs, at least 1)")
      ->capture_default_str()
      ->check(shrm::jobs::kNonNegative);
  app.add_option("--cache-mib", cache_mib, "L_lm and rho_lpq caches together, in MiB (LRU)")
      ->capture_default_str();
  app.add_option("--memory-mib", memory_mib,
                 "memory budget of the daemon in MiB: every job's stages reserve their estimated "
                 "peak from it first; a job that does not fit now gets RESOURCE_EXHAUSTED (retried "
                 "by clients), one larger than the budget INVALID_ARGUMENT (default: 3/4 of the "
                 "cgroup's memory limit, or of the machine's memory)")
      ->check(shrm::jobs::kPositive);
  app.add_option("--grace-period", grace_s,
                 "seconds running jobs get to finish after SIGTERM/SIGINT")
      ->capture_default_str()
      ->check(shrm::jobs::kNonNegative);
  app.add_option("--idle-timeout", idle_timeout_s,
                 "seconds an upload may go without a chunk, or a client without reading the "
                 "result, before the call is ended (0: never)")
      ->capture_default_str()
      ->check(shrm::jobs::kNonNegative);
  app.add_option("--decode-isolation", decode_isolation,
                 "'process': every uploaded map is first decoded in an isolated child process, so "
                 "an input that crashes the decoder costs that process, not the daemon; 'off': "
                 "decode in the daemon only")
      ->capture_default_str()
      ->check(CLI::IsMember({"process", "off"}));
  app.add_option("--decode-memory-mib", decode_memory_mib,
                 "address-space limit of an isolated decoding process, in MiB")
      ->capture_default_str()
      ->check(shrm::jobs::kPositive);
  app.add_option("--decode-timeout", decode_timeout_s,
                 "seconds an isolated decoding process may take (wall and CPU time)")
      ->capture_default_str()
      ->check(shrm::jobs::kPositive);
  // Testing only (tests/deploy_test.sh): files starting with SHRM-TEST-POISON crash the isolated
  // decoder, SHRM-TEST-HANG make it hang.
  app.add_flag("--test-decoder-hooks", opt.service.decode_limits.test_hooks)->group("");
  // Testing only (tests/deploy_test.sh): Prefilter jobs with this brdf spec wait before writing
  // their result until the daemon begins draining.
  app.add_option("--test-hold-brdf", opt.service.test_hold_brdf)->group("");
  app.add_flag("--reflection", opt.reflection, "enable gRPC server reflection");
  app.add_option("--metrics-port", opt.metrics_port,
                 "serve Prometheus metrics on GET /metrics at this port (-1: off, 0: any)")
      ->capture_default_str()
      ->check(shrm::jobs::InRange(-1, 65535));
  app.add_option("--metrics-address", opt.metrics_address,
                 "IPv4 address of the metrics endpoint (loopback by default)")
      ->capture_default_str();
  app.add_option("--token-file", opt.security.token_file,
                 "bearer tokens, one a line: every call needs 'authorization: Bearer <token>' "
                 "(without TLS the listen address must be loopback)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-cert", opt.security.tls_cert_file, "PEM server certificate (chain)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", opt.security.tls_key_file, "PEM private key of --tls-cert")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-client-ca", opt.security.tls_client_ca,
                 "PEM CA: require client certificates signed by it (mutual TLS)")
      ->check(CLI::ExistingFile);
  std::string config_path;
  app.add_option("--config", config_path,
                 "config file: 'key = value' lines, keys are the long flag names; flags on the "
                 "command line override it")
      ->check(CLI::ExistingFile);
  // Usage errors exit 2, as the shrm command's and shrm-view's do (docs/server.md); CLI11's own
  // codes (105 for a missing file, 109 for an extra argument, ...) said nothing a unit could use.
  // --help and --version print and exit 0.
  const auto parse = [&app](int n, char** v) -> std::optional<int> {
    try {
      app.parse(n, v);
    } catch (const CLI::ParseError& e) {
      if (dynamic_cast<const CLI::ExtrasError*>(&e) != nullptr) {
        const std::string unknown =
            shrm::jobs::UnknownOptionMessage(app, std::vector<std::string>(v + 1, v + n));
        if (!unknown.empty()) {
          std::fprintf(stderr, "%s\nRun with --help for more information.\n", unknown.c_str());
          return kExitUsage;
        }
      }
      return app.exit(e) == 0 ? kExitOk : kExitUsage;
    }
    return std::nullopt;
  };
  if (const std::optional<int> rc = parse(argc, argv)) return *rc;
  if (!config_path.empty()) {
    // Parse again with the file's settings in front of the command line, leaving out the keys
    // the command line already gave (so they win).
    absl::StatusOr<std::vector<shrm::server::ConfigEntry>> entries =
        shrm::server::ReadConfigFile(config_path);
    absl::StatusOr<std::vector<std::string>> extra =
        entries.ok()
            ? shrm::server::ConfigToArgs(
                  *entries, {"reflection"},
                  [&](const std::string& key) {
                    return key != "config" && app.get_option_no_throw("--" + key) != nullptr;
                  },
                  [&](const std::string& key) {
                    return app.get_option_no_throw("--" + key)->count() > 0;
                  })
            : absl::StatusOr<std::vector<std::string>>(entries.status());
    if (!extra.ok()) {
      std::fprintf(stderr, "shrmd: error: %s: %s\n", config_path.c_str(),
                   std::string(extra.status().message()).c_str());
      return 1;
    }
    std::vector<std::string> args = {argv[0]};
    args.insert(args.end(), extra->begin(), extra->end());
    for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
    std::vector<char*> argv2;
    for (std::string& a : args) argv2.push_back(a.data());
    if (const std::optional<int> rc = parse(static_cast<int>(argv2.size()), argv2.data()))
      return *rc;
  }

  opt.service.spool_bytes = spool_mib * kMiB;
  opt.service.max_blob_bytes = max_blob_mib * kMiB;
  opt.service.cache_bytes = cache_mib * kMiB;
  if (memory_mib > 0) {
    opt.service.memory_bytes = memory_mib * kMiB;
    opt.service.memory_text = absl::StrCat("--memory-mib ", memory_mib);
  } else {
    // Three quarters: the rest is for the isolated decoders (same cgroup) and the allocator's
    // fragmentation.
    const shrm::server::SystemMemory system = shrm::server::SystemMemoryLimit();
    opt.service.memory_bytes = system.bytes / 4 * 3;
    opt.service.memory_text =
        absl::StrCat("--memory-mib ", opt.service.memory_bytes / kMiB, ": 3/4 of ", system.source);
  }
  opt.service.job_threads =
      job_threads > 0 ? job_threads : std::max(1, cores / opt.service.max_jobs);
  opt.service.decode_limits.memory_bytes = decode_memory_mib * kMiB;
  opt.service.decode_limits.timeout = absl::Seconds(decode_timeout_s);
  opt.service.idle_timeout = absl::Seconds(idle_timeout_s);

  // A file-size limit (RLIMIT_FSIZE) must fail a spool write with EFBIG (the upload gets
  // RESOURCE_EXHAUSTED), not kill the daemon with SIGXFSZ.
  signal(SIGXFSZ, SIG_IGN);

  // The decoder sandbox's zygote is forked now, before this process starts any thread.
  std::unique_ptr<shrm::server::DecoderSandbox> sandbox;
  if (decode_isolation == "process") {
    absl::StatusOr<std::unique_ptr<shrm::server::DecoderSandbox>> started =
        shrm::server::DecoderSandbox::Start();
    if (!started.ok()) {
      std::fprintf(stderr, "shrmd: error: %s\n", std::string(started.status().message()).c_str());
      return 1;
    }
    sandbox = *std::move(started);
    opt.service.decoder_sandbox = sandbox.get();
  }

  // Signals are taken by one thread with sigwait (blocked everywhere else, including the gRPC
  // threads created below).
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  absl::StatusOr<std::unique_ptr<shrm::server::ShrmServer>> server =
      shrm::server::ShrmServer::Start(opt);
  if (!server.ok()) {
    std::fprintf(stderr, "shrmd: error: %s\n", std::string(server.status().message()).c_str());
    return 1;
  }
  std::thread signal_thread([&] {
    int sig = 0;
    sigwait(&signals, &sig);
    shrm::server::LogEvent("signal", {{"signal", sig == SIGTERM ? "SIGTERM" : "SIGINT"}});
    (*server)->Shutdown(absl::Seconds(grace_s));
  });
  (*server)->Wait();
  signal_thread.join();
  return 0;
}
