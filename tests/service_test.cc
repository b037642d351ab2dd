// Loopback tests of the shrm service: an in-process server (server/server.h) on an ephemeral
// port, the client library (client/shrm_client.h), and `shrm prefilter --server` against the
// embedded `shrm prefilter` (byte-identical SHRM files).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "client/shrm_client.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_table.h"
#include "core/envmap/envmap.h"
#include "core/envmap/lighting.h"
#include "core/io/sha256.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_file.h"
#include "jobs/prefilter_job.h"
#include "nlohmann/json.hpp"
#include "server/metrics.h"
#include "server/server.h"
#include "tests/stage_gate.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace v1 = ::shrm::v1;
using client::ShrmClient;
using server::ServerOptions;
using server::ShrmServer;

// Small explicit orders keep every prefilter well under a second on the bundled 1024 x 512 maps;
// equal F for both BRDFs is what lets the second call hit the L_lm cache (keyed by F).
constexpr int kTestF = 8;
constexpr int kTestP = 2;
constexpr int kTestFaceSize = 32;
// A large upload: 64 MiB in 1 MiB chunks (the issue's size; well past the 4 MiB message limit).
constexpr size_t kLargeUploadBytes = 64u << 20;
// Upload limit of the "small limit" server, and an upload just above it.
constexpr uint64_t kSmallBlobLimit = 64 << 10;
// Slow jobs for admission/deadline tests: every stage sleeps this long (6 stages: ~1.2 s a job).
constexpr absl::Duration kSlowStage = absl::Milliseconds(200);
// Safety net of the gate tests (tests/stage_gate.h): how long a job may take to reach the gate,
// or a refusal to be counted, before the test fails instead of hanging. Not a timing claim:
// passing never depends on it.
constexpr absl::Duration kGateTimeout = absl::Seconds(60);
// Attempts of a call that fails in the transport before it reaches the server.
constexpr int kTransportAttempts = 5;
// The deadline of the abandonment test: the job is held at the stage gate until it has passed,
// so it only has to be long enough for the call to reach the server on a loaded 2-core machine
// (a 200 ms deadline once expired before the call arrived, and nothing was abandoned). Not a
// timing claim: the test waits for it to pass.
constexpr absl::Duration kHeldDeadline = absl::Seconds(10);
// The server's deadline can be later than the timeout says: grpc-timeout travels in whole units
// (milliseconds for 10 s), rounded up, and the server dates the call's arrival itself. The gate
// opens this long after the deadline (a margin of 100 ms once opened it before the server's
// deadline on a busy machine: the stop was counted as a cancellation). Not a timing claim: a
// longer margin only makes the test wait longer.
constexpr absl::Duration kTimeoutRounding = absl::Seconds(1);
// How long the server may take to notice a deadline or a cancellation and stop the job: it checks
// between stages, so one slow stage (200 ms) plus scheduling; generous, because the poll returns
// as soon as the count moves and a loaded 2-core CI machine must not fail it.
constexpr absl::Duration kAbandonWithin = absl::Seconds(30);
constexpr int kConcurrentJobs = 3;
// The tabulated BRDF of the blob tests: GGX sampled on a small grid (smooth enough for F = 8).
constexpr char kTableSource[] = "ggx:alpha=0.5,f0=1";
constexpr int kTableThetaI = 32, kTableThetaO = 32, kTablePhi = 16;

