// SHA-256 of files and byte strings (FIPS 180-4; the x86 SHA extensions where present), as
// lowercase hex. Used to record the source of an SHRM file and, in the service, to address
// uploaded content.
#ifndef SHRM_CORE_IO_SHA256_H_
#define SHRM_CORE_IO_SHA256_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace shrm {
namespace internal {

// The hash itself; `extensions` = false keeps to the portable code (the tests check both).
class Sha256 {
 public:
  explicit Sha256(bool extensions = true);
  void Update(std::string_view bytes);
  // The digest of everything given so far; the object is then spent.
  std::array<unsigned char, 32> Digest();

 private:
  uint32_t state_[8];
  unsigned char block_[64];
  size_t held_ = 0;     // bytes of block_ waiting for a whole block
  uint64_t total_ = 0;  // bytes given
  bool extensions_;
};

// True when this CPU has the SHA extensions (and SSSE3, SSE4.1) that Sha256 uses.
bool Sha256HasExtensions();
// `blocks` 64-byte blocks into `state` (the compression function).
void Sha256Blocks(uint32_t state[8], const unsigned char* data, size_t blocks, bool extensions);
std::string HexDigest(const std::array<unsigned char, 32>& digest);

}  // namespace internal

std::string Sha256Hex(std::string_view bytes);
// True for 64 lowercase hex digits (the form hashes travel in: docs/server.md).
bool IsSha256Hex(std::string_view s);

// Incremental SHA-256: Update() with consecutive pieces, then Hex() once (the service hashes
// file chunks as they are sent or received, overlapping the hash with the transfer).
class Sha256Stream {
 public:
  Sha256Stream() = default;
  Sha256Stream(const Sha256Stream&) = delete;
  Sha256Stream& operator=(const Sha256Stream&) = delete;
  void Update(std::string_view bytes);
  // The digest of everything given so far, as lowercase hex; the stream is then spent.
  std::string Hex();

 private:
  internal::Sha256 hash_;
};
// Streams the file in chunks; NotFound / Unavailable errors name the file.
absl::StatusOr<std::string> Sha256OfFile(const std::string& path);

}  // namespace shrm

#endif  // SHRM_CORE_IO_SHA256_H_
