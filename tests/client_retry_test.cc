// The client's retries against a scripted server: a call that the server (or a proxy) dropped
// with CANCELLED before answering is sent again, as gRPC does to calls a server received but had
// not started when it shut down (the drain race of tests/deploy_test.sh); a CANCELLED the shrm
// server sent itself, or one after the caller's own cancel, is final.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "client/remote_jobs.h"
#include "client/shrm_client.h"
#include "proto/status_details.h"
#include "shrm/v1/shrm.grpc.pb.h"

namespace shrm {
namespace {

// Fails the first `drops` calls of each method with `drop`, then answers: HasBlob "present",
// Prefilter NOT_FOUND from the shrm server (final, so the test sees how many attempts were made).
class ScriptedServer final : public v1::Shrm::Service {
 public:
  ScriptedServer(int drops, grpc::Status drop) : drops_(drops), drop_(std::move(drop)) {}

  grpc::Status HasBlob(grpc::ServerContext*, const v1::HasBlobRequest*,
                       v1::HasBlobResponse* response) override {
    if (has_blob_calls_++ < drops_) return drop_;
    response->set_present(true);
    return grpc::Status::OK;
  }
  grpc::Status Prefilter(grpc::ServerContext*, const v1::PrefilterRequest*,
                         grpc::ServerWriter<v1::PrefilterEvent>*) override {
    if (prefilter_calls_++ < drops_) return drop_;
    return wire::ToGrpcStatus(absl::NotFoundError("scripted final answer"));
  }

  int has_blob_calls() const { return has_blob_calls_; }
  int prefilter_calls() const { return prefilter_calls_; }

 private:
  const int drops_;
  const grpc::Status drop_;
  std::atomic<int> has_blob_calls_{0};
  std::atomic<int> prefilter_calls_{0};
};

// Short backoffs: the test waits for retries, not for time.
client::ClientOptions FastRetries() {
  client::ClientOptions o;
  o.initial_backoff = absl::Milliseconds(1);
  o.max_backoff = absl::Milliseconds(2);
  return o;
}

class ClientRetryTest : public ::testing::Test {
 protected:
  void Serve(int drops, grpc::Status drop) {
    service_ = std::make_unique<ScriptedServer>(drops, std::move(drop));
    grpc::ServerBuilder b;
    int port = 0;
    b.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    b.RegisterService(service_.get());
    server_ = b.BuildAndStart();
    ASSERT_NE(server_, nullptr);
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c =
        client::ShrmClient::Connect(absl::StrCat("127.0.0.1:", port), FastRetries());
    ASSERT_TRUE(c.ok()) << c.status();
    client_ = *std::move(c);
  }
  void TearDown() override {
    if (server_) server_->Shutdown();
  }

  std::unique_ptr<ScriptedServer> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<client::ShrmClient> client_;
};

const grpc::Status kDropped(grpc::StatusCode::CANCELLED, "Cancelled");

TEST_F(ClientRetryTest, DroppedUnaryCallIsSentAgain) {
  Serve(2, kDropped);
  absl::StatusOr<v1::HasBlobResponse> r = client_->HasBlob(std::string(64, 'a'));
  ASSERT_TRUE(r.ok()) << r.status();
  EXPECT_TRUE(r->present());
  EXPECT_EQ(service_->has_blob_calls(), 3);
}

TEST_F(ClientRetryTest, DroppedStreamingCallIsSentAgain) {
  Serve(1, kDropped);
  absl::StatusOr<client::PrefilterOutcome> r = client_->Prefilter(v1::PrefilterRequest());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kNotFound) << r.status();
  EXPECT_EQ(service_->prefilter_calls(), 2);
  EXPECT_EQ(client_->resent_calls(), 1);
}

// A replica killed while a Prefilter call was on its way: the load balancer answers UNAVAILABLE
// with no shrm error details before any event, the client library sends the call again by itself,
// and the job's retries (the batch summary's "retries") count those calls (tests/deploy_test.sh
// checks that a broken Prefilter call shows in the summaries).
TEST_F(ClientRetryTest, CallsSentAgainCountAsTheJobsRetries) {
  Serve(2, grpc::Status(grpc::StatusCode::UNAVAILABLE, "upstream: 502"));
  int retries = -1;
  const absl::Status s = client::RunRemoteJob(
      client_.get(), jobs::EnvironmentSpec(), "scripted",
      [&] { return client_->Prefilter(v1::PrefilterRequest()).status(); }, nullptr, &retries);
  EXPECT_EQ(s.code(), absl::StatusCode::kNotFound) << s;  // the scripted final answer
  EXPECT_EQ(service_->prefilter_calls(), 3);
  EXPECT_EQ(retries, 2);
}

TEST_F(ClientRetryTest, ServersOwnCancelledIsFinal) {
  Serve(1, wire::ToGrpcStatus(absl::CancelledError("cancelled by the client")));
  EXPECT_EQ(client_->HasBlob(std::string(64, 'a')).status().code(), absl::StatusCode::kCancelled);
  EXPECT_EQ(service_->has_blob_calls(), 1);
  EXPECT_EQ(client_->Prefilter(v1::PrefilterRequest()).status().code(),
            absl::StatusCode::kCancelled);
  EXPECT_EQ(service_->prefilter_calls(), 1);
}

TEST_F(ClientRetryTest, NotSentAgainAfterTheCallersCancel) {
  Serve(1, kDropped);
  const std::atomic<bool> cancel{true};
  absl::StatusOr<client::PrefilterOutcome> r =
      client_->Prefilter(v1::PrefilterRequest(), {}, absl::InfiniteDuration(), &cancel);
  EXPECT_EQ(r.status().code(), absl::StatusCode::kCancelled) << r.status();
  EXPECT_EQ(service_->prefilter_calls(), 1);
}

}  // namespace
}  // namespace shrm
