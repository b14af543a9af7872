// The calling thread's large working buffers (scratch.h).
#include "core/scratch.h"

#include <sys/mman.h>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define ISOSLAB_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define ISOSLAB_ASAN 1
#endif
#if defined(ISOSLAB_ASAN)
#include <sanitizer/asan_interface.h>
#else
#define ASAN_POISON_MEMORY_REGION(p, n) ((void)(p), (void)(n))
#define ASAN_UNPOISON_MEMORY_REGION(p, n) ((void)(p), (void)(n))
#endif

#include <array>
#include <cstdint>
#include <cstdlib>

namespace isoslab {
namespace {

constexpr std::size_t kPage = 4096;
constexpr std::size_t kHugePage = std::size_t{2} << 20;
// Below kCached a buffer comes from the heap, where glibc keeps freed space anyway; below kMapped
// from the thread's cache; from kMapped on it is mapped on its own, in huge pages where it spans
// them.
constexpr std::size_t kCached = std::size_t{64} << 10;
constexpr std::size_t kMapped = std::size_t{1} << 20;
// The most that a thread's cache holds, in buffers and in bytes.
constexpr std::size_t kSlots = 32;
constexpr std::size_t kCacheBytes = std::size_t{8} << 20;

// A cached request rounded up to a size class an eighth of its power of two wide, so that requests
// that differ a little share buffers; the class is a function of the request alone, so a buffer's
// size is known again when it comes back.
std::size_t classOf(std::size_t bytes) {
  std::size_t top = 1;
  while (top <= bytes / 2) top *= 2;
  const std::size_t step = std::max<std::size_t>(top / 8, kPage);
  return (bytes + step - 1) / step * step;
}

std::size_t pagesOf(std::size_t bytes) {
  return (bytes + kPage - 1) / kPage * kPage;
}

struct Cache {
  struct Slot {
    void* p = nullptr;
    std::size_t bytes = 0;
  };
  std::array<Slot, kSlots> slots{};
  std::size_t used = 0, total = 0;

  ~Cache() { clear(); }
  void clear() noexcept {
    for (std::size_t k = 0; k < used; ++k) release(slots[k]);
    used = total = 0;
  }
  static void release(const Slot& slot) noexcept {
    ASAN_UNPOISON_MEMORY_REGION(slot.p, slot.bytes);
    std::free(slot.p);
  }
  void drop(std::size_t k) noexcept {
    release(slots[k]);
    total -= slots[k].bytes;
    slots[k] = slots[--used];
  }
  // Frees as many cached bytes as a new buffer takes (the largest first), so that memory grows only
  // where it would have grown without the cache.
  void makeRoom(std::size_t bytes) noexcept {
    for (std::size_t freed = 0; freed < bytes && used > 0;) {
      const std::size_t k = largest();
      freed += slots[k].bytes;
      drop(k);
    }
  }
  std::size_t largest() const noexcept {
    std::size_t s = 0;
    for (std::size_t k = 1; k < used; ++k) s = slots[k].bytes > slots[s].bytes ? k : s;
    return s;
  }
};

thread_local Cache cache;

void* takeCached(std::size_t bytes) {
  const std::size_t size = classOf(bytes);
  Cache& c = cache;
  // The smallest cached buffer that holds it, if at most twice as large.
  std::size_t best = c.used;
  for (std::size_t k = 0; k < c.used; ++k) {
    const std::size_t have = c.slots[k].bytes;
    if (have >= size && have <= 2 * size && (best == c.used || have < c.slots[best].bytes)) best = k;
  }
  if (best < c.used) {
    void* p = c.slots[best].p;
    ASAN_UNPOISON_MEMORY_REGION(p, c.slots[best].bytes);
    c.total -= c.slots[best].bytes;
    c.slots[best] = c.slots[--c.used];
    return p;
  }
  c.makeRoom(size);
  void* p = std::malloc(size);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}

void giveCached(void* p, std::size_t bytes) noexcept {
  Cache& c = cache;
  // A buffer holds at least its request's class (a larger one may have served it).
  const std::size_t size = classOf(bytes);
  if (c.used == kSlots || c.total + size > kCacheBytes) {
    std::free(p);
    return;
  }
  // Under AddressSanitizer a cached buffer may be neither read nor written until it is taken again.
  ASAN_POISON_MEMORY_REGION(p, size);
  c.slots[c.used++] = {p, size};
  c.total += size;
}

// A mapping of its own, starting at a huge page, so that the huge pages that it spans are used
// when the system allows (transparent huge pages, "madvise" or "always"): one page fault for 2 MiB
// instead of 512.
void* takeMapped(std::size_t bytes) {
  const std::size_t size = pagesOf(bytes);
  cache.makeRoom(size);
#if defined(ISOSLAB_ASAN)
  // AddressSanitizer checks only what malloc gives.
  void* p = std::aligned_alloc(kHugePage, (size + kHugePage - 1) / kHugePage * kHugePage);
  if (p == nullptr) throw std::bad_alloc();
#else
  void* raw = ::mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const auto start = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = (start + kHugePage - 1) / kHugePage * kHugePage;
  if (aligned > start) ::munmap(raw, aligned - start);
  const std::uintptr_t end = start + size + kHugePage;
  if (end > aligned + size) ::munmap(reinterpret_cast<void*>(aligned + size), end - (aligned + size));
  void* p = reinterpret_cast<void*>(aligned);
  ::madvise(p, size, MADV_HUGEPAGE);
#endif
  return p;
}

}  // namespace

void* takeScratch(std::size_t bytes) {
  if (bytes >= kMapped) return takeMapped(bytes);
  if (bytes >= kCached) return takeCached(bytes);
  void* p = std::malloc(bytes == 0 ? 1 : bytes);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}

void giveScratch(void* p, std::size_t bytes) noexcept {
  if (p == nullptr) return;
  if (bytes >= kMapped) {
#if defined(ISOSLAB_ASAN)
    std::free(p);
#else
    ::munmap(p, pagesOf(bytes));
#endif
  } else if (bytes >= kCached) {
    giveCached(p, bytes);
  } else {
    std::free(p);
  }
}

void releaseScratch() noexcept {
  cache.clear();
}

std::size_t cachedScratchBytes() noexcept {
  return cache.total;
}

}  // namespace isoslab
