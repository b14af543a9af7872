#include "metrics/components.h"

#include "metrics/component_filter.h"
#include "metrics/report.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
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
  pipeline.sequentialVoxels = 0;  // threads even on a small volume
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

// A report's summary (count, closed, the largest by triangles with ties by id) kept as the stream
// goes equals the one made from every component at the end, for lists shorter and longer than the
// ties among a foam's many small blobs of the same size.
TEST(Components, SummaryEqualsTheReportOfEveryComponent) {
  for (Method method : {Method::kMarchingCubes, Method::kTetra6}) {
    SCOPED_TRACE(std::string(methodName(method)));
    const ComponentRun r = run(foam(11), {40, 40, 40}, method, 0.7);
    ASSERT_GT(r.components.size(), 100u);
    std::map<std::uint64_t, int> sizes;
    for (const Component& c : r.components) ++sizes[c.triangles];
    ASSERT_LT(sizes.size(), r.components.size() / 2);  // many ties
    for (std::size_t listed :
         {std::size_t{0}, std::size_t{1}, std::size_t{10}, std::size_t{97}, r.components.size() + 5}) {
      SCOPED_TRACE("listed " + std::to_string(listed));
      ComponentSink sink;
      sink.summarize(listed);
      sink.begin(r.header);
      for (const MeshChunk& chunk : r.chunks) sink.consume(chunk);
      sink.finish();
      EXPECT_TRUE(sink.components().empty());
      EXPECT_EQ(sink.summary().count, r.components.size());
      EXPECT_EQ(componentsJson(sink.summary()).dump(), componentsJson(r.components, listed).dump());
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

// --- Keeping components: the two passes of component_filter.h ---

struct FilterRun {
  std::vector<Component> found;  // the first pass's
  std::vector<bool> kept;
  IndexedMesh mesh;  // the second pass's output
  MeshHeader header;
};

using Field = std::function<float(std::int64_t, std::int64_t, std::int64_t)>;

// Both passes through the pipeline, each over a source of its own.
FilterRun filterRun(const Field& field, std::array<std::int64_t, 3> dims, Method method, double iso,
                    const ComponentRules& rules, int threads = 1) {
  ExtractOptions options;
  options.method = method;
  options.iso = iso;
  PipelineOptions pipeline;
  pipeline.threads = threads;
  pipeline.sequentialVoxels = 0;  // threads even on a small volume
  testing::VectorSource first(dims, field);
  const LatticeFrame frame = LatticeFrame::physical(first.info());
  auto extractor = makeExtractor(options, first.info(), frame);
  const MeshHeader header = extractionHeader(options, first.info(), frame, *extractor);
  ComponentSink found;
  found.setSeed(rules.seed);
  runPipeline(first, *extractor, found, header, pipeline);
  FilterRun r;
  r.found = found.components();
  r.kept = selectComponents(r.found, rules);
  testing::VectorSource second(dims, field);
  extractor = makeExtractor(options, second.info(), frame);
  MemoryMeshSink memory;
  ComponentFilterSink filter(memory, keptParts(found, r.kept));
  runPipeline(second, *extractor, filter, header, pipeline);
  r.mesh = memory.mesh();
  r.header = memory.header();
  return r;
}

// The reference: the whole mesh's components by union-find (roots are smallest vertices), and the
// mesh cut to the triangles of the roots `keep`, its used vertices renumbered in id order.
IndexedMesh wholeMeshKeep(const IndexedMesh& mesh, const std::function<bool(VertexId root)>& keep) {
  std::vector<VertexId> parent(mesh.positions.size());
  std::iota(parent.begin(), parent.end(), VertexId{0});
  auto find = [&](VertexId v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const Triangle& t : mesh.triangles) {
    for (std::size_t k = 1; k < 3; ++k) {
      const VertexId a = find(t[0]);
      const VertexId b = find(t[k]);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  std::vector<VertexId> newId(mesh.positions.size(), ~VertexId{0});
  std::vector<bool> used(mesh.positions.size(), false);
  for (const Triangle& t : mesh.triangles) {
    if (keep(find(t[0]))) used[t[0]] = used[t[1]] = used[t[2]] = true;
  }
  IndexedMesh out;
  for (VertexId v = 0; v < mesh.positions.size(); ++v) {
    if (!used[v]) continue;
    newId[v] = static_cast<VertexId>(out.positions.size());
    out.positions.push_back(mesh.positions[v]);
  }
  for (const Triangle& t : mesh.triangles) {
    if (keep(find(t[0]))) out.triangles.push_back({newId[t[0]], newId[t[1]], newId[t[2]]});
  }
  return out;
}

Field ballsField(const std::vector<Ball>& balls) {
  return [balls](std::int64_t i, std::int64_t j, std::int64_t k) {
    float v = -1e9f;
    for (const Ball& b : balls) v = std::max(v, ballField(b, i, j, k));
    return v;
  };
}

void expectSameMesh(const IndexedMesh& expected, const IndexedMesh& actual) {
  ASSERT_EQ(expected.positions.size(), actual.positions.size());
  ASSERT_EQ(expected.triangles.size(), actual.triangles.size());
  EXPECT_TRUE(expected.positions == actual.positions);
  EXPECT_TRUE(expected.triangles == actual.triangles);
}

const std::vector<Ball> kAllBalls(kBalls.begin(), kBalls.end());

TEST(ComponentFilter, KeepLargestGivesTheLargestSphereAsIfExtractedAlone) {
  for (Method method : {Method::kMarchingCubes, Method::kTetra6, Method::kBcc12, Method::kMarchingCubes33}) {
    SCOPED_TRACE(std::string(methodName(method)));
    for (const ComponentMeasure measure : {ComponentMeasure::kTriangles, ComponentMeasure::kVolume}) {
      ComponentRules rules;
      rules.keepLargest = 1;
      rules.measure = measure;
      const FilterRun r = filterRun(ballsField(kAllBalls), kBallDims, method, 0.0, rules);
      ASSERT_EQ(r.found.size(), 4u);
      const std::size_t largest =
          std::max_element(r.found.begin(), r.found.end(),
                           [](const Component& a, const Component& b) { return a.triangles < b.triangles; }) -
          r.found.begin();
      EXPECT_EQ(std::count(r.kept.begin(), r.kept.end(), true), 1);
      EXPECT_TRUE(r.kept[largest]);
      const IndexedMesh alone = run(ballsField({kBalls[3]}), kBallDims, method, 0.0).mesh;
      expectSameMesh(alone, r.mesh);
      EXPECT_FALSE(r.header.cellVolumes);
    }
  }
}

TEST(ComponentFilter, MinVolumeKeepsExactlyThoseAboveTheCut) {
  // Analytic volumes 333, 1260, 3262 and 4577: a cut at 2000 keeps the two largest balls, at 300
  // all four, at 5000 none.
  for (Method method : {Method::kMarchingCubes, Method::kTetra5}) {
    SCOPED_TRACE(std::string(methodName(method)));
    ComponentRules rules;
    rules.minVolume = 2000;
    FilterRun r = filterRun(ballsField(kAllBalls), kBallDims, method, 0.0, rules);
    expectSameMesh(run(ballsField({kBalls[2], kBalls[3]}), kBallDims, method, 0.0).mesh, r.mesh);
    rules.minVolume = 300;
    r = filterRun(ballsField(kAllBalls), kBallDims, method, 0.0, rules);
    expectSameMesh(run(ballsField(kAllBalls), kBallDims, method, 0.0).mesh, r.mesh);
    rules.minVolume = 5000;
    r = filterRun(ballsField(kAllBalls), kBallDims, method, 0.0, rules);
    EXPECT_TRUE(r.mesh.positions.empty());
    EXPECT_TRUE(r.mesh.triangles.empty());
  }
}

TEST(ComponentFilter, SeedKeepsTheNearestComponent) {
  ComponentRules rules;
  // Just outside ball 1's surface, nearer to it than to any other.
  rules.seed = Vec3f{24.6f + 6.7f + 1.5f, 22.2f, 17.7f};
  rules.seedReach = std::sqrt(3.0);
  FilterRun r = filterRun(ballsField(kAllBalls), kBallDims, Method::kMarchingCubes, 0.0, rules);
  expectSameMesh(run(ballsField({kBalls[1]}), kBallDims, Method::kMarchingCubes, 0.0).mesh, r.mesh);
  for (const Component& c : r.found) EXPECT_TRUE(std::isfinite(c.seedDistance));
  // With a threshold that drops ball 1, the nearest remaining one.
  rules.minTriangles = r.mesh.triangles.size() + 1;
  r = filterRun(ballsField(kAllBalls), kBallDims, Method::kMarchingCubes, 0.0, rules);
  expectSameMesh(run(ballsField({kBalls[2]}), kBallDims, Method::kMarchingCubes, 0.0).mesh, r.mesh);
}

TEST(ComponentFilter, SeedOutsideEveryComponentIsAnError) {
  ComponentRules rules;
  rules.seed = Vec3f{90, 2, 2};
  rules.seedReach = 1;
  try {
    filterRun(ballsField(kAllBalls), kBallDims, Method::kMarchingCubes, 0.0, rules);
    FAIL() << "no error";
  } catch (const Error& e) {
    // The bounds the message gives are those of the balls' whole mesh, from its vertices.
    const IndexedMesh mesh = run(ballsField(kAllBalls), kBallDims, Method::kMarchingCubes, 0.0).mesh;
    ASSERT_FALSE(mesh.positions.empty());
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::array<double, 6> box{kInf, kInf, kInf, -kInf, -kInf, -kInf};
    for (const Vec3f& p : mesh.positions) {
      const std::array<double, 3> q{p.x, p.y, p.z};
      for (std::size_t a = 0; a < 3; ++a) {
        box[a] = std::min(box[a], q[a]);
        box[a + 3] = std::max(box[a + 3], q[a]);
      }
    }
    EXPECT_EQ(std::string(e.what()),
              fmt::format("--seed 90,2,2 lies outside every component's bounds (grown by 1): the 4 components lie "
                          "within x {:.6g} .. {:.6g}, y {:.6g} .. {:.6g}, z {:.6g} .. {:.6g}",
                          box[0], box[3], box[1], box[4], box[2], box[5]));
  }
  try {
    selectComponents({}, rules);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--seed 90,2,2 lies outside every component's bounds (grown by 1): the surface is empty");
  }
}

TEST(ComponentFilter, SelectionAppliesThresholdsThenSeedThenLargest) {
  std::vector<Component> c(5);
  const std::uint64_t triangles[5] = {10, 50, 30, 50, 5};
  const double volumes[5] = {-100, 1, 40, 20, 7};
  for (std::size_t i = 0; i < c.size(); ++i) {
    c[i].id = i;
    c[i].triangles = triangles[i];
    c[i].volume = volumes[i];
  }
  ComponentRules rules;
  rules.keepLargest = 2;
  EXPECT_EQ(selectComponents(c, rules), (std::vector<bool>{false, true, false, true, false}));  // a tie: both 50
  rules.keepLargest = 1;
  EXPECT_EQ(selectComponents(c, rules), (std::vector<bool>{false, true, false, false, false}));  // the lower id
  rules.measure = ComponentMeasure::kVolume;  // |volume|: an inside-out part counts by its size
  EXPECT_EQ(selectComponents(c, rules), (std::vector<bool>{true, false, false, false, false}));
  rules.keepLargest = 3;
  rules.minTriangles = 11;
  EXPECT_EQ(selectComponents(c, rules), (std::vector<bool>{false, true, true, true, false}));
  rules.minVolume = 20;
  EXPECT_EQ(selectComponents(c, rules), (std::vector<bool>{false, false, true, true, false}));
  EXPECT_EQ(rules.text(), "--min-triangles 11 --min-volume 20 --keep-largest 3 --component-measure volume");
}

// Foams join parts late (U shapes) and touch the faces: the filter's output equals the whole mesh
// cut to the chosen components by a union-find over it, for every method and two thread counts.
TEST(ComponentFilter, FoamEqualsAWholeMeshCut) {
  for (const double iso : {0.5, 0.8}) {
    for (Method method : kMethods) {
      SCOPED_TRACE(std::string(methodName(method)) + " iso " + std::to_string(iso));
      const ComponentRun whole = run(foam(23), {40, 40, 40}, method, iso);
      const std::map<VertexId, Reference> reference = wholeMeshComponents(whole.mesh);
      // The 3 largest of those with at least 4 triangles, by a sort of the reference.
      std::vector<std::pair<std::uint64_t, VertexId>> bySize;
      for (const auto& [root, ref] : reference) {
        if (ref.triangles >= 4) bySize.emplace_back(ref.triangles, root);
      }
      std::sort(bySize.begin(), bySize.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
      });
      bySize.resize(std::min<std::size_t>(3, bySize.size()));
      const auto keep = [&](VertexId root) {
        return std::any_of(bySize.begin(), bySize.end(), [&](const auto& e) { return e.second == root; });
      };
      const IndexedMesh expected = wholeMeshKeep(whole.mesh, keep);
      ComponentRules rules;
      rules.keepLargest = 3;
      rules.minTriangles = 4;
      for (int threads : {1, 3}) {
        SCOPED_TRACE(threads);
        const FilterRun r = filterRun(foam(23), {40, 40, 40}, method, iso, rules, threads);
        expectSameMesh(expected, r.mesh);
      }
    }
  }
}

TEST(ComponentFilter, RefusesAStreamThatIsNotTheFirstPasss) {
  ComponentRun first = run(foam(3), {40, 40, 40}, Method::kMarchingCubes, 0.8);
  ComponentSink found;
  found.begin(first.header);
  for (const MeshChunk& c : first.chunks) found.consume(c);
  found.finish();
  ASSERT_GT(found.parts(), 10u);
  const std::vector<bool> all(found.components().size(), true);
  // Another foam streams into the filter built for this one.
  const ComponentRun other = run(foam(4), {40, 40, 40}, Method::kMarchingCubes, 0.8);
  MemoryMeshSink memory;
  ComponentFilterSink filter(memory, keptParts(found, all));
  filter.begin(other.header);
  try {
    for (const MeshChunk& c : other.chunks) filter.consume(c);
    filter.finish();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("the input changed between the two passes of the component filter (", 0), 0u)
        << e.what();
  }
}

}  // namespace
}  // namespace isoslab
