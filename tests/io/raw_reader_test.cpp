#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "io/error.h"
#include "io/raw_reader.h"
#include "test_support.h"

namespace isoslab {
namespace {

void writeBytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

std::vector<std::vector<float>> readAll(SliceSource& s) {
  std::vector<std::vector<float>> slices;
  std::vector<float> slice(static_cast<std::size_t>(s.info().sliceVoxels()));
  while (s.readSlice(slice)) slices.push_back(slice);
  return slices;
}

std::string openError(const std::string& input, const RawOptions& options) {
  try {
    auto r = RawReader::open(input, options);
    readAll(*r);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

RawOptions u16Options(std::int64_t nz) {
  RawOptions o;
  o.dims = {2, 2, nz};
  o.type = VoxelType::kU16;
  return o;
}

TEST(RawReader, SingleFileWithHeaderAndBigEndian) {
  const std::string dir = testing::tempDir();
  std::vector<std::uint8_t> bytes = {0xAA, 0xBB, 0xCC};  // header
  for (int v = 0; v < 8; ++v) {
    bytes.push_back(0);
    bytes.push_back(static_cast<std::uint8_t>(v));
  }
  writeBytes(dir + "/v.raw", bytes);
  RawOptions o = u16Options(2);
  o.headerBytes = 3;
  o.byteOrder = ByteOrder::kBig;
  o.spacing = {1, 1, 2.5};
  auto r = RawReader::open(dir + "/v.raw", o);
  EXPECT_EQ(r->info().spacing[2], 2.5);
  const auto slices = readAll(*r);
  ASSERT_EQ(slices.size(), 2u);
  EXPECT_EQ(slices[1], (std::vector<float>{4, 5, 6, 7}));
}

TEST(RawReader, PerSliceFilesByPatternAndFolderInNaturalOrder) {
  const std::string dir = testing::tempDir();
  for (int k = 1; k <= 11; ++k) {
    writeBytes(dir + "/s." + std::to_string(k), {static_cast<std::uint8_t>(k), 0, 0, 0, 0, 0, 0, 0});
  }
  RawOptions o = u16Options(0);
  auto byPattern = RawReader::open(dir + "/s.%d", o);
  EXPECT_EQ(byPattern->info().dims[2], 11);
  const auto a = readAll(*byPattern);
  auto byFolder = RawReader::open(dir, o);
  const auto b = readAll(*byFolder);
  ASSERT_EQ(a.size(), 11u);
  EXPECT_EQ(a, b);
  for (int k = 0; k < 11; ++k) EXPECT_EQ(a[static_cast<std::size_t>(k)][0], static_cast<float>(k + 1));
  o.dims[2] = 5;
  EXPECT_EQ(readAll(*RawReader::open(dir, o)).size(), 5u);
}

TEST(RawReader, GzipIsInflatedAsAStream) {
  const std::string dir = testing::tempDir();
  gzFile f = gzopen((dir + "/v.raw.gz").c_str(), "wb");
  const std::uint8_t data[8] = {1, 0, 2, 0, 3, 0, 4, 0};
  gzwrite(f, data, 8);
  gzwrite(f, data, 8);
  gzclose(f);
  auto r = RawReader::open(dir + "/v.raw.gz", u16Options(2));
  const auto slices = readAll(*r);
  ASSERT_EQ(slices.size(), 2u);
  EXPECT_EQ(slices[1], (std::vector<float>{1, 2, 3, 4}));
  EXPECT_EQ(openError(dir + "/v.raw.gz", u16Options(3)), dir + "/v.raw.gz: data ends after 16 of 24 bytes");
}

TEST(RawReader, BadInputsGiveOneClearMessage) {
  const std::string dir = testing::tempDir();
  writeBytes(dir + "/short.raw", std::vector<std::uint8_t>(10, 0));
  EXPECT_EQ(openError(dir + "/short.raw", u16Options(3)),
            dir + "/short.raw: holds 10 bytes, but dims 2x2x3 of u16 after a 0-byte header need 24");
  EXPECT_EQ(openError(dir + "/missing.raw", u16Options(3)),
            dir + "/missing.raw: cannot open: No such file or directory");
  RawOptions zero = u16Options(3);
  zero.dims[0] = 0;
  EXPECT_EQ(openError(dir + "/short.raw", zero),
            dir + "/short.raw: dims 0x2x3 are invalid: every axis needs at least 2 points");
  RawOptions negative = u16Options(3);
  negative.dims[1] = -4;
  EXPECT_EQ(openError(dir + "/short.raw", negative),
            dir + "/short.raw: dims 2x-4x3 are invalid: every axis needs at least 2 points");
  RawOptions huge = u16Options(2000000000);
  huge.dims[0] = 2000000000;
  huge.dims[1] = 2000000000;
  EXPECT_EQ(openError(dir + "/short.raw", huge),
            dir + "/short.raw: dims 2000000000x2000000000x2000000000 are invalid: the voxel count overflows");
  EXPECT_EQ(openError(dir + "/none.%d", u16Options(0)),
            dir + "/none.%d: the pattern matches no file (tried indices 0 and 1)");
}

}  // namespace
}  // namespace isoslab
