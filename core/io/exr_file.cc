#include "core/io/exr_file.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <tuple>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"

namespace shrm::exr {
namespace {

// OpenImageIO's order of well-known channel names within a layer (its OpenEXR reader sorts a
// part's channels by layer, then by this list, then by name).
constexpr const char* kSpecialChannels[] = {"R",    "Red", "G",     "Green", "B",    "Blue", "real",
                                            "imag", "A",   "Alpha", "AR",    "RA",   "AG",   "GA",
                                            "AB",   "BA",  "Z",     "Depth", "Zback"};
constexpr int kNotSpecial = static_cast<int>(std::size(kSpecialChannels));

// (layer, rank among the special names, name) of a channel "layer.name" (layer "" without a dot).
std::tuple<std::string, int, std::string> ChannelKey(const std::string& full) {
  const size_t dot = full.rfind('.');
  std::string layer = dot == std::string::npos ? "" : full.substr(0, dot);
  std::string suffix = dot == std::string::npos ? full : full.substr(dot + 1);
  int rank = kNotSpecial;
  for (int i = 0; i < kNotSpecial; ++i) {
    if (suffix == kSpecialChannels[i]) {
      rank = i;
      break;
    }
  }
  return {std::move(layer), rank, std::move(suffix)};
}

// Checks that every part is flat, single-sampled and within `limits`.
absl::Status CheckPartHeader(const std::string& path, const Imf::Header& h, int part,
                             const ImageLimits& limits, int max_channels) {
  const std::string where = part == 0 ? path : absl::StrCat(path, " (part ", part, ")");
  if (h.hasType() && (h.type() == Imf::DEEPSCANLINE || h.type() == Imf::DEEPTILE)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": deep images are not supported"));
  }
  const Imath::Box2i dw = h.dataWindow();
  const int64_t w = int64_t{dw.max.x} - dw.min.x + 1;
  const int64_t hh = int64_t{dw.max.y} - dw.min.y + 1;
  if (w <= 0 || hh <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": invalid dimensions ", w, " x ", hh, " x 1"));
  }
  if (w > limits.max_width || hh > limits.max_height || w * hh > limits.max_pixels) {
    return absl::ResourceExhaustedError(
        absl::StrCat(where, ": image is ", w, " x ", hh, ", above the limits of ", limits.max_width,
                     " x ", limits.max_height, " and ", limits.max_pixels, " pixels"));
  }
  int n = 0;
  for (auto it = h.channels().begin(); it != h.channels().end(); ++it, ++n) {
    if (it.channel().xSampling != 1 || it.channel().ySampling != 1) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": channel ", it.name(), " is subsampled, which is not supported"));
    }
  }
  if (n < 1 || n > max_channels) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": unsupported channel count ", n));
  }
  return absl::OkStatus();
}

std::vector<std::string> ChannelNames(const Imf::Header& h) {
  std::vector<std::string> names;
  for (auto it = h.channels().begin(); it != h.channels().end(); ++it)
    names.emplace_back(it.name());
  return names;
}

// A growing in-memory file for OpenEXR's writer.
class StringOStream final : public Imf::OStream {
 public:
  StringOStream() : Imf::OStream("memory.exr") {}
  void write(const char c[], int n) override {
    if (pos_ + n > bytes_.size()) bytes_.resize(pos_ + n);
    std::memcpy(bytes_.data() + pos_, c, static_cast<size_t>(n));
    pos_ += static_cast<uint64_t>(n);
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = pos; }
  std::string Take() { return std::move(bytes_); }

 private:
  std::string bytes_;
  uint64_t pos_ = 0;
};

}  // namespace

std::vector<std::string> OrderedChannels(const std::vector<std::string>& names) {
  std::vector<std::string> sorted = names;
  std::stable_sort(sorted.begin(), sorted.end(), [](const std::string& a, const std::string& b) {
    return ChannelKey(a) < ChannelKey(b);
  });
  return sorted;
}

struct PartReader::File {
  explicit File(const std::string& path) : file(path.c_str(), /*numThreads=*/0) {}
  Imf::MultiPartInputFile file;
};

PartReader::PartReader(std::string path, std::unique_ptr<File> file, std::vector<PartInfo> parts)
    : path_(std::move(path)), file_(std::move(file)), parts_(std::move(parts)) {}
PartReader::~PartReader() = default;

