// Operational tests of shrmd (docs/server.md, "Security" and "Operations"): bearer tokens over
// local credentials, TLS and mutual TLS with certificates generated here by the `openssl` CLI,
// gRPC health names, and graceful shutdown with a job in flight. In-process servers on ephemeral
// loopback ports.
#include <arpa/inet.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/shrm_client.h"
#include "server/auth.h"
#include "server/server.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

namespace v1 = ::shrm::v1;
using client::ClientOptions;
using client::ShrmClient;
using server::ServerOptions;
using server::ShrmServer;

constexpr char kToken[] = "s3cr3t-token-for-tests";
constexpr char kOtherToken[] = "second-valid-token";
// A refused connection (bad TLS peer) is retried by the client; one attempt keeps it short.
constexpr int kNoRetries = 1;
// Deadline of calls expected to fail at the transport (handshake refused): long enough for a
// loopback TLS handshake on a loaded 2-core machine, short enough to keep the test quick.
constexpr absl::Duration kFailingCallTimeout = absl::Seconds(5);
// Deadline of a health check over loopback (a trivial call; generous for a loaded machine).
constexpr auto kHealthTimeout = std::chrono::seconds(10);
// Slow job for the shutdown test: 6 stages x 200 ms = ~1.2 s, well inside the grace period.
constexpr absl::Duration kSlowStage = absl::Milliseconds(200);
// Grace period for the shutdown test: far longer than the slow job, so it must complete.
constexpr absl::Duration kGrace = absl::Seconds(20);
// Wait for the slow job to report its first progress event before shutting down.
constexpr auto kJobStartTimeout = std::chrono::seconds(20);
// Wait for the metrics endpoint's answer over loopback (a loaded 2-core machine can be slow).
constexpr int kMetricsReadTimeoutMs = 10000;
constexpr int kTestF = 8;
constexpr int kTestP = 2;
constexpr int kTestFaceSize = 32;

void WriteFile(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// Sends `request` to 127.0.0.1:port and returns the whole answer ("" on a socket error).
std::string HttpExchange(int port, const std::string& request) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return "";
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  ::inet_pton(AF_INET, "127.0.0.1", &addr.sin_addr);
  std::string out;
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
      ::send(fd, request.data(), request.size(), MSG_NOSIGNAL) ==
          static_cast<ssize_t>(request.size())) {
    char buf[4096];
    for (;;) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, kMetricsReadTimeoutMs) <= 0) break;
      const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
      if (n <= 0) break;
      out.append(buf, static_cast<size_t>(n));
    }
  }
  ::close(fd);
  return out;
}

class ServiceOpsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::UniqueTempPath("ops");
    std::filesystem::create_directories(dir_);
    token_file_ = dir_ + "/tokens";
    WriteFile(token_file_, absl::StrCat("# test tokens\n", kToken, "\n\n  ", kOtherToken, "  \n"));
  }
  void TearDown() override {
    servers_.clear();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  absl::StatusOr<ShrmServer*> Start(ServerOptions opt) {
    opt.listen = "127.0.0.1:0";
    opt.service.spool_dir = dir_ + "/spool" + std::to_string(servers_.size());
    if (opt.service.max_jobs < 1) opt.service.max_jobs = 2;
    absl::StatusOr<std::unique_ptr<ShrmServer>> s = ShrmServer::Start(opt);
    if (!s.ok()) return s.status();
    servers_.push_back(std::move(*s));
    return servers_.back().get();
  }

  std::unique_ptr<ShrmClient> Connect(int port, ClientOptions opt) {
    absl::StatusOr<std::unique_ptr<ShrmClient>> c =
        ShrmClient::Connect(absl::StrCat("127.0.0.1:", port), opt);
    EXPECT_TRUE(c.ok()) << c.status();
    return c.ok() ? std::move(*c) : nullptr;
  }

  // Runs `openssl` to make a CA, a server certificate for 127.0.0.1/localhost and a client
  // certificate, both signed by the CA. False when the openssl CLI fails.
  bool MakeCertificates() {
    WriteFile(dir_ + "/server.ext", "subjectAltName=DNS:localhost,IP:127.0.0.1\n");
    WriteFile(dir_ + "/client.ext", "extendedKeyUsage=clientAuth\n");
    const std::string d = dir_;
    const std::string key = "-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
    const std::vector<std::string> commands = {
        absl::StrCat("openssl req -x509 ", key, " -days 2 -subj /CN=shrm-test-ca -keyout ", d,
                     "/ca.key -out ", d, "/ca.pem"),
        absl::StrCat("openssl req ", key, " -subj /CN=localhost -keyout ", d, "/server.key -out ",
                     d, "/server.csr"),
        absl::StrCat("openssl x509 -req -in ", d, "/server.csr -CA ", d, "/ca.pem -CAkey ", d,
                     "/ca.key -CAcreateserial -days 2 -extfile ", d, "/server.ext -out ", d,
                     "/server.pem"),
        absl::StrCat("openssl req ", key, " -subj /CN=shrm-test-client -keyout ", d,
                     "/client.key -out ", d, "/client.csr"),
        absl::StrCat("openssl x509 -req -in ", d, "/client.csr -CA ", d, "/ca.pem -CAkey ", d,
                     "/ca.key -CAcreateserial -days 2 -extfile ", d, "/client.ext -out ", d,
                     "/client.pem"),
    };
    for (const std::string& c : commands) {
      if (std::system((c + " >/dev/null 2>&1").c_str()) != 0) {
        ADD_FAILURE() << "failed: " << c;
        return false;
      }
    }
    return true;
  }

  // grpc.health.v1.Health/Check through a generic stub (no health.proto header in Debian 12):
  // the request is field 1 (service name); the answer's field 1 is the status (1 = SERVING).
  static int HealthStatus(const std::shared_ptr<grpc::Channel>& channel,
                          const std::string& service) {
    std::string req = "\x0a";
    req.push_back(static_cast<char>(service.size()));
    req += service;
    grpc::Slice slice(req);
    grpc::ByteBuffer request(&slice, 1);
    grpc::GenericStub stub(channel);
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + kHealthTimeout);
    grpc::CompletionQueue cq;
    auto call = stub.PrepareUnaryCall(&context, "/grpc.health.v1.Health/Check", request, &cq);
    call->StartCall();
    grpc::ByteBuffer response;
    grpc::Status status;
    call->Finish(&response, &status, reinterpret_cast<void*>(1));
    void* tag = nullptr;
    bool ok = false;
    EXPECT_TRUE(cq.Next(&tag, &ok));
    cq.Shutdown();
    while (cq.Next(&tag, &ok)) {
    }
    if (!status.ok()) return -static_cast<int>(status.error_code());
    std::vector<grpc::Slice> slices;
    EXPECT_TRUE(response.Dump(&slices).ok());
    std::string bytes;
    for (const grpc::Slice& s : slices) bytes.append(s.begin(), s.end());
    if (bytes.empty()) return 0;  // UNKNOWN (a default enum is not serialized)
    EXPECT_EQ(bytes.size(), 2u);
    EXPECT_EQ(bytes[0], '\x08');
    return bytes.size() == 2 ? bytes[1] : -1;
  }

  std::string dir_;
  std::string token_file_;
  std::vector<std::unique_ptr<ShrmServer>> servers_;
};

TEST(AuthTest, ConstantTimeEquals) {
  EXPECT_TRUE(server::ConstantTimeEquals("abc", "abc"));
  EXPECT_TRUE(server::ConstantTimeEquals("", ""));
  EXPECT_FALSE(server::ConstantTimeEquals("abc", "abd"));
  EXPECT_FALSE(server::ConstantTimeEquals("abc", "abcd"));
  EXPECT_FALSE(server::ConstantTimeEquals("abc", ""));
}

TEST(AuthTest, LoopbackAddresses) {
  EXPECT_TRUE(server::IsLoopbackAddress("127.0.0.1:0"));
  EXPECT_TRUE(server::IsLoopbackAddress("[::1]:50051"));
  EXPECT_TRUE(server::IsLoopbackAddress("localhost:50051"));
  EXPECT_FALSE(server::IsLoopbackAddress("[::]:50051"));
  EXPECT_FALSE(server::IsLoopbackAddress("0.0.0.0:50051"));
  EXPECT_FALSE(server::IsLoopbackAddress("10.1.2.3:50051"));
}

TEST_F(ServiceOpsTest, TokenFileIsParsed) {
  absl::StatusOr<std::vector<std::string>> t = server::ReadTokenFile(token_file_);
  ASSERT_TRUE(t.ok()) << t.status();
  EXPECT_EQ(*t, (std::vector<std::string>{kToken, kOtherToken}));
  WriteFile(dir_ + "/empty", "# nothing\n\n");
  EXPECT_FALSE(server::ReadTokenFile(dir_ + "/empty").ok());
}

