#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "encode/draco_codec.h"
#include "encode/draco_writers.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_reader.h"
#include "encode/mesh_writer.h"
#include "extract/frame.h"
#include "io/open_source.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::slurp;

struct Written {
  IndexedMesh mesh;  // the uncompressed mesh
  MeshStats stats;
  MeshHeader header;
  std::vector<std::pair<std::string, double>> details;
};

Written writeMesh(const std::string& input, double iso, const std::string& path, const WriterOptions& options,
                  bool normals = false) {
  auto source = openSource(input, {});
  ExtractOptions e;
  e.iso = iso;
  e.normals = normals;
  const LatticeFrame frame = LatticeFrame::physical(source->info());
  auto extractor = makeExtractor(e, source->info(), frame);
  auto writer = makeMeshWriter(path, options);
  MemoryMeshSink memory;
  MeshStatsSink stats;
  TeeSink tee({writer.get(), &memory, &stats});
  MeshHeader header;
  header.normals = normals;
  header.method = "mc";
  header.iso = iso;
  header.space = frame.name();
  header.volumeBounds = frame.bounds(source->info().dims);
  runPipeline(*source, *extractor, tee, header);
  return {memory.mesh(), stats.stats(), header, writer->details()};
}

MeshStats measure(const IndexedMesh& mesh) {
  MeshStatsSink s;
  feedMesh(mesh, MeshHeader{}, s);
  return s.stats();
}

double detail(const Written& w, const std::string& key) {
  for (const auto& [k, v] : w.details) {
    if (k == key) return v;
  }
  ADD_FAILURE() << "no detail " << key;
  return 0;
}

// Every decoded vertex is the quantized image of an original vertex, within half a step of it.
void expectQuantizedImage(const Written& w, const IndexedMesh& decoded, const WriterOptions& options) {
  const DracoSettings s = dracoSettingsFor(w.header.volumeBounds, options);
  const double step = s.range / (std::ldexp(1.0, s.quantBits) - 1);
  std::map<std::array<float, 3>, Vec3f> image;
  for (const Vec3f& p : w.mesh.positions) {
    image[{dracoDequantized(p.x, s.origin[0], s), dracoDequantized(p.y, s.origin[1], s),
           dracoDequantized(p.z, s.origin[2], s)}] = p;
  }
  for (const Vec3f& d : decoded.positions) {
    const auto found = image.find({d.x, d.y, d.z});
    ASSERT_NE(found, image.end()) << d.x << " " << d.y << " " << d.z;
    const Vec3f& o = found->second;
    EXPECT_LE(std::abs(d.x - o.x), 0.5 * step * (1 + 1e-5));
    EXPECT_LE(std::abs(d.y - o.y), 0.5 * step * (1 + 1e-5));
    EXPECT_LE(std::abs(d.z - o.z), 0.5 * step * (1 + 1e-5));
  }
}

TEST(GlbDraco, ChunkedSphereRoundTripsAndItsSeamsWeld) {
  for (bool normals : {false, true}) {
    const std::string dir = testing::tempDir();
    WriterOptions options;
    options.chunkTriangles = 2000;  // several chunks, so several seams
    const Written w = writeMesh("phantom:sphere?n=64&r=20", 800, dir + "/s.glb", options, normals);
    EXPECT_GE(detail(w, "chunks"), 6.0);
    EXPECT_LE(detail(w, "worst_quantization_error"), 0.5 * detail(w, "quantization_step") * (1 + 1e-5));
    const IndexedMesh decoded = readMesh(dir + "/s.glb");
    EXPECT_EQ(decoded.triangles.size(), w.mesh.triangles.size());
    EXPECT_EQ(decoded.positions.size(), w.mesh.positions.size());  // seams welded, nothing lost
    EXPECT_EQ(decoded.normals.size(), normals ? decoded.positions.size() : 0u);
    expectQuantizedImage(w, decoded, options);
    const MeshStats s = measure(decoded);
    EXPECT_TRUE(s.closed());
    EXPECT_TRUE(s.oriented());
    EXPECT_EQ(s.euler, 2);
    EXPECT_EQ(testing::fileCount(dir), 1);  // no spool left
  }
}

TEST(GlbDraco, TorusCutByTheVolumeKeepsItsTopology) {
  const std::string dir = testing::tempDir();
  WriterOptions options;
  options.chunkTriangles = 1500;
  // The torus pokes out of the z range: open along the volume's faces.
  const Written w = writeMesh("phantom:torus?n=60,60,12&R=18&r=7", 930, dir + "/t.glb", options);
  ASSERT_GT(w.stats.boundaryEdges, 0u);
  const IndexedMesh decoded = readMesh(dir + "/t.glb");
  const MeshStats s = measure(decoded);
  EXPECT_EQ(decoded.triangles.size(), w.mesh.triangles.size());
  EXPECT_EQ(s.boundaryEdges, w.stats.boundaryEdges);
  EXPECT_EQ(s.nonManifoldEdges, 0u);
  EXPECT_EQ(s.euler, w.stats.euler);
}

