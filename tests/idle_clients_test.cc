// Idle and slow clients (docs/server.md, "Idle and slow clients"): 1,000 uploads that send
// nothing and uploads that stall mid-stream do not stop the daemon serving others, and the idle
// timeout ends them (nothing kept); a client that stops reading its result has its call ended,
// which frees the job slot. In-process server on a loopback port.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/shrm_client.h"
#include "core/io/sha256.h"
#include "server/server.h"
#include "tests/small_job.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace v1 = ::shrm::v1;

// The idle timeout of the test server: short, since the test waits for it to end the stalled
// calls; long enough that the served calls (a few ms of transfer each) never come near it on a
// loaded machine.
constexpr absl::Duration kIdleTimeout = absl::Seconds(3);
// Safety net for a stalled call the server failed to end: far beyond the idle timeout, so only
// a server that never ends it reaches it (and the test then fails, not hangs).
constexpr auto kNeverEndedDeadline = std::chrono::seconds(120);
constexpr int kSilentUploads = 1000;
constexpr int kChannels = 10;  // the silent uploads spread over several connections
constexpr int kStalledMidStream = 10;
// A result far larger than the HTTP/2 flow-control window of the client that does not read it,
// so that it blocks the server's writes: an SHRM at face S holds 6 S^2 (P+1)^2 RGB floats.
constexpr int kLargeFaceSize = 256;  // 42 MB uncompressed, about 4.8 MB as written (compressed)
// The reading client's stream window (gRPC's default lookahead): 1/70 of the result.
constexpr int kClientWindowBytes = 64 * 1024;
constexpr absl::Duration kWaitPoll = absl::Milliseconds(100);
constexpr int kWaitPolls = 1200;  // 120 s

class IdleClientsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::UniqueTempPath("idle");
    server::ServerOptions opt;
    opt.listen = "127.0.0.1:0";
    opt.service.spool_dir = dir_ + "/spool";
    opt.service.max_jobs = 1;
    opt.service.idle_timeout = kIdleTimeout;
    absl::StatusOr<std::unique_ptr<server::ShrmServer>> s = server::ShrmServer::Start(opt);
    ASSERT_TRUE(s.ok()) << s.status();
    server_ = *std::move(s);
    target_ = absl::StrCat("127.0.0.1:", server_->port());
  }
  void TearDown() override {
    server_->Shutdown(absl::ZeroDuration());
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  std::unique_ptr<client::ShrmClient> Client() {
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c =
        client::ShrmClient::Connect(target_, {});
    EXPECT_TRUE(c.ok()) << c.status();
    return c.ok() ? *std::move(c) : nullptr;
  }
  int IncomingFiles() const { return testing::CountFiles(dir_ + "/spool/incoming"); }

  std::string dir_, target_;
  std::unique_ptr<server::ShrmServer> server_;
};

// An upload call held open by the test.
struct OpenUpload {
  std::unique_ptr<grpc::ClientContext> context;
  v1::UploadBlobResponse response;
  std::unique_ptr<grpc::ClientWriter<v1::UploadBlobChunk>> writer;
};

TEST_F(IdleClientsTest, SilentAndStalledUploadsDoNotStopServiceAndEndAtTheIdleTimeout) {
  std::vector<std::unique_ptr<v1::Shrm::Stub>> stubs;
  for (int i = 0; i < kChannels; ++i) {
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);  // one connection each
    stubs.push_back(v1::Shrm::NewStub(
        grpc::CreateCustomChannel(target_, grpc::InsecureChannelCredentials(), args)));
  }
  std::vector<OpenUpload> open(kSilentUploads + kStalledMidStream);
  for (size_t i = 0; i < open.size(); ++i) {
    OpenUpload& u = open[i];
    u.context = std::make_unique<grpc::ClientContext>();
    u.context->set_deadline(std::chrono::system_clock::now() + kNeverEndedDeadline);
    u.writer = stubs[i % kChannels]->UploadBlob(u.context.get(), &u.response);
    if (i >= kSilentUploads) {  // stalled mid-stream: the first chunk of a larger upload
      v1::UploadBlobChunk chunk;
      chunk.set_sha256(std::string(64, 'a'));
      chunk.set_total_size(1 << 20);
      chunk.set_data(std::string(1 << 10, 'x'));
      ASSERT_TRUE(u.writer->Write(chunk));
    }
  }

  // Served while they are open: an upload, a job, a lookup.
  std::unique_ptr<client::ShrmClient> c = Client();
  absl::StatusOr<std::string> sha =
      c->UploadIfMissing(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/courtyard.exr"));
  ASSERT_TRUE(sha.ok()) << sha.status();
  absl::StatusOr<client::PrefilterOutcome> job = c->Prefilter(testing::SmallPrefilterRequest(*sha));
  ASSERT_TRUE(job.ok()) << job.status();
  EXPECT_FALSE(job->shrm_file.empty());
  absl::StatusOr<v1::HasBlobResponse> has = c->HasBlob(*sha);
  ASSERT_TRUE(has.ok()) << has.status();
  EXPECT_TRUE(has->present());

  // The server ends every one of them (CANCELLED: the server cancelled the call), none runs
  // into the client's own deadline, and no partial upload is left.
  int ended_by_server = 0;
  for (OpenUpload& u : open) {
    const grpc::Status s = u.writer->Finish();
    ended_by_server += s.error_code() == grpc::StatusCode::CANCELLED;
  }
  EXPECT_EQ(ended_by_server, static_cast<int>(open.size()));
  EXPECT_EQ(server_->idle_calls_ended(), static_cast<int64_t>(open.size()));
  // A client sees CANCELLED as soon as the server cancels the call, before the handler thread
  // has returned and removed the partial upload: wait for the handlers (the bound is a safety
  // net, not a timing check), then nothing may be left.
  for (int i = 0; i < kWaitPolls && IncomingFiles() != 0; ++i) absl::SleepFor(kWaitPoll);
  EXPECT_EQ(IncomingFiles(), 0);
  // And it serves on.
  EXPECT_TRUE(c->HasBlob(*sha).ok());
}

