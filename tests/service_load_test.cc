// Load tests of the shrm service over loopback (in-process server on an ephemeral port): many
// concurrent clients with a mix of Prefilter and Analyze calls (every request answered once,
// correctly, byte-identical to the embedded run), and admission control under a burst of slow
// jobs with --max-jobs 1. Also the shrmd config file parser (server/config_file.h).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/shrm_client.h"
#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "core/io/sha256.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_file.h"
#include "jobs/prefilter_job.h"
#include "server/config_file.h"
#include "server/server.h"
#include "tests/stage_gate.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace v1 = ::shrm::v1;
using client::ShrmClient;
using server::ServerOptions;
using server::ShrmServer;

// Small jobs: a 16 x 16 face and explicit low orders keep each request to milliseconds once the
// caches are warm, so 400 requests finish in seconds even on a loaded 2-core machine.
constexpr int kLoadF = 8;
constexpr int kLoadP = 2;
constexpr int kLoadFaceSize = 16;
constexpr double kAnalyzeEpsilon = 0.1;
constexpr char kPrefilterBrdf[] = "phong:s=32";
constexpr char kAnalyzeBrdf[] = "phong:s=32";
constexpr int kLoadClients = 8;
constexpr int kRequestsPerClient = 50;
// Per-request deadline: generous (a warm request takes milliseconds) so a loaded CI machine does
// not fail the test, yet a lost request cannot hang the binary.
constexpr absl::Duration kLoadRequestDeadline = absl::Seconds(30);

// Admission burst: one job holds the single slot at a gate (tests/stage_gate.h) while the other
// clients arrive together.
constexpr int kBurstClients = 16;
// Safety net: how long the held job may take to reach the gate, and the deadline of the refused
// calls (a wrongly queued call fails instead of hanging). Passing never depends on it.
constexpr absl::Duration kGateTimeout = absl::Seconds(60);
// Attempts of a call that fails in the transport before it reaches the server.
constexpr int kTransportAttempts = 5;

