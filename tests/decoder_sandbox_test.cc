// The query of death (docs/server.md): uploaded maps are decoded first in an isolated child
// process (server/decoder_sandbox.h). A file that crashes the decoder, hangs it or exhausts its
// memory costs that child only: the caller gets a final INVALID_ARGUMENT (reason DECODER_CRASHED)
// and the sandbox, the daemon and its other jobs go on. Clean files and the decoder's ordinary
// errors come back exactly as in-process decoding gives them (the reference: core's ProbeImage
// and ReadImageRgb called here, in this process).
#include "server/decoder_sandbox.h"

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/shrm_client.h"
#include "core/io/image.h"
#include "proto/status_details.h"
#include "server/server.h"
#include "tests/small_job.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace v1 = ::shrm::v1;
using server::DecodeLimits;
using server::DecoderSandbox;

// Time limit of the hanging decoder: short, since the test waits for it; the alarm ends it
// whatever the machine's load.
constexpr absl::Duration kHangTimeout = absl::Seconds(1);
// An address-space limit far below what decoding a 1024 x 512 map needs (the child's libraries
// alone map more): the child runs out of memory.
constexpr uint64_t kStarvedMemory = 32ull << 20;
constexpr int kConcurrentChecks = 8;

std::string RealMap(const char* name) {
  return absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/", name, ".exr");
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The sandbox must be forked while the process has one thread: a global environment sets it up
// before any test runs (gRPC starts its threads later, in the tests).
// (A failure there would make gtest skip the tests, which CTest counts as passed: the status is
// kept and each test fails on it instead.)
DecoderSandbox* g_sandbox = nullptr;
absl::Status g_start_status = absl::UnknownError("the test environment did not run");
class SandboxEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    absl::StatusOr<std::unique_ptr<DecoderSandbox>> s = DecoderSandbox::Start();
    g_start_status = s.status();
    if (!s.ok()) return;
    sandbox_ = *std::move(s);
    g_sandbox = sandbox_.get();
  }
  void TearDown() override {
    g_sandbox = nullptr;
    sandbox_.reset();
  }

 private:
  std::unique_ptr<DecoderSandbox> sandbox_;
};
::testing::Environment* const kEnvironment =
    ::testing::AddGlobalTestEnvironment(new SandboxEnvironment);

class DecoderSandboxTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(g_start_status.ok()) << g_start_status;
    ASSERT_NE(g_sandbox, nullptr);
    dir_ = testing::UniqueTempPath("sandbox");
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::string Write(const std::string& name, const std::string& bytes) {
    const std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  static DecodeLimits TestHooks() {
    DecodeLimits l;
    l.test_hooks = true;
    return l;
  }
  // What decoding `path` in this process answers.
  static absl::Status InProcess(const std::string& path) {
    absl::Status s = ProbeImage(path).status();
    if (s.ok()) s = ReadImageRgb(path, {}, NonFinitePolicy::kReplaceZero).status();
    return s;
  }
  std::string dir_;
};

bool Crashed(const absl::Status& s) {
  return s.code() == absl::StatusCode::kInvalidArgument &&
         wire::ErrorReason(s) == wire::kReasonDecoderCrashed;
}

TEST_F(DecoderSandboxTest, RealMapsDecodeCleanly) {
  for (const char* name : {"courtyard", "interior"}) {
    EXPECT_TRUE(g_sandbox->Check(RealMap(name), {}).ok()) << name;
  }
}

TEST_F(DecoderSandboxTest, DecoderErrorsAreThoseOfInProcessDecoding) {
  const std::string exr = ReadAll(RealMap("forest"));
  const std::vector<std::string> files = {
      Write("truncated.exr", exr.substr(0, exr.size() / 3)),
      Write("header_only.exr", exr.substr(0, 300)),
      Write("text.exr", "not an image at all\n"),
      Write("empty.exr", ""),
  };
  for (const std::string& f : files) {
    const absl::Status want = InProcess(f);
    ASSERT_FALSE(want.ok()) << f;
    const absl::Status got = g_sandbox->Check(f, {});
    EXPECT_EQ(got.code(), want.code()) << f << ": " << got;
    EXPECT_EQ(got.message(), want.message()) << f;
    EXPECT_FALSE(Crashed(got)) << f;
  }
}

TEST_F(DecoderSandboxTest, CrashCostsTheChildOnly) {
  const std::string poison = Write("poison.exr", std::string(server::kTestPoisonMagic) + "\n");
  const absl::Status s = g_sandbox->Check(poison, TestHooks());
  EXPECT_TRUE(Crashed(s)) << s;
  EXPECT_NE(s.message().find("SIGABRT"), std::string::npos) << s;
  EXPECT_NE(s.message().find(poison), std::string::npos) << s;
  // The sandbox goes on: the zygote is alive and the next check is clean.
  EXPECT_EQ(::kill(g_sandbox->zygote_pid(), 0), 0);
  EXPECT_TRUE(g_sandbox->Check(RealMap("city"), TestHooks()).ok());
  // Without the test hooks the same bytes are just not an image.
  const absl::Status plain = g_sandbox->Check(poison, {});
  EXPECT_FALSE(plain.ok());
  EXPECT_FALSE(Crashed(plain)) << plain;
}

