// A gate for the service's test stage hook (ServiceOptions::test_stage_hook): while closed, every
// job that reaches a stage waits there. Admission tests hold one job in its slot with it and check
// what the other calls get meanwhile, by the order of events rather than by wall-clock time
// (CI shares two cores; a test that measures milliseconds fails when the machine is busy).
#ifndef SHRM_TESTS_STAGE_GATE_H_
#define SHRM_TESTS_STAGE_GATE_H_

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "absl/time/time.h"

namespace shrm::testing {

class StageGate {
 public:
  StageGate() = default;
  // A gate that holds jobs only at `stage` (e.g. "write": after the cube is made).
  explicit StageGate(std::string stage) : stage_(std::move(stage)) {}
  // The hook to install; it shares the gate's state, so it may outlive nothing it points to.
  std::function<void(std::string_view)> Hook() const {
    return [s = state_, only = stage_](std::string_view stage) {
      if (!only.empty() && stage != only) return;
      std::unique_lock<std::mutex> lock(s->mu);
      if (s->open) return;
      ++s->held;
      s->cv.notify_all();
      s->cv.wait(lock, [&] { return s->open; });
    };
  }
  // Waits until `n` stage entries have been held; false if `timeout` passes first (a safety
  // net that turns a broken server into a failure instead of a hung test, not a timing claim).
  bool WaitHeld(int n, absl::Duration timeout) const {
    std::unique_lock<std::mutex> lock(state_->mu);
    return state_->cv.wait_for(lock, absl::ToChronoNanoseconds(timeout),
                               [&] { return state_->held >= n; });
  }
  void Open() const {
    std::lock_guard<std::mutex> lock(state_->mu);
    state_->open = true;
    state_->cv.notify_all();
  }

 private:
  struct State {
    std::mutex mu;
    std::condition_variable cv;
    bool open = false;
    int held = 0;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
  std::string stage_;  // "" = every stage
};

}  // namespace shrm::testing

#endif  // SHRM_TESTS_STAGE_GATE_H_
