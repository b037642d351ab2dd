#include "jobs/memory_estimate.h"

#include <algorithm>

namespace shrm::jobs {

uint64_t MapBytes(int64_t pixels) {
  return static_cast<uint64_t>(std::max<int64_t>(pixels, 0)) * kMapBytesPerPixel;
}

uint64_t ReferenceBytes(int64_t pixels) {
  return static_cast<uint64_t>(std::max<int64_t>(pixels, 0)) * kReferenceBytesPerPixel;
}

uint64_t ShrmCubeBytes(int face_size, int p_b) {
  const uint64_t s = static_cast<uint64_t>(std::max(face_size, 0));
  const uint64_t coeffs = static_cast<uint64_t>(p_b + 1) * static_cast<uint64_t>(p_b + 1);
  return 6 * s * s * coeffs * 3 * kCubeBytesPerValue + (p_b > 0 ? kGridSlabBytes : 0);
}

uint64_t IblOutputBytes(const IblJob& job) {
  uint64_t texels = 0;
  const absl::StatusOr<ibl::MipChain> chain = IblJobChain(job);
  if (chain.ok()) {
    for (int s : chain->face_size) texels += 6 * static_cast<uint64_t>(s) * s;
  } else {  // not reached for a valid job; the full chain of the base size bounds any chain
    texels = 8 * static_cast<uint64_t>(job.face_size) * job.face_size;
  }
  const uint64_t chains = job.sheen ? 2 : 1;
  const uint64_t irradiance = 6 * static_cast<uint64_t>(job.irradiance_size) * job.irradiance_size;
  const uint64_t dfg = static_cast<uint64_t>(job.dfg_size) * job.dfg_size;
  return (texels * chains + irradiance + dfg) * kChainBytesPerTexel;
}

}  // namespace shrm::jobs
