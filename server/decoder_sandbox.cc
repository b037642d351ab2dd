#include "server/decoder_sandbox.h"

#include <dirent.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "core/io/image.h"
#include "proto/status_details.h"

namespace shrm::server {
namespace {

// A check request (followed by the path) and the answers, as bytes on SOCK_SEQPACKET sockets.
struct RequestHeader {
  int32_t max_width;
  int32_t max_height;
  int64_t max_pixels;
  int64_t max_file_bytes;
  uint64_t memory_bytes;
  int64_t timeout_s;
  int32_t test_hooks;
  int32_t path_size;
};
enum ReplyKind : int32_t {
  kDecoderResult = 1,  // from the decoder: value = absl::StatusCode, then the message
  kDecoderEnded = 2,   // from the monitor: value = the decoder's wait status
};
struct ReplyHeader {
  int32_t kind;
  int32_t value;
};
constexpr size_t kMaxMessageBytes = 8192;
// Clean blobs remembered by a DecodeGuard (about 100 bytes each); beyond that the set starts
// again, which costs one more check per blob, never a wrong answer.
constexpr size_t kMaxRememberedBlobs = 1 << 16;
// AddressSanitizer and ThreadSanitizer reserve terabytes of address space for their shadow
// memory: no RLIMIT_AS can be applied under them.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kSanitizerShadow = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
constexpr bool kSanitizerShadow = true;
#else
constexpr bool kSanitizerShadow = false;
#endif
#else
constexpr bool kSanitizerShadow = false;
#endif
constexpr size_t kMaxReplyText = kMaxMessageBytes - sizeof(ReplyHeader);

void SendReply(int fd, ReplyKind kind, int32_t value, std::string_view text) {
  char buf[kMaxMessageBytes];
  const ReplyHeader h{kind, value};
  std::memcpy(buf, &h, sizeof h);
  const size_t n = std::min(text.size(), kMaxReplyText);
  std::memcpy(buf + sizeof h, text.data(), n);
  while (send(fd, buf, sizeof h + n, MSG_NOSIGNAL) < 0 && errno == EINTR) {
  }
}

// The decoding child: limits, the test hooks, then the same calls as in-process decoding.
[[noreturn]] void DecoderMain(const RequestHeader& h, const std::string& path, int fd) {
  prctl(PR_SET_DUMPABLE, 0);  // no core dumps of crashes the sandbox is there to contain
  const rlimit no_core{0, 0};
  setrlimit(RLIMIT_CORE, &no_core);
  if (!kSanitizerShadow) {  // the sanitizers' shadow memory alone reserves terabytes of address
                            // space
    const rlimit as{h.memory_bytes, h.memory_bytes};
    setrlimit(RLIMIT_AS, &as);
  }
  const rlim_t seconds = static_cast<rlim_t>(std::max<int64_t>(1, h.timeout_s));
  const rlimit cpu{seconds, seconds + 1};
  setrlimit(RLIMIT_CPU, &cpu);
  signal(SIGALRM, SIG_DFL);
  alarm(static_cast<unsigned>(seconds));
  if (h.test_hooks != 0) {
    char head[32] = {};
    std::ifstream(path, std::ios::binary).read(head, sizeof head - 1);
    if (std::string_view(head).starts_with(kTestPoisonMagic)) std::abort();
    if (std::string_view(head).starts_with(kTestHangMagic)) {
      for (;;) pause();
    }
  }
  ImageLimits limits;
  limits.max_width = h.max_width;
  limits.max_height = h.max_height;
  limits.max_pixels = h.max_pixels;
  limits.max_file_bytes = h.max_file_bytes;
  absl::Status s = ProbeImage(path, limits).status();
  // Non-finite pixels are the daemon's to judge (its policy); the check is about the decoder.
  if (s.ok()) s = ReadImageRgb(path, limits, NonFinitePolicy::kReplaceZero).status();
  SendReply(fd, kDecoderResult, static_cast<int32_t>(s.code()), std::string(s.message()));
  _exit(0);
}

// Between the zygote and a decoder: forks the decoder, waits for it, says how it ended.
[[noreturn]] void MonitorMain(const RequestHeader& h, const std::string& path, int fd) {
  const pid_t child = fork();
  if (child == 0) DecoderMain(h, path, fd);
  if (child < 0) _exit(0);  // the parent sees the socket close without an answer
  int status = 0;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  SendReply(fd, kDecoderEnded, status, "");
  _exit(0);
}

// Receives one request and the socket to answer on.
ssize_t ReceiveRequest(int control, char* buf, size_t size, int* fd) {
  *fd = -1;
  iovec iov{buf, size};
  alignas(cmsghdr) char control_buf[CMSG_SPACE(sizeof(int))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control_buf;
  msg.msg_controllen = sizeof control_buf;
  const ssize_t n = recvmsg(control, &msg, 0);
  if (n > 0) {
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_RIGHTS) {
        std::memcpy(fd, CMSG_DATA(c), sizeof(int));
      }
    }
  }
  return n;
}

[[noreturn]] void ZygoteMain(int control, pid_t daemon) {
  prctl(PR_SET_NAME, "shrmd-decoder");
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != daemon) _exit(0);  // the daemon died before the line above
  // The daemon decides when to stop: it closes the control socket (or dies).
  signal(SIGTERM, SIG_IGN);
  signal(SIGINT, SIG_IGN);
  signal(SIGPIPE, SIG_IGN);
  signal(SIGCHLD, SIG_IGN);  // monitors are reaped by the kernel
  char buf[kMaxMessageBytes];
  for (;;) {
    int fd = -1;
    const ssize_t n = ReceiveRequest(control, buf, sizeof buf, &fd);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) _exit(0);
    RequestHeader h;
    const bool well_formed = static_cast<size_t>(n) >= sizeof h &&
                             (std::memcpy(&h, buf, sizeof h), h.path_size >= 0) &&
                             static_cast<size_t>(n) == sizeof h + static_cast<size_t>(h.path_size);
    if (fd >= 0 && well_formed) {
      const std::string path(buf + sizeof h, static_cast<size_t>(h.path_size));
      const pid_t monitor = fork();
      if (monitor == 0) {
        close(control);
        signal(SIGCHLD, SIG_DFL);  // the monitor waits for its decoder
        MonitorMain(h, path, fd);
      }
    }
    if (fd >= 0) close(fd);
  }
}