std::string MapPath(const char* name) {
  return absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/", name);
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class ServiceLoadTest : public ::testing::Test {
 protected:
  void TearDown() override {
    servers_.clear();
    std::error_code ec;
    for (const std::string& d : dirs_) std::filesystem::remove_all(d, ec);
  }

  std::unique_ptr<ShrmClient> StartServer(ServerOptions opt) {
    const std::string dir = testing::UniqueTempPath(absl::StrCat("loadspool", dirs_.size()));
    dirs_.push_back(dir);
    opt.listen = "127.0.0.1:0";
    opt.service.spool_dir = dir;
    absl::StatusOr<std::unique_ptr<ShrmServer>> s = ShrmServer::Start(opt);
    EXPECT_TRUE(s.ok()) << s.status();
    if (!s.ok()) return nullptr;
    port_ = (*s)->port();
    servers_.push_back(std::move(*s));
    return Connect();
  }

  // Each client has its own TCP connection, as separate client processes would.
  std::unique_ptr<ShrmClient> Connect() const {
    client::ClientOptions options;
    options.own_connection = true;
    absl::StatusOr<std::unique_ptr<ShrmClient>> c =
        ShrmClient::Connect(absl::StrCat("127.0.0.1:", port_), options);
    EXPECT_TRUE(c.ok()) << c.status();
    return c.ok() ? std::move(*c) : nullptr;
  }

  static v1::PrefilterRequest PrefilterRequest(const std::string& sha, const std::string& map) {
    v1::PrefilterRequest req;
    req.mutable_environment()->add_sha256(sha);
    req.mutable_environment()->add_source_names(map);
    req.set_brdf(kPrefilterBrdf);
    req.mutable_orders()->set_f(kLoadF);
    req.mutable_orders()->set_p(kLoadP);
    req.set_face_size(kLoadFaceSize);
    req.set_verify(0);
    return req;
  }

  int port_ = 0;
  std::vector<std::unique_ptr<ShrmServer>> servers_;
  std::vector<std::string> dirs_;
};

// The embedded run of the load test's Prefilter job (the job layer's embedded run and
// WriteShrmFile, as the CLI writes it): the bytes every remote answer must equal.
std::string EmbeddedShrmBytes(const std::string& map, const std::string& sha) {
  jobs::PrefilterJob job;
  job.env.files = {map};
  job.brdf = kPrefilterBrdf;
  jobs::UseExplicitOrders(&job, jobs::Orders{kLoadF, kLoadP});
  job.verify = 0;  // as the requests (the check is not what the load test is about)
  job.face_size = kLoadFaceSize;
  absl::StatusOr<jobs::PrefilterRun> pr = jobs::RunPrefilterJob(job, /*threads=*/1);
  EXPECT_TRUE(pr.ok()) << pr.status();
  if (!pr.ok()) return "";
  EXPECT_EQ(pr->provenance.source.sha256, sha);
  const std::string local = testing::UniqueTempPath("load_embedded.shrm.exr");
  EXPECT_TRUE(WriteShrmFile(local, pr->result.cube, pr->attributes).ok());
  std::string bytes = ReadFile(local);
  std::filesystem::remove(local);
  return bytes;
}

TEST_F(ServiceLoadTest, ConcurrentClientsMixedCallsAllAnsweredCorrectly) {
  ServerOptions opt;
  opt.service.max_jobs = kLoadClients;  // admission must not refuse anything here
  opt.service.job_threads = 1;
  auto c = StartServer(opt);
  ASSERT_NE(c, nullptr);
  const std::string map = MapPath("courtyard.exr");
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();

  // Expected answers, computed once in process.
  const std::string expected_file = EmbeddedShrmBytes(map, *sha);
  ASSERT_FALSE(expected_file.empty());
  const std::string expected_sha = Sha256Hex(expected_file);
  EnvMapOptions eo;
  eo.paths = {map};
  absl::StatusOr<EnvMap> env = EnvMap::Load(eo);
  ASSERT_TRUE(env.ok());
  auto abrdf = ParseBrdfSpec(kAnalyzeBrdf);
  ASSERT_TRUE(abrdf.ok());
  PrefilterOptions po;
  po.epsilon = kAnalyzeEpsilon;
  po.synthesize = false;
  absl::StatusOr<PrefilterResult> expected_analysis = Prefilter(*env, **abrdf, po);
  ASSERT_TRUE(expected_analysis.ok());
  const ShrmAnalysis& ea = expected_analysis->analysis;

  v1::AnalyzeRequest areq;
  areq.mutable_environment()->add_sha256(*sha);
  areq.set_brdf(kAnalyzeBrdf);
  areq.add_epsilon(kAnalyzeEpsilon);
  const v1::PrefilterRequest preq = PrefilterRequest(*sha, map);

  struct Tally {
    int sent = 0, ok = 0, prefilter_ok = 0, analyze_ok = 0, wrong = 0;
    std::vector<std::string> errors;
  };
  std::vector<Tally> tally(kLoadClients);
  std::vector<std::thread> threads;
  for (int i = 0; i < kLoadClients; ++i) {
    threads.emplace_back([&, i] {
      Tally& t = tally[i];
      std::unique_ptr<ShrmClient> ci = Connect();
      if (ci == nullptr) return;
      for (int k = 0; k < kRequestsPerClient; ++k) {
        ++t.sent;
        if ((i + k) % 2 == 0) {
          absl::StatusOr<client::PrefilterOutcome> r =
              ci->Prefilter(preq, nullptr, kLoadRequestDeadline);
          if (!r.ok()) {
            t.errors.push_back(std::string(r.status().ToString()));
            continue;
          }
          ++t.ok;
          ++t.prefilter_ok;
          // The trailer's SHA-256 is the file's, and the file is the embedded run's.
          if (Sha256Hex(r->shrm_file) != r->shrm_sha256 || r->shrm_sha256 != expected_sha ||
              r->shrm_file != expected_file || r->report.f_b() != kLoadF) {
            ++t.wrong;
          }
        } else {
          absl::StatusOr<v1::AnalyzeResponse> r = ci->Analyze(areq, kLoadRequestDeadline);
          if (!r.ok()) {
            t.errors.push_back(std::string(r.status().ToString()));
            continue;
          }
          ++t.ok;
          ++t.analyze_ok;
          if (r->results_size() != 1 || r->results(0).f_b() != ea.f_b ||
              r->results(0).p_b() != ea.p_b || r->results(0).eps_bound() != ea.eps_bound) {
            ++t.wrong;
          }
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  int total_ok = 0;
  for (int i = 0; i < kLoadClients; ++i) {
    const Tally& t = tally[i];
    EXPECT_EQ(t.sent, kRequestsPerClient) << "client " << i;
    EXPECT_EQ(t.ok, kRequestsPerClient)
        << "client " << i << ", first error: " << (t.errors.empty() ? "" : t.errors[0]);
    EXPECT_EQ(t.prefilter_ok + t.analyze_ok, kRequestsPerClient) << "client " << i;
    EXPECT_EQ(t.wrong, 0) << "client " << i;
    total_ok += t.ok;
  }
  EXPECT_EQ(total_ok, kLoadClients * kRequestsPerClient);
}

TEST_F(ServiceLoadTest, BurstAboveMaxJobsIsRefusedQuicklyAndAcceptedJobsSucceed) {
  // "Quickly" without a clock: the accepted job is held at the gate until every other call has
  // returned, so a refusal can only come back at once (never queued behind the held job).
  ServerOptions opt;
  opt.service.max_jobs = 1;
  testing::StageGate gate;
  opt.service.test_stage_hook = gate.Hook();
  auto c = StartServer(opt);
  ASSERT_NE(c, nullptr);
  const std::string map = MapPath("interior.exr");
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();
  const v1::PrefilterRequest req = PrefilterRequest(*sha, map);

  // Connect every client first, then release them together.
  std::vector<std::unique_ptr<ShrmClient>> clients;
  for (int i = 0; i < kBurstClients; ++i) {
    clients.push_back(Connect());
    ASSERT_NE(clients.back(), nullptr);
  }
  std::vector<absl::Status> results(kBurstClients);
  std::vector<int64_t> retry_after(kBurstClients);
  // Each connection made before the burst (HasBlob retries transport failures itself).
  for (auto& ci : clients) ASSERT_TRUE(ci->HasBlob(*sha).ok());
  auto run = [&](int i) {
    // Sent again if it fails in the transport before reaching the server (a loaded machine may
    // drop a connection): the test is about the server's answer.
    absl::StatusOr<client::PrefilterOutcome> r;
    for (int attempt = 0; attempt < kTransportAttempts; ++attempt) {
      r = clients[i]->Prefilter(req, nullptr, i == 0 ? absl::InfiniteDuration() : kGateTimeout);
      if (r.ok() || !client::IsTransient(r.status())) break;
    }
    results[i] = r.status();
    if (r.ok() && (Sha256Hex(r->shrm_file) != r->shrm_sha256 || r->shrm_file.empty())) {
      results[i] = absl::DataLossError("accepted job returned a bad file");
    }
    retry_after[i] = clients[i]->last_retry_after_ms();
  };
  std::thread holder(run, 0);
  ASSERT_TRUE(gate.WaitHeld(1, kGateTimeout)) << "the first job never reached a stage";
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  std::vector<std::thread> threads;
  for (int i = 1; i < kBurstClients; ++i) {
    threads.emplace_back([&, i] {
      ++ready;
      while (!go.load()) std::this_thread::yield();
      run(i);
    });
  }
  while (ready.load() < kBurstClients - 1) std::this_thread::yield();
  go = true;
  for (auto& t : threads) t.join();
  gate.Open();
  holder.join();
  int ok = 0, refused = 0;
  for (int i = 0; i < kBurstClients; ++i) {
    if (results[i].ok()) {
      ++ok;
      continue;
    }
    EXPECT_EQ(results[i].code(), absl::StatusCode::kResourceExhausted) << results[i];
    EXPECT_GT(retry_after[i], 0) << "client " << i;
    ++refused;
  }
  EXPECT_TRUE(results[0].ok()) << results[0];
  EXPECT_GE(ok, 1);
  EXPECT_GE(refused, 1);
  EXPECT_EQ(ok + refused, kBurstClients);
}

TEST(ConfigFileTest, ParsesKeyValueLinesAndCommandLineWins) {
  const std::string text =
      "# shrmd config\n"
      "\n"
      "listen = 127.0.0.1:6000\n"
      "  max-jobs=3  \n"
      "spool-dir = \"/var/spool/shrm d\"\n"
      "reflection = true\n"
      "metrics-port = 9100\n";
  absl::StatusOr<std::vector<server::ConfigEntry>> entries = server::ParseConfigText(text);
  ASSERT_TRUE(entries.ok()) << entries.status();
  ASSERT_EQ(entries->size(), 5u);
  EXPECT_EQ((*entries)[1].key, "max-jobs");
  EXPECT_EQ((*entries)[1].value, "3");
  EXPECT_EQ((*entries)[1].line, 4);
  EXPECT_EQ((*entries)[2].value, "/var/spool/shrm d");
  const auto known = [](const std::string& k) { return k != "nosuch"; };
  // max-jobs is on the command line: the file's value is left out.
  const auto given = [](const std::string& k) { return k == "max-jobs"; };
  absl::StatusOr<std::vector<std::string>> args =
      server::ConfigToArgs(*entries, {"reflection"}, known, given);
  ASSERT_TRUE(args.ok()) << args.status();
  const std::vector<std::string> want = {
      "--listen",     "127.0.0.1:6000", "--spool-dir", "/var/spool/shrm d",
      "--reflection", "--metrics-port", "9100"};
  EXPECT_EQ(*args, want);

  // false drops a boolean flag; another value is an error.
  auto off = server::ParseConfigText("reflection = false\n");
  ASSERT_TRUE(off.ok());
  auto off_args = server::ConfigToArgs(*off, {"reflection"}, known, given);
  ASSERT_TRUE(off_args.ok());
  EXPECT_TRUE(off_args->empty());
  auto bad_bool = server::ParseConfigText("reflection = maybe\n");
  ASSERT_TRUE(bad_bool.ok());
  EXPECT_EQ(server::ConfigToArgs(*bad_bool, {"reflection"}, known, given).status().code(),
            absl::StatusCode::kInvalidArgument);

  // Errors name the line.
  for (const char* bad :
       {"listen\n", "= 3\n", "--listen = x\n", "a = 1\na = 2\n", "a = \"open\n"}) {
    absl::StatusOr<std::vector<server::ConfigEntry>> r = server::ParseConfigText(bad);
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(r.status().message().find("line"), std::string::npos) << r.status();
  }
  // Found by fuzzing (docs/fuzzing.md): "help = x" passed CLI11's own --help to shrmd, which then
  // printed its help and exited at startup; help, version and config are not settings.
  for (const char* action : {"help = x\n", "version = 1\n", "config = /etc/other.conf\n"}) {
    auto entries_of_action = server::ParseConfigText(action);
    ASSERT_TRUE(entries_of_action.ok());
    const absl::Status refused =
        server::ConfigToArgs(
            *entries_of_action, {}, [](const std::string&) { return true; }, given)
            .status();
    EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument) << action;
    EXPECT_NE(refused.message().find("is not a setting"), std::string::npos) << refused;
  }
  // Found by fuzzing (docs/fuzzing.md): a NUL inside a value cut the argument shrmd parsed short.
  auto nul = server::ParseConfigText(std::string("max-jobs = 2\ntls-key = /etc/k\0ey\n", 33));
  EXPECT_EQ(nul.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(nul.status().message().find("line 2: contains a NUL byte"), std::string::npos)
      << nul.status();
  auto unknown = server::ParseConfigText("\nnosuch = 1\n");
  ASSERT_TRUE(unknown.ok());
  absl::Status s = server::ConfigToArgs(*unknown, {}, known, given).status();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("line 2"), std::string::npos) << s;
  EXPECT_EQ(server::ReadConfigFile("/nonexistent/shrmd.conf").status().code(),
            absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace shrm
