// The blob store under disk trouble (docs/server.md, "Disk"): a write that hits a file-size limit
// (RLIMIT_FSIZE, the way a full disk fails a write) gives RESOURCE_EXHAUSTED (SPOOL_FULL, with a
// retry delay), leaves no partial file and the store keeps serving; a blob whose bytes changed on
// disk (this process's, or one found at startup) is hashed again, dropped and reported missing,
// never served; through the service the client uploads it again and the job succeeds with the
// output of an intact run.
#include "server/blob_store.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "client/remote_jobs.h"
#include "client/shrm_client.h"
#include "core/io/sha256.h"
#include "proto/status_details.h"
#include "server/server.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

using server::BlobStore;

constexpr uint64_t kBound = 1ull << 30;  // far above what the tests store
// The file-size limit of the full-spool test and an upload above and one below it.
constexpr rlim_t kFileLimit = 1 << 20;
constexpr size_t kTooBig = 2 << 20;
constexpr size_t kFits = 256 << 10;
// A small job for the service test.
constexpr int kTestF = 8;
constexpr int kTestP = 2;
constexpr int kTestFaceSize = 16;

std::string Bytes(size_t n, char fill) { return std::string(n, fill); }

absl::StatusOr<std::string> Store(BlobStore* store, const std::string& bytes) {
  absl::StatusOr<std::unique_ptr<BlobStore::Upload>> up = store->BeginUpload();
  if (!up.ok()) return up.status();
  if (absl::Status s = (*up)->Append(bytes); !s.ok()) return s;
  return store->Commit(up->get(), Sha256Hex(bytes));
}

// Flips one byte in the middle of `path` (same size).
void FlipByte(const std::string& path) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(0, std::ios::end);
  const std::streamoff mid = f.tellg() / 2;
  f.seekg(mid);
  char c = 0;
  f.get(c);
  f.seekp(mid);
  f.put(static_cast<char>(c ^ 0x5a));
}

// A later change of the file's bytes: flipped, and the modification time one second after the
// one the store saw (set explicitly: a write in the same tick of the file system's coarse clock
// would keep it, and the test must not depend on how much time passes).
void Corrupt(const std::string& path) {
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  FlipByte(path);
  timespec times[2] = {st.st_atim, st.st_mtim};
  times[1].tv_sec += 1;
  ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), times, 0), 0);
}

bool ReportedMissing(const absl::Status& s) {
  return s.code() == absl::StatusCode::kNotFound &&
         wire::ErrorReason(s) == wire::kReasonBlobNotFound;
}

class BlobStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::UniqueTempPath("blobs");
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  int IncomingFiles() const { return testing::CountFiles(dir_ + "/spool/incoming"); }
  // A loopback server on this test's spool and a client of it (quick retries).
  void StartService() {
    server::ServerOptions opt;
    opt.listen = "127.0.0.1:0";
    opt.service.spool_dir = dir_ + "/spool";
    opt.service.max_jobs = 2;
    absl::StatusOr<std::unique_ptr<server::ShrmServer>> srv = server::ShrmServer::Start(opt);
    ASSERT_TRUE(srv.ok()) << srv.status();
    server_ = *std::move(srv);
    client::ClientOptions copt;
    copt.initial_backoff = absl::Milliseconds(1);
    absl::StatusOr<std::unique_ptr<client::ShrmClient>> c =
        client::ShrmClient::Connect(absl::StrCat("127.0.0.1:", server_->port()), copt);
    ASSERT_TRUE(c.ok()) << c.status();
    client_ = *std::move(c);
  }
  // A small prefilter job of `file` (explicit orders, no check: neither is what these test).
  static jobs::PrefilterJob SmallJob(const std::string& file) {
    jobs::PrefilterJob job;
    job.env.files = {file};
    job.brdf = "phong:s=32";
    jobs::UseExplicitOrders(&job, jobs::Orders{kTestF, kTestP});
    job.verify = 0;
    job.face_size = kTestFaceSize;
    return job;
  }
  std::string dir_;
  std::unique_ptr<server::ShrmServer> server_;
  std::unique_ptr<client::ShrmClient> client_;
};

