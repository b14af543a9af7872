// isoslab extract --roi: the same file, byte for byte, as extracting a cropped copy of the volume
// (in voxel space, whose indices start at the box's corner); a physical box selects the lattice
// points inside it; the note, the report, and the Philips series read only the box's slices.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/volume_info.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::runCli;
using testing::slurp;

constexpr std::array<std::int64_t, 3> kDims{48, 40, 36};
const LatticeBox kBox{{5, 6, 4}, {40, 34, 30}};
const std::string kRaw = "--raw-dims 48,40,36 --raw-type i16";

// The head phantom as raw i16 voxels, written by `isoslab phantom`, and the box cut out of it by
// hand into a second raw file.
struct Volumes {
  std::string full;
  std::string cropped;
  std::string croppedRaw;  // the raw options that read `cropped`
};

Volumes writeVolumes(const std::string& dir) {
  Volumes v{dir + "/head.raw", dir + "/box.raw", ""};
  const auto r = runCli(fmt::format("phantom 'phantom:head?n={},{},{}' -o {}", kDims[0], kDims[1], kDims[2], v.full));
  EXPECT_EQ(r.exitCode, 0) << r.err;
  const std::string bytes = slurp(v.full);
  EXPECT_EQ(bytes.size(), static_cast<std::size_t>(kDims[0] * kDims[1] * kDims[2] * 2));
  std::string box;
  for (std::int64_t k = kBox.lo[2]; k <= kBox.hi[2]; ++k)
    for (std::int64_t j = kBox.lo[1]; j <= kBox.hi[1]; ++j)
      box += bytes.substr(static_cast<std::size_t>(((k * kDims[1] + j) * kDims[0] + kBox.lo[0]) * 2),
                          static_cast<std::size_t>((kBox.hi[0] - kBox.lo[0] + 1) * 2));
  std::ofstream(v.cropped, std::ios::binary) << box;
  const auto d = kBox.dims();
  v.croppedRaw = fmt::format("--raw-dims {},{},{} --raw-type i16", d[0], d[1], d[2]);
  return v;
}

TEST(Roi, VoxelSpaceGivesTheBytesOfACroppedCopy) {
  const std::string dir = testing::tempDir();
  const Volumes v = writeVolumes(dir);
  for (const char* method : {"mc", "mt5", "mt6", "bcc12", "mt24", "mc33"}) {
    for (const char* format : {"ply", "obj"}) {
      const std::string options = fmt::format("--iso -400 --method {} --normals --space voxel -q", method);
      auto r = runCli(fmt::format("extract {} {} {} -o {}/copy.{}", v.cropped, v.croppedRaw, options, dir, format));
      ASSERT_EQ(r.exitCode, 0) << r.err;
      for (const char* threads : {"1", "3"}) {
        r = runCli(fmt::format("extract {} {} --roi 5,6,4,40,34,30 {} --threads {} -o {}/roi.{}", v.full, kRaw, options,
                               threads, dir, format));
        ASSERT_EQ(r.exitCode, 0) << r.err;
        EXPECT_EQ(r.err, "");
        const std::string roi = slurp(fmt::format("{}/roi.{}", dir, format));
        EXPECT_GT(roi.size(), 10000u);
        EXPECT_TRUE(roi == slurp(fmt::format("{}/copy.{}", dir, format))) << method << " " << format;
      }
    }
  }
}

