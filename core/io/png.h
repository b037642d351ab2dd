// PNG encoding (8-bit grey, grey + alpha, RGB, RGBA) with zlib, without OpenImageIO: previews,
// the glTF IBL's RGBD images and LUTs are written on every job's path (see exr_file.h for why
// OpenImageIO stays off it). The file is a pure function of the pixels: IHDR, one IDAT, IEND;
// no time, gamma or colour chunk (the values are stored as given). Internal to core/io.
#ifndef SHRM_CORE_IO_PNG_H_
#define SHRM_CORE_IO_PNG_H_

#include <cstdint>
#include <span>
#include <string>

#include "absl/status/statusor.h"

namespace shrm::png {

// `pixels`: width * height * channels bytes, rows from the top, channels interleaved.
absl::StatusOr<std::string> Encode8(int width, int height, int channels,
                                    std::span<const uint8_t> pixels);

}  // namespace shrm::png

#endif  // SHRM_CORE_IO_PNG_H_
