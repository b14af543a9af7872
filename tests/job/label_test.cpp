// Label maps (issue 35): the label complex and its surfaces, against answers known by construction
// and brute-force counts over the voxels.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include <nlohmann/json.hpp>

#include "core/volume_info.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_reader.h"
#include "extract/label_extractor.h"
#include "io/label_source.h"
#include "io/label_table.h"
#include "io/pad_source.h"
#include "io/volume_writer.h"
#include "job/extract_job.h"
#include "process/decimation.h"
#include "process/label_surfaces.h"
#include "process/smoothing.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace isoslab {
namespace {

using testing::VectorSource;

// A label volume and its brute-force facts.
struct Labels {
  std::array<std::int64_t, 3> dims{};
  std::vector<float> values;
  std::int32_t at(std::int64_t i, std::int64_t j, std::int64_t k) const {
    if (i < 0 || j < 0 || k < 0 || i >= dims[0] || j >= dims[1] || k >= dims[2]) return 0;
    return static_cast<std::int32_t>(values[static_cast<std::size_t>((k * dims[1] + j) * dims[0] + i)]);
  }
  // Voxel faces between different labels, per unordered pair (the outside is 0).
  std::map<std::pair<std::int32_t, std::int32_t>, std::int64_t> faces() const {
    std::map<std::pair<std::int32_t, std::int32_t>, std::int64_t> out;
    for (std::int64_t k = -1; k < dims[2]; ++k) {
      for (std::int64_t j = -1; j < dims[1]; ++j) {
        for (std::int64_t i = -1; i < dims[0]; ++i) {
          const std::int32_t a = at(i, j, k);
          for (const auto& [b, inside] :
               {std::pair{at(i + 1, j, k), j >= 0 && k >= 0}, std::pair{at(i, j + 1, k), i >= 0 && k >= 0},
                std::pair{at(i, j, k + 1), i >= 0 && j >= 0}}) {
            if (inside && a != b) ++out[std::minmax(a, b)];
          }
        }
      }
    }
    return out;
  }
  std::map<std::int32_t, std::int64_t> counts() const {
    std::map<std::int32_t, std::int64_t> out;
    for (float v : values) ++out[static_cast<std::int32_t>(v)];
    return out;
  }
};

// The complex, whole, as the pipeline streams it.
struct Complex {
  std::vector<Vec3f> positions;
  std::vector<Triangle> triangles;
  std::vector<LabelPair> sides;
  std::map<std::int32_t, std::uint64_t> splits, pinches;
  std::vector<MeshChunk> chunks;
};

class ComplexSink final : public MeshSink {
 public:
  explicit ComplexSink(Complex& c) : c_(c) {}
  void begin(const MeshHeader& h) override { EXPECT_TRUE(h.labels); }
  void consume(const MeshChunk& chunk) override {
    EXPECT_EQ(chunk.firstVertex, c_.positions.size());
    EXPECT_EQ(chunk.faceLabels.size(), chunk.triangles.size());
    c_.positions.insert(c_.positions.end(), chunk.positions.begin(), chunk.positions.end());
    c_.triangles.insert(c_.triangles.end(), chunk.triangles.begin(), chunk.triangles.end());
    c_.sides.insert(c_.sides.end(), chunk.faceLabels.begin(), chunk.faceLabels.end());
    for (std::int32_t l : chunk.labelSplits) ++c_.splits[l];
    for (std::int32_t l : chunk.labelPinches) ++c_.pinches[l];
    c_.chunks.push_back(chunk);
  }
  void finish() override {}

 private:
  Complex& c_;
};

Complex extractComplex(const Labels& labels, int threads, VolumeInfo* infoOut = nullptr) {
  auto volume = std::make_unique<VectorSource>(labels.dims, labels.values);
  const VolumeInfo info = volume->info();
  if (infoOut != nullptr) *infoOut = info;
  auto checked = std::make_unique<LabelSource>(std::move(volume), "test", std::nullopt);
  PadSource source(std::move(checked), 0.0f);
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeLabelExtractor(info, frame);
  Complex c;
  ComplexSink sink(c);
  PipelineOptions options;
  options.threads = threads;
  options.sequentialVoxels = 0;
  options.runVoxels = 64;
  runPipeline(source, *extractor, sink, labelHeader(info, frame), options);
  return c;
}

// One label's surface out of the complex: the triangles with it on a side, facing out of it.
std::vector<Triangle> surfaceOf(const Complex& c, std::int32_t label) {
  std::vector<Triangle> out;
  for (std::size_t t = 0; t < c.triangles.size(); ++t) {
    const Triangle& tri = c.triangles[t];
    if (c.sides[t][1] == label) out.push_back(tri);
    if (c.sides[t][0] == label) out.push_back({tri[0], tri[2], tri[1]});
  }
  return out;
}

struct Topology {
  std::int64_t unpairedEdges = 0;        // directed uses without their reverse
  std::int64_t nonManifoldEdges = 0;     // edges used by more than two triangles
  std::int64_t nonManifoldVertices = 0;  // vertices whose triangles form several fans
  std::int64_t euler = 0;
  double volume = 0;
};

Topology topology(const std::vector<Vec3f>& p, const std::vector<Triangle>& tris) {
  Topology t;
  std::map<std::pair<VertexId, VertexId>, int> directed;
  std::map<VertexId, std::vector<std::pair<VertexId, VertexId>>> links;
  std::set<VertexId> vertices;
  for (const Triangle& tri : tris) {
    for (int k = 0; k < 3; ++k) {
      const VertexId a = tri[static_cast<std::size_t>(k)], b = tri[static_cast<std::size_t>((k + 1) % 3)],
                     c = tri[static_cast<std::size_t>((k + 2) % 3)];
      ++directed[{a, b}];
      links[a].push_back({b, c});
      vertices.insert(a);
    }
    const Vec3f &a = p[tri[0]], &b = p[tri[1]], &c = p[tri[2]];
    t.volume +=
        (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
         double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) /
        6.0;
  }
  std::int64_t edges = 0;
  for (const auto& [e, n] : directed) {
    const auto back = directed.find({e.second, e.first});
    const int m = back == directed.end() ? 0 : back->second;
    if (n != m) t.unpairedEdges += std::abs(n - m);
    if (e.first < e.second || m == 0) ++edges;
    if (e.first < e.second && n + m > 2) ++t.nonManifoldEdges;
  }
  for (auto& [v, link] : links) {
    // The link edges b -> c around v must form one cycle.
    std::map<VertexId, VertexId> next;
    bool simple = true;
    for (const auto& [b, c] : link) simple = simple && next.emplace(b, c).second;
    std::size_t steps = 0;
    VertexId at = link.front().first;
    do {
      const auto it = next.find(at);
      if (it == next.end()) break;
      at = it->second;
      ++steps;
    } while (at != link.front().first && steps <= link.size());
    if (!simple || steps != link.size()) ++t.nonManifoldVertices;
  }
  t.euler = static_cast<std::int64_t>(vertices.size()) - edges + static_cast<std::int64_t>(tris.size());
  return t;
}

// The area of the complex's faces between two labels.
double areaOf(const Complex& c, std::pair<std::int32_t, std::int32_t> pair) {
  double area = 0;
  for (std::size_t t = 0; t < c.triangles.size(); ++t) {
    if (std::pair<std::int32_t, std::int32_t>(std::minmax(c.sides[t][0], c.sides[t][1])) != pair) continue;
    const Vec3f &a = c.positions[c.triangles[t][0]], &b = c.positions[c.triangles[t][1]],
                &d = c.positions[c.triangles[t][2]];
    const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
    const double vx = double(d.x) - a.x, vy = double(d.y) - a.y, vz = double(d.z) - a.z;
    area += 0.5 * std::sqrt((uy * vz - uz * vy) * (uy * vz - uz * vy) + (uz * vx - ux * vz) * (uz * vx - ux * vz) +
                            (ux * vy - uy * vx) * (ux * vy - uy * vx));
  }
  return area;
}

Labels randomLabels(std::array<std::int64_t, 3> dims, int labels, unsigned seed) {
  std::mt19937 rng(seed);
  Labels l;
  l.dims = dims;
  l.values.resize(static_cast<std::size_t>(dims[0] * dims[1] * dims[2]));
  std::uniform_int_distribution<int> pick(0, labels - 1);
  for (float& v : l.values) v = static_cast<float>(pick(rng));
  return l;
}

TEST(LabelComplex, BinaryNoiseGivesClosedManifoldSurfacesOfExactVolume) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const Labels l = randomLabels({11, 9, 10}, 2, seed);
    const Complex c = extractComplex(l, 1);
    const Topology t = topology(c.positions, surfaceOf(c, 1));
    EXPECT_EQ(t.unpairedEdges, 0);
    EXPECT_EQ(t.nonManifoldEdges, 0);
    EXPECT_EQ(t.nonManifoldVertices, 0);
    EXPECT_NEAR(t.volume, static_cast<double>(l.counts().at(1)), 1e-9);
    // The voxel faces between the label and the rest (brute force), each of area 1.
    EXPECT_NEAR(areaOf(c, {0, 1}), static_cast<double>(l.faces().at({0, 1})), 1e-9);
    EXPECT_TRUE(c.pinches.empty());
  }
}

TEST(LabelComplex, ManyLabelsShareEveryInterfaceAndAddUpToTheUnion) {
  const Labels l = randomLabels({12, 10, 9}, 5, 7);
  const Complex c = extractComplex(l, 1);
  const auto faces = l.faces();
  std::set<std::pair<std::int32_t, std::int32_t>> pairs;
  for (const LabelPair& s : c.sides) {
    pairs.insert(std::pair<std::int32_t, std::int32_t>(std::minmax(s[0], s[1])));
    // The back label connects later: the background is always in front.
    EXPECT_NE(s[1], 0);
  }
  EXPECT_EQ(pairs.size(), faces.size());
  for (const auto& [pair, n] : faces) {
    EXPECT_NEAR(areaOf(c, pair), static_cast<double>(n), 1e-9) << pair.first << "|" << pair.second;
  }
  double sum = 0;
  for (std::int32_t label = 1; label < 5; ++label) {
    const Topology t = topology(c.positions, surfaceOf(c, label));
    EXPECT_EQ(t.unpairedEdges, 0) << label;
    EXPECT_NEAR(t.volume, static_cast<double>(l.counts().at(label)), 1e-9) << label;
    EXPECT_EQ(t.nonManifoldEdges, 0) << label;
    sum += t.volume;
  }
  // The union of the labels, as one label: its surface encloses what the labels add up to.
  Labels u = l;
  for (float& v : u.values) v = v != 0 ? 1.0f : 0.0f;
  const Complex uc = extractComplex(u, 1);
  EXPECT_NEAR(topology(uc.positions, surfaceOf(uc, 1)).volume, sum, 1e-9);
}

