// readMesh() (encode/mesh_reader.h) checked against readers isoslab did not write: Draco's
// ReadMeshFromFile for PLY, OBJ and STL, and tinyobjloader for OBJ; and on files that Draco's own
// encoders wrote.
#include <gtest/gtest.h>

#include <draco/io/mesh_io.h>
#include <draco/io/obj_encoder.h>
#include <draco/io/ply_encoder.h>
#include <draco/io/stl_encoder.h>
#include <tiny_obj_loader.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "encode/indexed_mesh.h"
#include "encode/mesh_reader.h"
#include "encode/mesh_writer.h"
#include "test_support.h"

namespace isoslab {
namespace {

// A triangle as vertex ids, rotated so that its smallest id comes first (orientation kept).
Triangle canonical(Triangle t) {
  while (t[0] > t[1] || t[0] > t[2]) t = {t[1], t[2], t[0]};
  return t;
}

std::vector<Triangle> canonicalSorted(const std::vector<Triangle>& triangles) {
  std::vector<Triangle> out;
  for (const Triangle& t : triangles) out.push_back(canonical(t));
  std::sort(out.begin(), out.end());
  return out;
}

// Draco's mesh in `ours`'s vertex ids: each Draco point goes to the nearest of our vertices by
// brute force, which must be within `tolerance`, so that a parser's last-digit rounding is allowed
// but no vertex may be missing, moved or merged. Returns the triangles; fails the test otherwise.
std::vector<Triangle> inOurIds(const draco::Mesh& theirs, const IndexedMesh& ours, double tolerance) {
  const draco::PointAttribute* position = theirs.GetNamedAttribute(draco::GeometryAttribute::POSITION);
  EXPECT_NE(position, nullptr);
  if (position == nullptr) return {};
  std::vector<VertexId> ids(theirs.num_points());
  double worst = 0;
  for (std::uint32_t p = 0; p < theirs.num_points(); ++p) {
    float v[3];
    position->ConvertValue<float, 3>(position->mapped_index(draco::PointIndex(p)), v);
    double best = INFINITY;
    for (std::size_t k = 0; k < ours.positions.size(); ++k) {
      const Vec3f& q = ours.positions[k];
      const double d = std::hypot(q.x - v[0], q.y - v[1], q.z - v[2]);
      if (d < best) {
        best = d;
        ids[p] = static_cast<VertexId>(k);
      }
    }
    worst = std::max(worst, best);
  }
  EXPECT_LE(worst, tolerance);
  std::vector<Triangle> triangles;
  for (std::uint32_t f = 0; f < theirs.num_faces(); ++f) {
    const auto& face = theirs.face(draco::FaceIndex(f));
    triangles.push_back({ids[face[0].value()], ids[face[1].value()], ids[face[2].value()]});
  }
  return triangles;
}

std::unique_ptr<draco::Mesh> dracoRead(const std::string& path) {
  auto read = draco::ReadMeshFromFile(path);
  EXPECT_TRUE(read.ok()) << path << ": " << read.status().error_msg_string();
  return read.ok() ? std::move(read).value() : nullptr;
}

// A closed surface with normals, written by isoslab in `format`.
struct Written {
  testing::Extraction x;
  std::string path;
};

Written writeSphere(const std::string& dir, const std::string& format) {
  Written w{testing::extract("phantom:sphere?n=24&r=8", Method::kTetra6, 920, true), dir + "/s." + format};
  auto writer = makeMeshWriter(w.path, WriterOptions{});
  MeshHeader h;
  h.normals = format != "stl";
  h.method = "mt6";
  h.iso = 920;
  h.space = "voxel";
  feedMesh(w.x.mesh, h, *writer);
  return w;
}

// Our reading of isoslab's PLY, OBJ and STL has the same vertices and triangles as Draco's.
TEST(MeshReader, AgreesWithDracoOnIsoslabsFiles) {
  const std::string dir = testing::tempDir();
  for (const std::string format : {"ply", "obj", "stl"}) {
    SCOPED_TRACE(format);
    const Written w = writeSphere(dir, format);
    const IndexedMesh ours = readMesh(w.path);
    ASSERT_EQ(ours.positions.size(), w.x.mesh.positions.size());
    const auto theirs = dracoRead(w.path);
    ASSERT_NE(theirs, nullptr);
    EXPECT_EQ(theirs->num_faces(), ours.triangles.size());
    // Draco keeps PLY's vertices and deduplicates OBJ's corners into points. Its STL points are
    // (position, facet normal) pairs, so only corners of coplanar neighbours share one; ours welds
    // by position alone, and the mapping below checks that against Draco's positions.
    if (format != "stl") {
      EXPECT_EQ(theirs->num_points(), ours.positions.size());
    }
    EXPECT_EQ(canonicalSorted(inOurIds(*theirs, ours, 1e-5)), canonicalSorted(ours.triangles));
  }
}

// Files that Draco's encoders wrote (not isoslab's writers) read as the mesh Draco wrote.
TEST(MeshReader, ReadsWhatDracosEncodersWrite) {
  const std::string dir = testing::tempDir();
  const Written w = writeSphere(dir, "ply");
  const auto source = dracoRead(w.path);
  ASSERT_NE(source, nullptr);
  ASSERT_TRUE(draco::PlyEncoder().EncodeToFile(*source, dir + "/draco.ply"));
  ASSERT_TRUE(draco::ObjEncoder().EncodeToFile(*source, dir + "/draco.obj"));
  ASSERT_TRUE(draco::StlEncoder().EncodeToFile(*source, dir + "/draco.stl").ok());
  for (const std::string name : {"draco.ply", "draco.obj", "draco.stl"}) {
    SCOPED_TRACE(name);
    const IndexedMesh back = readMesh(dir + "/" + name);
    EXPECT_EQ(back.positions.size(), w.x.mesh.positions.size());
    EXPECT_EQ(back.triangles.size(), w.x.mesh.triangles.size());
    EXPECT_EQ(canonicalSorted(inOurIds(*source, back, 1e-5)), canonicalSorted(back.triangles));
  }
}

// An ASCII PLY with the sphere's vertices (odd spacing, a colour and a skipped list among their
// properties), its triangles as faces (a pair of them as one quad), and an element of another name
// between them: ours and Draco's readings agree, and ours equals the mesh written, to the printed
// digits.
TEST(MeshReader, AsciiPlyAgreesWithDraco) {
  const std::string dir = testing::tempDir();
  const testing::Extraction x = testing::extract("phantom:sphere?n=24&r=8", Method::kTetra6, 920, true);
  const IndexedMesh& mesh = x.mesh;
  ASSERT_GT(mesh.triangles.size(), 100u);
  // The first two triangles that share an edge, as one quad (a, b, c, d) fanned back into them.
  std::size_t quad = mesh.triangles.size();
  std::array<VertexId, 4> corners{};
  for (std::size_t k = 0; k < 3 && quad == mesh.triangles.size(); ++k) {
    const Triangle& t = mesh.triangles[0];
    for (std::size_t u = 1; u < mesh.triangles.size() && quad == mesh.triangles.size(); ++u) {
      const Triangle& o = mesh.triangles[u];
      for (std::size_t j = 0; j < 3; ++j) {
        // o has the edge t[k+1] -> t[k], its third corner after it: (t[k], t[k+1], t[k+2]) and
        // (t[k], o's third, t[k+1])... fanned from t[k+1]: (t[k+1], t[k+2], t[k]) and (t[k+1], t[k], y).
        if (o[j] == t[(k + 1) % 3] && o[(j + 1) % 3] == t[k]) {
          corners = {t[(k + 1) % 3], t[(k + 2) % 3], t[k], o[(j + 2) % 3]};
          quad = u;
        }
      }
    }
  }
  ASSERT_NE(quad, mesh.triangles.size());
  const std::string path = dir + "/a.ply";
  {
    std::ofstream out(path, std::ios::binary);
    out << "ply\r\nformat ascii 1.0\ncomment written by a test\nelement vertex " << mesh.positions.size()
        << "\nproperty float x\nproperty float y\nproperty double quality\nproperty uchar red\nproperty list uchar int "
           "junk\n"
        << "property float z\nelement camera 2\nproperty float view\n"
        << "element face " << mesh.triangles.size() - 1 << "\nproperty list uchar uint vertex_indices\n"
        << "end_header\n";
    char line[256];
    for (const Vec3f& p : mesh.positions) {
      std::snprintf(line, sizeof line, "%.9g \t %.9g 0.25 200 2 -1 +7   %.9g\r\n", p.x, p.y, p.z);
      out << line;
    }
    out << "1.5\n-2e3\n";
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      if (t == 0) out << "4 " << corners[0] << " " << corners[1] << " " << corners[2] << " " << corners[3] << "\n";
      if (t == 0 || t == quad) continue;
      out << "3 " << mesh.triangles[t][0] << " " << mesh.triangles[t][1] << " " << mesh.triangles[t][2] << "\n";
    }
  }
  const IndexedMesh ours = readMesh(path);
  ASSERT_EQ(ours.positions.size(), mesh.positions.size());
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    ASSERT_EQ(ours.positions[v].x, mesh.positions[v].x) << v;
    ASSERT_EQ(ours.positions[v].y, mesh.positions[v].y) << v;
    ASSERT_EQ(ours.positions[v].z, mesh.positions[v].z) << v;
  }
  EXPECT_TRUE(ours.normals.empty());
  EXPECT_EQ(canonicalSorted(ours.triangles), canonicalSorted(mesh.triangles));
  const auto theirs = dracoRead(path);
  ASSERT_NE(theirs, nullptr);
  EXPECT_EQ(theirs->num_faces(), ours.triangles.size());
  EXPECT_EQ(canonicalSorted(inOurIds(*theirs, ours, 0)), canonicalSorted(ours.triangles));
}

