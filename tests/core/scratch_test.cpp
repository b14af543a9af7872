// Working arrays in huge pages (core/scratch.h).
#include "core/scratch.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <numeric>
#include <sstream>
#include <string>
#include <thread>

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

TEST(Scratch, LargeBuffersStartAtAHugePageAndAreWhollyUsable) {
  for (const std::size_t bytes : {kScratchMapped, (std::size_t{5} << 20) + 17, std::size_t{40} << 20}) {
    auto* p = static_cast<std::uint8_t*>(takeScratch(bytes));
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % kHugePage, 0u) << bytes;
    std::memset(p, 0xab, bytes);
    EXPECT_EQ(p[bytes - 1], 0xab);
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

TEST(Scratch, VectorsKeepTheirValuesAcrossGrowthAndThreads) {
  ScratchVector<std::uint32_t> v;
  for (std::uint32_t k = 0; k < 1'000'000; ++k) v.push_back(k);  // from the heap to mappings
  for (std::uint32_t k = 0; k < v.size(); ++k) ASSERT_EQ(v[k], k);
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
