#include "core/transform/fftw_wisdom.h"

#include <fftw3.h>

namespace shrm::internal {

fftw_plan_s* PlanRingFft(const RingFft& fft, bool wisdom_only) {
  if (fft.width < 1 || fft.howmany < 1) return nullptr;
  const int width = fft.width, nc = width / 2 + 1;
  // Buffers of the transforms' own alignment (fftw_malloc, as ShtPlan's work buffers): FFTW plans
  // for, and records, the alignment it is given.
  double* re = fftw_alloc_real(static_cast<size_t>(fft.howmany) * width);
  fftw_complex* co = fftw_alloc_complex(static_cast<size_t>(fft.howmany) * nc);
  fftw_plan plan = nullptr;
  if (re != nullptr && co != nullptr) {
    int n[1] = {width};
    const unsigned flags = FFTW_ESTIMATE | (wisdom_only ? FFTW_WISDOM_ONLY : 0u);
    plan = fft.forward ? fftw_plan_many_dft_r2c(1, n, fft.howmany, re, nullptr, 1, width, co,
                                                nullptr, 1, nc, flags)
                       : fftw_plan_many_dft_c2r(1, n, fft.howmany, co, nullptr, 1, nc, re, nullptr,
                                                1, width, flags);
  }
  fftw_free(re);
  fftw_free(co);
  return plan;
}

std::vector<RingFft> WisdomRingFfts() {
  constexpr int kChannels = 3;
  std::vector<RingFft> out;
  // FftFriendlyRings (core/shrm/shrm_synthesis.h): multiples of 8 whose cofactor is 7-smooth.
  const auto smooth = [](int v) {
    for (int p : {2, 3, 5, 7})
      while (v % p == 0) v /= p;
    return v == 1;
  };
  for (int rings = 32; rings <= 2048; rings += 8) {
    if (smooth(rings / 8)) out.push_back({2 * rings, 2 * kChannels, false});
  }
  for (int width = 256; width <= 8192; width *= 2) out.push_back({width, 2 * kChannels, true});
  return out;
}

}  // namespace shrm::internal
