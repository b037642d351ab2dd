// The table of render modes (viewer/render_mode.h): one line per mode. Keys 3 and 4 are reserved
// for the low-frequency SH lighting and H-basis irradiance modes.
#include "viewer/mode_global_shrm.h"
#include "viewer/mode_irradiance.h"
#include "viewer/mode_local_shrm.h"
#include "viewer/mode_reference.h"
#include "viewer/mode_sh_lighting.h"
#include "viewer/mode_split_sum.h"
#include "viewer/render_mode.h"

namespace shrm::viewer {
namespace {

const ModeInfo kModes[] = {
    {1, "global-shrm", "global SHRM, one reflection map per frame (eq. 5.35)", MakeGlobalShrmMode},
    {2, "local-shrm", "local SHRM per pixel (eq. 5.10)", MakeLocalShrmMode},
    {3, "sh-lighting", "SH lighting, per-pixel BRDF coefficients (keys S N T)", MakeShLightingMode},
    {4, "irradiance", "irradiance normal mapping, H-basis (keys S N)", MakeIrradianceMode},
    {5, "reference", "ground truth: brute-force integration, progressive", MakeReferenceMode},
    {6, "split-sum", "split-sum IBL of a GGX BRDF (shrm ibl's chain x DFG), as engines shade",
     MakeSplitSumMode},
};

}  // namespace

std::span<const ModeInfo> RegisteredModes() { return kModes; }

const ModeInfo* FindMode(int key) {
  for (const ModeInfo& m : kModes)
    if (m.key == key) return &m;
  return nullptr;
}

}  // namespace shrm::viewer
