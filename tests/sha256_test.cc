// SHA-256 (core/io/sha256.h), both the portable code and the x86 SHA-extensions path, against
// FIPS 180-2's published vectors and against OpenSSL's libcrypto (an independent
// implementation, linked into this test only) on random inputs of every length around the
// 64-byte block and the padding's 56-byte boundary, fed whole and in uneven pieces.
#include "core/io/sha256.h"

#include <openssl/sha.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "tests/test_paths.h"

namespace shrm {
namespace {

std::string OpenSslHex(const std::string& bytes) {
  std::array<unsigned char, SHA256_DIGEST_LENGTH> md{};
  SHA256(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), md.data());
  return internal::HexDigest(md);
}

std::string Hash(const std::string& bytes, bool extensions) {
  internal::Sha256 h(extensions);
  h.Update(bytes);
  return internal::HexDigest(h.Digest());
}

std::string RandomBytes(std::mt19937& rng, size_t n) {
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(rng() & 255);
  return s;
}

// The code paths to check: the portable one always, the extensions where this CPU has them.
std::vector<bool> Paths() {
  std::vector<bool> paths = {false};
  if (internal::Sha256HasExtensions()) paths.push_back(true);
  return paths;
}

TEST(Sha256Test, FipsVectors) {
  for (bool ext : Paths()) {
    SCOPED_TRACE(ext ? "SHA extensions" : "portable");
    // FIPS 180-2, appendix B.1-B.3.
    EXPECT_EQ(Hash("", ext), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    EXPECT_EQ(Hash("abc", ext), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    EXPECT_EQ(Hash("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq", ext),
              "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    EXPECT_EQ(Hash(std::string(1000000, 'a'), ext),
              "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  }
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Sha256Test, EqualsLibcryptoAtEveryLengthAroundTheBlocks) {
  std::mt19937 rng(29);
  for (bool ext : Paths()) {
    SCOPED_TRACE(ext ? "SHA extensions" : "portable");
    for (size_t n = 0; n <= 300; ++n) {
      const std::string s = RandomBytes(rng, n);
      ASSERT_EQ(Hash(s, ext), OpenSslHex(s)) << n << " bytes";
    }
    for (size_t n : {4095, 4096, 65535, 65536, 65537, 1000003}) {
      const std::string s = RandomBytes(rng, n);
      ASSERT_EQ(Hash(s, ext), OpenSslHex(s)) << n << " bytes";
    }
  }
}

TEST(Sha256Test, PiecesGiveTheDigestOfTheWhole) {
  std::mt19937 rng(31);
  const std::string s = RandomBytes(rng, 5000);
  const std::string want = OpenSslHex(s);
  for (bool ext : Paths()) {
    for (int trial = 0; trial < 50; ++trial) {
      internal::Sha256 h(ext);
      for (size_t at = 0; at < s.size();) {
        const size_t n = std::min<size_t>(s.size() - at, rng() % 150);
        h.Update(std::string_view(s).substr(at, n));
        at += n;
      }
      ASSERT_EQ(internal::HexDigest(h.Digest()), want) << trial;
    }
  }
  Sha256Stream stream;
  stream.Update(std::string_view(s).substr(0, 77));
  stream.Update(std::string_view(s).substr(77));
  EXPECT_EQ(stream.Hex(), want);
}

TEST(Sha256Test, FilesAndTheirErrors) {
  const std::string path = testing::UniqueTempPath("sha.bin");
  std::mt19937 rng(37);
  const std::string s = RandomBytes(rng, 200000);  // several of the reader's 64 KiB chunks
  std::ofstream(path, std::ios::binary) << s;
  EXPECT_EQ(*Sha256OfFile(path), OpenSslHex(s));
  std::filesystem::remove(path);
  const auto missing = Sha256OfFile(path);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find(path), std::string::npos);
}

TEST(Sha256Test, HexForm) {
  EXPECT_TRUE(IsSha256Hex(Sha256Hex("x")));
  EXPECT_FALSE(IsSha256Hex("ABC"));
  EXPECT_FALSE(IsSha256Hex(std::string(64, 'g')));
}

}  // namespace
}  // namespace shrm
