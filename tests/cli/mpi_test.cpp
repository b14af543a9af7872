// `isoslab extract` under mpirun (issue 20): every number of ranks gives the bytes of one process,
// and a rank that fails stops every rank with one line and no output. The ranks run as root in
// CI, hence --allow-run-as-root; -q keeps mpirun's own banners off stderr, so that stderr is
// isoslab's alone. ASan's leak check is off for the ranks: Open MPI keeps memory until exit.
// orte_abort_on_non_zero_status 0 lets every rank end by itself (mpirun otherwise kills the rest
// when the first exits non-zero), so that each rank's exit status can be checked. Each mpirun keeps
// its session directory under the test's own temporary directory (orte_tmpdir_base): ctest runs
// these tests side by side, and one mpirun removing the shared /tmp/ompi.* tree while another
// creates its own there failed a CI run ("ORTE_ERROR_LOG ... session_dir.c", exit 1).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "test_support.h"

namespace isoslab {
namespace {

namespace fs = std::filesystem;
using testing::runCli;
using testing::slurp;

#if defined(ISOSLAB_TEST_MPI)

struct RanksResult {
  int exitCode = -1;
  std::string err;
  std::vector<int> rankCodes;  // each rank's own exit status, by rank
};

// `isoslab ARGS` on `ranks` MPI ranks; each rank's exit status is recorded through a shell.
// With `eachRank`, every rank runs to its end (then mpirun's own status is 0).
RanksResult runRanks(int ranks, const std::string& args, bool eachRank = true) {
  const std::string dir = testing::tempDir();
  const std::string cmd = fmt::format(
      "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 OMPI_MCA_orte_tmpdir_base={} timeout 300 {} -q "
      "--allow-run-as-root --oversubscribe {} -np {} "
      "sh -c '\"$0\" \"$@\"; rc=$?; echo $rc > {}/rc.$OMPI_COMM_WORLD_RANK; exit $rc' {} {} 2>{}/stderr </dev/null "
      ">/dev/null",
      dir, ISOSLAB_MPIEXEC, eachRank ? "--mca orte_abort_on_non_zero_status 0" : "", ranks, dir, ISOSLAB_CLI_PATH, args,
      dir);
  const int status = std::system(cmd.c_str());
  RanksResult r;
  r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = slurp(dir + "/stderr");
  for (int k = 0; k < ranks; ++k) {
    const std::string code = slurp(fmt::format("{}/rc.{}", dir, k));
    r.rankCodes.push_back(code.empty() ? -1 : std::stoi(code));
  }
  fs::remove_all(dir);
  return r;
}

// Every method, .ply and .glb, on 1, 2 and 3 ranks of a noisy phantom (40 slices: ranges of 39,
// 19 + 20, 13 + 13 + 13 slabs), against one process; and with threads inside the ranks.
TEST(Mpi, EveryNumberOfRanksWritesTheBytesOfOneProcess) {
  const std::string dir = testing::tempDir();
  const std::string input = "'phantom:head?n=48,44,40&noise=60' --iso 0 --normals -q";
  for (const Method m : testing::kAllMethods) {
    const std::string method(methodName(m));
    for (const std::string ext : {"ply", "glb"}) {
      const std::string single = fmt::format("{}/{}.{}", dir, method, ext);
      const auto one = runCli(fmt::format("extract {} --method {} -o {}", input, method, single));
      ASSERT_EQ(one.exitCode, 0) << one.err;
      const std::string expected = slurp(single);
      ASSERT_FALSE(expected.empty());
      for (const int ranks : {1, 2, 3}) {
        const std::string out = fmt::format("{}/{}-{}.{}", dir, method, ranks, ext);
        const auto r = runRanks(ranks, fmt::format("extract {} --method {} -o {}", input, method, out));
        ASSERT_EQ(r.exitCode, 0) << method << " " << ranks << " ranks: " << r.err;
        EXPECT_EQ(r.err, "");
        EXPECT_TRUE(slurp(out) == expected) << method << " ." << ext << " on " << ranks << " ranks";
      }
    }
  }
  // Ranks with threads of their own, the caps, a report and a component filter (two passes).
  const std::string options = "--method mt6 --threads 2 --sequential-voxels 0 --close-boundary --keep-largest 2";
  const auto one = runCli(fmt::format("extract {} {} -o {}/f.glb --report {}/f.json", input, options, dir, dir));
  ASSERT_EQ(one.exitCode, 0) << one.err;
  const auto r = runRanks(3, fmt::format("extract {} {} -o {}/f3.glb --report {}/f3.json", input, options, dir, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_TRUE(slurp(dir + "/f3.glb") == slurp(dir + "/f.glb"));
  const std::string report = slurp(dir + "/f3.json");
  EXPECT_NE(report.find("\"ranks\": 3"), std::string::npos) << report.substr(0, 400);
  // --seed: only rank 0 sees the first pass's components, and chooses.
  const auto seeded = runCli(fmt::format("extract {} --seed 20,20,20 -o {}/s.ply", input, dir));
  ASSERT_EQ(seeded.exitCode, 0) << seeded.err;
  const auto s2 = runRanks(2, fmt::format("extract {} --seed 20,20,20 -o {}/s2.ply", input, dir));
  ASSERT_EQ(s2.exitCode, 0) << s2.err;
  EXPECT_EQ(s2.err, "");
  EXPECT_TRUE(slurp(dir + "/s2.ply") == slurp(dir + "/s.ply"));
}

// The Philips series (140 slices, 1 mm) on two ranks: rank 1 reads only its own 70 files.
TEST(Mpi, PhilipsSeriesOnTwoRanks) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string dir = testing::tempDir();
  for (const std::string ext : {"ply", "glb"}) {
    const auto one = runCli(fmt::format("extract {} --iso 300 -q -o {}/one.{}", philips, dir, ext));
    ASSERT_EQ(one.exitCode, 0) << one.err;
    const auto r = runRanks(2, fmt::format("extract {} --iso 300 -q -o {}/two.{}", philips, dir, ext));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err, "");
    const std::string expected = slurp(fmt::format("{}/one.{}", dir, ext));
    EXPECT_GT(expected.size(), 1000000u);
    EXPECT_TRUE(slurp(fmt::format("{}/two.{}", dir, ext)) == expected) << ext;
  }
}

// A corrupt slice in the last rank's range: every rank exits 1, stderr holds the one line that
// one process prints for the same input (naming the file), and no output is left.
TEST(Mpi, ARankThatFailsStopsEveryRank) {
  const std::string dir = testing::tempDir();
  // A gzip NIfTI cut at 70% of its bytes: the header and the low slices read, slice ~28 of 40 does not.
  const auto w = runCli(fmt::format("phantom 'phantom:head?n=48,44,40&noise=60' -o {}/v.nii.gz", dir));
  ASSERT_EQ(w.exitCode, 0) << w.err;
  fs::resize_file(dir + "/v.nii.gz", fs::file_size(dir + "/v.nii.gz") * 7 / 10);
  const auto one = runCli(fmt::format("extract {}/v.nii.gz --iso 0 -q -o {}/one.glb", dir, dir));
  ASSERT_EQ(one.exitCode, 1);
  ASSERT_NE(one.err.find(dir + "/v.nii.gz: "), std::string::npos) << one.err;
  ASSERT_EQ(std::count(one.err.begin(), one.err.end(), '\n'), 1) << one.err;
  for (const int ranks : {2, 3}) {
    const auto r = runRanks(
        ranks, fmt::format("extract {}/v.nii.gz --iso 0 -q -o {}/out.glb --report {}/out.json", dir, dir, dir));
    EXPECT_EQ(r.err, one.err) << ranks << " ranks";
    EXPECT_EQ(r.rankCodes, std::vector<int>(static_cast<std::size_t>(ranks), 1)) << ranks << " ranks";
    EXPECT_FALSE(fs::exists(dir + "/out.glb"));
    EXPECT_FALSE(fs::exists(dir + "/out.json"));
    EXPECT_EQ(testing::fileCount(dir), 1) << "only v.nii.gz: no temporary file is left";
  }
  // mpirun as users run it: its status is non-zero.
  const auto plain = runRanks(2, fmt::format("extract {}/v.nii.gz --iso 0 -q -o {}/out.glb", dir, dir), false);
  EXPECT_NE(plain.exitCode, 0);
  EXPECT_EQ(plain.err, one.err);

  // A DICOM file of the Philips series cut short in its pixel data: I1210 is slice 120 of 140
  // (the files' numbers follow z), in rank 1's range of two and rank 2's of three.
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string series = dir + "/philips";
  fs::copy(philips, series);
  fs::resize_file(series + "/I1210", fs::file_size(series + "/I1210") - 200000);
  const auto single = runCli(fmt::format("extract {} --iso 300 -q -o {}/p.glb", series, dir));
  ASSERT_EQ(single.exitCode, 1);
  ASSERT_EQ(single.err, fmt::format("isoslab: error: {}/I1210: not a readable DICOM file: I/O suspension or "
                                    "premature end of stream\n",
                                    series));
  for (const int ranks : {2, 3}) {
    const auto r = runRanks(ranks, fmt::format("extract {} --iso 300 -q -o {}/p.glb", series, dir));
    EXPECT_EQ(r.err, single.err) << ranks << " ranks";
    EXPECT_EQ(r.rankCodes, std::vector<int>(static_cast<std::size_t>(ranks), 1)) << ranks << " ranks";
    EXPECT_FALSE(fs::exists(dir + "/p.glb"));
  }
}

// An error that every rank meets before extracting (an unknown input) prints once.
TEST(Mpi, AnErrorOfEveryRankPrintsOnce) {
  const std::string dir = testing::tempDir();
  const auto one = runCli(fmt::format("extract {}/missing.nii --iso 1 -q -o {}/o.ply", dir, dir));
  ASSERT_EQ(one.exitCode, 1);
  const auto r = runRanks(3, fmt::format("extract {}/missing.nii --iso 1 -q -o {}/o.ply", dir, dir));
  EXPECT_EQ(r.err, one.err);
  EXPECT_EQ(r.rankCodes, std::vector<int>(3, 1));
}

// isoslab batch over 3 ranks: rank r takes inputs r, r + 3, ...; rank 0 writes the summary. The
// meshes are those of one process's batch, and one bad input fails alone.
TEST(Mpi, BatchSpreadsTheInputsOverTheRanks) {
  const std::string dir = testing::tempDir();
  std::ofstream(dir + "/list.txt") << "phantom:head?n=24,20,16&noise=60\nphantom:sphere?n=20\n"
                                   << dir << "/absent.nii\nphantom:torus?n=24\nphantom:box?n=20\n";
  const auto one = runCli(fmt::format("batch {0}/list.txt --out {0}/one -q -- --iso 0 --method mc", dir));
  ASSERT_EQ(one.exitCode, 1) << one.err;
  const auto r = runRanks(3, fmt::format("batch {0}/list.txt --out {0}/three -q -- --iso 0 --method mc", dir));
  EXPECT_EQ(r.rankCodes, std::vector<int>(3, 1));
  EXPECT_EQ(r.err, fmt::format("isoslab: batch: 1 of 5 inputs failed ({}/three/batch.json)\n", dir));
  for (const std::string name : {"head_n_24_20_16_noise_60", "sphere_n_20", "torus_n_24", "box_n_20"}) {
    const std::string mesh = slurp(fmt::format("{}/one/{}.glb", dir, name));
    EXPECT_FALSE(mesh.empty()) << name;
    EXPECT_TRUE(slurp(fmt::format("{}/three/{}.glb", dir, name)) == mesh) << name;
  }
  const std::string summary = slurp(dir + "/three/batch.json");
  EXPECT_NE(summary.find("\"ranks\": 3"), std::string::npos);
  EXPECT_NE(summary.find("\"failed\": 1"), std::string::npos);
}

// Label surfaces (issue 35): the .glb of every label, the per-label files and the report (whose
// voxel counts each rank takes from its own slices) are one process's, on 2 and 3 ranks, as they
// are, smoothed and decimated, and with the per-label component rules (issue 37).
TEST(Mpi, LabelSurfacesOnRanksAreOneProcesssBytes) {
  for (const char* finish : {"", " --smooth 20 --decimate 0.3", " --keep-largest 2 --min-volume 10"}) {
    SCOPED_TRACE(finish);
    const std::string dir = testing::tempDir();
    const std::string input = std::string("'phantom:checker?n=40,36,30&b=3&labels=20' -q") + finish;
    const auto one = runCli(fmt::format("extract {} -o {}/one.glb --report {}/one.json", input, dir, dir));
    ASSERT_EQ(one.exitCode, 0) << one.err;
    if (std::string(finish).find("--decimate") == std::string::npos) {
      EXPECT_EQ(one.err, "");
    } else {
      EXPECT_TRUE(one.err.starts_with("isoslab: warning: --decimate 0.3 kept ")) << one.err;
      EXPECT_EQ(std::count(one.err.begin(), one.err.end(), '\n'), 1) << one.err;
    }
    fs::create_directories(dir + "/p1");
    ASSERT_EQ(runCli(fmt::format("extract {} -o '{}/p1/{{label}}.ply'", input, dir)).exitCode, 0);
    // The report without its times, memory and paths (at any depth).
    const auto stable = [](const std::string& path) {
      const std::function<void(nlohmann::json&)> strip = [&](nlohmann::json& j) {
        if (!j.is_object() && !j.is_array()) return;
        if (j.is_object()) {
          for (auto it = j.begin(); it != j.end();) {
            const std::string& key = it.key();
            const bool drop = key.find("seconds") != std::string::npos || key.ends_with("_mib") ||
                              key == "ring_bytes" || key == "path" || key == "ranks";
            it = drop ? j.erase(it) : std::next(it);
          }
        }
        for (nlohmann::json& child : j) strip(child);
      };
      nlohmann::json report = nlohmann::json::parse(slurp(path));
      strip(report);
      return report.dump(2);
    };
    const std::string report = stable(dir + "/one.json");
    ASSERT_NE(report.find("\"voxels\": "), std::string::npos);
    for (const int ranks : {2, 3}) {
      const auto r = runRanks(ranks, fmt::format("extract {} -o {}/r.glb --report {}/r.json", input, dir, dir));
      ASSERT_EQ(r.exitCode, 0) << r.err;
      // One process's warnings, once, and no more: a decimation's that stopped short of its
      // fraction, and nothing without one.
      EXPECT_EQ(r.err, one.err);
      EXPECT_TRUE(slurp(dir + "/r.glb") == slurp(dir + "/one.glb")) << ranks << " ranks";
      EXPECT_EQ(stable(dir + "/r.json"), report) << ranks << " ranks";
      const std::string folder = fmt::format("{}/p{}", dir, ranks);
      fs::create_directories(folder);
      ASSERT_EQ(runRanks(ranks, fmt::format("extract {} -o '{}/{{label}}.ply'", input, folder)).exitCode, 0);
      for (int label = 1; label <= 20; ++label) {
        EXPECT_TRUE(slurp(fmt::format("{}/{}.ply", folder, label)) == slurp(fmt::format("{}/p1/{}.ply", dir, label)))
            << ranks << " ranks, label " << label;
      }
    }
    fs::remove_all(dir);
  }
}

// Several iso values in one pass (issue 35): each rank runs every value's slab workers, and the
// .glb and the per-value files are one process's, also with the component rules (issue 37).
TEST(Mpi, IsoListsOnRanksAreOneProcesssBytes) {
  for (const char* rules : {"", " --keep-largest 1"}) {
    SCOPED_TRACE(rules);
    const std::string dir = testing::tempDir();
    const std::string input =
        std::string("'phantom:head?n=40,36,30&noise=40' --iso skin,300 --close-boundary -q") + rules;
    ASSERT_EQ(runCli(fmt::format("extract {} -o {}/one.glb", input, dir)).exitCode, 0);
    ASSERT_EQ(runCli(fmt::format("extract {} -o '{}/one-{{iso}}.ply'", input, dir)).exitCode, 0);
    for (const int ranks : {2, 3}) {
      const auto r = runRanks(ranks, fmt::format("extract {} -o {}/r.glb", input, dir));
      ASSERT_EQ(r.exitCode, 0) << r.err;
      EXPECT_EQ(r.err, "");
      EXPECT_TRUE(slurp(dir + "/r.glb") == slurp(dir + "/one.glb")) << ranks << " ranks";
      ASSERT_EQ(runRanks(ranks, fmt::format("extract {} -o '{}/r-{{iso}}.ply'", input, dir)).exitCode, 0);
      for (const char* iso : {"-400", "300"}) {
        const std::string one = slurp(fmt::format("{}/one-{}.ply", dir, iso));
        EXPECT_FALSE(one.empty());
        EXPECT_TRUE(slurp(fmt::format("{}/r-{}.ply", dir, iso)) == one) << ranks << " ranks, iso " << iso;
      }
    }
    fs::remove_all(dir);
  }
}

#else

TEST(Mpi, EveryNumberOfRanksWritesTheBytesOfOneProcess) {
  GTEST_SKIP() << "built without MPI (ISOSLAB_MPI)";
}

#endif

}  // namespace
}  // namespace isoslab