TEST_F(ServiceOpsTest, BearerTokenIsRequired) {
  ServerOptions opt;
  opt.security.token_file = token_file_;
  absl::StatusOr<ShrmServer*> s = Start(opt);
  ASSERT_TRUE(s.ok()) << s.status();
  const int port = (*s)->port();

  for (const char* token : {kToken, kOtherToken}) {
    ClientOptions good;
    good.token = token;
    auto c = Connect(port, good);
    ASSERT_NE(c, nullptr);
    absl::StatusOr<v1::ListBrdfModelsResponse> r = c->ListBrdfModels();
    EXPECT_TRUE(r.ok()) << r.status();
  }
  ClientOptions from_file;
  from_file.token_file = token_file_;
  EXPECT_TRUE(Connect(port, from_file)->ListBrdfModels().ok());

  ClientOptions wrong;
  wrong.token = "s3cr3t-token-for-test";  // a prefix of the real one
  absl::StatusOr<v1::ListBrdfModelsResponse> r = Connect(port, wrong)->ListBrdfModels();
  EXPECT_EQ(r.status().code(), absl::StatusCode::kUnauthenticated) << r.status();
  // The token must never come back in an error message.
  EXPECT_EQ(r.status().message().find(kToken), std::string::npos);

  // No token at all, over local credentials (the transport the server expects).
  auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", port),
                                     grpc::experimental::LocalCredentials(LOCAL_TCP));
  auto stub = v1::Shrm::NewStub(channel);
  grpc::ClientContext context;
  v1::ListBrdfModelsRequest req;
  v1::ListBrdfModelsResponse resp;
  EXPECT_EQ(stub->ListBrdfModels(&context, req, &resp).error_code(),
            grpc::StatusCode::UNAUTHENTICATED);

  // Health probes need no token.
  EXPECT_EQ(HealthStatus(channel, server::kReadinessService), 1);
}

TEST_F(ServiceOpsTest, TokensWithoutTlsRefuseNonLoopbackListen) {
  ServerOptions opt;
  opt.security.token_file = token_file_;
  opt.listen = "0.0.0.0:0";
  opt.service.spool_dir = dir_ + "/spool";
  absl::StatusOr<std::unique_ptr<ShrmServer>> s = ShrmServer::Start(opt);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(s.status().message().find("loopback"), std::string::npos) << s.status();
}

TEST_F(ServiceOpsTest, TlsAndMutualTls) {
  ASSERT_TRUE(MakeCertificates());
  ServerOptions tls;
  tls.security.tls_cert_file = dir_ + "/server.pem";
  tls.security.tls_key_file = dir_ + "/server.key";
  tls.security.token_file = token_file_;
  absl::StatusOr<ShrmServer*> s = Start(tls);
  ASSERT_TRUE(s.ok()) << s.status();
  ClientOptions c;
  c.tls_ca_file = dir_ + "/ca.pem";
  c.token = kToken;
  EXPECT_TRUE(Connect((*s)->port(), c)->ListBrdfModels().ok());
  c.token = "wrong";
  EXPECT_EQ(Connect((*s)->port(), c)->ListBrdfModels().status().code(),
            absl::StatusCode::kUnauthenticated);

  ServerOptions mtls;
  mtls.security.tls_cert_file = dir_ + "/server.pem";
  mtls.security.tls_key_file = dir_ + "/server.key";
  mtls.security.tls_client_ca = dir_ + "/ca.pem";
  absl::StatusOr<ShrmServer*> m = Start(mtls);
  ASSERT_TRUE(m.ok()) << m.status();
  ClientOptions no_cert;
  no_cert.tls_ca_file = dir_ + "/ca.pem";
  no_cert.max_attempts = kNoRetries;
  no_cert.call_timeout = kFailingCallTimeout;
  EXPECT_FALSE(Connect((*m)->port(), no_cert)->ListBrdfModels().ok());
  ClientOptions with_cert = no_cert;
  with_cert.tls_cert_file = dir_ + "/client.pem";
  with_cert.tls_key_file = dir_ + "/client.key";
  EXPECT_TRUE(Connect((*m)->port(), with_cert)->ListBrdfModels().ok());
}

TEST_F(ServiceOpsTest, HealthNamesServe) {
  absl::StatusOr<ShrmServer*> s = Start({});
  ASSERT_TRUE(s.ok()) << s.status();
  auto channel = grpc::CreateChannel(absl::StrCat("127.0.0.1:", (*s)->port()),
                                     grpc::InsecureChannelCredentials());
  EXPECT_EQ(HealthStatus(channel, server::kLivenessService), 1);
  EXPECT_EQ(HealthStatus(channel, server::kReadinessService), 1);
  EXPECT_EQ(HealthStatus(channel, ""), 1);
  EXPECT_EQ(HealthStatus(channel, "no.such.service"), -static_cast<int>(grpc::NOT_FOUND));
}

