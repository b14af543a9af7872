// `isoslab batch` (issue 20): many inputs, one mesh and report each, a summary, and a bad input
// that is reported while the others go on.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli/batch.h"
#include "test_support.h"

namespace isoslab {
namespace {

namespace fs = std::filesystem;
using testing::runCli;
using testing::slurp;

TEST(Batch, NamesComeFromTheInputs) {
  EXPECT_EQ(cli::batchName("scans/knee.nii.gz"), "knee");
  EXPECT_EQ(cli::batchName("scans/knee.NRRD"), "knee");
  EXPECT_EQ(cli::batchName("/data/ct-philips-head/"), "ct-philips-head");
  EXPECT_EQ(cli::batchName("/data/series 1"), "series_1");
  EXPECT_EQ(cli::batchName("slice.0001.dat"), "slice.0001.dat");  // not a volume extension: kept
  EXPECT_EQ(cli::batchName("phantom:head?n=48,44,40&noise=60"), "head_n_48_44_40_noise_60");
  EXPECT_EQ(cli::batchName("/"), "input");
}

// Four lines (a comment and a blank line between), one of them a missing file, two of one name:
// each good input's mesh is the bytes `isoslab extract` writes for it, the bad one is listed with
// its one-line error, and the status is 1.
TEST(Batch, ManyInputsOneMeshAndReportEachAndASummary) {
  const std::string dir = testing::tempDir();
  const std::string missing = dir + "/absent.nii.gz";
  std::ofstream(dir + "/list.txt") << "# inputs\nphantom:head?n=24,20,16&noise=60\n\n"
                                   << missing << "\n  phantom:sphere?n=20  \nphantom:head?n=24,20,16&noise=60\n";
  const auto r =
      // --quiet is batch's option too: after `--` it is extract's.
      runCli(
          fmt::format("batch {0}/list.txt --out {0}/out --jobs 2 --format ply -- --iso 0 --method mt6 --quiet", dir));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err, fmt::format("isoslab: batch: 1 of 4 inputs failed ({}/out/batch.json)\n", dir));
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 2 + 4) << r.out;

  const auto summary = nlohmann::json::parse(slurp(dir + "/out/batch.json"));
  EXPECT_EQ(summary["inputs"], 4);
  EXPECT_EQ(summary["failed"], 1);
  const auto& rows = summary["results"];
  ASSERT_EQ(rows.size(), 4u);
  const std::vector<std::string> names{"head_n_24_20_16_noise_60", "", "sphere_n_20", "head_n_24_20_16_noise_60-2"};
  const std::vector<std::string> inputs{"phantom:head?n=24,20,16&noise=60", missing, "phantom:sphere?n=20",
                                        "phantom:head?n=24,20,16&noise=60"};
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(rows[k]["input"], inputs[k]);
    if (k == 1) {
      EXPECT_EQ(rows[k]["status"], "failed");
      EXPECT_EQ(rows[k]["exit_code"], 1);
      const auto single = runCli(fmt::format("extract {} --iso 0 -q -o {}/x.ply", missing, dir));
      EXPECT_EQ("isoslab: error: " + rows[k]["error"].get<std::string>() + "\n", single.err);
      continue;
    }
    EXPECT_EQ(rows[k]["status"], "ok");
    const std::string mesh = fmt::format("{}/out/{}.ply", dir, names[k]);
    EXPECT_EQ(rows[k]["output"], mesh);
    const auto report = nlohmann::json::parse(slurp(fmt::format("{}/out/{}.json", dir, names[k])));
    EXPECT_EQ(rows[k]["triangles"], report["triangles"]);
    const auto one = runCli(fmt::format("extract '{}' --iso 0 --method mt6 -q -o {}/one.ply", inputs[k], dir));
    ASSERT_EQ(one.exitCode, 0) << one.err;
    EXPECT_TRUE(slurp(mesh) == slurp(dir + "/one.ply")) << names[k];
  }
  // The sphere at iso 0 is empty: its warning is kept.
  EXPECT_EQ(rows[2]["warnings"].size(), 1u);
  // Nothing else in the folder: 3 meshes, 3 reports, batch.json; no stderr files left.
  EXPECT_EQ(testing::fileCount(dir + "/out"), 7);
}

// A name that a later repeat would take is skipped: sphere_n_20, then a missing file whose own name
// is sphere_n_20-2, then the sphere again: sphere_n_20-3, never a second sphere_n_20-2.
TEST(Batch, RepeatedNamesNeverCollide) {
  const std::string dir = testing::tempDir();
  std::ofstream(dir + "/list.txt") << "phantom:sphere?n=20\n" << dir << "/sphere_n_20-2.nii\nphantom:sphere?n=20\n";
  const auto r = runCli(fmt::format("batch {0}/list.txt --out {0}/out -q -- --iso 900", dir));
  EXPECT_EQ(r.exitCode, 1);
  const auto rows = nlohmann::json::parse(slurp(dir + "/out/batch.json"))["results"];
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0]["output"], dir + "/out/sphere_n_20.glb");
  EXPECT_EQ(rows[1]["status"], "failed");
  EXPECT_EQ(rows[2]["output"], dir + "/out/sphere_n_20-3.glb");
}

TEST(Batch, OutputAndReportAreTheBatchs) {
  const std::string dir = testing::tempDir();
  std::ofstream(dir + "/list.txt") << "phantom:sphere?n=20\n";
  const auto r = runCli(fmt::format("batch {0}/list.txt --out {0}/out -- --iso 0 -o x.glb", dir));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: batch: '-o' is set for each input (DIR/NAME.glb and DIR/NAME.json)\n");
  const auto empty = runCli(fmt::format("batch {0}/none.txt --out {0}/out -- --iso 0", dir));
  EXPECT_EQ(empty.exitCode, 1);
  EXPECT_EQ(empty.err, fmt::format("isoslab: error: {}/none.txt: cannot open: No such file or directory\n", dir));
  std::ofstream(dir + "/blank.txt") << "# nothing\n\n";
  const auto blank = runCli(fmt::format("batch {0}/blank.txt --out {0}/out -- --iso 0", dir));
  EXPECT_EQ(blank.exitCode, 1);
  EXPECT_EQ(blank.err,
            fmt::format("isoslab: error: {}/blank.txt: lists no input (one per line; # starts a comment)\n", dir));
}

}  // namespace
}  // namespace isoslab
