// Internal to core/shrm: resampling of an equiangular (alpha, beta) grid of SHRM coefficients onto
// the texel centres of a cube map (Ramamoorthi & Hanrahan, "Frequency Space Environment Map
// Rendering", sec. 5.6.2 step 3: the SHRM is synthesized on the (alpha, beta) grid of eqs.
// 5.23-5.24 / 5.14, then resampled onto the cube's texels).
//
// Each texel centre R (or T) is mapped to its SH angles (alpha, beta) (ShrmAnglesFromWorld,
// core/shrm/shrm_eval.h) and its coefficients are the 4 x 4 Lagrange (cubic) interpolation
//   B(alpha, beta) = sum_{a,b=0..3} w_a(t_alpha) w_b(t_beta) B(alpha_{j0-1+a}, beta_{k0-1+b}),
//   w_0(t) = -t (t-1) (t-2) / 6, w_1(t) = (t+1) (t-1) (t-2) / 2,
//   w_2(t) = -(t+1) t (t-2) / 2, w_3(t) = (t+1) t (t-1) / 6,
// periodic in beta, with two padding rows beyond each pole (the trigonometric-polynomial
// continuation to alpha < 0 and alpha > pi). The taps depend only on (S_B, grid size, column
// convention) and are cached per process. Float weights and accumulation; AVX-512 kernels for the
// fixed strides of P = 0..3 with 3 channels. Design notes (grid size, error): docs/shrm.md.
#ifndef SHRM_CORE_SHRM_CUBE_RESAMPLE_H_
#define SHRM_CORE_SHRM_CUBE_RESAMPLE_H_

#include <cstddef>
#include <vector>

#include "core/shrm/shrm_map.h"

namespace shrm::internal {

// Column convention of a grid: kShrm = BuildGrid's beta_k = 2 pi k / nb; kSht = a lat-long
// map of core/transform/sht.h (SH azimuth of column i: 3 pi / 2 - 2 pi (i + 1/2) / nb).
enum class GridColumns { kShrm, kSht };

// Resamples a padded grid (rows -2 .. na + 1, nb = 2 na columns, `stride` floats per node) onto
// the texel centres of `cube` (already sized).
void ResampleToCube(const float* values, int na, int stride, GridColumns columns, int threads,
                    ShrmCube& cube);

// The same from a slab of the padded grid: rows first_row .. first_row + row_count - 1 at `rows`
// (row_count x nb x grid_stride floats, of which the first `stride` of each node are its values;
// grid_stride >= stride, e.g. rounded up to 16 floats so that every node starts a 64-byte line
// when `rows` does). Only the texels whose 4-row stencil starts in
// [first_row, first_row + row_count - 3) are written, so slabs whose owned starts tile
// [0, na + 1) and overlap by 3 rows write every texel exactly once (ShrmSynthesizer::BuildCube
// when the whole grid would be large).
void ResampleToCubeFromRows(const float* rows, int first_row, int row_count, int na, int stride,
                            int grid_stride, GridColumns columns, int threads, ShrmCube& cube);

// dst[0 .. n) = src[0 .. n) with non-temporal stores where dst is 64-byte aligned (AVX-512; a
// plain copy otherwise): a large output written once, e.g. a cube of many coefficients per texel,
// skips the reads for ownership that ordinary stores of lines not in cache cost. Ends with a store
// fence, so the values are visible to other threads once it returns.
void StreamFloats(const float* src, size_t n, float* dst);

// Reserves `n` floats in `v` and, for large buffers on Linux, asks for transparent huge pages on
// the 2 MB-aligned part of the new (untouched) storage before it is first written. THP is usually
// in "madvise" mode, and first-touch page faults on 4 KB pages dominate writing a fresh 10-20 MB
// cube (~0.35 ms per MB measured on the benchmark VM, ~0.09 ms per MB with 2 MB pages). A hint
// only: no effect on the values, ignored where unsupported.
void ReserveLargeBuffer(std::vector<float>& v, size_t n);

}  // namespace shrm::internal

#endif  // SHRM_CORE_SHRM_CUBE_RESAMPLE_H_