TEST(LabelComplex, ThreadsGiveTheSameChunks) {
  const Labels l = randomLabels({20, 17, 31}, 6, 3);
  const Complex one = extractComplex(l, 1);
  const Complex three = extractComplex(l, 3);
  ASSERT_EQ(one.chunks.size(), three.chunks.size());
  for (std::size_t k = 0; k < one.chunks.size(); ++k) {
    EXPECT_EQ(one.chunks[k].positions, three.chunks[k].positions);
    EXPECT_EQ(one.chunks[k].triangles, three.chunks[k].triangles);
    EXPECT_EQ(one.chunks[k].faceLabels, three.chunks[k].faceLabels);
    EXPECT_EQ(one.chunks[k].labelSplits, three.chunks[k].labelSplits);
    EXPECT_EQ(one.chunks[k].labelPinches, three.chunks[k].labelPinches);
  }
}

TEST(LabelComplex, ASingleVoxelIsACubeOfEightCorners) {
  Labels l;
  l.dims = {1, 1, 1};
  l.values = {4};
  VolumeInfo info;
  const Complex c = extractComplex(l, 1, &info);
  EXPECT_EQ(c.positions.size(), 8u);
  EXPECT_EQ(c.triangles.size(), 12u);
  const Topology t = topology(c.positions, surfaceOf(c, 4));
  EXPECT_EQ(t.euler, 2);
  EXPECT_DOUBLE_EQ(t.volume, 1.0);
  for (const Vec3f& p : c.positions) {
    EXPECT_EQ(std::abs(p.x), 0.5f);
    EXPECT_EQ(std::abs(p.y), 0.5f);
    EXPECT_EQ(std::abs(p.z), 0.5f);
  }
}

// The job end to end on the label phantoms: per-label files and the report.
struct LabelRun {
  ExtractReport report;
  std::map<std::int32_t, IndexedMesh> meshes;
};

LabelRun runLabels(const std::string& input, const std::string& dir, int threads = 1) {
  ExtractSettings s;
  s.inputs = {input};
  s.output = dir + "/{label}.ply";
  s.threads = threads;
  LabelRun r;
  r.report = runExtract(s);
  for (const ExtractLabel& l : r.report.labels) r.meshes[l.value] = readMesh(l.path);
  return r;
}

TEST(LabelPhantoms, EachSurfaceIsClosedManifoldOutwardWithItsEulerCharacteristic) {
  const std::string dir = testing::tempDir();
  struct Case {
    const char* input;
    std::map<std::int32_t, std::int64_t> euler;
  };
  const std::vector<Case> cases{
      {"phantom:nested?n=30", {{1, 2}, {2, 4}, {3, 4}}},  // a ball and two shells (two spheres each)
      {"phantom:boxes?n=24", {{1, 2}, {2, 2}, {3, 2}}},
      {"phantom:voxel", {{1, 2}}},
      {"phantom:touch?at=face", {{1, 2}}},    // one box of two voxels
      {"phantom:touch?at=edge", {{1, 4}}},    // two cubes, split along their shared edge
      {"phantom:touch?at=corner", {{1, 4}}},  // two cubes, split at their shared corner
      {"phantom:checker?n=12&b=4&labels=27", {}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.input);
    const LabelRun r = runLabels(c.input, dir);
    ASSERT_FALSE(r.report.labels.empty());
    for (const ExtractLabel& l : r.report.labels) {
      const IndexedMesh& m = r.meshes.at(l.value);
      const Topology t = topology(m.positions, m.triangles);
      EXPECT_EQ(t.unpairedEdges, 0) << l.value;
      EXPECT_EQ(t.nonManifoldEdges, 0) << l.value;
      EXPECT_EQ(t.nonManifoldVertices, 0) << l.value;
      EXPECT_NEAR(t.volume, l.voxelVolume, 1e-9 * l.voxelVolume) << l.value;  // positive: outward
      EXPECT_EQ(l.stats.triangles, m.triangles.size());
      EXPECT_TRUE(l.stats.closed());
      EXPECT_EQ(l.pinches, 0u);
      // 27 labels in 27 blocks: boxes.
      const std::int64_t expected = c.euler.empty() ? 2 : c.euler.at(l.value);
      EXPECT_EQ(t.euler, expected) << l.value;
    }
  }
  // The splits: an edge touch duplicates the edge's two points, a corner touch its one point.
  EXPECT_EQ(runLabels("phantom:touch?at=edge", dir).report.labels.at(0).splits, 2u);
  EXPECT_EQ(runLabels("phantom:touch?at=corner", dir).report.labels.at(0).splits, 1u);
  // Two cubes' 16 corners, the split face's two vertices (one per copy of the shared edge) and the
  // centres of the four faces around that edge, which fan around them.
  EXPECT_EQ(runLabels("phantom:touch?at=edge", dir).meshes.at(1).positions.size(), 22u);
}

TEST(LabelPhantoms, TouchingBoxesShareTheirFaceInOppositeOrientation) {
  const std::string dir = testing::tempDir();
  const LabelRun r = runLabels("phantom:boxes?n=24", dir, 2);
  // Boxes 8 wide along x, 12 by 12 in y and z: two interfaces of 12 x 12 voxel faces.
  ASSERT_EQ(r.report.interfaces.size(), 2u);
  for (const ExtractInterface& i : r.report.interfaces) {
    EXPECT_EQ(i.b, i.a + 1);
    EXPECT_EQ(i.triangles, 2u * 144u);
    EXPECT_DOUBLE_EQ(i.area, 144.0);
  }
  // Every triangle of box 1 on its face with box 2 is in box 2's surface, reversed.
  const IndexedMesh& a = r.meshes.at(1);
  const IndexedMesh& b = r.meshes.at(2);
  auto key = [](const IndexedMesh& m, const Triangle& t, bool reversed) {
    std::array<std::array<float, 3>, 3> p{};
    for (int k = 0; k < 3; ++k) {
      const Vec3f& v = m.positions[t[static_cast<std::size_t>(reversed ? (3 - k) % 3 : k)]];
      p[static_cast<std::size_t>(k)] = {v.x, v.y, v.z};
    }
    std::rotate(p.begin(), std::min_element(p.begin(), p.end()), p.end());
    return p;
  };
  std::set<std::array<std::array<float, 3>, 3>> inB;
  for (const Triangle& t : b.triangles) inB.insert(key(b, t, false));
  std::size_t shared = 0;
  for (const Triangle& t : a.triangles) shared += inB.count(key(a, t, true));
  EXPECT_EQ(shared, 2u * 144u);
}

TEST(LabelPhantoms, TheReportCountsVoxelsAndVolumes) {
  const std::string dir = testing::tempDir();
  const LabelRun r = runLabels("phantom:nested?n=30", dir);
  Labels l;
  l.dims = {30, 30, 30};
  auto phantom = openSource("phantom:nested?n=30", {});
  std::vector<float> slice;
  while (readSliceInto(*phantom, slice)) l.values.insert(l.values.end(), slice.begin(), slice.end());
  const auto counts = l.counts();
  for (const ExtractLabel& label : r.report.labels) {
    EXPECT_EQ(label.voxels, counts.at(label.value));
    EXPECT_NEAR(label.stats.volume, static_cast<double>(label.voxels), 1e-9 * static_cast<double>(label.voxels));
  }
  const auto faces = l.faces();
  for (const ExtractInterface& i : r.report.interfaces) {
    EXPECT_NEAR(i.area, static_cast<double>(faces.at({i.a, i.b})), 1e-9);
  }
}

