#ifndef SHRM_CORE_TRANSFORM_FFTW_WISDOM_H_
#define SHRM_CORE_TRANSFORM_FFTW_WISDOM_H_

// The FFTW plans of the SH transforms' phi stage, and the wisdom the build makes for them.
//
// FFTW_ESTIMATE still searches its solvers for every new size: 1-2 ms a plan here, about 2 ms
// more for the planner's first use in a process, so that a `shrm ibl` run spent ~5 ms planning
// its five transforms' FFTs, as long as their execution. The build plans the sizes shrm's
// transforms use most (WisdomRingFfts) the same way and keeps FFTW's record of each plan, its
// "wisdom" (tools/fftw_wisdom_gen.cc, a generated source); ShtPlan imports the record of a size
// before planning it, and FFTW then rebuilds the plan it had chosen without searching. The plan,
// and so every transform's result, is the one FFTW_ESTIMATE makes on the build machine. Where a
// record does not apply (a program run on a processor without the SIMD instructions the build
// machine's plan uses), FFTW drops it and plans as without it (FFTW's documented fallback for
// wisdom from another machine).

#include <vector>

struct fftw_plan_s;  // fftw3.h's plan type (fftw_plan is a pointer to it)

namespace shrm::internal {

// One batch of the transforms' phi stage (ShtPlan): `howmany` real rings of `width` samples, each
// ring's samples contiguous and the rings `width` apart, to (forward) or from their
// width / 2 + 1 complex spectra, the spectra width / 2 + 1 apart: two rings per channel, the
// north and south ring of a pair.
struct RingFft {
  int width = 0;
  int howmany = 0;
  bool forward = false;  // real to complex (analysis); else complex to real (synthesis)
  friend bool operator==(const RingFft&, const RingFft&) = default;
};

// The plan of `fft` made with FFTW_ESTIMATE (and FFTW_WISDOM_ONLY when `wisdom_only`: null then
// unless the planner holds wisdom for it) on fftw_malloc'ed buffers of the layout the transforms
// execute it on. Null when FFTW cannot make it. The caller holds FftwPlannerMutex()
// (core/transform/sht.h) when other threads may plan.
fftw_plan_s* PlanRingFft(const RingFft& fft, bool wisdom_only = false);

// The batches the build makes wisdom for, three channels each (howmany 6): the syntheses on every
// grid of 32 to 2048 rings that FftFriendlyRings gives (widths 2 x rings: every split-sum level,
// irradiance cube and P = 0 SHRM of the default jobs), and the analysis of lat-long maps 256 to
// 8192 pixels wide.
std::vector<RingFft> WisdomRingFfts();

// The build's wisdom for `fft` (FFTW's text form, for fftw_import_wisdom_from_string), or null
// for a batch it made none for. Defined by the generated source.
const char* BuiltInWisdom(const RingFft& fft);

}  // namespace shrm::internal

#endif  // SHRM_CORE_TRANSFORM_FFTW_WISDOM_H_