TEST_F(BlobStoreTest, FullSpoolIsResourceExhaustedLeavesNothingAndServesOn) {
  absl::StatusOr<std::unique_ptr<BlobStore>> store = BlobStore::Open(dir_ + "/spool", kBound);
  ASSERT_TRUE(store.ok()) << store.status();
  absl::StatusOr<std::string> kept = Store(store->get(), Bytes(kFits, 'a'));
  ASSERT_TRUE(kept.ok()) << kept.status();

  signal(SIGXFSZ, SIG_IGN);  // as shrmd does: EFBIG instead of a signal
  rlimit old{};
  getrlimit(RLIMIT_FSIZE, &old);
  const rlimit small{kFileLimit, old.rlim_max};
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  absl::StatusOr<std::string> full = Store(store->get(), Bytes(kTooBig, 'b'));
  absl::StatusOr<std::string> fits = Store(store->get(), Bytes(kFits, 'c'));
  setrlimit(RLIMIT_FSIZE, &old);

  EXPECT_EQ(full.status().code(), absl::StatusCode::kResourceExhausted) << full.status();
  EXPECT_EQ(wire::ErrorReason(full.status()), wire::kReasonSpoolFull);
  EXPECT_TRUE(wire::RetryDelay(full.status()).has_value());
  EXPECT_EQ(IncomingFiles(), 0);  // no partial upload left
  EXPECT_FALSE((*store)->Size(Sha256Hex(Bytes(kTooBig, 'b'))).has_value());
  EXPECT_EQ((*store)->total_bytes(), 2 * kFits);
  // Served on: the next upload is stored, the earlier blob is intact.
  ASSERT_TRUE(fits.ok()) << fits.status();
  EXPECT_TRUE((*store)->Pin(*kept).ok());
  EXPECT_TRUE((*store)->Pin(*fits).ok());
}

TEST_F(BlobStoreTest, ChangedBytesAreDroppedNeverServed) {
  absl::StatusOr<std::unique_ptr<BlobStore>> store = BlobStore::Open(dir_ + "/spool", kBound);
  ASSERT_TRUE(store.ok()) << store.status();
  const std::string bytes = Bytes(kFits, 'd');
  absl::StatusOr<std::string> sha = Store(store->get(), bytes);
  ASSERT_TRUE(sha.ok()) << sha.status();
  const std::string path = dir_ + "/spool/" + *sha;
  ASSERT_TRUE((*store)->Pin(*sha).ok());
  Corrupt(path);
  const absl::StatusOr<std::unique_ptr<BlobStore::Lease>> bad = (*store)->Pin(*sha);
  EXPECT_TRUE(ReportedMissing(bad.status())) << bad.status();
  EXPECT_NE(bad.status().message().find("no longer match"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_FALSE((*store)->Size(*sha).has_value());
  EXPECT_EQ((*store)->total_bytes(), 0u);
  // Uploaded again, it is served again.
  ASSERT_TRUE(Store(store->get(), bytes).ok());
  EXPECT_TRUE((*store)->Pin(*sha).ok());
}

// A blob found at startup has not been hashed by this process: it is, at its first use, even
// when its modification time was put back (corruption the file's metadata does not show).
TEST_F(BlobStoreTest, BlobsFoundAtStartupAreVerifiedAtFirstUse) {
  std::string good, bad;
  {
    absl::StatusOr<std::unique_ptr<BlobStore>> store = BlobStore::Open(dir_ + "/spool", kBound);
    ASSERT_TRUE(store.ok()) << store.status();
    good = *Store(store->get(), Bytes(kFits, 'e'));
    bad = *Store(store->get(), Bytes(kFits, 'f'));
  }
  const std::string path = dir_ + "/spool/" + bad;
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  FlipByte(path);
  const timespec times[2] = {st.st_atim, st.st_mtim};
  ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), times, 0), 0);

  absl::StatusOr<std::unique_ptr<BlobStore>> store = BlobStore::Open(dir_ + "/spool", kBound);
  ASSERT_TRUE(store.ok()) << store.status();
  EXPECT_TRUE((*store)->Size(bad).has_value());  // indexed by name until used
  EXPECT_TRUE(ReportedMissing((*store)->Pin(bad).status()));
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE((*store)->Pin(good).ok());
}

