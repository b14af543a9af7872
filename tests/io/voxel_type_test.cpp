#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "io/file_list.h"
#include "core/voxel_type.h"

namespace isoslab {
namespace {

TEST(VoxelType, NamesRoundTrip) {
  for (VoxelType t : {VoxelType::kU8, VoxelType::kI8, VoxelType::kU16, VoxelType::kI16, VoxelType::kU32,
                      VoxelType::kI32, VoxelType::kF32, VoxelType::kF64}) {
    EXPECT_EQ(parseVoxelType(voxelTypeName(t)), t);
  }
  EXPECT_EQ(parseVoxelType("INT16"), VoxelType::kI16);
  EXPECT_EQ(parseVoxelType("double"), VoxelType::kF64);
  EXPECT_FALSE(parseVoxelType("i12").has_value());
  EXPECT_EQ(voxelSize(VoxelType::kF64), 8u);
}

TEST(VoxelType, ConvertsBothByteOrders) {
  const std::byte big[4] = {std::byte{0x01}, std::byte{0x02}, std::byte{0xff}, std::byte{0xfe}};
  float out[2];
  convertToFloat(big, VoxelType::kU16, ByteOrder::kBig, out);
  EXPECT_EQ(out[0], 258.0f);
  EXPECT_EQ(out[1], 65534.0f);
  convertToFloat(big, VoxelType::kI16, ByteOrder::kLittle, out);
  EXPECT_EQ(out[0], 513.0f);
  EXPECT_EQ(out[1], -257.0f);
}

TEST(VoxelType, FromFloatRoundsAndClamps) {
  const float in[4] = {-3.6f, 2.5f, 300.0f, 99.4f};
  std::byte bytes[4];
  convertFromFloat(in, VoxelType::kU8, bytes);
  EXPECT_EQ(std::to_integer<int>(bytes[0]), 0);
  EXPECT_EQ(std::to_integer<int>(bytes[1]), 2);  // round half to even
  EXPECT_EQ(std::to_integer<int>(bytes[2]), 255);
  EXPECT_EQ(std::to_integer<int>(bytes[3]), 99);
  EXPECT_EQ(quantize(-40000, VoxelType::kI16), -32768);
}

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
