// OpenEXR files through OpenEXR's own library, without OpenImageIO: the common path of every job
// (the bundled maps, SHRM cube files, float outputs), so that a process that reads and writes only
// EXR never loads OpenImageIO and its dependency tree (about 150 ms at process start on Debian 12;
// docs/architecture.md "Start-up"). Internal to core/io: image.h and cube_exr.h are the API.
//
// Callers run CheckExrHeader (image.h) on the file first; these functions add the checks that
// need OpenEXR's parsed header (part count, deep parts, channel list, limits).
#ifndef SHRM_CORE_IO_EXR_FILE_H_
#define SHRM_CORE_IO_EXR_FILE_H_

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/io/image.h"

namespace shrm::exr {

// The channels ReadImageRgb takes, in OpenImageIO's order for EXR (so that files read the same
// as they did through OpenImageIO): by layer name, within a layer R, G, B, A (and the other
// well-known names) before the rest in name order.
std::vector<std::string> OrderedChannels(const std::vector<std::string>& names);

// Channels of an image file (ImageHeader::channels).
inline constexpr int kMaxImageChannels = 64;

// The header of a single-part, flat EXR image (format "openexr"; file_bytes left to the caller).
absl::StatusOr<ImageHeader> Probe(const std::string& path, const ImageLimits& limits);

// The first min(3, channels) channels of OrderedChannels as float, interleaved, rows from the top
// of the data window; `header` receives Probe's answer.
absl::StatusOr<std::vector<float>> ReadChannels(const std::string& path, const ImageLimits& limits,
                                                ImageHeader* header, int* channels_read);

// A float OpenEXR file (zip compression at zlib's fastest level, or none; no date or software
// stamp) holding `image`.
absl::StatusOr<std::string> EncodeFloat(const Image& image, bool compress = true);

// A multi-part file (SHRM cube files: six parts). Open parses every header and checks each part
// is flat and within `limits`; Read decodes one part's channels as float into the caller's
// buffer with the caller's strides.
struct PartInfo {
  std::string name;
  int width = 0;
  int height = 0;
  std::vector<std::string> channels;  // in file order (sorted by name)
  std::map<std::string, std::string> string_attributes;
};
struct ChannelDestination {
  std::string channel;
  float* first = nullptr;  // the value of pixel (0, 0) of the data window
  size_t x_stride = 0;     // in floats
  size_t y_stride = 0;     // in floats
};
class PartReader {
 public:
  // More than `max_parts` parts, or a part with more than `max_channels` channels, is
  // InvalidArgument.
  static absl::StatusOr<std::unique_ptr<PartReader>> Open(const std::string& path,
                                                          const ImageLimits& limits, int max_parts,
                                                          int max_channels);
  ~PartReader();
  const std::vector<PartInfo>& parts() const { return parts_; }
  absl::Status Read(int part, const std::vector<ChannelDestination>& destinations);

 private:
  struct File;
  PartReader(std::string path, std::unique_ptr<File> file, std::vector<PartInfo> parts);
  std::string path_;
  std::unique_ptr<File> file_;
  std::vector<PartInfo> parts_;
};

}  // namespace shrm::exr

#endif  // SHRM_CORE_IO_EXR_FILE_H_