// The connected parts of a mesh (triangles that share a vertex).
std::size_t meshParts(const IndexedMesh& m) {
  std::vector<std::size_t> parent(m.positions.size());
  for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = i;
  const auto find = [&](std::size_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const Triangle& t : m.triangles) {
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  std::set<std::size_t> roots;
  for (const Triangle& t : m.triangles) roots.insert(find(t[0]));
  return roots.size();
}

// Per-label component rules on a volume whose specks are placed by hand: two boxes (labels 1 and 2)
// side by side, a speck of each inside the other, specks of 1 in the background and on top of 2,
// and a lone voxel of label 3. Every count below is derived from that layout.
TEST(LabelComponentRules, SpecksGoToTheLabelAroundThemAndSurfacesStayClosed) {
  const std::string dir = testing::tempDir();
  const auto layout = [](std::int64_t x, std::int64_t y, std::int64_t z) -> float {
    if (x == 5 && y == 5 && z == 5) return 2;                  // A: in box 1
    if (x == 12 && y == 5 && z == 5) return 1;                 // C: in box 2
    if (x == 12 && y == 5 && z == 10) return 1;                // D: on box 2, five faces free
    if (x == 17 && y == 17 && (z == 16 || z == 17)) return 1;  // B: two voxels alone
    if (x == 18 && y == 2 && z == 2) return 3;                 // E: label 3's only voxel
    const bool inY = y >= 2 && y <= 9, inZ = z >= 2 && z <= 9;
    if (inY && inZ && x >= 2 && x <= 9) return 1;    // box 1: 8 x 8 x 8
    if (inY && inZ && x >= 10 && x <= 15) return 2;  // box 2: 6 x 8 x 8
    return 0;
  };
  testing::VectorSource volume({20, 20, 20}, layout);
  const std::string input = dir + "/specks.nrrd";
  writeVolume(volume, input, {});
  const auto run = [&](const std::function<void(ExtractSettings&)>& rules, const std::string& name) {
    ExtractSettings s;
    s.inputs = {input};
    s.labels = parseLabelRequest("all");
    s.output = dir + "/" + name + "_{label}.ply";
    s.labelTopology = true;
    rules(s);
    LabelRun r;
    r.report = runExtract(s);
    for (const ExtractLabel& l : r.report.labels) r.meshes[l.value] = readMesh(l.path);
    return r;
  };
  const auto closedParts = [](const LabelRun& r, std::int32_t label) {
    const IndexedMesh& m = r.meshes.at(label);
    const Topology t = topology(m.positions, m.triangles);
    EXPECT_EQ(t.unpairedEdges, 0) << "label " << label;
    EXPECT_EQ(t.nonManifoldEdges, 0) << "label " << label;
    return meshParts(m);
  };

  // Without rules: label 1's surface has five parts (its box, the cavity around A, B, C, D) and
  // label 2's three (its box, the cavity around C, A).
  const LabelRun plain = run([](ExtractSettings&) {}, "plain");
  EXPECT_EQ(closedParts(plain, 1), 5u);
  EXPECT_EQ(closedParts(plain, 2), 3u);

  // --keep-largest 1: A goes to 1 (all its faces), C to 2, B and D to the background (D: five
  // faces free against one on box 2). The boxes are whole again: 512 and 384 voxels, one part
  // each with 2 x 6 x 64 = 768 and 2 x (48 + 48 + 64) = 640 triangles; label 3 keeps its voxel.
  const LabelRun largest = run([](ExtractSettings& s) { s.components.keepLargest = 1; }, "largest");
  ASSERT_EQ(largest.report.labels.size(), 3u);
  const ExtractLabel& one = largest.report.labels[0];
  const ExtractLabel& two = largest.report.labels[1];
  EXPECT_EQ(one.voxels, 512);
  EXPECT_EQ(two.voxels, 384);
  EXPECT_EQ(largest.report.labels[2].voxels, 1);
  EXPECT_EQ(one.stats.triangles, 768u);
  EXPECT_EQ(two.stats.triangles, 640u);
  EXPECT_NEAR(one.stats.volume, 512.0, 1e-9 * 512);
  EXPECT_EQ(closedParts(largest, 1), 1u);
  EXPECT_EQ(closedParts(largest, 2), 1u);
  ASSERT_TRUE(one.components && two.components);
  EXPECT_EQ(one.components->components, 4u);
  EXPECT_EQ(one.components->dropped, 3u);
  EXPECT_EQ(one.components->voxelsGiven, 4);
  EXPECT_EQ(one.components->voxelsTaken, 1);
  EXPECT_EQ(two.components->dropped, 1u);
  EXPECT_EQ(two.components->voxelsTaken, 1);
  const nlohmann::json filter = nlohmann::json::parse(largest.report.componentFilterJson);
  EXPECT_EQ(filter["rules"], "--keep-largest 1");
  EXPECT_EQ(filter["kept"]["count"], 3);  // the two boxes and E
  EXPECT_EQ(filter["dropped"]["count"], 4);
  EXPECT_EQ(filter["dropped"]["voxels"], 5);
  // The interface of the boxes: 64 faces, two triangles each, shared.
  ASSERT_EQ(largest.report.interfaces.size(), 1u);
  EXPECT_EQ(largest.report.interfaces[0].triangles, 128u);

  // --min-volume 2 (and --min-triangles 13, the same cut: a voxel has 12 triangles, two have 20):
  // the one-voxel specks go (A, C, D and E), B stays; label 3 loses its only voxel, and says so.
  for (const bool byTriangles : {false, true}) {
    const LabelRun small = run(
        [&](ExtractSettings& s) {
          if (byTriangles) {
            s.components.minTriangles = 13;
          } else {
            s.components.minVolume = 2.0;
          }
        },
        byTriangles ? "triangles" : "volume");
    ASSERT_EQ(small.report.labels.size(), 2u) << byTriangles;
    EXPECT_EQ(small.report.labels[0].voxels, 511 + 1 + 2);
    EXPECT_EQ(small.report.labels[1].voxels, 384);
    EXPECT_EQ(closedParts(small, 1), 2u);  // its box and B
    EXPECT_EQ(closedParts(small, 2), 1u);
    ASSERT_FALSE(small.report.warnings.empty());
    EXPECT_EQ(small.report.warnings.back(), "label 3 ('3'): the component rules dropped every component of it");
  }
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

std::string writeText(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

TEST(LabelCli, BadInputGetsOneLineAndLeavesNothing) {
  const std::string dir = testing::tempDir();
  const std::string table = writeText(dir + "/t.txt", "# a table\n1 Liver 200 80 60\n2 Spleen 120 60 200\n");
  struct Case {
    std::string args;
    int exit;
    std::string message;
  };
  const std::vector<Case> cases{
      {"'phantom:voxel' --labels Liver -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --labels names 'Liver', but no label table gives names (--label-table)\n"},
      {"'phantom:voxel' --labels Livr,2 --label-table " + table + " -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --labels names 'Livr', which " + table + " does not hold; the nearest is 'Liver' (1)\n"},
      {"'phantom:voxel' --label-table " + writeText(dir + "/bad.txt", "1 Liver\nLiver 2\n") + " -o " + dir +
           "/{name}.ply",
       1,
       "isoslab: error: " + dir + "/bad.txt:2: 'Liver 2' is not a label line: its first field is not a whole number\n"},
      {"'phantom:voxel' --labels 3-1 -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --labels range '3-1' is reversed\n"},
      {"'phantom:voxel' --labels all --normals -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --normals does not apply to label surfaces yet\n"},
      {"'phantom:voxel' --labels all -o " + dir + "/one.stl", 2,
       "isoslab: error: -o '" + dir +
           "/one.stl' is one file: label surfaces go to a pattern such as 'labels/{name}.stl' (a file per label), "
           "a .glb or .3mf (a mesh per label) or a .ply of the whole label complex\n"},
      {"'phantom:sphere?n=8' --iso 0.3,0.6 --decimate 0.2 -o " + dir + "/{iso}.ply", 2,
       "isoslab: error: --decimate does not apply to several iso values in one pass yet\n"},
      {"'phantom:sphere?n=8' --iso 0.3,0.6 --seed 1,2,3 -o " + dir + "/{iso}.ply", 2,
       "isoslab: error: --seed does not apply to several iso values in one pass yet\n"},
      {"'phantom:voxel' --labels all --seed 1,2,3 -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --seed does not apply to label surfaces yet\n"},
      {"'phantom:voxel' --labels 1-16777215 -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --labels ranges select 16777215 labels; a selection holds at most 1000000 (use all)\n"},
      // Each value once, and 0 (never kept) not at all.
      {"'phantom:voxel' --labels 1-800000,500000-1200000,0-5 -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --labels ranges select 1200000 labels; a selection holds at most 1000000 (use all)\n"},
      {"'phantom:voxel' --channel 1 -o " + dir + "/{name}.ply", 1,
       "isoslab: error: --channel: phantom:voxel has one value per voxel (channel 0 only)\n"},
      {"'phantom:voxel' --labels all --iso 3 -o " + dir + "/{name}.ply", 2,
       "isoslab: error: --iso and --labels exclude each other: a run meshes an iso value or labels\n"},
      {"'phantom:sphere?n=4' --labels all -o " + dir + "/{name}.ply", 1,
       "isoslab: error: phantom:sphere?n=4: voxel (0, 0, 0) holds 974.0192, which is not a label (a label map holds "
       "whole numbers); for a scalar volume give --iso\n"},
  };
  for (const Case& c : cases) {
    const auto r = testing::runCli("extract " + c.args + " -q");
    EXPECT_EQ(r.exitCode, c.exit) << c.args;
    EXPECT_EQ(r.err, c.message) << c.args;
    EXPECT_EQ(testing::fileCount(dir), 2) << c.args;  // the two tables only
  }
  // Labels of 2^24 and beyond: a float slice reads 16777217 as 16777216, so the two would be one
  // label; both are refused, and so is 2^24 itself. 2^24 - 1 is read exactly.
  const auto raw32 = [&](const std::string& name, std::int32_t a, std::int32_t b) {
    std::vector<std::int32_t> voxels(4 * 4 * 4, 0);
    voxels[21] = a;  // (1, 1, 1)
    voxels[22] = b;  // (2, 1, 1)
    std::ofstream(dir + "/" + name, std::ios::binary)
        .write(reinterpret_cast<const char*>(voxels.data()), static_cast<std::streamsize>(voxels.size() * 4));
    return dir + "/" + name + " --raw-dims 4,4,4 --raw-type i32 --labels all -o " + dir + "/{label}.ply -q";
  };
  for (const auto& [a, b, read] : std::vector<std::tuple<std::int32_t, std::int32_t, std::string>>{
           {16777217, 16777216, "16777216"}, {1, -16777217, "-16777216"}, {5, 2147483647, "2147483648"}}) {
    const auto r = testing::runCli("extract " + raw32("big.raw", a, b));
    EXPECT_EQ(r.exitCode, 1) << a << " " << b;
    EXPECT_EQ(r.err, "isoslab: error: " + dir + "/big.raw: voxel (" + (a > 16777215 ? "1" : "2") +
                         ", 1, 1) holds 16777216 or more in magnitude (read as " + read +
                         "), beyond the labels read exactly (whole numbers up to 16777215 in magnitude); for a "
                         "scalar volume give --iso\n");
    std::filesystem::remove(dir + "/big.raw");
    EXPECT_EQ(testing::fileCount(dir), 2);
  }
  const auto edge =
      testing::runCli("extract " + raw32("edge.raw", 16777215, -16777215) + " --report " + dir + "/e.json");
  ASSERT_EQ(edge.exitCode, 0) << edge.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/16777215.ply"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/-16777215.ply"));
  for (const std::string f : {"/16777215.ply", "/-16777215.ply", "/e.json", "/edge.raw"})
    std::filesystem::remove(dir + f);
  // A number beyond the labels in --labels is not taken for a name.
  for (const std::string list : {"16777216", "1-99999999999", "-16777216-3"}) {
    const auto r = testing::runCli("extract 'phantom:voxel' --labels " + list + " -o " + dir + "/{label}.ply -q");
    EXPECT_EQ(r.exitCode, 2) << list;
    const std::string number = list == "16777216" ? list : list == "1-99999999999" ? "99999999999" : "-16777216";
    EXPECT_EQ(r.err, "isoslab: error: --labels '" + number +
                         "' is beyond the labels a map can hold (whole numbers from -16777215 to 16777215)\n");
  }
  // Two labels whose names give one file: the run stops and leaves none of its files.
  const std::string clash = writeText(dir + "/clash.txt", "1 a/b\n2 a_b\n");
  const auto r =
      testing::runCli("extract 'phantom:boxes?n=12&count=2' --label-table " + clash + " -o " + dir + "/{name}.ply -q");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err,
            "isoslab: error: -o pattern '" + dir + "/{name}.ply' gives '" + dir + "/a_b.ply' to labels 1 and 2\n");
  EXPECT_EQ(testing::fileCount(dir), 3);
}

