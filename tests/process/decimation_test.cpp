#include "process/decimation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "extract/frame.h"
#include "io/pad_source.h"
#include "metrics/mesh_stats.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace isoslab {
namespace {

using Field = std::function<float(std::int64_t, std::int64_t, std::int64_t)>;

struct Decimated {
  IndexedMesh original, decimated;
  MeshStats stats;  // of the decimated mesh, measured as it streamed
  DecimationReport report;
};

// Extracts (capped), decimates with small blocks so that there are many seams, and measures.
Decimated decimate(const Field& field, std::array<std::int64_t, 3> dims, Method method, const DecimateOptions& o,
                   int threads = 1) {
  ExtractOptions options;
  options.method = method;
  options.iso = 0;
  options.closeBoundary = true;
  std::unique_ptr<SliceSource> source = std::make_unique<testing::VectorSource>(dims, field);
  const VolumeInfo info = source->info();
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  source = std::make_unique<PadSource>(std::move(source));
  MemoryMeshSink original, decimated;
  MeshStatsSink stats;
  TeeSink after({&decimated, &stats});
  DecimationSink decimation(after, o);
  TeeSink before({&original, &decimation});
  PipelineOptions p;
  p.threads = threads;
  p.sequentialVoxels = 0;  // threads even on a small volume
  runPipeline(*source, *extractor, before, header, p);
  return {original.mesh(), decimated.mesh(), stats.stats(), decimation.report()};
}

using Vec3d = std::array<double, 3>;

// The distance from p to triangle abc: by the closest point on its plane when that lies inside,
// else by the nearest point of its three edges.
double distanceToTriangle(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const auto segment = [&](const Vec3d& x, const Vec3d& y) {
    Vec3d xy{y[0] - x[0], y[1] - x[1], y[2] - x[2]};
    const double len2 = xy[0] * xy[0] + xy[1] * xy[1] + xy[2] * xy[2];
    double t = len2 > 0 ? ((p[0] - x[0]) * xy[0] + (p[1] - x[1]) * xy[1] + (p[2] - x[2]) * xy[2]) / len2 : 0;
    t = std::clamp(t, 0.0, 1.0);
    return std::hypot(p[0] - x[0] - t * xy[0], p[1] - x[1] - t * xy[1], p[2] - x[2] - t * xy[2]);
  };
  const Vec3d e1{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const Vec3d n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
  const double n2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  if (n2 > 0) {
    const double d = ((p[0] - a[0]) * n[0] + (p[1] - a[1]) * n[1] + (p[2] - a[2]) * n[2]) / n2;
    const Vec3d q{p[0] - d * n[0], p[1] - d * n[1], p[2] - d * n[2]};
    // Inside when q is on the inner side of all three edges.
    const auto side = [&](const Vec3d& x, const Vec3d& y) {
      const Vec3d xy{y[0] - x[0], y[1] - x[1], y[2] - x[2]}, xq{q[0] - x[0], q[1] - x[1], q[2] - x[2]};
      const Vec3d c2{xy[1] * xq[2] - xy[2] * xq[1], xy[2] * xq[0] - xy[0] * xq[2], xy[0] * xq[1] - xy[1] * xq[0]};
      return c2[0] * n[0] + c2[1] * n[1] + c2[2] * n[2] >= 0;
    };
    if (side(a, b) && side(b, c) && side(c, a)) return std::abs(d) * std::sqrt(n2);
  }
  return std::min({segment(a, b), segment(b, c), segment(c, a)});
}

// Exact distances to a mesh's surface, up to `reach`: each unit cell lists the triangles whose
// box, grown by `reach`, meets it, so a point's nearest triangle within `reach` is among its cell's.
// Farther points get infinity.
class MeshDistance {
 public:
  MeshDistance(const IndexedMesh& mesh, double reach) : mesh_(mesh), reach_(reach) {
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      std::array<double, 3> lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
      for (VertexId v : mesh.triangles[t]) {
        const Vec3d p = at(v);
        for (std::size_t a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
      }
      for (auto i = cell(lo[0] - reach); i <= cell(hi[0] + reach); ++i)
        for (auto j = cell(lo[1] - reach); j <= cell(hi[1] + reach); ++j)
          for (auto k = cell(lo[2] - reach); k <= cell(hi[2] + reach); ++k) cells_[{i, j, k}].push_back(t);
    }
  }
  double operator()(const Vec3d& p) const {
    const auto found = cells_.find({cell(p[0]), cell(p[1]), cell(p[2])});
    double best = INFINITY;
    if (found == cells_.end()) return best;
    for (std::size_t t : found->second) {
      const Triangle& tri = mesh_.triangles[t];
      best = std::min(best, distanceToTriangle(p, at(tri[0]), at(tri[1]), at(tri[2])));
    }
    return best <= reach_ ? best : INFINITY;
  }

 private:
  static std::int64_t cell(double x) { return static_cast<std::int64_t>(std::floor(x)); }
  Vec3d at(VertexId v) const { return {mesh_.positions[v].x, mesh_.positions[v].y, mesh_.positions[v].z}; }
  const IndexedMesh& mesh_;
  double reach_;
  std::map<std::array<std::int64_t, 3>, std::vector<std::size_t>> cells_;
};

// Both sides of the Hausdorff distance between a decimation and its original, measured here rather
// than taken from the report: every decimated triangle's sample points (centroid and edge
// midpoints, which the report measures: its distanceMax must be their largest distance) and three
// points between them, to the original surface, within `bound` voxels (the unit here); every
// original vertex to the decimated surface, within `backBound`. The decimation bounds only the first
// side (the README says so), so the other gets its own bound: half a voxel, the lattice's own
// resolution, even where the first is tighter.
void expectWithin(const Decimated& r, double bound, double backBound = 0.5) {
  const MeshDistance toOriginal(r.original, 2 * bound);
  double samples = 0, between = 0, sum = 0;
  for (const Triangle& tri : r.decimated.triangles) {
    const Vec3f& a = r.decimated.positions[tri[0]];
    const Vec3f& b = r.decimated.positions[tri[1]];
    const Vec3f& c = r.decimated.positions[tri[2]];
    const auto point = [&](double u, double v, double w) {
      return Vec3d{u * a.x + v * b.x + w * c.x, u * a.y + v * b.y + w * c.y, u * a.z + v * b.z + w * c.z};
    };
    for (const Vec3d& q :
         {point(1.0 / 3, 1.0 / 3, 1.0 / 3), point(0.5, 0.5, 0), point(0, 0.5, 0.5), point(0.5, 0, 0.5)}) {
      samples = std::max(samples, toOriginal(q));
      sum += toOriginal(q);
    }
    for (const Vec3d& q :
         {point(4.0 / 6, 1.0 / 6, 1.0 / 6), point(1.0 / 6, 4.0 / 6, 1.0 / 6), point(1.0 / 6, 1.0 / 6, 4.0 / 6)}) {
      between = std::max(between, toOriginal(q));
    }
  }
  const MeshDistance toDecimated(r.decimated, 2 * backBound);
  double back = 0;
  for (const Vec3f& p : r.original.positions) back = std::max(back, toDecimated({p.x, p.y, p.z}));
  std::printf("[decimation] %zu -> %zu triangles: samples %.4f, between them %.4f, original vertices %.4f\n",
              r.original.triangles.size(), r.decimated.triangles.size(), samples, between, back);
  EXPECT_LE(samples, bound + 1e-9);
  EXPECT_NEAR(r.report.distanceMax, samples, 1e-6);
  ASSERT_EQ(r.report.samples, 4 * r.decimated.triangles.size());
  EXPECT_NEAR(r.report.distanceMean, sum / double(r.report.samples), 1e-9);
  EXPECT_LE(between, bound + 1e-9);
  EXPECT_LE(back, backBound + 1e-9);
}

// A lumpy ball cut by the volume's faces and a torus beside it: curvature, caps and two components.
Field lumpyScene() {
  return [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i), y = double(j), z = double(k);
    const double ball = 13.0 - std::hypot(x - 12.2, y - 14.1, z - 3.3) + 0.8 * std::sin(0.5 * x) * std::cos(0.4 * y);
    const double torus = 3.5 - std::hypot(std::hypot(x - 30.2, z - 22.1) - 8.0, y - 16.3);
    return static_cast<float>(std::max(ball, torus));
  };
}

DecimateOptions smallBlocks(double ratio) {
  DecimateOptions o;
  o.ratio = ratio;
  o.blockSlabs = 10;
  o.blockTriangles = 2000;
  return o;
}

TEST(Decimation, StaysClosedManifoldAndNearTheSurfaceAcrossManySeams) {
  for (Method method : {Method::kMarchingCubes, Method::kTetra6, Method::kMarchingCubes33}) {
    SCOPED_TRACE(std::string(methodName(method)));
    for (double ratio : {0.5, 0.2}) {
      SCOPED_TRACE(ratio);
      const Decimated r = decimate(lumpyScene(), {44, 32, 44}, method, smallBlocks(ratio));
      ASSERT_GE(r.report.blocks, 3u);
      EXPECT_EQ(r.report.trianglesIn, r.original.triangles.size());
      EXPECT_EQ(r.report.trianglesOut, r.decimated.triangles.size());
      // The input was closed, manifold and consistently wound: so is the output.
      EXPECT_EQ(r.stats.boundaryEdges, 0u);
      EXPECT_EQ(r.stats.nonManifoldEdges, 0u);
      EXPECT_EQ(r.stats.inconsistentEdges, 0u);
      // Small blocks of a small, curved mesh: the half-voxel bound freezes some triangles, so the
      // ratio is approached from above (without the bound it is met: the next test).
      const double kept = double(r.decimated.triangles.size()) / double(r.original.triangles.size());
      EXPECT_GE(kept, ratio - 0.03);
      EXPECT_LE(kept, ratio + 0.15);
      // Every vertex is an original one (collapses move none), and the sample points the report
      // measures lie within half a voxel of the original surface: checked by brute force.
      const std::set<std::array<float, 3>> originals = [&] {
        std::set<std::array<float, 3>> s;
        for (const Vec3f& p : r.original.positions) s.insert({p.x, p.y, p.z});
        return s;
      }();
      for (const Vec3f& p : r.decimated.positions) ASSERT_TRUE(originals.count({p.x, p.y, p.z})) << "a new vertex";
      expectWithin(r, 0.5);
      EXPECT_GT(r.report.distanceMean, 0.0);
    }
  }
}

// An integer field whose samples often equal the iso value: marching cubes puts vertices on those
// samples, so many original triangles have two corners on one point (their distance is undefined
// by the closed form). The report's distances are still those of the brute force, mean and max.
TEST(Decimation, DegenerateOriginalsLeaveTheReportsDistancesExact) {
  const Field steps = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<float>(std::round(9.0 - std::hypot(double(i) - 15.3, double(j) - 14.1, double(k) - 16.2) +
                                         0.8 * std::sin(0.9 * double(i)) * std::cos(0.7 * double(k))));
  };
  const Decimated r = decimate(steps, {32, 30, 34}, Method::kMarchingCubes, smallBlocks(0.2));
  std::size_t flat = 0;
  for (const Triangle& t : r.original.triangles) {
    const Vec3f &a = r.original.positions[t[0]], &b = r.original.positions[t[1]], &c = r.original.positions[t[2]];
    flat += a == b || b == c || c == a ? 1 : 0;
  }
  EXPECT_GT(flat, 20u);
  EXPECT_LT(r.decimated.triangles.size(), r.original.triangles.size() / 2);
  expectWithin(r, 0.5, 1.0);  // the decimation bounds only the first side
}

