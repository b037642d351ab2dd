// Memory-aware admission (docs/server.md, "Memory"): the budget's accounting, and a real shrmd
// (the built daemon, its defaults except a small budget and a private spool) running a mix of
// the largest jobs it accepts from several clients at its default --max-jobs: its peak resident
// memory, read from /proc (VmHWM), stays within --memory-mib; jobs held back are refused with
// MEMORY_BUSY and complete when sent again; a job larger than the budget is refused for good.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "client/shrm_client.h"
#include "jobs/memory_estimate.h"
#include "proto/status_details.h"
#include "server/memory_budget.h"
#include "server/server.h"
#include "tests/loopback.h"
#include "tests/stage_gate.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace v1 = ::shrm::v1;
using server::MemoryBudget;

constexpr uint64_t kMiB = uint64_t{1} << 20;
// Clients send a refused job again after the server's delay (1 s) for as long as the running jobs
// take (seconds each); far more attempts than that needs.
constexpr int kAttempts = 600;
constexpr absl::Duration kPoll = absl::Milliseconds(100);
constexpr int kStartPolls = 300;     // 30 s for the daemon to start on a loaded machine
constexpr int kReleasePolls = 1200;  // 120 s for handlers to return (a safety net)

TEST(MemoryBudgetTest, ReservesRefusesWhatDoesNotFitNowAndWhatNeverFits) {
  MemoryBudget budget(100 * kMiB, "--memory-mib 300");
  {
    MemoryBudget::Reservation a(&budget);
    ASSERT_TRUE(a.Add(60 * kMiB, "decoding the map").ok());
    MemoryBudget::Reservation b(&budget);
    // 60 + 50 > 100: not now (retry), and the message says what is free.
    const absl::Status busy = b.Add(50 * kMiB, "an SHRM cube");
    EXPECT_TRUE(absl::IsResourceExhausted(busy)) << busy;
    EXPECT_EQ(wire::ErrorReason(busy), wire::kReasonMemoryBusy);
    EXPECT_TRUE(wire::RetryDelay(busy).has_value());
    EXPECT_TRUE(absl::StrContains(busy.message(), "40 of 100 MiB are free")) << busy;
    EXPECT_EQ(b.bytes(), 0u);  // a refused reservation holds nothing
    ASSERT_TRUE(b.Add(40 * kMiB, "an SHRM cube").ok());
    EXPECT_EQ(budget.reserved(), 100 * kMiB);
    // A job that holds 60 and asks 50 more can never fit: final, naming the need and the limit.
    const absl::Status never = a.Add(50 * kMiB, "an SHRM cube");
    EXPECT_TRUE(absl::IsInvalidArgument(never)) << never;
    EXPECT_EQ(wire::ErrorReason(never), wire::kReasonJobTooLarge);
    EXPECT_TRUE(absl::StrContains(never.message(), "110 MiB")) << never;
    EXPECT_TRUE(absl::StrContains(never.message(), "--memory-mib 300")) << never;
  }
  EXPECT_EQ(budget.reserved(), 0u);  // released with the reservations
  EXPECT_EQ(budget.peak_reserved(), 100 * kMiB);

  MemoryBudget unlimited(0, "none");
  MemoryBudget::Reservation r(&unlimited);
  EXPECT_TRUE(r.Add(uint64_t{1} << 50, "anything").ok());
}

TEST(MemoryBudgetTest, SystemLimitIsAtMostThePhysicalMemory) {
  const server::SystemMemory m = server::SystemMemoryLimit();
  const uint64_t physical =
      static_cast<uint64_t>(sysconf(_SC_PHYS_PAGES)) * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
  EXPECT_GT(m.bytes, 0u);
  EXPECT_LE(m.bytes, physical) << m.source;
  EXPECT_FALSE(m.source.empty());
}

// What jobs may hold in the in-process server below (its budget is set from the test process's
// memory at start, so this is what is left for jobs, give or take what the process allocates
// while the server starts; the test reads the exact figure back).
constexpr uint64_t kInProcessJobBytes = uint64_t{512} << 20;
// A held job's safety net: far beyond a job of a second; a server that never gets there fails
// the test instead of hanging it (not a timing claim).
constexpr absl::Duration kGateTimeout = absl::Seconds(300);
constexpr absl::Duration kRefusalDeadline = absl::Seconds(120);

