#include "viewer/cube_convert.h"

#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/parallel.h"
#include "core/sh/rotation.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm::viewer {

absl::StatusOr<ShrmCube> ConvertShrmKind(const ShrmCube& cube, ShrmKind to, int threads) {
  if (cube.face_size < 1 || cube.pmax < 0 || cube.channels < 1 || cube.data.size() != cube.size()) {
    return absl::InvalidArgumentError("ConvertShrmKind: inconsistent SHRM cube");
  }
  if (threads < 1) return absl::InvalidArgumentError("ConvertShrmKind: threads must be >= 1");
  if (cube.kind == to) return cube;
  if (cube.pmax > kMaxRotationLmax) {
    return absl::InvalidArgumentError(
        absl::StrCat("ConvertShrmKind: P = ", cube.pmax, " > ", kMaxRotationLmax));
  }
  ShrmCube out = cube;
  out.kind = to;
  const int s = cube.face_size, n = cube.coeff_count(), ch = cube.channels;
  ParallelChunks(6 * s, threads, [&](int begin, int end) {
    std::vector<double> in(n), res(n);
    for (int row = begin; row < end; ++row) {
      const int face = row / s, y = row % s;
      for (int x = 0; x < s; ++x) {
        double alpha, beta;
        ShrmAnglesFromWorld(CubeTexelDirection(face, x, y, s), &alpha, &beta);
        Mat3 rot = ShrmLocalFrame(alpha, beta);
        if (to == ShrmKind::kLocal) rot = rot.Transposed();
        const size_t base = cube.Index(face, x, y, 0, 0);
        for (int c = 0; c < ch; ++c) {
          for (int k = 0; k < n; ++k) in[k] = cube.data[base + k * ch + c];
          RotateSh(cube.pmax, rot, in, res);
          for (int k = 0; k < n; ++k) out.data[base + k * ch + c] = static_cast<float>(res[k]);
        }
      }
    }
  });
  return out;
}

}  // namespace shrm::viewer