// A client that starts a job with a large result and never reads it: the server's writes block
// on flow control until the idle timeout ends the call; the only job slot is then free again.
TEST_F(IdleClientsTest, ClientThatStopsReadingLosesItsCallAndFreesTheSlot) {
  std::unique_ptr<client::ShrmClient> c = Client();
  absl::StatusOr<std::string> sha =
      c->UploadIfMissing(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  ASSERT_TRUE(sha.ok()) << sha.status();

  // The receiver sets the flow-control windows: with gRPC's bandwidth-delay probe on (the
  // default), the client grows its window while the data flows fast and may take the whole
  // result into its buffers before the server ever blocks (what failed once under
  // ThreadSanitizer: the call ended OK). Without the probe the window stays at the lookahead.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, kClientWindowBytes);
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);  // its own connection, its own windows
  auto stub = v1::Shrm::NewStub(
      grpc::CreateCustomChannel(target_, grpc::InsecureChannelCredentials(), args));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kNeverEndedDeadline);
  std::unique_ptr<grpc::ClientReader<v1::PrefilterEvent>> reader =
      stub->Prefilter(&context, testing::SmallPrefilterRequest(*sha, kLargeFaceSize));
  // Read nothing: the server blocks in its writes. The only job slot stays taken meanwhile.
  v1::PrefilterEvent ev;
  int events = 0;
  bool saw_file_end = false;
  // Wait until the server has given up (the watchdog ended the call) before reading; the bound
  // is a safety net far beyond the idle timeout, not a timing check.
  for (int i = 0; i < kWaitPolls && server_->idle_calls_ended() == 0; ++i) {
    absl::SleepFor(kWaitPoll);
  }
  EXPECT_EQ(server_->idle_calls_ended(), 1);
  while (reader->Read(&ev)) {
    ++events;
    saw_file_end |= ev.has_shrm_file() && ev.shrm_file().last();
  }
  const grpc::Status s = reader->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::CANCELLED) << s.error_message();
  EXPECT_FALSE(saw_file_end);
  EXPECT_GT(events, 0);
  // The client has its status before the handler has returned and released the slot: wait for
  // it (safety-net bound, not a timing check).
  for (int i = 0; i < kWaitPolls && server_->running_jobs() != 0; ++i) absl::SleepFor(kWaitPoll);
  EXPECT_EQ(server_->running_jobs(), 0);
  // The slot is free again: the next job is admitted (max_jobs 1).
  absl::StatusOr<client::PrefilterOutcome> next =
      c->Prefilter(testing::SmallPrefilterRequest(*sha));
  EXPECT_TRUE(next.ok()) << next.status();
}

// The same for a live call (docs/live.md) whose client stops reading its frames: the frame's
// writes block, the idle timeout ends the call, and the slot it held is free again.
TEST_F(IdleClientsTest, LiveClientThatStopsReadingLosesItsCallAndFreesTheSlot) {
  std::unique_ptr<client::ShrmClient> c = Client();
  absl::StatusOr<std::string> sha =
      c->UploadIfMissing(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  ASSERT_TRUE(sha.ok()) << sha.status();
  grpc::ChannelArguments args;  // as above: a window that stays small
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, kClientWindowBytes);
  args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  auto stub = v1::Shrm::NewStub(
      grpc::CreateCustomChannel(target_, grpc::InsecureChannelCredentials(), args));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + kNeverEndedDeadline);
  auto stream = stub->Live(&context);
  v1::LiveRequest open, env, brdf;
  open.mutable_open()->set_face_size(kLargeFaceSize);
  env.mutable_environment()->add_sha256(*sha);
  brdf.set_brdf("microfacet:sigma=0.3");
  ASSERT_TRUE(stream->Write(open) && stream->Write(env) && stream->Write(brdf));
  // Read nothing, but keep sending (a rotation each poll, so only the watch on the frames'
  // writes can end the call); wait until the server has given up (safety-net bound, not a
  // timing check).
  v1::LiveRequest turn;
  for (int i = 0; i < kWaitPolls && server_->idle_calls_ended() == 0; ++i) {
    turn.mutable_rotation()->set_yaw_deg(i);
    if (!stream->Write(turn)) break;
    absl::SleepFor(kWaitPoll);
  }
  for (int i = 0; i < kWaitPolls && server_->idle_calls_ended() == 0; ++i) {
    absl::SleepFor(kWaitPoll);
  }
  EXPECT_EQ(server_->idle_calls_ended(), 1);
  v1::LiveEvent ev;
  while (stream->Read(&ev)) {
  }
  const grpc::Status s = stream->Finish();
  EXPECT_EQ(s.error_code(), grpc::StatusCode::CANCELLED) << s.error_message();
  for (int i = 0; i < kWaitPolls && server_->running_jobs() != 0; ++i) absl::SleepFor(kWaitPoll);
  EXPECT_EQ(server_->running_jobs(), 0);
  absl::StatusOr<client::PrefilterOutcome> next =
      c->Prefilter(testing::SmallPrefilterRequest(*sha));
  EXPECT_TRUE(next.ok()) << next.status();
}

}  // namespace
}  // namespace shrm
