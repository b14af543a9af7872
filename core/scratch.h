// Working arrays that cost fewer page faults.
//
// The program fixes glibc's mmap threshold (cli/main.cpp), so every buffer above it is mapped when
// made and unmapped when freed, and each of its pages faults in again on first use: a decimation
// makes and frees its per-call arrays (edge tallies, fans, the simplifier's per-vertex arrays, the
// grid of original triangles) hundreds of times a block, and those faults were a quarter of its
// time on this project's VM (docs/performance.md, issue 36). A ScratchVector's buffers:
//   - below 64 KiB come from the heap, as any;
//   - from 64 KiB to 1 MiB go back to a small cache of the calling thread (at most 8 MiB), and the
//     next such request of that thread takes one that fits (at most twice its size);
//   - from 1 MiB on are mapped on their own from a huge-page boundary, with transparent huge pages
//     asked for (madvise), so that each 2 MiB that they span faults in once, not 512 times.
// The cache does not add to the peak: a request that no cached buffer fits first frees cached
// buffers (the largest first) until as many bytes are freed as it asks for, and so does a mapped
// one, so memory grows only where it would have grown without the cache. releaseScratch() empties
// the calling thread's cache; a thread's cache is emptied when the thread ends. Under
// AddressSanitizer every buffer comes from malloc, and cached ones are poisoned.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

namespace isoslab {

/// A buffer of at least `bytes`, from the calling thread's cache when one fits. Throws
/// std::bad_alloc.
void* takeScratch(std::size_t bytes);
/// Gives back a buffer from takeScratch (any thread's) that was asked for with `bytes`.
void giveScratch(void* p, std::size_t bytes) noexcept;
/// Frees the calling thread's cached buffers.
void releaseScratch() noexcept;
/// The bytes in the calling thread's cache (for tests).
std::size_t cachedScratchBytes() noexcept;

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
