// isoslab render and extract --preview, through the program, with the PNGs read back by
// OpenImageIO.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <set>

#include "test_support.h"

namespace isoslab {
namespace {

using testing::runCli;
using testing::slurp;

struct Png {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<std::uint8_t> pixels;
  std::array<int, 3> at(int x, int y) const {
    const std::size_t i =
        3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x));
    return {pixels[i], pixels[i + 1], pixels[i + 2]};
  }
};

Png readPng(const std::string& path) {
  Png png;
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path << ": " << OIIO::geterror();
  if (!in) return png;
  png.width = in->spec().width;
  png.height = in->spec().height;
  png.channels = in->spec().nchannels;
  png.pixels.resize(static_cast<std::size_t>(png.width) * static_cast<std::size_t>(png.height) * 3);
  EXPECT_EQ(png.channels, 3);
  EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::UINT8, png.pixels.data()));
  return png;
}

// The preview is render of the written PLY, byte for byte, for 1 and 3 threads, flat and smooth.
TEST(Render, PreviewEqualsRenderOfTheWrittenMesh) {
  const std::string dir = testing::tempDir();
  const std::string input = "'phantom:head?n=48,44,40'";
  std::string first;
  for (const std::string normals : {"", " --normals"}) {
    for (const std::string threads : {"1", "3"}) {
      SCOPED_TRACE(normals + " threads " + threads);
      const std::string mesh = dir + "/h" + threads + ".ply";
      const auto r = runCli("extract " + input + normals + " --threads " + threads + " -q -o " + mesh + " --preview " +
                            dir + "/p.png --preview-view iso --preview-size 320x240");
      ASSERT_EQ(r.exitCode, 0) << r.err;
      const auto v = runCli("render " + mesh + " -o " + dir + "/r.png --view iso --size 320x240");
      ASSERT_EQ(v.exitCode, 0) << v.err;
      EXPECT_EQ(
          v.err,
          "isoslab: " +
              std::to_string(
                  testing::extract("phantom:head?n=48,44,40", Method::kMarchingCubes, -400).mesh.triangles.size()) +
              " triangles, 320x240 pixels -> " + dir + "/r.png\n");
      const std::string preview = slurp(dir + "/p.png");
      EXPECT_EQ(preview, slurp(dir + "/r.png"));
      if (threads == "1") first = preview;
      EXPECT_EQ(preview, first);  // the same bytes for every thread count
      const Png png = readPng(dir + "/p.png");
      EXPECT_EQ(png.width, 320);
      EXPECT_EQ(png.height, 240);
      EXPECT_EQ(png.at(0, 0), (std::array<int, 3>{255, 255, 255}));
      EXPECT_NE(png.at(160, 120), (std::array<int, 3>{255, 255, 255}));
    }
    first.clear();
  }
}

// Draco's quantized positions move silhouette pixels by at most about one: the .glb's render and
// the preview differ in few pixels.
TEST(Render, GlbRendersLikeThePreviewWithinQuantization) {
  const std::string dir = testing::tempDir();
  ASSERT_EQ(runCli("extract 'phantom:sphere?n=48&r=16' -q --chunk-triangles 2000 -o " + dir + "/s.glb --preview " +
                   dir + "/p.png --preview-size 200")
                .exitCode,
            0);
  ASSERT_EQ(runCli("render " + dir + "/s.glb -o " + dir + "/r.png --size 200").exitCode, 0);
  const Png p = readPng(dir + "/p.png");
  const Png r = readPng(dir + "/r.png");
  ASSERT_EQ(p.pixels.size(), r.pixels.size());
  int differ = 0;
  for (int y = 0; y < 200; ++y) {
    for (int x = 0; x < 200; ++x) {
      const auto a = p.at(x, y);
      const auto b = r.at(x, y);
      for (int c = 0; c < 3; ++c) differ += std::abs(a[c] - b[c]) > 8 ? 1 : 0;
    }
  }
  EXPECT_LT(differ, 3 * 200 * 200 / 100) << "more than 1% of the pixels differ";
  // Colour by chunk: the sphere's chunks show in several palette colours.
  ASSERT_EQ(runCli("render " + dir + "/s.glb -o " + dir + "/c.png --size 200 --chunk-colours").exitCode, 0);
  const Png c = readPng(dir + "/c.png");
  std::set<std::array<int, 3>> hues;
  for (int y = 0; y < 200; y += 4) {
    for (int x = 0; x < 200; x += 4) {
      const auto px = c.at(x, y);
      if (px != std::array<int, 3>{255, 255, 255}) hues.insert({px[0] / 64, px[1] / 64, px[2] / 64});
    }
  }
  EXPECT_GE(hues.size(), 3u);
}

