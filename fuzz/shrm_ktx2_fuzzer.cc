// The SHRM's KTX2 container reader (core/export/shrm_ktx2.h: `shrm eval | render | explicit` and
// shrm-view read `.shrm.ktx2` files with it): DecodeShrmKtx2 on the bytes (identifier, header,
// level index, Key/Value Data, the shrm:* conventions, the level's values). A file that reads is
// evaluated at a few directions, encoded again and decoded: the cube must survive bit for bit.
//
// Input: the whole input is the file.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "core/export/shrm_ktx2.h"
#include "core/shrm/shrm_eval.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  shrm::ImageLimits limits;
  limits.max_width = 256;
  limits.max_pixels = int64_t{1} << 14;
  absl::StatusOr<shrm::ShrmFile> file =
      shrm::DecodeShrmKtx2("fuzz.shrm.ktx2", shrm::fuzz::AsView(data, size), limits);
  if (!file.ok()) return 0;
  const shrm::ShrmCube& cube = file->cube;
  shrm::fuzz::Check(cube.face_size > 0 && cube.data.size() == cube.size(),
                    "a read cube has S x S x 6 texels of ShCount(pmax) x 3 values");
  for (const shrm::Vec3& n : {shrm::Vec3{0, 1, 0}, shrm::Vec3{0.6, 0, -0.8}})
    (void)shrm::ShrmEval(cube, n, shrm::Vec3{0, 0, 1});
  absl::StatusOr<std::string> again =
      shrm::EncodeShrmKtx2("again", cube, file->attributes, /*half=*/false);
  shrm::fuzz::Check(again.ok(), "a decoded cube encodes again");
  absl::StatusOr<shrm::ShrmFile> back = shrm::DecodeShrmKtx2("again", *again, limits);
  shrm::fuzz::Check(back.ok(), "an encoded cube decodes");
  shrm::fuzz::Check(back->cube.face_size == cube.face_size && back->cube.pmax == cube.pmax &&
                        back->cube.kind == cube.kind && back->cube.index == cube.index &&
                        std::memcmp(back->cube.data.data(), cube.data.data(),
                                    cube.data.size() * sizeof(float)) == 0,
                    "an encoded cube decodes unchanged");
  return 0;
}
