// Content-addressed blob store: a spool directory of files named by their SHA-256 (lowercase
// hex), so that core's EnvMap::Load reads them by path. Uploads go to `<dir>/incoming/` and are
// renamed into place only after their hash is verified. The total size is bounded: least recently
// used blobs are evicted, except those pinned by a running job (BlobStore::Pin).
//
// Disk trouble (docs/server.md, "Disk"): a write that finds the disk full (ENOSPC, EDQUOT) or a
// file-size limit (EFBIG) fails the upload with RESOURCE_EXHAUSTED (reason SPOOL_FULL, with a
// RetryInfo) and leaves nothing behind. A stored blob is hashed again before it is served when
// it has not been verified by this process (found at startup) or its size or modification time
// changed since; one whose bytes no longer match its name is deleted and reported missing
// (NOT_FOUND, reason BLOB_NOT_FOUND: clients upload it again).
#ifndef SHRM_SERVER_BLOB_STORE_H_
#define SHRM_SERVER_BLOB_STORE_H_

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/sha256.h"

namespace shrm::server {

class BlobStore {
 public:
  // A blob kept from eviction while the lease lives.
  class Lease {
   public:
    Lease(BlobStore* store, std::string sha256, std::string path);
    ~Lease();
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    const std::string& path() const { return path_; }
    const std::string& sha256() const { return sha256_; }

   private:
    BlobStore* store_;
    std::string sha256_, path_;
  };

  // An upload in progress: bytes appended to a private temporary file.
  class Upload {
   public:
    ~Upload();  // removes the temporary file unless committed
    absl::Status Append(std::string_view bytes);
    uint64_t size() const { return size_; }

   private:
    friend class BlobStore;
    Upload() = default;
    std::string tmp_path_;
    int fd_ = -1;
    uint64_t size_ = 0;
    bool committed_ = false;
  };

  // Creates `dir` (and dir/incoming) if needed and indexes the blobs already there.
  static absl::StatusOr<std::unique_ptr<BlobStore>> Open(const std::string& dir,
                                                         uint64_t max_total_bytes);

  // Size of a stored blob, or nullopt.
  std::optional<uint64_t> Size(const std::string& sha256);
  // Pins a stored blob, verifying it first when needed (see above); NotFound (BLOB_NOT_FOUND)
  // naming the hash when absent or dropped as corrupt.
  absl::StatusOr<std::unique_ptr<Lease>> Pin(const std::string& sha256);

  absl::StatusOr<std::unique_ptr<Upload>> BeginUpload();
  // Verifies the SHA-256 of the upload against `expected` (InvalidArgument on a mismatch), moves
  // it into place and evicts as needed. Returns the hash.
  absl::StatusOr<std::string> Commit(Upload* upload, const std::string& expected);

  // A fresh temporary path inside the spool (for outputs); the caller removes it.
  std::string TempPath(std::string_view suffix);

  uint64_t total_bytes();
  const std::string& dir() const { return dir_; }

 private:
  struct Entry {
    uint64_t size = 0;
    int pins = 0;
    std::list<std::string>::iterator lru;
    bool verified = false;  // hashed by this process (at upload or at a pin)
    int64_t mtime_ns = 0;   // of the file when verified
  };
  BlobStore(std::string dir, uint64_t max_total_bytes)
      : dir_(std::move(dir)), max_total_bytes_(max_total_bytes) {}
  std::string PathOf(const std::string& sha256) const { return dir_ + "/" + sha256; }
  void Unpin(const std::string& sha256);
  void EvictLocked();
  // Removes a blob whose bytes do not match its name (file and entry).
  void DropLocked(const std::string& sha256);

  const std::string dir_;
  const uint64_t max_total_bytes_;
  std::mutex mu_;
  uint64_t total_ = 0;
  uint64_t next_temp_ = 0;
  std::map<std::string, Entry> blobs_;
  std::list<std::string> lru_;  // most recent first
};

}  // namespace shrm::server

#endif  // SHRM_SERVER_BLOB_STORE_H_