// A label table is text in any line ending, with or without a UTF-8 byte order mark; an ITK-SNAP
// name may hold '#'. What is no text table is refused in one line: a device (/dev/zero was read
// until memory ran out), a folder, UTF-16, a NUL byte.
TEST(LabelTables, AreTextInAnyLineEndingAndRefuseWhatIsNot) {
  const std::string dir = testing::tempDir();
  const LabelTable mac = readLabelTable(writeText(dir + "/mac.txt", "\xEF\xBB\xBF# old Mac\r1 Liver\r2 Spleen\r"));
  ASSERT_EQ(mac.entries.size(), 2u);
  EXPECT_EQ(mac.entries[0].name, "Liver");
  EXPECT_EQ(mac.entries[1].value, 2);
  const LabelTable itk = readLabelTable(
      writeText(dir + "/itk.txt",
                "# ITK-SnAP\r\n    1   255 0 0  1 1 1  \"Label #1\"  # a comment\r\n    2 0 255 0 1 1 1 \"B\"\n"));
  ASSERT_EQ(itk.entries.size(), 2u);
  EXPECT_EQ(itk.entries[0].name, "Label #1");
  EXPECT_EQ(itk.entries[1].name, "B");
  const auto refused = [](const std::string& path) {
    try {
      readLabelTable(path);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("read");
  };
  EXPECT_EQ(refused("/dev/zero"), "/dev/zero: the label table is not a regular file");
  EXPECT_EQ(refused(dir), dir + ": the label table is not a regular file");
  EXPECT_EQ(refused(writeText(dir + "/u16.txt", std::string("\xFF\xFE"
                                                            "1\0 \0A\0",
                                                            8))),
            dir + "/u16.txt: the label table is UTF-16 text; save it as UTF-8");
  EXPECT_EQ(refused(writeText(dir + "/nul.txt", std::string("1 A\n\0", 5))),
            dir + "/nul.txt: the label table holds a NUL byte: it is no text");
  EXPECT_EQ(refused(writeText(dir + "/big.txt", "1 Liver\n16777216 Big\n")),
            dir +
                "/big.txt:2: label 16777216 is beyond the labels a map can hold (whole numbers from -16777215 to "
                "16777215)");
}

TEST(LabelCli, AbsentLabelsWarnAndInfoSaysLabelMap) {
  const std::string dir = testing::tempDir();
  const auto r = testing::runCli("extract 'phantom:voxel' --labels 1,7 -o " + dir + "/{label}.ply");
  EXPECT_EQ(r.exitCode, 0);
  EXPECT_NE(r.err.find("warning: label 7 ('7') is not in the volume\n"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/1.ply"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/7.ply"));
  // A label map needs neither --iso nor --labels.
  const auto implicit = testing::runCli("extract 'phantom:nested?n=20' -o " + dir + "/n{label}.ply -q");
  EXPECT_EQ(implicit.exitCode, 0) << implicit.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/n3.ply"));
  const auto info = testing::runCli("info 'phantom:nested?n=20'");
  EXPECT_NE(info.out.find("labels     3 (a label map"), std::string::npos) << info.out;
}

TEST(LabelCli, TheGlbHasANamedColouredNodePerLabelForThreeJs) {
  const std::string npm = ISOSLAB_NPM_DIR;
  if (const std::string why = testing::gltfClientsMissing(npm); !why.empty()) GTEST_SKIP() << why;
  const std::string dir = testing::tempDir();
  // A 3D Slicer colour table: INDEX NAME R G B A.
  const std::string table =
      writeText(dir + "/c.ctbl",
                "# Color table file\n0 Background 0 0 0 0\n1 Core 230 40 40 255\n2 Middle 40 200 60 "
                "255\n3 Outer 50 80 220 255\n");
  const auto r = testing::runCli("extract 'phantom:nested?n=24' --label-table " + table + " -o " + dir +
                                 "/n.glb --report " + dir + "/r.json -q");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::string cmd = "node " + npm + "/gltf_check.mjs " + dir + "/n.glb > " + dir + "/client.json 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << testing::slurp(dir + "/client.json");
  const auto client = nlohmann::json::parse(testing::slurp(dir + "/client.json"));
  const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
  EXPECT_EQ(client["errors"], 0);
  EXPECT_EQ(client["warnings"], 0);
  const std::map<std::string, std::string> colours{{"Core", "e62828"}, {"Middle", "28c83c"}, {"Outer", "3250dc"}};
  ASSERT_EQ(client["nodes"].size(), 3u);
  for (const auto& label : report["labels"]) {
    const std::string name = label["name"];
    EXPECT_EQ(client["nodes"][name]["color"], colours.at(name));
    EXPECT_EQ(client["nodes"][name]["triangles"], label["triangles"]);
  }
  // Each label's chunks weld into its closed surface.
  for (const auto& mesh : client["meshes"]) {
    EXPECT_EQ(mesh["welded"]["boundaryEdges"], 0) << mesh["name"];
    EXPECT_EQ(mesh["welded"]["nonmanifoldEdges"], 0) << mesh["name"];
  }
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// A 3D Slicer segmentation as its documentation describes it: a NRRD with key:=value pairs per
// segment; `layers` > 1 makes it 4-D, layers first.
std::string writeSegNrrd(const std::string& path, int layers) {
  std::string header = "NRRD0004\n# Complete NRRD file format specification at:\n";
  header += layers > 1 ? "type: unsigned char\ndimension: 4\nspace: left-posterior-superior\nsizes: " +
                             std::to_string(layers) + " 6 5 4\n"
                       : "type: unsigned char\ndimension: 3\nspace: left-posterior-superior\nsizes: 6 5 4\n";
  header += layers > 1 ? "space directions: none (0.5,0,0) (0,0.75,0) (0,0,2)\nkinds: list domain domain domain\n"
                       : "space directions: (0.5,0,0) (0,0.75,0) (0,0,2)\nkinds: domain domain domain\n";
  header += "encoding: raw\nspace origin: (10,-20,30)\n";
  header +=
      "Segment0_Color:=0.8 0.2 0.1\nSegment0_ID:=Segment_1\nSegment0_LabelValue:=1\nSegment0_Layer:=0\n"
      "Segment0_Name:=Liver\nSegment1_Color:=0.1 0.4 0.9\nSegment1_ID:=Segment_2\nSegment1_LabelValue:=2\n"
      "Segment1_Layer:=0\nSegment1_Name:=Kidney\n";
  if (layers > 1) {
    header +=
        "Segment2_Color:=0 1 0\nSegment2_ID:=Segment_3\nSegment2_LabelValue:=1\nSegment2_Layer:=1\n"
        "Segment2_Name:=Tumour\n";
  }
  header += "\n";
  std::string data;
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < 5; ++j) {
      for (int i = 0; i < 6; ++i) {
        // Layer 0: Liver in voxels i 1..2, Kidney in i 3..4 (rows j 1..3, slices k 1..2); layer 1:
        // the Tumour overlapping both, at i 2..3.
        const bool inside = j >= 1 && j <= 3 && k >= 1 && k <= 2;
        const char l0 = inside && i >= 1 && i <= 2 ? 1 : inside && i >= 3 && i <= 4 ? 2 : 0;
        const char l1 = inside && i >= 2 && i <= 3 ? 1 : 0;
        data += l0;
        if (layers > 1) data += l1;
      }
    }
  }
  std::ofstream(path, std::ios::binary) << header << data;
  return path;
}

TEST(LabelInputs, SlicerSegNrrdGivesNamesColoursAndPositions) {
  const std::string dir = testing::tempDir();
  const std::string seg = writeSegNrrd(dir + "/s.seg.nrrd", 1);
  ExtractSettings s;
  s.inputs = {seg};
  s.output = dir + "/{name}.ply";
  s.space = OutputSpace::kLps;
  const ExtractReport r = runExtract(s);  // a segmentation: labels without being asked
  ASSERT_EQ(r.labels.size(), 2u);
  EXPECT_EQ(r.labels[0].name, "Liver");
  EXPECT_EQ(r.labels[0].color, (std::array<std::uint8_t, 3>{204, 51, 26}));
  EXPECT_TRUE(r.labels[0].colorFromTable);
  EXPECT_EQ(r.labels[1].name, "Kidney");
  EXPECT_EQ(r.labels[1].color, (std::array<std::uint8_t, 3>{26, 102, 230}));
  EXPECT_TRUE(std::filesystem::exists(dir + "/Liver.ply"));
  // Liver: voxels i 1..2, j 1..3, k 1..2, boxes half a voxel beyond: x 10 + 0.5 * [0.5, 2.5].
  const std::array<double, 6> liver{10.25, -20 + 0.75 * 0.5, 30 + 2 * 0.5, 11.25, -20 + 0.75 * 3.5, 30 + 2 * 2.5};
  for (std::size_t a = 0; a < 6; ++a) EXPECT_NEAR(r.labels[0].stats.bounds[a], liver[a], 1e-5) << a;
  EXPECT_NEAR(r.labels[0].stats.volume, 12 * 0.5 * 0.75 * 2, 1e-9);
  EXPECT_EQ(r.interfaces.size(), 1u);  // Liver and Kidney touch
  EXPECT_NEAR(r.interfaces[0].area, 6 * 0.75 * 2, 1e-9);
}

// A segmentation's description is read whole, or the file is refused in one line: layers on the
// last axis (which a reader of the first volume would drop), contradicting axes, segments with a
// shared value, a layer beyond the file's, malformed values and colours; a gap in the segments'
// numbering loses none of them.
TEST(LabelInputs, SegNrrdMetadataIsReadWholeOrRefused) {
  const std::string dir = testing::tempDir();
  // writeSegNrrd's file with its header edited: each pair (from, to) replaced once.
  const auto edited = [&](int layers, const std::vector<std::pair<std::string, std::string>>& edits) {
    const std::string path = writeSegNrrd(dir + "/e.seg.nrrd", layers);
    std::string text = testing::slurp(path);
    const std::size_t end = text.find("\n\n");
    std::string header = text.substr(0, end);
    for (const auto& [from, to] : edits) {
      const std::size_t at = header.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) header.replace(at, from.size(), to);
    }
    std::ofstream(path, std::ios::binary) << header << text.substr(end);
    return path;
  };
  const std::string last = "sizes: 6 5 4 2";
  const std::string lastDirections = "space directions: (0.5,0,0) (0,0.75,0) (0,0,2) none";
  const std::string firstSizes = "sizes: 2 6 5 4";
  const std::string firstDirections = "space directions: none (0.5,0,0) (0,0.75,0) (0,0,2)";
  const std::string kinds = "kinds: list domain domain domain";
  const std::string lastKinds = "kinds: domain domain domain list";
  struct Case {
    int layers;
    std::vector<std::pair<std::string, std::string>> edits;
    std::string options, message;
  };
  const std::vector<Case> cases{
      {2,
       {{firstSizes, last}, {firstDirections, lastDirections}, {kinds, lastKinds}},
       "",
       ": its segmentation layers lie on the last axis; isoslab reads them from the first, as 3D Slicer writes them"},
      {2,
       {{firstSizes, last}, {firstDirections, lastDirections}, {kinds + "\n", ""}},
       "",
       ": its segmentation layers lie on the last axis; isoslab reads them from the first, as 3D Slicer writes them"},
      {2,
       {{kinds, lastKinds}},
       "",
       ": NRRD kinds 'domain domain domain list' and space directions 'none (0.5,0,0) (0,0.75,0) (0,0,2)' do not "
       "name one non-spatial axis, first or last"},
      {2,
       {{kinds, "kinds: domain list domain domain"}, {firstDirections + "\n", ""}},
       "",
       ": NRRD kinds 'domain list domain domain' and space directions '' do not name one non-spatial axis, first or "
       "last"},
      {1,
       {{"Segment1_LabelValue:=2", "Segment1_LabelValue:=1"}},
       "",
       ": Liver and Kidney both have LabelValue 1 in layer 0"},
      {1, {{"Segment1_Layer:=0", "Segment1_Layer:=1"}}, "", ": Segment1_Layer 1 is beyond the file's 1 layer"},
      {2, {{"Segment2_Layer:=1", "Segment2_Layer:=2"}}, "", ": Segment2_Layer 2 is beyond the file's 2 layers"},
      {1,
       {{"Segment0_LabelValue:=1", "Segment0_LabelValue:=1 2"}},
       "",
       ": Segment0_LabelValue '1 2' is not one whole number"},
      {1,
       {{"Segment0_Color:=0.8 0.2 0.1", "Segment0_Color:=2 0 0"}},
       "",
       ": Segment0_Color '2 0 0' is not three numbers from 0 to 1"},
      {1,
       {{"Segment0_Color:=0.8 0.2 0.1", "Segment0_Color:=0.8 0.2"}},
       "",
       ": Segment0_Color '0.8 0.2' is not three numbers from 0 to 1"},
      {1,
       {{"Segment0_Name:=Liver", "Segment0_Name:=Liver\nSegment4_Name:=Orphan"}},
       "",
       ": Segment4_Name describes a segment with no Segment4_LabelValue"},
  };
  for (const Case& c : cases) {
    const std::string seg = edited(c.layers, c.edits);
    const auto r = testing::runCli("extract " + seg + " " + c.options + " -o " + dir + "/x.ply -q");
    EXPECT_EQ(r.exitCode, 1) << c.message;
    EXPECT_EQ(r.err, "isoslab: error: " + seg + c.message + "\n");
    EXPECT_FALSE(std::filesystem::exists(dir + "/x.ply"));
  }
  // A channel beyond 0 of a one-layer file names nothing.
  const std::string one = writeSegNrrd(dir + "/one.seg.nrrd", 1);
  const auto channel = testing::runCli("extract " + one + " --channel 1 -o " + dir + "/x.ply -q");
  EXPECT_EQ(channel.exitCode, 1);
  EXPECT_EQ(channel.err, "isoslab: error: --channel: " + one + " has one value per voxel (channel 0 only)\n");
  // Segments numbered 0 and 7: both are read, with their names and colours.
  const std::string gap = edited(1, {{"Segment1_Color", "Segment7_Color"},
                                     {"Segment1_ID", "Segment7_ID"},
                                     {"Segment1_LabelValue", "Segment7_LabelValue"},
                                     {"Segment1_Layer", "Segment7_Layer"},
                                     {"Segment1_Name", "Segment7_Name"}});
  ExtractSettings s;
  s.inputs = {gap};
  s.output = dir + "/{name}.ply";
  const ExtractReport r = runExtract(s);
  ASSERT_EQ(r.labels.size(), 2u);
  EXPECT_EQ(r.labels[1].name, "Kidney");
  EXPECT_EQ(r.labels[1].color, (std::array<std::uint8_t, 3>{26, 102, 230}));
}

