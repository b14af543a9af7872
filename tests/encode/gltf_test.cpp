// .glb round trips through `decode` and `metrics`, the metadata every mesh file carries, and the
// conventions of the programs that open them (3D Slicer's SPACE tag, glTF's frame).
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"
#include "encode/mesh_reader.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::runCli;
using testing::slurp;

nlohmann::json json(const std::string& path) {
  return nlohmann::json::parse(slurp(path));
}

nlohmann::json metrics(const std::string& mesh) {
  const auto r = runCli("metrics " + mesh);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  return nlohmann::json::parse(r.out);
}

// The topology fields that a round trip must keep exactly.
const char* kTopology[] = {"vertices",          "triangles",          "boundary_edges", "interior_boundary_edges",
                           "nonmanifold_edges", "inconsistent_edges", "euler"};

// Extracts `input` to a .glb in small chunks, then checks that `metrics` of the .glb and of its
// decoded PLY give the extraction's own counts.
void expectExactRoundTrip(const std::string& input, const std::string& options, const std::string& label) {
  const std::string dir = testing::tempDir();
  const auto x = runCli("extract " + input + " " + options + " -q -o " + dir + "/m.glb --report " + dir + "/r.json");
  ASSERT_EQ(x.exitCode, 0) << label << ": " << x.err;
  const auto report = json(dir + "/r.json");
  ASSERT_GT(report["output"]["chunks"].get<double>(), 3) << label;
  ASSERT_GT(report["output"]["seam_vertices"].get<double>(), 0) << label;
  const auto d = runCli("decode " + dir + "/m.glb -o " + dir + "/d.ply");
  ASSERT_EQ(d.exitCode, 0) << label << ": " << d.err;
  const auto fromGlb = metrics(dir + "/m.glb");
  const auto fromPly = metrics(dir + "/d.ply");
  for (const char* key : kTopology) {
    EXPECT_EQ(fromGlb[key], report[key]) << label << ": .glb " << key;
    EXPECT_EQ(fromPly[key], report[key]) << label << ": decoded PLY " << key;
  }
}

TEST(GlbSeams, DecodeGivesTheExtractionsTopologyOnTheNoisyHead) {
  for (const char* method : {"mc", "mt5", "mt6", "bcc12"}) {
    expectExactRoundTrip("'phantom:head?n=48,48,40&noise=40'",
                         std::string("--iso -400 --chunk-triangles 3000 --method ") + method, method);
  }
}

// Values 99, 100 and 101 in equal parts, at iso 100: a third of the lattice points lie on the
// surface, so that many distinct vertices share a position (every crossed edge that ends at such a
// point puts its vertex there), inside a chunk and across seams.
TEST(GlbSeams, DecodeGivesTheExtractionsTopologyWhereAThirdOfTheValuesEqualTheIso) {
  const std::string dir = testing::tempDir();
  const std::int64_t n = 28;
  std::vector<std::uint8_t> v(static_cast<std::size_t>(n * n * n));
  std::uint32_t state = 12345;
  for (auto& x : v) {
    state = state * 1664525u + 1013904223u;
    x = static_cast<std::uint8_t>(99 + (state >> 16) % 3);
  }
  std::ofstream(dir + "/f.raw", std::ios::binary)
      .write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size()));
  for (const char* method : {"mc", "mt5", "mt6", "bcc12"}) {
    expectExactRoundTrip(
        dir + "/f.raw", std::string("--raw-dims 28,28,28 --iso 100 --chunk-triangles 4000 --method ") + method, method);
  }
}

TEST(GlbSeams, UncompressedGlbDecodesToTheSameMesh) {
  const std::string dir = testing::tempDir();
  const std::string in = "'phantom:head?n=40,40,32' --iso -400 --normals -q";
  ASSERT_EQ(runCli("extract " + in + " --draco off -o " + dir + "/p.glb --report " + dir + "/r.json").exitCode, 0);
  ASSERT_EQ(runCli("extract " + in + " -o " + dir + "/p.ply").exitCode, 0);
  const IndexedMesh glb = readMesh(dir + "/p.glb");
  const IndexedMesh ply = readMesh(dir + "/p.ply");
  EXPECT_EQ(glb.positions, ply.positions);  // plain accessors keep every float, in extraction order
  EXPECT_EQ(glb.normals, ply.normals);
  EXPECT_EQ(glb.triangles, ply.triangles);
  const auto report = json(dir + "/r.json");
  const auto m = metrics(dir + "/p.glb");
  for (const char* key : kTopology) EXPECT_EQ(m[key], report[key]) << key;
}