TEST(Roi, PhysicalBoxSelectsTheLatticePointsInside) {
  const std::string dir = testing::tempDir();
  const Volumes v = writeVolumes(dir);
  const std::string input = fmt::format("{} {} --spacing 0.5,0.75,2 --iso -400", v.full, kRaw);
  auto r = runCli(fmt::format("extract {} --roi 5,6,4,40,34,30 -o {}/voxel.ply", input, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // x = 0.5 i: 2.1 .. 20 holds i = 5 .. 40; y = 0.75 j: 4.5 .. 25.5 holds j = 6 .. 34; z = 2 k:
  // 7.5 .. 61 holds k = 4 .. 30.
  r =
      runCli(fmt::format("extract {} --roi 2.1,4.5,7.5,20,25.5,61 --roi-space physical -o {}/physical.ply --report "
                         "{}/r.json",
                         input, dir, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("isoslab: --roi 2.1,4.5,7.5,20,25.5,61 (physical coordinates) selects lattice points "
                       "5,6,4,40,34,30 (36x29x27)\n"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(slurp(dir + "/voxel.ply") == slurp(dir + "/physical.ply"));
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["dims"], nlohmann::json::array({36, 29, 27}));
  EXPECT_EQ(report["roi"]["box"], nlohmann::json::array({5, 6, 4, 40, 34, 30}));
  EXPECT_EQ(report["roi"]["requested"], nlohmann::json::array({2.1, 4.5, 7.5, 20, 25.5, 61}));
  EXPECT_EQ(report["roi"]["space"], "physical");
  EXPECT_EQ(report["roi"]["clipped"], false);
  EXPECT_EQ(report["roi"]["input_dims"], nlohmann::json::array({48, 40, 36}));
  // In RAS, x and y are negated: the same points.
  r = runCli(fmt::format("extract {} --space ras --roi=-20,-25.5,7.5,-2.1,-4.5,61 --roi-space physical -o {}/ras.ply",
                         input, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("(ras coordinates) selects lattice points 5,6,4,40,34,30"), std::string::npos) << r.err;
  // With --space voxel a physical box is in the input's lattice indices, rounded inwards.
  r = runCli(fmt::format("extract {} --space voxel --roi 4.5,5.1,3.9,40.9,34,30 --roi-space physical -q -o {}/v.ply",
                         input, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  r = runCli(fmt::format("extract {} --space voxel --roi 5,6,4,40,34,30 -q -o {}/v2.ply", input, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(slurp(dir + "/v.ply") == slurp(dir + "/v2.ply"));
}

TEST(Roi, ABoxPartlyOutsideIsClippedWithANote) {
  const std::string dir = testing::tempDir();
  const Volumes v = writeVolumes(dir);
  auto r = runCli(fmt::format("extract {} {} --iso -400 --roi=-5,0,30,100,39,35 -o {}/a.ply --report {}/r.json", v.full,
                              kRaw, dir, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("isoslab: --roi -5,0,30,100,39,35 reaches past the volume's 48x40x36 lattice points: clipped "
                       "to 0,0,30,47,39,35\n"),
            std::string::npos)
      << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["dims"], nlohmann::json::array({48, 40, 6}));
  EXPECT_EQ(report["roi"]["box"], nlohmann::json::array({0, 0, 30, 47, 39, 35}));
  EXPECT_EQ(report["roi"]["clipped"], true);
  EXPECT_EQ(report["roi"]["space"], "voxel");
  EXPECT_TRUE(report["warnings"].empty()) << report["warnings"];
  // --quiet keeps the note to itself.
  r = runCli(fmt::format("extract {} {} --iso -400 --roi=-5,0,30,100,39,35 -q -o {}/a.ply", v.full, kRaw, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err, "");
}

// The whole series is 140 slices; the box's 20 are the only ones whose files are opened after the
// header scan (the scan reads every file's header, pixel data aside).
TEST(Roi, PhilipsSeriesBoxOf20Slices) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string dir = testing::tempDir();
  const auto r = runCli(fmt::format("extract {} --iso 350 --roi 0,0,60,511,511,79 -o {}/box.ply --report {}/r.json -q",
                                    philips, dir, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["dims"], nlohmann::json::array({512, 512, 20}));
  EXPECT_EQ(report["roi"]["input_dims"], nlohmann::json::array({512, 512, 140}));
  EXPECT_GT(report["triangles"].get<std::int64_t>(), 10000);
  EXPECT_EQ(report["interior_boundary_edges"], 0);
  // The slices' z: 1 mm apart, the box's 20 slices span 19 mm.
  const auto& vb = report["volume_bounds"];
  EXPECT_NEAR(vb[5].get<double>() - vb[2].get<double>(), 19.0, 1e-3);
}

}  // namespace
}  // namespace isoslab
