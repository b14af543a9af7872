#include <gtest/gtest.h>

#include <cstring>
#include <vector>

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

}  // namespace
}  // namespace isoslab
