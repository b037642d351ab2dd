// The `shrm` program's operator new/delete (cli/large_allocations.cc, linked into this test as
// into the program): blocks below 32 MiB come from malloc's heap, grown at start-up and advised
// for huge pages (and advised again where it grows past that), shared by every thread, with
// freed neighbours merged for later requests; blocks of 32 MiB or more are huge-page-advised
// mappings of their own, starting on a 2 MiB boundary and as long as the request rounded up to
// whole 2 MiB (the header is on an ordinary page below), kept for reuse when freed (a bounded
// cache) and otherwise returned to the system. Checked against the kernel's own account of the
// process's mappings (/proc/self/smaps).
#include <cstdint>
#include <fstream>
#include <memory>
#include <new>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"

namespace {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
constexpr bool kReplaced = false;  // the file compiles to nothing under ASan and TSan
#else
constexpr bool kReplaced = true;
#endif

constexpr uintptr_t kHugePage = uintptr_t{2} << 20;
constexpr size_t kLarge = size_t{40} << 20;  // above the 32 MiB threshold

// The smaps entry of the mapping holding `p`: its "VmFlags:" line ("" when not found), and its
// address range.
std::string VmFlagsOf(const void* p, uintptr_t* begin = nullptr, uintptr_t* end = nullptr) {
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  bool inside = false;
  const uintptr_t a = reinterpret_cast<uintptr_t>(p);
  while (std::getline(smaps, line)) {
    uintptr_t lo = 0, hi = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> lo >> dash >> hi && dash == '-') {
      inside = lo <= a && a < hi;
      if (inside && begin != nullptr) *begin = lo;
      if (inside && end != nullptr) *end = hi;
    } else if (inside && line.rfind("VmFlags:", 0) == 0) {
      return line;
    }
  }
  return "";
}

int CountMappings() {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  int n = 0;
  while (std::getline(maps, line)) ++n;
  return n;
}

// Freed neighbours merge: a 4 MiB and a 6 MiB block freed serve a 9 MiB one from the same memory
// (as blocks of their own sizes, cached by size, they could not: the job's EXR decoder buffers
// and the Legendre work array after them), so the pages already touched are used again. (First
// in the file: the other tests' freed blocks could serve it too.)
TEST(LargeAllocationsTest, FreedNeighboursServeALargerBlock) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  constexpr size_t kA = size_t{4} << 20, kB = size_t{6} << 20, kC = size_t{9} << 20;
  char* a = static_cast<char*>(::operator new(kA));
  char* b = static_cast<char*>(::operator new(kB));
  ASSERT_LT(a, b);
  // The first blocks of the process lie in the advised heap (from its first byte on).
  if (std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good()) {
    EXPECT_NE(VmFlagsOf(a).find(" hg"), std::string::npos);
  }
  for (size_t i = 0; i < kA; i += 4096) a[i] = 1;
  for (size_t i = 0; i < kB; i += 4096) b[i] = 1;
  const uintptr_t first = reinterpret_cast<uintptr_t>(a);
  const uintptr_t last = reinterpret_cast<uintptr_t>(b) + kB;
  ::operator delete(b);
  ::operator delete(a);
  void* c = ::operator new(kC);
  EXPECT_GE(reinterpret_cast<uintptr_t>(c), first);
  EXPECT_LE(reinterpret_cast<uintptr_t>(c) + kC, last);
  ::operator delete(c);
}

TEST(LargeAllocationsTest, LargeBlocksAreHugePageAdvisedMappingsOfTheirOwn) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  auto block = std::make_unique<char[]>(kLarge);
  const uintptr_t a = reinterpret_cast<uintptr_t>(block.get());
  EXPECT_EQ(a % kHugePage, 0u);
  const std::string flags = VmFlagsOf(block.get());
  ASSERT_FALSE(flags.empty());
  // MADV_HUGEPAGE, on kernels built with transparent huge pages (the advice is the program's;
  // whether the kernel follows it is the system's setting).
  if (std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good()) {
    EXPECT_NE(flags.find(" hg"), std::string::npos) << flags;
  }
  // Every byte is usable, zero-initialized by make_unique<char[]>.
  for (size_t i = 0; i < kLarge; i += 4096) EXPECT_EQ(block[i], 0);
  block[kLarge - 1] = 1;
}

// A block of exactly k x 2 MiB (the power-of-two arrays of a job) is k huge pages: the advised
// mapping starts at the block and ends at its end, so touching the last byte does not fault in
// (and have the kernel zero) one more huge page.
TEST(LargeAllocationsTest, WholeHugePagesAreNotExceeded) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  // (Sizes above every block the other tests free: a cached block of up to twice the request
  // would serve it otherwise, by design.)
  for (size_t k : {21, 25}) {
    const size_t n = k * kHugePage;
    void* p = ::operator new(n);
    uintptr_t begin = 0, end = 0;
    ASSERT_FALSE(VmFlagsOf(p, &begin, &end).empty());
    EXPECT_EQ(begin, reinterpret_cast<uintptr_t>(p)) << k;
    EXPECT_EQ(end - begin, n) << k;
    static_cast<char*>(p)[n - 1] = 1;
    ::operator delete(p);
  }
}

