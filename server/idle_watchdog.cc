#include "server/idle_watchdog.h"

#include <algorithm>
#include <chrono>

namespace shrm::server {
namespace {

int64_t NowNs() { return absl::GetCurrentTimeNanos(); }

// How often the watchdog looks: a quarter of the timeout, at most a second (so a call ends
// between 1x and 1.25x the timeout after its last progress).
constexpr absl::Duration kMaxScanPeriod = absl::Seconds(1);

}  // namespace

IdleWatchdog::Call::Call(IdleWatchdog* dog, grpc::ServerContext* context)
    : dog_(dog), context_(context), last_ns_(NowNs()) {}

IdleWatchdog::Call::~Call() {
  if (dog_ == nullptr) return;
  std::lock_guard<std::mutex> lock(dog_->mu_);
  dog_->calls_.erase(self_);
}

void IdleWatchdog::Call::Progress() { last_ns_.store(NowNs(), std::memory_order_relaxed); }

IdleWatchdog::IdleWatchdog(absl::Duration timeout) : timeout_(timeout) {
  if (timeout_ > absl::ZeroDuration()) thread_ = std::thread([this] { Loop(); });
}

IdleWatchdog::~IdleWatchdog() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    stop_ = true;
  }
  stopped_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::unique_ptr<IdleWatchdog::Call> IdleWatchdog::Watch(grpc::ServerContext* context) {
  if (timeout_ <= absl::ZeroDuration()) return std::unique_ptr<Call>(new Call(nullptr, context));
  std::unique_ptr<Call> c(new Call(this, context));
  std::lock_guard<std::mutex> lock(mu_);
  c->self_ = calls_.insert(calls_.end(), c.get());
  return c;
}

void IdleWatchdog::Loop() {
  const absl::Duration period = std::min(timeout_ / 4, kMaxScanPeriod);
  const int64_t limit_ns = absl::ToInt64Nanoseconds(timeout_);
  const auto period_ns = std::chrono::nanoseconds(absl::ToInt64Nanoseconds(period));
  std::unique_lock<std::mutex> lock(mu_);
  while (!stopped_.wait_for(lock, period_ns, [this] { return stop_; })) {
    const int64_t now = NowNs();
    for (Call* c : calls_) {
      if (!c->ended_.load() && now - c->last_ns_.load(std::memory_order_relaxed) > limit_ns) {
        c->ended_.store(true);
        ++ended_total_;
        c->context_->TryCancel();
      }
    }
  }
}

}  // namespace shrm::server
