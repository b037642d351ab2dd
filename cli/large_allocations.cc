// Replaces the global operator new / delete of the program it is linked into (the `shrm` command)
// so that the memory a job touches comes in transparent huge pages (madvise MADV_HUGEPAGE) and is
// reused rather than mapped afresh:
// - blocks below kLargeThreshold (32 MiB, the largest mmap threshold glibc takes) come from
//   malloc's heap, which is grown at start-up by kHeapReserve and advised for huge pages, and
//   advised again wherever it grows past that (AdviseHeapGrowth), with the heap below the advised
//   range filled at start-up so that every later block lies in advised memory; every thread
//   allocates from it (one arena), and freed blocks go back to it, where neighbours merge;
// - larger blocks get their own 2 MiB-aligned advised mapping, kept for reuse when freed (a
//   bounded cache) and otherwise returned to the system.
//
// Why (docs/architecture.md "Start-up"): a job touches tens of MB of fresh memory (the decoded
// map, the EXR decoder's buffers, the SHRM cube, the encoded file), one page fault per 4 KiB page.
// Where faults are expensive (measured here: ~17 us each in a paravirtualized VM, 8,400 faults in
// a 270 ms prefilter), one fault per 2 MiB instead took the process from 270 to 185 ms. Where
// transparent huge pages are off, the advice does nothing and the memory is ordinary.
//
// Every fresh huge page is zeroed by the kernel on first touch (~0.2 ms here), so what counts is
// how much memory a job touches in all. Up to session 31 every block of 1 MiB or more had a
// mapping of its own, reused only by a request of the same size class: the EXR decoder's 4 and
// 6 MB buffers, freed after the decode, could not serve the 9 MB Legendre work array that
// followed, and each mip level's grid took its own. In the heap, freed neighbours merge and
// serve any later request that fits: `shrm ibl` touches ~5 MB less and runs 2-5% faster, the
// default `shrm prefilter` 10-13% (docs/results.md "Speed, session 32").
//
// A block of kLargeThreshold or more starts on a 2 MiB boundary and is recognised at delete by
// that and by the 64-byte header just below it (at the end of an ordinary page of its mapping),
// holding a magic number and its own address, so no table or lock is needed. Not compiled under
// AddressSanitizer, which must see every allocation itself.
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

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
// glibc's DEFAULT_MMAP_THRESHOLD_MAX on 64-bit systems: malloc maps larger blocks by itself.
constexpr size_t kLargeThreshold = size_t{32} << 20;
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

// The end of the heap's huge-page-advised part (0 before HeapSetup).
std::atomic<uintptr_t> g_advised_end{0};

// Advises the heap's growth past g_advised_end for huge pages (malloc grows it with brk, in steps
// of at least M_TOP_PAD, without advice). Called after every block of 1 MiB or more, before the
// caller touches it; the small blocks in a growth that no such block followed keep 4 KiB pages.
void AdviseHeapGrowth() {
  const uintptr_t end = reinterpret_cast<uintptr_t>(sbrk(0)) & ~(kHugePage - 1);
  uintptr_t advised = g_advised_end.load(std::memory_order_relaxed);
  while (advised != 0 && end > advised) {
    if (g_advised_end.compare_exchange_weak(advised, end)) {
      madvise(reinterpret_cast<void*>(advised), end - advised, MADV_HUGEPAGE);
      return;
    }
  }
}

void* Allocate(size_t n) noexcept {
  if (n >= kLargeThreshold) return MapLarge(n);
  void* p = std::malloc(n == 0 ? 1 : n);
  if (n >= (size_t{1} << 20)) AdviseHeapGrowth();
  return p;
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

// The heap that serves everything below kLargeThreshold (the program's blocks, e.g. an SHT plan's
// tables, a synthesis grid, the decoded map, and the libraries' buffers), grown once at start-up
// by kHeapReserve of address space (untouched pages cost nothing) and that part advised for huge
// pages. glibc is told to take every block below kLargeThreshold from the heap, never to give
// its top back (a later job would fault it in again), and to keep one arena: other threads'
// arenas would be mappings of their own, neither advised nor shared. Each fresh 4 KiB page costs
// one fault (~17 us in a paravirtualized VM: 4.3 ms a MB, against 0.75 ms a MB for a huge page,
// whose fault zeroes 2 MiB at once); an `shrm ibl` run touched ~1,800 of them.
constexpr size_t kHeapReserve = size_t{128} << 20;
constexpr size_t kHeapStep = size_t{32} << 20;  // M_TOP_PAD after start-up
constexpr size_t kCacheLine = 64;

// The block that fills the heap below its huge-page-advised range (HeapSetup); volatile, as the
// compiler may drop a malloc whose block is never read.
void* volatile g_below_advice = nullptr;

struct HeapSetup {
  HeapSetup() {
    mallopt(M_MMAP_THRESHOLD, static_cast<int>(kLargeThreshold));
    mallopt(M_TRIM_THRESHOLD, static_cast<int>(size_t{1} << 30));
    mallopt(M_ARENA_MAX, 1);
    // The heap grows when a request fits neither its free blocks nor its top chunk: by the request
    // plus M_TOP_PAD, with the new top chunk's header written right after the request. A page
    // touched before the advice keeps its whole 2 MiB range in 4 KiB pages (the kernel then has
    // a page table there), so the advice starts at the first 2 MiB boundary after that header.
    // The top is taken whole first, then a request grows the heap.
    const size_t top = mallinfo2().keepcost;
    void* fill = top > kCacheLine ? std::malloc(top - kCacheLine) : nullptr;
    mallopt(M_TOP_PAD, static_cast<int>(kHeapReserve));
    constexpr size_t kProbe = size_t{256} << 10;
    constexpr int kMaxProbes = 8;
    void* probes[kMaxProbes] = {};
    const uintptr_t old_end = reinterpret_cast<uintptr_t>(sbrk(0));
    uintptr_t begin = 0;
    for (int i = 0; i < kMaxProbes; ++i) {
      probes[i] = std::malloc(kProbe);
      if (probes[i] == nullptr) break;
      const uintptr_t end = reinterpret_cast<uintptr_t>(sbrk(0));
      if (end == old_end) continue;  // served by a free block: the heap did not grow
      const uintptr_t header = reinterpret_cast<uintptr_t>(probes[i]) + kProbe + kCacheLine;
      const uintptr_t advised_end = end & ~(kHugePage - 1);
      begin = (header + kHugePage - 1) & ~(kHugePage - 1);
      if (advised_end > begin) {
        madvise(reinterpret_cast<void*>(begin), advised_end - begin, MADV_HUGEPAGE);
        g_advised_end.store(advised_end);
      } else {
        begin = 0;
      }
      break;
    }
    for (void* q : probes) std::free(q);
    std::free(fill);
    mallopt(M_TOP_PAD, static_cast<int>(kHeapStep));
    // The top chunk now starts below the advised range; a block up to its first boundary, never
    // freed and never touched past its header, makes every later block come from advised
    // memory (a job's first large block, the decoded map, had its first 2 MiB in 4 KiB pages,
    // each a TLB miss for the lookups of the base level).
    const uintptr_t top_start = reinterpret_cast<uintptr_t>(sbrk(0)) - mallinfo2().keepcost;
    constexpr size_t kChunkHeader = 2 * sizeof(size_t);
    if (begin != 0 && begin > top_start + 2 * kChunkHeader) {
      g_below_advice = std::malloc(begin - top_start - 2 * kChunkHeader);
    }
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
