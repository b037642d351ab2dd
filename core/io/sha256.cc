#include "core/io/sha256.h"

#include <dlfcn.h>
#include <openssl/opensslv.h>
#include <openssl/sha.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

#define SHRM_STR2(x) #x
#define SHRM_STR(x) SHRM_STR2(x)

namespace shrm {
namespace {

constexpr char kLibCrypto[] = "libcrypto.so." SHRM_STR(OPENSSL_VERSION_MAJOR);

// libcrypto is loaded the first time a hash is taken, not with the program: its relocations
// alone took ~1 ms of every `shrm` start, and most commands (--help, info, eval, render, sky)
// never hash (docs/architecture.md "Start-up"). The digest is OpenSSL's SHA-256 itself (its
// assembly, with the CPU's SHA extensions where present), through the direct SHA256_* functions:
// the EVP interface's first use initialises OpenSSL's provider machinery, ~3 ms here.
struct Crypto {
  int (*init)(SHA256_CTX*);
  int (*update)(SHA256_CTX*, const void*, size_t);
  int (*final)(unsigned char*, SHA256_CTX*);
};

template <typename F>
void Bind(void* handle, const char* name, F* f) {
  *f = reinterpret_cast<F>(dlsym(handle, name));
  if (*f == nullptr) {
    std::fprintf(stderr, "shrm: fatal: %s lacks %s: %s\n", kLibCrypto, name, dlerror());
    std::abort();
  }
}

const Crypto& Lib() {
  static const Crypto crypto = [] {
    void* handle = dlopen(kLibCrypto, RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) {
      // An installation problem (the packages depend on it), not an input error.
      std::fprintf(stderr, "shrm: fatal: cannot load %s (SHA-256): %s\n", kLibCrypto, dlerror());
      std::abort();
    }
    Crypto c{};
    Bind(handle, "SHA256_Init", &c.init);
    Bind(handle, "SHA256_Update", &c.update);
    Bind(handle, "SHA256_Final", &c.final);
    return c;  // kept loaded for the life of the process
  }();
  return crypto;
}

std::string Hex(const unsigned char* d, unsigned n) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string s(2 * n, '0');
  for (unsigned i = 0; i < n; ++i) {
    s[2 * i] = kDigits[d[i] >> 4];
    s[2 * i + 1] = kDigits[d[i] & 15];
  }
  return s;
}

std::unique_ptr<SHA256_CTX> NewSha256() {
  auto ctx = std::make_unique<SHA256_CTX>();
  Lib().init(ctx.get());
  return ctx;
}

std::string Finish(SHA256_CTX* ctx) {
  std::array<unsigned char, SHA256_DIGEST_LENGTH> md{};
  Lib().final(md.data(), ctx);
  return Hex(md.data(), SHA256_DIGEST_LENGTH);
}

}  // namespace

std::string Sha256Hex(std::string_view bytes) {
  std::unique_ptr<SHA256_CTX> ctx = NewSha256();
  Lib().update(ctx.get(), bytes.data(), bytes.size());
  return Finish(ctx.get());
}

Sha256Stream::Sha256Stream() : ctx_(NewSha256().release()) {}

Sha256Stream::~Sha256Stream() { delete static_cast<SHA256_CTX*>(ctx_); }

void Sha256Stream::Update(std::string_view bytes) {
  Lib().update(static_cast<SHA256_CTX*>(ctx_), bytes.data(), bytes.size());
}

std::string Sha256Stream::Hex() { return Finish(static_cast<SHA256_CTX*>(ctx_)); }

absl::StatusOr<std::string> Sha256OfFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat(path, ": cannot open file"));
  std::unique_ptr<SHA256_CTX> ctx = NewSha256();
  std::array<char, 1 << 16> buf;
  while (in) {
    in.read(buf.data(), buf.size());
    if (in.gcount() > 0) Lib().update(ctx.get(), buf.data(), in.gcount());
  }
  if (in.bad()) return absl::UnavailableError(absl::StrCat(path, ": read error"));
  return Finish(ctx.get());
}

bool IsSha256Hex(std::string_view s) {
  if (s.size() != 64) return false;
  for (char c : s) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

}  // namespace shrm
