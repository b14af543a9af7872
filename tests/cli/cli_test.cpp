#include <gtest/gtest.h>

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::slurp;

using testing::runCli;

TEST(Cli, ExtractWritesMeshAndReport) {
  const std::string dir = testing::tempDir();
  const auto r = runCli("extract 'phantom:sphere?n=64&r=20&field=distance' --iso 800 -o " + dir + "/s.ply --report " +
                        dir + "/r.json --quiet");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  for (const char* key :
       {"method", "iso", "dims", "spacing", "vertices", "triangles", "bounds", "area", "volume", "boundary_edges",
        "nonmanifold_edges", "euler", "seconds", "peak_rss_mib", "output", "degenerate_triangles", "volume_cells"}) {
    EXPECT_TRUE(report.contains(key)) << key;
  }
  for (const char* key : {"read", "extract", "write", "total"}) EXPECT_TRUE(report["seconds"].contains(key)) << key;
  EXPECT_EQ(report["method"], "mc");
  EXPECT_EQ(report["euler"], 2);
  EXPECT_EQ(report["boundary_edges"], 0);
  EXPECT_EQ(report["bounds"].size(), 6u);
  EXPECT_NEAR(report["bounds"][0].get<double>(), 31.5 - 20, 0.05);
  EXPECT_EQ(report["output"]["bytes"].get<std::int64_t>(), static_cast<std::int64_t>(fs::file_size(dir + "/s.ply")));
  EXPECT_EQ(testing::fileCount(dir), 2);
}

TEST(Cli, PhantomStreamedFromMemoryOrFromItsRawFileGivesTheSameBytes) {
  const std::string dir = testing::tempDir();
  const std::string spec = "'phantom:head?n=48,40,36'";
  const auto p = runCli("phantom " + spec + " -o " + dir + "/head.raw");
  ASSERT_EQ(p.exitCode, 0) << p.err;
  EXPECT_EQ(p.out,
            dir + "/head.raw: 138240 bytes; read it back with --raw-dims 48,40,36 --raw-type i16 --spacing 1,1,1\n");
  for (const char* method : {"mc", "mt5", "mt6", "bcc12"}) {
    const std::string m = std::string(" --method ") + method;
    ASSERT_EQ(runCli("extract " + spec + " --iso -400 --normals -q -o " + dir + "/a.ply" + m).exitCode, 0);
    ASSERT_EQ(runCli("extract " + dir + "/head.raw --raw-dims 48,40,36 --raw-type i16 --iso -400 --normals -q -o " +
                     dir + "/b.ply" + m)
                  .exitCode,
              0);
    const std::string a = slurp(dir + "/a.ply");
    EXPECT_GT(a.size(), 10000u);
    EXPECT_EQ(a, slurp(dir + "/b.ply")) << method;
  }
}

struct BadCase {
  std::string args;
  std::string error;
};

TEST(Cli, BadInputGivesOneLineANonZeroExitAndNoOutput) {
  const std::string dir = testing::tempDir();
  {
    std::ofstream f(dir + "/short.raw", std::ios::binary);
    f << std::string(100, '\0');
  }
  const std::string out = " -o " + dir + "/out.ply";
  const std::vector<BadCase> cases = {
      {"extract " + dir + "/short.raw --raw-dims 8,8,8 --iso 1" + out,
       dir + "/short.raw: holds 100 bytes, but dims 8x8x8 of u8 after a 0-byte header need 512"},
      {"extract " + dir + "/short.raw --raw-dims 0,8,8 --iso 1" + out,
       dir + "/short.raw: dims 0x8x8 are invalid: every axis needs at least 2 points"},
      {"extract " + dir + "/short.raw --raw-dims 8,-3,8 --iso 1" + out,
       dir + "/short.raw: dims 8x-3x8 are invalid: every axis needs at least 2 points"},
      {"extract " + dir + "/short.raw --raw-dims 4000000000,4000000000,4000000000 --iso 1" + out,
       dir + "/short.raw: dims 4000000000x4000000000x4000000000 are invalid: an axis exceeds 2147483647 points"},
      {"extract " + dir + "/short.raw --raw-dims 2000000000,2000000000,2000000000 --iso 1" + out,
       dir + "/short.raw: dims 2000000000x2000000000x2000000000 are invalid: the voxel count overflows"},
      {"extract " + dir + "/short.raw --raw-dims 8,8,8 --raw-type u12 --iso 1" + out,
       "--raw-type: unknown voxel type 'u12' (use u8 i8 u16 i16 u32 i32 f32 f64)"},
      {"extract " + dir + "/missing.raw --raw-dims 8,8,8 --iso 1" + out,
       dir + "/missing.raw: cannot open: No such file or directory"},
      {"extract " + dir + "/missing.raw --iso 1" + out, dir + "/missing.raw: cannot open: No such file or directory"},
      {"extract " + dir + "/short.raw --iso 1" + out,
       dir + "/short.raw: unrecognised input format; for raw data give --raw-dims X,Y[,Z] and --raw-type"},
      {"extract 'phantom:sphere?n=16' -o " + dir + "/no/such/folder/out.ply",
       dir + "/no/such/folder/out.ply: cannot create the output: the folder '" + dir +
           "/no/such/folder' does not exist"},
      {"extract 'phantom:sphere?n=16' --method mt7" + out,
       "--method: unknown method 'mt7' (use mc, mt5, mt6 or bcc12)"},
      {"extract 'phantom:sphere?n=16'" + out.substr(0, out.size() - 3) + "xyz",
       dir + "/out.xyz: unknown mesh format '.xyz' (use .ply, .stl, .obj, .glb or .drc)"},
  };
  for (const BadCase& c : cases) {
    const auto r = runCli(c.args);
    EXPECT_EQ(r.exitCode, 1) << c.args;
    EXPECT_EQ(r.err, "isoslab: error: " + c.error + "\n") << c.args;
    EXPECT_EQ(testing::fileCount(dir), 1) << c.args;  // only short.raw
  }
}

