// Working arrays in huge pages, faulted in ahead.
//
// The program fixes glibc's mmap threshold (cli/main.cpp), so every buffer above it is mapped when
// made and unmapped when freed, and each of its 4 KiB pages faults in again on first use: a
// decimation makes and frees its per-call arrays (edge tallies, fans, the simplifier's per-vertex
// arrays, the grid of original triangles) hundreds of times a block, and those faults were a
// quarter of its time on this project's VM (docs/performance.md, issue 36). So a ScratchVector's
// buffer of kScratchMapped or more is a mapping of its own whose pages the kernel fills in one call
// (madvise MADV_POPULATE_WRITE) rather than one trap a page; from kScratchHuge on it starts at a
// 2 MiB boundary, with transparent huge pages asked for, so that each whole 2 MiB that it spans is
// one page. A smaller buffer comes from malloc. Under AddressSanitizer every buffer comes from
// malloc, which it checks.
//
// A mapped buffer is resident whole from the start, so an array with a tail that it never writes
// (grown by doubling, or reserved for the worst case) holds memory that it does not use: size such
// arrays exactly, or count first.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

namespace isoslab {

/// Buffers of at least this many bytes are mappings of their own, resident when made (the program's
/// mmap threshold, cli/main.cpp).
inline constexpr std::size_t kScratchMapped = std::size_t{256} << 10;
/// Buffers of at least this many bytes start at a huge page boundary, in huge pages.
inline constexpr std::size_t kScratchHuge = std::size_t{2} << 20;

/// A buffer of at least `bytes`, resident when made if `populate` (and mapped). Throws
/// std::bad_alloc.
void* takeScratch(std::size_t bytes, bool populate = true);
/// Gives back a buffer from takeScratch that was asked for with `bytes`.
void giveScratch(void* p, std::size_t bytes) noexcept;

/// An allocator of scratch buffers; `Populate` false for arrays that may use only a part of what
/// they reserve (their pages then fault in as they are written).
template <class T, bool Populate = true>
struct ScratchAllocator {
  using value_type = T;
  template <class U>
  struct rebind {
    using other = ScratchAllocator<U, Populate>;
  };
  ScratchAllocator() noexcept = default;
  template <class U>
  ScratchAllocator(const ScratchAllocator<U, Populate>&) noexcept {}  // NOLINT: converting, as allocators do
  T* allocate(std::size_t n) {
    if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
    return static_cast<T*>(takeScratch(n * sizeof(T), Populate));
  }
  void deallocate(T* p, std::size_t n) noexcept { giveScratch(p, n * sizeof(T)); }
  template <class U>
  bool operator==(const ScratchAllocator<U, Populate>&) const noexcept {
    return true;
  }
};

template <class T>
using ScratchVector = std::vector<T, ScratchAllocator<T>>;
/// For an array reserved for the most it may hold.
template <class T>
using LazyScratchVector = std::vector<T, ScratchAllocator<T, false>>;

}  // namespace isoslab