absl::StatusOr<std::unique_ptr<PartReader>> PartReader::Open(const std::string& path,
                                                             const ImageLimits& limits,
                                                             int max_parts, int max_channels) {
  try {
    auto file = std::make_unique<File>(path);
    const int n = file->file.parts();
    if (n > max_parts) {
      return absl::InvalidArgumentError(
          max_parts == 1 ? absl::StrCat(path, ": multi-part/multi-subimage files are not supported")
                         : absl::StrCat(path, ": has ", n, " parts, more than ", max_parts));
    }
    std::vector<PartInfo> parts;
    for (int p = 0; p < n; ++p) {
      const Imf::Header& h = file->file.header(p);
      SHRM_RETURN_IF_ERROR(CheckPartHeader(path, h, p, limits, max_channels));
      PartInfo info;
      if (h.hasName()) info.name = h.name();
      const Imath::Box2i dw = h.dataWindow();
      info.width = dw.max.x - dw.min.x + 1;
      info.height = dw.max.y - dw.min.y + 1;
      info.channels = ChannelNames(h);
      for (auto it = h.begin(); it != h.end(); ++it) {
        if (std::strcmp(it.attribute().typeName(), "string") == 0) {
          info.string_attributes[it.name()] =
              static_cast<const Imf::StringAttribute&>(it.attribute()).value();
        }
      }
      parts.push_back(std::move(info));
    }
    return std::unique_ptr<PartReader>(new PartReader(path, std::move(file), std::move(parts)));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": cannot read openexr header: ", e.what()));
  }
}

absl::Status PartReader::Read(int part, const std::vector<ChannelDestination>& destinations) {
  try {
    Imf::InputPart in(file_->file, part);
    const Imath::Box2i dw = in.header().dataWindow();
    Imf::FrameBuffer fb;
    for (const ChannelDestination& d : destinations) {
      fb.insert(d.channel, Imf::Slice::Make(Imf::FLOAT, d.first, dw, d.x_stride * sizeof(float),
                                            d.y_stride * sizeof(float)));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(path_, parts_.size() > 1 ? absl::StrCat(" (part ", part, ")") : std::string(),
                     ": cannot decode pixels: ", e.what()));
  }
  return absl::OkStatus();
}

absl::StatusOr<ImageHeader> Probe(const std::string& path, const ImageLimits& limits) {
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<PartReader> reader,
                        PartReader::Open(path, limits, 1, kMaxImageChannels));
  const PartInfo& part = reader->parts().at(0);
  ImageHeader header;
  header.format = "openexr";
  header.width = part.width;
  header.height = part.height;
  header.channels = static_cast<int>(part.channels.size());
  return header;
}

absl::StatusOr<std::vector<float>> ReadChannels(const std::string& path, const ImageLimits& limits,
                                                ImageHeader* header, int* channels_read) {
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<PartReader> reader,
                        PartReader::Open(path, limits, 1, kMaxImageChannels));
  const PartInfo& part = reader->parts().at(0);
  header->format = "openexr";
  header->width = part.width;
  header->height = part.height;
  header->channels = static_cast<int>(part.channels.size());
  const std::vector<std::string> order = OrderedChannels(part.channels);
  const int n = std::min<int>(3, static_cast<int>(order.size()));
  std::vector<float> values(static_cast<size_t>(part.width) * part.height * n);
  std::vector<ChannelDestination> dest;
  for (int c = 0; c < n; ++c) {
    dest.push_back(
        {order[c], values.data() + c, static_cast<size_t>(n), static_cast<size_t>(n) * part.width});
  }
  SHRM_RETURN_IF_ERROR(reader->Read(0, dest));
  *channels_read = n;
  return values;
}

absl::StatusOr<std::string> EncodeFloat(const Image& image, bool compress) {
  static constexpr const char* kNames[4][4] = {
      {"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};
  if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
      image.pixels.size() != static_cast<size_t>(image.width) * image.height * image.channels) {
    return absl::InvalidArgumentError(absl::StrCat("inconsistent image to encode (", image.width,
                                                   " x ", image.height, " x ", image.channels,
                                                   "; 1 to 4 channels)"));
  }
  try {
    StringOStream stream;
    {
      Imf::Header header(image.width, image.height);
      header.compression() = compress ? Imf::ZIP_COMPRESSION : Imf::NO_COMPRESSION;
      // zlib's fastest level: float data compresses little at any level (a 128 x 128 x 3 table:
      // 191,604 bytes in 7.1 ms at the library's default level, 191,492 bytes in 5.0 ms at 1,
      // 196,956 bytes uncompressed).
      header.zipCompressionLevel() = 1;
      Imf::FrameBuffer fb;
      const size_t xs = sizeof(float) * image.channels;
      for (int c = 0; c < image.channels; ++c) {
        const char* name = kNames[image.channels - 1][c];
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
        fb.insert(name,
                  Imf::Slice(Imf::FLOAT,
                             reinterpret_cast<char*>(const_cast<float*>(image.pixels.data()) + c),
                             xs, xs * image.width));
      }
      Imf::OutputFile out(stream, header, /*numThreads=*/0);
      out.setFrameBuffer(fb);
      out.writePixels(image.height);
    }  // the destructor writes the offset table
    return stream.Take();
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat("cannot encode the image as OpenEXR: ", e.what()));
  }
}

}  // namespace shrm::exr
