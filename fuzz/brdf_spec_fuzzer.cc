// BRDF spec strings (`--brdf`, manifests' "brdfs", requests' `brdf`) through ParseBrdfSpec, and
// the other option strings every front end parses with the job layer's parsers: layouts, SHRM
// kinds, directions, orders, tolerances, IBL formats, SH windows, containers and DFG choices.
//
// Input: the whole input is the string. A spec that parses must round-trip: its canonical
// spec() parses to a model with the same canonical spec (brdf.h), and its transfer function is
// evaluated at a few angles. File-based specs (table:PATH, merl:PATH) are left to the
// brdf_table and merl harnesses, which feed the files themselves.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/brdf/brdf.h"
#include "core/envmap/envmap.h"
#include "fuzz/fuzz_util.h"
#include "jobs/ibl_job.h"
#include "jobs/option_text.h"
#include "jobs/prefilter_job.h"

namespace {

void FuzzBrdfSpec(std::string_view text) {
  if (shrm::BrdfSpecFile(text).has_value()) return;
  absl::StatusOr<std::unique_ptr<shrm::Brdf>> brdf = shrm::ParseBrdfSpec(text);
  if (!brdf.ok()) return;
  const std::string canonical = (*brdf)->spec();
  absl::StatusOr<std::unique_ptr<shrm::Brdf>> again = shrm::ParseBrdfSpec(canonical);
  shrm::fuzz::Check(again.ok(), "the canonical spec of a parsed BRDF parses");
  shrm::fuzz::Check((*again)->spec() == canonical, "the canonical spec is a fixed point");
  double out[4] = {};
  shrm::fuzz::Check((*brdf)->channels() >= 1 && (*brdf)->channels() <= 4, "1..4 channels");
  for (double t : {0.1, 1.0, 2.5}) (*brdf)->ReparamTransferAll(t, 0.5 * t, 0.7, out);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text = shrm::fuzz::AsView(data, size);
  const absl::string_view atext(text.data(), text.size());  // Debian's Abseil: not std's
  FuzzBrdfSpec(text);
  (void)shrm::SplitBrdfSpec(text);
  (void)shrm::ParseEnvLayout(text);
  (void)shrm::jobs::ParseShrmKind(atext);
  (void)shrm::jobs::ParseDirectionText(atext, "--view");
  (void)shrm::jobs::ParseOrdersText(atext, "--orders");
  (void)shrm::jobs::ParseToleranceText(atext, "--tolerance");
  (void)shrm::jobs::ParseIblFormat(atext);
  (void)shrm::jobs::ParseIblShWindow(atext);
  (void)shrm::jobs::ValidateDfgChoice(atext);
  if (absl::StatusOr<std::vector<shrm::jobs::IblContainer>> c =
          shrm::jobs::ParseIblContainers(atext);
      c.ok()) {
    const std::string listed = shrm::jobs::IblContainersText(*c);
    absl::StatusOr<std::vector<shrm::jobs::IblContainer>> again =
        shrm::jobs::ParseIblContainers(listed);
    shrm::fuzz::Check(again.ok() && *again == *c, "containers round-trip through their text");
  }
  return 0;
}
