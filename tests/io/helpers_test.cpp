// The small helpers that several readers and writers share.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>

#include "core/atomic_file.h"
#include "io/volume_file.h"

namespace isoslab {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const noexcept { std::fclose(f); }
};

// Whether a file holding `bytes` starts with gzip's magic bytes, read from its start.
bool gzipMagicOf(const std::string& bytes) {
  const std::unique_ptr<std::FILE, FileCloser> f(std::tmpfile());
  EXPECT_NE(f, nullptr);
  if (f == nullptr) return false;
  EXPECT_EQ(std::fwrite(bytes.data(), 1, bytes.size(), f.get()), bytes.size());
  std::rewind(f.get());
  return startsWithGzipMagic(f.get());
}

TEST(GzipMagic, RecognisesOnlyTheTwoMagicBytes) {
  EXPECT_TRUE(gzipMagicOf(std::string("\x1f\x8b\x08\x00", 4)));
  EXPECT_TRUE(gzipMagicOf(std::string("\x1f\x8b", 2)));
  EXPECT_FALSE(gzipMagicOf(std::string("\x8b\x1f", 2)));
  EXPECT_FALSE(gzipMagicOf(std::string("\x78\x9c", 2)));  // a zlib stream
  EXPECT_FALSE(gzipMagicOf(std::string("\x1f", 1)));      // too short
  EXPECT_FALSE(gzipMagicOf(std::string()));
}

TEST(FolderOf, IsTheParentOrTheCurrentFolder) {
  EXPECT_EQ(folderOf("mesh.glb"), ".");
  EXPECT_EQ(folderOf(""), ".");
  EXPECT_EQ(folderOf("out/mesh.glb"), "out");
  EXPECT_EQ(folderOf("/tmp/a/mesh.glb"), "/tmp/a");
  EXPECT_EQ(folderOf("/mesh.glb"), "/");
}

}  // namespace
}  // namespace isoslab
