// The SHRM file reader (`shrm eval`, shrm-view, clients reading a server's result):
// ReadShrmFile -> ReadCubeExr (magic bytes, the six parts, header limits, channel lists) and
// the shrm:* attribute checks (format tag, kind, index, pmax against the channels). A file that
// reads is evaluated at a few directions, encoded again and read back: the cube must survive.
//
// Input: the whole input is the file.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "core/io/cube_exr.h"
#include "core/io/image.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_file.h"
#include "fuzz/fuzz_util.h"

namespace {

bool SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path =
      shrm::fuzz::WriteScratchFile("cube.shrm.exr", shrm::fuzz::AsView(data, size));
  shrm::ImageLimits limits;
  limits.max_width = 256;
  limits.max_height = 256;
  limits.max_pixels = int64_t{1} << 14;
  (void)shrm::ReadCubeExr(path, limits);
  absl::StatusOr<shrm::ShrmFile> file = shrm::ReadShrmFile(path, limits);
  if (!file.ok()) return 0;
  const shrm::ShrmCube& cube = file->cube;
  shrm::fuzz::Check(cube.face_size > 0 && cube.data.size() == cube.size(),
                    "a read cube has S x S x 6 texels of ShCount(pmax) x channels values");
  for (const shrm::Vec3& n : {shrm::Vec3{0, 1, 0}, shrm::Vec3{0.6, 0, -0.8}})
    (void)shrm::ShrmEval(cube, n, shrm::Vec3{0, 0, 1});

  absl::StatusOr<std::string> again = shrm::EncodeShrmFile("again", cube, {}, false);
  if (!again.ok()) return 0;
  const std::string again_path = shrm::fuzz::WriteScratchFile("again.shrm.exr", *again);
  absl::StatusOr<shrm::ShrmFile> back = shrm::ReadShrmFile(again_path, limits);
  shrm::fuzz::Check(back.ok(), "an encoded cube reads back");
  shrm::fuzz::Check(back->cube.face_size == cube.face_size && back->cube.pmax == cube.pmax &&
                        back->cube.kind == cube.kind && back->cube.index == cube.index &&
                        SameBits(back->cube.data, cube.data),
                    "an encoded cube reads back unchanged");
  return 0;
}
