// Real scans from ../shared/data; every test skips when the data is absent.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "io/open_source.h"
#include "test_support.h"

namespace isoslab {
namespace {

TEST(RealData, EngineAtIso90IsClosedWhereInteriorAndOrdersTheMethods) {
  const std::string engine = testing::sharedData("engine/engine_256x256x128_uint8.raw.gz");
  if (engine.empty()) GTEST_SKIP() << "../shared/data/engine is absent";
  SourceOptions o;
  o.raw = RawOptions{};
  o.raw->dims = {256, 256, 128};
  std::uint64_t mc = 0, mt6 = 0, bcc = 0;
  for (Method m : {Method::kMarchingCubes, Method::kTetra6, Method::kBcc12}) {
    auto source = openSource(engine, o);
    const testing::Extraction x = testing::extract(*source, m, 90);
    EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u) << methodName(m);
    EXPECT_EQ(x.stats.nonManifoldEdges, 0u) << methodName(m);
    EXPECT_EQ(x.stats.inconsistentEdges, 0u) << methodName(m);
    (m == Method::kMarchingCubes ? mc : m == Method::kTetra6 ? mt6 : bcc) = x.stats.triangles;
  }
  EXPECT_GT(mt6, mc);
  EXPECT_GT(bcc, mt6);
}

// The Philips head at -400 (skin) is cut by the volume's faces; --close-boundary closes it.
TEST(RealData, PhilipsHeadWithCloseBoundaryHasNoBoundaryEdges) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  ExtractOptions options;
  options.iso = -400;
  options.closeBoundary = true;
  const testing::Extraction x = testing::extract(openSource(philips, {}), options, 2);
  EXPECT_GT(x.stats.triangles, 1000000u);
  EXPECT_EQ(x.stats.boundaryEdges, 0u);
  EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u);
  EXPECT_EQ(x.stats.nonManifoldEdges, 0u);
  EXPECT_EQ(x.stats.inconsistentEdges, 0u);
}

// The head without its holder: one closed component, checked by `isoslab metrics` on the file
// written. The holder is the second largest (about 715,000 triangles of 2.56 million).
TEST(RealData, PhilipsHeadKeepLargestIsOneClosedComponent) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string dir = testing::tempDir();
  const auto r = testing::runCli(
      fmt::format("extract {} --iso -400 --close-boundary --keep-largest 1 -q -o {}/head.ply --report {}/r.json",
                  philips, dir, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
  EXPECT_GT(report["components"]["count"].get<int>(), 10);
  EXPECT_EQ(report["component_filter"]["kept"]["count"], 1);
  EXPECT_GT(report["component_filter"]["dropped"]["triangles"].get<double>(), 500000);
  const auto m = testing::runCli(fmt::format("metrics {}/head.ply", dir));
  ASSERT_EQ(m.exitCode, 0) << m.err;
  const auto metrics = nlohmann::json::parse(m.out);
  EXPECT_EQ(metrics["components"]["count"], 1);
  EXPECT_EQ(metrics["components"]["closed"], 1);
  EXPECT_EQ(metrics["boundary_edges"], 0);
  EXPECT_EQ(metrics["nonmanifold_edges"], 0);
  EXPECT_EQ(metrics["triangles"], report["components"]["largest"][0]["triangles"]);
  EXPECT_GT(metrics["triangles"].get<double>(), 1500000);
}

// --decimate 0.1 on the head at -400: 10% +- 1% of the triangles, as closed and manifold as the
// input (open only at the volume's faces), every sample point within half a voxel of the original
// surface, and the .glb's chunks join without a crack (decode welds them; no hole appears).
TEST(RealData, PhilipsHeadDecimatedToATenth) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string dir = testing::tempDir();
  const auto r = testing::runCli(
      fmt::format("extract {} --iso -400 --decimate 0.1 --chunk-triangles 60000 -q -o {}/head.glb --report {}/r.json",
                  philips, dir, dir));
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
  const auto& d = report["decimation"];
  EXPECT_NEAR(d["kept_fraction"].get<double>(), 0.1, 0.01);
  EXPECT_LT(d["distance_max_voxels"].get<double>(), 0.5);
  EXPECT_EQ(report["nonmanifold_edges"], 0);
  EXPECT_EQ(report["inconsistent_edges"], 0);
  EXPECT_EQ(report["interior_boundary_edges"], 0);
  EXPECT_GT(report["output"]["chunks"].get<double>(), 2);
  const auto decoded = testing::runCli(fmt::format("decode {}/head.glb -o {}/head.ply", dir, dir));
  ASSERT_EQ(decoded.exitCode, 0) << decoded.err;
  const auto m = testing::runCli(fmt::format("metrics {}/head.ply", dir));
  ASSERT_EQ(m.exitCode, 0) << m.err;
  const auto metrics = nlohmann::json::parse(m.out);
  EXPECT_EQ(metrics["triangles"], report["triangles"]);
  EXPECT_EQ(metrics["boundary_edges"], report["boundary_edges"]);
  EXPECT_EQ(metrics["interior_boundary_edges"], 0);
  EXPECT_EQ(metrics["nonmanifold_edges"], 0);
}

TEST(RealData, CtHeadBigEndianSlicesAtIso600IsClosedWhereInterior) {
  const std::string cthead = testing::sharedData("cthead");
  if (cthead.empty()) GTEST_SKIP() << "../shared/data/cthead is absent";
  SourceOptions o;
  o.raw = RawOptions{};
  o.raw->dims = {256, 256, 0};
  o.raw->type = VoxelType::kU16;
  o.raw->byteOrder = ByteOrder::kBig;
  o.raw->spacing = {1, 1, 2};
  auto source = openSource(cthead, o);
  EXPECT_EQ(source->info().dims[2], 113);
  const testing::Extraction x = testing::extract(*source, Method::kMarchingCubes, 600);
  EXPECT_GT(x.stats.triangles, 100000u);
  EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u);
  EXPECT_EQ(x.stats.nonManifoldEdges, 0u);
  EXPECT_EQ(x.stats.inconsistentEdges, 0u);
  EXPECT_GT(x.stats.degenerateTriangles, 0u);                       // integer data: values exactly at 600 occur
  EXPECT_NEAR(x.stats.bounds[5] - x.stats.bounds[2], 224.0, 10.0);  // about 113 slices x 2
}

}  // namespace
}  // namespace isoslab