std::string MapPath(const char* name) {
  return absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/", name);
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class ServiceTest : public ::testing::Test {
 protected:
  void TearDown() override {
    servers_.clear();
    std::error_code ec;
    for (const std::string& d : dirs_) std::filesystem::remove_all(d, ec);
  }

  // Starts a server on a free loopback port; returns a connected client.
  std::unique_ptr<ShrmClient> StartServer(ServerOptions opt = {}) {
    const std::string dir = testing::UniqueTempPath(absl::StrCat("spool", dirs_.size()));
    dirs_.push_back(dir);
    opt.listen = "127.0.0.1:0";
    opt.service.spool_dir = dir;
    if (opt.service.max_jobs < 1) opt.service.max_jobs = 2;
    absl::StatusOr<std::unique_ptr<ShrmServer>> s = ShrmServer::Start(opt);
    EXPECT_TRUE(s.ok()) << s.status();
    port_ = (*s)->port();
    servers_.push_back(std::move(*s));
    absl::StatusOr<std::unique_ptr<ShrmClient>> c =
        ShrmClient::Connect(absl::StrCat("127.0.0.1:", port_));
    EXPECT_TRUE(c.ok()) << c.status();
    return std::move(*c);
  }

  static v1::PrefilterRequest Request(const std::string& sha, const std::string& brdf) {
    v1::PrefilterRequest req;
    req.mutable_environment()->add_sha256(sha);
    req.set_brdf(brdf);
    req.mutable_orders()->set_f(kTestF);
    req.mutable_orders()->set_p(kTestP);
    req.set_face_size(kTestFaceSize);
    return req;
  }

  int port_ = 0;
  std::vector<std::unique_ptr<ShrmServer>> servers_;
  std::vector<std::string> dirs_;
};

// Polls `count` until it exceeds `before` or `within` passes; returns the last value.
uint64_t WaitForIncrease(const std::function<uint64_t()>& count, uint64_t before,
                         absl::Duration within = kAbandonWithin) {
  const absl::Time end = absl::Now() + within;
  uint64_t n = count();
  while (n <= before && absl::Now() < end) {
    absl::SleepFor(absl::Milliseconds(20));
    n = count();
  }
  return n;
}

// Waits until no job holds a slot (or kAbandonWithin passes): false if one still does.
bool WaitForSlotsFree() {
  const absl::Time end = absl::Now() + kAbandonWithin;
  while (server::Metrics::Global().JobsInFlight() > 0 && absl::Now() < end) {
    absl::SleepFor(absl::Milliseconds(10));
  }
  return server::Metrics::Global().JobsInFlight() == 0;
}

// One Prefilter call, sent again while it fails in the transport before reaching the server
// (client::IsTransient; a loaded machine may drop a fresh connection): the tests that use it
// are about the server's answer.
absl::StatusOr<client::PrefilterOutcome> PrefilterReachingServer(ShrmClient* c,
                                                                 const v1::PrefilterRequest& req,
                                                                 absl::Duration deadline) {
  absl::StatusOr<client::PrefilterOutcome> r;
  for (int attempt = 0; attempt < kTransportAttempts; ++attempt) {
    r = c->Prefilter(req, nullptr, deadline);
    if (r.ok() || !client::IsTransient(r.status())) break;
  }
  return r;
}

TEST_F(ServiceTest, RoundTripMatchesEmbeddedRunAndHitsLightingCache) {
  auto c = StartServer();
  const std::string map = MapPath("courtyard.exr");
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();
  EXPECT_EQ(*sha, *Sha256OfFile(map));
  absl::StatusOr<v1::HasBlobResponse> has = c->HasBlob(*sha);
  ASSERT_TRUE(has.ok());
  EXPECT_TRUE(has->present());
  EXPECT_EQ(has->size(), std::filesystem::file_size(map));

  int progress_events = 0;
  auto req1 = Request(*sha, "phong:s=32");
  req1.mutable_environment()->add_source_names(map);
  absl::StatusOr<client::PrefilterOutcome> r1 =
      c->Prefilter(req1, [&](const v1::PrefilterProgress&) { ++progress_events; });
  ASSERT_TRUE(r1.ok()) << r1.status();
  EXPECT_GE(progress_events, 4);
  EXPECT_FALSE(r1->report.cache().lighting_hit());
  EXPECT_FALSE(r1->report.cache().brdf_hit());
  EXPECT_EQ(r1->report.f_b(), kTestF);

  auto req2 = Request(*sha, "microfacet:sigma=0.2");
  req2.mutable_environment()->add_source_names(map);
  absl::StatusOr<client::PrefilterOutcome> r2 = c->Prefilter(req2);
  ASSERT_TRUE(r2.ok()) << r2.status();
  EXPECT_TRUE(r2->report.cache().lighting_hit());
  EXPECT_FALSE(r2->report.cache().brdf_hit());
  EXPECT_NE(r2->report.report_json().find("\"lighting\": \"hit\""), std::string::npos);

  // The same job in process: the job layer's embedded run (core's Prefilter(), the attributes the
  // CLI writes) and WriteShrmFile: byte for byte the same file.
  jobs::PrefilterJob job;
  job.env.files = {map};
  job.brdf = "microfacet:sigma=0.2";
  jobs::UseExplicitOrders(&job, jobs::Orders{kTestF, kTestP});  // verify: both at the default 64
  job.face_size = kTestFaceSize;
  // Thread count must not matter (core's transforms are bit-exact in it).
  absl::StatusOr<jobs::PrefilterRun> pr = jobs::RunPrefilterJob(job, /*threads=*/3);
  ASSERT_TRUE(pr.ok()) << pr.status();
  EXPECT_EQ(pr->provenance.source.sha256, *sha);
  const std::string local = testing::UniqueTempPath("embedded.shrm.exr");
  ASSERT_TRUE(WriteShrmFile(local, pr->result.cube, pr->attributes).ok());
  const std::string local_bytes = ReadFile(local);
  std::filesystem::remove(local);
  EXPECT_EQ(r2->shrm_file.size(), local_bytes.size());
  EXPECT_TRUE(r2->shrm_file == local_bytes) << "remote SHRM file differs from the embedded one";
}

// The visual report's data (OUTPUT_REPORT_VISUALS): never in the default outputs (it costs
// brute-force sums), and when asked for, the same JSON as the embedded run computes (so
// `shrm prefilter --server --report-html` writes the embedded page but for the timings).
TEST_F(ServiceTest, VisualReportDataOnlyWhenAskedAndEqualToTheEmbeddedRun) {
  auto c = StartServer();
  const std::string map = MapPath("courtyard.exr");
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();
  auto plain = Request(*sha, "ggx:alpha=0.3");
  absl::StatusOr<client::PrefilterOutcome> r1 = c->Prefilter(plain);
  ASSERT_TRUE(r1.ok()) << r1.status();
  EXPECT_TRUE(r1->report.report_visuals_json().empty());
  EXPECT_FALSE(r1->shrm_file.empty());

  auto with_visuals = plain;
  for (auto o : {v1::OUTPUT_SHRM_FILE, v1::OUTPUT_REPORT, v1::OUTPUT_REPORT_VISUALS})
    with_visuals.add_outputs(o);
  absl::StatusOr<client::PrefilterOutcome> r2 = c->Prefilter(with_visuals);
  ASSERT_TRUE(r2.ok()) << r2.status();
  EXPECT_TRUE(r2->shrm_file == r1->shrm_file);
  const nlohmann::json remote = nlohmann::json::parse(r2->report.report_visuals_json());
  EXPECT_NE(r2->report.report_json().find("\"report_ms\""), std::string::npos);

  jobs::PrefilterJob job;
  job.env.files = {map};
  job.brdf = "ggx:alpha=0.3";
  jobs::UseExplicitOrders(&job, jobs::Orders{kTestF, kTestP});
  job.face_size = kTestFaceSize;
  absl::StatusOr<jobs::PrefilterRun> local =
      jobs::RunPrefilterJob(job, /*threads=*/3, nullptr, /*visuals=*/true);
  ASSERT_TRUE(local.ok()) << local.status();
  EXPECT_TRUE(remote == local->visuals) << "the server's visual report data differs";
  EXPECT_EQ(remote["pairs"]["points"].size(), 256u);
}

// Runs `shrm prefilter` with `args` embedded and with --server on `port`; expects the same file
// bytes and returns the remote run's report.
std::string RemoteReportWithEmbeddedBytes(const std::string& args, int port) {
  const std::string a = testing::UniqueTempPath("cli_embedded.shrm.exr");
  const std::string b = testing::UniqueTempPath("cli_remote.shrm.exr");
  const std::string rep = testing::UniqueTempPath("cli_remote.json");
  const std::string common = absl::StrCat(" prefilter ", args, " > /dev/null 2>&1");
  EXPECT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, common, " -o ", a).c_str()), 0) << args;
  EXPECT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, common, " -o ", b, " --report ", rep,
                                     " --server 127.0.0.1:", port)
                            .c_str()),
            0)
      << args;
  const std::string ea = ReadFile(a), eb = ReadFile(b), report = ReadFile(rep);
  EXPECT_FALSE(ea.empty());
  EXPECT_TRUE(ea == eb) << "shrm --server wrote a different file: " << args;
  for (const auto& f : {a, b, rep}) std::filesystem::remove(f);
  return report;
}

TEST_F(ServiceTest, CliServerOutputIsByteIdenticalToEmbedded) {
  auto c = StartServer();
  const std::string map = MapPath("city.exr");
  const std::string report = RemoteReportWithEmbeddedBytes(
      absl::StrCat("--env ", map,
                   " --brdf microfacet:sigma=0.3 --epsilon 0.1 --rotate 30,10,5 "
                   "--kind local"),
      port_);
  EXPECT_NE(report.find("\"F_B\""), std::string::npos);

  // analyze --server runs too.
  EXPECT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, " analyze --env ", map,
                                     " --brdf phong:s=32 --epsilon 0.1 --json --server "
                                     "127.0.0.1:",
                                     port_, " > /dev/null 2>&1")
                            .c_str()),
            0);
}

// A tolerance job (the rule runs the core pipeline on the server, uncached) gives the embedded
// bytes, and its report carries the estimate.
TEST_F(ServiceTest, ToleranceJobRunsRemotelyWithTheEmbeddedBytes) {
  auto c = StartServer();
  const std::string report = RemoteReportWithEmbeddedBytes(
      absl::StrCat("--env ", MapPath("forest.exr"),
                   " --brdf phong:s=64 --tolerance 0.02 --window auto --verify 32"),
      port_);
  EXPECT_NE(report.find("\"tolerance\": {"), std::string::npos) << report.substr(0, 400);
  EXPECT_NE(report.find("\"met\": true"), std::string::npos);
  EXPECT_NE(report.find("\"measured\": {"), std::string::npos);
}

// Peak lights (the epsilon rule's cached path hands such jobs to the core pipeline whole; the
// tolerance rule's runs it anyway): the embedded bytes, the lights in the report.
TEST_F(ServiceTest, PeakLightsJobRunsRemotelyWithTheEmbeddedBytes) {
  auto c = StartServer();
  const std::string report = RemoteReportWithEmbeddedBytes(
      absl::StrCat("--env ", MapPath("city.exr"),
                   " --brdf microfacet:sigma=0.3 --epsilon 0.1 --peak-lights --rotate 30,10,5 "
                   "--verify 16"),
      port_);
  EXPECT_NE(report.find("\"peak_lights\": {"), std::string::npos) << report.substr(0, 400);
  EXPECT_NE(report.find("\"count\": 29"), std::string::npos) << report.substr(0, 400);
  // The default (auto: the wire's PEAK_LIGHTS_AUTO = 0, no flag) with the tolerance rule splits
  // city's sun on both sides alike; a loose tolerance keeps the job short, and without a check
  // (--verify 0) no verdict of a few pairs can fail it (this is about the bytes).
  const std::string by_default = RemoteReportWithEmbeddedBytes(
      absl::StrCat("--env ", MapPath("city.exr"),
                   " --brdf microfacet:sigma=0.3 --tolerance 0.05 --verify 0 --threads 2"),
      port_);
  EXPECT_NE(by_default.find("\"mode\": \"auto\""), std::string::npos) << by_default.substr(0, 400);
  EXPECT_NE(by_default.find("\"count\": 29"), std::string::npos) << by_default.substr(0, 400);
}