// The header lines of a PLY, up to end_header.
std::vector<std::string> plyHeader(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::vector<std::string> lines;
  for (std::string l; std::getline(f, l) && l != "end_header";) lines.push_back(l);
  return lines;
}

bool has(const std::vector<std::string>& lines, const std::string& line) {
  return std::find(lines.begin(), lines.end(), line) != lines.end();
}

TEST(MeshMetadata, DecodeCarriesMethodIsoSpaceAndTheVolume) {
  const std::string dir = testing::tempDir();
  ASSERT_EQ(runCli("extract 'phantom:sphere?n=24&r=8' --iso 0.5 --method mt6 --space ras -q -o " + dir +
                   "/s.glb --report " + dir + "/r.json")
                .exitCode,
            0);
  const auto report = json(dir + "/r.json");
  ASSERT_EQ(runCli("decode " + dir + "/s.glb -o " + dir + "/d.ply").exitCode, 0);
  const auto header = plyHeader(dir + "/d.ply");
  EXPECT_TRUE(has(header, "comment isoslab mt6 iso 0.5 space ras")) << header[2];
  EXPECT_TRUE(has(header, "comment SPACE=RAS"));
  MeshMetadata meta;
  readMesh(dir + "/d.ply", &meta);
  EXPECT_EQ(meta.method, "mt6");
  EXPECT_EQ(meta.iso, 0.5);
  EXPECT_EQ(meta.space, "ras");
  ASSERT_TRUE(meta.volumeBounds.has_value());
  for (int k = 0; k < 6; ++k)
    EXPECT_EQ((*meta.volumeBounds)[static_cast<std::size_t>(k)], report["volume_bounds"][k].get<double>());
  ASSERT_TRUE(meta.volumeFaces.has_value());
  // RAS negates x and y of the (identity) phantom frame: the lattice's x-min face (i = 0) is the
  // plane x = 0 with the volume on its negative side, and its x-max face (i = 23) is x = -23.
  EXPECT_EQ((*meta.volumeFaces)[0], (FacePlane{1, 0, 0, 0}));
  EXPECT_EQ((*meta.volumeFaces)[1], (FacePlane{-1, 0, 0, 23}));
  EXPECT_GT(meta.positionTolerance, 0);  // half the Draco step of the .glb it came from
}

// 3D Slicer reads SPACE=LPS or SPACE=RAS from the STL header and from PLY and OBJ comments, and
// takes LPS when the tag is missing.
TEST(MeshMetadata, EveryFormatTagsItsCoordinateSpaceAsSlicerReadsIt) {
  const std::string dir = testing::tempDir();
  for (const char* space : {"lps", "ras"}) {
    const std::string tag = std::string("SPACE=") + (std::string(space) == "lps" ? "LPS" : "RAS");
    for (const char* ext : {"ply", "obj", "stl"}) {
      const std::string out = dir + "/m_" + space + "." + ext;
      ASSERT_EQ(runCli(std::string("extract 'phantom:sphere?n=16&r=5' --space ") + space + " -q -o " + out).exitCode,
                0);
      const std::string bytes = slurp(out);
      const std::string head = bytes.substr(0, std::string(ext) == "stl" ? 80 : 400);
      EXPECT_NE(head.find(tag), std::string::npos) << out << ": " << head;
      if (std::string(ext) == "stl") {
        EXPECT_NE(head.rfind("solid", 0), 0u);  // binary STL must not look ASCII
      }
      MeshMetadata meta;
      readMesh(out, &meta);
      EXPECT_EQ(meta.space, space) << out;
    }
  }
  // Voxel coordinates are no patient space: no tag.
  ASSERT_EQ(runCli("extract 'phantom:sphere?n=16&r=5' --space voxel -q -o " + dir + "/v.ply").exitCode, 0);
  EXPECT_EQ(slurp(dir + "/v.ply").substr(0, 400).find("SPACE="), std::string::npos);
}

