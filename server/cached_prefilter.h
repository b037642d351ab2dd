// The prefilter pipeline of core/shrm/prefilter.cc with content-keyed caches of its two
// expensive inputs: the lighting coefficients L_lm (and the map's energy) and the BRDF
// coefficients rho_lpq. It composes the same public core functions in the same order with the
// same arguments as shrm::Prefilter(), so its cube is bit-identical to the embedded CLI's
// (tests/service_test.cc checks the files byte for byte). A lighting hit skips decoding the map.
#ifndef SHRM_SERVER_CACHED_PREFILTER_H_
#define SHRM_SERVER_CACHED_PREFILTER_H_

#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_coefficients.h"
#include "core/envmap/envmap.h"
#include "core/shrm/prefilter.h"
#include "server/lru_cache.h"

namespace shrm::server {

struct CachedLighting {
  LightingStage stage;                  // L_lm up to the key's degree, rotated; the energy
  EnvLayout layout = EnvLayout::kAuto;  // the resolved layout of the decoded map
};

struct CachedBrdf {
  BrdfStage stage;
};

class PrefilterCaches {
 public:
  // Each cache gets half of `max_bytes`.
  explicit PrefilterCaches(size_t max_bytes) : lighting(max_bytes / 2), brdf(max_bytes / 2) {}
  LruCache<CachedLighting> lighting;
  LruCache<CachedBrdf> brdf;
};

struct CachedPrefilterInput {
  EnvMapOptions env;    // paths = the blob files
  std::string env_key;  // identifies the map content and everything L_lm depends on except F
  const Brdf* brdf = nullptr;
  PrefilterOptions options;
  // Largest cube (6 S^2 (P_B + 1)^2 RGB values) synthesized; 0 = no limit. Checked once S_B and
  // P_B are known: InvalidArgument naming them.
  double max_cube_values = 0;
};

struct CachedPrefilterResult {
  PrefilterResult result;  // timings: decode (on a lighting miss), brdf, lighting, analysis,
                           // synthesis
  EnvLayout layout = EnvLayout::kAuto;
  bool lighting_hit = false;
  bool brdf_hit = false;
};

// Called before each stage ("brdf", "decode", "lighting", "analysis", "synthesis"); a non-OK
// status (cancellation, deadline) stops the pipeline with that status.
using StageHook = PrefilterProgress;

absl::StatusOr<CachedPrefilterResult> CachedPrefilter(const CachedPrefilterInput& input,
                                                      PrefilterCaches* caches,
                                                      const StageHook& hook);

}  // namespace shrm::server

#endif  // SHRM_SERVER_CACHED_PREFILTER_H_
