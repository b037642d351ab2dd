// Multi-part OpenEXR cube files: six parts (one per cube face, GL order +X, -X, +Y, -Y, +Z, -Z),
// each an S x S image with `groups` RGB channel triples, plus string attributes in the header.
// This is the container of the SHRM file (docs/formats.md); it knows nothing of SH semantics.
//
// Channel names: group g's channels are "<group_names[g]>.R", ".G", ".B" (EXR layer syntax),
// so any EXR tool lists them; pixel type float32, or half on request. Part names are
// "px", "nx", "py", "ny", "pz", "nz". Attributes are stored as string attributes of every part
// (names prefixed "shrm:" by the caller).
// Writes are atomic: a temporary file in the target folder renamed into place when complete.
#ifndef SHRM_CORE_IO_CUBE_EXR_H_
#define SHRM_CORE_IO_CUBE_EXR_H_

#include <cstddef>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "absl/functional/function_ref.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/image.h"

namespace shrm {

struct CubeExr {
  int face_size = 0;
  std::vector<std::string> group_names;  // one RGB triple per name
  // data[(((face * S + y) * S + x) * groups + g) * 3 + c]
  std::vector<float> data;
  std::map<std::string, std::string> attributes;
  bool half = false;  // store as half float (16 bit) instead of float32

  int groups() const { return static_cast<int>(group_names.size()); }
  size_t size() const { return size_t{6} * face_size * face_size * group_names.size() * 3; }
};

// The file's bytes, encoded in memory (`name` only labels error messages). Six scanline parts
// named after the faces, channels "<group>.R/.G/.B", no compression, the attributes as strings.
// With `cube.data` empty, `values` (same layout) are encoded instead, without a copy.
absl::StatusOr<std::string> EncodeCubeExr(const CubeExr& cube, const std::string& name,
                                          std::span<const float> values = {});
// The same bytes handed to `sink` in pieces (the header, then runs of lines of about 1 MB), so a
// large cube is never held encoded whole; an invalid cube is refused before anything is sunk.
// `total_bytes` (optional) gets the file's size before the first piece.
absl::Status EncodeCubeExrTo(const CubeExr& cube, const std::string& name,
                             std::span<const float> values,
                             absl::FunctionRef<void(std::string_view)> sink,
                             size_t* total_bytes = nullptr);
// Streamed into `path` atomically (temporary file + rename).
absl::Status WriteCubeExr(const std::string& path, const CubeExr& cube,
                          std::span<const float> values = {});

// Reads a file written by WriteCubeExr (or any six-part EXR with the same part and channel
// structure). The header is validated against `limits` before any pixel is decoded; deep parts
// are rejected.
absl::StatusOr<CubeExr> ReadCubeExr(const std::string& path, const ImageLimits& limits = {});

}  // namespace shrm

#endif  // SHRM_CORE_IO_CUBE_EXR_H_
