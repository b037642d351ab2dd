#include "server/metrics.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "shrm/version.h"

namespace shrm::server {
namespace {

// How often the accept loop checks for shutdown.
constexpr int kPollIntervalMs = 100;
// A client gets this long to send its request line (a slow or idle peer cannot hold the thread).
constexpr int kReadTimeoutMs = 2000;
constexpr size_t kMaxRequestBytes = 8192;

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '\\' || c == '"') out.push_back('\\');
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out.push_back(c);
  }
  return out;
}

std::string Number(double v) { return absl::StrFormat("%.17g", v); }

void WriteAll(int fd, const std::string& data) {
  size_t off = 0;
  while (off < data.size()) {
    const ssize_t n = ::send(fd, data.data() + off, data.size() - off, MSG_NOSIGNAL);
    if (n <= 0) {
      if (n < 0 && errno == EINTR) continue;
      return;
    }
    off += static_cast<size_t>(n);
  }
}

// Reads until the end of the request headers (or a limit/timeout); returns what was read.
std::string ReadRequest(int fd) {
  std::string req;
  char buf[1024];
  while (req.size() < kMaxRequestBytes && req.find("\r\n\r\n") == std::string::npos &&
         req.find("\n\n") == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, kReadTimeoutMs) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n <= 0) break;
    req.append(buf, static_cast<size_t>(n));
  }
  return req;
}

std::string Response(const std::string& status, const std::string& type, const std::string& body) {
  return absl::StrCat("HTTP/1.0 ", status, "\r\nContent-Type: ", type,
                      "\r\nContent-Length: ", body.size(), "\r\nConnection: close\r\n\r\n", body);
}

}  // namespace

Metrics& Metrics::Global() {
  static Metrics* m = new Metrics();
  return *m;
}

uint64_t Metrics::RequestCount(const std::string& method, const std::string& code) const {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = requests_.find({method, code});
  return it == requests_.end() ? 0 : it->second;
}

void Metrics::RecordRequest(const std::string& method, const std::string& code, double seconds) {
  std::lock_guard<std::mutex> lock(mu_);
  ++requests_[{method, code}];
  Histogram& h = latency_[method];
  size_t i = 0;
  while (i < kLatencyBuckets.size() && seconds > kLatencyBuckets[i]) ++i;
  if (i < kLatencyBuckets.size()) ++h.buckets[i];
  ++h.count;
  h.sum += seconds;
}

void Metrics::RecordCache(const std::string& cache, bool hit) {
  std::lock_guard<std::mutex> lock(mu_);
  ++cache_[{cache, hit}];
}

void Metrics::RecordRejected(const std::string& reason) {
  std::lock_guard<std::mutex> lock(mu_);
  ++rejected_[reason];
}

void Metrics::RecordAbandoned(const std::string& reason, const std::string& stage) {
  std::lock_guard<std::mutex> lock(mu_);
  ++abandoned_[{reason, stage}];
}

uint64_t Metrics::AbandonedCount(const std::string& reason) const {
  std::lock_guard<std::mutex> lock(mu_);
  uint64_t n = 0;
  for (const auto& [k, v] : abandoned_) n += k.first == reason ? v : 0;
  return n;
}

