#include "core/io/image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"
#include "core/io/exr_file.h"
#include "core/io/image_module.h"
#include "core/io/png.h"

namespace shrm {

absl::StatusOr<std::string> DetectImageFormat(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": is a folder, not an image file"));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open file"));
  std::array<unsigned char, 8> b{};
  in.read(reinterpret_cast<char*>(b.data()), b.size());
  const std::streamsize n = in.gcount();
  if (n >= 4 && b[0] == 0x76 && b[1] == 0x2f && b[2] == 0x31 && b[3] == 0x01) return "openexr";
  if (n >= 8 && b[0] == 0x89 && b[1] == 'P' && b[2] == 'N' && b[3] == 'G') return "png";
  if (n >= 4 && ((b[0] == 'I' && b[1] == 'I' && b[2] == 42 && b[3] == 0) ||
                 (b[0] == 'M' && b[1] == 'M' && b[2] == 0 && b[3] == 42)))
    return "tiff";
  if (n >= 2 && b[0] == '#' && b[1] == '?') return "hdr";
  if (n >= 3 && b[0] == 'P' && (b[1] == 'F' || b[1] == 'f') && std::isspace(b[2])) return "pnm";
  return absl::InvalidArgumentError(
      absl::StrCat(path,
                   ": unrecognized file signature (expected OpenEXR, Radiance HDR, PFM, "
                   "TIFF or PNG)"));
}

namespace {

// OpenEXR header walking (CheckExrHeader): the file layout of "OpenEXR File Layout" (magic,
// version and flags, then per part a list of attributes name\0 type\0 int32 size value,
// ended by an empty name; multi-part files end the list of headers with an empty header).
constexpr uint32_t kExrTiledFlag = 0x200;
constexpr uint32_t kExrLongNamesFlag = 0x400;
constexpr uint32_t kExrNonImageFlag = 0x800;  // deep data
constexpr uint32_t kExrMultiPartFlag = 0x1000;
constexpr int kExrMaxParts = 1024;

class ExrHeaderWalker {
 public:
  ExrHeaderWalker(const std::string& path, const ImageLimits& limits)
      : path_(path), limits_(limits) {}

  absl::Status Walk() {
    std::error_code ec;
    file_bytes_ = static_cast<int64_t>(std::filesystem::file_size(path_, ec));
    if (ec) return absl::NotFoundError(absl::StrCat(path_, ": ", ec.message()));
    in_.open(path_, std::ios::binary);
    if (!in_) return absl::NotFoundError(absl::StrCat(path_, ": cannot open file"));
    uint32_t magic = 0, version = 0;
    if (!ReadU32(&magic) || !ReadU32(&version)) return Bad("shorter than its 8-byte preamble");
    if (version & kExrNonImageFlag) {
      return absl::InvalidArgumentError(absl::StrCat(path_, ": deep images are not supported"));
    }
    max_name_ = (version & kExrLongNamesFlag) ? 255 : 31;
    tiled_ = version & kExrTiledFlag;
    for (int part = 0;; ++part) {
      if (part >= kExrMaxParts) return Bad(absl::StrCat("more than ", kExrMaxParts, " parts"));
      SHRM_RETURN_IF_ERROR(WalkPart());
      if (!(version & kExrMultiPartFlag)) return absl::OkStatus();
      if (in_.peek() == 0) return absl::OkStatus();  // the empty header ends the list
      if (in_.peek() == std::char_traits<char>::eof()) return Bad("unterminated list of parts");
    }
  }

 private:
  absl::Status Bad(absl::string_view what) const {
    return absl::InvalidArgumentError(absl::StrCat(path_, ": malformed OpenEXR header: ", what));
  }
  bool ReadU32(uint32_t* v) {
    unsigned char b[4];
    if (!in_.read(reinterpret_cast<char*>(b), 4)) return false;
    *v = b[0] | (b[1] << 8) | (b[2] << 16) | (uint32_t{b[3]} << 24);
    return true;
  }
  bool ReadI32(int32_t* v) {
    uint32_t u = 0;
    if (!ReadU32(&u)) return false;
    *v = static_cast<int32_t>(u);
    return true;
  }
  // A NUL-terminated name of at most max_name_ characters.
  bool ReadName(std::string* out) {
    out->clear();
    for (char c; in_.get(c);) {
      if (c == '\0') return true;
      if (out->size() >= max_name_) return false;
      out->push_back(c);
    }
    return false;
  }
  int64_t Remaining() { return file_bytes_ - static_cast<int64_t>(in_.tellg()); }

