#include "server/blob_store.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "core/io/sha256.h"
#include "proto/status_details.h"

namespace shrm::server {
namespace fs = std::filesystem;

BlobStore::Lease::Lease(BlobStore* store, std::string sha256, std::string path)
    : store_(store), sha256_(std::move(sha256)), path_(std::move(path)) {}

BlobStore::Lease::~Lease() { store_->Unpin(sha256_); }

BlobStore::Upload::~Upload() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !tmp_path_.empty()) ::unlink(tmp_path_.c_str());
}

absl::Status BlobStore::Upload::Append(std::string_view bytes) {
  const char* p = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return absl::UnavailableError(absl::StrCat("spool write failed: ", std::strerror(errno)));
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  size_ += bytes.size();
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<BlobStore>> BlobStore::Open(const std::string& dir,
                                                           uint64_t max_total_bytes) {
  std::error_code ec;
  fs::create_directories(fs::path(dir) / "incoming", ec);
  if (ec) {
    return absl::UnavailableError(
        absl::StrCat("cannot create spool directory ", dir, ": ", ec.message()));
  }
  std::unique_ptr<BlobStore> store(new BlobStore(dir, max_total_bytes));
  // Leftovers of a previous run.
  for (const auto& e : fs::directory_iterator(fs::path(dir) / "incoming", ec)) {
    fs::remove(e.path(), ec);
  }
  std::vector<std::pair<fs::file_time_type, std::string>> found;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || !IsSha256Hex(name)) continue;
    found.emplace_back(e.last_write_time(), name);
    Entry entry;
    entry.size = e.file_size();
    store->total_ += entry.size;
    store->blobs_[name] = entry;
  }
  std::sort(found.begin(), found.end());  // oldest first -> pushed to the front last = newest
  for (const auto& [t, name] : found) {
    store->lru_.push_front(name);
    store->blobs_[name].lru = store->lru_.begin();
  }
  std::lock_guard<std::mutex> lock(store->mu_);
  store->EvictLocked();
  return store;
}

std::optional<uint64_t> BlobStore::Size(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = blobs_.find(sha256);
  if (it == blobs_.end()) return std::nullopt;
  return it->second.size;
}

absl::StatusOr<std::unique_ptr<BlobStore::Lease>> BlobStore::Pin(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = blobs_.find(sha256);
  if (it == blobs_.end()) {
    return wire::WithErrorReason(absl::NotFoundError(absl::StrCat(
                                     "blob ", sha256, " is not on the server (upload it first)")),
                                 wire::kReasonBlobNotFound, "sha256", sha256);
  }
  ++it->second.pins;
  lru_.splice(lru_.begin(), lru_, it->second.lru);
  return std::make_unique<Lease>(this, sha256, PathOf(sha256));
}

void BlobStore::Unpin(const std::string& sha256) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = blobs_.find(sha256);
  if (it != blobs_.end()) --it->second.pins;
  EvictLocked();
}

std::string BlobStore::TempPath(std::string_view suffix) {
  std::lock_guard<std::mutex> lock(mu_);
  return absl::StrCat(dir_, "/incoming/tmp-", ::getpid(), "-", next_temp_++, std::string(suffix));
}

absl::StatusOr<std::unique_ptr<BlobStore::Upload>> BlobStore::BeginUpload() {
  std::unique_ptr<Upload> up(new Upload());
  up->tmp_path_ = TempPath(".upload");
  up->fd_ = ::open(up->tmp_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (up->fd_ < 0) {
    return absl::UnavailableError(
        absl::StrCat("spool: cannot create a file: ", std::strerror(errno)));
  }
  return up;
}

absl::StatusOr<std::string> BlobStore::Commit(Upload* upload, const std::string& expected) {
  if (::close(upload->fd_) != 0) {
    upload->fd_ = -1;
    return absl::UnavailableError("spool: closing the upload failed");
  }
  upload->fd_ = -1;
  absl::StatusOr<std::string> hash = Sha256OfFile(upload->tmp_path_);
  if (!hash.ok()) return absl::UnavailableError("spool: cannot hash the upload");
  if (*hash != expected) {
    return absl::InvalidArgumentError(
        absl::StrCat("upload declared sha256 ", expected, " but its content hashes to ", *hash));
  }
  std::lock_guard<std::mutex> lock(mu_);
  if (std::rename(upload->tmp_path_.c_str(), PathOf(*hash).c_str()) != 0) {
    return absl::UnavailableError("spool: cannot move the upload into place");
  }
  upload->committed_ = true;
  auto it = blobs_.find(*hash);
  if (it == blobs_.end()) {
    lru_.push_front(*hash);
    Entry e;
    e.size = upload->size_;
    e.lru = lru_.begin();
    blobs_[*hash] = e;
    total_ += upload->size_;
  } else {
    lru_.splice(lru_.begin(), lru_, it->second.lru);
  }
  EvictLocked();
  return *hash;
}

uint64_t BlobStore::total_bytes() {
  std::lock_guard<std::mutex> lock(mu_);
  return total_;
}

void BlobStore::EvictLocked() {
  // From the least recently used end; pinned blobs stay (the bound is then exceeded until they
  // are released).
  auto it = lru_.end();
  while (total_ > max_total_bytes_ && it != lru_.begin()) {
    --it;
    auto b = blobs_.find(*it);
    if (b->second.pins > 0) continue;
    ::unlink(PathOf(*it).c_str());
    total_ -= b->second.size;
    blobs_.erase(b);
    it = lru_.erase(it);
  }
}

}  // namespace shrm::server
