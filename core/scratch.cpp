// Large working buffers in huge pages (scratch.h).
#include "core/scratch.h"

#include <sys/mman.h>

#include <cstdint>
#include <cstdlib>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define ISOSLAB_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define ISOSLAB_ASAN 1
#endif

namespace isoslab {
namespace {

constexpr std::size_t kPage = 4096;
constexpr std::size_t kHugePage = std::size_t{2} << 20;

std::size_t pagesOf(std::size_t bytes) {
  return (bytes + kPage - 1) / kPage * kPage;
}

#if !defined(ISOSLAB_ASAN)
// Faults the mapping in with one call, writable. Kernels before 5.14 refuse the advice (EINVAL);
// their pages then fault in on first use, as any mapping's do.
void fillIn(void* p, std::size_t size) {
#if defined(MADV_POPULATE_WRITE)
  ::madvise(p, size, MADV_POPULATE_WRITE);
#else
  (void)p, (void)size;
#endif
}
#endif

}  // namespace

void* takeScratch(std::size_t bytes, bool populate) {
#if defined(ISOSLAB_ASAN)
  const std::size_t fromMalloc = kScratchHuge;  // AddressSanitizer checks what malloc gives
#else
  const std::size_t fromMalloc = kScratchMapped;
#endif
  if (bytes < fromMalloc) {
    void* p = std::malloc(bytes == 0 ? 1 : bytes);
    if (p == nullptr) throw std::bad_alloc();
    return p;
  }
  const std::size_t size = pagesOf(bytes);
#if defined(ISOSLAB_ASAN)
  void* p = std::aligned_alloc(kHugePage, (size + kHugePage - 1) / kHugePage * kHugePage);
  if (p == nullptr) throw std::bad_alloc();
  (void)populate;
  return p;
#else
  if (bytes < kScratchHuge) {
    void* p = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) throw std::bad_alloc();
    if (populate) fillIn(p, size);
    return p;
  }
  // One huge page more than asked, and the ends unmapped: a mapping that starts at a huge page.
  void* raw = ::mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const auto start = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = (start + kHugePage - 1) / kHugePage * kHugePage;
  if (aligned > start) ::munmap(raw, aligned - start);
  const std::uintptr_t end = start + size + kHugePage;
  if (end > aligned + size) ::munmap(reinterpret_cast<void*>(aligned + size), end - (aligned + size));
  void* p = reinterpret_cast<void*>(aligned);
  // Where the system does not grant them (transparent huge pages "never"), ordinary pages.
  ::madvise(p, size, MADV_HUGEPAGE);
  if (populate) fillIn(p, size);
  return p;
#endif
}

void giveScratch(void* p, std::size_t bytes) noexcept {
  if (p == nullptr) return;
#if defined(ISOSLAB_ASAN)
  (void)bytes;
  std::free(p);
#else
  if (bytes < kScratchMapped) {
    std::free(p);
  } else {
    ::munmap(p, pagesOf(bytes));
  }
#endif
}

}  // namespace isoslab