// A bound too tight for any collapse on a curved surface: every triangle is left as it was, so every
// sample point lies on an original triangle and the report's distances are 0 exactly (the search
// would find each triangle itself, with rounding about its plane).
TEST(Decimation, TrianglesLeftAsTheyWereMeasureZero) {
  const Field torus = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<float>(4.5 - std::hypot(std::hypot(double(i) - 15.2, double(k) - 14.1) - 8.3, double(j) - 8.4));
  };
  DecimateOptions o = smallBlocks(0.2);
  o.maxDistance = 1e-9;
  const Decimated r = decimate(torus, {31, 18, 30}, Method::kMarchingCubes, o);
  ASSERT_GT(r.original.triangles.size(), 1000u);
  ASSERT_EQ(r.decimated.triangles.size(), r.original.triangles.size());
  EXPECT_EQ(r.report.samples, 4 * r.original.triangles.size());
  EXPECT_EQ(r.report.distanceMax, 0.0);
  EXPECT_EQ(r.report.distanceMean, 0.0);
}

// A foam of small blobs cut by many seams: the frozen ring about a block's border can hold an edge
// between two input corners in both of its triangles. The simplifier is given those triangles, their
// corners fixed, so that no collapse makes such an edge again outside them (four triangles on it):
// without them, 5 of this foam's 35 simplify calls made one, which the check found and repaired.
TEST(Decimation, FrozenEdgesAreNeverMadeAgain) {
  const Field foam = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = 1.7 * double(i), y = 1.7 * double(j), z = 1.7 * double(k);
    return static_cast<float>(std::cos(0.9 * x + 0.3 * y) * std::cos(0.8 * y + 0.2 * z) * std::cos(0.85 * z + 0.1 * x) -
                              0.1);
  };
  DecimateOptions o = smallBlocks(0.1);
  o.blockSlabs = 3;
  o.blockTriangles = 500;
  const Decimated r = decimate(foam, {40, 40, 40}, Method::kMarchingCubes, o);
  ASSERT_GT(r.report.blocks, 10u);
  EXPECT_LT(r.decimated.triangles.size(), r.original.triangles.size() * 6 / 10);
  EXPECT_EQ(r.report.brokenShape, 0u);
  EXPECT_EQ(r.stats.boundaryEdges, 0u);
  EXPECT_EQ(r.stats.nonManifoldEdges, 0u);
  EXPECT_EQ(r.stats.inconsistentEdges, 0u);
  // In batches of components (each batch keeps its context on top of its share of the target): the
  // same, and about as many triangles kept.
  o.batchTriangles = 300;
  const Decimated batched = decimate(foam, {40, 40, 40}, Method::kMarchingCubes, o);
  EXPECT_EQ(batched.report.brokenShape, 0u);
  EXPECT_EQ(batched.stats.nonManifoldEdges, 0u);
  EXPECT_NEAR(double(batched.decimated.triangles.size()) / double(r.decimated.triangles.size()), 1.0, 0.02);
}

