// Real scans from ../shared/data; every test skips when the data is absent.
#include <gtest/gtest.h>

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
