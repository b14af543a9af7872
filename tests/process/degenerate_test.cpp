// The collapse of degenerate triangles (process/degenerate.h): hand-made meshes whose result is
// known, and extracted surfaces with samples exactly at the iso value, checked by brute force
// (coincident corners, edge uses, one fan per vertex) and streamed against one whole chunk.
#include "process/degenerate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "encode/indexed_mesh.h"
#include "extract/frame.h"
#include "io/pad_source.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace isoslab {
namespace {

// Streams `chunks` (positions and triangles with global ids, in order) through the collapse.
IndexedMesh collapse(const std::vector<MeshChunk>& chunks, bool remap, DegenerateCounts* counts = nullptr) {
  MemoryMeshSink memory;
  DegenerateCollapseSink sink(memory, remap);
  sink.begin(MeshHeader{});
  for (const MeshChunk& c : chunks) sink.consume(c);
  sink.finish();
  if (counts != nullptr) *counts = sink.counts();
  return memory.mesh();
}

MeshChunk chunkOf(VertexId first, std::vector<Vec3f> positions, std::vector<Triangle> triangles) {
  MeshChunk c;
  c.firstVertex = first;
  c.positions = std::move(positions);
  c.triangles = std::move(triangles);
  return c;
}

// The octahedron: 0 +x, 1 -x, 2 +y, 3 -y, 4 +z, 5 -z; counter-clockwise seen from outside.
const std::vector<Vec3f> kOctahedron{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
const std::vector<Triangle> kTop{{4, 0, 2}, {4, 2, 1}};
const std::vector<Triangle> kBottom{{5, 2, 0}, {5, 1, 2}, {5, 3, 1}, {5, 0, 3}};
const std::vector<Triangle> kTopRest{{4, 1, 3}, {4, 3, 0}};

// The octahedron with its top vertex split along an edge of length zero: vertex 6 (at the top too)
// takes the fan's half towards -y, and the triangles (4, 1, 6) and (4, 6, 0) close the seam.
// Closed and manifold by ids, with two zero-area triangles.
std::vector<Triangle> splitTop() {
  return {{6, 1, 3}, {6, 3, 0}, {4, 1, 6}, {4, 6, 0}};
}

TEST(Degenerate, AZeroLengthVertexSplitCollapsesBackToTheOctahedron) {
  std::vector<Vec3f> positions = kOctahedron;
  positions.push_back({0, 0, 1});
  std::vector<Triangle> whole = kTop;
  whole.insert(whole.end(), kBottom.begin(), kBottom.end());
  std::vector<Triangle> split = splitTop();
  std::vector<Triangle> all = whole;
  all.insert(all.end(), split.begin(), split.end());

  std::vector<Triangle> expected = whole;
  expected.insert(expected.end(), kTopRest.begin(), kTopRest.end());
  std::sort(expected.begin(), expected.end());

  // One chunk, and two: vertex 6 and its triangles in the second.
  const std::vector<std::vector<MeshChunk>> streams{{chunkOf(0, positions, all)},
                                                    {chunkOf(0, kOctahedron, whole), chunkOf(6, {{0, 0, 1}}, split)}};
  for (const auto& stream : streams) {
    DegenerateCounts counts;
    IndexedMesh merged = collapse(stream, true, &counts);
    EXPECT_EQ(counts.clusters, 1);
    EXPECT_EQ(counts.vertices, 1);
    EXPECT_EQ(counts.triangles, 2);
    EXPECT_EQ(counts.splits, 0);
    EXPECT_EQ(counts.refused, 0);
    std::sort(merged.triangles.begin(), merged.triangles.end());
    EXPECT_EQ(merged.triangles, expected);   // the survivor is the smaller id, 4
    EXPECT_EQ(merged.positions.size(), 7u);  // positions pass as they came

    // Without remap the kept triangles keep their ids: the two degenerate ones go.
    IndexedMesh kept = collapse(stream, false);
    std::vector<Triangle> keptExpected = whole;
    keptExpected.insert(keptExpected.end(), {{6, 1, 3}, {6, 3, 0}});
    std::sort(keptExpected.begin(), keptExpected.end());
    std::sort(kept.triangles.begin(), kept.triangles.end());
    EXPECT_EQ(kept.triangles, keptExpected);
  }
}

TEST(Degenerate, AMergeThatWouldRepeatANeighbourIsRefusedAndItsPointsMovedApart) {
  // a = 0 and b = 1 share a position and the zero-length edge of (0, 1, 4); both also make a
  // triangle from neighbour 2, so the merged point would start two fan edges at 2.
  const std::vector<Vec3f> p{{0, 0, 0}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}};
  const std::vector<Triangle> t{{0, 2, 3}, {1, 2, 5}, {0, 1, 4}};
  DegenerateCounts counts;
  const IndexedMesh out = collapse({chunkOf(0, p, t)}, true, &counts);
  EXPECT_EQ(out.triangles, t);
  EXPECT_EQ(counts.clusters, 0);
  EXPECT_EQ(counts.refused, 1);
  EXPECT_EQ(counts.refusedTriangles, 1);
  EXPECT_EQ(counts.triangles, 0);
  // Instead, b moves a thousandth of the way to the mean of its neighbours 0, 2, 4 and 5
  // (0.25, -0.25, 0.25), so that (0, 1, 4) is a sliver; a stays.
  EXPECT_EQ(counts.separated, 1);
  EXPECT_EQ(out.positions[0], p[0]);
  EXPECT_EQ(out.positions[1], (Vec3f{0.00025f, -0.00025f, 0.00025f}));
}

// What a welded mesh must be after the collapse, counted by brute force.
struct Check {
  std::size_t coincident = 0;  // triangles with two corners at one position
  std::size_t badEdges = 0;    // an undirected edge not used once each way
  std::size_t badFans = 0;     // a vertex whose triangles are not one closed fan
  double area = 0;
};

Check check(const IndexedMesh& m) {
  Check c;
  std::map<std::pair<VertexId, VertexId>, int> directed;
  std::map<VertexId, std::map<VertexId, VertexId>> link;  // vertex -> (a -> b) of its triangles
  std::map<VertexId, int> linkUses;
  for (const Triangle& t : m.triangles) {
    const Vec3f& a = m.positions[t[0]];
    const Vec3f& b = m.positions[t[1]];
    const Vec3f& d = m.positions[t[2]];
    if (a == b || b == d || a == d) ++c.coincident;
    const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
    const double vx = double(d.x) - a.x, vy = double(d.y) - a.y, vz = double(d.z) - a.z;
    c.area += 0.5 * std::hypot(uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx);
    for (std::size_t k = 0; k < 3; ++k) {
      ++directed[{t[k], t[(k + 1) % 3]}];
      link[t[k]][t[(k + 1) % 3]] = t[(k + 2) % 3];
      ++linkUses[t[k]];
    }
  }
  for (const auto& [e, n] : directed) {
    const auto back = directed.find({e.second, e.first});
    if (n != 1 || back == directed.end() || back->second != 1) ++c.badEdges;
  }
  for (const auto& [v, next] : link) {
    // One cycle through every fan edge (a repeated start already shows as a lost map entry).
    if (static_cast<int>(next.size()) != linkUses[v]) {
      ++c.badFans;
      continue;
    }
    std::size_t steps = 0;
    VertexId at = next.begin()->first;
    do {
      const auto it = next.find(at);
      if (it == next.end()) break;
      at = it->second;
      ++steps;
    } while (at != next.begin()->first && steps <= next.size());
    if (steps != next.size() || at != next.begin()->first) ++c.badFans;
  }
  return c;
}

// An integer field (twice the distance to a centre, rounded) has many samples exactly at an
// integer iso value: every crossed edge at such a sample puts its vertex on it.
std::unique_ptr<SliceSource> integerBall(std::array<std::int64_t, 3> dims) {
  return std::make_unique<testing::VectorSource>(dims, [](std::int64_t x, std::int64_t y, std::int64_t z) {
    const double dx = double(x) - 9.3, dy = double(y) - 10.1, dz = double(z) - 8.7;
    return static_cast<float>(std::round(2.0 * std::sqrt(dx * dx + dy * dy + 1.4 * dz * dz)));
  });
}

TEST(Degenerate, StreamedCollapseOfAnIntegerFieldLeavesAClosedManifoldWithoutZeroAreaTriangles) {
  for (const Method method : kMethods) {
    for (const bool close : {false, true}) {
      SCOPED_TRACE(::testing::Message() << "method " << static_cast<int>(method) << " close " << close);
      ExtractOptions options;
      options.method = method;
      options.iso = 14;
      options.closeBoundary = close;
      auto source = integerBall({22, 21, 19});
      const VolumeInfo info = source->info();
      const LatticeFrame frame = LatticeFrame::physical(info);
      auto extractor = makeExtractor(options, info, frame);
      const MeshHeader header = extractionHeader(options, info, frame, *extractor);
      if (close) source = std::make_unique<PadSource>(std::move(source));
      MemoryMeshSink raw;
      MemoryMeshSink streamed;
      DegenerateCollapseSink collapse(streamed, true);
      TeeSink tee({&raw, &collapse});
      runPipeline(*source, *extractor, tee, header, PipelineOptions{});

      const Check before = check(raw.mesh());
      ASSERT_GT(before.coincident, 20u) << "the field should put vertices on samples";
      const DegenerateCounts& counts = collapse.counts();
      EXPECT_EQ(counts.refused, 0);
      EXPECT_EQ(streamed.mesh().triangles.size() + static_cast<std::size_t>(counts.triangles),
                raw.mesh().triangles.size());
      const Check after = check(streamed.mesh());
      EXPECT_EQ(after.coincident, 0u);
      EXPECT_EQ(after.badEdges, 0u);
      EXPECT_EQ(after.badFans, 0u);
      EXPECT_NEAR(after.area, before.area, 1e-9 * before.area);  // only zero-area triangles went

      // The whole mesh as one chunk gives the same triangles.
      MemoryMeshSink whole;
      DegenerateCollapseSink once(whole, true);
      feedMesh(raw.mesh(), header, once);
      EXPECT_EQ(whole.mesh().triangles, streamed.mesh().triangles);
    }
  }
}

}  // namespace
}  // namespace isoslab