// A binary PLY whose positions and normals use every scalar type but float (signed values where the
// type has them), with skipped properties and lists between them, 16-bit face lists and a trailing
// element of another name: each value reads back exactly.
TEST(MeshReader, BinaryPlyReadsEveryScalarType) {
  const std::string dir = testing::tempDir();
  std::string body;
  const auto put = [&body](auto v) { body.append(reinterpret_cast<const char*>(&v), sizeof v); };
  const double xs[4] = {-1.25, 2.5, 0.0, 1e-3};
  const std::int16_t ys[4] = {-300, 7, 0, 32767};
  const std::uint16_t zs[4] = {65535, 1, 0, 40000};
  const std::int8_t nx[4] = {-128, 127, 0, -1};
  const std::uint32_t ny[4] = {4000000000u, 1, 0, 12345};
  const std::int32_t nz[4] = {-2000000000, 5, 0, -7};
  for (int v = 0; v < 4; ++v) {
    put(xs[v]);
    put(std::uint8_t{200});  // red, skipped
    put(ys[v]);
    put(std::uint16_t{2}), put(1.5f), put(-2.5f);  // a list of two floats, skipped
    put(zs[v]);
    put(nx[v]), put(ny[v]), put(nz[v]);
  }
  const std::uint16_t faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (const auto& f : faces) {
    put(std::uint16_t{3});
    for (const std::uint16_t i : f) put(i);
  }
  put(std::int32_t{-9});  // the element "edge", skipped
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float64 x\nproperty uchar red\n"
      "property short y\nproperty list uint16 float32 junk\nproperty ushort z\nproperty int8 nx\n"
      "property uint ny\nproperty int32 nz\nelement face 4\nproperty list ushort uint16 vertex_indices\n"
      "element edge 1\nproperty int a\nend_header\n";
  const std::string path = dir + "/b.ply";
  std::ofstream(path, std::ios::binary) << header << body;
  const IndexedMesh mesh = readMesh(path);
  ASSERT_EQ(mesh.positions.size(), 4u);
  ASSERT_EQ(mesh.normals.size(), 4u);
  for (std::size_t v = 0; v < 4; ++v) {
    SCOPED_TRACE(v);
    EXPECT_EQ(mesh.positions[v].x, static_cast<float>(xs[v]));
    EXPECT_EQ(mesh.positions[v].y, static_cast<float>(ys[v]));
    EXPECT_EQ(mesh.positions[v].z, static_cast<float>(zs[v]));
    EXPECT_EQ(mesh.normals[v].x, static_cast<float>(nx[v]));
    EXPECT_EQ(mesh.normals[v].y, static_cast<float>(ny[v]));
    EXPECT_EQ(mesh.normals[v].z, static_cast<float>(nz[v]));
  }
  ASSERT_EQ(mesh.triangles.size(), 4u);
  for (std::size_t t = 0; t < 4; ++t) {
    EXPECT_EQ(mesh.triangles[t], (Triangle{faces[t][0], faces[t][1], faces[t][2]})) << t;
  }
}

