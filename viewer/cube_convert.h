// Conversion between the two SHRM kinds, texel by texel (SHRM paper eq. 5.14, docs/shrm.md):
//   global = D(Rot) local,   local = D(Rot)^T global = D(Rot^T) global,
// with Rot = Rz(beta) Ry(alpha) the local frame of the texel's centre direction (alpha, beta its
// SH angles; core/shrm/shrm_synthesis.h ShrmLocalFrame) and D the exact real-SH rotation of
// order P (core/sh/rotation.h RotateSh). Exact at texel centres: the viewer computes (or reads)
// one kind and derives the other, so modes 1 (global) and 2 (local) show the same SHRM.
#ifndef SHRM_VIEWER_CUBE_CONVERT_H_
#define SHRM_VIEWER_CUBE_CONVERT_H_

#include "absl/status/statusor.h"
#include "core/shrm/shrm_map.h"

namespace shrm::viewer {

// The cube as `to` (a copy when it already is). Errors: inconsistent cube, threads < 1.
[[nodiscard]] absl::StatusOr<ShrmCube> ConvertShrmKind(const ShrmCube& cube, ShrmKind to,
                                                       int threads = 1);

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_CUBE_CONVERT_H_
