// Replaces the global operator new / delete of the program it is linked into (the `shrm` command)
// so that allocations of 1 MiB or more get their own 2 MiB-aligned anonymous mapping advised for
// transparent huge pages (madvise MADV_HUGEPAGE), and go back to the system when freed.
//
// Why (docs/architecture.md "Start-up"): a job touches tens of MB of fresh memory (the decoded
// map, the EXR decoder's buffers, the SHRM cube, the encoded file), one page fault per 4 KiB page.
// Where faults are expensive (measured here: ~17 us each in a paravirtualized VM, 8,400 faults in
// a 270 ms prefilter), one fault per 2 MiB instead took the process from 270 to 185 ms. Where
// transparent huge pages are off, the advice does nothing and the mappings are ordinary.
//
// Freed blocks are kept for reuse (up to kCacheSlots mappings and kCacheBytes in all): a job
// allocates the same large buffers again and again (one synthesis grid, Legendre work array and
// cube per mip level, the map's copies for each check), and every fresh mapping is zeroed by the
// kernel page by page on first touch (measured: ~30% of an `shrm ibl` run before the cache). A
// block is reused for a request of at least half its size, so a cached mapping never holds more
// than twice what it serves.
//
// Blocks below 1 MiB go to malloc, whose heap is grown once at start-up and huge-page-advised
// (HeapSetup below). A large block starts on a 2 MiB boundary and is recognised at delete by that
// and by the 64-byte header just below it (at the end of an ordinary page of its mapping), holding
// a magic number and its own address, so no table or lock is needed. Not compiled under
// AddressSanitizer, which must see every allocation itself.
#include <malloc.h>
#include <sys/mman.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define SHRM_NO_LARGE_ALLOCATIONS 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define SHRM_NO_LARGE_ALLOCATIONS 1
#endif

#ifndef SHRM_NO_LARGE_ALLOCATIONS

