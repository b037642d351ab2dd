#include "core/io/cube_exr.h"

#include <Imath/half.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string_view>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"
#include "core/io/exr_file.h"

namespace shrm {
namespace {

constexpr int kMaxGroups = 1024;  // (P + 1)^2 coefficient triples: P <= 31
constexpr const char* kChannelSuffix[3] = {".R", ".G", ".B"};

// OpenEXR file-format constants (openexr.com, "OpenEXR File Layout").
constexpr int32_t kMultipartFlag = 0x1000;
constexpr size_t kMaxShortName = 31;  // names up to 31 bytes without the long-names flag
constexpr int32_t kPixelHalf = 1, kPixelFloat = 2;
// Attributes the writer sets itself for every part.
constexpr std::string_view kReservedAttributes[] = {
    "channels",           "chunkCount",        "compression", "dataWindow",
    "displayWindow",      "lineOrder",         "name",        "pixelAspectRatio",
    "screenWindowCenter", "screenWindowWidth", "type"};

// Little-endian serialization into a string.
class ExrWriter {
 public:
  void Byte(uint8_t b) { bytes_.push_back(static_cast<char>(b)); }
  void Int(int32_t v) { Put(&v, 4); }
  void Uint16(uint16_t v) { Put(&v, 2); }
  void Uint64(uint64_t v) { Put(&v, 8); }
  void Float(float v) { Put(&v, 4); }
  void Raw(const std::string& s) { bytes_ += s; }
  void Str0(const std::string& s) {
    bytes_ += s;
    Byte(0);
  }
  size_t size() const { return bytes_.size(); }
  std::string& bytes() { return bytes_; }
  std::string Take() { return std::move(bytes_); }
  static std::string IntBytes(int32_t v) {
    ExrWriter w;
    w.Int(v);
    return w.Take();
  }
  static std::string FloatBytes(float v) {
    ExrWriter w;
    w.Float(v);
    return w.Take();
  }