// Runs `command` through the shell; returns its stdout ("" and a failure when it exits non-zero).
std::string CliOutput(const std::string& command) {
  const std::string out = testing::UniqueTempPath("cli_stdout.txt");
  const int rc = std::system(absl::StrCat(command, " > ", out, " 2>/dev/null").c_str());
  EXPECT_EQ(rc, 0) << command;
  std::string text = ReadFile(out);
  std::filesystem::remove(out);
  return text;
}

TEST_F(ServiceTest, CliReferenceAndIrradianceRunRemotelyWithTheEmbeddedResults) {
  auto c = StartServer();
  const std::string map = MapPath("forest.exr");
  const std::string server = absl::StrCat(" --server 127.0.0.1:", port_);
  // reference: the same brute-force sum, printed with 9 digits (the values are equal doubles).
  const std::string ref = absl::StrCat(SHRM_CLI_PATH, " reference --env ", map,
                                       " --brdf phong:s=16 --normal 0,1,0 --view 0.3,0.8,0.2 "
                                       "--rotate 40,0,0 --json");
  const std::string embedded_ref = CliOutput(ref);
  EXPECT_NE(embedded_ref.find("rgb"), std::string::npos);
  EXPECT_EQ(CliOutput(ref + server), embedded_ref);
  // irradiance: coefficients from the server, the cube built locally: equal files.
  const std::string a = testing::UniqueTempPath("irr_embedded.exr");
  const std::string b = testing::UniqueTempPath("irr_remote.exr");
  const std::string irr =
      absl::StrCat(SHRM_CLI_PATH, " irradiance --env ", map, " --size 16 --json --rotate 0,20,0");
  const std::string embedded_irr = CliOutput(absl::StrCat(irr, " -o ", a));
  const std::string remote_irr = CliOutput(absl::StrCat(irr, " -o ", b, server));
  EXPECT_EQ(remote_irr.substr(0, remote_irr.find("\"output\"")),
            embedded_irr.substr(0, embedded_irr.find("\"output\"")));
  // Both state the coefficients' measured error (the server's check at the default normals).
  EXPECT_NE(embedded_irr.find("\"normals\": 64"), std::string::npos) << embedded_irr;
  EXPECT_FALSE(ReadFile(a).empty());
  EXPECT_TRUE(ReadFile(a) == ReadFile(b)) << "remote irradiance cube differs";
  for (const auto& f : {a, b}) std::filesystem::remove(f);

  // Bad directions and a missing map are refused with the right codes.
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok());
  v1::ReferenceRequest req;
  req.mutable_environment()->add_sha256(*sha);
  req.set_brdf("phong:s=16");
  req.mutable_index()->set_y(1);
  absl::StatusOr<v1::ReferenceResponse> r = c->Reference(req);  // no view
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
  EXPECT_NE(r.status().message().find("view"), absl::string_view::npos) << r.status();
  req.mutable_view()->set_x(0);  // present but zero
  r = c->Reference(req);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
  v1::IrradianceRequest ir;
  ir.mutable_environment()->add_sha256(std::string(64, 'a'));
  absl::StatusOr<v1::IrradianceResponse> e = c->Irradiance(ir);
  EXPECT_EQ(e.status().code(), absl::StatusCode::kNotFound) << e.status();
  ir.mutable_environment()->set_sha256(0, *sha);
  ir.set_verify(-1);
  e = c->Irradiance(ir);
  EXPECT_EQ(e.status().code(), absl::StatusCode::kInvalidArgument) << e.status();
  EXPECT_NE(e.status().message().find("verify"), absl::string_view::npos) << e.status();
  ir.set_verify(0);
  e = c->Irradiance(ir);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->measured_count(), 0);
}

TEST_F(ServiceTest, CliTokenFileFlagAuthenticates) {
  const std::string tokens = testing::UniqueTempPath("tokens.txt");
  {
    std::ofstream out(tokens);
    out << "# test token\ncli-flag-token\n";
  }
  ServerOptions opt;
  opt.security.token_file = tokens;
  auto c = StartServer(opt);
  const std::string analyze = absl::StrCat(
      SHRM_CLI_PATH, " analyze --brdf phong:s=32 --epsilon 0.1 --server 127.0.0.1:", port_,
      " > /dev/null 2>&1");
  EXPECT_NE(std::system(analyze.c_str()), 0) << "no token must be refused";
  EXPECT_EQ(std::system(absl::StrCat(analyze, " --token-file ", tokens).c_str()), 0);
  std::filesystem::remove(tokens);
}

TEST_F(ServiceTest, CliJobsWaitForAFreeSlotWhenTheServerIsFull) {
  // Two CLI jobs, one slot: the first is held at the gate until the server has refused the
  // second at least once, so the second must wait the server's retry-after-ms and run after it.
  ServerOptions opt;
  opt.service.max_jobs = 1;
  testing::StageGate gate;
  opt.service.test_stage_hook = gate.Hook();
  auto c = StartServer(opt);
  const std::string map = MapPath("interior.exr");
  ASSERT_TRUE(c->UploadIfMissing(map).ok());
  auto refused = [] {
    return server::Metrics::Global().RequestCount("Prefilter", "RESOURCE_EXHAUSTED");
  };
  const uint64_t refused_before = refused();
  std::vector<std::string> reports;
  std::vector<std::thread> jobs;
  for (int i = 0; i < 2; ++i) {
    reports.push_back(testing::UniqueTempPath(absl::StrCat("full", i, ".json")));
    const std::string out = testing::UniqueTempPath(absl::StrCat("full", i, ".shrm.exr"));
    const std::string cmd =
        absl::StrCat(SHRM_CLI_PATH, " prefilter --env ", map, " --brdf phong:s=", 8 + i,
                     " --orders 8,0 --size 16 --verify 0 -o ", out, " --report ", reports.back(),
                     " --server 127.0.0.1:", port_, " > /dev/null 2>&1");
    jobs.emplace_back([cmd, out] {
      EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
      std::filesystem::remove(out);
    });
  }
  EXPECT_TRUE(gate.WaitHeld(1, kGateTimeout)) << "no job reached a stage";
  EXPECT_GT(WaitForIncrease(refused, refused_before, kGateTimeout), refused_before)
      << "the second job was never refused";
  gate.Open();
  for (std::thread& t : jobs) t.join();
  // One job found the only slot taken, waited the server's retry-after-ms and ran.
  int retries = 0;
  for (const std::string& r : reports) {
    const nlohmann::json j = nlohmann::json::parse(ReadFile(r), nullptr, false);
    ASSERT_TRUE(j.contains("retries")) << r;
    retries += j["retries"].get<int>();
    std::filesystem::remove(r);
  }
  EXPECT_GE(retries, 1);
}

TEST_F(ServiceTest, UploadOverLimitIsRefused) {
  ServerOptions opt;
  opt.service.max_blob_bytes = kSmallBlobLimit;
  auto c = StartServer(opt);
  const std::string big(kSmallBlobLimit + 1, 'x');
  absl::StatusOr<std::string> r = c->UploadBytes(big);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kResourceExhausted) << r.status();
  EXPECT_NE(r.status().message().find("limit"), std::string::npos);
  // Still serving.
  EXPECT_TRUE(c->UploadBytes(std::string(100, 'y')).ok());
}