// Admission by the order of events, not by time: job A is held (tests/stage_gate.h) after its
// cube is made, holding its memory; job B, which does not fit beside it, is refused with
// MEMORY_BUSY and a retry delay at once (never queued); once A has finished, B runs. A job larger
// than everything is refused for good, and nothing stays reserved.
TEST(MemoryAdmissionInProcessTest, AJobThatDoesNotFitBesideAnotherIsRefusedUntilItEnds) {
  const std::string dir = testing::UniqueTempPath("memory_inprocess");
  server::ServerOptions opt;
  opt.listen = "127.0.0.1:0";
  opt.service.spool_dir = dir + "/spool";
  opt.service.max_jobs = 2;  // slots for both: only memory holds B back
  opt.service.cache_bytes = 16 << 20;
  opt.service.memory_bytes = server::ProcessRssBytes() + opt.service.cache_bytes +
                             server::kServiceReserveBytes + kInProcessJobBytes;
  opt.service.memory_text = "the test's budget";
  testing::StageGate gate("write");
  opt.service.test_stage_hook = gate.Hook();
  absl::StatusOr<std::unique_ptr<server::ShrmServer>> srv = server::ShrmServer::Start(opt);
  ASSERT_TRUE(srv.ok()) << srv.status();
  const uint64_t job_bytes = (*srv)->memory().job_bytes();
  ASSERT_GT(job_bytes, kInProcessJobBytes / 2);
  const std::string target = absl::StrCat("127.0.0.1:", (*srv)->port());
  absl::StatusOr<std::unique_ptr<client::ShrmClient>> a = client::ShrmClient::Connect(target, {});
  absl::StatusOr<std::unique_ptr<client::ShrmClient>> b = client::ShrmClient::Connect(target, {});
  ASSERT_TRUE(a.ok() && b.ok());
  absl::StatusOr<std::string> sha =
      (*a)->UploadIfMissing(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/courtyard.exr"));
  ASSERT_TRUE(sha.ok()) << sha.status();

  // A cube whose job needs just over half of what jobs may hold, even without its map (B finds
  // L_lm in the cache and decodes nothing): two never fit together.
  constexpr int kP = 2;
  const uint64_t fixed = jobs::kJobBaseBytes + jobs::MapBytes(1024 * 512);
  int face = 16;
  while (jobs::kJobBaseBytes + jobs::ShrmCubeBytes(face, kP) <= job_bytes / 2) face += 16;
  ASSERT_LE(fixed + jobs::ShrmCubeBytes(face, kP), job_bytes);
  v1::PrefilterRequest req;
  req.mutable_environment()->add_sha256(*sha);
  req.set_brdf("microfacet:sigma=0.2");  // not radially symmetric: P_B is the P asked for
  req.mutable_orders()->set_f(8);
  req.mutable_orders()->set_p(kP);
  req.set_face_size(face);
  req.set_verify(0);  // no check: the reservations are the map's and the cube's alone

  absl::Status a_status;
  std::thread holder([&] { a_status = (*a)->Prefilter(req).status(); });
  ASSERT_TRUE(gate.WaitHeld(1, kGateTimeout)) << "job A never reached its write stage";
  EXPECT_EQ((*srv)->memory().reserved(), fixed + jobs::ShrmCubeBytes(face, kP));
  // A B that got past admission would wait at the gate: its deadline turns that into a failure
  // instead of a hung test (a refusal comes back at once; not a timing claim).
  const absl::Status busy = (*b)->Prefilter(req, nullptr, kRefusalDeadline).status();
  EXPECT_TRUE(absl::IsResourceExhausted(busy)) << busy;
  EXPECT_EQ(wire::ErrorReason(busy), wire::kReasonMemoryBusy) << busy;
  EXPECT_TRUE(wire::RetryDelay(busy).has_value()) << busy;
  // B's own reservations went with its refusal: A's alone are held.
  EXPECT_EQ((*srv)->memory().reserved(), fixed + jobs::ShrmCubeBytes(face, kP));
  gate.Open();
  holder.join();
  EXPECT_TRUE(a_status.ok()) << a_status;
  // A's handler may still be returning when its client has the file (its slot and memory go
  // when it has): B is sent again after the server's delay, as clients do.
  absl::Status b_again;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    b_again = (*b)->Prefilter(req).status();
    const absl::Duration delay = client::ServerRetryDelay(b_again);
    if (delay <= absl::ZeroDuration()) break;
    absl::SleepFor(delay);
  }
  EXPECT_TRUE(b_again.ok()) << b_again;

  // Larger than what jobs may ever hold: INVALID_ARGUMENT, final.
  v1::PrefilterRequest huge = req;
  huge.set_face_size(1024);
  ASSERT_GT(jobs::ShrmCubeBytes(1024, kP), job_bytes);
  const absl::Status never = (*b)->Prefilter(huge).status();
  EXPECT_TRUE(absl::IsInvalidArgument(never)) << never;
  EXPECT_EQ(wire::ErrorReason(never), wire::kReasonJobTooLarge) << never;
  EXPECT_TRUE(absl::StrContains(never.message(), "the test's budget")) << never;

  // Everything released once the handlers have returned (safety-net bound, not a timing check).
  for (int i = 0; i < kReleasePolls && (*srv)->running_jobs() != 0; ++i) absl::SleepFor(kPoll);
  EXPECT_EQ((*srv)->memory().reserved(), 0u);
  EXPECT_LE((*srv)->memory().peak_reserved(), job_bytes);
  (*srv)->Shutdown(absl::ZeroDuration());
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

// The budget of the daemon under test: small enough that two of the largest jobs it accepts do
// not fit together (so admission must hold one back), large enough for the daemon's own memory,
// a 64 MiB cache and the service's reserve.
constexpr int kMemoryMib = 1024;
constexpr int kCacheMib = 64;
// The jobs are sized to this fraction of what jobs may hold: each needs more than half, so two
// never run at once, and stays clear of the limit (the sizes come in steps).
constexpr double kJobFraction = 0.9;
constexpr int kClients = 3;

// The JSON lines of the daemon's log.
std::vector<nlohmann::json> LogLines(const std::string& path) {
  std::vector<nlohmann::json> out;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    nlohmann::json j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    if (j.is_object()) out.push_back(std::move(j));
  }
  return out;
}

