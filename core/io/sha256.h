// SHA-256 of files and byte strings (OpenSSL's libcrypto), as lowercase hex. Used to record the
// source of an SHRM file and, in the service, to address uploaded content.
#ifndef SHRM_CORE_IO_SHA256_H_
#define SHRM_CORE_IO_SHA256_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace shrm {

std::string Sha256Hex(std::string_view bytes);
// Streams the file in chunks; NotFound / Unavailable errors name the file.
absl::StatusOr<std::string> Sha256OfFile(const std::string& path);

}  // namespace shrm

#endif  // SHRM_CORE_IO_SHA256_H_