// Layers may overlap, so their surfaces may cross: the decimation's crossing test compares
// triangles of one layer only. It compared every pair, so that two overlapping balls in two layers
// kept every triangle (each try was refused as crossing).
TEST(LabelInputs, OverlappingLayersDecimateAndStayClosed) {
  const std::string dir = testing::tempDir();
  const std::string seg = dir + "/balls.seg.nrrd";
  const int n = 24;
  std::string header = fmt::format(
      "NRRD0004\ntype: unsigned char\ndimension: 4\nspace: left-posterior-superior\nsizes: 2 {0} {0} {0}\n"
      "space directions: none (1,0,0) (0,1,0) (0,0,1)\nkinds: list domain domain domain\nencoding: raw\n"
      "space origin: (0,0,0)\nSegment0_ID:=A\nSegment0_LabelValue:=1\nSegment0_Layer:=0\nSegment0_Name:=A\n"
      "Segment1_ID:=B\nSegment1_LabelValue:=1\nSegment1_Layer:=1\nSegment1_Name:=B\n\n",
      n);
  std::string data;
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const auto in = [&](double cx) {
          return (i - cx) * (i - cx) + (j - 11.5) * (j - 11.5) + (k - 11.5) * (k - 11.5) < 64;
        };
        data += static_cast<char>(in(9.5) ? 1 : 0);   // layer 0: ball A
        data += static_cast<char>(in(13.5) ? 1 : 0);  // layer 1: ball B, overlapping A
      }
    }
  }
  std::ofstream(seg, std::ios::binary) << header << data;
  for (const char* threads : {"1", "2"}) {
    const auto r = testing::runCli("extract " + seg + " --max-error 1 --threads " + threads + " -o '" + dir + "/t" +
                                   threads + "{name}.ply' --report " + dir + "/r.json -q");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
    const auto& d = report["decimation"];
    EXPECT_EQ(d["regions_kept_whole"], 0);
    EXPECT_LT(d["triangles_after"].get<double>(), 0.5 * d["triangles_before"].get<double>());
    ASSERT_EQ(report["labels"].size(), 2u);
    for (const auto& l : report["labels"]) {
      EXPECT_TRUE(l["closed"].get<bool>()) << l["name"];
    }
  }
  EXPECT_TRUE(testing::slurp(dir + "/t1A.ply") == testing::slurp(dir + "/t2A.ply"));
  EXPECT_TRUE(testing::slurp(dir + "/t1B.ply") == testing::slurp(dir + "/t2B.ply"));
}

// One pass keys a label by its layer in the upper bits of a 32-bit value (core/volume_info.h): a
// segmentation of more layers than fit is refused in one line, and a channel still reads one.
TEST(LabelInputs, MoreLayersThanOnePassHoldsAreRefused) {
  const std::string dir = testing::tempDir();
  const std::string seg = dir + "/many.seg.nrrd";
  const int layers = kMaxLayers + 1;
  std::string header = fmt::format(
      "NRRD0004\ntype: unsigned char\ndimension: 4\nspace: left-posterior-superior\nsizes: {} 3 3 3\n"
      "space directions: none (1,0,0) (0,1,0) (0,0,1)\nkinds: list domain domain domain\nencoding: raw\n"
      "space origin: (0,0,0)\n",
      layers);
  for (int k = 0; k < layers; ++k) {
    header +=
        fmt::format("Segment{0}_ID:=S{0}\nSegment{0}_LabelValue:=1\nSegment{0}_Layer:={0}\nSegment{0}_Name:=N{0}\n", k);
  }
  std::string data(static_cast<std::size_t>(layers) * 27, '\0');
  data[static_cast<std::size_t>(layers) * 13 + 5] = 1;  // the middle voxel, in layer 5
  std::ofstream(seg, std::ios::binary) << header << "\n" << data;
  const auto refused = testing::runCli("extract " + seg + " -o " + dir + "/x.ply -q");
  EXPECT_EQ(refused.exitCode, 1);
  EXPECT_EQ(refused.err, "isoslab: error: " + seg +
                             ": 32 segmentation layers; one pass reads at most 31: choose one "
                             "with --channel\n");
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.ply"));
  const auto one = testing::runCli("extract " + seg + " --channel 5 -o " + dir + "/{name}.ply -q");
  EXPECT_EQ(one.exitCode, 0) << one.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/N5.ply"));
}

