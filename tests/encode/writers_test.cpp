#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/statfs.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_reader.h"
#include "encode/mesh_writer.h"
#include "encode/obj_writer.h"
#include "encode/ply_writer.h"
#include "encode/stl_writer.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::slurp;

// Streams `mesh` in two chunks (triangles of chunk 1 use vertices of chunk 0), as extraction does.
void stream(const IndexedMesh& mesh, MeshSink& sink, bool normals) {
  MeshHeader h;
  h.normals = normals;
  h.method = "mc";
  h.iso = 50;
  h.space = "voxel";
  sink.begin(h);
  const std::size_t half = mesh.positions.size() / 2;
  MeshChunk a;
  a.positions.assign(mesh.positions.begin(), mesh.positions.begin() + static_cast<std::ptrdiff_t>(half));
  if (normals) a.normals.assign(mesh.normals.begin(), mesh.normals.begin() + static_cast<std::ptrdiff_t>(half));
  MeshChunk b;
  b.slab = 1;
  b.firstVertex = static_cast<VertexId>(half);
  b.positions.assign(mesh.positions.begin() + static_cast<std::ptrdiff_t>(half), mesh.positions.end());
  if (normals) b.normals.assign(mesh.normals.begin() + static_cast<std::ptrdiff_t>(half), mesh.normals.end());
  // Triangles stay in order: chunk a takes them while they use only its vertices.
  bool inA = true;
  for (const Triangle& t : mesh.triangles) {
    inA = inA && std::max({t[0], t[1], t[2]}) < half;
    (inA ? a : b).triangles.push_back(t);
  }
  sink.consume(a);
  sink.consume(b);
  sink.finish();
}

TEST(PlyWriter, RoundTripsPositionsNormalsAndFaces) {
  const testing::Extraction x = testing::extract("phantom:sphere?n=24&r=8", Method::kTetra6, 920, true);
  const std::string dir = testing::tempDir();
  PlyWriter w(dir + "/s.ply");
  stream(x.mesh, w, true);
  EXPECT_EQ(w.bytes(), static_cast<std::int64_t>(fs::file_size(dir + "/s.ply")));
  const IndexedMesh back = readMesh(dir + "/s.ply");
  EXPECT_EQ(back.positions, x.mesh.positions);
  EXPECT_EQ(back.normals, x.mesh.normals);
  EXPECT_EQ(back.triangles, x.mesh.triangles);
  EXPECT_EQ(testing::fileCount(dir), 1);  // no spool or temporary file left
}

