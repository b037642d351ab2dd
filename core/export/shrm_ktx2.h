// The SHRM file in a KTX 2.0 container (docs/formats.md "SHRM in KTX2"): what an engine uploads
// as it is and evaluates with the shipped shaders (shaders/, docs/shaders.md).
//
//   a cube-map array (faceCount 6, layerCount (P + 1)^2, one level): layer k holds SH coefficient
//   k = p (p + 1) + q of every texel, faces +X -X +Y -Y +Z -Z (core/base/cubemap.h), row 0 first;
//   R32G32B32A32_SFLOAT (or R16G16B16A16_SFLOAT with `half`), RGB = the coefficient of the
//   channel, A = 0 (unused: RGBA because RGB32F textures are not sampleable everywhere);
//   Key/Value Data: every shrm:* attribute of the EXR container (ShrmConventionAttributes plus the
//   producer's), shrm:face_order and shrm:layout stating this layout.
//
// Uploaded as a 2D array texture, layer k * 6 + face is coefficient k of that face (the shaders'
// binding); uploaded as a cube-map array, cube k is coefficient k.
#ifndef SHRM_CORE_EXPORT_SHRM_KTX2_H_
#define SHRM_CORE_EXPORT_SHRM_KTX2_H_

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/io/image.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_map.h"

namespace shrm {

// The texel data of the container's single level, [k][face][y][x][RGBA]: also what shrm-view
// uploads (the same bytes an engine takes from the file).
std::vector<float> ShrmCoefficientLayers(const ShrmCube& cube);

// The file's bytes; `extra` keys must start with "shrm:" (as for the EXR container). `label`
// names the output in errors. InvalidArgument for an inconsistent cube or non-finite values.
absl::StatusOr<std::string> EncodeShrmKtx2(const std::string& label, const ShrmCube& cube,
                                           const std::map<std::string, std::string>& extra,
                                           bool half = false);

// Parses an SHRM KTX2 file (only what EncodeShrmKtx2 writes: the two formats, one level, no
// supercompression, the layer count of shrm:pmax, every offset and length inside the file).
// Errors (InvalidArgument) name `label` and the field.
absl::StatusOr<ShrmFile> DecodeShrmKtx2(const std::string& label, std::string_view bytes,
                                        const ImageLimits& limits = {});

// True when `bytes` start with the KTX 2.0 identifier.
bool IsKtx2(std::string_view bytes);

// Reads an SHRM file in either container (KTX2 by its identifier, else the six-part EXR of
// core/shrm/shrm_file.h).
absl::StatusOr<ShrmFile> ReadShrm(const std::string& path, const ImageLimits& limits = {});

}  // namespace shrm

#endif  // SHRM_CORE_EXPORT_SHRM_KTX2_H_
