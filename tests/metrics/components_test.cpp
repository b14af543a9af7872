#include "metrics/components.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <random>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "extract/frame.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace isoslab {
namespace {

// Keeps every chunk of a stream, to feed it again split differently.
class ChunkRecorder final : public MeshSink {
 public:
  void begin(const MeshHeader& header) override {
    header_ = header;
    chunks_.clear();
  }
  void consume(const MeshChunk& chunk) override { chunks_.push_back(chunk); }
  void finish() override {}
  const std::vector<MeshChunk>& chunks() const { return chunks_; }
  const MeshHeader& header() const { return header_; }

 private:
  MeshHeader header_;
  std::vector<MeshChunk> chunks_;
};

struct ComponentRun {
  IndexedMesh mesh;
  std::vector<MeshChunk> chunks;
  MeshHeader header;
  std::vector<Component> components;
};

ComponentRun run(const std::function<float(std::int64_t, std::int64_t, std::int64_t)>& field,
                 std::array<std::int64_t, 3> dims, Method method, double iso, int threads = 1) {
  testing::VectorSource source(dims, field);
  ExtractOptions options;
  options.method = method;
  options.iso = iso;
  const LatticeFrame frame = LatticeFrame::physical(source.info());
  auto extractor = makeExtractor(options, source.info(), frame);
  const MeshHeader header = extractionHeader(options, source.info(), frame, *extractor);
  MemoryMeshSink memory;
  ChunkRecorder recorder;
  ComponentSink components;
  TeeSink tee({&memory, &recorder, &components});
  PipelineOptions pipeline;
  pipeline.threads = threads;
  runPipeline(source, *extractor, tee, header, pipeline);
  return {memory.mesh(), recorder.chunks(), header, components.components()};
}

// Feeds `chunks` again with every `group` consecutive chunks merged into one (0: all in one): a
// merged chunk still references only its own and the previous merged chunk's vertices.
std::vector<Component> rechunked(const std::vector<MeshChunk>& chunks, const MeshHeader& header, std::size_t group) {
  if (group == 0) group = chunks.size();
  ComponentSink sink;
  sink.begin(header);
  for (std::size_t first = 0; first < chunks.size(); first += group) {
    MeshChunk merged;
    merged.slab = chunks[first].slab;
    merged.firstVertex = chunks[first].firstVertex;
    for (std::size_t c = first; c < std::min(first + group, chunks.size()); ++c) {
      merged.positions.insert(merged.positions.end(), chunks[c].positions.begin(), chunks[c].positions.end());
      merged.boundary.insert(merged.boundary.end(), chunks[c].boundary.begin(), chunks[c].boundary.end());
      merged.triangles.insert(merged.triangles.end(), chunks[c].triangles.begin(), chunks[c].triangles.end());
    }
    sink.consume(merged);
  }
  sink.finish();
  return sink.components();
}

// The reference: union-find over the whole mesh, with each component's triangles, boundary and
// non-manifold edges counted from a map of every edge. Keyed by the smallest vertex id.
struct Reference {
  std::uint64_t triangles = 0;
  std::uint64_t boundaryEdges = 0;
  std::uint64_t nonManifoldEdges = 0;
};

std::map<VertexId, Reference> wholeMeshComponents(const IndexedMesh& mesh) {
  std::vector<VertexId> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), VertexId{0});
  auto find = [&](VertexId v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  // The smaller id as root, so that each root is its component's smallest vertex.
  auto join = [&](VertexId a, VertexId b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  };
  std::map<std::pair<VertexId, VertexId>, int> edgeUses;
  for (const Triangle& t : mesh.triangles) {
    join(t[0], t[1]);
    join(t[0], t[2]);
    for (std::size_t k = 0; k < 3; ++k) {
      ++edgeUses[std::minmax(t[k], t[(k + 1) % 3])];
    }
  }
  std::map<VertexId, Reference> out;
  for (const Triangle& t : mesh.triangles) ++out[find(t[0])].triangles;
  for (const auto& [edge, uses] : edgeUses) {
    Reference& r = out[find(edge.first)];
    if (uses == 1) ++r.boundaryEdges;
    if (uses > 2) ++r.nonManifoldEdges;
  }
  return out;
}