// A sphere larger than its volume is cut by all six faces: the report's boundary edges all lie on
// them. metrics must say the same from each file, and null where the file cannot say (STL).
TEST(MeshMetadata, MetricsAgreesWithTheReportOnAnOpenMesh) {
  const std::string dir = testing::tempDir();
  const std::string in = "'phantom:sphere?n=24&r=14' -q --chunk-triangles 500";
  ASSERT_EQ(runCli("extract " + in + " -o " + dir + "/o.glb --report " + dir + "/r.json").exitCode, 0);
  const auto report = json(dir + "/r.json");
  ASSERT_GT(report["boundary_edges"].get<int>(), 100);
  ASSERT_EQ(report["interior_boundary_edges"], 0);
  for (const char* ext : {"ply", "obj"}) {
    ASSERT_EQ(runCli("extract " + in + " -o " + dir + "/o." + ext).exitCode, 0);
    const auto m = metrics(dir + "/o." + ext);
    EXPECT_EQ(m["boundary_edges"], report["boundary_edges"]) << ext;
    EXPECT_EQ(m["interior_boundary_edges"], 0) << ext;
    EXPECT_EQ(m["volume_bounds"], report["volume_bounds"]) << ext;
  }
  EXPECT_EQ(metrics(dir + "/o.glb")["interior_boundary_edges"], 0);
  ASSERT_EQ(runCli("decode " + dir + "/o.glb -o " + dir + "/d.obj").exitCode, 0);
  EXPECT_EQ(metrics(dir + "/d.obj")["interior_boundary_edges"], 0);
  ASSERT_EQ(runCli("extract " + in + " -o " + dir + "/o.stl").exitCode, 0);
  const auto stl = metrics(dir + "/o.stl");
  EXPECT_TRUE(stl["interior_boundary_edges"].is_null());
  EXPECT_TRUE(stl["volume_bounds"].is_null());
}

// The reproducer: the Philips head's skull at 350 HU, open where the scan ends.
TEST(MeshMetadata, SkullFromDicomMeasuresAsItsReport) {
  const std::string data = testing::sharedData("ct-philips-head");
  if (data.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string dir = testing::tempDir();
  ASSERT_EQ(runCli("extract " + data + " --iso 350 -q -o " + dir + "/skull.glb --report " + dir + "/r.json").exitCode,
            0);
  const auto report = json(dir + "/r.json");
  ASSERT_EQ(runCli("decode " + dir + "/skull.glb -o " + dir + "/skull.ply").exitCode, 0);
  for (const std::string mesh : {"skull.glb", "skull.ply"}) {
    const auto m = metrics(dir + "/" + mesh);
    for (const char* key : kTopology) EXPECT_EQ(m[key], report[key]) << mesh << " " << key;
  }
}

// The topology that gltf_check.mjs finds once it has welded the draco3d-decoded primitives by
// their _ISOSLAB_SEAM keys itself: the extraction's own counts.
void expectWeldedAsReport(const nlohmann::json& seen, const nlohmann::json& report, const std::string& label) {
  const auto& w = seen["welded"];
  EXPECT_EQ(w["primitives"], report["output"].value("chunks", 1)) << label;
  EXPECT_EQ(w["vertices"], report["vertices"]) << label;
  EXPECT_EQ(w["triangles"], report["triangles"]) << label;
  EXPECT_EQ(w["boundaryEdges"], report["boundary_edges"]) << label;
  EXPECT_EQ(w["nonmanifoldEdges"], report["nonmanifold_edges"]) << label;
  EXPECT_EQ(w["euler"], report["euler"]) << label;
}

// The Khronos validator and three.js (tests/encode/js/gltf_check.mjs) on every kind of .glb:
// Draco chunks with seam keys and normals, plain accessors, and the raw frame. three.js applies
// the root node, so the loaded box must be the report's bounds in glTF's frame, in metres.
TEST(GltfClients, ValidateAndLoadInGltfsFrame) {
  const std::string npm = ISOSLAB_NPM_DIR;
  if (const std::string why = testing::gltfClientsMissing(npm); !why.empty()) GTEST_SKIP() << why;
  const std::string dir = testing::tempDir();
  struct Case {
    std::string options;
    bool gltfFrame;
    const char* space;
  };
  for (const Case& c : {Case{"--chunk-triangles 4000", true, "lps"}, Case{"--draco off", true, "lps"},
                        Case{"--chunk-triangles 4000", true, "ras"}, Case{"--draco off", true, "ras"},
                        Case{"--chunk-triangles 4000 --gltf-frame raw", false, "lps"},
                        Case{"--draco off --gltf-frame raw", false, "lps"}}) {
    const auto x = runCli("extract 'phantom:head?n=48,48,40' --iso -400 --normals --space " + std::string(c.space) +
                          " " + c.options + " -q -o " + dir + "/h.glb --report " + dir + "/r.json");
    ASSERT_EQ(x.exitCode, 0) << c.options << ": " << x.err;
    const auto report = json(dir + "/r.json");
    const std::string cmd = "node " + npm + "/gltf_check.mjs " + dir + "/h.glb > " + dir + "/client.json 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/client.json");
    const auto seen = json(dir + "/client.json");
    EXPECT_EQ(seen["errors"], 0) << c.options << ": " << seen["messages"];
    EXPECT_EQ(seen["warnings"], 0) << c.options << ": " << seen["messages"];
    EXPECT_EQ(seen["triangles"], report["triangles"]) << c.options;
    expectWeldedAsReport(seen, report, c.options);
    const auto& b = report["bounds"];
    double lo[3], hi[3];
    double scale = 1;
    if (!c.gltfFrame) {
      for (int a = 0; a < 3; ++a) {
        lo[a] = b[a].get<double>();
        hi[a] = b[a + 3].get<double>();
      }
    } else if (std::string(c.space) == "lps") {  // (x, y, z) -> (x, z, -y) mm -> m
      scale = 0.001;
      lo[0] = b[0].get<double>(), lo[1] = b[2].get<double>(), lo[2] = -b[4].get<double>();
      hi[0] = b[3].get<double>(), hi[1] = b[5].get<double>(), hi[2] = -b[1].get<double>();
    } else {  // RAS: (x, y, z) -> (-x, z, y)
      scale = 0.001;
      lo[0] = -b[3].get<double>(), lo[1] = b[2].get<double>(), lo[2] = b[1].get<double>();
      hi[0] = -b[0].get<double>(), hi[1] = b[5].get<double>(), hi[2] = b[4].get<double>();
    }
    const double step =
        report["output"].contains("quantization_step") ? report["output"]["quantization_step"].get<double>() : 0.0;
    const double tolerance = scale * (0.5 * step + 1e-4);
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(seen["min"][a].get<double>(), scale * lo[a], tolerance) << c.options << " axis " << a;
      EXPECT_NEAR(seen["max"][a].get<double>(), scale * hi[a], tolerance) << c.options << " axis " << a;
    }
    EXPECT_EQ(seen["extras"]["frame"], c.gltfFrame ? "gltf" : "raw");
    EXPECT_EQ(seen["extras"]["space"], c.space);
  }
}