TEST(Decimation, WithoutTheDistanceBoundTheRatioIsMet) {
  for (double ratio : {0.5, 0.2, 0.1}) {
    SCOPED_TRACE(ratio);
    DecimateOptions o = smallBlocks(ratio);
    o.maxDistance = 0;
    const Decimated r = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, o);
    const double kept = double(r.decimated.triangles.size()) / double(r.original.triangles.size());
    EXPECT_NEAR(kept, ratio, 0.03);  // meshoptimizer stops a little past each target
    EXPECT_EQ(r.stats.boundaryEdges, 0u);
    EXPECT_EQ(r.stats.nonManifoldEdges, 0u);
    EXPECT_EQ(r.stats.inconsistentEdges, 0u);
  }
}

// meshoptimizer is called on batches of whole components: the ball's and the torus's pieces in each
// block and region go to separate calls, each with its share of the target.
TEST(Decimation, BatchesOfComponentsKeepTheSurfaceAndTheRatio) {
  DecimateOptions whole = smallBlocks(0.3);
  DecimateOptions batched = whole;
  batched.batchTriangles = 200;
  const Decimated a = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, whole);
  const Decimated b = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, batched);
  EXPECT_EQ(b.report.trianglesIn, a.report.trianglesIn);
  EXPECT_EQ(b.stats.boundaryEdges, 0u);
  EXPECT_EQ(b.stats.nonManifoldEdges, 0u);
  EXPECT_EQ(b.stats.inconsistentEdges, 0u);
  EXPECT_EQ(b.stats.euler, a.stats.euler);  // the same topology: no part lost, no handle made
  expectWithin(b, 0.5);
  const double keptWhole = double(a.decimated.triangles.size()) / double(a.original.triangles.size());
  const double keptBatched = double(b.decimated.triangles.size()) / double(b.original.triangles.size());
  EXPECT_NEAR(keptBatched, keptWhole, 0.05);
  // Batches change where meshoptimizer stops, so the meshes differ.
  EXPECT_FALSE(a.decimated.triangles == b.decimated.triangles);
}