// Through the service: the client finds the blob missing, uploads it again and the job's file
// equals the one of a run on an intact spool.
TEST_F(BlobStoreTest, ClientRecoversFromACorruptBlob) {
  ASSERT_NO_FATAL_FAILURE(StartService());
  const jobs::PrefilterJob job =
      SmallJob(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  int retries = 0;
  absl::StatusOr<client::RemotePrefilterResult> first =
      client::RunRemotePrefilter(client_.get(), "interior", job, {}, &retries);
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_EQ(retries, 0);
  absl::StatusOr<std::string> sha = Sha256OfFile(job.env.files[0]);
  ASSERT_TRUE(sha.ok());
  Corrupt(dir_ + "/spool/" + *sha);
  absl::StatusOr<client::RemotePrefilterResult> second =
      client::RunRemotePrefilter(client_.get(), "interior", job, {}, &retries);
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(retries, 1);  // BLOB_NOT_FOUND once, then uploaded again
  EXPECT_EQ(second->outcome.shrm_file, first->outcome.shrm_file);
  server_->Shutdown(absl::ZeroDuration());
}

// A map the server cannot decode is named in the client's message by the user's own file, as an
// embedded run names it: the server says "blob <sha256>" (no path of its own), and the client knows
// which file it uploaded as that blob.
TEST_F(BlobStoreTest, RemoteErrorsNameTheLocalFile) {
  ASSERT_NO_FATAL_FAILURE(StartService());
  const std::string file = dir_ + "/not_a_map.exr";
  {
    std::ofstream out(file, std::ios::binary);
    out << "these bytes are no image format's";
  }
  absl::StatusOr<std::string> sha = Sha256OfFile(file);
  ASSERT_TRUE(sha.ok());
  absl::StatusOr<client::RemotePrefilterResult> r =
      client::RunRemotePrefilter(client_.get(), "target", SmallJob(file), {}, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument) << r.status();
  const std::string message(r.status().message());
  EXPECT_NE(message.find(absl::StrCat("target: ", file, ": unrecognized file signature")),
            std::string::npos)
      << message;
  EXPECT_EQ(message.find(*sha), std::string::npos) << message;
  // A BRDF table travels as a blob too: the server's "BRDF blob <sha>" is the local file, named
  // as the embedded run names it ("brdf table 'PATH': not an SHRMBRDF file ...").
  const std::string table = dir_ + "/not_a_table.shrmbrdf";
  {
    std::ofstream out(table, std::ios::binary);
    out << "these bytes are no BRDF table's";
  }
  absl::StatusOr<std::string> table_sha = Sha256OfFile(table);
  ASSERT_TRUE(table_sha.ok());
  jobs::PrefilterJob job = SmallJob(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  job.brdf = "table:" + table;
  r = client::RunRemotePrefilter(client_.get(), "target", job, {}, nullptr);
  ASSERT_FALSE(r.ok());
  const std::string table_message(r.status().message());
  EXPECT_NE(table_message.find(absl::StrCat("brdf table '", table, "': not an SHRMBRDF file")),
            std::string::npos)
      << table_message;
  EXPECT_EQ(table_message.find(*table_sha), std::string::npos) << table_message;
  server_->Shutdown(absl::ZeroDuration());
}

// A local file the client cannot upload (a folder, a missing BRDF table) is named once, not
// once by the hash of the file and again by the upload ("/x: /x: cannot open file").
TEST_F(BlobStoreTest, FilesTheClientCannotUploadAreNamedOnce) {
  ASSERT_NO_FATAL_FAILURE(StartService());
  const auto count = [](const std::string& text, const std::string& part) {
    size_t n = 0;
    for (size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
    return n;
  };
  const std::string folder = dir_ + "/maps.exr";
  std::filesystem::create_directories(folder);
  absl::StatusOr<client::RemotePrefilterResult> r =
      client::RunRemotePrefilter(client_.get(), "target", SmallJob(folder), {}, nullptr);
  ASSERT_FALSE(r.ok());
  const std::string message(r.status().message());
  EXPECT_NE(message.find(absl::StrCat(folder, ": is a folder, not a file")), std::string::npos)
      << message;
  EXPECT_EQ(count(message, folder), 1u) << message;
  jobs::PrefilterJob job = SmallJob(absl::StrCat(SHRM_SOURCE_DIR, "/data/envmaps/interior.exr"));
  const std::string table = dir_ + "/missing.shrmbrdf";
  job.brdf = "table:" + table;
  r = client::RunRemotePrefilter(client_.get(), "target", job, {}, nullptr);
  ASSERT_FALSE(r.ok());
  const std::string table_message(r.status().message());
  EXPECT_NE(table_message.find(absl::StrCat(table, ": cannot open file")), std::string::npos)
      << table_message;
  EXPECT_EQ(count(table_message, table), 1u) << table_message;
  server_->Shutdown(absl::ZeroDuration());
}

}  // namespace
}  // namespace shrm