TEST_F(ServiceTest, LargeChunkedUploadKeepsItsHash) {
  auto c = StartServer();
  std::string bytes(kLargeUploadBytes, '\0');
  std::mt19937_64 rng(42);
  for (size_t i = 0; i + 8 <= bytes.size(); i += 8) {
    const uint64_t v = rng();
    std::memcpy(&bytes[i], &v, 8);
  }
  absl::StatusOr<std::string> sha = c->UploadBytes(bytes);
  ASSERT_TRUE(sha.ok()) << sha.status();
  EXPECT_EQ(*sha, Sha256Hex(bytes));
  absl::StatusOr<v1::HasBlobResponse> has = c->HasBlob(*sha);
  ASSERT_TRUE(has.ok());
  EXPECT_TRUE(has->present());
  EXPECT_EQ(has->size(), kLargeUploadBytes);
}

TEST_F(ServiceTest, MalformedRequestsGetTheRightStatusAndTheServerKeepsServing) {
  auto c = StartServer();
  const std::string map_bytes = ReadFile(MapPath("interior.exr"));
  absl::StatusOr<std::string> good = c->UploadBytes(map_bytes);
  ASSERT_TRUE(good.ok());
  absl::StatusOr<std::string> truncated = c->UploadBytes(map_bytes.substr(0, map_bytes.size() / 3));
  ASSERT_TRUE(truncated.ok());
  std::string huge_hdr = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n";
  huge_hdr += std::string(1024, '\x01');
  absl::StatusOr<std::string> huge = c->UploadBytes(huge_hdr);
  ASSERT_TRUE(huge.ok());

  struct Case {
    const char* what;
    v1::PrefilterRequest req;
    absl::StatusCode code;
    const char* message_part;
  };
  std::vector<Case> cases;
  cases.push_back({"truncated EXR", Request(*truncated, "phong:s=32"),
                   absl::StatusCode::kInvalidArgument, "blob"});
  // core's header check (before decoding) answers ResourceExhausted for over-limit images.
  cases.push_back({"100000 x 100000 Radiance header", Request(*huge, "phong:s=32"),
                   absl::StatusCode::kResourceExhausted, "100000 x 100000"});
  cases.push_back({"bad BRDF spec", Request(*good, "nosuchmodel:x=1"),
                   absl::StatusCode::kInvalidArgument, "brdf"});
  cases.push_back({"file BRDF spec", Request(*good, "merl:/etc/passwd"),
                   absl::StatusCode::kInvalidArgument, "merl"});
  cases.push_back({"missing blob", Request(std::string(64, 'a'), "phong:s=32"),
                   absl::StatusCode::kNotFound, "upload it first"});
  cases.push_back({"malformed hash", Request("xyz", "phong:s=32"),
                   absl::StatusCode::kInvalidArgument, "sha256"});
  auto orders = Request(*good, "phong:s=32");
  orders.mutable_orders()->set_f(100000);
  cases.push_back({"orders out of range", orders, absl::StatusCode::kInvalidArgument, "orders"});
  auto eps = Request(*good, "phong:s=32");
  eps.set_epsilon(1.5);
  cases.push_back({"epsilon out of range", eps, absl::StatusCode::kInvalidArgument, "epsilon"});
  for (const Case& k : cases) {
    absl::StatusOr<client::PrefilterOutcome> r = c->Prefilter(k.req);
    EXPECT_EQ(r.status().code(), k.code) << k.what << ": " << r.status();
    EXPECT_NE(r.status().message().find(k.message_part), std::string::npos)
        << k.what << ": " << r.status();
    EXPECT_EQ(r.status().message().find(dirs_[0]), std::string::npos)
        << k.what << ": the message leaks the spool path: " << r.status();
  }
  absl::StatusOr<client::PrefilterOutcome> ok = c->Prefilter(Request(*good, "phong:s=32"));
  EXPECT_TRUE(ok.ok()) << ok.status();
}

TEST_F(ServiceTest, AdmissionControlRefusesExcessJobsQuickly) {
  // The only slot is held by a job waiting at the gate; every other job must be refused at once
  // (never queued behind it): they return while the held job still cannot finish.
  ServerOptions opt;
  opt.service.max_jobs = 1;
  testing::StageGate gate;
  opt.service.test_stage_hook = gate.Hook();
  auto c = StartServer(opt);
  absl::StatusOr<std::string> sha = c->UploadIfMissing(MapPath("interior.exr"));
  ASSERT_TRUE(sha.ok());
  absl::Status held;
  std::thread holder([&] { held = c->Prefilter(Request(*sha, "phong:s=32")).status(); });
  ASSERT_TRUE(gate.WaitHeld(1, kGateTimeout)) << "the first job never reached a stage";
  std::vector<absl::Status> results(kConcurrentJobs);
  std::vector<int64_t> retry_after(kConcurrentJobs);
  std::vector<std::thread> threads;
  for (int i = 0; i < kConcurrentJobs; ++i) {
    threads.emplace_back([&, i] {
      auto ci = ShrmClient::Connect(absl::StrCat("127.0.0.1:", port_));
      // A deadline only so that a queued (wrongly accepted) call fails instead of hanging.
      results[i] =
          PrefilterReachingServer(ci->get(), Request(*sha, "phong:s=32"), kGateTimeout).status();
      retry_after[i] = (*ci)->last_retry_after_ms();
    });
  }
  for (auto& t : threads) t.join();
  gate.Open();
  holder.join();
  EXPECT_TRUE(held.ok()) << held;
  for (int i = 0; i < kConcurrentJobs; ++i) {
    EXPECT_EQ(results[i].code(), absl::StatusCode::kResourceExhausted) << results[i];
    EXPECT_GT(retry_after[i], 0);
  }
}

TEST_F(ServiceTest, ShortDeadlineGivesDeadlineExceededAndTheServerAbandonsTheJob) {
  // By the order of events: the job waits at the gate until the client has seen its deadline
  // pass, then the server must stop it at its next stage check and count it.
  ServerOptions opt;
  testing::StageGate gate;
  opt.service.test_stage_hook = gate.Hook();
  auto c = StartServer(opt);
  absl::StatusOr<std::string> sha = c->UploadIfMissing(MapPath("interior.exr"));
  ASSERT_TRUE(sha.ok());
  auto abandoned = [] { return server::Metrics::Global().AbandonedCount("deadline"); };
  const uint64_t before = abandoned();
  absl::Status status;
  std::thread caller(
      [&] { status = c->Prefilter(Request(*sha, "phong:s=32"), nullptr, kHeldDeadline).status(); });
  const bool reached = gate.WaitHeld(1, kGateTimeout);
  const absl::Time held_by = absl::Now();
  caller.join();  // returns once the client's deadline has passed: the job is held meanwhile
  // The server's deadline is the call's arrival plus the timeout the client sent (gRPC sends the
  // time left, not the instant), so it can lie after the client's; it is at most held_by +
  // kHeldDeadline. Past it, the server's next check must find the deadline, not a cancellation.
  absl::SleepFor(held_by + kHeldDeadline + kTimeoutRounding - absl::Now());
  gate.Open();
  ASSERT_TRUE(reached) << "the job never reached a stage";
  EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded) << status;
  // The server stops the job at its next stage boundary, counted in /metrics.
  EXPECT_EQ(WaitForIncrease(abandoned, before), before + 1);
  EXPECT_NE(
      server::Metrics::Global().Render().find("shrm_jobs_abandoned_total{reason=\"deadline\""),
      std::string::npos);
}