// tinyobjloader keeps the file's vertex order, so the comparison is index by index.
TEST(MeshReader, AgreesWithTinyobjloaderOnIsoslabsObj) {
  const std::string dir = testing::tempDir();
  const Written w = writeSphere(dir, "obj");
  const IndexedMesh ours = readMesh(w.path);
  tinyobj::ObjReader reader;
  ASSERT_TRUE(reader.ParseFromFile(w.path)) << reader.Error();
  EXPECT_EQ(reader.Warning(), "");
  const tinyobj::attrib_t& a = reader.GetAttrib();
  ASSERT_EQ(a.vertices.size(), 3 * ours.positions.size());
  ASSERT_EQ(a.normals.size(), 3 * ours.normals.size());
  ASSERT_FALSE(ours.normals.empty());
  for (std::size_t v = 0; v < ours.positions.size(); ++v) {
    const Vec3f& p = ours.positions[v];
    const Vec3f& n = ours.normals[v];
    ASSERT_NEAR(a.vertices[3 * v], p.x, 1e-5 * std::abs(p.x)) << v;
    ASSERT_NEAR(a.vertices[3 * v + 1], p.y, 1e-5 * std::abs(p.y)) << v;
    ASSERT_NEAR(a.vertices[3 * v + 2], p.z, 1e-5 * std::abs(p.z)) << v;
    ASSERT_NEAR(a.normals[3 * v], n.x, 1e-6) << v;
    ASSERT_NEAR(a.normals[3 * v + 1], n.y, 1e-6) << v;
    ASSERT_NEAR(a.normals[3 * v + 2], n.z, 1e-6) << v;
  }
  std::vector<Triangle> theirs;
  for (const tinyobj::shape_t& s : reader.GetShapes()) {
    for (std::size_t f = 0; f < s.mesh.num_face_vertices.size(); ++f) {
      ASSERT_EQ(s.mesh.num_face_vertices[f], 3);
      Triangle t{};
      for (std::size_t c = 0; c < 3; ++c) t[c] = static_cast<VertexId>(s.mesh.indices[3 * f + c].vertex_index);
      theirs.push_back(t);
    }
  }
  EXPECT_EQ(theirs, ours.triangles);
}

