// Ends calls that make no progress (docs/server.md, "Idle and slow clients"): an upload whose
// client stops sending, a file transfer whose client stops reading. Each watched call reports
// progress (a chunk received or sent); a call that reports none for the timeout is cancelled
// from the watchdog's thread, which makes its blocked Read or Write return false, so its handler
// thread, its job slot and its pinned blobs are released. Only the transfer loops are watched:
// a job computing for minutes between two messages is not idle.
#ifndef SHRM_SERVER_IDLE_WATCHDOG_H_
#define SHRM_SERVER_IDLE_WATCHDOG_H_

#include <grpcpp/server_context.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <thread>

#include "absl/time/time.h"

namespace shrm::server {

class IdleWatchdog {
 public:
  // A call under watch, from IdleWatchdog::Watch() to its destruction.
  class Call {
   public:
    ~Call();
    Call(const Call&) = delete;
    Call& operator=(const Call&) = delete;
    void Progress();
    // Whether the watchdog ended the call (its Read/Write failed because of it).
    bool ended_idle() const { return ended_.load(); }

   private:
    friend class IdleWatchdog;
    Call(IdleWatchdog* dog, grpc::ServerContext* context);
    IdleWatchdog* const dog_;  // null: no timeout
    grpc::ServerContext* const context_;
    std::atomic<int64_t> last_ns_;
    std::atomic<bool> ended_{false};
    std::list<Call*>::iterator self_;
  };

  // timeout <= 0: calls are never ended (Watch() still works).
  explicit IdleWatchdog(absl::Duration timeout);
  ~IdleWatchdog();
  IdleWatchdog(const IdleWatchdog&) = delete;
  IdleWatchdog& operator=(const IdleWatchdog&) = delete;

  std::unique_ptr<Call> Watch(grpc::ServerContext* context);
  absl::Duration timeout() const { return timeout_; }
  // Calls ended so far.
  int64_t ended() const { return ended_total_.load(); }

 private:
  void Loop();
  const absl::Duration timeout_;
  std::mutex mu_;  // guards calls_ and stop_
  std::condition_variable stopped_;
  std::list<Call*> calls_;
  bool stop_ = false;
  std::atomic<int64_t> ended_total_{0};
  std::thread thread_;
};

}  // namespace shrm::server

#endif  // SHRM_SERVER_IDLE_WATCHDOG_H_