TEST(Cli, UsageErrorsExitWithTwo) {
  const auto r = runCli("extract");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: INPUT is required (see isoslab --help)\n");
  EXPECT_EQ(runCli("--help").exitCode, 0);
}

TEST(Cli, AFullDiskLeavesNoPartialFile) {
  // ulimit -f makes writes past 64 KiB fail with EFBIG, as a full disk would fail them.
  const std::string dir = testing::tempDir();
  const std::string cmd = std::string("bash -c \"ulimit -f 64; exec ") + ISOSLAB_CLI_PATH +
                          " extract 'phantom:sphere?n=96&r=40' -q -o " + dir + "/big.ply\" 2>" + dir + "/err";
  const int status = std::system(cmd.c_str());
  EXPECT_NE(status, 0);
  std::ifstream f(dir + "/err");
  std::string line;
  std::getline(f, line);
  EXPECT_EQ(line, "isoslab: error: " + dir + "/big.ply: cannot write the spool file: File too large");
  EXPECT_FALSE(fs::exists(dir + "/big.ply"));
  EXPECT_EQ(testing::fileCount(dir), 1);  // only the captured stderr
}

TEST(Cli, DicomFolderChoosesTheLargestSeriesAndSaysSo) {
  const std::string dir = testing::sharedData("ct-ge-tilt");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/ct-ge-tilt is absent";
  const std::string out = testing::tempDir();
  const auto r = runCli("extract " + dir + " --iso 300 --space ras -o " + out + "/ge.stl --report " + out + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("isoslab: skipped 1 files that are not DICOM images\n"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("isoslab: warning: 13 gaps of up to 7 mm"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(slurp(out + "/r.json"));
  EXPECT_EQ(report["reader"], "dicom");
  EXPECT_EQ(report["space"], "ras");
  const auto info = runCli("info " + dir);
  EXPECT_EQ(info.exitCode, 0);
  EXPECT_NE(info.out.find("1 DICOM series; 1 files skipped (not DICOM images)\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("  value range    -1500 .. 2121 (after rescale)\n"), std::string::npos) << info.out;
  const auto strict = runCli("extract " + dir + " --iso 300 --strict -o " + out + "/x.ply");
  EXPECT_EQ(strict.exitCode, 1);
  EXPECT_EQ(strict.err.rfind("isoslab: error: series 1.2.826.0.1.3680043.9.4245.", 0), 0u) << strict.err;
  EXPECT_FALSE(fs::exists(out + "/x.ply"));
}

TEST(Cli, OutputBytesAreTheSameForEveryThreadCount) {
  const std::string dir = testing::tempDir();
  for (const char* method : {"mc", "mt5", "mt6", "bcc12"}) {
    for (const char* ext : {"ply", "glb"}) {
      std::string first;
      for (int threads : {1, 2, 4}) {
        const std::string out = fmt::format("{}/t{}.{}", dir, threads, ext);
        const auto r =
            testing::runCli(fmt::format("extract 'phantom:head?n=48,44,40&noise=60' --iso 0 --normals -q "
                                        "--chunk-triangles 3000 --method {} --threads {} -o {}",
                                        method, threads, out));
        ASSERT_EQ(r.exitCode, 0) << r.err;
        const std::string bytes = slurp(out);
        EXPECT_GT(bytes.size(), 10000u);
        if (threads == 1) {
          first = bytes;
        } else {
          EXPECT_TRUE(bytes == first) << method << " " << ext << " threads " << threads;
        }
      }
    }
  }
}

TEST(Cli, InfoPrintsGeometryAndRange) {
  const auto r = runCli("info 'phantom:box?n=10,12,14&lo=2,2,2&hi=5,5,5'");
  ASSERT_EQ(r.exitCode, 0);
  EXPECT_NE(r.out.find("dims       10 x 12 x 14\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("range      0 .. 100\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("type       u8\n"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace isoslab