TEST_F(ServiceTest, ClientCancellationStopsTheJob) {
  ServerOptions opt;
  opt.service.test_stage_delay = kSlowStage;
  auto c = StartServer(opt);
  absl::StatusOr<std::string> sha = c->UploadIfMissing(MapPath("interior.exr"));
  ASSERT_TRUE(sha.ok());
  auto abandoned = [] { return server::Metrics::Global().AbandonedCount("cancelled"); };
  const uint64_t before = abandoned();
  std::atomic<bool> cancel{false};
  int events = 0;
  // Cancel after the first progress event (the job has ~1 s of stages left).
  absl::StatusOr<client::PrefilterOutcome> r = c->Prefilter(
      Request(*sha, "phong:s=32"),
      [&](const v1::PrefilterProgress&) {
        ++events;
        cancel = true;
      },
      absl::InfiniteDuration(), &cancel);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kCancelled) << r.status();
  EXPECT_GE(events, 1);
  EXPECT_EQ(WaitForIncrease(abandoned, before), before + 1);
  // The server is still serving: a normal job succeeds once the stopped one has given its slot
  // back (the client learns of the cancellation before the server's handler has returned).
  EXPECT_TRUE(WaitForSlotsFree()) << "the cancelled job kept its slot";
  absl::StatusOr<client::PrefilterOutcome> ok = c->Prefilter(Request(*sha, "phong:s=8"));
  EXPECT_TRUE(ok.ok()) << ok.status();
}

// Behind a round-robin target over two replicas with separate spools, the CLI's remote job finds
// its map wherever the job lands (re-upload after NOT_FOUND) and writes the embedded bytes.
TEST_F(ServiceTest, CliJobRetriesAcrossReplicasThatLackTheMap) {
  auto c1 = StartServer();
  const int port1 = port_;
  auto c2 = StartServer();
  const int port2 = port_;
  const std::string map = MapPath("courtyard.exr");
  // Only replica 1 has the map at first.
  ASSERT_TRUE(c1->UploadIfMissing(map).ok());
  const std::string a = testing::UniqueTempPath("rr_embedded.shrm.exr");
  for (const char* brdf : {"phong:s=16", "phong:s=32", "microfacet:sigma=0.3", "ward:alpha=0.2"}) {
    const std::string b = testing::UniqueTempPath("rr_remote.shrm.exr");
    const std::string rep = testing::UniqueTempPath("rr_remote.json");
    const std::string args = absl::StrCat(" prefilter --env ", map, " --brdf ", brdf,
                                          " --orders 8,2 --size 32 > /dev/null 2>&1");
    ASSERT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, args, " -o ", a).c_str()), 0);
    ASSERT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, args, " -o ", b, " --report ", rep,
                                       " --server ipv4:127.0.0.1:", port1, ",127.0.0.1:", port2)
                              .c_str()),
              0)
        << brdf;
    EXPECT_TRUE(ReadFile(a) == ReadFile(b)) << brdf << ": the remote file differs";
    const nlohmann::json report = nlohmann::json::parse(ReadFile(rep), nullptr, false);
    ASSERT_TRUE(report.contains("retries")) << ReadFile(rep);
    // One NOT_FOUND, then two copies uploaded land on both replicas: at most one retry a job.
    EXPECT_LE(report["retries"].get<int>(), 1) << brdf;
    for (const auto& f : {a, b, rep}) std::filesystem::remove(f);
  }
}

TEST_F(ServiceTest, AnalyzeAndListBrdfModels) {
  auto c = StartServer();
  absl::StatusOr<v1::ListBrdfModelsResponse> models = c->ListBrdfModels();
  ASSERT_TRUE(models.ok());
  EXPECT_EQ(models->models_size(), static_cast<int>(ListBrdfModels().size()));
  absl::StatusOr<std::string> sha = c->UploadIfMissing(MapPath("forest.exr"));
  ASSERT_TRUE(sha.ok());
  v1::AnalyzeRequest req;
  req.mutable_environment()->add_sha256(*sha);
  req.set_brdf("phong:s=32");
  req.add_epsilon(0.1);
  absl::StatusOr<v1::AnalyzeResponse> resp = c->Analyze(req);
  ASSERT_TRUE(resp.ok()) << resp.status();
  ASSERT_EQ(resp->results_size(), 1);
  // The same analysis in process.
  EnvMapOptions eo;
  eo.paths = {MapPath("forest.exr")};
  auto env = EnvMap::Load(eo);
  auto brdf = ParseBrdfSpec("phong:s=32");
  PrefilterOptions po;
  po.epsilon = 0.1;
  po.synthesize = false;
  auto pr = Prefilter(*env, **brdf, po);
  ASSERT_TRUE(pr.ok());
  EXPECT_EQ(resp->results(0).f_b(), pr->analysis.f_b);
  EXPECT_EQ(resp->results(0).p_b(), pr->analysis.p_b);
  EXPECT_EQ(resp->results(0).eps_bound(), pr->analysis.eps_bound);
}

// Writes kTableSource sampled as a SHRMBRDF table to `path`.
void WriteGgxTable(const std::string& path) {
  auto ggx = ParseBrdfSpec(kTableSource);
  ASSERT_TRUE(ggx.ok()) << ggx.status();
  absl::StatusOr<BrdfTableData> table =
      SampleBrdfTable(**ggx, kTableThetaI, kTableThetaO, kTablePhi);
  ASSERT_TRUE(table.ok()) << table.status();
  ASSERT_TRUE(WriteBrdfTable(path, *table).ok());
}

TEST_F(ServiceTest, TableBrdfTravelsAsBlobAndMatchesEmbeddedByteForByte) {
  auto c = StartServer();
  const std::string table = testing::UniqueTempPath("ggx_table.shrmbrdf");
  WriteGgxTable(table);
  const std::string map = MapPath("courtyard.exr");
  const std::string a = testing::UniqueTempPath("table_embedded.shrm.exr");
  const std::string b = testing::UniqueTempPath("table_remote.shrm.exr");
  const std::string rep = testing::UniqueTempPath("table_remote.json");
  const std::string common =
      absl::StrCat(" prefilter --env ", map, " --brdf table:", table, " --orders ", kTestF, ",",
                   kTestP, " --size ", kTestFaceSize, " > /dev/null 2>&1");
  ASSERT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, common, " -o ", a).c_str()), 0);
  ASSERT_EQ(std::system(absl::StrCat(SHRM_CLI_PATH, common, " -o ", b, " --report ", rep,
                                     " --server 127.0.0.1:", port_)
                            .c_str()),
            0);
  const std::string ea = ReadFile(a), eb = ReadFile(b);
  EXPECT_FALSE(ea.empty());
  EXPECT_TRUE(ea == eb) << "shrm --server with a table BRDF wrote a different file";
  absl::StatusOr<ShrmFile> remote = ReadShrmFile(b);
  ASSERT_TRUE(remote.ok()) << remote.status();
  EXPECT_EQ(remote->attributes.at("shrm:brdf"), absl::StrCat("table:", table));
  const std::string report = ReadFile(rep);
  EXPECT_NE(report.find(absl::StrCat("\"table:", table, "\"")), std::string::npos) << report;
  EXPECT_EQ(report.find(dirs_[0]), std::string::npos) << "the report leaks the spool path";
  EXPECT_NE(report.find("\"brdf\": \"miss\""), std::string::npos) << report;

  // The table went up as a blob under its content hash.
  const std::string table_sha = *Sha256OfFile(table);
  absl::StatusOr<v1::HasBlobResponse> has = c->HasBlob(table_sha);
  ASSERT_TRUE(has.ok());
  EXPECT_TRUE(has->present());

  // Again with the same content under another name: rho_lpq comes from the cache (keyed by the
  // blob's hash, not by a path or the display spec).
  absl::StatusOr<std::string> env_sha = c->UploadIfMissing(map);
  ASSERT_TRUE(env_sha.ok());
  auto req = Request(*env_sha, "table:@");
  req.set_brdf_blob_sha256(table_sha);
  absl::StatusOr<client::PrefilterOutcome> r = c->Prefilter(req);
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_TRUE(r->report.cache().brdf_hit());
  EXPECT_TRUE(r->report.cache().lighting_hit());
  EXPECT_EQ(r->report.brdf(), absl::StrCat("table:@", table_sha));

  // Analyze takes blob BRDFs too.
  v1::AnalyzeRequest areq;
  areq.set_brdf("table:@");
  areq.set_brdf_blob_sha256(table_sha);
  areq.set_brdf_display_spec("table:mine.shrmbrdf");
  areq.add_epsilon(0.1);
  absl::StatusOr<v1::AnalyzeResponse> an = c->Analyze(areq);
  ASSERT_TRUE(an.ok()) << an.status();
  EXPECT_EQ(an->brdf(), "table:mine.shrmbrdf");
  ASSERT_EQ(an->results_size(), 1);
  EXPECT_GT(an->results(0).f_brdf(), 0);
  for (const auto& f : {a, b, rep, table}) std::filesystem::remove(f);
}