namespace {

constexpr size_t kHugePage = size_t{2} << 20;
constexpr size_t kLargeThreshold = size_t{1} << 20;
// The header sits at the end of an ordinary page just below the block, so that the block itself
// starts on a 2 MiB boundary and a block of k x 2 MiB (the common power-of-two arrays) takes k
// huge pages, not k + 1 of which the last holds 64 bytes: every huge page touched is zeroed whole
// by the kernel.
constexpr size_t kHeaderPage = 4096;
constexpr size_t kHeaderBytes = 64;
constexpr uint64_t kMagic = 0x53'48'52'4d'4c'41'52'47ull;  // "SHRMLARG"

struct Header {
  uint64_t magic;
  const void* self;  // the header's own address: a stray match of the magic number fails this
  size_t body;       // bytes of the block's mapping, from its 2 MiB boundary on
};

// The mapping of a header: its page and the body after it.
void* MappingOf(const Header* h) {
  return const_cast<char*>(reinterpret_cast<const char*>(h) + kHeaderBytes - kHeaderPage);
}
size_t MappedBytes(const Header* h) { return kHeaderPage + h->body; }
void* BlockOf(Header* h) { return reinterpret_cast<char*>(h) + kHeaderBytes; }

constexpr int kCacheSlots = 16;
constexpr size_t kCacheBytes = size_t{1} << 30;

// Freed mappings (their headers), guarded by a spin lock: operator new must not depend on
// anything that allocates or needs construction.
struct Cache {
  std::atomic_flag busy = ATOMIC_FLAG_INIT;
  Header* slot[kCacheSlots] = {};
  size_t bytes = 0;
  void Lock() {
    while (busy.test_and_set(std::memory_order_acquire)) {
    }
  }
  void Unlock() { busy.clear(std::memory_order_release); }
};
Cache g_cache;

// The smallest cached mapping of `body` to 2 x `body` bytes, taken out of the cache.
Header* TakeCached(size_t body) {
  g_cache.Lock();
  int best = -1;
  for (int i = 0; i < kCacheSlots; ++i) {
    const Header* h = g_cache.slot[i];
    if (h == nullptr || h->body < body || h->body > 2 * body) continue;
    if (best < 0 || h->body < g_cache.slot[best]->body) best = i;
  }
  Header* h = nullptr;
  if (best >= 0) {
    h = g_cache.slot[best];
    g_cache.slot[best] = nullptr;
    g_cache.bytes -= MappedBytes(h);
  }
  g_cache.Unlock();
  return h;
}

// Keeps a freed mapping if there is room; false when the caller must unmap it.
bool PutCached(Header* h) {
  g_cache.Lock();
  bool kept = false;
  if (g_cache.bytes + MappedBytes(h) <= kCacheBytes) {
    for (Header*& slot : g_cache.slot) {
      if (slot == nullptr) {
        slot = h;
        g_cache.bytes += MappedBytes(h);
        kept = true;
        break;
      }
    }
  }
  g_cache.Unlock();
  return kept;
}

void* MapLarge(size_t n) {
  if (n > (SIZE_MAX >> 2)) return nullptr;
  const size_t body = (n + kHugePage - 1) & ~(kHugePage - 1);
  if (Header* h = TakeCached(body)) return BlockOf(h);
  const size_t length = kHeaderPage + body + kHugePage;  // room to align the body to 2 MiB
  void* m = mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (m == MAP_FAILED) return nullptr;
  const uintptr_t raw = reinterpret_cast<uintptr_t>(m);
  const uintptr_t start = (raw + kHeaderPage + kHugePage - 1) & ~(kHugePage - 1);
  const uintptr_t first = start - kHeaderPage;  // the header's page
  if (const size_t head = first - raw; head > 0) munmap(m, head);
  if (const size_t tail = raw + length - (start + body); tail > 0) {
    munmap(reinterpret_cast<void*>(start + body), tail);
  }
  madvise(reinterpret_cast<void*>(start), body, MADV_HUGEPAGE);
  auto* h = reinterpret_cast<Header*>(start - kHeaderBytes);
  h->magic = kMagic;
  h->self = h;
  h->body = body;
  return reinterpret_cast<void*>(start);
}

// The header of a block MapLarge returned, or nullptr for any other pointer. (The 64 bytes below
// any pointer on a 2 MiB boundary are readable: operator new's own blocks have their header page
// there, and malloc's blocks their chunk headers, within the same heap or mapping.)
const Header* LargeHeader(void* p) {
  if ((reinterpret_cast<uintptr_t>(p) & (kHugePage - 1)) != 0) return nullptr;
  const auto* h = reinterpret_cast<const Header*>(static_cast<char*>(p) - kHeaderBytes);
  return h->magic == kMagic && h->self == h ? h : nullptr;
}

void* Allocate(size_t n) noexcept {
  if (n >= kLargeThreshold) return MapLarge(n);
  return std::malloc(n == 0 ? 1 : n);
}

void Release(void* p) noexcept {
  if (p == nullptr) return;
  if (const Header* h = LargeHeader(p)) {
    if (!PutCached(const_cast<Header*>(h))) munmap(MappingOf(h), MappedBytes(h));
  } else {
    std::free(p);
  }
}

void* AllocateOrThrow(size_t n) {
  while (true) {
    if (void* p = Allocate(n)) return p;
    std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

// The heap that serves everything below kLargeThreshold (the program's own medium blocks, e.g.
// an SHT plan's tables, and the libraries' buffers) grown once by kHeapReserve and that part
// advised for huge pages, with glibc told to take blocks up to kLargeThreshold from the heap
// rather than from mappings of their own. Each fresh 4 KiB page costs one fault (~17 us in a
// paravirtualized VM: 4.3 ms a MB, against 0.75 ms a MB for a huge page, whose fault zeroes 2 MiB
// at once); an `shrm ibl` run touched ~1,800 of them.
constexpr size_t kHeapReserve = size_t{32} << 20;

struct HeapSetup {
  HeapSetup() {
    // Blocks below 1 MiB from the heap; the heap never trimmed below what it grew to.
    mallopt(M_MMAP_THRESHOLD, static_cast<int>(2 * kHeapReserve));
    mallopt(M_TRIM_THRESHOLD, static_cast<int>(4 * kHeapReserve));
    void* p = std::malloc(kHeapReserve);
    if (p != nullptr) {
      const uintptr_t raw = reinterpret_cast<uintptr_t>(p);
      const uintptr_t begin = (raw + kHugePage - 1) & ~(kHugePage - 1);
      const uintptr_t end = (raw + kHeapReserve) & ~(kHugePage - 1);
      if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
      std::free(p);
    }
    mallopt(M_MMAP_THRESHOLD, static_cast<int>(kLargeThreshold));
  }
};
const HeapSetup g_heap_setup;

}  // namespace

void* operator new(size_t n) { return AllocateOrThrow(n); }
void* operator new[](size_t n) { return AllocateOrThrow(n); }
void* operator new(size_t n, const std::nothrow_t&) noexcept { return Allocate(n); }
void* operator new[](size_t n, const std::nothrow_t&) noexcept { return Allocate(n); }
void operator delete(void* p) noexcept { Release(p); }
void operator delete[](void* p) noexcept { Release(p); }
void operator delete(void* p, size_t) noexcept { Release(p); }
void operator delete[](void* p, size_t) noexcept { Release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { Release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { Release(p); }

#endif  // SHRM_NO_LARGE_ALLOCATIONS
