// MERL isotropic BRDF files (`--brdf merl:FILE`, an uploaded "merl:@" blob): ParseBrdfSpec ->
// LoadMerlBrdf (the 12-byte dims header, the exact size of 3 x 90 x 90 x 180 doubles), and the
// lookups of a loaded table (half/difference angle bins) at any angles a job asks for.
//
// Input: byte 0 bit 0 clear: the rest is the file as it is (header and size checks). Bit 0 set:
// the rest gives angles, looked up in a table loaded once from a real-size file whose doubles
// include NaN, infinities, negatives and huge values (writing 35 MB per input would make this
// harness a hundred times slower without reaching more of the reader).
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/base/geometry.h"
#include "core/brdf/brdf.h"
#include "core/brdf/merl.h"
#include "fuzz/fuzz_util.h"

namespace {

constexpr double kPi = shrm::kPi;

const shrm::Brdf& LoadedTable() {
  static const std::unique_ptr<shrm::Brdf> brdf = [] {
    const double special[] = {0.02,
                              -1.0,
                              std::numeric_limits<double>::quiet_NaN(),
                              std::numeric_limits<double>::infinity(),
                              1e300,
                              0.5,
                              0.0};
    std::vector<double> data(3 * static_cast<size_t>(shrm::kMerlSize));
    for (size_t i = 0; i < data.size(); ++i) data[i] = special[i % std::size(special)];
    const std::string path = shrm::fuzz::ScratchDir() + "/loaded.merl";
    shrm::fuzz::Check(
        shrm::WriteMerlFile(path, {shrm::kMerlThetaH, shrm::kMerlThetaD, shrm::kMerlPhiD}, data)
            .ok(),
        "write a MERL file");
    absl::StatusOr<std::unique_ptr<shrm::Brdf>> b = shrm::ParseBrdfSpec("merl:" + path);
    shrm::fuzz::Check(b.ok(), "a real-size MERL file loads");
    return *std::move(b);
  }();
  return *brdf;
}

shrm::Vec3 UnitVector(FuzzedDataProvider* fdp) {
  const double z = fdp->ConsumeFloatingPointInRange(-1.0, 1.0);
  const double phi = fdp->ConsumeFloatingPointInRange(0.0, 2 * kPi);
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  if ((data[0] & 1) == 0) {
    const std::string path =
        shrm::fuzz::WriteScratchFile("brdf.merl", shrm::fuzz::AsView(data + 1, size - 1));
    (void)shrm::ParseBrdfSpec("merl:" + path);
    return 0;
  }
  const shrm::Brdf& b = LoadedTable();
  FuzzedDataProvider fdp(data + 1, size - 1);
  double out[3] = {};
  while (fdp.remaining_bytes() > 0) {
    const double ti = fdp.ConsumeFloatingPointInRange(0.0, kPi);
    const double to = fdp.ConsumeFloatingPointInRange(0.0, kPi);
    const double phi = fdp.ConsumeFloatingPointInRange(-2 * kPi, 2 * kPi);
    b.ReparamTransferAll(ti, to, phi, out);
    const shrm::Vec3 n = UnitVector(&fdp), v = UnitVector(&fdp), w = UnitVector(&fdp);
    for (int c = 0; c < 3; ++c) (void)b.Transfer(n, v, w, c);
  }
  return 0;
}