 private:
  static_assert(std::endian::native == std::endian::little, "EXR is little-endian");
  void Put(const void* p, size_t n) { bytes_.append(static_cast<const char*>(p), n); }
  std::string bytes_;
};

}  // namespace

absl::Status EncodeCubeExrTo(const CubeExr& cube, const std::string& name,
                             std::span<const float> values,
                             absl::FunctionRef<void(std::string_view)> sink, size_t* total_bytes) {
  const std::span<const float> data =
      cube.data.empty() ? values : std::span<const float>(cube.data);
  if (cube.face_size < 1 || cube.groups() < 1 || cube.groups() > kMaxGroups ||
      data.size() != cube.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ": inconsistent cube to write (face size ", cube.face_size, ", ", cube.groups(),
        " channel groups, ", data.size(), " values, expected ", cube.size(), ")"));
  }
  for (const auto& [k, v] : cube.attributes) {
    if (k.empty() || k.size() > kMaxShortName || k.find('\0') != std::string::npos ||
        std::find(std::begin(kReservedAttributes), std::end(kReservedAttributes), k) !=
            std::end(kReservedAttributes)) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, ": attribute name '", k, "' is empty, too long or reserved"));
    }
  }
  // The OpenEXR 2 multi-part scanline layout (openexr.com, "OpenEXR File Layout"), written
  // directly: OpenEXR's writer posts every uncompressed line as a task to its global thread
  // pool once OpenImageIO has sized it, which cost 5-10 ms per 1.2 MB file in the service
  // against ~0.3 ms here. The file is a pure function of the cube (no date or software stamp),
  // so equal jobs give byte-identical files; OpenImageIO and OpenEXR read it (tests).
  const int s = cube.face_size;
  const int groups = cube.groups();
  const int value_bytes = cube.half ? 2 : 4;
  // Channels in the file's order (sorted by name, as OpenEXR lists them): the value offset of
  // each within a texel's group-major RGB block.
  std::map<std::string, int> channels;
  for (int g = 0; g < groups; ++g)
    for (int c = 0; c < 3; ++c) channels[cube.group_names[g] + kChannelSuffix[c]] = g * 3 + c;
  if (channels.size() != static_cast<size_t>(groups) * 3) {
    return absl::InvalidArgumentError(absl::StrCat(name, ": duplicate channel group names"));
  }
  for (const auto& [ch, offset] : channels) {
    if (ch.size() > kMaxShortName) {
      return absl::InvalidArgumentError(absl::StrCat(name, ": channel name '", ch, "' too long"));
    }
  }
  const size_t line_bytes = size_t{1} * s * channels.size() * value_bytes;

  ExrWriter out;
  out.Int(20000630);            // magic
  out.Int(2 | kMultipartFlag);  // version 2, multi-part, short names
  for (int f = 0; f < kCubeFaceCount; ++f) {
    // Attributes in name order (as OpenEXR writes them); the part's own, then the cube's.
    std::map<std::string, std::pair<std::string, std::string>> attrs;  // name -> (type, bytes)
    ExrWriter v;
    for (const auto& [ch, offset] : channels) {
      v.Str0(ch);
      v.Int(cube.half ? kPixelHalf : kPixelFloat);
      v.Int(0);  // pLinear (1 byte) + 3 reserved bytes
      v.Int(1);  // x sampling
      v.Int(1);  // y sampling
    }
    v.Byte(0);
    attrs["channels"] = {"chlist", v.Take()};
    attrs["chunkCount"] = {"int", ExrWriter::IntBytes(s)};  // one line per chunk (uncompressed)
    attrs["compression"] = {"compression", std::string(1, '\0')};  // NO_COMPRESSION
    const std::string box = ExrWriter::IntBytes(0) + ExrWriter::IntBytes(0) +
                            ExrWriter::IntBytes(s - 1) + ExrWriter::IntBytes(s - 1);
    attrs["dataWindow"] = {"box2i", box};
    attrs["displayWindow"] = {"box2i", box};
    attrs["lineOrder"] = {"lineOrder", std::string(1, '\0')};  // INCREASING_Y
    attrs["name"] = {"string", kCubeFaceNames[f]};
    attrs["pixelAspectRatio"] = {"float", ExrWriter::FloatBytes(1)};
    attrs["screenWindowCenter"] = {"v2f", ExrWriter::FloatBytes(0) + ExrWriter::FloatBytes(0)};
    attrs["screenWindowWidth"] = {"float", ExrWriter::FloatBytes(1)};
    attrs["type"] = {"string", "scanlineimage"};
    for (const auto& [k, val] : cube.attributes) attrs[k] = {"string", val};
    for (const auto& [k, tv] : attrs) {
      out.Str0(k);
      out.Str0(tv.first);
      out.Int(static_cast<int32_t>(tv.second.size()));
      out.Raw(tv.second);
    }
    out.Byte(0);  // end of this part's header
  }
  out.Byte(0);  // end of the headers
  // Offset tables (every chunk's position), then the chunks: part, y, size, the line's values
  // channel by channel.
  const size_t chunk_bytes = 12 + line_bytes;
  const size_t first_chunk = out.size() + size_t{8} * kCubeFaceCount * s;
  for (int f = 0; f < kCubeFaceCount; ++f)
    for (int y = 0; y < s; ++y) out.Uint64(first_chunk + (size_t{1} * f * s + y) * chunk_bytes);
  const size_t texel_values = size_t{1} * groups * 3;
  if (total_bytes != nullptr)
    *total_bytes = first_chunk + size_t{1} * kCubeFaceCount * s * chunk_bytes;
  sink(out.bytes());
  // The chunks, a run of lines at a time (about 1 MB) through one reused buffer.
  const size_t lines_per_piece = std::max<size_t>(1, (size_t{1} << 20) / chunk_bytes);
  std::string piece(std::min(lines_per_piece, size_t{1} * kCubeFaceCount * s) * chunk_bytes, '\0');
  size_t pos = 0;
  auto put = [&](const void* p, size_t n) {
    std::memcpy(piece.data() + pos, p, n);
    pos += n;
  };
  for (int f = 0; f < kCubeFaceCount; ++f) {
    for (int y = 0; y < s; ++y) {
      const int32_t head[3] = {f, y, static_cast<int32_t>(line_bytes)};
      put(head, sizeof(head));
      const float* row = data.data() + (size_t{1} * f * s + y) * s * texel_values;
      for (const auto& [ch, offset] : channels) {
        for (int x = 0; x < s; ++x) {
          const float value = row[x * texel_values + offset];
          if (cube.half) {
            const uint16_t bits = Imath::half(value).bits();
            put(&bits, 2);
          } else {
            put(&value, 4);
          }
        }
      }
      if (pos + chunk_bytes > piece.size()) {
        sink(std::string_view(piece.data(), pos));
        pos = 0;
      }
    }
  }
  if (pos > 0) sink(std::string_view(piece.data(), pos));
  return absl::OkStatus();
}

