// Working arrays in huge pages (core/scratch.h).
#include "core/scratch.h"

#include <gtest/gtest.h>
#include <sys/mman.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace isoslab {
namespace {

constexpr std::size_t kHugePage = std::size_t{2} << 20;

// A counter of /proc/vmstat (0 where absent).
std::uint64_t vmstat(const std::string& name) {
  std::ifstream in("/proc/vmstat");
  std::string key;
  std::uint64_t value = 0;
  while (in >> key >> value) {
    if (key == name) return value;
  }
  return 0;
}

// The AnonHugePages of the mapping that holds p, in KiB, from /proc/self/smaps.
std::uint64_t hugeKiBAt(const void* p) {
  std::ifstream in("/proc/self/smaps");
  const auto at = reinterpret_cast<std::uintptr_t>(p);
  std::string line;
  bool inside = false;
  while (std::getline(in, line)) {
    std::uintptr_t from = 0, to = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> from >> dash >> to && dash == '-') {
      inside = from <= at && at < to;
    } else if (inside && line.rfind("AnonHugePages:", 0) == 0) {
      return std::stoull(line.substr(std::strlen("AnonHugePages:")));
    }
  }
  return 0;
}

// Whether this build has AddressSanitizer (gcc says so by a macro, clang 14 by __has_feature).
constexpr bool underAddressSanitizer() {
#if defined(__SANITIZE_ADDRESS__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

TEST(Scratch, LargeBuffersStartAtAHugePageAndAreWhollyUsable) {
  for (const std::size_t bytes : {kScratchHuge, (std::size_t{5} << 20) + 17, std::size_t{40} << 20}) {
    for (const bool populate : {true, false}) {
      auto* p = static_cast<std::uint8_t*>(takeScratch(bytes, populate));
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % kHugePage, 0u) << bytes;
      // Fresh pages are zero, filled in or not (malloc's, under AddressSanitizer, need not be).
      if (!underAddressSanitizer()) {
        EXPECT_EQ(p[bytes / 2], 0) << bytes;
      }
      std::memset(p, 0xab, bytes);
      EXPECT_EQ(p[bytes - 1], 0xab);
      giveScratch(p, bytes);
    }
  }
  // Mapped but smaller than a huge page: any alignment of a page.
  for (const std::size_t bytes : {kScratchMapped, kScratchMapped + 5, kScratchHuge - 1}) {
    auto* p = static_cast<std::uint8_t*>(takeScratch(bytes));
    std::memset(p, 0xcd, bytes);
    EXPECT_EQ(p[bytes - 1], 0xcd);
    giveScratch(p, bytes);
  }
  // Small ones come from malloc: any size, zero too.
  for (const std::size_t bytes : {std::size_t{0}, std::size_t{1}, kScratchMapped - 1}) {
    auto* p = static_cast<std::uint8_t*>(takeScratch(bytes));
    ASSERT_NE(p, nullptr);
    if (bytes > 0) p[bytes - 1] = 1;
    giveScratch(p, bytes);
  }
}

// Whether a mapping holds the address (from /proc/self/maps).
bool mapped(const void* p) {
  std::ifstream in("/proc/self/maps");
  const auto at = reinterpret_cast<std::uintptr_t>(p);
  std::string line;
  while (std::getline(in, line)) {
    std::uintptr_t from = 0, to = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> from >> dash >> to && dash == '-' && from <= at && at < to) return true;
  }
  return false;
}