  static int FixedSize(const std::string& type) {
    static const std::map<std::string, int> kSizes = {
        {"box2i", 16},    {"box2f", 16},   {"v2i", 8},      {"v2f", 8},
        {"v2d", 16},      {"v3i", 12},     {"v3f", 12},     {"v3d", 24},
        {"int", 4},       {"float", 4},    {"double", 8},   {"compression", 1},
        {"lineOrder", 1}, {"envmap", 1},   {"tiledesc", 9}, {"chromaticities", 32},
        {"m33f", 36},     {"m44f", 64},    {"m33d", 72},    {"m44d", 128},
        {"rational", 8},  {"timecode", 8}, {"keycode", 28}, {"deepImageState", 1}};
    const auto it = kSizes.find(type);
    return it == kSizes.end() ? 0 : it->second;
  }

  // A channel list: entries name\0 + 16 bytes, then an empty name, exactly `size` bytes (OpenEXR
  // reads up to the empty name whatever the size says).
  absl::Status CheckChannelList(const std::string& attr, int32_t size) {
    const int64_t end = static_cast<int64_t>(in_.tellg()) + size;
    std::string channel;
    while (true) {
      if (!ReadName(&channel) || static_cast<int64_t>(in_.tellg()) > end) {
        return Bad(absl::StrCat("attribute '", attr, "': a channel name runs past its size"));
      }
      if (channel.empty()) break;
      in_.seekg(16, std::ios::cur);
      if (static_cast<int64_t>(in_.tellg()) > end) {
        return Bad(
            absl::StrCat("attribute '", attr, "': channel '", channel, "' runs past its size"));
      }
    }
    if (static_cast<int64_t>(in_.tellg()) != end) {
      return Bad(absl::StrCat("attribute '", attr, "': the channel list ends before its size"));
    }
    return absl::OkStatus();
  }

  absl::Status WalkPart() {
    bool deep_type = false, has_window = false;
    int64_t width = 0, height = 0;
    uint32_t tile_x = 0, tile_y = 0;
    bool has_tiles = false;
    std::string name, type;
    while (true) {
      if (!ReadName(&name)) return Bad("unterminated or over-long attribute name");
      if (name.empty()) break;
      if (!ReadName(&type)) return Bad(absl::StrCat("attribute '", name, "': bad type name"));
      int32_t size = 0;
      if (!ReadI32(&size)) return Bad(absl::StrCat("attribute '", name, "': no size"));
      const int64_t remaining = Remaining();
      if (size < 0 || size > remaining) {
        return Bad(absl::StrCat("attribute '", name, "' claims ", size, " bytes, the file has ",
                                remaining, " left"));
      }
      const std::streampos value_start = in_.tellg();
      // OpenEXR reads these types without looking at the size: another size puts it out of step
      // with the file (it then reads text as the next attribute's size).
      if (const int fixed = FixedSize(type); fixed > 0 && size != fixed) {
        return Bad(absl::StrCat("attribute '", name, "' of type ", type, " has ", size,
                                " bytes, not ", fixed));
      }
      if (type == "chlist") SHRM_RETURN_IF_ERROR(CheckChannelList(name, size));
      in_.clear();
      in_.seekg(value_start);
      if (name == "dataWindow" && type == "box2i" && size == 16) {
        int32_t x0, y0, x1, y1;
        if (!ReadI32(&x0) || !ReadI32(&y0) || !ReadI32(&x1) || !ReadI32(&y1))
          return Bad("dataWindow");
        width = int64_t{x1} - x0 + 1;
        height = int64_t{y1} - y0 + 1;
        has_window = true;
      } else if (type == "preview" && size >= 8) {
        uint32_t w = 0, h = 0;
        if (!ReadU32(&w) || !ReadU32(&h)) return Bad("preview");
        if (8 + 4 * uint64_t{w} * h != static_cast<uint64_t>(size)) {
          return Bad(absl::StrCat("preview ", w, " x ", h, " does not fit its ", size, " bytes"));
        }
      } else if (type == "stringvector") {
        for (int64_t left = size; left > 0;) {
          int32_t n = 0;
          if (left < 4 || !ReadI32(&n) || n < 0 || n > left - 4) {
            return Bad(absl::StrCat("attribute '", name, "': a string longer than the attribute"));
          }
          in_.seekg(n, std::ios::cur);
          left -= 4 + int64_t{n};
        }
      } else if (name == "tiles" && type == "tiledesc" && size == 9) {
        if (!ReadU32(&tile_x) || !ReadU32(&tile_y)) return Bad("tiles");
        has_tiles = true;
      } else if (name == "chunkCount" && type == "int" && size == 4) {
        int32_t chunks = 0;
        if (!ReadI32(&chunks) || chunks < 0 || int64_t{chunks} * 8 > file_bytes_) {
          return Bad(absl::StrCat("chunkCount ", chunks, " does not fit the file"));
        }
      } else if (name == "type" && type == "string" && size < 64) {
        std::string value(static_cast<size_t>(size), '\0');
        in_.read(value.data(), size);
        deep_type = value.rfind("deep", 0) == 0;
      }
      in_.clear();
      in_.seekg(value_start + static_cast<std::streamoff>(size));
      if (!in_) return Bad(absl::StrCat("attribute '", name, "' runs past the end"));
    }
    if (deep_type) {
      return absl::InvalidArgumentError(absl::StrCat(path_, ": deep images are not supported"));
    }
    if (!has_window) return absl::OkStatus();  // OpenEXR refuses a header without one
    if (width < 1 || height < 1) {
      return Bad(absl::StrCat("empty or inverted dataWindow (", width, " x ", height, ")"));
    }
    if (width > limits_.max_width || height > limits_.max_height ||
        width * height > limits_.max_pixels) {
      return absl::ResourceExhaustedError(absl::StrCat(
          path_, ": image is ", width, " x ", height, ", above the limits of ", limits_.max_width,
          " x ", limits_.max_height, " and ", limits_.max_pixels, " pixels"));
    }
    if (tiled_ || has_tiles) {
      // Level 0's tile offsets alone (8 bytes each) must fit in the file.
      if (tile_x < 1 || tile_y < 1) return Bad("tiles of zero size");
      const int64_t tiles = ((width + tile_x - 1) / tile_x) * ((height + tile_y - 1) / tile_y);
      if (tiles * 8 > file_bytes_) {
        return Bad(
            absl::StrCat(tiles, " tiles of ", tile_x, " x ", tile_y, " do not fit the file"));
      }
    }
    return absl::OkStatus();
  }

