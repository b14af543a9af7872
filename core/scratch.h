// Working arrays in huge pages.
//
// The program fixes glibc's mmap threshold (cli/main.cpp), so every buffer above it is mapped when
// made and unmapped when freed, and each of its 4 KiB pages faults in again on first use: a
// decimation makes and frees its per-call arrays (edge tallies, fans, the simplifier's per-vertex
// arrays, the grid of original triangles) hundreds of times a block, and those faults were a
// quarter of its time on this project's VM (docs/performance.md, issue 36). A ScratchVector's
// buffer of kScratchMapped or more is a mapping of its own that starts at a 2 MiB boundary, with
// transparent huge pages asked for (madvise), so that each whole 2 MiB that it spans faults in
// once, not 512 times; a smaller one comes from malloc. Under AddressSanitizer every buffer comes
// from malloc, which it checks.
//
// A huge page is resident whole once any byte of it is written, so an array with an untouched tail
// (grown by doubling, say) can hold up to 2 MiB more than it uses: reserve such arrays at their size.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

namespace isoslab {

/// Buffers of at least this many bytes are mapped in huge pages.
inline constexpr std::size_t kScratchMapped = std::size_t{1} << 20;

/// A buffer of at least `bytes`. Throws std::bad_alloc.
void* takeScratch(std::size_t bytes);
/// Gives back a buffer from takeScratch that was asked for with `bytes`.
void giveScratch(void* p, std::size_t bytes) noexcept;

template <class T>
struct ScratchAllocator {
  using value_type = T;
  ScratchAllocator() noexcept = default;
  template <class U>
  ScratchAllocator(const ScratchAllocator<U>&) noexcept {}  // NOLINT: converting, as allocators do
  T* allocate(std::size_t n) {
    if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
    return static_cast<T*>(takeScratch(n * sizeof(T)));
  }
  void deallocate(T* p, std::size_t n) noexcept { giveScratch(p, n * sizeof(T)); }
  template <class U>
  bool operator==(const ScratchAllocator<U>&) const noexcept {
    return true;
  }
};

template <class T>
using ScratchVector = std::vector<T, ScratchAllocator<T>>;

}  // namespace isoslab
