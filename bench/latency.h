// Latency bookkeeping shared by the service benchmarks (plain mains, not Google Benchmark's
// runner: their figures are distributions over requests).
#ifndef SHRM_BENCH_LATENCY_H_
#define SHRM_BENCH_LATENCY_H_

#include <algorithm>
#include <chrono>
#include <vector>

namespace shrm::bench {

using Clock = std::chrono::steady_clock;

inline double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

// The q-quantile (nearest rank) of `v`; 0 for an empty sample.
inline double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

}  // namespace shrm::bench

#endif  // SHRM_BENCH_LATENCY_H_