  const std::string& path_;
  const ImageLimits& limits_;
  std::ifstream in_;
  int64_t file_bytes_ = 0;
  size_t max_name_ = 31;
  bool tiled_ = false;
};

}  // namespace

absl::Status CheckExrHeader(const std::string& path, const ImageLimits& limits) {
  return ExrHeaderWalker(path, limits).Walk();
}

absl::Status CheckPngHeader(const std::string& path, const ImageLimits& limits) {
  auto bad = [&](absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": malformed PNG: ", what));
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open"));
  in.seekg(0, std::ios::end);
  const int64_t file_bytes = static_cast<int64_t>(in.tellg());
  in.seekg(0);
  unsigned char b[25];
  if (!in.read(reinterpret_cast<char*>(b), 8)) return bad("shorter than its signature");
  auto u32 = [](const unsigned char* p) {
    return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
  };
  // PNG specification, "Chunk layout": length (at most 2^31 - 1), type, data, CRC; IHDR first.
  for (int64_t at = 8, chunk = 0; at < file_bytes; ++chunk) {
    if (at + 12 > file_bytes) return bad(absl::StrCat("chunk ", chunk, " is cut short"));
    in.seekg(at);
    if (!in.read(reinterpret_cast<char*>(b), 8)) return bad("unreadable chunk header");
    const uint32_t length = u32(b);
    const std::string type(reinterpret_cast<const char*>(b + 4), 4);
    if (length > 0x7FFFFFFFu || at + 12 + int64_t{length} > file_bytes) {
      return bad(absl::StrCat("chunk ", chunk, " ('", absl::CHexEscape(type), "') claims ", length,
                              " bytes, beyond the file's ", file_bytes));
    }
    if (chunk == 0) {
      if (type != "IHDR" || length != 13) return bad("the first chunk is not a 13-byte IHDR");
      if (!in.read(reinterpret_cast<char*>(b), 8)) return bad("unreadable IHDR");
      const int64_t width = u32(b), height = u32(b + 4);
      if (width < 1 || height < 1) return bad("zero width or height");
      if (width > limits.max_width || height > limits.max_height ||
          width * height > limits.max_pixels) {
        return absl::ResourceExhaustedError(absl::StrCat(
            path, ": image is ", width, " x ", height, ", above the limits of ", limits.max_width,
            " x ", limits.max_height, " and ", limits.max_pixels, " pixels"));
      }
    }
    at += 12 + int64_t{length};
    if (type == "IEND") break;
  }
  return absl::OkStatus();
}