// An outside reader of the normals: VTK 9.1's vtkPLYReader (tests/encode/vtk_ply_normals.py) must
// read a normal for every vertex, each the phantom surface's own (a sphere in voxels, an ellipsoid
// once scaled by an uneven spacing) within a degree.
TEST(PlyWriter, VtkReadsTheNormalsAsTheSurfaces) {
  if (std::system("/usr/bin/python3 -c 'import vtkmodules.vtkIOPLY' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "Debian's python3-vtk9 is absent";
  const std::string dir = testing::tempDir();
  for (const char* spacing : {"1,1,1", "0.8,1,1.5"}) {
    const auto x =
        testing::runCli(std::string("extract 'phantom:sphere?n=48&r=15&c=24,24,24&field=distance&spacing=") + spacing +
                        "' --iso 850 --normals -q -o " + dir + "/s.ply --report " + dir + "/r.json");
    ASSERT_EQ(x.exitCode, 0) << x.err;
    const std::string report = testing::slurp(dir + "/r.json");
    const std::size_t at = report.find("\"vertices\": ");
    ASSERT_NE(at, std::string::npos);
    const long long vertices = std::stoll(report.substr(at + 12));
    double s[3];
    ASSERT_EQ(std::sscanf(spacing, "%lf,%lf,%lf", &s[0], &s[1], &s[2]), 3);
    char args[200];
    std::snprintf(args, sizeof args, " %lld %g %g %g %s %s %s", vertices, 24 * s[0], 24 * s[1], 24 * s[2],
                  std::to_string(s[0]).c_str(), std::to_string(s[1]).c_str(), std::to_string(s[2]).c_str());
    const std::string cmd = "/usr/bin/python3 " ISOSLAB_TESTS_DIR "/encode/vtk_ply_normals.py " + dir + "/s.ply" +
                            args + " > " + dir + "/vtk.txt 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << spacing << ": " << testing::slurp(dir + "/vtk.txt");
    std::printf("[vtk ply] spacing %s: %s", spacing, testing::slurp(dir + "/vtk.txt").c_str());
  }
}

TEST(PlyWriter, HeaderIsStandardAndPaddedToItsReservedSize) {
  IndexedMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  const std::string dir = testing::tempDir();
  PlyWriter w(dir + "/t.ply");
  stream(m, w, false);
  const std::string bytes = slurp(dir + "/t.ply");
  const std::string tail =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar uint vertex_indices\nend_header\n";
  const std::size_t end = bytes.find("end_header\n") + 11;
  EXPECT_EQ(bytes.substr(0, 58), "ply\nformat binary_little_endian 1.0\ncomment isoslab mc iso");
  EXPECT_EQ(bytes.substr(end - tail.size(), tail.size()), tail);
  EXPECT_EQ(bytes.size(), end + 3 * 12 + 13);
  EXPECT_EQ(bytes[end + 36], 3);  // the face's vertex count
}

TEST(StlWriter, RoundTripsTheWeldedMesh) {
  const testing::Extraction x = testing::extract("phantom:torus?n=40,40,20&R=11&r=4", Method::kMarchingCubes, 960);
  const std::string dir = testing::tempDir();
  StlWriter w(dir + "/t.stl");
  stream(x.mesh, w, false);
  const std::string bytes = slurp(dir + "/t.stl");
  EXPECT_EQ(bytes.size(), 84 + 50 * x.mesh.triangles.size());
  EXPECT_NE(bytes.substr(0, 5), "solid");
  const IndexedMesh back = readMesh(dir + "/t.stl");
  EXPECT_EQ(back.triangles.size(), x.mesh.triangles.size());
  EXPECT_EQ(back.positions.size(), x.mesh.positions.size());
}

TEST(ObjWriter, RoundTripsExactly) {
  const testing::Extraction x = testing::extract("phantom:sphere?n=32&r=10", Method::kMarchingCubes, 900, true);
  const std::string dir = testing::tempDir();
  ObjWriter w(dir + "/s.obj");
  stream(x.mesh, w, true);
  const IndexedMesh back = readMesh(dir + "/s.obj");
  EXPECT_EQ(back.positions, x.mesh.positions);
  EXPECT_EQ(back.normals, x.mesh.normals);
  EXPECT_EQ(back.triangles, x.mesh.triangles);
}

TEST(Writers, AnAbandonedWriterLeavesNothing) {
  const std::string dir = testing::tempDir();
  for (const char* name : {"a.ply", "a.stl"}) {
    auto w = makeMeshWriter(dir + "/" + name);
    w->begin(MeshHeader{});
    MeshChunk c;
    c.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    c.triangles = {{0, 1, 2}};
    w->consume(c);
  }
  EXPECT_EQ(testing::fileCount(dir), 0);
}

TEST(Writers, ErrorsNameTheOutput) {
  const std::string dir = testing::tempDir();
  try {
    makeMeshWriter(dir + "/mesh.xyz");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              dir + "/mesh.xyz: unknown mesh format '.xyz' (use .ply, .stl, .obj, .glb, .drc or .3mf)");
  }
  try {
    auto w = makeMeshWriter(dir + "/nope/mesh.ply");
    w->begin(MeshHeader{});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              dir + "/nope/mesh.ply: cannot create the output: the folder '" + dir + "/nope' does not exist");
  }
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

TEST(Writers, OutputsGetTheUsualPermissions) {
  const std::string dir = testing::tempDir();
  auto w = makeMeshWriter(dir + "/p.ply");
  w->begin(MeshHeader{});
  w->finish();
  const mode_t mask = ::umask(0);
  ::umask(mask);
  const auto perms = fs::status(dir + "/p.ply").permissions();
  EXPECT_EQ(static_cast<unsigned>(perms) & 0777u, 0666u & ~static_cast<unsigned>(mask));
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// lib3mf (with libzip, libcrypto and libbz2) comes from a module loaded only for a 3MF output
// (core/modules.h): the dynamic loader's log of a PLY run names none of them.
TEST(ThreeMfModule, IsLoadedOnlyForA3mf) {
  const std::string dir = testing::tempDir();
  ::setenv("LD_DEBUG", "files", 1);
  const auto ply = testing::runCli("extract 'phantom:sphere?n=16' -o " + dir + "/p.ply -q");
  const auto threeMf = testing::runCli("extract 'phantom:sphere?n=16' -o " + dir + "/p.3mf -q");
  ::unsetenv("LD_DEBUG");
  ASSERT_EQ(ply.exitCode, 0) << ply.err;
  ASSERT_EQ(threeMf.exitCode, 0) << threeMf.err;
  EXPECT_NE(ply.err.find("file=libdraco"), std::string::npos) << "no loader log";
  for (const char* library : {"libisoslab_3mf.so", "lib3MF", "libzip", "libcrypto"}) {
    EXPECT_EQ(ply.err.find(library), std::string::npos) << library;
  }
  EXPECT_NE(threeMf.err.find("libisoslab_3mf.so"), std::string::npos);
  EXPECT_NE(threeMf.err.find("lib3MF"), std::string::npos);
}

// A program whose 3MF module is missing says so in one line and leaves no output; its other
// formats still work.
TEST(ThreeMfModule, AMissingModuleIsOneLine) {
  const std::string dir = testing::tempDir();
  fs::copy_file(ISOSLAB_CLI_PATH, dir + "/isoslab");
  const auto run = [&](const std::string& output) {
    const std::string cmd = "env -u ISOSLAB_3MF_MODULE " + dir + "/isoslab extract 'phantom:sphere?n=16' -o " + dir +
                            "/" + output + " -q >" + dir + "/out 2>" + dir + "/err </dev/null";
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  EXPECT_NE(run("p.3mf"), 0);
  EXPECT_EQ(slurp(dir + "/err"),
            "isoslab: error: 3MF files need the 3MF module libisoslab_3mf.so, which was not found\n");
  EXPECT_EQ(slurp(dir + "/out"), "");
  EXPECT_FALSE(fs::exists(dir + "/p.3mf"));
  EXPECT_EQ(run("p.stl"), 0) << slurp(dir + "/err");
  EXPECT_TRUE(fs::exists(dir + "/p.stl"));
  // A module that the variable names is the one loaded, or the line says why it cannot be.
  std::ofstream(dir + "/bogus.so") << std::string(200, 'x');
  const auto named = [&](const std::string& module) {
    const std::string cmd = "ISOSLAB_3MF_MODULE=" + module + " " + ISOSLAB_CLI_PATH +
                            " extract 'phantom:sphere?n=16' -o " + dir + "/q.3mf -q 2>" + dir + "/err </dev/null";
    return std::system(cmd.c_str());
  };
  EXPECT_NE(named(dir + "/bogus.so"), 0);
  EXPECT_EQ(slurp(dir + "/err"),
            "isoslab: error: 3MF files need the 3MF module libisoslab_3mf.so, but "
            "$ISOSLAB_3MF_MODULE names one that cannot be loaded: " +
                dir + "/bogus.so: invalid ELF header\n");
  const std::string other = fs::path(ISOSLAB_CLI_PATH).parent_path().parent_path().string() + "/io/libisoslab_dicom.so";
  EXPECT_NE(named(other), 0);
  EXPECT_EQ(slurp(dir + "/err"), "isoslab: error: 3MF files need the 3MF module libisoslab_3mf.so, but " + other +
                                     " lacks its entry isoslab_3mf_module\n");
  EXPECT_FALSE(fs::exists(dir + "/q.3mf"));
}

}  // namespace
}  // namespace isoslab

namespace isoslab {
namespace {

// AtomicFile::insertFront moves what was written up and leaves the front to be written: by moving
// extents (a multiple of 4096 on ext4 or XFS) or by copying, from the end, in 1 MiB steps (here 3.5
// MiB, so that steps overlap what they move).
TEST(AtomicFile, InsertFrontMovesWhatWasWrittenUp) {
  const std::string dir = testing::tempDir();
  std::string body(std::size_t{7} << 19, '\0');
  for (std::size_t i = 0; i < body.size(); ++i) body[i] = static_cast<char>('a' + (i * 7 + i / 4099) % 26);
  for (const std::int64_t front : {std::int64_t{5000}, std::int64_t{8192}, std::int64_t{3} << 20}) {
    const std::string path = dir + "/f" + std::to_string(front);
    AtomicFile file(path);
    file.write(body.data(), body.size());
    file.insertFront(front);
    EXPECT_EQ(file.size(), static_cast<std::int64_t>(body.size()) + front);
    const std::string head(static_cast<std::size_t>(front), '#');
    file.write(head.data(), head.size());
    file.commit();
    EXPECT_TRUE(slurp(path) == head + body) << front;
  }
  // Nothing written yet: the front is all there is.
  AtomicFile empty(dir + "/empty");
  EXPECT_FALSE(empty.insertFront(4096));
  empty.write(std::string(4096, 'x').data(), 4096);
  empty.commit();
  EXPECT_EQ(slurp(dir + "/empty"), std::string(4096, 'x'));
}

// Forty outputs open at once, written in turn in pieces of many sizes: more than the process's
// budget of large stdio buffers (the rest get the default one); four of them past the 4 MiB at which
// a background flush starts (at most two run at once), one moved to another owner mid-way and one
// abandoned. Every committed file holds exactly what was written to it, and no temporary is left.
TEST(AtomicFile, ManyAtOnceEachGetsItsOwnBytes) {
  const std::string dir = testing::tempDir() + "/many";
  fs::create_directories(dir);
  constexpr int kFiles = 40;
  std::vector<std::unique_ptr<AtomicFile>> files;
  std::vector<std::string> expected(kFiles);
  for (int f = 0; f < kFiles; ++f) files.push_back(std::make_unique<AtomicFile>(dir + "/" + std::to_string(f)));
  std::string piece;
  for (int round = 0; round < 40; ++round) {
    for (int f = 0; f < kFiles; ++f) {
      // Files 0 to 3: 1 byte to 300 KiB a piece, so that some pieces pass the buffer and some fill
      // it; the rest up to 5 KiB.
      const int most = f < 4 ? 300 << 10 : 5 << 10;
      const auto n = static_cast<std::size_t>(1 + (round * 7919 + f * 104729) % most);
      piece.assign(n, static_cast<char>('A' + (round + f) % 26));
      piece[0] = static_cast<char>('0' + f % 10);
      files[static_cast<std::size_t>(f)]->write(piece.data(), piece.size());
      expected[static_cast<std::size_t>(f)] += piece;
    }
    // File 2 passed 4 MiB at round 22: its flush's state moves with it.
    if (round == 30) files[2] = std::make_unique<AtomicFile>(std::move(*files[2]));
  }
  for (int f = 0; f < kFiles; ++f) {
    if (f != 7) files[static_cast<std::size_t>(f)]->commit();  // 7 is abandoned
  }
  files.clear();
  for (int f = 0; f < kFiles; ++f) {
    const std::string path = dir + "/" + std::to_string(f);
    if (f == 7) {
      EXPECT_FALSE(fs::exists(path));
      continue;
    }
    if (f < 4) {
      EXPECT_GT(expected[static_cast<std::size_t>(f)].size(), std::size_t{4} << 20);
    }
    EXPECT_TRUE(slurp(path) == expected[static_cast<std::size_t>(f)]) << path;
  }
  std::size_t left = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++left;
  EXPECT_EQ(left, std::size_t{kFiles - 1});
}

// A PLY is the same bytes on a disk that moves the faces' extents (ext4 here) and on one that
// copies them (tmpfs): the header pads the header and the vertices to whole 4 KiB blocks either way,
// with comment lines (of spaces) of at most 80 bytes.
TEST(PlyWriter, TheSameBytesWhetherTheFacesMoveOrAreCopied) {
  struct statfs shm {};
  if (::statfs("/dev/shm", &shm) != 0 || shm.f_type != 0x01021994) GTEST_SKIP() << "no tmpfs at /dev/shm";
  const std::string disk = testing::tempDir();
  const std::string memory = "/dev/shm/isoslab-ply-" + std::to_string(::getpid());
  fs::create_directories(memory);
  for (const char* options : {"", " --labels all"}) {
    const std::string input = *options != 0 ? "'phantom:nested?n=40'" : "'phantom:sphere?n=40&r=15'";
    const auto a = testing::runCli("extract " + input + options + " -q -o " + disk + "/m.ply");
    const auto b = testing::runCli("extract " + input + options + " -q -o " + memory + "/m.ply");
    ASSERT_EQ(a.exitCode, 0) << a.err;
    ASSERT_EQ(b.exitCode, 0) << b.err;
    const std::string bytes = slurp(disk + "/m.ply");
    EXPECT_TRUE(bytes == slurp(memory + "/m.ply")) << options;
    const std::size_t end = bytes.find("end_header\n") + 11;
    std::istringstream header(bytes.substr(0, end));
    std::size_t vertices = 0;
    bool normals = false;
    for (std::string line; std::getline(header, line);) {
      if (line.find_first_not_of(' ', 7) == std::string::npos) {  // a pad
        EXPECT_LE(line.size() + 1, 80u) << line;
      }
      std::sscanf(line.c_str(), "element vertex %zu", &vertices);
      normals = normals || line == "property float nx";
    }
    ASSERT_GT(vertices, 0u);
    EXPECT_EQ((end + vertices * (normals ? 24 : 12)) % 4096, 0u) << options;
  }
  fs::remove_all(memory);
}

}  // namespace
}  // namespace isoslab