int CountThreads() {
  int n = 0;
  if (DIR* d = opendir("/proc/self/task")) {
    while (dirent* e = readdir(d)) n += e->d_name[0] != '.';
    closedir(d);
  }
  return n;
}

// Threads that shared libraries started from their static initializers, before main() (Debian's
// OpenImageIO pulls in log4cplus, whose thread pool starts at load time and waits on a condition
// variable, holding no lock). The executable's initializers run after the libraries'.
const int kThreadsAtStartup = CountThreads();

std::string SignalName(int sig) {
  const char* abbrev = sigabbrev_np(sig);
  return abbrev != nullptr ? absl::StrCat("SIG", abbrev) : absl::StrCat("signal ", sig);
}

// Why the decoder ended without an answer, from its wait status.
std::string HowItEnded(int status, const DecodeLimits& limits) {
  const int64_t seconds = absl::ToInt64Seconds(limits.timeout);
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGALRM || sig == SIGXCPU) {
      return absl::StrCat("the image decoder ran past its time limit of ", seconds, " s");
    }
    return absl::StrCat("the image decoder crashed (", SignalName(sig), "; its memory limit is ",
                        limits.memory_bytes >> 20, " MiB)");
  }
  if (WIFEXITED(status)) {
    return absl::StrCat("the image decoder exited with code ", WEXITSTATUS(status));
  }
  return absl::StrCat("the image decoder ended with wait status ", status);
}

}  // namespace

absl::StatusOr<std::unique_ptr<DecoderSandbox>> DecoderSandbox::Start() {
  if (const int threads = CountThreads(); threads != kThreadsAtStartup) {
    return absl::FailedPreconditionError(
        absl::StrCat("decoder sandbox: must start before the program starts threads (it has ",
                     threads, ", the libraries started ", kThreadsAtStartup, " before main)"));
  }
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) {
    return absl::InternalError(absl::StrCat("decoder sandbox: socketpair: ", strerror(errno)));
  }
  const pid_t daemon = getpid();
  const pid_t zygote = fork();
  if (zygote < 0) {
    close(sv[0]);
    close(sv[1]);
    return absl::InternalError(absl::StrCat("decoder sandbox: fork: ", strerror(errno)));
  }
  if (zygote == 0) {
    close(sv[0]);
    ZygoteMain(sv[1], daemon);
  }
  close(sv[1]);
  return std::unique_ptr<DecoderSandbox>(new DecoderSandbox(sv[0], zygote));
}

