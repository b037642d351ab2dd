// Image input for shrm: float pixels from EXR (through OpenEXR), Radiance HDR, PFM, TIFF and PNG
// files (through OpenImageIO, in the module of image_module.h, loaded on first use), validated
// before any pixel is decoded.
//
// Safety rules (docs/formats.md, "Input validation"): the reader is chosen by the file's magic
// bytes, never by its extension, and OpenImageIO is not allowed to try other readers; the header
// (dimensions, channel count, pixel type, file size) is checked against ImageLimits before
// pixels are read; deep and multi-part EXR files are rejected. Non-finite pixels are reported
// with their count and first position, or replaced by 0 when the policy allows it.
// All failures are absl::Status values whose message names the file and the problem.
#ifndef SHRM_CORE_IO_IMAGE_H_
#define SHRM_CORE_IO_IMAGE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace shrm {

// Upper bounds checked against the header before decoding.
struct ImageLimits {
  int max_width = 16384;
  int max_height = 16384;
  int64_t max_pixels = int64_t{256} << 20;    // 256 Mpixel
  int64_t max_file_bytes = int64_t{4} << 30;  // 4 GiB
};

enum class NonFinitePolicy {
  kReject,       // fail with the count and the first position of NaN/Inf values
  kReplaceZero,  // replace them by 0 (the caller is told how many through Image::replaced)
};

// What the header says, before decoding.
struct ImageHeader {
  std::string format;  // format name chosen from the magic bytes (OpenImageIO's), e.g. "openexr"
  int width = 0;
  int height = 0;
  int channels = 0;
  int64_t file_bytes = 0;
};

// A decoded image: interleaved float channels, rows from the top.
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> pixels;  // size width * height * channels
  int64_t replaced_non_finite = 0;

  float at(int x, int y, int c) const {
    return pixels[(static_cast<size_t>(y) * width + x) * channels + c];
  }
};

// Format name for the file's first bytes ("openexr", "hdr", "pnm" (PFM), "tiff", "png"), or an
// InvalidArgument error naming the unrecognized signature.
absl::StatusOr<std::string> DetectImageFormat(const std::string& path);

// Walks an OpenEXR file's header(s) (every part of a multi-part file) before OpenEXR parses them,
// and refuses what Debian's OpenEXR 3.1.5 would turn into a huge allocation or an unsafe read
// (found by fuzzing, docs/fuzzing.md): an attribute whose declared size exceeds the bytes left in
// the file, a preview or string vector whose contents disagree with that size, an unterminated or
// over-long name, a chunk count or tile offset table larger than the file could hold, a
// dataWindow that is empty, inverted or beyond `limits` (ResourceExhausted), and deep data
// (CVE-2023-5841). Everything else is left to OpenEXR. Called by ProbeImage/ReadImageRgb and by
// ReadCubeExr for "openexr" files.
absl::Status CheckExrHeader(const std::string& path, const ImageLimits& limits);

// Walks a PNG file's chunks before libpng (through OpenImageIO) reads them, and refuses a chunk
// whose declared length runs past the file's end: libpng allocates and clears a text or
// metadata chunk's declared size before reading it, so a 640-byte file claiming a 1.6 GB tEXt
// chunk cost 1.6 GB of touched memory (found by fuzzing, docs/fuzzing.md). Also: IHDR first,
// 13 bytes, a nonzero size within `limits` (ResourceExhausted). Called by ProbeImage/ReadImageRgb
// for "png" files.
absl::Status CheckPngHeader(const std::string& path, const ImageLimits& limits);

// Opens the file and validates its header against `limits` without decoding pixels.
absl::StatusOr<ImageHeader> ProbeImage(const std::string& path, const ImageLimits& limits = {});

// Reads the first 3 channels (RGB; a 1- or 2-channel image is expanded to grey RGB) as float.
absl::StatusOr<Image> ReadImageRgb(const std::string& path, const ImageLimits& limits = {},
                                   NonFinitePolicy policy = NonFinitePolicy::kReject);

// Writes `image` as a float OpenEXR file. The pixels go to a temporary file in the same folder,
// which is renamed over `path` only once it is complete: an existing output is never left
// half-written.
absl::Status WriteExr(const std::string& path, const Image& image);

// Writes a tone-mapped 8-bit sRGB preview (PNG or TIFF by extension) of a linear RGB image: scale
// by 2^exposure, Reinhard x / (1 + x) per channel, sRGB OETF, 8-bit rounding. Atomic like WriteExr.
absl::Status WritePreviewPng(const std::string& path, const Image& linear, double exposure = 0);
// The same tone mapping in memory: values in [0, 1], sRGB-encoded, for EncodeImage(kPng8).
Image TonemapPreview(const Image& linear, double exposure = 0);

// Writes `image` (values in [0, 1], clamped; NaN -> 0) as 8-bit PNG or TIFF, chosen by the
// extension (.png, .tif, .tiff; anything else is InvalidArgument), without any colour
// transform. Atomic like WriteExr.
absl::Status WriteImage8Bit(const std::string& path, const Image& image);
// WriteImage8Bit's extension rule alone, for checking an output path before any work.
absl::Status Check8BitExtension(const std::string& path);

// The same encodings in memory (for outputs that every front end writes identically): a float
// OpenEXR file (zip, or uncompressed for data that zip barely shrinks, such as smooth tables of
// values in [0, 1]; fixed date) or an 8-bit PNG of values in [0, 1] (clamped, NaN -> 0, no colour
// transform; a 4th channel is stored as given, not as premultiplied alpha). InvalidArgument for
// an inconsistent image.
enum class ImageEncoding { kExrFloat, kExrFloatUncompressed, kPng8 };
absl::StatusOr<std::string> EncodeImage(const Image& image, ImageEncoding encoding);

}  // namespace shrm

#endif  // SHRM_CORE_IO_IMAGE_H_