namespace {

// The checks of every format before its reader opens the file (format by magic bytes, file size,
// the EXR header walk), then the header from OpenEXR (EXR) or the image module (the others).
absl::StatusOr<ImageHeader> CheckedHeader(const std::string& path, const ImageLimits& limits,
                                          const image_module::Api** module) {
  ImageHeader header;
  SHRM_ASSIGN_OR_RETURN(header.format, DetectImageFormat(path));
  std::error_code ec;
  header.file_bytes = static_cast<int64_t>(std::filesystem::file_size(path, ec));
  if (ec) return absl::NotFoundError(absl::StrCat(path, ": ", ec.message()));
  if (header.file_bytes > limits.max_file_bytes) {
    return absl::ResourceExhaustedError(absl::StrCat(path, ": file is ", header.file_bytes,
                                                     " bytes, above the limit of ",
                                                     limits.max_file_bytes));
  }
  if (header.format == "openexr") {
    SHRM_RETURN_IF_ERROR(CheckExrHeader(path, limits));
    *module = nullptr;
  } else {
    if (header.format == "png") SHRM_RETURN_IF_ERROR(CheckPngHeader(path, limits));
    SHRM_ASSIGN_OR_RETURN(*module, image_module::Get());
  }
  return header;
}

// 8-bit values of an image in [0, 1]: clamped, NaN -> 0, rounded.
std::vector<unsigned char> To8Bit(const Image& image) {
  std::vector<unsigned char> bytes(image.pixels.size());
  for (size_t i = 0; i < bytes.size(); ++i) {
    const float v = image.pixels[i];
    const float c = std::isnan(v) ? 0.0f : std::clamp(v, 0.0f, 1.0f);
    bytes[i] = static_cast<unsigned char>(std::lround(c * 255.0f));
  }
  return bytes;
}

absl::Status CheckConsistent(const Image& image, const std::string& what) {
  if (image.width <= 0 || image.height <= 0 || image.channels <= 0 ||
      image.pixels.size() != static_cast<size_t>(image.width) * image.height * image.channels) {
    return absl::InvalidArgumentError(
        absl::StrCat(what, " (", image.width, " x ", image.height, " x ", image.channels, ")"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<ImageHeader> ProbeImage(const std::string& path, const ImageLimits& limits) {
  const image_module::Api* module = nullptr;
  SHRM_ASSIGN_OR_RETURN(ImageHeader header, CheckedHeader(path, limits, &module));
  if (module == nullptr) {
    SHRM_ASSIGN_OR_RETURN(const ImageHeader exr, exr::Probe(path, limits));
    header.width = exr.width;
    header.height = exr.height;
    header.channels = exr.channels;
  } else {
    SHRM_RETURN_IF_ERROR(module->probe(path, limits, &header));
  }
  return header;
}

absl::StatusOr<Image> ReadImageRgb(const std::string& path, const ImageLimits& limits,
                                   NonFinitePolicy policy) {
  const image_module::Api* module = nullptr;
  SHRM_ASSIGN_OR_RETURN(ImageHeader header, CheckedHeader(path, limits, &module));
  std::vector<float> raw;
  int nc = 0;  // channels in `raw`
  if (module == nullptr) {
    SHRM_ASSIGN_OR_RETURN(raw, exr::ReadChannels(path, limits, &header, &nc));
  } else {
    SHRM_ASSIGN_OR_RETURN(raw, module->read(path, limits, &header, /*unassociated_alpha=*/false));
    nc = header.channels;
  }
  Image img;
  img.width = header.width;
  img.height = header.height;
  img.channels = 3;
  // Three channels already: checked in place and kept (no second copy of the pixels).
  if (nc == 3) {
    img.pixels = std::move(raw);
  } else {
    img.pixels.resize(static_cast<size_t>(img.width) * img.height * 3);
  }
  int64_t bad = 0;
  int64_t first_bad = -1;
  // Three channels read: one branch-free pass counts the non-finite values (exponent bits all
  // set), and only a map that has some takes the per-value pass below.
  if (nc == 3) {
    int64_t count = 0;
    for (const float v : img.pixels) {
      uint32_t bits;
      std::memcpy(&bits, &v, sizeof bits);
      count += (bits & 0x7f800000u) == 0x7f800000u;
    }
    if (count == 0) {
      img.replaced_non_finite = 0;
      return img;
    }
  }
  for (size_t p = 0; p < static_cast<size_t>(img.width) * img.height; ++p) {
    for (int c = 0; c < 3; ++c) {
      float v = nc == 3 ? img.pixels[p * 3 + c] : raw[p * nc + std::min(c, nc >= 3 ? c : 0)];
      if (!std::isfinite(v)) {
        if (first_bad < 0) first_bad = static_cast<int64_t>(p);
        ++bad;
        v = 0.0f;
      }
      img.pixels[p * 3 + c] = v;
    }
  }
  if (bad > 0 && policy == NonFinitePolicy::kReject) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": ", bad,
        " non-finite (NaN/Inf) channel values; first at pixel (x=", first_bad % img.width,
        ", y=", first_bad / img.width, "); fix the image or allow replacing them by 0"));
  }
  img.replaced_non_finite = bad;
  return img;
}

absl::Status WriteExr(const std::string& path, const Image& image) {
  SHRM_RETURN_IF_ERROR(CheckConsistent(image, absl::StrCat(path, ": inconsistent image to write")));
  SHRM_ASSIGN_OR_RETURN(const std::string bytes, exr::EncodeFloat(image));
  return WriteFileAtomically(path, bytes);
}

namespace {

// "png" or "tiff" by the path's extension; nullptr for any other.
const char* Format8Bit(const std::string& path) {
  const std::string ext = absl::AsciiStrToLower(std::filesystem::path(path).extension().string());
  return ext == ".png" ? "png" : (ext == ".tif" || ext == ".tiff") ? "tiff" : nullptr;
}

}  // namespace

absl::Status Check8BitExtension(const std::string& path) {
  if (Format8Bit(path) != nullptr) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(path, ": 8-bit output needs a .png, .tif or .tiff extension"));
}

absl::Status WriteImage8Bit(const std::string& path, const Image& image) {
  SHRM_RETURN_IF_ERROR(Check8BitExtension(path));
  const char* format = Format8Bit(path);
  SHRM_RETURN_IF_ERROR(CheckConsistent(image, absl::StrCat(path, ": inconsistent image to write")));
  const std::vector<unsigned char> bytes = To8Bit(image);
  if (std::string(format) == "png") {
    SHRM_ASSIGN_OR_RETURN(const std::string png,
                          png::Encode8(image.width, image.height, image.channels, bytes));
    return WriteFileAtomically(path, png);
  }
  SHRM_ASSIGN_OR_RETURN(const image_module::Api* module, image_module::Get());
  const std::string tmp = TempPathFor(path);
  if (absl::Status s = module->write8(tmp, image, format, bytes.data()); !s.ok()) {
    DiscardTempFile(tmp);
    return absl::Status(s.code(), absl::StrCat(path, ": ", s.message()));
  }
  return CommitTempFile(tmp, path);
}

absl::StatusOr<std::string> EncodeImage(const Image& image, ImageEncoding encoding) {
  SHRM_RETURN_IF_ERROR(CheckConsistent(image, "inconsistent image to encode"));
  if (encoding == ImageEncoding::kExrFloat) return exr::EncodeFloat(image);
  if (encoding == ImageEncoding::kExrFloatUncompressed)
    return exr::EncodeFloat(image, /*compress=*/false);
  // The values are stored as given (a 4th channel is not taken as premultiplied alpha: RGBD data
  // in the glTF IBL's PNGs is not premultiplied).
  return png::Encode8(image.width, image.height, image.channels, To8Bit(image));
}

Image TonemapPreview(const Image& linear, double exposure) {
  Image encoded = linear;
  const double scale = std::exp2(exposure);
  for (float& v : encoded.pixels) {
    double x = std::max(0.0, static_cast<double>(v)) * scale;
    if (!std::isfinite(x)) x = 0;
    x = x / (1.0 + x);
    v = static_cast<float>(x <= 0.0031308 ? 12.92 * x : 1.055 * std::pow(x, 1 / 2.4) - 0.055);
  }
  return encoded;
}

absl::Status WritePreviewPng(const std::string& path, const Image& linear, double exposure) {
  return WriteImage8Bit(path, TonemapPreview(linear, exposure));
}

}  // namespace shrm