uint64_t PeakRssBytes(pid_t pid) {
  std::ifstream status(absl::StrCat("/proc/", pid, "/status"));
  std::string key;
  uint64_t kb = 0;
  while (status >> key) {
    if (key == "VmHWM:") status >> kb;
  }
  return kb * 1024;
}

class MemoryAdmissionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::UniqueTempPath("memory");
    std::filesystem::create_directories(dir_);
    log_ = dir_ + "/shrmd.log";
    const int port = testing::FreeLoopbackPort();
    ASSERT_GT(port, 0);
    target_ = absl::StrCat("127.0.0.1:", port);
    const std::string spool = dir_ + "/spool";
    const std::string memory = std::to_string(kMemoryMib);
    const std::string cache = std::to_string(kCacheMib);
    daemon_ = fork();
    ASSERT_GE(daemon_, 0);
    if (daemon_ == 0) {
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(fd, 2);
      execl(SHRMD_PATH, SHRMD_PATH, "--listen", target_.c_str(), "--spool-dir", spool.c_str(),
            "--memory-mib", memory.c_str(), "--cache-mib", cache.c_str(),
            static_cast<char*>(nullptr));
      _exit(127);
    }
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c =
        client::ShrmClient::Connect(target_, {});
    ASSERT_TRUE(c.ok()) << c.status();
    client_ = *std::move(c);
    for (int i = 0; i < kStartPolls && !client_->ListBrdfModels().ok(); ++i) {
      absl::SleepFor(kPoll);
    }
    ASSERT_TRUE(client_->ListBrdfModels().ok()) << "shrmd did not start; its log: " << log_;
    for (const nlohmann::json& j : LogLines(log_)) {
      if (j.value("event", "") == "listening") {
        job_bytes_ = std::stoull(j.value("job_memory_mib", "0")) * kMiB;
      }
    }
    ASSERT_GT(job_bytes_, 0u) << "no job_memory_mib in the daemon's log " << log_;
  }
  void TearDown() override {
    if (daemon_ > 0) {
      kill(daemon_, SIGTERM);
      waitpid(daemon_, nullptr, 0);
    }
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  std::string dir_, log_, target_;
  pid_t daemon_ = -1;
  uint64_t job_bytes_ = 0;
  std::unique_ptr<client::ShrmClient> client_;
};

