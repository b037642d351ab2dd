// SHA-256 of files and byte strings (OpenSSL's libcrypto), as lowercase hex. Used to record the
// source of an SHRM file and, in the service, to address uploaded content.
#ifndef SHRM_CORE_IO_SHA256_H_
#define SHRM_CORE_IO_SHA256_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace shrm {

std::string Sha256Hex(std::string_view bytes);
// True for 64 lowercase hex digits (the form hashes travel in: docs/server.md).
bool IsSha256Hex(std::string_view s);

// Incremental SHA-256: Update() with consecutive pieces, then Hex() once (the service hashes
// file chunks as they are sent or received, overlapping the hash with the transfer).
class Sha256Stream {
 public:
  Sha256Stream();
  ~Sha256Stream();
  Sha256Stream(const Sha256Stream&) = delete;
  Sha256Stream& operator=(const Sha256Stream&) = delete;
  void Update(std::string_view bytes);
  // The digest of everything given so far, as lowercase hex; the stream is then spent.
  std::string Hex();

 private:
  void* ctx_;  // EVP_MD_CTX (kept out of the header)
};
// Streams the file in chunks; NotFound / Unavailable errors name the file.
absl::StatusOr<std::string> Sha256OfFile(const std::string& path);

}  // namespace shrm

#endif  // SHRM_CORE_IO_SHA256_H_