absl::StatusOr<std::string> EncodeCubeExr(const CubeExr& cube, const std::string& name,
                                          std::span<const float> values) {
  std::string bytes;
  size_t total = 0;
  SHRM_RETURN_IF_ERROR(EncodeCubeExrTo(
      cube, name, values,
      [&](std::string_view piece) {
        if (bytes.empty()) bytes.reserve(total);  // one allocation, not zero-filled
        bytes.append(piece);
      },
      &total));
  return bytes;
}

absl::Status WriteCubeExr(const std::string& path, const CubeExr& cube,
                          std::span<const float> values) {
  AtomicFileWriter out(path);
  SHRM_RETURN_IF_ERROR(
      EncodeCubeExrTo(cube, path, values, [&](std::string_view piece) { out.Append(piece); }));
  return out.Commit();
}

absl::StatusOr<CubeExr> ReadCubeExr(const std::string& path, const ImageLimits& limits) {
  SHRM_ASSIGN_OR_RETURN(const std::string format, DetectImageFormat(path));
  if (format != "openexr") {
    return absl::InvalidArgumentError(absl::StrCat(path, ": not an OpenEXR file (", format, ")"));
  }
  std::error_code ec;
  const auto bytes = std::filesystem::file_size(path, ec);
  if (ec) return absl::NotFoundError(absl::StrCat(path, ": ", ec.message()));
  if (static_cast<int64_t>(bytes) > limits.max_file_bytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat(path, ": file is ", bytes, " bytes, above the limit"));
  }
  SHRM_RETURN_IF_ERROR(CheckExrHeader(path, limits));
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<exr::PartReader> reader,
                        exr::PartReader::Open(path, limits, kCubeFaceCount, 3 * kMaxGroups));
  const std::vector<exr::PartInfo>& parts = reader->parts();
  if (parts.size() < static_cast<size_t>(kCubeFaceCount)) {
    // An environment map (one part) given where an SHRM or a cube of six parts is read.
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": not a cube file: it has ", parts.size(), " part", parts.size() == 1 ? "" : "s",
        ", a cube file (an SHRM: docs/formats.md) has the six faces as parts (face ",
        kCubeFaceNames[parts.size()], " missing)"));
  }
  const exr::PartInfo& first = parts[0];
  CubeExr cube;
  cube.face_size = first.width;
  // Channel groups in the order OpenImageIO lists them (by layer name, then R, G, B), each of
  // which must be a complete RGB triple.
  const std::vector<std::string> ordered = exr::OrderedChannels(first.channels);
  const int nch = static_cast<int>(ordered.size());
  if (first.width != first.height || first.width < 1 || first.width > limits.max_width ||
      int64_t{6} * first.width * first.width > limits.max_pixels || nch % 3 != 0 ||
      nch / 3 > kMaxGroups) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not an SHRM cube part (", first.width, " x ", first.height, ", ", nch,
                     " channels; expected square faces and RGB channel triples)"));
  }
  for (int g = 0; g < nch / 3; ++g) {
    const std::string& name = ordered[g * 3];
    if (!absl::EndsWith(name, ".R")) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": channel ", name, " is not the R channel of a triple"));
    }
    const std::string group = name.substr(0, name.size() - 2);
    for (int c = 1; c < 3; ++c) {
      if (ordered[g * 3 + c] != group + kChannelSuffix[c]) {
        return absl::InvalidArgumentError(absl::StrCat(path, ": channel ", ordered[g * 3 + c],
                                                       " where ", group, kChannelSuffix[c],
                                                       " was expected"));
      }
    }
    cube.group_names.push_back(group);
  }
  for (const auto& [k, v] : first.string_attributes) {
    if (absl::StartsWith(k, "shrm:")) cube.attributes[k] = v;
  }
  cube.data.resize(cube.size());
  const size_t face_values = size_t{1} * cube.face_size * cube.face_size * nch;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    if (parts[f].width != cube.face_size || parts[f].height != cube.face_size ||
        exr::OrderedChannels(parts[f].channels) != ordered) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": part ", f, " differs in size or channels from part 0"));
    }
    std::vector<exr::ChannelDestination> dest;
    for (int c = 0; c < nch; ++c) {
      dest.push_back({ordered[c], cube.data.data() + f * face_values + c, static_cast<size_t>(nch),
                      static_cast<size_t>(nch) * cube.face_size});
    }
    SHRM_RETURN_IF_ERROR(reader->Read(f, dest));
  }
  return cube;
}

}  // namespace shrm