TEST(Decimation, TheSameForEveryThreadCount) {
  const Decimated one = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, smallBlocks(0.25), 1);
  const Decimated three = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, smallBlocks(0.25), 3);
  EXPECT_TRUE(one.decimated.positions == three.decimated.positions);
  EXPECT_TRUE(one.decimated.triangles == three.decimated.triangles);
}

TEST(Decimation, MaxErrorAloneDecimatesFlatPartsAndBoundsTheDistance) {
  DecimateOptions o = smallBlocks(1.0);
  o.maxError = 0.2;
  o.maxDistance = 0.2;
  const Decimated r = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, o);
  EXPECT_LT(r.decimated.triangles.size(), r.original.triangles.size() / 2);
  expectWithin(r, 0.2);  // the original vertices lie up to 0.23 voxel away: within half a voxel
  EXPECT_EQ(r.stats.boundaryEdges, 0u);
  EXPECT_EQ(r.stats.nonManifoldEdges, 0u);
}

// Without the measure (the program's run without --report), the output is the same and the
// report says the distance was not measured.
TEST(Decimation, WithoutTheMeasureTheOutputIsTheSame) {
  DecimateOptions measured = smallBlocks(0.25);
  DecimateOptions quiet = measured;
  quiet.measure = false;
  const Decimated a = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, measured);
  const Decimated b = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, quiet);
  EXPECT_TRUE(a.decimated.positions == b.decimated.positions);
  EXPECT_TRUE(a.decimated.triangles == b.decimated.triangles);
  EXPECT_TRUE(a.report.measured);
  EXPECT_GT(a.report.samples, 0u);
  EXPECT_FALSE(b.report.measured);
  EXPECT_EQ(b.report.samples, 0u);
  EXPECT_EQ(b.report.distanceMax, 0.0);
}

