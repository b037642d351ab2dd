// libshrm_imageio.so: the OpenImageIO and OpenColorIO half of shrm_io (image_module.h). Every
// OpenImageIO / OpenColorIO exception is caught here and returned as an absl::Status.
#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "core/io/image_module.h"

namespace shrm::image_module {
namespace {

namespace OCIO = OCIO_NAMESPACE;

// ---- OpenImageIO ------------------------------------------------------------------------------

absl::StatusOr<std::unique_ptr<OIIO::ImageInput>> OpenChecked(const std::string& path,
                                                              const ImageLimits& limits,
                                                              ImageHeader* header,
                                                              OIIO::ImageSpec* spec_out,
                                                              bool unassociated_alpha = false) {
  static std::once_flag once;
  std::call_once(once, [] {
    // Never let an unexpected file reach a reader other than the one its magic bytes select.
    OIIO::attribute("try_all_readers", 0);
  });
  auto in = OIIO::ImageInput::create(header->format);
  if (!in) {
    return absl::InternalError(
        absl::StrCat(path, ": no OpenImageIO reader for format ", header->format));
  }
  OIIO::ImageSpec spec;
  OIIO::ImageSpec config;
  if (unassociated_alpha) config.attribute("oiio:UnassociatedAlpha", 1);
  if (!in->open(path, spec, config)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": cannot read ", header->format, " header: ", in->geterror()));
  }
  header->width = spec.width;
  header->height = spec.height;
  header->channels = spec.nchannels;
  if (spec.deep) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": deep images are not supported"));
  }
  if (in->seek_subimage(1, 0)) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": multi-part/multi-subimage files are not supported"));
  }
  in->seek_subimage(0, 0);
  if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": invalid dimensions ", spec.width, " x ",
                                                   spec.height, " x ", spec.depth));
  }
  if (spec.width > limits.max_width || spec.height > limits.max_height ||
      int64_t{spec.width} * spec.height > limits.max_pixels) {
    return absl::ResourceExhaustedError(absl::StrCat(
        path, ": image is ", spec.width, " x ", spec.height, ", above the limits of ",
        limits.max_width, " x ", limits.max_height, " and ", limits.max_pixels, " pixels"));
  }
  if (spec.nchannels < 1 || spec.nchannels > 64) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": unsupported channel count ", spec.nchannels));
  }
  if (spec_out != nullptr) *spec_out = spec;
  return in;
}

absl::Status Probe(const std::string& path, const ImageLimits& limits, ImageHeader* header) {
  SHRM_ASSIGN_OR_RETURN(auto in, OpenChecked(path, limits, header, nullptr));
  in->close();
  return absl::OkStatus();
}

absl::StatusOr<std::vector<float>> Read(const std::string& path, const ImageLimits& limits,
                                        ImageHeader* header, bool unassociated_alpha) {
  SHRM_ASSIGN_OR_RETURN(auto in, OpenChecked(path, limits, header, nullptr, unassociated_alpha));
  std::vector<float> raw(static_cast<size_t>(header->width) * header->height * header->channels);
  if (!in->read_image(0, 0, 0, header->channels, OIIO::TypeDesc::FLOAT, raw.data())) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": cannot decode pixels: ", in->geterror()));
  }
  in->close();
  return raw;
}

absl::StatusOr<bool> IsFloat(const std::string& path, const ImageLimits& limits,
                             const std::string& format) {
  ImageHeader header;
  header.format = format;
  OIIO::ImageSpec spec;
  SHRM_ASSIGN_OR_RETURN(auto in, OpenChecked(path, limits, &header, &spec));
  in->close();
  const auto base = static_cast<OIIO::TypeDesc::BASETYPE>(spec.format.basetype);
  return base == OIIO::TypeDesc::HALF || base == OIIO::TypeDesc::FLOAT ||
         base == OIIO::TypeDesc::DOUBLE;
}

absl::Status Write8(const std::string& path, const Image& image, const std::string& format,
                    const unsigned char* bytes) {
  auto out = OIIO::ImageOutput::create(format);
  if (!out) return absl::InternalError(absl::StrCat("no OpenImageIO writer for ", format));
  OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
  // A fixed capture date (OpenImageIO would stamp the wall-clock time into TIFF headers): equal
  // pixels give byte-identical files, so pipelines can compare outputs by hash.
  spec.attribute("DateTime", "1970:01:01 00:00:00");
  spec.attribute("oiio:UnassociatedAlpha", 1);
  if (!out->open(path, spec) || !out->write_image(OIIO::TypeDesc::UINT8, bytes) || !out->close()) {
    return absl::UnavailableError(absl::StrCat(path, ": cannot write: ", out->geterror()));
  }
  return absl::OkStatus();
}