DecoderSandbox::~DecoderSandbox() {
  close(control_);
  while (waitpid(zygote_, nullptr, 0) < 0 && errno == EINTR) {
  }
}

absl::Status DecoderSandbox::Check(const std::string& path, const DecodeLimits& limits) {
  ++checks_;
  const RequestHeader h{
      limits.image.max_width,    limits.image.max_height,
      limits.image.max_pixels,   limits.image.max_file_bytes,
      limits.memory_bytes,       std::max<int64_t>(1, absl::ToInt64Seconds(limits.timeout)),
      limits.test_hooks ? 1 : 0, static_cast<int32_t>(path.size())};
  if (sizeof h + path.size() > kMaxMessageBytes) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": path too long for the decoder"));
  }
  std::string request(reinterpret_cast<const char*>(&h), sizeof h);
  request += path;
  int sv[2];
  if (socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv) != 0) {
    return absl::InternalError(absl::StrCat("decoder sandbox: socketpair: ", strerror(errno)));
  }
  iovec iov{request.data(), request.size()};
  alignas(cmsghdr) char control_buf[CMSG_SPACE(sizeof(int))] = {};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control_buf;
  msg.msg_controllen = sizeof control_buf;
  cmsghdr* c = CMSG_FIRSTHDR(&msg);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SCM_RIGHTS;
  c->cmsg_len = CMSG_LEN(sizeof(int));
  std::memcpy(CMSG_DATA(c), &sv[1], sizeof(int));
  ssize_t sent;
  while ((sent = sendmsg(control_, &msg, MSG_NOSIGNAL)) < 0 && errno == EINTR) {
  }
  close(sv[1]);
  if (sent < 0) {
    close(sv[0]);
    return absl::InternalError(
        absl::StrCat("decoder sandbox: the decoder process is gone (", strerror(errno), ")"));
  }
  std::optional<absl::Status> result;
  std::optional<int> ended;
  char buf[kMaxMessageBytes];
  while (!ended) {
    const ssize_t n = recv(sv[0], buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < static_cast<ssize_t>(sizeof(ReplyHeader))) break;
    ReplyHeader r;
    std::memcpy(&r, buf, sizeof r);
    if (r.kind == kDecoderResult) {
      result = absl::Status(static_cast<absl::StatusCode>(r.value),
                            absl::string_view(buf + sizeof r, n - sizeof r));
    } else if (r.kind == kDecoderEnded) {
      ended = r.value;
    }
  }
  close(sv[0]);
  if (!ended) {
    return absl::InternalError("decoder sandbox: the decoding process ended without an answer");
  }
  if (WIFEXITED(*ended) && WEXITSTATUS(*ended) == 0 && result) return *result;
  return wire::WithErrorReason(
      absl::InvalidArgumentError(absl::StrCat(
          path, ": ", HowItEnded(*ended, limits),
          "; the file was decoded in an isolated process, so only that process was lost; the "
          "input is refused")),
      wire::kReasonDecoderCrashed);
}

absl::Status DecodeGuard::Vet(const std::string& sha256, const std::string& path,
                              const ImageLimits& image) {
  if (sandbox_ == nullptr) return absl::OkStatus();
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (clean_.contains(sha256)) return absl::OkStatus();
    if (auto it = refused_.find(sha256); it != refused_.end()) return it->second;
  }
  DecodeLimits limits = limits_;
  limits.image = image;
  absl::Status s = sandbox_->Check(path, limits);
  if (wire::ErrorReason(s) == wire::kReasonDecoderCrashed) {
    s = wire::WithErrorReason(absl::InvalidArgumentError(s.message()), wire::kReasonDecoderCrashed,
                              "sha256", sha256);
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (s.ok()) {
    if (clean_.size() >= kMaxRememberedBlobs) clean_.clear();  // checked again when used again
    clean_.insert(sha256);
  } else if (wire::ErrorReason(s) == wire::kReasonDecoderCrashed) {
    refused_.emplace(sha256, s);
  }
  return s;
}

}  // namespace shrm::server
