#include "core/io/atomic_file.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"

namespace shrm {

std::string TempPathFor(const std::string& path) {
  // Keep the extension last so that writers choosing the format by extension still can.
  const std::filesystem::path p(path);
  return (p.parent_path() /
          absl::StrCat(p.stem().string(), ".tmp-", ::getpid(), p.extension().string()))
      .string();
}

void DiscardTempFile(const std::string& tmp) {
  std::error_code ec;
  std::filesystem::remove(tmp, ec);
}

absl::Status CommitTempFile(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    DiscardTempFile(tmp);
    return absl::UnavailableError(absl::StrCat(path, ": cannot rename into place: ", ec.message()));
  }
  return absl::OkStatus();
}

absl::Status WriteFileAtomically(const std::string& path, std::string_view bytes) {
  const std::string tmp = TempPathFor(path);
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      DiscardTempFile(tmp);
      return absl::UnavailableError(absl::StrCat(path, ": cannot write"));
    }
  }
  return CommitTempFile(tmp, path);
}

}  // namespace shrm
