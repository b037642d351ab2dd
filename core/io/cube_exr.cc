#include "core/io/cube_exr.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenImageIO/imageio.h>

#include <cstring>
#include <exception>
#include <filesystem>
#include <memory>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/io/atomic_file.h"

namespace shrm {
namespace {

constexpr int kMaxGroups = 1024;  // (P + 1)^2 coefficient triples: P <= 31
constexpr const char* kChannelSuffix[3] = {".R", ".G", ".B"};

// An OpenEXR output stream into a string (seekable: the writer patches its offset tables).
class MemoryOStream final : public Imf::OStream {
 public:
  explicit MemoryOStream(size_t reserve) : Imf::OStream("memory") { bytes_.reserve(reserve); }
  void write(const char c[], int n) override {
    if (pos_ + n > bytes_.size()) bytes_.resize(pos_ + n);
    std::memcpy(bytes_.data() + pos_, c, n);
    pos_ += n;
  }
  uint64_t tellp() override { return pos_; }
  void seekp(uint64_t pos) override { pos_ = pos; }
  std::string Take() { return std::move(bytes_); }

 private:
  std::string bytes_;
  uint64_t pos_ = 0;
};

}  // namespace

absl::StatusOr<std::string> EncodeCubeExr(const CubeExr& cube, const std::string& name) {
  if (cube.face_size < 1 || cube.groups() < 1 || cube.groups() > kMaxGroups ||
      cube.data.size() != cube.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        name, ": inconsistent cube to write (face size ", cube.face_size, ", ", cube.groups(),
        " channel groups, ", cube.data.size(), " values, expected ", cube.size(), ")"));
  }
  // OpenEXR directly, into memory: OpenImageIO 2.4 cannot write multi-part files to a memory
  // proxy, and the service sends the bytes rather than writing and reading back a file. The
  // file is a pure function of the cube (no date or software stamp), so equal jobs give
  // byte-identical files.
  const int s = cube.face_size;
  const int nch = cube.groups() * 3;
  const Imf::PixelType type = cube.half ? Imf::HALF : Imf::FLOAT;
  std::vector<Imf::Header> headers;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    Imf::Header h(s, s);
    h.setName(kCubeFaceNames[f]);
    h.setType(Imf::SCANLINEIMAGE);
    h.compression() = Imf::NO_COMPRESSION;  // float SH data gains ~4% from ZIP at 2x the time
    for (const std::string& g : cube.group_names)
      for (const char* c : kChannelSuffix) h.channels().insert(g + c, Imf::Channel(type));
    for (const auto& [k, v] : cube.attributes) h.insert(k, Imf::StringAttribute(v));
    headers.push_back(std::move(h));
  }
  try {
    MemoryOStream stream(size_t{1} * cube.data.size() * (cube.half ? 2 : 4));
    // OpenEXR converts pixel types only when reading: half output needs half input.
    std::vector<Imath::half> halves;
    if (cube.half) halves.assign(cube.data.begin(), cube.data.end());
    const size_t value_bytes = cube.half ? sizeof(Imath::half) : sizeof(float);
    char* base = cube.half ? reinterpret_cast<char*>(halves.data())
                           : reinterpret_cast<char*>(const_cast<float*>(cube.data.data()));
    {
      Imf::MultiPartOutputFile file(stream, headers.data(), kCubeFaceCount);
      const size_t x_stride = value_bytes * nch;
      for (int f = 0; f < kCubeFaceCount; ++f) {
        char* face = base + value_bytes * f * s * s * nch;
        Imf::FrameBuffer fb;
        for (int g = 0; g < cube.groups(); ++g) {
          for (int c = 0; c < 3; ++c) {
            fb.insert(cube.group_names[g] + kChannelSuffix[c],
                      Imf::Slice(type, face + value_bytes * (g * 3 + c), x_stride, x_stride * s));
          }
        }
        Imf::OutputPart part(file, f);
        part.setFrameBuffer(fb);
        part.writePixels(s);
      }
    }
    return stream.Take();
  } catch (const std::exception& e) {
    return absl::InternalError(absl::StrCat(name, ": cannot encode the EXR: ", e.what()));
  }
}

absl::Status WriteCubeExr(const std::string& path, const CubeExr& cube) {
  SHRM_ASSIGN_OR_RETURN(std::string bytes, EncodeCubeExr(cube, path));
  return WriteFileAtomically(path, bytes);
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
  auto in = OIIO::ImageInput::create("openexr");
  if (!in) return absl::InternalError("no OpenImageIO reader for openexr");
  OIIO::ImageSpec spec;
  if (!in->open(path, spec)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": cannot read header: ", in->geterror()));
  }
  CubeExr cube;
  cube.face_size = spec.width;
  const int nch = spec.nchannels;
  if (spec.deep || spec.width != spec.height || spec.width < 1 || spec.width > limits.max_width ||
      int64_t{6} * spec.width * spec.width > limits.max_pixels || nch % 3 != 0 ||
      nch / 3 > kMaxGroups) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not an SHRM cube part (", spec.width, " x ", spec.height, ", ", nch,
                     " channels; expected square faces and RGB channel triples)"));
  }
  for (int g = 0; g < nch / 3; ++g) {
    const std::string& name = spec.channelnames[g * 3];
    if (!absl::EndsWith(name, ".R")) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": channel ", name, " is not the R channel of a triple"));
    }
    cube.group_names.push_back(name.substr(0, name.size() - 2));
  }
  for (const OIIO::ParamValue& p : spec.extra_attribs) {
    if (absl::StartsWith(p.name().string(), "shrm:") && p.type() == OIIO::TypeDesc::STRING)
      cube.attributes[p.name().string()] = p.get_string();
  }
  cube.data.resize(cube.size());
  const size_t face_values = size_t{1} * cube.face_size * cube.face_size * nch;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    if (!in->seek_subimage(f, 0, spec)) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": has fewer than 6 parts (face ", kCubeFaceNames[f], " missing)"));
    }
    if (spec.deep || spec.width != cube.face_size || spec.height != cube.face_size ||
        spec.nchannels != nch) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": part ", f, " differs in size or channels from part 0"));
    }
    if (!in->read_image(f, 0, 0, nch, OIIO::TypeDesc::FLOAT, cube.data.data() + f * face_values)) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ": cannot decode face ", kCubeFaceNames[f], ": ", in->geterror()));
    }
  }
  if (in->seek_subimage(kCubeFaceCount, 0)) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": has more than 6 parts"));
  }
  in->close();
  return cube;
}

}  // namespace shrm