TEST_F(ServiceOpsTest, GracefulShutdownFinishesJobInFlight) {
  ServerOptions opt;
  opt.service.test_stage_delay = kSlowStage;
  absl::StatusOr<ShrmServer*> s = Start(opt);
  ASSERT_TRUE(s.ok()) << s.status();
  auto c = Connect((*s)->port(), {});
  absl::StatusOr<std::string> sha =
      c->UploadIfMissing(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  ASSERT_TRUE(sha.ok()) << sha.status();
  v1::PrefilterRequest req;
  req.mutable_environment()->add_sha256(*sha);
  req.set_brdf("phong:s=32");
  req.mutable_orders()->set_f(kTestF);
  req.mutable_orders()->set_p(kTestP);
  req.set_face_size(kTestFaceSize);

  std::promise<void> started;
  std::once_flag once;
  std::future<absl::StatusOr<client::PrefilterOutcome>> job = std::async(std::launch::async, [&] {
    return c->Prefilter(req, [&](const v1::PrefilterProgress&) {
      std::call_once(once, [&] { started.set_value(); });
    });
  });
  ASSERT_EQ(started.get_future().wait_for(kJobStartTimeout), std::future_status::ready);
  // What shrmd's SIGTERM handler does.
  const auto t0 = std::chrono::steady_clock::now();
  (*s)->Shutdown(kGrace);
  (*s)->Wait();
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_LT(took, absl::ToChronoSeconds(kGrace));
  absl::StatusOr<client::PrefilterOutcome> outcome = job.get();
  ASSERT_TRUE(outcome.ok()) << outcome.status();
  EXPECT_FALSE(outcome->shrm_file.empty());
}

TEST_F(ServiceOpsTest, MetricsOverHttp) {
  ServerOptions opt;
  opt.metrics_port = 0;
  absl::StatusOr<ShrmServer*> s = Start(opt);
  ASSERT_TRUE(s.ok()) << s.status();
  ASSERT_GT((*s)->metrics_port(), 0);
  auto c = Connect((*s)->port(), {});
  ASSERT_TRUE(c->ListBrdfModels().ok());
  EXPECT_EQ(c->HasBlob("not-a-hash").status().code(), absl::StatusCode::kInvalidArgument);
  absl::StatusOr<std::string> sha =
      c->UploadIfMissing(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  ASSERT_TRUE(sha.ok()) << sha.status();
  v1::PrefilterRequest req;
  req.mutable_environment()->add_sha256(*sha);
  req.set_brdf("phong:s=32");
  req.mutable_orders()->set_f(kTestF);
  req.mutable_orders()->set_p(kTestP);
  req.set_face_size(kTestFaceSize);
  ASSERT_TRUE(c->Prefilter(req).ok());

  const std::string answer =
      HttpExchange((*s)->metrics_port(), "GET /metrics HTTP/1.0\r\nHost: x\r\n\r\n");
  EXPECT_EQ(answer.rfind("HTTP/1.0 200 OK\r\n", 0), 0u) << answer;
  EXPECT_NE(answer.find("text/plain; version=0.0.4"), std::string::npos);
  for (const char* line : {
           "shrm_requests_total{method=\"ListBrdfModels\",code=\"OK\"} ",
           "shrm_requests_total{method=\"HasBlob\",code=\"INVALID_ARGUMENT\"} ",
           "shrm_request_duration_seconds_bucket{method=\"Prefilter\",le=\"+Inf\"} ",
           "shrm_request_duration_seconds_count{method=\"Prefilter\"} ",
           "shrm_jobs_in_flight 0",
           "shrm_cache_requests_total{cache=\"lighting\",result=\"miss\"} ",
           "shrm_cache_requests_total{cache=\"brdf\",result=\"miss\"} ",
           "shrm_rejected_total{reason=\"invalid_argument\"} ",
       }) {
    EXPECT_NE(answer.find(line), std::string::npos) << line << "\n" << answer;
  }
  EXPECT_EQ(
      HttpExchange((*s)->metrics_port(), "GET /other HTTP/1.0\r\n\r\n").rfind("HTTP/1.0 404", 0),
      0u);
  EXPECT_EQ(
      HttpExchange((*s)->metrics_port(), "POST /metrics HTTP/1.0\r\n\r\n").rfind("HTTP/1.0 405", 0),
      0u);
}

}  // namespace
}  // namespace shrm
