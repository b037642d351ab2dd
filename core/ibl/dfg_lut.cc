// ComputeDfgLut: the precomputed table where it applies (core/ibl/dfg.h), else the quadrature.
#include <cstddef>

#include "core/base/status_macros.h"
#include "core/ibl/dfg.h"

namespace shrm::ibl {
namespace internal {
// Written by the build (core/ibl/tools/dfg_table_gen.cc): [row][column][value], the layout of
// kPrecomputedDfgRows, kPrecomputedDfgSize and kPrecomputedDfgValues.
extern const float
    kPrecomputedDfgTable[kPrecomputedDfgRows * kPrecomputedDfgSize * kPrecomputedDfgValues];
}  // namespace internal
namespace {

// Index of a channel's value in a table entry; -1 for kZero.
int ValueIndex(DfgChannel c) {
  switch (c) {
    case DfgChannel::kGgxScale:
      return 0;
    case DfgChannel::kGgxBias:
      return 1;
    case DfgChannel::kGgxEnergy:
      return 2;
    case DfgChannel::kCharlieNeubelt:
      return 3;
    case DfgChannel::kSheenAlbedo:
      return 4;
    case DfgChannel::kZero:
      break;
  }
  return -1;
}

bool Precomputed(int size, const DfgLutLayout& layout) {
  return size == kPrecomputedDfgSize && layout.roughness_axis == RoughnessAxis::kPerceptual &&
         (layout.roughness_texel_offset == 0 || layout.roughness_texel_offset == 1);
}

}  // namespace

absl::StatusOr<DfgLut> ComputeDfgLut(int size, const DfgLutLayout& layout, int threads) {
  SHRM_RETURN_IF_ERROR(ValidateDfgLut(size, layout, threads));
  if (!Precomputed(size, layout)) return ComputeDfgLutByQuadrature(size, layout, threads);
  DfgLut lut;
  lut.size = size;
  lut.channels = static_cast<int>(layout.channels.size());
  lut.layout = layout;
  lut.data.assign(static_cast<size_t>(size) * size * lut.channels, 0.0f);
  const int shift = layout.roughness_texel_offset == 0 ? 0 : 1;
  for (int row = 0; row < size; ++row) {
    const int j = layout.row_order == RowOrder::kSmoothFirst ? row : size - 1 - row;
    const float* in = &internal::kPrecomputedDfgTable[static_cast<size_t>(j + shift) * size *
                                                      kPrecomputedDfgValues];
    float* out = &lut.data[static_cast<size_t>(row) * size * lut.channels];
    for (int col = 0; col < size; ++col)
      for (int c = 0; c < lut.channels; ++c) {
        const int v = ValueIndex(layout.channels[c]);
        out[col * lut.channels + c] = v < 0 ? 0.0f : in[col * kPrecomputedDfgValues + v];
      }
  }
  return lut;
}

absl::StatusOr<DfgLut> ComputeDfgLut(int size, DfgConsumer consumer, int threads) {
  return ComputeDfgLut(size, LayoutFor(consumer), threads);
}

}  // namespace shrm::ibl
