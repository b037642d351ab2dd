#include "server/blob_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "core/io/sha256.h"
#include "proto/status_details.h"

namespace shrm::server {
namespace fs = std::filesystem;
namespace {

// How long a client is asked to wait after a full spool (space comes back as jobs release blobs
// and uploads finish or fail).
constexpr absl::Duration kSpoolFullRetryAfter = absl::Seconds(2);

int64_t MtimeNs(const struct stat& st) {
  return int64_t{st.st_mtim.tv_sec} * 1000000000 + st.st_mtim.tv_nsec;
}

}  // namespace

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
      if (errno == ENOSPC || errno == EDQUOT || errno == EFBIG) {
        // Another replica may have room, or this one once jobs release their blobs.
        return wire::WithRetryDelay(
            wire::WithErrorReason(absl::ResourceExhaustedError(absl::StrCat(
                                      "spool full: cannot store the upload (", std::strerror(errno),
                                      " after ", size_, " bytes); nothing was kept")),
                                  wire::kReasonSpoolFull),
            kSpoolFullRetryAfter);
      }
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
  auto missing = [&](const char* why) {
    return wire::WithErrorReason(absl::NotFoundError(absl::StrCat("blob ", sha256, why)),
                                 wire::kReasonBlobNotFound, "sha256", sha256);
  };
  struct stat st {};
  {
    std::lock_guard<std::mutex> lock(mu_);
    auto it = blobs_.find(sha256);
    if (it == blobs_.end()) return missing(" is not on the server (upload it first)");
    if (::stat(PathOf(sha256).c_str(), &st) != 0) {
      DropLocked(sha256);
      return missing(" is no longer on the server's disk (upload it again)");
    }
    ++it->second.pins;
    lru_.splice(lru_.begin(), lru_, it->second.lru);
    const Entry& e = it->second;
    if (e.verified && static_cast<uint64_t>(st.st_size) == e.size && MtimeNs(st) == e.mtime_ns) {
      return std::make_unique<Lease>(this, sha256, PathOf(sha256));
    }
  }
  // Hashed outside the lock (other calls go on); the pin keeps it from eviction meanwhile.
  auto lease = std::make_unique<Lease>(this, sha256, PathOf(sha256));
  const absl::StatusOr<std::string> hash = Sha256OfFile(PathOf(sha256));
  std::lock_guard<std::mutex> lock(mu_);
  auto it = blobs_.find(sha256);
  if (it == blobs_.end() || !hash.ok() || *hash != sha256) {
    if (it != blobs_.end()) DropLocked(sha256);
    return missing(
        ": its bytes on the server no longer match its SHA-256; dropped (upload it again)");
  }
  it->second.verified = true;
  it->second.size = static_cast<uint64_t>(st.st_size);
  it->second.mtime_ns = MtimeNs(st);
  return lease;
}

void BlobStore::DropLocked(const std::string& sha256) {
  auto it = blobs_.find(sha256);
  if (it == blobs_.end()) return;
  ::unlink(PathOf(sha256).c_str());
  total_ -= it->second.size;
  lru_.erase(it->second.lru);
  blobs_.erase(it);
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
  struct stat st {};
  const bool have_stat = ::stat(PathOf(*hash).c_str(), &st) == 0;
  auto it = blobs_.find(*hash);
  if (it == blobs_.end()) {
    lru_.push_front(*hash);
    Entry e;
    e.size = upload->size_;
    e.lru = lru_.begin();
    it = blobs_.emplace(*hash, e).first;
    total_ += upload->size_;
  } else {
    lru_.splice(lru_.begin(), lru_, it->second.lru);
  }
  // The bytes just hashed are the file now in place.
  it->second.verified = have_stat;
  it->second.mtime_ns = have_stat ? MtimeNs(st) : 0;
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