// With threads, blocks are taken four (or three) at a time and simplified two side by side (then
// their regions, as their blocks are done): the same triangles, the same vertices and the same
// report as one block at a time, whether or not the budget lets blocks queue up, and on the threads
// of the extraction too.
TEST(Decimation, BlocksSideBySideGiveTheSameOutputAndReport) {
  DecimateOptions near = smallBlocks(0.25);
  near.blockSlabs = 3;  // many blocks: pairs, and an odd one at the end
  near.blockTriangles = 500;
  // A bound of two voxels: the original triangles that a region's checks see reach further than
  // the chunk below its range.
  DecimateOptions far = near;
  far.maxError = 2;
  far.maxDistance = 2;
  for (const DecimateOptions& one : {near, far}) {
    SCOPED_TRACE(one.maxDistance);
    DecimateOptions two = one;
    two.threads = 2;
    DecimateOptions tight = two;
    // The blocks here have 500 to 1,560 triangles: with this budget the largest go alone, the
    // middling ones in threes (no room for a fourth), the small ones in fours.
    tight.pairBytes = 1200 * kPairBytesPerTriangle;
    DecimateOptions snug = two;
    snug.pairBytes = 1600 * kPairBytesPerTriangle;  // threes and fours
    const Decimated a = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, one);
    ASSERT_GT(a.report.blocks, 5u);
    for (const auto& [options, threads] :
         {std::pair{two, 1}, std::pair{two, 3}, std::pair{tight, 2}, std::pair{snug, 2}}) {
      const Decimated b = decimate(lumpyScene(), {44, 32, 44}, Method::kMarchingCubes, options, threads);
      EXPECT_TRUE(a.decimated.positions == b.decimated.positions);
      EXPECT_TRUE(a.decimated.triangles == b.decimated.triangles);
      EXPECT_EQ(a.report.blocks, b.report.blocks);
      EXPECT_EQ(a.report.regions, b.report.regions);
      EXPECT_EQ(a.report.attempts, b.report.attempts);
      EXPECT_EQ(a.report.frozenTriangles, b.report.frozenTriangles);
      EXPECT_EQ(a.report.distanceMax, b.report.distanceMax);
      EXPECT_EQ(a.report.distanceMean, b.report.distanceMean);
      EXPECT_EQ(b.stats.boundaryEdges, 0u);
      EXPECT_EQ(b.stats.nonManifoldEdges, 0u);
    }
  }
}