// The seam attribute itself, where it must appear: a field whose values are a third each 99, 100
// and 101, at iso 100, in small chunks (so that many vertices share a position, inside a chunk and
// across seams), for every method. The client welds the primitives by the keys and must find the
// extraction's topology: its vertices, triangles, boundary edges and Euler characteristic.
TEST(GltfClients, ValidateAndLoadTheSeamAttribute) {
  const std::string npm = ISOSLAB_NPM_DIR;
  if (const std::string why = testing::gltfClientsMissing(npm); !why.empty()) GTEST_SKIP() << why;
  const std::string dir = testing::tempDir();
  std::vector<std::uint8_t> v(20 * 20 * 20);
  std::uint32_t state = 777;
  for (auto& x : v) {
    state = state * 1664525u + 1013904223u;
    x = static_cast<std::uint8_t>(99 + (state >> 16) % 3);
  }
  std::ofstream(dir + "/f.raw", std::ios::binary)
      .write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size()));
  for (const char* method : {"mc", "mt5", "mt6", "bcc12"}) {
    const auto x = runCli("extract " + dir + "/f.raw --raw-dims 20,20,20 --iso 100 --normals --chunk-triangles 3000 " +
                          "--method " + method + " -q -o " + dir + "/s.glb --report " + dir + "/r.json");
    ASSERT_EQ(x.exitCode, 0) << method << ": " << x.err;
    const auto report = json(dir + "/r.json");
    ASSERT_GT(report["output"]["chunks"].get<double>(), 2) << method;
    ASSERT_GT(report["output"]["seam_keys"].get<double>(), 0) << method;
    ASSERT_GT(report["output"]["seam_unwelded"].get<double>(), 0) << method;
    ASSERT_GT(report["boundary_edges"].get<double>(), 0) << method;  // open where the volume ends
    EXPECT_NE(slurp(dir + "/s.glb").find("\"_ISOSLAB_SEAM\""), std::string::npos) << method;
    const std::string cmd = "node " + npm + "/gltf_check.mjs " + dir + "/s.glb > " + dir + "/client.json 2>&1";
    ASSERT_EQ(std::system(cmd.c_str()), 0) << slurp(dir + "/client.json");
    const auto seen = json(dir + "/client.json");
    EXPECT_EQ(seen["errors"], 0) << method << ": " << seen["messages"];
    EXPECT_EQ(seen["warnings"], 0) << method << ": " << seen["messages"];
    EXPECT_EQ(seen["triangles"], report["triangles"]) << method;
    expectWeldedAsReport(seen, report, method);
  }
}

}  // namespace
}  // namespace isoslab