TEST(LargeAllocationsTest, FreedBlocksGoBackAndContentsSurviveGrowth) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  // Growth across the threshold copies the contents from malloc to a mapping and on.
  std::vector<uint32_t> v;
  for (uint32_t i = 0; i < (48u << 20) / 4; ++i) v.push_back(i * 2654435761u);
  for (uint32_t i = 0; i < v.size(); ++i) ASSERT_EQ(v[i], i * 2654435761u);
  v.clear();
  v.shrink_to_fit();
  // Many large blocks allocated and freed leave at most the cache's mappings behind (one here:
  // every block of the loop has the same rounded size and reuses the first one's mapping).
  const int before = CountMappings();
  for (int k = 0; k < 20; ++k) {
    std::vector<float> big(kLarge / sizeof(float) + k, 1.0f);
    ASSERT_EQ(big.back(), 1.0f);
  }
  EXPECT_LE(CountMappings(), before + 2);  // + what the reading itself may have allocated
}

TEST(LargeAllocationsTest, FreedBlocksAreReusedWithinBounds) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  constexpr size_t kSize = size_t{80} << 20;
  void* first = ::operator new(kSize);
  static_cast<char*>(first)[kSize - 1] = 7;
  ::operator delete(first);
  // The same size again: the cached mapping, contents as left (operator new does not clear).
  void* again = ::operator new(kSize);
  EXPECT_EQ(again, first);
  // A large block of less than half the cached one's size gets a mapping of its own.
  void* small = ::operator new (size_t{34} << 20);
  EXPECT_NE(small, first);
  ::operator delete(small);
  ::operator delete(again);
  // The cache is bounded: 40 blocks of 64 MiB (2.5 GiB) freed at once leave at most the cache's
  // 1 GiB mapped.
  std::vector<void*> blocks;
  for (int k = 0; k < 40; ++k) blocks.push_back(::operator new (size_t{64} << 20));
  const int held = CountMappings();
  for (void* b : blocks) ::operator delete(b);
  EXPECT_LE(CountMappings(), held - 40 + 16);
}

// Blocks below 32 MiB (an SHT plan's tables, a Legendre work array, a library's line buffers)
// come from malloc's heap, whose first part was grown at start-up and advised for huge pages: a
// 256 KiB block is not a mapping of its own (glibc would map it by itself above its default
// 128 KiB threshold), nor is a 4 MiB one, and both lie in an advised part of the heap.
TEST(LargeAllocationsTest, MediumBlocksComeFromTheHugePageAdvisedHeap) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  const int before = CountMappings();
  std::vector<std::unique_ptr<char[]>> blocks;
  constexpr int kBlocks = 32;
  for (int i = 0; i < kBlocks; ++i) {
    blocks.push_back(std::make_unique<char[]>(size_t{256} << 10));
  }
  auto medium = std::make_unique<char[]>(size_t{4} << 20);
  // (+ 2: the advice may split the heap's mapping where it grows.)
  EXPECT_LE(CountMappings(), before + 2) << "medium blocks got mappings of their own";
  if (std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good()) {
    int advised = 0;
    for (const auto& b : blocks) advised += VmFlagsOf(b.get()).find(" hg") != std::string::npos;
    // Every one: the heap below the advised range is filled at start-up (a block that took its
    // first 2 MiB in 4 KiB pages cost a TLB miss per lookup).
    EXPECT_EQ(advised, kBlocks);
    EXPECT_NE(VmFlagsOf(medium.get()).find(" hg"), std::string::npos);
  }
}

// The heap past the start-up reserve (128 MiB) is advised as it grows, and other threads
// allocate from the same heap (one arena: other arenas would be mappings of their own, neither
// advised nor shared).
TEST(LargeAllocationsTest, HeapGrowthAndOtherThreadsAreAdvised) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  if (!std::ifstream("/sys/kernel/mm/transparent_hugepage/enabled").good()) {
    GTEST_SKIP() << "no transparent huge pages in this kernel";
  }
  // (Each block's middle: a block's first bytes may lie below the first 2 MiB boundary of an
  // advised range.)
  constexpr size_t kBlock = size_t{20} << 20;
  std::vector<void*> blocks;
  for (int k = 0; k < 10; ++k) blocks.push_back(::operator new(kBlock));  // 200 MiB
  for (void* p : blocks) {
    EXPECT_NE(VmFlagsOf(static_cast<char*>(p) + kBlock / 2).find(" hg"), std::string::npos) << p;
  }
  constexpr size_t kThreadBlock = size_t{3} << 20;
  void* from_thread = nullptr;
  std::thread([&] { from_thread = ::operator new(kThreadBlock); }).join();
  EXPECT_NE(VmFlagsOf(static_cast<char*>(from_thread) + kThreadBlock / 2).find(" hg"),
            std::string::npos);
  ::operator delete(from_thread);
  for (void* p : blocks) ::operator delete(p);
}

TEST(LargeAllocationsTest, SmallBlocksAndFailuresBehaveAsTheStandardSays) {
  if (!kReplaced) GTEST_SKIP() << "not replaced under AddressSanitizer";
  for (size_t n : {size_t{0}, size_t{1}, size_t{100}, (size_t{1} << 20) - 1}) {
    void* p = ::operator new(n);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(p) % alignof(std::max_align_t), 0u);
    ::operator delete(p);
  }
  EXPECT_EQ(::operator new (size_t{1} << 62, std::nothrow), nullptr);
  EXPECT_THROW((void)::operator new (size_t{1} << 62), std::bad_alloc);
  ::operator delete(nullptr);
}

}  // namespace