TEST(DrcWriter, OneDracoMeshThatDracoDecoderReads) {
  const std::string dir = testing::tempDir();
  const Written w = writeMesh("phantom:sphere?n=48&r=15", 850, dir + "/s.drc", {});
  const IndexedMesh ours = readMesh(dir + "/s.drc");
  EXPECT_EQ(ours.triangles.size(), w.mesh.triangles.size());
  if (std::system("command -v draco_decoder >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "draco_decoder (Debian draco) is absent";
  const std::string cmd = "draco_decoder -i " + dir + "/s.drc -o " + dir + "/back.ply >/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const IndexedMesh theirs = readMesh(dir + "/back.ply");
  EXPECT_EQ(theirs.triangles.size(), w.mesh.triangles.size());
  EXPECT_EQ(theirs.positions.size(), w.mesh.positions.size());
}

TEST(GlbDraco, RealClientsLoadIt) {
  const std::string npm = ISOSLAB_NPM_DIR;
  if (const std::string why = testing::gltfClientsMissing(npm); !why.empty()) GTEST_SKIP() << why;
  const std::string dir = testing::tempDir();
  const auto r = testing::runCli("extract 'phantom:head?n=64,64,56' --iso -400 --normals --chunk-triangles 5000 -o " +
                                 dir + "/h.glb --report " + dir + "/r.json -q");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  const std::string cmd = "node " + npm + "/gltf_check.mjs " + dir + "/h.glb > " + dir + "/client.json 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/client.json");
  const auto seen = nlohmann::json::parse(slurp(dir + "/client.json"));
  EXPECT_EQ(seen["errors"], 0) << seen["messages"];
  EXPECT_EQ(seen["warnings"], 0) << seen["messages"];
  EXPECT_EQ(seen["triangles"], report["triangles"]);
  EXPECT_EQ(seen["primitives"].get<double>(), report["output"]["chunks"].get<double>());
  EXPECT_GT(report["output"]["chunks"].get<double>(), 2.0);
  // three.js applies the root node: glTF's frame in metres, (x, y, z) = 0.001 (x, z, -y).
  const double halfStep = 0.001 * 0.5 * report["output"]["quantization_step"].get<double>() * (1 + 1e-5);
  const auto& b = report["bounds"];
  const double lo[3] = {b[0].get<double>(), b[2].get<double>(), -b[4].get<double>()};
  const double hi[3] = {b[3].get<double>(), b[5].get<double>(), -b[1].get<double>()};
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(seen["min"][a].get<double>(), 0.001 * lo[a], halfStep + 1e-9);
    EXPECT_NEAR(seen["max"][a].get<double>(), 0.001 * hi[a], halfStep + 1e-9);
  }
  EXPECT_EQ(seen["extras"]["method"], "mc");
  EXPECT_EQ(seen["extras"]["iso"], -400);
}

TEST(GlbDraco, FailuresLeaveNothingBehind) {
  const std::string dir = testing::tempDir();
  const auto missing = testing::runCli("extract 'phantom:sphere?n=32' -q -o " + dir + "/none/s.glb");
  EXPECT_EQ(missing.exitCode, 1);
  EXPECT_EQ(missing.err, "isoslab: error: " + dir + "/none/s.glb: cannot create the output: the folder '" + dir +
                             "/none' does not exist\n");
  const std::string cmd = std::string("bash -c \"ulimit -f 16; exec ") + ISOSLAB_CLI_PATH +
                          " extract 'phantom:head?n=96' -q --chunk-triangles 20000 -o " + dir + "/big.glb\" 2>" + dir +
                          "/err";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  const std::string err = slurp(dir + "/err");
  EXPECT_EQ(err.rfind("isoslab: error: " + dir + "/big.glb: cannot write", 0), 0u) << err;
  EXPECT_EQ(err.find('\n'), err.size() - 1) << err;
  EXPECT_FALSE(fs::exists(dir + "/big.glb"));
  EXPECT_EQ(testing::fileCount(dir), 1);  // only the captured stderr: no temporary output, no spool
  const auto bad = testing::runCli("decode " + dir + "/err -o " + dir + "/x.ply");
  EXPECT_EQ(bad.exitCode, 1);
  EXPECT_EQ(bad.err,
            "isoslab: error: " + dir + "/err: unknown mesh format (PLY, binary STL, OBJ, .glb or .drc expected)\n");
}

TEST(GlbDraco, DecodeCommandWritesTheWeldedMesh) {
  const std::string dir = testing::tempDir();
  ASSERT_EQ(
      testing::runCli("extract 'phantom:sphere?n=40&r=12' -q --chunk-triangles 1000 -o " + dir + "/s.glb").exitCode, 0);
  ASSERT_EQ(testing::runCli("extract 'phantom:sphere?n=40&r=12' -q -o " + dir + "/s.ply").exitCode, 0);
  const auto r = testing::runCli("decode " + dir + "/s.glb -o " + dir + "/d.ply");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const IndexedMesh a = readMesh(dir + "/s.ply");
  const IndexedMesh b = readMesh(dir + "/d.ply");
  EXPECT_EQ(a.triangles.size(), b.triangles.size());
  EXPECT_EQ(a.positions.size(), b.positions.size());
  EXPECT_TRUE(measure(b).closed());
}

}  // namespace
}  // namespace isoslab
