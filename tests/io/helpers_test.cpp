// The small helpers that several readers and writers share.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
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

// A spool gives back exactly what was written, in order, in pieces of any size, as often as it
// is rewound; reading past its end is an error that names its owner, and it leaves no file.
TEST(SpoolFile, ReadsBackWhatWasWrittenAndNothingMore) {
  const std::string folder = ::testing::TempDir() + "/isoslab-spool-test-" + std::to_string(::getpid());
  std::filesystem::create_directories(folder);
  SpoolFile spool(folder, "out/mesh.ply");
  std::vector<std::uint32_t> written(300000);
  for (std::size_t k = 0; k < written.size(); ++k) written[k] = static_cast<std::uint32_t>(k * 2654435761u);
  spool.write(written.data(), 100 * sizeof(std::uint32_t));
  spool.write(written.data() + 100, (written.size() - 100) * sizeof(std::uint32_t));
  EXPECT_EQ(spool.size(), static_cast<std::int64_t>(written.size() * sizeof(std::uint32_t)));
  for (int pass = 0; pass < 2; ++pass) {
    spool.rewind();
    std::vector<std::uint32_t> back(written.size());
    spool.read(back.data(), 7 * sizeof(std::uint32_t));
    spool.read(back.data() + 7, (back.size() - 7) * sizeof(std::uint32_t));
    EXPECT_EQ(back, written);
    std::uint32_t more = 0;
    try {
      spool.read(&more, 1);
      ADD_FAILURE() << "read past the end";
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), "out/mesh.ply: cannot read the spool file back: it is short");
    }
  }
  EXPECT_TRUE(std::filesystem::is_empty(folder));
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace isoslab