TEST_F(ServiceTest, BadBrdfBlobsGetNotFoundAndInvalidArgumentWithoutPaths) {
  auto c = StartServer();
  absl::StatusOr<std::string> env_sha = c->UploadIfMissing(MapPath("interior.exr"));
  ASSERT_TRUE(env_sha.ok());
  const std::string missing(64, 'b');
  // A table whose header promises more values than it holds.
  std::string corrupt = "SHRMBRDF";
  for (uint32_t v : {1u, 1u, 0u, 0u, 8u, 8u, 4u}) corrupt.append(reinterpret_cast<char*>(&v), 4);
  corrupt += std::string(100, '\x3f');
  absl::StatusOr<std::string> corrupt_sha = c->UploadBytes(corrupt);
  ASSERT_TRUE(corrupt_sha.ok());

  struct Case {
    const char* what;
    std::string spec, sha;
    absl::StatusCode code;
    std::string message_part;
  };
  const std::vector<Case> cases = {
      {"missing table blob", "table:@", missing, absl::StatusCode::kNotFound,
       absl::StrCat("BRDF blob ", missing)},
      {"missing MERL blob", "merl:@", missing, absl::StatusCode::kNotFound, "upload it first"},
      {"corrupt table blob", "table:@", *corrupt_sha, absl::StatusCode::kInvalidArgument,
       absl::StrCat("BRDF blob ", *corrupt_sha)},
      {"corrupt MERL blob", "merl:@", *corrupt_sha, absl::StatusCode::kInvalidArgument,
       absl::StrCat("BRDF blob ", *corrupt_sha)},
      {"table:@ without a hash", "table:@", "", absl::StatusCode::kInvalidArgument,
       "brdf_blob_sha256"},
      {"hash with an analytic BRDF", "phong:s=32", *corrupt_sha, absl::StatusCode::kInvalidArgument,
       "brdf_blob_sha256"},
      {"table path", "table:/etc/passwd", "", absl::StatusCode::kInvalidArgument, "table:@"},
  };
  for (const Case& k : cases) {
    auto req = Request(*env_sha, k.spec);
    req.set_brdf_blob_sha256(k.sha);
    absl::StatusOr<client::PrefilterOutcome> r = c->Prefilter(req);
    EXPECT_EQ(r.status().code(), k.code) << k.what << ": " << r.status();
    EXPECT_NE(r.status().message().find(k.message_part), std::string::npos)
        << k.what << ": " << r.status();
    EXPECT_EQ(r.status().message().find(dirs_[0]), std::string::npos)
        << k.what << ": the message leaks the spool path: " << r.status();
  }
  absl::StatusOr<client::PrefilterOutcome> ok = c->Prefilter(Request(*env_sha, "phong:s=32"));
  EXPECT_TRUE(ok.ok()) << ok.status();
}

// --- Live (docs/live.md) ------------------------------------------------------------------------

// The file `shrm prefilter` writes for one live state (the job's check off, the paper's rule).
std::string EmbeddedLiveFile(const std::string& map, const std::string& brdf,
                             std::optional<std::array<double, 3>> rotate) {
  jobs::PrefilterJob job;
  job.env.files = {map};
  job.env.rotate_ypr_deg = rotate;
  job.brdf = brdf;
  jobs::UseEpsilonRule(&job, jobs::kDefaultEpsilon);
  job.verify = 0;
  job.face_size = kTestFaceSize;
  absl::StatusOr<jobs::PrefilterRun> pr = jobs::RunPrefilterJob(job, /*threads=*/1);
  EXPECT_TRUE(pr.ok()) << pr.status();
  if (!pr.ok()) return "";
  absl::StatusOr<std::string> bytes =
      EncodeShrmFile("embedded", pr->result.cube, pr->attributes, false);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  return bytes.ok() ? *bytes : "";
}

v1::LiveRequest LiveEnvironment(const std::string& sha, const std::string& name) {
  v1::LiveRequest r;
  r.mutable_environment()->add_sha256(sha);
  r.mutable_environment()->add_source_names(name);
  return r;
}
v1::LiveRequest LiveBrdf(const std::string& spec) {
  v1::LiveRequest r;
  r.set_brdf(spec);
  return r;
}
v1::LiveRequest LiveRotation(double yaw) {
  v1::LiveRequest r;
  r.mutable_rotation()->set_yaw_deg(yaw);
  return r;
}
v1::LiveOpen LiveOpenAt(int face_size) {
  v1::LiveOpen open;
  open.set_face_size(face_size);
  return open;
}

// A live call opened at kTestFaceSize with the map (uploaded, request 1) and the BRDF (request 2)
// sent.
std::unique_ptr<client::LiveCall> OpenLiveOn(ShrmClient* c, const std::string& map,
                                             const std::string& brdf) {
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  EXPECT_TRUE(sha.ok()) << sha.status();
  absl::StatusOr<std::unique_ptr<client::LiveCall>> call = c->OpenLive(LiveOpenAt(kTestFaceSize));
  EXPECT_TRUE(call.ok()) << call.status();
  if (!sha.ok() || !call.ok()) return nullptr;
  EXPECT_TRUE((*call)->Send(LiveEnvironment(*sha, map)));
  EXPECT_TRUE((*call)->Send(LiveBrdf(brdf)));
  return *std::move(call);
}

// Frames until the one of request `update` (frames of earlier states may come first).
std::optional<client::LiveFrameOutcome> FrameOf(client::LiveCall* call, uint64_t update) {
  for (;;) {
    absl::StatusOr<std::optional<client::LiveFrameOutcome>> f = call->Next();
    EXPECT_TRUE(f.ok()) << f.status();
    if (!f.ok() || !f->has_value()) return std::nullopt;
    if ((*f)->update >= update) return *f;
  }
}

// Each frame is the file `shrm prefilter` writes for the same state: a map and a BRDF, then the
// map rotated, then another BRDF.
TEST_F(ServiceTest, LiveFramesAreThePrefilterFilesOfEachState) {
  auto c = StartServer();
  const std::string map = MapPath("courtyard.exr");
  std::unique_ptr<client::LiveCall> call = OpenLiveOn(c.get(), map, "microfacet:sigma=0.3");
  ASSERT_NE(call, nullptr);
  client::LiveCall& live = *call;
  std::optional<client::LiveFrameOutcome> f = FrameOf(&live, 2);
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->update, 2u);
  EXPECT_TRUE(f->shrm_file == EmbeddedLiveFile(map, "microfacet:sigma=0.3", std::nullopt));
  ASSERT_TRUE(live.Send(LiveRotation(90)));
  f = FrameOf(&live, 3);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(f->shrm_file ==
              EmbeddedLiveFile(map, "microfacet:sigma=0.3", std::array<double, 3>{90, 0, 0}));
  ASSERT_TRUE(live.Send(LiveBrdf("phong:s=32")));
  ASSERT_TRUE(live.CloseSending());
  f = FrameOf(&live, 4);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(f->shrm_file == EmbeddedLiveFile(map, "phong:s=32", std::array<double, 3>{90, 0, 0}));
  absl::StatusOr<std::optional<client::LiveFrameOutcome>> end = live.Next();
  ASSERT_TRUE(end.ok()) << end.status();
  EXPECT_FALSE(end->has_value());
  EXPECT_TRUE(live.Finish().ok());
}

