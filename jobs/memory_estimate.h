// What a job's stages hold in memory at their peak, estimated from the request before they run:
// the service admits a job's stages against its memory budget with these (server/memory_budget.h,
// docs/server.md "Memory"). Each figure is an upper bound of the peak RSS the stage adds, from
// the measured peaks of the embedded pipeline and of shrmd (docs/results.md "Memory admission";
// tests/memory_admission_test.cc measures shrmd's peak RSS against the budget).
#ifndef SHRM_JOBS_MEMORY_ESTIMATE_H_
#define SHRM_JOBS_MEMORY_ESTIMATE_H_

#include <cstdint>

#include "core/shrm/shrm_synthesis.h"
#include "jobs/ibl_job.h"

namespace shrm::jobs {

// Every job: the BRDF's coefficients (a MERL table's 35 MB included), L_lm, FFT plans, worker
// stacks and the request's own buffers.
inline constexpr uint64_t kJobBaseBytes = uint64_t{64} << 20;
// A decoded map, per input pixel: the decoder's buffer, the float RGB image, the colour
// conversion's copy, the resampled layout and the sample list of the brute-force checks (about
// 48 bytes). Measured at most 90 bytes (prefilter and ibl, 1024 x 512 to 4096 x 2048).
inline constexpr uint64_t kMapBytesPerPixel = 112;
// An SHRM cube, per value (6 S^2 (P + 1)^2 RGB): the float cube, the encoder's copy and the
// encoded file held for the transfer. Measured about 8 (the CLI and shrmd, S = 512, P = 4).
inline constexpr uint64_t kCubeBytesPerValue = 12;
// A radiance chain, per texel of all levels: the double-precision convolution, the stored
// format, the containers' encoded copies. Measured at most 55 (shrmd; size 1024, rgba32f, sheen,
// every container).
inline constexpr uint64_t kChainBytesPerTexel = 72;

// The job's own check (verify > 0), per input pixel: the brute-force reference's samples and
// their hierarchy (core/shrm/fast_reference.h). Measured about 300 (the CLI on a 1024 x 512 map:
// peak RSS with --verify 64 against --verify 0).
inline constexpr uint64_t kReferenceBytesPerPixel = 400;

// Decoding and transforming a map of `pixels` input pixels (all files of a cube together).
uint64_t MapBytes(int64_t pixels);
// The job's check of a map of `pixels` input pixels.
uint64_t ReferenceBytes(int64_t pixels);
// The synthesis grid's slab (ShrmGridOptions::max_grid_bytes: the (alpha, beta) grid of F_B +
// P_B is made and resampled in slabs within it, up to kSlabGrowthForThreads times it so that each
// thread has rows of its own; before, the whole grid was held: 0.8 GB at (42, 21) even for a
// 16 x 16 cube).
inline constexpr uint64_t kGridSlabBytes = kSlabGrowthForThreads * ShrmGridOptions{}.max_grid_bytes;
// Synthesizing and encoding an SHRM cube of face size S_B and order P_B (P_B > 0: with the grid's
// slab).
uint64_t ShrmCubeBytes(int face_size, int p_b);
// An IBL job's outputs (the chains, the irradiance cube, the DFG table and their files), beyond
// its map. The job must be valid (ValidateIblJob).
uint64_t IblOutputBytes(const IblJob& job);

}  // namespace shrm::jobs

#endif  // SHRM_JOBS_MEMORY_ESTIMATE_H_