// A surface in every slab up to the top, in blocks of 2 to 6 slabs: where the stream's last chunk
// closes a block (3 slabs), one thread simplifies that block in its own call and the last half
// block alone at the end, two threads take both in one call. The same triangles, closed.
TEST(Decimation, TheLastHalfBlockGivesTheSameOutputAloneOrWithItsBlock) {
  const auto field = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<float>(30.0 - std::hypot(double(x) - 22.0, double(y) - 16.0, double(z) - 60.0));
  };
  for (std::int64_t k = 2; k <= 6; ++k) {
    DecimateOptions one = smallBlocks(0.25);
    one.blockSlabs = k;
    one.blockTriangles = 1;
    DecimateOptions two = one;
    two.threads = 2;
    const Decimated a = decimate(field, {44, 32, 44}, Method::kMarchingCubes, one);
    const Decimated b = decimate(field, {44, 32, 44}, Method::kMarchingCubes, two, 2);
    EXPECT_TRUE(a.decimated.triangles == b.decimated.triangles);
    EXPECT_EQ(a.stats.boundaryEdges, 0u);
    EXPECT_EQ(a.stats.nonManifoldEdges, 0u);
    EXPECT_EQ(b.stats.boundaryEdges, 0u);
  }
}

TEST(Decimation, RefusesBadOptions) {
  DecimateOptions o;
  o.ratio = 0;
  EXPECT_EQ(checkDecimateOptions(o), "`decimate` must be above 0 and at most 1");
  o.ratio = 1.5;
  EXPECT_EQ(checkDecimateOptions(o), "`decimate` must be above 0 and at most 1");
  o.ratio = 0.5;
  o.maxError = -1;
  EXPECT_EQ(checkDecimateOptions(o), "`max_error` must be 0 or more");
  MemoryMeshSink memory;
  EXPECT_THROW(DecimationSink(memory, o), Error);
  o.maxError = 0;
  o.batchTriangles = 0;
  EXPECT_EQ(checkDecimateOptions(o), "a simplifier batch needs at least 1 triangle");
}

// Issue 36's local repairs: a repair simplifies again only the neighbourhood of its frozen patch
// (with the collapses made around it replayed as renames), and gives the triangles that replaying
// the whole region gives, try for try. A lumpy, noisy ball whose collapses may move the surface a
// voxel (--max-error 1) while the bound is a quarter voxel: the check finds a triangle beyond it.
TEST(Decimation, LocalRepairsGiveTheTrianglesOfRegionWideOnes) {
  const Field noisy = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i), y = double(j), z = double(k);
    return static_cast<float>(14.0 - std::hypot(x - 20, y - 18, z - 19) + 0.8 * std::sin(0.5 * x) * std::cos(0.4 * y));
  };
  DecimateOptions o = smallBlocks(0.1);
  o.maxError = 1.0;
  o.maxDistance = 0.25;
  const Decimated local = decimate(noisy, {40, 38, 40}, Method::kMarchingCubes, o);
  o.localRepairs = false;
  const Decimated whole = decimate(noisy, {40, 38, 40}, Method::kMarchingCubes, o);
  ASSERT_GT(local.report.repairedRegions, 0u);
  EXPECT_EQ(local.report.repairedRegions, whole.report.repairedRegions);
  EXPECT_EQ(local.report.attempts, whole.report.attempts);
  EXPECT_EQ(local.report.frozenTriangles, whole.report.frozenTriangles);
  // The same triangles, corner for corner (the output numbers its vertices in the order that the
  // triangles come, which differs).
  const auto corners = [](const IndexedMesh& m) {
    std::vector<std::array<Vec3d, 3>> all;
    for (const Triangle& t : m.triangles) {
      std::array<Vec3d, 3> c;
      for (std::size_t k = 0; k < 3; ++k) c[k] = {m.positions[t[k]].x, m.positions[t[k]].y, m.positions[t[k]].z};
      all.push_back(c);
    }
    std::sort(all.begin(), all.end());
    return all;
  };
  EXPECT_EQ(corners(local.decimated), corners(whole.decimated));
  EXPECT_EQ(local.stats.boundaryEdges, 0u);
  EXPECT_EQ(local.stats.nonManifoldEdges, 0u);
  EXPECT_EQ(local.stats.inconsistentEdges, 0u);
  // The bound holds at the sample points (between them a collapse's error may reach --max-error).
  EXPECT_LE(local.report.distanceMax, 0.25 + 1e-9);
  EXPECT_GT(local.report.distanceMax, 0.2);
}

}  // namespace
}  // namespace isoslab