// The cube of an SHRM file's bytes (read back through a temporary file).
std::vector<float> CubeOfFile(const std::string& bytes) {
  const std::string path = testing::UniqueTempPath("live_frame") + ".shrm.exr";
  std::ofstream(path, std::ios::binary) << bytes;
  absl::StatusOr<ShrmFile> f = ReadShrmFile(path);
  std::filesystem::remove(path);
  EXPECT_TRUE(f.ok()) << f.status();
  return f.ok() ? f->cube.data : std::vector<float>{};
}

v1::LiveRequest LiveCoefficientsOf(const std::vector<double>& rgb, int lmax,
                                   std::optional<std::array<double, 3>> energy) {
  v1::LiveRequest r;
  r.mutable_coefficients()->set_lmax(lmax);
  for (double v : rgb) r.mutable_coefficients()->add_rgb(v);
  if (energy) {
    for (double e : *energy) r.mutable_coefficients()->add_energy(e);
  }
  return r;
}

v1::LiveRequest LiveViewOf(std::optional<std::array<double, 3>> v) {
  v1::LiveRequest r;
  r.mutable_view();
  if (v) {
    r.mutable_view()->mutable_direction()->set_x((*v)[0]);
    r.mutable_view()->mutable_direction()->set_y((*v)[1]);
    r.mutable_view()->mutable_direction()->set_z((*v)[2]);
  }
  return r;
}

// The lighting as SH coefficients: the map's own L_lm (to a degree above F_rho, with the map's
// energy, computed here by core's transform) give the map's frame, cube for cube (the session
// truncates them to F_rho, as the map's transform at F_rho gives them); a rotation then turns them
// as it turns the map. A view adds its eq. 5.35 map to each frame; view_only sends only that.
TEST_F(ServiceTest, LiveCoefficientsGiveTheMapsFramesAndViewsTheirMaps) {
  auto c = StartServer();
  const std::string map = MapPath("courtyard.exr");
  const std::string brdf = "microfacet:sigma=0.3";
  constexpr int kLmax = 20;  // above F_rho of the BRDF at epsilon 0.03, below the map's H / 2
  EnvMapOptions options;
  options.paths = {map};
  absl::StatusOr<EnvMap> env = EnvMap::Load(options);
  ASSERT_TRUE(env.ok()) << env.status();
  absl::StatusOr<std::vector<double>> light =
      LightingCoefficients(*env, kLmax, Mat3::Identity(), /*threads=*/1);
  ASSERT_TRUE(light.ok()) << light.status();
  const std::array<double, 3> energy = LightingEnergy(*env);

  std::unique_ptr<client::LiveCall> call = OpenLiveOn(c.get(), map, brdf);
  ASSERT_NE(call, nullptr);
  client::LiveCall& live = *call;
  std::optional<client::LiveFrameOutcome> f = FrameOf(&live, 2);
  ASSERT_TRUE(f.has_value());
  EXPECT_FALSE(f->view.has_value());
  EXPECT_TRUE(f->view_file.empty());
  const std::vector<float> of_map = CubeOfFile(f->shrm_file);
  ASSERT_FALSE(of_map.empty());

  const std::array<double, 3> view{0.3, 0.5, -0.8};
  ASSERT_TRUE(live.Send(LiveViewOf(view)));
  f = FrameOf(&live, 3);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(f->shrm_file == EmbeddedLiveFile(map, brdf, std::nullopt)) << "only the view changed";
  ASSERT_TRUE(f->view.has_value());
  const double norm = std::sqrt(0.09 + 0.25 + 0.64);
  EXPECT_NEAR((*f->view)[0], 0.3 / norm, 1e-15);
  const std::string view_file = f->view_file;
  EXPECT_FALSE(view_file.empty());
  ASSERT_TRUE(live.Send(LiveViewOf(std::nullopt)));
  f = FrameOf(&live, 4);
  ASSERT_TRUE(f.has_value());
  EXPECT_FALSE(f->view.has_value());
  EXPECT_TRUE(f->view_file.empty());

  ASSERT_TRUE(live.Send(LiveCoefficientsOf(*light, kLmax, energy)));
  f = FrameOf(&live, 5);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(CubeOfFile(f->shrm_file) == of_map)
      << "the coefficients' frame differs from the map's";
  ASSERT_TRUE(live.Send(LiveRotation(90)));
  ASSERT_TRUE(live.CloseSending());
  f = FrameOf(&live, 6);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(CubeOfFile(f->shrm_file) ==
              CubeOfFile(EmbeddedLiveFile(map, brdf, std::array<double, 3>{90, 0, 0})));
  absl::StatusOr<std::optional<client::LiveFrameOutcome>> end = live.Next();
  ASSERT_TRUE(end.ok()) << end.status();
  EXPECT_FALSE(end->has_value());
  EXPECT_TRUE(live.Finish().ok());

  // view_only: the view maps alone, nothing before the view is set.
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();
  v1::LiveOpen open = LiveOpenAt(kTestFaceSize);
  open.set_view_only(true);
  absl::StatusOr<std::unique_ptr<client::LiveCall>> only = c->OpenLive(open);
  ASSERT_TRUE(only.ok()) << only.status();
  ASSERT_TRUE((*only)->Send(LiveEnvironment(*sha, map)));
  ASSERT_TRUE((*only)->Send(LiveBrdf(brdf)));
  ASSERT_TRUE((*only)->Send(LiveViewOf(view)));
  ASSERT_TRUE((*only)->CloseSending());
  f = FrameOf(only->get(), 3);
  ASSERT_TRUE(f.has_value());
  EXPECT_TRUE(f->shrm_file.empty());
  EXPECT_TRUE(f->view_file == view_file);
  end = (*only)->Next();
  ASSERT_TRUE(end.ok()) << end.status();
  EXPECT_FALSE(end->has_value());
  EXPECT_TRUE((*only)->Finish().ok());
}

