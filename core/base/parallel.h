// A minimal fork-join helper for the library's data-parallel loops (no thread pool: jobs are
// coarse, and threads are started per call).
#ifndef SHRM_CORE_BASE_PARALLEL_H_
#define SHRM_CORE_BASE_PARALLEL_H_

#include <algorithm>
#include <thread>
#include <vector>

namespace shrm {

// Runs `body(begin, end)` over [0, n) split into at most `threads` contiguous chunks, on the
// calling thread when one chunk suffices.
template <typename Body>
void ParallelChunks(int n, int threads, Body&& body) {
  threads = std::max(1, std::min(threads, n));
  if (threads == 1) {
    body(0, n);
    return;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const int b = static_cast<int>(static_cast<long>(n) * t / threads);
    const int e = static_cast<int>(static_cast<long>(n) * (t + 1) / threads);
    pool.emplace_back([&body, b, e] { body(b, e); });
  }
  for (auto& th : pool) th.join();
}

}  // namespace shrm

#endif  // SHRM_CORE_BASE_PARALLEL_H_