TEST_F(MemoryAdmissionTest, LargestJobsAtTheDefaultMaxJobsStayWithinTheBudget) {
  const std::string map = absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/courtyard.exr");
  absl::StatusOr<std::string> sha = client_->UploadIfMissing(map);
  ASSERT_TRUE(sha.ok()) << sha.status();
  constexpr int64_t kMapPixels = 1024 * 512;
  const uint64_t target = static_cast<uint64_t>(kJobFraction * static_cast<double>(job_bytes_));
  const uint64_t fixed = jobs::kJobBaseBytes + jobs::MapBytes(kMapPixels);
  ASSERT_GT(target, fixed);

  // The largest prefilter: explicit orders F = 8, P = 4, the job's own check at its default 64
  // pairs (the brute-force reference of the map) and the largest face size (a multiple of 16)
  // whose cube fits the target.
  constexpr int kP = 4;
  const uint64_t checked = fixed + jobs::ReferenceBytes(kMapPixels);
  int face = 16;
  while (checked + jobs::ShrmCubeBytes(face + 16, kP) <= target) face += 16;
  v1::PrefilterRequest prefilter;
  prefilter.mutable_environment()->add_sha256(*sha);
  prefilter.set_brdf("microfacet:sigma=0.2");
  prefilter.mutable_orders()->set_f(8);
  prefilter.mutable_orders()->set_p(kP);
  prefilter.set_face_size(face);
  ASSERT_GT(checked + jobs::ShrmCubeBytes(face, kP), job_bytes_ / 2) << "two would fit together";

  // The largest IBL set: base size a power of two, with the sheen chain when it fits.
  jobs::IblJob ibl_job;
  ibl_job.face_size = 64;
  for (int s = 64; s <= 2048; s *= 2) {
    for (bool sheen : {false, true}) {
      jobs::IblJob j;
      j.face_size = s;
      j.sheen = sheen;
      if (fixed + jobs::IblOutputBytes(j) <= target) ibl_job = j;
    }
  }
  ASSERT_GT(fixed + jobs::IblOutputBytes(ibl_job), job_bytes_ / 2) << "two would fit together";
  v1::IblRequest ibl;
  ibl.mutable_environment()->add_sha256(*sha);
  ibl.set_face_size(ibl_job.face_size);
  ibl.set_sheen(ibl_job.sheen);

  v1::IrradianceRequest irradiance;
  irradiance.mutable_environment()->add_sha256(*sha);

  std::vector<std::thread> clients;
  std::vector<absl::Status> results(kClients * 3);
  for (int id = 0; id < kClients; ++id) {
    clients.emplace_back([&, id] {
      client::ClientOptions o;
      o.own_connection = true;
      absl::StatusOr<std::unique_ptr<client::ShrmClient>> c =
          client::ShrmClient::Connect(target_, o);
      if (!c.ok()) {
        results[id * 3] = c.status();
        return;
      }
      for (int k = 0; k < 3; ++k) {
        const int which = (id + k) % 3;
        absl::Status s;
        // Sent again after the server's delay while it says busy (slots or memory), as the
        // CLI's remote jobs do (client/remote_jobs.h).
        for (int attempt = 0; attempt < kAttempts; ++attempt) {
          if (which == 0) {
            s = (*c)->Prefilter(prefilter).status();
          } else if (which == 1) {
            s = (*c)->Ibl(ibl).status();
          } else {
            s = (*c)->Irradiance(irradiance).status();
          }
          const absl::Duration delay = client::ServerRetryDelay(s);
          if (delay <= absl::ZeroDuration()) break;
          absl::SleepFor(delay);
        }
        results[id * 3 + k] = s;
      }
    });
  }
  for (std::thread& t : clients) t.join();
  for (const absl::Status& s : results) EXPECT_TRUE(s.ok()) << s;

  // A cube that can never fit: refused for good, naming the need and the budget.
  v1::PrefilterRequest huge = prefilter;
  huge.set_face_size(512);
  huge.mutable_orders()->set_p(6);
  ASSERT_GT(jobs::ShrmCubeBytes(512, 6), job_bytes_);
  absl::StatusOr<client::PrefilterOutcome> refused = client_->Prefilter(huge);
  ASSERT_FALSE(refused.ok());
  EXPECT_TRUE(absl::IsInvalidArgument(refused.status())) << refused.status();
  EXPECT_EQ(wire::ErrorReason(refused.status()), wire::kReasonJobTooLarge);
  EXPECT_TRUE(absl::StrContains(refused.status().message(), "--memory-mib 1024"))
      << refused.status();

  // The measured peak of the daemon, against the budget.
  const uint64_t peak = PeakRssBytes(daemon_);
  EXPECT_GT(peak, 0u);
  EXPECT_LE(peak, uint64_t{kMemoryMib} * kMiB)
      << "peak RSS " << (peak >> 20) << " MiB; prefilter face " << face << ", ibl size "
      << ibl_job.face_size << (ibl_job.sheen ? " with sheen" : "");
  // How often admission held a job back (reported: whether two big jobs met depends on the
  // machine's timing; MemoryAdmissionInProcessTest checks the refusal by the order of events).
  int memory_busy = 0;
  for (const nlohmann::json& j : LogLines(log_)) {
    memory_busy += j.value("status", "") == "RESOURCE_EXHAUSTED" &&
                   absl::StrContains(j.value("message", ""), "MiB are free now");
  }
  std::printf(
      "memory admission: budget %d MiB, jobs %llu MiB, prefilter face %d, ibl size %d%s, peak RSS "
      "%llu MiB, %d refusals\n",
      kMemoryMib, static_cast<unsigned long long>(job_bytes_ >> 20), face, ibl_job.face_size,
      ibl_job.sheen ? " with sheen" : "", static_cast<unsigned long long>(peak >> 20), memory_busy);
}

}  // namespace
}  // namespace shrm
