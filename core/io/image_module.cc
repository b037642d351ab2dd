#include "core/io/image_module.h"

#include <dlfcn.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace shrm::image_module {
namespace {

std::atomic<bool> loaded{false};

}  // namespace

std::vector<std::string> SearchDirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("SHRM_MODULE_DIR"); env != nullptr && env[0] != '\0') {
    dirs.emplace_back(env);
  }
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path prefix = exe.parent_path().parent_path();
    dirs.push_back((prefix / "lib" / "shrm").string());
    dirs.push_back((prefix / SHRM_INSTALL_LIBDIR / "shrm").string());
  }
  dirs.emplace_back(SHRM_INSTALL_FULL_LIBDIR "/shrm");
  return dirs;
}

namespace {

struct LoadResult {
  const Api* api = nullptr;
  absl::Status status;
};

LoadResult Load() {
  std::vector<std::string> tried;
  for (const std::string& dir : SearchDirs()) {
    const std::string path = absl::StrCat(dir, "/", kFileName);
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      tried.push_back(absl::StrCat(path, " (not found)"));
      continue;
    }
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      const char* why = dlerror();
      tried.push_back(absl::StrCat(path, " (", why != nullptr ? why : "dlopen failed", ")"));
      continue;
    }
    using EntryPoint = const Api* (*)();
    auto entry = reinterpret_cast<EntryPoint>(dlsym(handle, kEntryPoint));
    const Api* api = entry != nullptr ? entry() : nullptr;
    if (api == nullptr || api->abi_version != kAbiVersion) {
      tried.push_back(absl::StrCat(path, " (not this build's module: interface version ",
                                   api != nullptr ? api->abi_version : -1, ", expected ",
                                   kAbiVersion, ")"));
      dlclose(handle);
      continue;
    }
    return {api, absl::OkStatus()};  // kept loaded for the life of the process
  }
  return {nullptr,
          absl::FailedPreconditionError(absl::StrCat(
              "the OpenImageIO/OpenColorIO module of shrm (", kFileName,
              ", needed for this image format or colour conversion) cannot be loaded; tried: ",
              absl::StrJoin(tried, "; "), ". Reinstall shrm or set SHRM_MODULE_DIR"))};
}

}  // namespace

absl::StatusOr<const Api*> Get() {
  static const LoadResult* const result = [] {
    auto* r = new LoadResult(Load());
    loaded.store(r->api != nullptr);
    return r;
  }();
  if (result->api == nullptr) return result->status;
  return result->api;
}

bool Loaded() { return loaded.load(); }

}  // namespace shrm::image_module
