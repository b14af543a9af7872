// The thread's cache of working buffers (core/scratch.h).
#include "core/scratch.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <thread>

namespace isoslab {
namespace {

constexpr std::size_t kKiB = 1024;

TEST(Scratch, AFreedBufferServesTheNextRequestThatFits) {
  releaseScratch();
  void* first = takeScratch(300 * kKiB);
  giveScratch(first, 300 * kKiB);
  EXPECT_GE(cachedScratchBytes(), 300 * kKiB);
  // A little smaller, and a little larger within the same size class (an eighth of 256 KiB wide).
  void* again = takeScratch(290 * kKiB);
  EXPECT_EQ(again, first);
  EXPECT_EQ(cachedScratchBytes(), 0u);
  giveScratch(again, 290 * kKiB);
  void* third = takeScratch(300 * kKiB);
  EXPECT_EQ(third, first);
  giveScratch(third, 300 * kKiB);
  releaseScratch();
  EXPECT_EQ(cachedScratchBytes(), 0u);
}

TEST(Scratch, ARequestThatNothingFitsFreesAsMuchAsItTakes) {
  releaseScratch();
  // Size classes an eighth of the power of two wide: 100 KiB holds 104, 120 holds 120, 600 holds
  // 640 and 700 holds 704.
  void* a = takeScratch(100 * kKiB);
  void* b = takeScratch(120 * kKiB);
  void* c = takeScratch(600 * kKiB);
  giveScratch(a, 100 * kKiB);
  giveScratch(b, 120 * kKiB);
  giveScratch(c, 600 * kKiB);
  EXPECT_EQ(cachedScratchBytes(), (104 + 120 + 640) * kKiB);
  // 700 KiB fits none: the largest go until as much is freed (640 + 120), so memory does not grow.
  void* d = takeScratch(700 * kKiB);
  EXPECT_EQ(cachedScratchBytes(), 104 * kKiB);
  giveScratch(d, 700 * kKiB);
  EXPECT_EQ(cachedScratchBytes(), (104 + 704) * kKiB);
  // 150 KiB (class 160) is not served by a buffer more than twice its class: the 704 KiB one makes
  // room for it instead.
  void* e = takeScratch(150 * kKiB);
  EXPECT_NE(e, d);
  EXPECT_EQ(cachedScratchBytes(), 104 * kKiB);
  giveScratch(e, 150 * kKiB);
  releaseScratch();
}

TEST(Scratch, TheCacheHoldsAtMostEightMebibytes) {
  releaseScratch();
  std::vector<void*> buffers;
  for (int k = 0; k < 30; ++k) buffers.push_back(takeScratch(900 * kKiB));
  for (void* p : buffers) giveScratch(p, 900 * kKiB);
  EXPECT_LE(cachedScratchBytes(), std::size_t{8} << 20);
  EXPECT_GE(cachedScratchBytes(), std::size_t{7} << 20);
  releaseScratch();
  EXPECT_EQ(cachedScratchBytes(), 0u);
}

TEST(Scratch, LargeBuffersStartAtAHugePageAndAreNotCached) {
  releaseScratch();
  for (const std::size_t bytes : {std::size_t{1} << 20, (std::size_t{5} << 20) + 17}) {
    auto* p = static_cast<std::uint8_t*>(takeScratch(bytes));
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % (std::size_t{2} << 20), 0u);
    p[0] = 1;
    p[bytes - 1] = 2;  // the whole request is usable
    giveScratch(p, bytes);
    EXPECT_EQ(cachedScratchBytes(), 0u);
  }
}

TEST(Scratch, VectorsKeepTheirValuesAcrossGrowthAndThreads) {
  ScratchVector<std::uint32_t> v;
  for (std::uint32_t k = 0; k < 600'000; ++k) v.push_back(k);  // through the heap, the cache and a mapping
  for (std::uint32_t k = 0; k < v.size(); ++k) ASSERT_EQ(v[k], k);
  // Made on one thread, freed on another: it goes to the other thread's cache, which is emptied
  // when that thread ends.
  auto made = std::make_unique<ScratchVector<std::uint64_t>>(40'000);
  std::iota(made->begin(), made->end(), std::uint64_t{7});
  std::thread([&] {
    EXPECT_EQ((*made)[39'999], 40'006u);
    made.reset();
    EXPECT_GE(cachedScratchBytes(), 40'000 * sizeof(std::uint64_t));
  }).join();
  EXPECT_EQ(made, nullptr);
}

}  // namespace
}  // namespace isoslab
