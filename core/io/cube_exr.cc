#include "core/io/cube_exr.h"

#include <OpenImageIO/imageio.h>

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

}  // namespace

absl::Status WriteCubeExr(const std::string& path, const CubeExr& cube) {
  if (cube.face_size < 1 || cube.groups() < 1 || cube.groups() > kMaxGroups ||
      cube.data.size() != cube.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": inconsistent cube to write (face size ", cube.face_size, ", ", cube.groups(),
        " channel groups, ", cube.data.size(), " values, expected ", cube.size(), ")"));
  }
  const std::string tmp = TempPathFor(path);
  auto out = OIIO::ImageOutput::create("openexr");
  if (!out) return absl::InternalError("no OpenImageIO writer for openexr");
  if (!out->supports("multiimage")) {
    return absl::InternalError("OpenImageIO's openexr writer lacks multi-part support");
  }
  const int nch = cube.groups() * 3;
  std::vector<OIIO::ImageSpec> specs;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    OIIO::ImageSpec spec(cube.face_size, cube.face_size, nch,
                         cube.half ? OIIO::TypeDesc::HALF : OIIO::TypeDesc::FLOAT);
    spec.channelnames.clear();
    for (const std::string& g : cube.group_names)
      for (const char* s : kChannelSuffix) spec.channelnames.push_back(g + s);
    spec.attribute("oiio:subimagename", kCubeFaceNames[f]);
    // A fixed capture date keeps the file a pure function of its content (OpenImageIO would
    // stamp the wall-clock time), so equal jobs give byte-identical files.
    spec.attribute("DateTime", "1970:01:01 00:00:00");
    spec.attribute("compression", "none");  // float SH data gains ~4% from ZIP at 2x the write time
    for (const auto& [k, v] : cube.attributes) spec.attribute(k, v);
    specs.push_back(spec);
  }
  auto fail = [&](const std::string& what) {
    DiscardTempFile(tmp);
    return absl::UnavailableError(
        absl::StrCat(path, ": cannot write ", what, ": ", out->geterror()));
  };
  if (!out->open(tmp, kCubeFaceCount, specs.data())) return fail("header");
  const size_t face_values = size_t{1} * cube.face_size * cube.face_size * nch;
  for (int f = 0; f < kCubeFaceCount; ++f) {
    if (f > 0 && !out->open(tmp, specs[f], OIIO::ImageOutput::AppendSubimage))
      return fail(absl::StrCat("face ", kCubeFaceNames[f]));
    if (!out->write_image(OIIO::TypeDesc::FLOAT, cube.data.data() + f * face_values))
      return fail(absl::StrCat("face ", kCubeFaceNames[f]));
  }
  if (!out->close()) return fail("file");
  return CommitTempFile(tmp, path);
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