TEST(LabelInputs, ALayeredSegNrrdMeshesEveryLayerInOnePass) {
  const std::string dir = testing::tempDir();
  const std::string seg = writeSegNrrd(dir + "/l.seg.nrrd", 2);
  // A threshold takes one layer's values: a channel must choose it.
  const auto refused = testing::runCli("extract " + seg + " --iso 1 -o " + dir + "/x.ply -q");
  EXPECT_EQ(refused.exitCode, 1);
  EXPECT_EQ(refused.err, "isoslab: error: " + seg +
                             ": 2 segmentation layers (segments of different layers may overlap); a run meshes one: "
                             "choose it with --channel 0..1\n");
  // One pass over both layers: each surface is the bytes of its own layer's run, at 1 and 2 threads.
  const auto run = [&](const std::string& folder, const std::string& options) {
    std::filesystem::create_directories(dir + "/" + folder);
    const auto r = testing::runCli("extract " + seg + " " + options + " -o '" + dir + "/" + folder +
                                   "/{name}.ply' --report " + dir + "/" + folder + ".json -q");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    return nlohmann::json::parse(testing::slurp(dir + "/" + folder + ".json"));
  };
  run("c0", "--channel 0");
  run("c1", "--channel 1");
  const auto all = run("all", "--threads 1");
  run("threads", "--threads 2 --sequential-voxels 0");
  EXPECT_EQ(testing::fileCount(dir + "/all"), 3);
  for (const auto& [name, layer] : {std::pair{"Liver", "c0"}, std::pair{"Kidney", "c0"}, std::pair{"Tumour", "c1"}}) {
    const std::string own = testing::slurp(dir + "/" + layer + "/" + name + ".ply");
    EXPECT_FALSE(own.empty()) << name;
    EXPECT_TRUE(testing::slurp(dir + "/all/" + name + ".ply") == own) << name;
    EXPECT_TRUE(testing::slurp(dir + "/threads/" + name + ".ply") == own) << name;
  }
  // The report: each label's value and layer, voxels counted by layer, interfaces within a layer.
  EXPECT_EQ(all["layers"], 2);
  ASSERT_EQ(all["labels"].size(), 3u);
  const std::vector<std::tuple<std::string, int, int>> labels{{"Liver", 1, 0}, {"Kidney", 2, 0}, {"Tumour", 1, 1}};
  for (std::size_t n = 0; n < labels.size(); ++n) {
    const auto& l = all["labels"][n];
    EXPECT_EQ(l["name"], std::get<0>(labels[n]));
    EXPECT_EQ(l["value"], std::get<1>(labels[n]));
    EXPECT_EQ(l["layer"], std::get<2>(labels[n]));
    EXPECT_EQ(l["voxels"], 12) << l["name"];  // 2 x 3 x 2 voxels each
  }
  ASSERT_EQ(all["label_interfaces"].size(), 1u);
  EXPECT_EQ(all["label_interfaces"][0]["labels"], nlohmann::json::array({1, 2}));
  EXPECT_EQ(all["label_interfaces"][0]["layer"], 0);
  // {label} gives Liver (1 of layer 0) and Tumour (1 of layer 1) one file: refused, saying which.
  const auto clash = testing::runCli("extract " + seg + " -o '" + dir + "/{label}.ply' -q");
  EXPECT_EQ(clash.exitCode, 2);
  EXPECT_EQ(clash.err, "isoslab: error: -o pattern '" + dir + "/{label}.ply' gives '" + dir +
                           "/1.ply' to labels 1 and 1 of layer 1\n");
  // A value selects its label in every layer; a name, the label it names.
  const auto byValue = run("value", "--labels 1");
  ASSERT_EQ(byValue["labels"].size(), 2u);
  EXPECT_EQ(byValue["labels"][0]["name"], "Liver");
  EXPECT_EQ(byValue["labels"][1]["name"], "Tumour");
  EXPECT_EQ(byValue["warnings"].size(), 0u) << byValue["warnings"];
  const auto byName = run("name", "--labels Tumour");
  ASSERT_EQ(byName["labels"].size(), 1u);
  EXPECT_EQ(byName["labels"][0]["layer"], 1);
  EXPECT_TRUE(testing::slurp(dir + "/name/Tumour.ply") == testing::slurp(dir + "/c1/Tumour.ply"));
  // The component rules, whose second pass opens the file again with every layer.
  const auto rules = run("rules", "--keep-largest 1 --min-volume 1");
  for (const auto& [name, layer] : {std::pair{"Liver", "c0"}, std::pair{"Kidney", "c0"}, std::pair{"Tumour", "c1"}}) {
    EXPECT_TRUE(testing::slurp(dir + "/rules/" + name + ".ply") ==
                testing::slurp(dir + "/" + layer + "/" + name + ".ply"))
        << name;
  }
  for (const auto& l : rules["labels"]) EXPECT_EQ(l["components"]["found"], 1) << l["name"];
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// A mesh's triangles as sets of corner positions, rotated to start at the smallest corner.
std::multiset<std::array<std::array<float, 3>, 3>> triangleSet(const IndexedMesh& m) {
  std::multiset<std::array<std::array<float, 3>, 3>> out;
  for (const Triangle& t : m.triangles) {
    std::array<std::array<float, 3>, 3> p{};
    for (std::size_t k = 0; k < 3; ++k) p[k] = {m.positions[t[k]].x, m.positions[t[k]].y, m.positions[t[k]].z};
    std::rotate(p.begin(), std::min_element(p.begin(), p.end()), p.end());
    out.insert(p);
  }
  return out;
}

// The component rules apply to each value's surface: each file is the bytes of that value's own
// run with the same rules (its header naming its iso value), whichever rule drops what.
TEST(SeveralIsoValues, ComponentRulesApplyToEachSurface) {
  const std::string dir = testing::tempDir();
  const std::string input = "'phantom:head?n=64' --close-boundary -q";
  for (const std::string rules : {"--keep-largest 1", "--min-triangles 100", "--keep-largest 2 --min-volume 50"}) {
    SCOPED_TRACE(rules);
    const auto both = testing::runCli("extract " + input + " --iso 0,300 " + rules + " -o '" + dir +
                                      "/{iso}.ply' --report " + dir + "/r.json");
    ASSERT_EQ(both.exitCode, 0) << both.err;
    const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
    EXPECT_GT(report["component_filter"]["dropped"]["count"].get<int>(), 10);
    for (const char* iso : {"0", "300"}) {
      const auto one = testing::runCli("extract " + input + " --iso " + iso + " " + rules + " -o " + dir + "/one.ply");
      ASSERT_EQ(one.exitCode, 0) << one.err;
      const std::string own = testing::slurp(dir + "/one.ply");
      EXPECT_NE(own.find(std::string("comment isoslab mc iso ") + iso + " "), std::string::npos);
      EXPECT_TRUE(testing::slurp(dir + "/" + iso + ".ply") == own) << iso;
    }
  }
}

TEST(SeveralIsoValues, OnePassGivesEachValuesOwnSurface) {
  const std::string dir = testing::tempDir();
  for (const char* method : {"mc", "mt6"}) {
    SCOPED_TRACE(method);
    const auto r =
        testing::runCli(std::string("extract 'phantom:head?n=48' --iso skin,300 --close-boundary --method ") + method +
                        " -o '" + dir + "/{iso}.ply' --report " + dir + "/r.json -q");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
    ASSERT_EQ(report["labels"].size(), 2u);
    for (const auto& [value, name] : {std::pair{-400.0, "-400"}, std::pair{300.0, "300"}}) {
      const auto single = testing::runCli(std::string("extract 'phantom:head?n=48' --close-boundary --method ") +
                                          method + " --iso " + name + " -o " + dir + "/single.ply -q");
      ASSERT_EQ(single.exitCode, 0) << single.err;
      const IndexedMesh one = readMesh(dir + "/single.ply");
      const IndexedMesh part = readMesh(dir + "/" + name + ".ply");
      EXPECT_EQ(triangleSet(part), triangleSet(one)) << name;
      EXPECT_EQ(part.positions.size(), one.positions.size());
      const auto& entry = report["labels"][value < 0 ? 0 : 1];
      EXPECT_EQ(entry["iso"], value);
      EXPECT_EQ(entry["triangles"], one.triangles.size());
      EXPECT_EQ(entry["closed"], true);
    }
    // Threads run every value's slab workers side by side: the same bytes.
    const auto threaded = testing::runCli(
        std::string("extract 'phantom:head?n=48' --iso skin,300 --close-boundary --threads 2 --sequential-voxels 0 "
                    "--method ") +
        method + " -o " + dir + "/threads.glb -q");
    ASSERT_EQ(threaded.exitCode, 0) << threaded.err;
    const auto single = testing::runCli(std::string("extract 'phantom:head?n=48' --iso skin,300 --close-boundary "
                                                    "--threads 1 --method ") +
                                        method + " -o " + dir + "/single.glb -q");
    ASSERT_EQ(single.exitCode, 0) << single.err;
    EXPECT_TRUE(testing::slurp(dir + "/threads.glb") == testing::slurp(dir + "/single.glb"));
  }
  const auto twice = testing::runCli("extract 'phantom:head?n=48' --iso 300,300 -o '" + dir + "/{iso}.ply' -q");
  EXPECT_EQ(twice.exitCode, 2);
  EXPECT_EQ(twice.err, "isoslab: error: --iso lists a value twice\n");
  const auto autoList = testing::runCli("extract 'phantom:head?n=48' --iso auto,300 -o '" + dir + "/{iso}.ply' -q");
  EXPECT_EQ(autoList.exitCode, 2);
  EXPECT_NE(autoList.err.find("'auto' in 'auto,300' is not a number, bone or skin (a list takes no auto)"),
            std::string::npos)
      << autoList.err;
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// Without topology (the program's runs without --report) the complex .ply and every label's
// counts, area, volume and interfaces are those of the full split; only the topology is left out.
// The 7-label checker phantom run twice: as it is, to full.ply, and with `lighten` applied to
// the settings, to light.ply; the second run's settings are left in `s`.
struct LightRun {
  std::string dir = testing::tempDir();
  ExtractSettings s;
  ExtractReport full, light;
};
LightRun runFullAndLight(const std::function<void(ExtractSettings&)>& lighten) {
  LightRun r;
  r.s.inputs = {"phantom:checker?n=21,18,15&b=3&labels=7"};
  r.s.output = r.dir + "/full.ply";
  r.full = runExtract(r.s);
  r.s.output = r.dir + "/light.ply";
  lighten(r.s);
  r.light = runExtract(r.s);
  return r;
}

TEST(LabelSplit, WithoutTopologyTheComplexAndMeasuresAreTheSame) {
  const LightRun r = runFullAndLight([](ExtractSettings& s) { s.labelTopology = false; });
  const ExtractReport& full = r.full;
  const ExtractReport& light = r.light;
  EXPECT_EQ(testing::slurp(r.dir + "/full.ply"), testing::slurp(r.dir + "/light.ply"));
  ASSERT_EQ(light.labels.size(), full.labels.size());
  ASSERT_EQ(light.labels.size(), 7u);
  for (std::size_t n = 0; n < full.labels.size(); ++n) {
    const ExtractLabel& a = full.labels[n];
    const ExtractLabel& b = light.labels[n];
    EXPECT_TRUE(a.topology);
    EXPECT_FALSE(b.topology);
    EXPECT_TRUE(a.stats.closed());
    EXPECT_EQ(a.value, b.value);
    EXPECT_EQ(a.voxels, b.voxels);
    EXPECT_EQ(a.stats.triangles, b.stats.triangles);
    EXPECT_EQ(a.stats.area, b.stats.area);
    EXPECT_EQ(a.stats.volume, b.stats.volume);
    EXPECT_EQ(b.stats.edges, 0u);
  }
  ASSERT_EQ(light.interfaces.size(), full.interfaces.size());
  for (std::size_t n = 0; n < full.interfaces.size(); ++n) {
    EXPECT_EQ(light.interfaces[n].triangles, full.interfaces[n].triangles);
    EXPECT_EQ(light.interfaces[n].area, full.interfaces[n].area);
  }
}

// Without measures (the program's run without --report), the complex and the triangle counts are
// the same, and the report leaves out what was not measured rather than printing zeros.
TEST(LabelSplit, WithoutMeasuresTheComplexAndCountsAreTheSameAndTheReportSaysNothingElse) {
  LightRun r = runFullAndLight([](ExtractSettings& s) {
    s.labelTopology = false;
    s.labelMeasures = false;
  });
  const ExtractReport& full = r.full;
  const ExtractReport& light = r.light;
  ExtractSettings& s = r.s;
  const std::string& dir = r.dir;
  EXPECT_EQ(testing::slurp(dir + "/full.ply"), testing::slurp(dir + "/light.ply"));
  ASSERT_EQ(light.labels.size(), 7u);
  ASSERT_EQ(full.labels.size(), 7u);
  for (std::size_t n = 0; n < full.labels.size(); ++n) {
    EXPECT_EQ(full.labels[n].stats.triangles, light.labels[n].stats.triangles);
    EXPECT_GT(full.labels[n].stats.area, 0);
    EXPECT_TRUE(full.labels[n].measured);
    EXPECT_FALSE(light.labels[n].measured);
  }
  EXPECT_FALSE(full.interfaces.empty());
  EXPECT_TRUE(light.interfaces.empty());
  const auto json = nlohmann::json::parse(extractReportText(light, "extract", nullptr));
  ASSERT_EQ(json["labels"].size(), 7u);
  EXPECT_FALSE(json["labels"][0].contains("area"));
  EXPECT_FALSE(json["labels"][0].contains("mesh_volume"));
  EXPECT_EQ(json["labels"][0]["triangles"].get<std::uint64_t>(), full.labels[0].stats.triangles);
  // A .glb's nodes carry the measures, so it measures them whatever the setting says.
  s.output = dir + "/scene.glb";
  const ExtractReport scene = runExtract(s);
  ASSERT_EQ(scene.labels.size(), 7u);
  EXPECT_TRUE(scene.labels[0].measured);
  EXPECT_EQ(scene.labels[0].stats.area, full.labels[0].stats.area);
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// Whether segment p-q passes through the inside of triangle abc (not within `eps` of its edges or
// of the segment's ends): Moller and Trumbore's test in double.
bool crosses(const Vec3f& p, const Vec3f& q, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const double eps = 1e-9;
  const double d[3] = {double(q.x) - p.x, double(q.y) - p.y, double(q.z) - p.z};
  const double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
  const double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
  const double h[3] = {d[1] * e2[2] - d[2] * e2[1], d[2] * e2[0] - d[0] * e2[2], d[0] * e2[1] - d[1] * e2[0]};
  const double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
  if (std::abs(det) < 1e-15) return false;  // parallel: touching in a plane is not crossing
  const double s[3] = {double(p.x) - a.x, double(p.y) - a.y, double(p.z) - a.z};
  const double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
  const double qv[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
  const double v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det;
  const double t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
  return u > eps && v > eps && u + v < 1 - eps && t > eps && t < 1 - eps;
}

// Pairs of triangles of different labels that cross, by brute force: an edge of one through the
// inside of the other, or, for triangles with one corner position in common, the edge opposite it
// (a fold); triangles with an edge in common (interfaces, junction lines) are not compared.
std::int64_t crossings(const std::map<std::int32_t, IndexedMesh>& meshes) {
  struct Tri {
    std::array<Vec3f, 3> p;
    std::array<float, 6> box;
    std::int32_t label;
  };
  std::vector<Tri> all;
  for (const auto& [label, m] : meshes) {
    for (const Triangle& t : m.triangles) {
      Tri x{{m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]}, {}, label};
      x.box = {x.p[0].x, x.p[0].y, x.p[0].z, x.p[0].x, x.p[0].y, x.p[0].z};
      for (const Vec3f& v : x.p) {
        x.box[0] = std::min(x.box[0], v.x), x.box[1] = std::min(x.box[1], v.y), x.box[2] = std::min(x.box[2], v.z);
        x.box[3] = std::max(x.box[3], v.x), x.box[4] = std::max(x.box[4], v.y), x.box[5] = std::max(x.box[5], v.z);
      }
      all.push_back(x);
    }
  }
  std::sort(all.begin(), all.end(), [](const Tri& a, const Tri& b) { return a.box[0] < b.box[0]; });
  std::int64_t count = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    for (std::size_t j = i + 1; j < all.size() && all[j].box[0] <= all[i].box[3]; ++j) {
      const Tri& a = all[i];
      const Tri& b = all[j];
      if (a.label == b.label) continue;
      if (a.box[1] > b.box[4] || b.box[1] > a.box[4] || a.box[2] > b.box[5] || b.box[2] > a.box[5]) continue;
      // Corners in common: none, every edge is tested; one, the edges opposite it (a fold over
      // the corner); more, none.
      int shared = 0;
      std::size_t inA = 0, inB = 0;
      for (std::size_t u = 0; u < 3; ++u) {
        for (std::size_t v = 0; v < 3; ++v) {
          if (a.p[u] == b.p[v]) ++shared, inA = u, inB = v;
        }
      }
      if (shared > 1) continue;
      bool hit = false;
      for (std::size_t k = 0; k < 3 && !hit; ++k) {
        const bool fromA = shared == 1 && (k == inA || (k + 1) % 3 == inA);
        const bool fromB = shared == 1 && (k == inB || (k + 1) % 3 == inB);
        hit = (!fromA && crosses(a.p[k], a.p[(k + 1) % 3], b.p[0], b.p[1], b.p[2])) ||
              (!fromB && crosses(b.p[k], b.p[(k + 1) % 3], a.p[0], a.p[1], a.p[2]));
      }
      count += hit ? 1 : 0;
    }
  }
  return count;
}

// Issue 37: after --smooth 20, and after --smooth 20 --decimate 0.2, every label is still closed
// and manifold, its interfaces are the same triangles in both labels (reversed), no triangle of one
// label crosses one of another, and one thread gives the bytes of two.
TEST(LabelSmoothing, PhantomsStayClosedSharedAndUncrossed) {
  // The brute force finds a crossing: two triangles through each other.
  IndexedMesh flat{{{0, 0, 0}, {2, 0, 0}, {0, 2, 0}}, {}, {}, {{0, 1, 2}}, {}, 0, {}};
  IndexedMesh through{{{0.5f, 0.5f, -1}, {0.5f, 0.5f, 1}, {3, 3, 0.5f}}, {}, {}, {{0, 1, 2}}, {}, 0, {}};
  EXPECT_EQ(crossings({{1, flat}, {2, through}}), 1);
  for (const auto& [input, decimate] :
       {std::pair{"phantom:nested?n=20", 1.0}, std::pair{"phantom:boxes?n=16", 1.0},
        std::pair{"phantom:touch?at=edge", 1.0}, std::pair{"phantom:checker?n=12&b=4&labels=27", 1.0},
        std::pair{"phantom:nested?n=20", 0.2}, std::pair{"phantom:boxes?n=16", 0.2},
        std::pair{"phantom:touch?at=edge", 0.2}, std::pair{"phantom:checker?n=12&b=4&labels=27", 0.2}}) {
    SCOPED_TRACE(input);
    SCOPED_TRACE(decimate);
    const std::string dir = testing::tempDir();
    const std::string dir2 = testing::tempDir();
    ExtractSettings s;
    s.inputs = {input};
    s.output = dir + "/{label}.ply";
    s.smoothing.iterations = 20;
    s.decimate = decimate;
    s.threads = 1;
    const ExtractReport report = runExtract(s);
    if (decimate < 1) {
      ASSERT_TRUE(report.decimation.has_value());
      const DecimationReport& d = report.decimation->result;
      EXPECT_LT(d.trianglesOut, d.trianglesIn * 7 / 10);
      EXPECT_LE(d.distanceMax, kLabelDistanceBound + 1e-5);
      EXPECT_EQ(d.keptRegions, 0u);
    }
    s.output = dir2 + "/{label}.ply";
    s.threads = 2;
    runExtract(s);
    std::map<std::int32_t, IndexedMesh> meshes;
    for (const ExtractLabel& l : report.labels) {
      meshes[l.value] = readMesh(l.path);
      EXPECT_EQ(testing::slurp(l.path), testing::slurp(dir2 + "/" + std::to_string(l.value) + ".ply"));
      const Topology t = topology(meshes[l.value].positions, meshes[l.value].triangles);
      EXPECT_EQ(t.unpairedEdges, 0) << l.value;
      EXPECT_EQ(t.nonManifoldEdges, 0) << l.value;
      EXPECT_EQ(t.nonManifoldVertices, 0) << l.value;
      ASSERT_TRUE(l.smoothing.has_value());
      // Flat faces and straight junction lines stay; the nested balls' staircases move.
      if (std::string(input).find("nested") != std::string::npos) {
        EXPECT_GT(l.smoothing->first, 0.05) << l.value;
      }
      EXPECT_LE(l.smoothing->first, 0.5 + 1e-6) << l.value;
    }
    // Interfaces: the triangles of a that are b's reversed, by position, as many as the report says.
    using Key = std::array<std::array<float, 3>, 3>;
    const auto keys = [](const IndexedMesh& m, bool reverse) {
      std::set<Key> out;
      for (const Triangle& t : m.triangles) {
        const auto at = [&](VertexId v) {
          return std::array<float, 3>{m.positions[v].x, m.positions[v].y, m.positions[v].z};
        };
        out.insert(reverse ? Key{at(t[0]), at(t[2]), at(t[1])} : Key{at(t[0]), at(t[1]), at(t[2])});
      }
      return out;
    };
    for (const ExtractInterface& face : report.interfaces) {
      const std::set<Key> a = keys(meshes.at(face.a), false);
      const std::set<Key> b = keys(meshes.at(face.b), true);
      std::size_t shared = 0;
      for (const Key& k : a) shared += b.count(k);
      EXPECT_EQ(shared, face.triangles) << face.a << "|" << face.b;
    }
    EXPECT_EQ(crossings(meshes), 0);
    std::filesystem::remove_all(dir);
    std::filesystem::remove_all(dir2);
  }
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// A ball of diameter n split into `cells` Voronoi regions (labels 1..cells) around random seeds,
// the background outside.
Labels voronoiBall(std::int64_t n, int cells, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> coordinate(0.2 * static_cast<double>(n), 0.8 * static_cast<double>(n));
  std::vector<std::array<double, 3>> seeds(static_cast<std::size_t>(cells));
  for (auto& s : seeds) s = {coordinate(rng), coordinate(rng), coordinate(rng)};
  Labels l;
  l.dims = {n, n, n};
  const double c = 0.5 * static_cast<double>(n - 1), r2 = 0.24 * static_cast<double>(n * n);
  for (std::int64_t k = 0; k < n; ++k) {
    for (std::int64_t j = 0; j < n; ++j) {
      for (std::int64_t i = 0; i < n; ++i) {
        const std::array<double, 3> p{double(i), double(j), double(k)};
        if ((p[0] - c) * (p[0] - c) + (p[1] - c) * (p[1] - c) + (p[2] - c) * (p[2] - c) > r2) {
          l.values.push_back(0);
          continue;
        }
        std::size_t best = 0;
        double nearest = INFINITY;
        for (std::size_t s = 0; s < seeds.size(); ++s) {
          const double d = (p[0] - seeds[s][0]) * (p[0] - seeds[s][0]) + (p[1] - seeds[s][1]) * (p[1] - seeds[s][1]) +
                           (p[2] - seeds[s][2]) * (p[2] - seeds[s][2]);
          if (d < nearest) nearest = d, best = s;
        }
        l.values.push_back(static_cast<float>(best + 1));
      }
    }
  }
  return l;
}

// The complex's chunks through the sink that `make` makes in front of a collector, collected.
template <typename Make>
Complex through(const Complex& c, const VolumeInfo& info, Make&& make) {
  Complex out;
  ComplexSink sink(out);
  auto step = make(sink);
  step.begin(labelHeader(info, LatticeFrame::physical(info)));
  for (const MeshChunk& chunk : c.chunks) step.consume(chunk);
  step.finish();
  return out;
}

// The complex decimated as a stream, in blocks of `slabs` slabs; with `report`, the decimation's
// report there.
Complex decimateComplex(const Complex& c, const VolumeInfo& info, double ratio, int threads, std::int64_t slabs,
                        bool localRepairs = true, DecimationReport* report = nullptr) {
  DecimateOptions o;
  o.ratio = ratio;
  o.maxDistance = kLabelDistanceBound;
  o.blockSlabs = slabs;
  o.blockTriangles = 1;
  o.threads = threads;
  o.localRepairs = localRepairs;
  Complex out;
  ComplexSink sink(out);
  DecimationSink step(sink, o);
  step.begin(labelHeader(info, LatticeFrame::physical(info)));
  for (const MeshChunk& chunk : c.chunks) step.consume(chunk);
  step.finish();
  if (report != nullptr) *report = step.report();
  return out;
}

// The complex smoothed as the label job smooths it (--smooth 20); with threads, each round's steps
// shared down to single vertices.
Complex smoothComplex(const Complex& c, const VolumeInfo& info, int threads = 1) {
  SmoothOptions o;
  o.iterations = 20;
  o.passBand = kLabelPassBand;
  o.maxDisplacement = 0.5;
  return through(c, info, [&](MeshSink& next) { return SmoothingSink(next, o, threads, 1); });
}

double pointSegment(const Vec3f& p, const Vec3f& a, const Vec3f& b) {
  const double ab[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
  const double ap[3] = {double(p.x) - a.x, double(p.y) - a.y, double(p.z) - a.z};
  const double len = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
  const double t = len > 0 ? std::clamp((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / len, 0.0, 1.0) : 0.0;
  const double d[3] = {ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]};
  return std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

// The distance from p to triangle abc: to its plane where p projects inside it, else to its edges.
double pointTriangle(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const double u[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
  const double v[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
  const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
  if (nn > 0) {
    const double w[3] = {double(p.x) - a.x, double(p.y) - a.y, double(p.z) - a.z};
    const double h = (w[0] * n[0] + w[1] * n[1] + w[2] * n[2]) / nn;
    const double q[3] = {w[0] - h * n[0], w[1] - h * n[1], w[2] - h * n[2]};  // relative to a
    // Barycentric coordinates of q by areas against the normal.
    const auto side = [&](const double* x, const double* y) {
      const double cx[3] = {x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]};
      return cx[0] * n[0] + cx[1] * n[1] + cx[2] * n[2];
    };
    const double qb[3] = {q[0] - u[0], q[1] - u[1], q[2] - u[2]};
    const double cb[3] = {v[0] - u[0], v[1] - u[1], v[2] - u[2]};
    if (side(u, q) >= 0 && side(q, v) >= 0 && side(cb, qb) <= 0) return std::abs(h) * std::sqrt(nn);
  }
  return std::min({pointSegment(p, a, b), pointSegment(p, b, c), pointSegment(p, c, a)});
}

// The largest distance from the sample points of `after`'s triangles of `label` (centroid and edge
// midpoints) to `before`'s surface of that label, by brute force.
double labelDistance(const Complex& before, const Complex& after, std::int32_t label) {
  const std::vector<Triangle> original = surfaceOf(before, label);
  double worst = 0;
  for (const Triangle& t : surfaceOf(after, label)) {
    const Vec3f &a = after.positions[t[0]], &b = after.positions[t[1]], &c = after.positions[t[2]];
    const auto mid = [](const Vec3f& x, const Vec3f& y) {
      return Vec3f{(x.x + y.x) / 2, (x.y + y.y) / 2, (x.z + y.z) / 2};
    };
    for (const Vec3f& p : {Vec3f{(a.x + b.x + c.x) / 3, (a.y + b.y + c.y) / 3, (a.z + b.z + c.z) / 3}, mid(a, b),
                           mid(b, c), mid(c, a)}) {
      double nearest = INFINITY;
      for (const Triangle& o : original) {
        nearest =
            std::min(nearest, pointTriangle(p, before.positions[o[0]], before.positions[o[1]], before.positions[o[2]]));
      }
      worst = std::max(worst, nearest);
    }
  }
  return worst;
}

// Edges of the complex used by three triangles: the lines where three labels meet.
std::size_t junctionEdges(const Complex& c) {
  std::map<std::pair<VertexId, VertexId>, int> uses;
  for (const Triangle& t : c.triangles) {
    for (std::size_t k = 0; k < 3; ++k) ++uses[std::minmax(t[k], t[(k + 1) % 3])];
  }
  std::size_t n = 0;
  for (const auto& [e, u] : uses) n += u == 3 ? 1 : 0;
  return n;
}

// Issue 37: decimating the complex as a stream keeps every label's surface closed, of its genus
// and no more non-manifold than it was, within the distance bound of its own surface, and apart
// from the others (no crossing); the lines where three labels meet are simplified along
// themselves; the thread count changes nothing. Interfaces stay shared by construction (each is
// one set of triangles with a label on each side).
// Two triangles on the same three points: a label pressed flat (a 0|2 and a 1|2 triangle on one
// another) or a sheet folded onto itself. The copies of a split vertex lie on one point, so
// collapses onto them made such pairs (a hostile search's smallest case, 3 x 3 x 2 voxels, at
// --decimate 0.1 --max-error 1: two pairs) until the crossing search flagged them.
TEST(LabelDecimation, NoTwoTrianglesLieOnTheSamePoints) {
  const std::string dir = testing::tempDir();
  const std::array<std::array<std::array<float, 2>, 3>, 3> labels{
      {{{{2, 0}, {2, 1}, {1, 1}}}, {{{1, 2}, {0, 2}, {0, 1}}}, {{{1, 1}, {1, 1}, {0, 0}}}}};
  testing::VectorSource volume({2, 3, 3}, [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return labels[static_cast<std::size_t>(z)][static_cast<std::size_t>(y)][static_cast<std::size_t>(x)];
  });
  writeVolume(volume, dir + "/v.nrrd", {});
  for (const double maxError : {1.0, 2.0}) {
    ExtractSettings s;
    s.inputs = {dir + "/v.nrrd"};
    s.labels = parseLabelRequest("all");
    s.decimate = 0.1;
    s.maxError = maxError;
    s.threads = 1;
    s.output = dir + "/complex.ply";
    const ExtractReport r = runExtract(s);
    EXPECT_GT(r.decimation->result.trianglesOut, 0u);
    const IndexedMesh m = readMesh(s.output);
    std::map<std::array<std::array<float, 3>, 3>, std::size_t> seen;
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      std::array<std::array<float, 3>, 3> corners{};
      for (std::size_t k = 0; k < 3; ++k) {
        const Vec3f& p = m.positions[m.triangles[t][k]];
        corners[k] = {p.x, p.y, p.z};
      }
      std::sort(corners.begin(), corners.end());
      const auto [it, fresh] = seen.emplace(corners, t);
      EXPECT_TRUE(fresh) << "--max-error " << maxError << ": triangles " << it->second << " and " << t;
    }
  }
}

// Two labels of one voxel each, face to face: a bound of a voxel let the decimation press one flat
// onto the other's face, its four triangles on the face's four corners (split along the other
// diagonal, so that no two had the same three points), enclosing nothing. Folds like that are now
// refused as crossings.
TEST(LabelDecimation, NoLabelIsPressedFlat) {
  const std::string dir = testing::tempDir();
  testing::VectorSource volume({6, 6, 6}, [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return x == 2 && z == 2 && (y == 2 || y == 3) ? static_cast<float>(1 + y) : 0.0f;
  });
  writeVolume(volume, dir + "/v.nrrd", {});
  for (const double maxError : {0.75, 1.0, 2.0}) {
    ExtractSettings s;
    s.inputs = {dir + "/v.nrrd"};
    s.labels = parseLabelRequest("all");
    s.maxError = maxError;
    s.threads = 1;
    s.output = dir + "/{label}.ply";
    const ExtractReport r = runExtract(s);
    ASSERT_EQ(r.labels.size(), 2u);
    for (const auto& label : r.labels) {
      EXPECT_GT(label.stats.volume, 0.25) << "--max-error " << maxError << ", label " << label.value;
      EXPECT_TRUE(label.stats.closed()) << label.value;
    }
  }
}

// The constraints (sheets, lines, fixed corners, the volume's faces, the displacement limit) in the
// smoothing's rounds of steps side by side on threads: the same positions as on one thread.
TEST(LabelSmoothing, SameOnThreadsAsOnOne) {
  for (const auto& [name, labels] :
       {std::pair{"voronoi", voronoiBall(22, 7, 5)}, std::pair{"noise", randomLabels({9, 8, 10}, 3, 11)}}) {
    SCOPED_TRACE(name);
    VolumeInfo info;
    const Complex c = extractComplex(labels, 1, &info);
    const Complex one = smoothComplex(c, info);
    ASSERT_FALSE(one.positions.empty());
    EXPECT_NE(one.positions, c.positions);  // it moved
    for (const int threads : {2, 3}) {
      const Complex many = smoothComplex(c, info, threads);
      EXPECT_TRUE(many.positions == one.positions) << threads << " threads";
      EXPECT_EQ(many.triangles, one.triangles);
    }
  }
}

TEST(LabelDecimation, BlocksKeepEveryLabelClosedNearAndApart) {
  for (const auto& [name, labels] :
       {std::pair{"voronoi", voronoiBall(22, 7, 5)}, std::pair{"voronoi small cells", voronoiBall(18, 16, 9)},
        std::pair{"noise", randomLabels({9, 8, 10}, 3, 11)}}) {
    SCOPED_TRACE(name);
    VolumeInfo info;
    const Complex c = smoothComplex(extractComplex(labels, 1, &info), info);
    DecimationReport local, regionWide;
    const Complex d = decimateComplex(c, info, 0.2, 1, 6, true, &local);
    const Complex again = decimateComplex(c, info, 0.2, 1, 6, false, &regionWide);
    // Issue 36's local repairs: a repair simplifies again only around its frozen patch, and gives
    // the triangles that replaying the whole region gives (in another order), try for try. Every
    // case repairs; the noise repairs one region twice (the second starts from the first's result).
    EXPECT_GT(local.repairedRegions, 0u);
    if (std::string(name) == "noise") {
      EXPECT_GT(local.attempts, local.blocks + local.regions + local.repairedRegions);
    }
    EXPECT_EQ(local.repairedRegions, regionWide.repairedRegions);
    EXPECT_EQ(local.attempts, regionWide.attempts);
    // The report's seconds: a complex's calls search for crossings, inside the calls' own time (the
    // parts are timed within each call), and the distance is measured (the options' default).
    const DecimationReport::Seconds& seconds = local.seconds;
    EXPECT_GT(seconds.crossing, 0.0);
    EXPECT_GT(seconds.simplifier, 0.0);
    EXPECT_GT(seconds.checks, 0.0);
    EXPECT_GT(seconds.grids, 0.0);
    EXPECT_GE(seconds.calls * (1 + 1e-9), seconds.simplifier + seconds.checks + seconds.crossing);
    EXPECT_GT(seconds.measure, 0.0);
    EXPECT_EQ(local.frozenTriangles, regionWide.frozenTriangles);
    EXPECT_EQ(local.crossing, regionWide.crossing);
    // Corner for corner (the output numbers its vertices in the order that the triangles come).
    const auto sided = [](const Complex& x) {
      std::vector<std::pair<std::array<std::array<float, 3>, 3>, LabelPair>> all;
      for (std::size_t t = 0; t < x.triangles.size(); ++t) {
        std::array<std::array<float, 3>, 3> at;
        for (std::size_t k = 0; k < 3; ++k) {
          const Vec3f& p = x.positions[x.triangles[t][k]];
          at[k] = {p.x, p.y, p.z};
        }
        all.emplace_back(at, x.sides[t]);
      }
      std::sort(all.begin(), all.end());
      return all;
    };
    EXPECT_EQ(sided(d), sided(again));
    const Complex d2 = decimateComplex(c, info, 0.2, 2, 6);
    const Complex whole = decimateComplex(c, info, 0.2, 1, 1000);
    EXPECT_EQ(d.positions, d2.positions);
    EXPECT_EQ(d.triangles, d2.triangles);
    EXPECT_EQ(d.sides, d2.sides);
    ASSERT_EQ(d.sides.size(), d.triangles.size());
    // Smooth regions come near the ratio whole (22-27% here) and in blocks of six slabs (35-41%: what
    // touches a block's seam waits for the region across it, which holds its split curves); their
    // junction lines lose a third of their edges whole. The noise's regions are single voxels.
    if (std::string(name) != "noise") {
      EXPECT_LT(whole.triangles.size(), c.triangles.size() * 3 / 10);
      EXPECT_LT(d.triangles.size(), c.triangles.size() * 9 / 20);
      EXPECT_LT(junctionEdges(whole), junctionEdges(c) * 2 / 3);
      EXPECT_LT(junctionEdges(d), junctionEdges(c) * 4 / 5);
    }
    std::map<std::int32_t, IndexedMesh> meshes;
    for (const auto& [label, voxels] : labels.counts()) {
      if (label == 0) continue;
      SCOPED_TRACE(label);
      const Topology was = topology(c.positions, surfaceOf(c, label));
      const Topology now = topology(d.positions, surfaceOf(d, label));
      EXPECT_EQ(now.unpairedEdges, 0);
      EXPECT_LE(now.nonManifoldEdges, was.nonManifoldEdges);
      EXPECT_EQ(now.euler, was.euler);
      EXPECT_LE(labelDistance(c, d, label), kLabelDistanceBound + 1e-4);
      meshes[label] = IndexedMesh{d.positions, {}, {}, surfaceOf(d, label), {}, 0, {}};
    }
    EXPECT_EQ(crossings(meshes), 0);
  }
}

}  // namespace
}  // namespace isoslab