void expectSameComponents(const std::vector<Component>& expected, const std::vector<Component>& actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const Component& e = expected[i];
    const Component& a = actual[i];
    EXPECT_EQ(e.id, a.id);
    EXPECT_EQ(e.firstVertex, a.firstVertex);
    EXPECT_EQ(e.triangles, a.triangles);
    EXPECT_EQ(e.bounds, a.bounds);
    EXPECT_EQ(e.boundaryEdges, a.boundaryEdges);
    EXPECT_EQ(e.interiorBoundaryEdges, a.interiorBoundaryEdges);
    EXPECT_EQ(e.nonManifoldEdges, a.nonManifoldEdges);
    // Parts merge in another order when the chunks differ, so the sums round differently.
    EXPECT_NEAR(e.area, a.area, 1e-12 * std::max(1.0, std::abs(e.area)));
    EXPECT_NEAR(e.volume, a.volume, 1e-12 * std::max(1.0, std::abs(e.area)));
  }
}

IndexedMesh unitCube(float dx) {
  IndexedMesh m;
  for (int c = 0; c < 8; ++c) m.positions.push_back({dx + float(c & 1), float((c >> 1) & 1), float((c >> 2) & 1)});
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({VertexId(q[0]), VertexId(q[1]), VertexId(q[2])});
    m.triangles.push_back({VertexId(q[0]), VertexId(q[2]), VertexId(q[3])});
  }
  return m;
}

std::vector<Component> componentsOf(const IndexedMesh& mesh) {
  ComponentSink sink;
  feedMesh(mesh, MeshHeader{}, sink);
  return sink.components();
}

TEST(Components, TwoCubesOneWithAHole) {
  IndexedMesh mesh = unitCube(0);
  const IndexedMesh second = unitCube(3);
  for (Triangle t : second.triangles) {
    for (VertexId& v : t) v += 8;
    mesh.triangles.push_back(t);
  }
  mesh.positions.insert(mesh.positions.end(), second.positions.begin(), second.positions.end());
  mesh.triangles.erase(mesh.triangles.begin() + 3);  // a hole in the first cube

  const std::vector<Component> c = componentsOf(mesh);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].id, 0u);
  EXPECT_EQ(c[0].triangles, 11u);
  EXPECT_EQ(c[0].boundaryEdges, 3u);
  EXPECT_EQ(c[0].interiorBoundaryEdges, 3u);
  EXPECT_FALSE(c[0].closed());
  EXPECT_DOUBLE_EQ(c[0].area, 5.5);
  EXPECT_EQ(c[1].id, 1u);
  EXPECT_EQ(c[1].firstVertex, 8u);
  EXPECT_EQ(c[1].triangles, 12u);
  EXPECT_TRUE(c[1].closed());
  EXPECT_DOUBLE_EQ(c[1].area, 6.0);
  EXPECT_DOUBLE_EQ(c[1].volume, 1.0);
  EXPECT_EQ(c[1].bounds, (std::array<double, 6>{3, 0, 0, 4, 1, 1}));
}

TEST(Components, RefusesATriangleOutsideTheFront) {
  ComponentSink sink;
  sink.begin(MeshHeader{});
  MeshChunk chunk;
  chunk.positions.resize(3);
  chunk.triangles.push_back({0, 1, 2});
  sink.consume(chunk);
  chunk.slab = 1;
  chunk.firstVertex = 3;
  sink.consume(chunk);
  chunk.slab = 2;
  chunk.firstVertex = 6;
  try {
    sink.consume(chunk);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "slab 2: a triangle uses vertex 0, outside this chunk and the previous one");
  }
}

// Spheres of different radii, far enough apart (over 4 voxels between surfaces) that the cells
// crossing one sphere see only its own distance field.
struct Ball {
  double x, y, z, r;
};
constexpr std::array<Ball, 4> kBalls{
    {{8.3, 9.1, 10.2, 4.3}, {24.6, 22.2, 17.7, 6.7}, {46.1, 18.3, 19.4, 9.2}, {74.0, 20.4, 21.1, 10.3}}};
constexpr std::array<std::int64_t, 3> kBallDims{96, 40, 40};

float ballField(const Ball& b, std::int64_t i, std::int64_t j, std::int64_t k) {
  return static_cast<float>(b.r - std::hypot(double(i) - b.x, double(j) - b.y, double(k) - b.z));
}