TEST(Scratch, TheSystemGivesHugePagesWhereItAllowsThem) {
  if (underAddressSanitizer()) GTEST_SKIP() << "under AddressSanitizer every buffer comes from malloc";
  std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string text((std::istreambuf_iterator<char>(mode)), std::istreambuf_iterator<char>());
  if (text.empty() || text.find("[never]") != std::string::npos) {
    GTEST_SKIP() << "transparent huge pages are off here";
  }
  // A process may have them turned off for itself (prctl PR_SET_THP_DISABLE, some containers).
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("THP_enabled:", 0) == 0 && line.find('0') != std::string::npos) {
      GTEST_SKIP() << "transparent huge pages are off for this process";
    }
  }
  const std::size_t bytes = std::size_t{16} << 20;
  const std::uint64_t fallbacks = vmstat("thp_fault_fallback");
  auto* p = static_cast<std::uint8_t*>(takeScratch(bytes));
  std::memset(p, 1, bytes);
  const std::uint64_t huge = hugeKiBAt(p);
  // Granted (16 MiB is eight whole huge pages), unless the system had none free to give. (At
  // least: the kernel may have merged the mapping with a neighbour of the same kind.)
  if (vmstat("thp_fault_fallback") == fallbacks) {
    EXPECT_GE(huge, bytes / 1024);
  }
  giveScratch(p, bytes);
  // Given back whole: the mapping is gone (its first and last page).
  EXPECT_FALSE(mapped(p));
  EXPECT_FALSE(mapped(p + bytes - 1));
}

// How many of the pages of [p, p + bytes) are resident (mincore).
std::size_t residentPages(const void* p, std::size_t bytes) {
  const std::size_t page = 4096;
  std::vector<unsigned char> in((bytes + page - 1) / page);
  if (::mincore(const_cast<void*>(p), bytes, in.data()) != 0) return 0;
  return static_cast<std::size_t>(std::count_if(in.begin(), in.end(), [](unsigned char c) { return (c & 1) != 0; }));
}

// A mapped buffer is resident when it is made (one call, not a fault a page), unless it is asked
// for lazily; where the kernel predates MADV_POPULATE_WRITE (5.14), it faults in as it is used.
TEST(Scratch, MappedBuffersAreFilledInWhenMade) {
  if (underAddressSanitizer()) GTEST_SKIP() << "under AddressSanitizer every buffer comes from malloc";
  {
    void* probe = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    ASSERT_NE(probe, MAP_FAILED);
    const bool known = ::madvise(probe, 4096, MADV_POPULATE_WRITE) == 0;
    ::munmap(probe, 4096);
    if (!known) GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE";
  }
  for (const std::size_t bytes : {kScratchMapped, (std::size_t{3} << 20) + 100}) {
    const std::size_t pages = (bytes + 4095) / 4096;
    void* p = takeScratch(bytes);
    EXPECT_EQ(residentPages(p, bytes), pages) << bytes;
    giveScratch(p, bytes);
    void* lazy = takeScratch(bytes, false);
    EXPECT_EQ(residentPages(lazy, bytes), 0u) << bytes;
    giveScratch(lazy, bytes);
  }
  // Through the vectors.
  ScratchVector<std::uint64_t> filled;
  filled.reserve(100'000);
  EXPECT_EQ(residentPages(filled.data(), 800'000), (800'000 + 4095) / 4096);
  LazyScratchVector<std::uint64_t> lazy;
  lazy.reserve(100'000);
  EXPECT_EQ(residentPages(lazy.data(), 800'000), 0u);
}

TEST(Scratch, VectorsKeepTheirValuesAcrossGrowthAndThreads) {
  ScratchVector<std::uint32_t> v;
  for (std::uint32_t k = 0; k < 1'000'000; ++k) v.push_back(k);  // from the heap to mappings
  for (std::uint32_t k = 0; k < v.size(); ++k) ASSERT_EQ(v[k], k);
  LazyScratchVector<std::uint32_t> lazy(v.begin(), v.end());
  lazy.insert(lazy.end(), v.begin(), v.end());
  for (std::uint32_t k = 0; k < lazy.size(); ++k) ASSERT_EQ(lazy[k], k % v.size());
  // Made on one thread, freed on another.
  auto made = std::make_unique<ScratchVector<std::uint64_t>>(400'000);
  std::iota(made->begin(), made->end(), std::uint64_t{7});
  std::thread([&] {
    EXPECT_EQ((*made)[399'999], 400'006u);
    made.reset();
  }).join();
  EXPECT_EQ(made, nullptr);
}

}  // namespace
}  // namespace isoslab