// compare --suite figures: one labelled PNG per case, a panel of 360 x 390 pixels per method, and
// the triangle counts of each method as extract gives them.
TEST(Render, FiguresSuiteDrawsEveryCaseForEveryMethod) {
  const std::string dir = testing::tempDir();
  const auto r = runCli("compare --suite figures --methods mc,mt6 -q --out " + dir);
  ASSERT_EQ(r.exitCode, 0) << r.err;
  for (const char* name : {"cube2_iso100", "cube2_iso50", "cube6_iso100", "cube6_iso50", "cube80_iso100",
                           "cube80_iso50", "sphere_r28.46", "head"}) {
    const Png png = readPng(dir + "/" + name + ".png");
    EXPECT_EQ(png.width, 720) << name;
    EXPECT_EQ(png.height, 390) << name;
    // The label strip holds black text over white; the panels' centres are covered.
    int dark = 0;
    for (int y = 0; y < 30; ++y) {
      for (int x = 0; x < 360; ++x) dark += png.at(x, y)[0] < 100 ? 1 : 0;
    }
    EXPECT_GT(dark, 50) << name;
    EXPECT_NE(png.at(180, 210), (std::array<int, 3>{255, 255, 255})) << name;
    EXPECT_NE(png.at(540, 210), (std::array<int, 3>{255, 255, 255})) << name;
  }
  // The ear has only the tetrahedral methods of the list: one panel.
  EXPECT_EQ(readPng(dir + "/ear.png").width, 360);
  // The cube of edge 6 at iso 50: counts derived in Extract tests (mc 428, mt6 1,584).
  const std::string md = slurp(dir + "/figures.md");
  EXPECT_NE(md.find("| cube, edge 6, iso 50 | 428 | 1584 |"), std::string::npos) << md;
}

TEST(Render, BadInputAndOptionsGetOneLine) {
  const std::string dir = testing::tempDir();
  const auto missing = runCli("render " + dir + "/none.ply -o " + dir + "/x.png");
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.err, "isoslab: error: " + dir + "/none.ply: cannot open: No such file or directory\n");
  ASSERT_EQ(runCli("extract 'phantom:sphere?n=16' -q -o " + dir + "/s.ply").exitCode, 0);
  const std::vector<std::pair<std::string, std::string>> usage = {
      {"--size 0", "--size: '0' is not N or WxH pixels"},
      {"--size 20000", "--size: '20000' is not N or WxH pixels"},
      {"--size 10x", "--size: '10x' is not N or WxH pixels"},
      {"--view side", "--view: unknown view 'side' (use front, back, left, right, top, bottom or iso)"},
      {"--background pink", "--background: 'pink' is not white, black, grey or #rrggbb"},
      {"--shading phong", "--shading: unknown shading 'phong' (use auto, flat or smooth)"},
  };
  for (const auto& [option, message] : usage) {
    const auto r = runCli("render " + dir + "/s.ply -o " + dir + "/x.png " + option);
    EXPECT_EQ(r.exitCode, 2) << option;
    EXPECT_EQ(r.err, "isoslab: error: " + message + "\n") << option;
  }
  const auto folder = runCli("render " + dir + "/s.ply -o " + dir + "/no/x.png");
  EXPECT_EQ(folder.exitCode, 1);
  EXPECT_EQ(folder.err.rfind("isoslab: error: " + dir + "/no/x.png: ", 0), 0u) << folder.err;
  const auto same = runCli("extract 'phantom:sphere?n=16' -q -o " + dir + "/t.ply --preview " + dir + "/t.ply");
  EXPECT_EQ(same.exitCode, 2);
  EXPECT_EQ(same.err, "isoslab: error: --preview '" + dir + "/t.ply' names the same file as another output\n");
  EXPECT_EQ(testing::fileCount(dir), 1);  // only s.ply: no image, no temporary file
}

}  // namespace
}  // namespace isoslab
