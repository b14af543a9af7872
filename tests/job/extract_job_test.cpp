// The extraction job as a library call (job/extract_job.h, issue 34): the program's bytes and
// report, progress, stops that leave nothing, and settings errors that name the setting.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "core/error.h"
#include "core/interrupt.h"
#include "job/extract_job.h"
#include "test_support.h"

namespace isoslab {
namespace {

using testing::CliResult;
using testing::fileCount;
using testing::runCli;
using testing::slurp;
using testing::tempDir;

constexpr const char* kPhantom = "phantom:head?n=48,44,40&seed=5&noise=0.05";

ExtractSettings phantomSettings(const std::string& output) {
  ExtractSettings s;
  s.inputs = {kPhantom};
  s.output = output;
  s.iso = parseIsoRequest("0.5");
  s.method = Method::kTetra6;
  s.normals = true;
  return s;
}

// The report without what differs between two runs: times, memory, and the output's path.
nlohmann::json stable(const std::string& text) {
  nlohmann::json r = nlohmann::json::parse(text);
  r.erase("seconds");
  r.erase("peak_rss_mib");
  r["output"].erase("path");
  r["output"].erase("encode_seconds");
  return r;
}

TEST(ExtractJob, WritesTheProgramsBytesAndReport) {
  const std::string dir = tempDir();
  ExtractSettings s = phantomSettings(dir + "/lib.glb");
  s.reportPath = dir + "/lib.json";
  s.components.keepLargest = 1;
  s.smoothing.iterations = 4;
  s.threads = 2;
  s.sequentialVoxels = 0;
  const ExtractReport report = runExtract(s);
  const CliResult cli = runCli(fmt::format(
      "extract '{}' --iso 0.5 --method mt6 --normals --keep-largest 1 --smooth 4 --threads 2 --sequential-voxels 0 "
      "-q -o {}/cli.glb --report {}/cli.json",
      kPhantom, dir, dir));
  ASSERT_EQ(cli.exitCode, 0) << cli.err;
  EXPECT_EQ(slurp(dir + "/lib.glb"), slurp(dir + "/cli.glb"));
  EXPECT_EQ(stable(slurp(dir + "/lib.json")), stable(slurp(dir + "/cli.json")));
  // The typed report is what the JSON says.
  const nlohmann::json json = nlohmann::json::parse(slurp(dir + "/lib.json"));
  EXPECT_EQ(report.stats.triangles, json["triangles"].get<std::uint64_t>());
  EXPECT_EQ(report.method, "mt6");
  EXPECT_EQ(report.output.bytes, static_cast<std::int64_t>(slurp(dir + "/lib.glb").size()));
  ASSERT_TRUE(report.seconds.componentPass.has_value());
  EXPECT_EQ(report.seconds.total, json["seconds"]["total"].get<double>());
}

TEST(ExtractJob, TheSameBytesForEveryThreadCount) {
  const std::string dir = tempDir();
  std::string first;
  for (int threads : {1, 2, 3}) {
    ExtractSettings s = phantomSettings(dir + "/m.ply");
    s.threads = threads;
    s.sequentialVoxels = 0;
    runExtract(s);
    const std::string bytes = slurp(dir + "/m.ply");
    if (first.empty()) first = bytes;
    EXPECT_EQ(bytes, first) << threads << " threads";
  }
  EXPECT_GT(first.size(), 1000u);
}

// Records progress; asks to stop once `stopAfter` slabs have gone by (0: never).
class Recorder final : public ExtractObserver {
 public:
  explicit Recorder(int stopAfter = 0) : stopAfter_(stopAfter) {}
  void progress(const ExtractProgress& p) override {
    fractions.push_back(p.fraction);
    stages.emplace_back(p.stage);
  }
  void note(const std::string& text) override { notes.push_back(text); }
  void warning(const std::string& text) override { warnings.push_back(text); }
  bool stopRequested() override { return stopAfter_ > 0 && static_cast<int>(fractions.size()) >= stopAfter_; }

  std::vector<double> fractions;
  std::vector<std::string> stages, notes, warnings;