// ---- OpenColorIO ------------------------------------------------------------------------------

absl::StatusOr<OCIO::ConstConfigRcPtr> GetConfig(const std::string& file, const std::string& source,
                                                 std::string_view builtin_text) {
  static std::mutex mu;
  static auto* cache = new std::map<std::string, OCIO::ConstConfigRcPtr>();
  std::lock_guard<std::mutex> lock(mu);
  auto it = cache->find(file);
  if (it != cache->end()) return it->second;
  OCIO::ConstConfigRcPtr config;
  try {
    if (file.empty()) {
      std::istringstream in{std::string(builtin_text)};
      config = OCIO::Config::CreateFromStream(in);
    } else {
      if (!std::filesystem::exists(file)) {
        return absl::NotFoundError(absl::StrCat(file, ": OpenColorIO config not found"));
      }
      config = OCIO::Config::CreateFromFile(file.c_str());
    }
    config->validate();
  } catch (const OCIO::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": invalid OpenColorIO config: ", e.what()));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": cannot load OpenColorIO config: ", e.what()));
  }
  (*cache)[file] = config;
  return config;
}

std::vector<std::string> SpaceNames(const OCIO::ConstConfigRcPtr& config) {
  std::vector<std::string> names;
  const int n = config->getNumColorSpaces(OCIO::SEARCH_REFERENCE_SPACE_ALL, OCIO::COLORSPACE_ALL);
  for (int i = 0; i < n; ++i) {
    names.emplace_back(config->getColorSpaceNameByIndex(OCIO::SEARCH_REFERENCE_SPACE_ALL,
                                                        OCIO::COLORSPACE_ALL, i));
  }
  return names;
}

absl::StatusOr<OCIO::ConstColorSpaceRcPtr> FindSpace(const OCIO::ConstConfigRcPtr& config,
                                                     const std::string& name,
                                                     const std::string& source) {
  OCIO::ConstColorSpaceRcPtr space;
  try {
    space = config->getColorSpace(name.c_str());
  } catch (const OCIO::Exception&) {
    space = nullptr;
  }
  if (!space) {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown colour space '", name, "' (config ", source,
                     "); valid names: ", absl::StrJoin(SpaceNames(config), ", ")));
  }
  return space;
}

absl::StatusOr<std::vector<std::string>> ListColourSpaces(const std::string& file,
                                                          const std::string& source,
                                                          std::string_view builtin_text) {
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstConfigRcPtr config, GetConfig(file, source, builtin_text));
  try {
    return SpaceNames(config);
  } catch (const OCIO::Exception& e) {
    return absl::InternalError(absl::StrCat("OpenColorIO: ", e.what()));
  }
}

absl::Status ConvertColourSpace(std::span<float> rgb, const std::string& from,
                                const std::string& to, const std::string& file,
                                const std::string& source, std::string_view builtin_text) {
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstConfigRcPtr config, GetConfig(file, source, builtin_text));
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstColorSpaceRcPtr src, FindSpace(config, from, source));
  SHRM_ASSIGN_OR_RETURN(OCIO::ConstColorSpaceRcPtr dst, FindSpace(config, to, source));
  if (std::string(src->getName()) == dst->getName() || rgb.empty()) return absl::OkStatus();
  try {
    OCIO::ConstProcessorRcPtr processor = config->getProcessor(src, dst);
    if (processor->isNoOp()) return absl::OkStatus();
    OCIO::ConstCPUProcessorRcPtr cpu = processor->getDefaultCPUProcessor();
    // Rows of at most 2^20 pixels keep the image description's sizes small.
    constexpr size_t kRow = size_t{1} << 20;
    const size_t pixels = rgb.size() / 3;
    for (size_t start = 0; start < pixels; start += kRow) {
      const size_t n = std::min(kRow, pixels - start);
      OCIO::PackedImageDesc desc(rgb.data() + start * 3, static_cast<long>(n), 1, 3);
      cpu->apply(desc);
    }
  } catch (const OCIO::Exception& e) {
    return absl::InvalidArgumentError(absl::StrCat("cannot convert from '", from, "' to '", to,
                                                   "' (config ", source, "): ", e.what()));
  }
  return absl::OkStatus();
}

constexpr Api kApi{kAbiVersion, Probe, Read, IsFloat, Write8, ListColourSpaces, ConvertColourSpace};

}  // namespace
}  // namespace shrm::image_module

extern "C" __attribute__((visibility("default"))) const shrm::image_module::Api*
shrm_imageio_api() {
  return &shrm::image_module::kApi;
}