TEST(Components, SeparateSpheresMatchEachSphereExtractedAlone) {
  auto all = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    float v = -1e9f;
    for (const Ball& b : kBalls) v = std::max(v, ballField(b, i, j, k));
    return v;
  };
  for (Method method : {Method::kMarchingCubes, Method::kTetra6, Method::kBcc12}) {
    SCOPED_TRACE(std::string(methodName(method)));
    const std::vector<Component> found = run(all, kBallDims, method, 0.0).components;
    ASSERT_EQ(found.size(), kBalls.size());
    for (const Ball& b : kBalls) {
      SCOPED_TRACE(b.r);
      const auto alone = run([&](std::int64_t i, std::int64_t j, std::int64_t k) { return ballField(b, i, j, k); },
                             kBallDims, method, 0.0);
      ASSERT_EQ(alone.components.size(), 1u);
      const Component& expected = alone.components[0];
      testing::VectorSource source(
          kBallDims, [&](std::int64_t i, std::int64_t j, std::int64_t k) { return ballField(b, i, j, k); });
      const MeshStats stats = testing::extract(source, method, 0.0).stats;
      EXPECT_NEAR(expected.area, stats.area, 1e-12 * stats.area);
      EXPECT_NEAR(expected.volume, stats.volume, 1e-12 * stats.volume);
      EXPECT_EQ(expected.triangles, stats.triangles);
      // The component of the several-sphere field whose box holds the centre.
      const auto match = std::find_if(found.begin(), found.end(), [&](const Component& c) {
        return c.bounds[0] < b.x && b.x < c.bounds[3] && c.bounds[1] < b.y && b.y < c.bounds[4] && c.bounds[2] < b.z &&
               b.z < c.bounds[5];
      });
      ASSERT_NE(match, found.end());
      EXPECT_EQ(match->triangles, stats.triangles);
      EXPECT_NEAR(match->area, stats.area, 1e-9 * stats.area);
      EXPECT_NEAR(match->volume, stats.volume, 1e-9 * stats.volume);
      EXPECT_EQ(match->bounds, expected.bounds);
      EXPECT_TRUE(match->closed());
      EXPECT_NEAR(match->volume, 4.0 / 3.0 * M_PI * b.r * b.r * b.r, 0.05 * match->volume);
    }
  }
}

// Thresholded noise: above the percolation threshold one component spans the box, below it many
// small ones do; both have components that join late (U shapes) and open ones on the faces.
std::function<float(std::int64_t, std::int64_t, std::int64_t)> foam(unsigned seed) {
  auto values = std::make_shared<std::vector<float>>(40 * 40 * 40);
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> uniform(0.0f, 1.0f);
  for (float& v : *values) v = uniform(random);
  return [values](std::int64_t i, std::int64_t j, std::int64_t k) {
    return (*values)[static_cast<std::size_t>((k * 40 + j) * 40 + i)];
  };
}

TEST(Components, RandomFoamMatchesAWholeMeshUnionFind) {
  for (const double iso : {0.5, 0.75, 0.9}) {
    for (Method method : kMethods) {
      SCOPED_TRACE(std::string(methodName(method)) + " iso " + std::to_string(iso));
      const ComponentRun r = run(foam(17), {40, 40, 40}, method, iso);
      const std::map<VertexId, Reference> reference = wholeMeshComponents(r.mesh);
      ASSERT_EQ(r.components.size(), reference.size());
      ASSERT_GT(r.components.size(), iso > 0.6 ? 100u : 1u);
      std::uint64_t triangles = 0;
      auto expected = reference.begin();
      for (const Component& c : r.components) {
        EXPECT_EQ(c.firstVertex, expected->first);
        EXPECT_EQ(c.triangles, expected->second.triangles);
        EXPECT_EQ(c.boundaryEdges, expected->second.boundaryEdges);
        EXPECT_EQ(c.nonManifoldEdges, expected->second.nonManifoldEdges);
        triangles += c.triangles;
        ++expected;
      }
      EXPECT_EQ(triangles, r.mesh.triangles.size());
    }
  }
}

TEST(Components, SameForEveryThreadCount) {
  for (Method method : {Method::kMarchingCubes, Method::kBcc12}) {
    SCOPED_TRACE(std::string(methodName(method)));
    const ComponentRun one = run(foam(5), {40, 40, 40}, method, 0.7, 1);
    const ComponentRun three = run(foam(5), {40, 40, 40}, method, 0.7, 3);
    EXPECT_EQ(one.components, three.components);
  }
}

TEST(Components, SameForChunksSplitDifferently) {
  for (Method method : {Method::kMarchingCubes, Method::kTetra5}) {
    SCOPED_TRACE(std::string(methodName(method)));
    const ComponentRun r = run(foam(9), {40, 40, 40}, method, 0.6);
    for (std::size_t group : {std::size_t{2}, std::size_t{3}, std::size_t{7}, std::size_t{0}}) {
      SCOPED_TRACE(group);
      expectSameComponents(r.components, rechunked(r.chunks, r.header, group));
    }
  }
}

}  // namespace
}  // namespace isoslab