// A binary STL is told from ASCII by its size (84 + 50 n bytes), even when its header begins with
// "solid", as some exporters write it.
TEST(MeshReader, BinaryStlWhoseHeaderSaysSolid) {
  const std::string dir = testing::tempDir();
  std::string bytes = "solid exported by a CAD tool";
  bytes.resize(80, ' ');
  const std::uint32_t count = 2;
  bytes.append(reinterpret_cast<const char*>(&count), 4);
  const float tris[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 0}};
  for (const auto& t : tris) {
    bytes.append(reinterpret_cast<const char*>(t), sizeof t);
    bytes.append(2, '\0');
  }
  std::ofstream(dir + "/m.stl", std::ios::binary) << bytes;
  const IndexedMesh mesh = readMesh(dir + "/m.stl");
  EXPECT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.positions.size(), 4u);
}

// OBJ indices count from 1, or back from the latest vertex when negative.
TEST(MeshReader, ObjNegativeIndicesAreRelative) {
  const std::string dir = testing::tempDir();
  std::ofstream(dir + "/m.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 0\nf 2/1 -1//1 3\n";
  const IndexedMesh mesh = readMesh(dir + "/m.obj");
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.triangles[0], (Triangle{0, 1, 2}));
  EXPECT_EQ(mesh.triangles[1], (Triangle{1, 3, 2}));
}

// An OBJ that isoslab wrote for an empty surface (only its metadata comments) is an empty mesh.
TEST(MeshReader, EmptyObjFromIsoslabReads) {
  const std::string dir = testing::tempDir();
  {
    auto writer = makeMeshWriter(dir + "/e.obj", WriterOptions{});
    MeshHeader h;
    h.method = "mc";
    h.iso = 5;
    h.space = "voxel";
    writer->begin(h);
    writer->finish();
  }
  const IndexedMesh mesh = readMesh(dir + "/e.obj");
  EXPECT_TRUE(mesh.triangles.empty());
}

// Bytes in memory read as the same file would; the path's extension tells OBJ from STL.
TEST(MeshReader, DataInMemoryReadsAsTheFile) {
  const std::string dir = testing::tempDir();
  const Written w = writeSphere(dir, "obj");
  MeshMetadata fromFile;
  MeshMetadata fromData;
  EXPECT_EQ(readMeshData("memory.obj", testing::slurp(w.path), &fromData), readMesh(w.path, &fromFile));
  EXPECT_EQ(fromData.method, "mt6");
  EXPECT_EQ(fromFile.method, "mt6");
}

}  // namespace
}  // namespace isoslab
