// isoslab view: the self-contained HTML page, and (when node, the npm packages and Debian's chromium
// are here) that page opened in a real headless browser over http and from file://.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "test_support.h"

namespace isoslab {
namespace {

namespace fs = std::filesystem;
using testing::runCli;
using testing::slurp;

const std::string kNpm = ISOSLAB_NPM_DIR;

std::string absolute(const std::string& path) {
  return fs::absolute(path).lexically_normal().string();
}

// A chunked, Draco-compressed head and its report in a fresh folder.
std::string extractHead() {
  const std::string dir = testing::tempDir();
  const auto r = runCli("extract 'phantom:head?n=64,64,56' --iso -400 --chunk-triangles 5000 -o " + dir +
                        "/h.glb --report " + dir + "/r.json -q");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  return dir;
}

TEST(View, WritesOneSelfContainedPage) {
  if (!fs::exists(kNpm + "/node_modules/three"))
    GTEST_SKIP() << "three.js is absent from " << kNpm << " (scripts/test.sh installs it)";
  const std::string dir = extractHead();
  const auto r = runCli("view " + dir + "/h.glb --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "isoslab: viewer page -> " + absolute(dir + "/h.html") +
                       " (open it in a browser; it works from file://)\n");
  const std::string page = slurp(dir + "/h.html");
  ASSERT_GT(page.size(), 1000000u);  // three.js, the loaders, the Draco decoder and the mesh
  // Everything is embedded (the files as base64): no address the browser could fetch.
  EXPECT_EQ(page.find("http://"), std::string::npos);
  EXPECT_EQ(page.find("https://"), std::string::npos);
  EXPECT_EQ(page.find("src=\""), std::string::npos);
  EXPECT_NE(page.find("<title>h.glb - isoslab viewer</title>"), std::string::npos);
  EXPECT_EQ(testing::fileCount(dir), 3);  // h.glb, r.json, h.html: no temporary left

  // The same inputs give the same bytes; -o names the page.
  const auto again = runCli("view " + dir + "/h.glb --report " + dir + "/r.json -o " + dir + "/again.html");
  ASSERT_EQ(again.exitCode, 0) << again.err;
  EXPECT_EQ(slurp(dir + "/again.html"), page);
  // Without a report the page is smaller only by the report.
  ASSERT_EQ(runCli("view " + dir + "/h.glb -o " + dir + "/bare.html").exitCode, 0);
  EXPECT_LT(slurp(dir + "/bare.html").size(), page.size());
}

TEST(View, RealBrowserShowsTheMesh) {
  if (const std::string why = testing::gltfClientsMissing(kNpm); !why.empty()) GTEST_SKIP() << why;
  if (!fs::exists(kNpm + "/node_modules/playwright-core")) {
    GTEST_SKIP() << "playwright-core is absent from " << kNpm << " (scripts/test.sh installs it)";
  }
  const char* chromium = std::getenv("ISOSLAB_CHROMIUM");
  if (!fs::exists(chromium != nullptr ? chromium : "/usr/bin/chromium")) {
    GTEST_SKIP() << "no chromium at /usr/bin/chromium (Debian's package chromium; or set ISOSLAB_CHROMIUM)";
  }
  const std::string dir = extractHead();
  const auto view = runCli("view " + dir + "/h.glb --report " + dir + "/r.json");
  ASSERT_EQ(view.exitCode, 0) << view.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  const std::string cmd = "node " + kNpm + "/viewer_check.mjs " + dir + "/h.html " + dir + "/shot.png > " + dir +
                          "/browser.json 2>" + dir + "/browser.err";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/browser.json") << slurp(dir + "/browser.err");
  const auto seen = nlohmann::json::parse(slurp(dir + "/browser.json"));
  EXPECT_EQ(seen["triangles"], report["triangles"]) << seen;
  EXPECT_EQ(seen["primitives"].get<double>(), report["output"]["chunks"].get<double>()) << seen;
  EXPECT_GT(report["output"]["chunks"].get<double>(), 2.0);
  EXPECT_GT(seen["nonBlank"].get<double>(), 5000.0) << seen;      // of 800 x 600
  EXPECT_GT(seen["chunkChanged"].get<double>(), 1000.0) << seen;  // colour by chunk recolours it
  EXPECT_GT(seen["flatChanged"].get<double>(), 1000.0) << seen;   // and flat shading shows the facets
  EXPECT_NE(seen["title"].get<std::string>().find(std::to_string(report["triangles"].get<long long>()) + " triangles"),
            std::string::npos)
      << seen;
  EXPECT_TRUE(seen["external"].empty()) << seen;   // no request left the page (blob: and data: aside)
  EXPECT_EQ(seen["file"]["ready"], true) << seen;  // from file:// too
  EXPECT_EQ(seen["file"]["triangles"], report["triangles"]) << seen;
  ASSERT_TRUE(fs::exists(dir + "/shot.png"));
  EXPECT_GT(fs::file_size(dir + "/shot.png"), 10000u);
}

TEST(View, BadInputsFailInOneLineAndLeaveNoPage) {
  const std::string dir = testing::tempDir();
  const auto missing = runCli("view " + dir + "/missing.glb");
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.err, "isoslab: error: " + dir + "/missing.glb: cannot open: No such file or directory\n");

  {
    std::FILE* f = std::fopen((dir + "/s.ply").c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fputs("ply\nformat binary_little_endian 1.0\nelement vertex 0\nend_header\n", f);
    std::fclose(f);
  }
  const auto ply = runCli("view " + dir + "/s.ply");
  EXPECT_EQ(ply.exitCode, 1);
  EXPECT_EQ(ply.err, "isoslab: error: " + dir +
                         "/s.ply: not a .glb file (binary glTF starts with 'glTF'); view takes the .glb that extract "
                         "wrote\n");

  EXPECT_FALSE(fs::exists(dir + "/missing.html"));
  EXPECT_FALSE(fs::exists(dir + "/s.html"));
  EXPECT_EQ(testing::fileCount(dir), 1);  // s.ply
}

// A bad report and an output folder that does not exist: reached only once the page's scripts
// (three.js) are found, so this half skips, and says so, without them.
TEST(View, BadReportAndMissingFolderFailInOneLineAndLeaveNoPage) {
  if (!fs::exists(kNpm + "/node_modules/three"))
    GTEST_SKIP() << "three.js is absent from " << kNpm << " (scripts/test.sh installs it)";
  const std::string dir = testing::tempDir();
  const auto glb = runCli("extract 'phantom:sphere?n=24' -q -o " + dir + "/s.glb");
  ASSERT_EQ(glb.exitCode, 0) << glb.err;
  {
    std::FILE* f = std::fopen((dir + "/bad.json").c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fputs("{\"triangles\": ", f);
    std::fclose(f);
  }
  const auto bad = runCli("view " + dir + "/s.glb --report " + dir + "/bad.json");
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_EQ(bad.err.rfind("isoslab: error: " + dir + "/bad.json: not a JSON report: ", 0), 0u) << bad.err;
  EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1);
  const auto folder = runCli("view " + dir + "/s.glb -o " + dir + "/none/s.html");
  EXPECT_EQ(folder.exitCode, 1);
  EXPECT_EQ(folder.err.rfind("isoslab: error: " + dir + "/none/s.html: ", 0), 0u) << folder.err;
  EXPECT_FALSE(fs::exists(dir + "/s.html"));
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name == "s.glb" || name == "bad.json") << name;
  }
}

}  // namespace
}  // namespace isoslab