 private:
  int stopAfter_;
};

TEST(ExtractJob, ProgressRisesOverBothPassesToOne) {
  const std::string dir = tempDir();
  ExtractSettings s = phantomSettings(dir + "/m.ply");
  s.components.minTriangles = 10;
  Recorder r;
  runExtract(s, r);
  // Each pass reports every slab (39 of a 40-slice volume), then 1 once committed.
  ASSERT_EQ(r.fractions.size(), 2u * 39u + 1u);
  for (std::size_t i = 1; i < r.fractions.size(); ++i) EXPECT_LT(r.fractions[i - 1], r.fractions[i]) << i;
  EXPECT_EQ(r.fractions.back(), 1.0);
  EXPECT_EQ(r.stages.front(), "components");
  EXPECT_EQ(r.stages[39], "extract");
  EXPECT_NEAR(r.fractions[38], 0.5, 1e-12);
}

TEST(ExtractJob, AStopLeavesNoOutputAndNoTemporaryFile) {
  for (const char* format : {"glb", "ply", "drc", "obj", "stl"}) {
    const std::string dir = tempDir();
    ExtractSettings s = phantomSettings(fmt::format("{}/m.{}", dir, format));
    s.reportPath = dir + "/m.json";
    s.preview.path = dir + "/m.png";
    s.threads = 2;
    s.sequentialVoxels = 0;
    Recorder r(5);
    try {
      runExtract(s, r);
      ADD_FAILURE() << format << ": the run did not stop";
    } catch (const Interrupted& e) {
      EXPECT_EQ(e.signal(), 0);
    }
    EXPECT_EQ(r.fractions.size(), 5u) << format << ": stopped at the slab that asked";
    EXPECT_EQ(fileCount(dir), 0) << format;
  }
}

TEST(ExtractJob, SettingsErrorsNameTheSetting) {
  const std::string dir = tempDir();
  const auto message = [&](auto change) {
    ExtractSettings s = phantomSettings(dir + "/m.ply");
    change(s);
    try {
      runExtract(s);
    } catch (const SettingError& e) {
      return std::string(e.what());
    }
    return std::string("no SettingError");
  };
  EXPECT_EQ(message([](ExtractSettings& s) { s.threads = -1; }),
            "`threads` must be 1 to 256 (or 0: the default), not -1");
  EXPECT_EQ(message([&](ExtractSettings& s) { s.reportPath = dir + "/./m.ply"; }),
            fmt::format("`report` '{0}/./m.ply' names the same file as `output` '{0}/m.ply'", dir));
  EXPECT_EQ(message([](ExtractSettings& s) { s.decimate = 2; }), "`decimate` must be above 0 and at most 1");
  EXPECT_EQ(message([](ExtractSettings& s) { s.roi = std::array<double, 6>{0, 0, 9, 9, 9, 3}; }),
            "`roi` is reversed: its upper corner is below its lower one on axis 2");
  EXPECT_EQ(message([](ExtractSettings& s) {
              s.iso.reset();
              s.inputs = {"phantom:sphere?n=8"};
            }),
            "no SettingError");  // phantoms suggest their iso value
  EXPECT_EQ(settingsAsFlags(message([](ExtractSettings& s) { s.dracoLevel = 11; })),
            "--draco-level must be 0 to 10, not 11");
  EXPECT_EQ(fileCount(dir), 1);  // the one run that could go on wrote its mesh
}

TEST(ExtractJob, NotesAndWarningsReachTheObserver) {
  const std::string dir = tempDir();
  ExtractSettings s = phantomSettings(dir + "/m.ply");
  s.roi = std::array<double, 6>{-5, 0, 0, 100, 30, 30};
  s.iso = parseIsoRequest("5000");
  Recorder r;
  const ExtractReport report = runExtract(s, r);
  ASSERT_EQ(r.notes.size(), 1u);
  EXPECT_EQ(r.notes[0],
            "`roi` -5,0,0,100,30,30 reaches past the volume's 48x44x40 lattice points: clipped to "
            "0,0,0,47,30,30");
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings, report.warnings);
  EXPECT_NE(r.warnings[0].find("`iso` 5000 is above the input's value range"), std::string::npos) << r.warnings[0];
}

}  // namespace
}  // namespace isoslab
