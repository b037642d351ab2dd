// SHRMBRDF table files (core/brdf/brdf_table.h) as `--brdf table:FILE` and an uploaded BRDF blob
// ("table:@") reach them: ParseBrdfSpec("table:PATH") -> ReadBrdfTable (magic, version, header
// ranges, size against the header, non-finite values) -> TableBrdf; a table that loads is then
// looked up over a grid and at the poles and beyond the outer nodes (the symmetry continuation).
//
// Input: the whole input is the file.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_table.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path =
      shrm::fuzz::WriteScratchFile("brdf.table", shrm::fuzz::AsView(data, size));
  absl::StatusOr<std::unique_ptr<shrm::Brdf>> brdf = shrm::ParseBrdfSpec("table:" + path);
  if (!brdf.ok()) return 0;
  const shrm::Brdf& b = **brdf;
  shrm::fuzz::Check(b.channels() >= 1 && b.channels() <= 4, "a table has 1..4 channels");
  double out[4] = {};
  constexpr double kPi = shrm::kPi;
  for (double ti : {0.0, 1e-9, 0.5, kPi / 2, kPi - 1e-9, kPi}) {
    for (double to : {0.0, 0.3, kPi / 2, kPi - 1e-6}) {
      for (double phi : {0.0, 1.0, kPi, 1.5 * kPi, 2 * kPi, -0.5}) {
        b.ReparamTransferAll(ti, to, phi, out);
        for (int c = 0; c < b.channels(); ++c)
          shrm::fuzz::Check(std::isfinite(out[c]), "table lookups of finite values are finite");
      }
    }
  }
  (void)b.Transfer({0, 0, 1}, {0, 0.6, 0.8}, {0.8, 0, 0.6}, 0);
  (void)shrm::SampleBrdfTable(b, 5, 4, 3);
  (void)b.bandwidth_hint();
  return 0;
}
