#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>

#include "core/error.h"
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

TEST(RawReader, DataLongerThanTheDimsNeedGivesAWarningThatSaysWhatWouldFit) {
  const std::string dir = testing::tempDir();
  writeBytes(dir + "/exact.raw", std::vector<std::uint8_t>(24, 1));
  auto exact = RawReader::open(dir + "/exact.raw", u16Options(3));
  readAll(*exact);
  EXPECT_TRUE(exact->warnings().empty());

  writeBytes(dir + "/long.raw", std::vector<std::uint8_t>(32, 1));
  const std::vector<std::string> expected = {
      dir +
      "/long.raw: holds 32 bytes, 8 more than dims 2x2x3 of u16 need; the extra bytes are ignored; dims 2x2x4 "
      "would use them all"};
  auto plain = RawReader::open(dir + "/long.raw", u16Options(3));
  EXPECT_EQ(plain->warnings(), expected);  // a plain file is measured when opened
  EXPECT_EQ(readAll(*plain).size(), 3u);
  EXPECT_EQ(plain->warnings(), expected);

  RawOptions header = u16Options(3);
  header.headerBytes = 3;
  EXPECT_EQ(RawReader::open(dir + "/long.raw", header)->warnings(),
            std::vector<std::string>{dir + "/long.raw: holds 32 bytes, 5 more than dims 2x2x3 of u16 after a 3-byte "
                                           "header need; the extra bytes are ignored"});

  gzFile f = gzopen((dir + "/v.raw.gz").c_str(), "wb");
  const std::uint8_t data[8] = {1, 0, 2, 0, 3, 0, 4, 0};
  for (int n = 0; n < 3; ++n) gzwrite(f, data, 8);
  gzclose(f);
  auto gz = RawReader::open(dir + "/v.raw.gz", u16Options(2));
  EXPECT_TRUE(gz->warnings().empty());  // a compressed stream is measured at its end
  EXPECT_EQ(readAll(*gz).size(), 2u);
  const std::vector<std::string> inflated = {dir +
                                             "/v.raw.gz: holds 24 bytes once inflated, 8 more than dims 2x2x2 of u16 "
                                             "need; the extra bytes are ignored; dims 2x2x3 would use them all"};
  EXPECT_EQ(gz->warnings(), inflated);
  EXPECT_EQ(gz->warnings(), inflated);  // counted once
}

TEST(RawReader, SliceFilesLongerThanASliceGiveOneWarning) {
  const std::string dir = testing::tempDir();
  for (int k = 1; k <= 3; ++k) writeBytes(dir + "/s." + std::to_string(k), std::vector<std::uint8_t>(16, 0));
  auto all = RawReader::open(dir + "/s.%d", u16Options(0));
  EXPECT_EQ(all->warnings(),
            std::vector<std::string>{dir + "/s.1: holds 16 bytes, 8 more than one 2x2 slice of u16 needs, as do all 3 "
                                           "slice files; the extra bytes are ignored; a 4-byte type (u32, i32 or "
                                           "f32) would use them all"});
  writeBytes(dir + "/s.1", std::vector<std::uint8_t>(8, 0));
  writeBytes(dir + "/s.3", std::vector<std::uint8_t>(8, 0));
  writeBytes(dir + "/s.2", std::vector<std::uint8_t>(12, 0));
  auto one = RawReader::open(dir, u16Options(0));
  EXPECT_EQ(one->warnings(), std::vector<std::string>{dir + "/s.2: holds 12 bytes, 4 more than one 2x2 slice of u16 "
                                                            "needs; the extra bytes are ignored; a 2x3 slice would "
                                                            "use them all"});
  writeBytes(dir + "/s.1", std::vector<std::uint8_t>(16, 0));
  EXPECT_EQ(RawReader::open(dir, u16Options(0))->warnings(),
            std::vector<std::string>{dir + "/s.1: holds 16 bytes, 8 more than one 2x2 slice of u16 needs, as do 2 of "
                                           "the 3 slice files; the extra bytes are ignored; a 4-byte type (u32, i32 "
                                           "or f32) would use them all"});
}

}  // namespace
}  // namespace isoslab
