#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "io/file_list.h"

namespace isoslab {
namespace {

TEST(FileList, NaturalOrder) {
  std::vector<std::string> names = {"CThead.10", "CThead.2", "CThead.1", "CThead.100", "a01", "a1", "a0"};
  std::sort(names.begin(), names.end(), [](const auto& a, const auto& b) { return naturalLess(a, b); });
  EXPECT_EQ(names, (std::vector<std::string>{"CThead.1", "CThead.2", "CThead.10", "CThead.100", "a0", "a1", "a01"}));
}

TEST(FileList, SlicePatterns) {
  EXPECT_TRUE(isSlicePattern("CThead.%d"));
  EXPECT_TRUE(isSlicePattern("slice_%03d.raw"));
  EXPECT_FALSE(isSlicePattern("100%"));
  EXPECT_FALSE(isSlicePattern("a%s"));
  EXPECT_FALSE(isSlicePattern("%d_%d"));
  EXPECT_EQ(formatPattern("s%03d.raw", 7), "s007.raw");
}

}  // namespace
}  // namespace isoslab