std::string Metrics::Render() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::string out;
  absl::StrAppend(&out,
                  "# HELP shrm_build_info The version, git revision and conventions version of "
                  "this shrmd (docs/install.md).\n",
                  "# TYPE shrm_build_info gauge\n", "shrm_build_info{version=\"", Escape(kVersion),
                  "\",revision=\"", Escape(GitRevision()), "\",conventions=\"", kConventionsVersion,
                  "\"} 1\n");
  absl::StrAppend(&out, "# HELP shrm_requests_total Finished gRPC calls by method and code.\n",
                  "# TYPE shrm_requests_total counter\n");
  for (const auto& [k, v] : requests_) {
    absl::StrAppend(&out, "shrm_requests_total{method=\"", Escape(k.first), "\",code=\"",
                    Escape(k.second), "\"} ", v, "\n");
  }
  absl::StrAppend(&out, "# HELP shrm_request_duration_seconds Call latency by method.\n",
                  "# TYPE shrm_request_duration_seconds histogram\n");
  for (const auto& [method, h] : latency_) {
    const std::string m = Escape(method);
    uint64_t cumulative = 0;
    for (size_t i = 0; i < kLatencyBuckets.size(); ++i) {
      cumulative += h.buckets[i];
      absl::StrAppend(&out, "shrm_request_duration_seconds_bucket{method=\"", m, "\",le=\"",
                      Number(kLatencyBuckets[i]), "\"} ", cumulative, "\n");
    }
    absl::StrAppend(&out, "shrm_request_duration_seconds_bucket{method=\"", m, "\",le=\"+Inf\"} ",
                    h.count, "\n");
    absl::StrAppend(&out, "shrm_request_duration_seconds_sum{method=\"", m, "\"} ", Number(h.sum),
                    "\n");
    absl::StrAppend(&out, "shrm_request_duration_seconds_count{method=\"", m, "\"} ", h.count,
                    "\n");
  }
  absl::StrAppend(&out, "# HELP shrm_jobs_in_flight Prefilter/Analyze jobs holding a slot.\n",
                  "# TYPE shrm_jobs_in_flight gauge\n", "shrm_jobs_in_flight ",
                  jobs_in_flight_.load(), "\n");
  absl::StrAppend(&out, "# HELP shrm_cache_requests_total Cache lookups by cache and result.\n",
                  "# TYPE shrm_cache_requests_total counter\n");
  for (const auto& [k, v] : cache_) {
    absl::StrAppend(&out, "shrm_cache_requests_total{cache=\"", Escape(k.first), "\",result=\"",
                    k.second ? "hit" : "miss", "\"} ", v, "\n");
  }
  absl::StrAppend(&out, "# HELP shrm_rejected_total Refused requests and inputs by reason.\n",
                  "# TYPE shrm_rejected_total counter\n");
  for (const auto& [k, v] : rejected_) {
    absl::StrAppend(&out, "shrm_rejected_total{reason=\"", Escape(k), "\"} ", v, "\n");
  }
  absl::StrAppend(&out,
                  "# HELP shrm_jobs_abandoned_total Jobs stopped between stages (deadline passed "
                  "or client cancelled), by reason and the stage not started.\n",
                  "# TYPE shrm_jobs_abandoned_total counter\n");
  for (const auto& [k, v] : abandoned_) {
    absl::StrAppend(&out, "shrm_jobs_abandoned_total{reason=\"", Escape(k.first), "\",stage=\"",
                    Escape(k.second), "\"} ", v, "\n");
  }
  return out;
}

absl::StatusOr<std::unique_ptr<MetricsHttpServer>> MetricsHttpServer::Start(
    const std::string& address, int port) {
  std::unique_ptr<MetricsHttpServer> s(new MetricsHttpServer());
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  if (port < 0 || port > 65535 || ::inet_pton(AF_INET, address.c_str(), &addr.sin_addr) != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("--metrics-address/--metrics-port: bad address ", address, ":", port));
  }
  s->fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (s->fd_ < 0) return absl::UnavailableError("metrics: socket() failed");
  const int one = 1;
  ::setsockopt(s->fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  if (::bind(s->fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      ::listen(s->fd_, 16) != 0) {
    return absl::UnavailableError(
        absl::StrCat("metrics: cannot listen on ", address, ":", port, ": ", std::strerror(errno)));
  }
  socklen_t len = sizeof(addr);
  ::getsockname(s->fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  s->port_ = ntohs(addr.sin_port);
  s->thread_ = std::thread([p = s.get()] { p->Loop(); });
  return s;
}

MetricsHttpServer::~MetricsHttpServer() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (fd_ >= 0) ::close(fd_);
}

void MetricsHttpServer::Loop() {
  while (!stop_) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, kPollIntervalMs) <= 0) continue;
    const int c = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (c < 0) continue;
    const std::string req = ReadRequest(c);
    const size_t eol = req.find_first_of("\r\n");
    const std::string line = req.substr(0, eol);
    std::string resp;
    if (line.rfind("GET ", 0) != 0) {
      resp = Response("405 Method Not Allowed", "text/plain", "GET /metrics only\n");
    } else {
      const size_t sp = line.find(' ', 4);
      const std::string path = line.substr(4, sp == std::string::npos ? sp : sp - 4);
      if (path == "/metrics") {
        resp = Response("200 OK", "text/plain; version=0.0.4; charset=utf-8",
                        Metrics::Global().Render());
      } else {
        resp = Response("404 Not Found", "text/plain", "GET /metrics only\n");
      }
    }
    WriteAll(c, resp);
    ::close(c);
  }
}

}  // namespace shrm::server
