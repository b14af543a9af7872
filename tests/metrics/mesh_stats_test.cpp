#include <gtest/gtest.h>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "metrics/mesh_stats.h"

namespace isoslab {
namespace {

MeshStats measure(const IndexedMesh& mesh) {
  MeshStatsSink sink;
  feedMesh(mesh, MeshHeader{}, sink);
  return sink.stats();
}

IndexedMesh unitCube() {
  IndexedMesh m;
  for (int c = 0; c < 8; ++c) m.positions.push_back({float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1)});
  // Outward-facing quads split into triangles.
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({VertexId(q[0]), VertexId(q[1]), VertexId(q[2])});
    m.triangles.push_back({VertexId(q[0]), VertexId(q[2]), VertexId(q[3])});
  }
  return m;
}

TEST(MeshStats, UnitCubeIsClosedWithKnownAreaAndVolume) {
  const MeshStats s = measure(unitCube());
  EXPECT_EQ(s.vertices, 8u);
  EXPECT_EQ(s.triangles, 12u);
  EXPECT_EQ(s.edges, 18u);
  EXPECT_EQ(s.euler, 2);
  EXPECT_TRUE(s.closed());
  EXPECT_TRUE(s.oriented());
  EXPECT_DOUBLE_EQ(s.area, 6.0);
  EXPECT_DOUBLE_EQ(s.volume, 1.0);
  EXPECT_EQ(s.bounds, (std::array<double, 6>{0, 0, 0, 1, 1, 1}));
}

TEST(MeshStats, DetectsHolesFlipsNonManifoldEdgesAndDegenerateTriangles) {
  IndexedMesh holed = unitCube();
  holed.triangles.pop_back();
  const MeshStats h = measure(holed);
  EXPECT_EQ(h.boundaryEdges, 3u);
  EXPECT_EQ(h.interiorBoundaryEdges, 3u);
  EXPECT_FALSE(h.closed());

  IndexedMesh flipped = unitCube();
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  EXPECT_EQ(measure(flipped).inconsistentEdges, 3u);

  IndexedMesh fin = unitCube();
  fin.positions.push_back({0.5f, 0.5f, 0.5f});
  fin.triangles.push_back({0, 1, 8});
  EXPECT_EQ(measure(fin).nonManifoldEdges, 1u);

  IndexedMesh degenerate = unitCube();
  degenerate.positions.push_back({0, 0, 0});
  degenerate.triangles.push_back({0, 8, 1});
  degenerate.triangles.push_back({0, 1, 8});
  EXPECT_EQ(measure(degenerate).degenerateTriangles, 2u);
}

// The cube streamed as chunks: its bottom corners and face, then the top corners and the other
// faces (whose edges reach back into the first chunk), then an empty chunk.
std::vector<MeshChunk> cubeChunks() {
  const IndexedMesh cube = unitCube();
  std::vector<MeshChunk> chunks(3);
  for (std::int64_t z = 0; z < 3; ++z) chunks[static_cast<std::size_t>(z)].slab = z;
  chunks[0].positions.assign(cube.positions.begin(), cube.positions.begin() + 4);
  chunks[0].triangles.assign(cube.triangles.begin(), cube.triangles.begin() + 2);
  chunks[1].firstVertex = 4;
  chunks[1].positions.assign(cube.positions.begin() + 4, cube.positions.end());
  chunks[1].triangles.assign(cube.triangles.begin() + 2, cube.triangles.end());
  chunks[2].firstVertex = 8;
  for (auto& c : chunks) c.boundary.assign(c.positions.size(), 0);
  return chunks;
}

MeshStats measureChunks(const std::vector<MeshChunk>& chunks) {
  MeshStatsSink sink;
  sink.begin(MeshHeader{});
  for (const MeshChunk& c : chunks) sink.consume(c);
  sink.finish();
  return sink.stats();
}

TEST(MeshStats, EdgesAcrossChunksAreCountedOnce) {
  const MeshStats s = measureChunks(cubeChunks());
  const MeshStats whole = measure(unitCube());
  EXPECT_EQ(s.vertices, 8u);
  EXPECT_EQ(s.edges, whole.edges);
  EXPECT_EQ(s.euler, 2);
  EXPECT_TRUE(s.closed());
  EXPECT_TRUE(s.oriented());
  EXPECT_DOUBLE_EQ(s.volume, 1.0);
}

TEST(MeshStats, RejectsChunksThatBreakTheStreamingContract) {
  auto expectError = [](const std::vector<MeshChunk>& chunks, const char* message) {
    try {
      measureChunks(chunks);
      ADD_FAILURE() << "no error for: " << message;
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), message);
    }
  };
  std::vector<MeshChunk> gap = cubeChunks();
  gap[1].firstVertex = 5;
  expectError(gap, "slab 1: the chunk's vertices start at id 5, not at 4 where the previous chunk's ended");
  std::vector<MeshChunk> old = cubeChunks();
  old[2].positions.push_back({2, 2, 2});
  old[2].boundary.push_back(0);
  old[2].triangles.push_back({8, 0, 5});  // vertex 0 belongs to chunk 0, two chunks back
  expectError(old, "slab 2: a triangle uses vertex 0, outside this chunk and the previous one");
}

TEST(MeshStats, BoundaryEdgesOnTheVolumeFacesAreNotHoles) {
  IndexedMesh quad;
  quad.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.boundary = {kFaceXMin | kFaceYMin, kFaceYMin, 0, kFaceXMin};
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  const MeshStats s = measure(quad);
  EXPECT_EQ(s.boundaryEdges, 4u);
  EXPECT_EQ(s.interiorBoundaryEdges, 2u);  // 1-2 and 2-3 are not on a face of the volume
}

}  // namespace
}  // namespace isoslab