// Ten rotations while the session's worker is held (a producer far faster than the computation):
// once every request is read, the one frame computed is the last state's, the eleven states
// before it dropped and counted. By the order of events, not by timing.
TEST_F(ServiceTest, LiveSendsTheLatestStateAndCountsTheDroppedOnes) {
  std::atomic<int> requests{0};
  testing::StageGate gate("live frame");
  ServerOptions opt;
  opt.service.test_stage_hook = [&requests, hook = gate.Hook()](std::string_view stage) {
    if (stage == "live request") ++requests;
    hook(stage);
  };
  auto c = StartServer(opt);
  const std::string map = MapPath("courtyard.exr");
  std::unique_ptr<client::LiveCall> call = OpenLiveOn(c.get(), map, "microfacet:sigma=0.3");
  ASSERT_NE(call, nullptr);
  client::LiveCall& live = *call;
  for (int k = 1; k <= 10; ++k) ASSERT_TRUE(live.Send(LiveRotation(9.0 * k)));
  ASSERT_TRUE(live.CloseSending());
  EXPECT_TRUE(gate.WaitHeld(1, kGateTimeout)) << "the session never started a frame";
  for (int i = 0; i < 1200 && requests.load() < 12; ++i) absl::SleepFor(absl::Milliseconds(100));
  ASSERT_EQ(requests.load(), 12) << "the server did not read every request (safety net)";
  gate.Open();
  absl::StatusOr<std::optional<client::LiveFrameOutcome>> f = live.Next();
  ASSERT_TRUE(f.ok()) << f.status();
  ASSERT_TRUE(f->has_value());
  EXPECT_EQ((*f)->update, 12u);
  EXPECT_EQ((*f)->dropped, 11u);
  EXPECT_TRUE((*f)->shrm_file ==
              EmbeddedLiveFile(map, "microfacet:sigma=0.3", std::array<double, 3>{90, 0, 0}));
  absl::StatusOr<std::optional<client::LiveFrameOutcome>> end = live.Next();
  ASSERT_TRUE(end.ok()) << end.status();
  EXPECT_FALSE(end->has_value()) << "one frame for the twelve requests";
  EXPECT_TRUE(live.Finish().ok());
}

// `shrm live --server` writes the embedded `shrm live`'s files: a sequence and a turntable.
TEST_F(ServiceTest, CliLiveRemoteWritesTheEmbeddedFiles) {
  auto c = StartServer();
  const std::string a = MapPath("courtyard.exr"), b = MapPath("city.exr");
  for (const std::string& frames :
       {absl::StrCat("--sequence ", a, " ", b), absl::StrCat("--env ", a, " --turntable 3")}) {
    const std::string local = testing::UniqueTempPath("live_local");
    const std::string remote = testing::UniqueTempPath("live_remote");
    const std::string common =
        absl::StrCat(SHRM_CLI_PATH, " live ", frames,
                     " --brdf microfacet:sigma=0.3 --size 16 --view 0.2,0.5,-1 > /dev/null 2>&1");
    ASSERT_EQ(std::system(absl::StrCat(common, " -o ", local).c_str()), 0) << common;
    ASSERT_EQ(
        std::system(absl::StrCat(common, " -o ", remote, " --server 127.0.0.1:", port_).c_str()), 0)
        << common;
    for (int k = 0; k < 2; ++k) {
      const std::string name = absl::StrCat("/frame_000", k, ".shrm.exr");
      const std::string want = ReadFile(local + name);
      EXPECT_FALSE(want.empty()) << name;
      EXPECT_TRUE(want == ReadFile(remote + name)) << frames << name << ": the remote file differs";
      const std::string view = absl::StrCat("/frame_000", k, ".view.exr");
      const std::string want_view = ReadFile(local + view);
      EXPECT_FALSE(want_view.empty()) << view;
      EXPECT_TRUE(want_view == ReadFile(remote + view)) << frames << view << ": differs";
    }
    std::filesystem::remove_all(local);
    std::filesystem::remove_all(remote);
  }
}

// `shrm live --ktx2 --server` (LiveOpen.shrm_ktx2: the coefficient planes in the KTX2 container)
// writes the embedded run's frame_NNNN.shrm.ktx2, byte for byte.
TEST_F(ServiceTest, CliLiveRemoteWritesTheEmbeddedKtx2Files) {
  auto c = StartServer();
  const std::string common =
      absl::StrCat(SHRM_CLI_PATH, " live --env ", MapPath("courtyard.exr"),
                   " --turntable 2 --brdf microfacet:sigma=0.3 --size 16 --ktx2 > /dev/null 2>&1");
  const std::string local = testing::UniqueTempPath("live_ktx2_local");
  const std::string remote = testing::UniqueTempPath("live_ktx2_remote");
  ASSERT_EQ(std::system(absl::StrCat(common, " -o ", local).c_str()), 0) << common;
  ASSERT_EQ(
      std::system(absl::StrCat(common, " -o ", remote, " --server 127.0.0.1:", port_).c_str()), 0)
      << common;
  for (int k = 0; k < 2; ++k) {
    const std::string name = absl::StrCat("/frame_000", k, ".shrm.ktx2");
    const std::string want = ReadFile(local + name);
    EXPECT_EQ(want.substr(0, 12), std::string("\xABKTX 20\xBB\r\n\x1A\n", 12)) << name;
    EXPECT_TRUE(want == ReadFile(remote + name)) << name << ": the remote file differs";
  }
  std::filesystem::remove_all(local);
  std::filesystem::remove_all(remote);
}

// Bad requests end the call with their error, naming the request; the daemon serves on.
TEST_F(ServiceTest, LiveBadRequestsEndTheCallNamingTheRequest) {
  auto c = StartServer();
  const std::string map = MapPath("courtyard.exr");
  absl::StatusOr<std::string> sha = c->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();
  auto ended = [&](const std::vector<v1::LiveRequest>& requests) {
    absl::StatusOr<std::unique_ptr<client::LiveCall>> call = c->OpenLive(LiveOpenAt(kTestFaceSize));
    if (!call.ok()) return call.status();
    for (const v1::LiveRequest& r : requests) (*call)->Send(r);
    (*call)->CloseSending();
    while (true) {
      absl::StatusOr<std::optional<client::LiveFrameOutcome>> f = (*call)->Next();
      if (!f.ok() || !f->has_value()) break;
    }
    return (*call)->Finish();
  };
  absl::Status s = ended({LiveEnvironment(std::string(64, 'a'), "nothere.exr")});
  EXPECT_EQ(s.code(), absl::StatusCode::kNotFound) << s;
  EXPECT_NE(s.message().find("request 1"), std::string::npos) << s;
  s = ended({LiveEnvironment(*sha, map), LiveBrdf("phong:s=-1")});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find("request 2"), std::string::npos) << s;
  s = ended({LiveBrdf("table:/etc/passwd")});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  // Coefficients: a count that does not fit the degree, a degree out of range, a NaN, an energy
  // below the coefficients' own; a zero view.
  const std::vector<double> nine(27, 0.5);
  for (const v1::LiveRequest& bad_light :
       {LiveCoefficientsOf(nine, 3, std::nullopt), LiveCoefficientsOf(nine, 257, std::nullopt),
        LiveCoefficientsOf(nine, -1, std::nullopt),
        LiveCoefficientsOf(std::vector<double>(27, std::nan("")), 2, std::nullopt),
        LiveCoefficientsOf(nine, 2, std::array<double, 3>{1.0, 1.0, 1.0}),
        LiveCoefficientsOf(nine, 2, std::array<double, 3>{-1.0, 3.0, 3.0}),
        LiveViewOf(std::array<double, 3>{0, 0, 0})}) {
    s = ended({LiveBrdf("phong:s=32"), bad_light});
    EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
    EXPECT_NE(s.message().find("request 2"), std::string::npos) << s;
  }
  v1::LiveRequest open_again;
  *open_again.mutable_open() = LiveOpenAt(16);
  s = ended({open_again});
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  v1::LiveOpen bad_open;
  bad_open.mutable_orders()->set_f(8);
  bad_open.mutable_orders()->set_p(99);
  absl::StatusOr<std::unique_ptr<client::LiveCall>> bad = c->OpenLive(bad_open);
  ASSERT_TRUE(bad.ok()) << bad.status();
  (*bad)->CloseSending();
  while (true) {
    absl::StatusOr<std::optional<client::LiveFrameOutcome>> f = (*bad)->Next();
    if (!f.ok() || !f->has_value()) break;
  }
  s = (*bad)->Finish();
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(s.message().find("request 0"), std::string::npos) << s;
  // And it serves on.
  EXPECT_TRUE(c->HasBlob(*sha).ok());
}

}  // namespace
}  // namespace shrm