TEST_F(DecoderSandboxTest, HangEndsAtTheTimeLimit) {
  const std::string hang = Write("hang.exr", std::string(server::kTestHangMagic) + "\n");
  DecodeLimits l = TestHooks();
  l.timeout = kHangTimeout;
  const absl::Status s = g_sandbox->Check(hang, l);
  EXPECT_TRUE(Crashed(s)) << s;
  EXPECT_NE(s.message().find("time limit of 1 s"), std::string::npos) << s;
}

TEST_F(DecoderSandboxTest, MemoryLimitEndsTheChildNotTheCaller) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizers reserve terabytes of address space: no RLIMIT_AS under them";
#endif
  DecodeLimits l;
  l.memory_bytes = kStarvedMemory;
  const absl::Status s = g_sandbox->Check(RealMap("courtyard"), l);
  EXPECT_FALSE(s.ok());
  EXPECT_TRUE(g_sandbox->Check(RealMap("courtyard"), {}).ok());
}

TEST_F(DecoderSandboxTest, ConcurrentChecksGetTheirOwnAnswers) {
  const std::string poison = Write("poison.exr", std::string(server::kTestPoisonMagic) + "\n");
  std::vector<std::future<absl::Status>> checks;
  for (int i = 0; i < kConcurrentChecks; ++i) {
    checks.push_back(std::async(std::launch::async, [&, i] {
      return g_sandbox->Check(i % 2 ? poison : RealMap("interior"), TestHooks());
    }));
  }
  for (int i = 0; i < kConcurrentChecks; ++i) {
    const absl::Status s = checks[i].get();
    if (i % 2) {
      EXPECT_TRUE(Crashed(s)) << i << ": " << s;
    } else {
      EXPECT_TRUE(s.ok()) << i << ": " << s;
    }
  }
}

// Through the service: the poisoned job fails with a final error naming the blob, is not sent
// again by the client, is refused from the quarantine the next time (no new child), and the
// daemon serves the next job.
TEST_F(DecoderSandboxTest, PoisonedJobGetsAFinalErrorAndTheDaemonServesOn) {
  server::ServerOptions opt;
  opt.listen = "127.0.0.1:0";
  opt.service.spool_dir = dir_ + "/spool";
  opt.service.max_jobs = 2;
  opt.service.decoder_sandbox = g_sandbox;
  opt.service.decode_limits.test_hooks = true;
  absl::StatusOr<std::unique_ptr<server::ShrmServer>> srv = server::ShrmServer::Start(opt);
  ASSERT_TRUE(srv.ok()) << srv.status();
  absl::StatusOr<std::unique_ptr<client::ShrmClient>> c =
      client::ShrmClient::Connect(absl::StrCat("127.0.0.1:", (*srv)->port()), {});
  ASSERT_TRUE(c.ok()) << c.status();

  auto request = [&](const std::string& path) -> absl::StatusOr<client::PrefilterOutcome> {
    absl::StatusOr<std::string> sha = (*c)->UploadIfMissing(path);
    if (!sha.ok()) return sha.status();
    return (*c)->Prefilter(testing::SmallPrefilterRequest(*sha));
  };
  const std::string poison = Write("poison.exr", std::string(server::kTestPoisonMagic) + "\n");
  const int64_t before = g_sandbox->checks();
  absl::StatusOr<client::PrefilterOutcome> bad = request(poison);
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(Crashed(bad.status())) << bad.status();
  EXPECT_TRUE(wire::FromShrmServer(bad.status()));
  EXPECT_FALSE(client::IsTransient(bad.status()));
  EXPECT_NE(bad.status().message().find("blob "), std::string::npos) << bad.status();
  EXPECT_EQ(bad.status().message().find(opt.service.spool_dir), std::string::npos);
  EXPECT_EQ(g_sandbox->checks(), before + 1);  // one attempt, one child

  absl::StatusOr<client::PrefilterOutcome> again = request(poison);
  EXPECT_TRUE(Crashed(again.status())) << again.status();
  EXPECT_EQ(g_sandbox->checks(), before + 1);  // refused from the quarantine

  absl::StatusOr<client::PrefilterOutcome> good = request(RealMap("courtyard"));
  ASSERT_TRUE(good.ok()) << good.status();
  EXPECT_FALSE(good->shrm_file.empty());
  EXPECT_EQ(g_sandbox->checks(), before + 2);
  // A clean blob is checked once: the second job decodes it in the daemon directly.
  ASSERT_TRUE(request(RealMap("courtyard")).ok());
  EXPECT_EQ(g_sandbox->checks(), before + 2);
  (*srv)->Shutdown(absl::ZeroDuration());
}

}  // namespace
}  // namespace shrm
