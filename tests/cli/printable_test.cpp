// Printable outputs (.stl, .3mf): no zero-area triangles, closed and manifold when welded by
// position, as slicers weld them. Checked by brute force on the files, by lib3mf's own reader, and
// by PrusaSlicer's command line (Debian prusa-slicer), which reports the repairs it had to make.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "Model/COM/NMR_DLLInterfaces.h"
#include "test_support.h"

namespace isoslab {
namespace {

namespace fs = std::filesystem;

struct Mesh {
  std::string name;
  std::optional<std::array<int, 3>> color;
  std::vector<std::array<float, 3>> positions;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

// Binary STL, welded by exact position (as admesh, PrusaSlicer's mesh library, welds it).
Mesh readStl(const std::string& path) {
  const std::string bytes = testing::slurp(path);
  Mesh m;
  if (bytes.size() < 84) return m;
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  std::map<std::array<float, 3>, std::uint32_t> ids;
  for (std::uint32_t t = 0; t < n && 84 + 50 * (t + 1) <= bytes.size(); ++t) {
    std::array<std::uint32_t, 3> tri{};
    for (std::size_t k = 0; k < 3; ++k) {
      std::array<float, 3> p{};
      std::memcpy(p.data(), bytes.data() + 84 + 50 * t + 12 + 12 * k, 12);
      const auto [it, fresh] = ids.emplace(p, static_cast<std::uint32_t>(m.positions.size()));
      if (fresh) m.positions.push_back(p);
      tri[k] = it->second;
    }
    m.triangles.push_back(tri);
  }
  return m;
}

// Every mesh object of a .3mf, through lib3mf's reader.
std::vector<Mesh> read3mf(const std::string& path) {
  using namespace NMR;
  std::vector<Mesh> out;
  PLib3MFModel* model = nullptr;
  PLib3MFModelReader* reader = nullptr;
  EXPECT_EQ(lib3mf_createmodel(&model), LIB3MF_OK);
  EXPECT_EQ(lib3mf_model_queryreader(model, "3mf", &reader), LIB3MF_OK);
  EXPECT_EQ(lib3mf_reader_readfromfileutf8(reader, path.c_str()), LIB3MF_OK) << path;
  DWORD unit = 99;
  EXPECT_EQ(lib3mf_model_getunit(model, &unit), LIB3MF_OK);
  EXPECT_EQ(unit, static_cast<DWORD>(MODELUNIT_MILLIMETER));
  PLib3MFModelResourceIterator* objects = nullptr;
  EXPECT_EQ(lib3mf_model_getmeshobjects(model, &objects), LIB3MF_OK);
  BOOL more = false;
  while (lib3mf_resourceiterator_movenext(objects, &more) == LIB3MF_OK && more) {
    PLib3MFModelResource* object = nullptr;
    EXPECT_EQ(lib3mf_resourceiterator_getcurrent(objects, &object), LIB3MF_OK);
    Mesh m;
    char name[2048] = {};
    ULONG needed = 0;
    EXPECT_EQ(lib3mf_object_getnameutf8(object, name, sizeof name, &needed), LIB3MF_OK);
    m.name = name;
    DWORD vertices = 0;
    DWORD triangles = 0;
    lib3mf_meshobject_getvertexcount(object, &vertices);
    lib3mf_meshobject_gettrianglecount(object, &triangles);
    std::vector<MODELMESHVERTEX> v(vertices);
    std::vector<MODELMESHTRIANGLE> t(triangles);
    if (vertices > 0) lib3mf_meshobject_getvertices(object, v.data(), vertices, nullptr);
    if (triangles > 0) lib3mf_meshobject_gettriangleindices(object, t.data(), triangles, nullptr);
    for (const auto& p : v) m.positions.push_back({p.m_fPosition[0], p.m_fPosition[1], p.m_fPosition[2]});
    for (const auto& f : t) m.triangles.push_back({f.m_nIndices[0], f.m_nIndices[1], f.m_nIndices[2]});
    BOOL manifold = false;
    EXPECT_EQ(lib3mf_meshobject_ismanifoldandoriented(object, &manifold), LIB3MF_OK);
    EXPECT_TRUE(manifold) << m.name;
    PLib3MFDefaultPropertyHandler* handler = nullptr;
    if (lib3mf_object_createdefaultpropertyhandler(object, &handler) == LIB3MF_OK) {
      DWORD group = 0;
      DWORD index = 0;
      if (lib3mf_defaultpropertyhandler_getbasematerial(handler, &group, &index) == LIB3MF_OK) {
        PLib3MFModelBaseMaterial* materials = nullptr;
        if (lib3mf_model_getbasematerialbyid(model, group, &materials) == LIB3MF_OK) {
          BYTE r = 0, g = 0, b = 0, a = 0;
          if (lib3mf_basematerial_getdisplaycolor(materials, index, &r, &g, &b, &a) == LIB3MF_OK) {
            m.color = std::array<int, 3>{r, g, b};
          }
          lib3mf_release(materials);
        }
      }
      lib3mf_release(handler);
    }
    lib3mf_release(object);
    out.push_back(std::move(m));
  }
  lib3mf_release(objects);
  lib3mf_release(reader);
  lib3mf_release(model);
  return out;
}

// What a printer needs of a mesh, counted by brute force: no triangle with two corners at one
// position, and every edge used once in each direction.
struct Printable {
  std::size_t coincident = 0;
  std::size_t badEdges = 0;
};

Printable printable(const Mesh& m) {
  Printable p;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : m.triangles) {
    const auto& a = m.positions[t[0]];
    const auto& b = m.positions[t[1]];
    const auto& c = m.positions[t[2]];
    if (a == b || b == c || a == c) ++p.coincident;
    for (std::size_t k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  }
  for (const auto& [e, n] : directed) {
    const auto back = directed.find({e.second, e.first});
    if (n != 1 || back == directed.end() || back->second != 1) ++p.badEdges;
  }
  return p;
}

// The repairs PrusaSlicer 2.5's --info lists (only when it made them).
const char* const kRepairs[] = {"degenerate_facets", "edges_fixed",     "facets_removed",
                                "facets_added",      "facets_reversed", "backwards_edges"};

std::string prusaSlicer() {
  for (const char* p : {"/usr/bin/prusa-slicer", "/usr/local/bin/prusa-slicer"}) {
    if (fs::exists(p)) return p;
  }
  return {};
}

// PrusaSlicer's --info for a file: its lines, without the log's.
std::string prusaInfo(const std::string& slicer, const std::string& path, const std::string& dir) {
  const std::string out = dir + "/info.txt";
  const std::string cmd = slicer + " --info '" + path + "' >'" + out + "' 2>/dev/null";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return testing::slurp(out);
}

std::size_t countOf(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

void expectNoRepairs(const std::string& info, std::size_t objects) {
  EXPECT_EQ(countOf(info, "manifold = yes"), objects) << info.substr(0, 2000);
  for (const char* repair : kRepairs) EXPECT_EQ(countOf(info, repair), 0u) << repair << "\n" << info.substr(0, 2000);
}

// An integer field whose samples meet the iso value exactly: twice the distance to a point, rounded.
std::string writeIntegerBall(const std::string& dir) {
  std::vector<std::uint8_t> v;
  for (int z = 0; z < 19; ++z) {
    for (int y = 0; y < 21; ++y) {
      for (int x = 0; x < 22; ++x) {
        const double dx = x - 9.3, dy = y - 10.1, dz = z - 8.7;
        v.push_back(static_cast<std::uint8_t>(std::lround(2.0 * std::sqrt(dx * dx + dy * dy + 1.4 * dz * dz))));
      }
    }
  }
  const std::string path = dir + "/ball.raw";
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size()));
  return path;
}

TEST(Printable, StlAnd3mfDropTheZeroAreaTrianglesOfSamplesAtTheIsoValue) {
  const std::string dir = testing::tempDir();
  const std::string ball = writeIntegerBall(dir);
  const std::string common = " --raw-dims 22,21,19 --raw-type uint8 --iso 14 --close-boundary -q";
  for (const char* method : {"mc", "mt6"}) {
    SCOPED_TRACE(method);
    const std::string m = std::string(" --method ") + method;
    ASSERT_EQ(
        testing::runCli("extract " + ball + common + m + " -o " + dir + "/a.stl --report " + dir + "/a.json").exitCode,
        0);
    ASSERT_EQ(testing::runCli("extract " + ball + common + m + " -o " + dir + "/a.3mf").exitCode, 0);
    ASSERT_EQ(testing::runCli("extract " + ball + common + m + " --keep-degenerate -o " + dir + "/k.stl").exitCode, 0);
    const auto report = nlohmann::json::parse(testing::slurp(dir + "/a.json"));
    const auto extracted = report["triangles"].get<std::size_t>();
    const auto degenerate = report["degenerate_triangles"].get<std::size_t>();
    ASSERT_GT(degenerate, 10u);  // counted by the measures, not by the collapse
    EXPECT_EQ(report["output"]["degenerate_triangles_removed"].get<double>(), double(degenerate));
    EXPECT_EQ(report["output"]["coincident_clusters_separated"].get<double>(), 0.0);

    const Mesh kept = readStl(dir + "/k.stl");
    EXPECT_EQ(kept.triangles.size(), extracted);
    EXPECT_EQ(printable(kept).coincident, degenerate);

    const Mesh stl = readStl(dir + "/a.stl");
    EXPECT_EQ(stl.triangles.size(), extracted - degenerate);
    EXPECT_EQ(printable(stl).coincident, 0u);
    EXPECT_EQ(printable(stl).badEdges, 0u);

    const std::vector<Mesh> objects = read3mf(dir + "/a.3mf");
    ASSERT_EQ(objects.size(), 1u);
    EXPECT_EQ(objects[0].triangles.size(), stl.triangles.size());
    EXPECT_EQ(objects[0].positions.size(), stl.positions.size());  // merged by id as the STL is by position
    EXPECT_EQ(printable(objects[0]).coincident, 0u);
    EXPECT_EQ(printable(objects[0]).badEdges, 0u);
    EXPECT_FALSE(objects[0].color.has_value());
  }
  fs::remove_all(dir);
}

// Found by a hostile test: two points split into two fans each, sharing a triangle; each corner of
// that triangle must go to its own fan's vertex (the 3MF had four open edges).
TEST(Printable, SplitPointsThatShareATriangleStayClosedIn3mf) {
  const std::string dir = testing::tempDir();
  const unsigned char bytes[] = {3, 3, 1, 2, 1, 3, 1, 1, 1, 1, 1, 2, 1, 1, 1, 1, 1, 3};
  std::ofstream(dir + "/r.raw", std::ios::binary).write(reinterpret_cast<const char*>(bytes), sizeof bytes);
  ASSERT_EQ(
      testing::runCli("extract " + dir + "/r.raw --raw-dims 2,3,3 --raw-type uint8 --iso 2 --close-boundary -q -o " +
                      dir + "/r.3mf --report " + dir + "/r.json")
          .exitCode,
      0);
  const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
  EXPECT_EQ(report["output"]["coincident_points_split"].get<double>(), 2.0);
  const std::vector<Mesh> objects = read3mf(dir + "/r.3mf");
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(printable(objects[0]).coincident, 0u);
  EXPECT_EQ(printable(objects[0]).badEdges, 0u);
  fs::remove_all(dir);
}

TEST(Printable, ThePhilipsSkullNeedsNoRepairInPrusaSlicer) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string slicer = prusaSlicer();
  if (slicer.empty()) GTEST_SKIP() << "prusa-slicer is absent (scripts/setup.sh installs it)";
  const std::string dir = testing::tempDir();
  const std::string run = "extract " + philips + " --iso 350 --close-boundary --keep-largest 1 -q";
  ASSERT_EQ(testing::runCli(run + " -o " + dir + "/skull.stl --report " + dir + "/r.json").exitCode, 0);
  ASSERT_EQ(testing::runCli(run + " -o " + dir + "/skull.3mf").exitCode, 0);
  const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
  const auto degenerate = report["degenerate_triangles"].get<std::size_t>();
  EXPECT_EQ(degenerate, 3694u);  // what PrusaSlicer removed from the skull before the collapse
  EXPECT_EQ(report["output"]["degenerate_triangles_removed"].get<double>(), 3694.0);
  EXPECT_GE(report["output"]["coincident_points_split"].get<double>(), 1.0);  // two sheets touch at a sample

  const Mesh stl = readStl(dir + "/skull.stl");
  EXPECT_EQ(stl.triangles.size(), report["triangles"].get<std::size_t>() - degenerate);
  EXPECT_EQ(printable(stl).coincident, 0u);
  EXPECT_EQ(printable(stl).badEdges, 0u);
  const std::vector<Mesh> objects = read3mf(dir + "/skull.3mf");
  ASSERT_EQ(objects.size(), 1u);
  EXPECT_EQ(objects[0].triangles.size(), stl.triangles.size());
  // By id the split point is two vertices, by position one.
  EXPECT_EQ(objects[0].positions.size(), stl.positions.size() + 1);
  EXPECT_EQ(printable(objects[0]).badEdges, 0u);

  expectNoRepairs(prusaInfo(slicer, dir + "/skull.stl", dir), 1);
  expectNoRepairs(prusaInfo(slicer, dir + "/skull.3mf", dir), 1);
  fs::remove_all(dir);
}

TEST(Printable, TheAtlasThreeMfHasANamedColouredManifoldObjectPerLabel) {
  const std::string aal = "/usr/share/mricron/templates/aal.nii.gz";
  if (!fs::exists(aal)) GTEST_SKIP() << aal << " is absent (Debian mricron-data)";
  const std::string slicer = prusaSlicer();
  if (slicer.empty()) GTEST_SKIP() << "prusa-slicer is absent (scripts/setup.sh installs it)";
  const std::string dir = testing::tempDir();
  const std::string names = "/usr/share/mricron/templates/aal.nii.txt";
  ASSERT_EQ(testing::runCli("extract " + aal + " --label-table " + names + " -q -o " + dir + "/aal.3mf --report " +
                            dir + "/r.json")
                .exitCode,
            0);
  const auto report = nlohmann::json::parse(testing::slurp(dir + "/r.json"));
  const std::vector<Mesh> objects = read3mf(dir + "/aal.3mf");
  ASSERT_EQ(objects.size(), 116u);
  ASSERT_EQ(report["labels"].size(), 116u);
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const auto& label = report["labels"][k];
    SCOPED_TRACE(label["name"].get<std::string>());
    EXPECT_EQ(objects[k].name, label["name"].get<std::string>());
    ASSERT_TRUE(objects[k].color.has_value());
    EXPECT_EQ((*objects[k].color)[0], label["color"][0].get<int>());
    EXPECT_EQ((*objects[k].color)[1], label["color"][1].get<int>());
    EXPECT_EQ((*objects[k].color)[2], label["color"][2].get<int>());
    EXPECT_EQ(objects[k].triangles.size(), label["triangles"].get<std::size_t>());
    EXPECT_EQ(printable(objects[k]).coincident, 0u);
    EXPECT_EQ(printable(objects[k]).badEdges, 0u);
  }
  EXPECT_EQ(objects.front().name, "Precentral_L");  // aal.nii.txt's first name
  expectNoRepairs(prusaInfo(slicer, dir + "/aal.3mf", dir), 116);
  // Smoothed, the atlas is still printable as it is.
  ASSERT_EQ(testing::runCli("extract " + aal + " --smooth 20 -q -o " + dir + "/smooth.3mf").exitCode, 0);
  for (const Mesh& m : read3mf(dir + "/smooth.3mf")) {
    EXPECT_EQ(printable(m).coincident, 0u) << m.name;
    EXPECT_EQ(printable(m).badEdges, 0u) << m.name;
  }
  expectNoRepairs(prusaInfo(slicer, dir + "/smooth.3mf", dir), 116);
  fs::remove_all(dir);
}

// Names as a table gives them can hold bytes that are no UTF-8 (a Latin-1 table) or controls,
// which XML does not allow: each becomes U+FFFD, and a long name is cut at a character's end to
// 1024 bytes, so that lib3mf reads the file back (it refused the bytes, and left a 5,000-byte name
// empty).
TEST(Printable, ThreeMfNamesAreXmlThatLib3mfReadsBack) {
  const std::string dir = testing::tempDir();
  const std::string longName = std::string(1023, 'A') + "\xC3\xA9";  // a 2-byte character across 1024
  std::ofstream(dir + "/t.txt") << "1 ctl\x01x\n2 L\xE9sion\n3 " << longName << "\n4 ok\xC3\xA9\n";
  const auto r =
      testing::runCli("extract 'phantom:boxes?n=16&count=4' --label-table " + dir + "/t.txt -q -o " + dir + "/n.3mf");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::vector<Mesh> objects = read3mf(dir + "/n.3mf");
  ASSERT_EQ(objects.size(), 4u);
  EXPECT_EQ(objects[0].name, "ctl\xEF\xBF\xBDx");
  EXPECT_EQ(objects[1].name, "L\xEF\xBF\xBDsion");
  EXPECT_EQ(objects[2].name, std::string(1023, 'A'));
  EXPECT_EQ(objects[3].name, "ok\xC3\xA9");
  fs::remove_all(dir);
}

// Slicing to G-code takes PrusaSlicer about a minute a file here: the Release suite runs it; the
// sanitizer suite, whose files are the same bytes, skips it (tests/expected_skips.txt).
TEST(Printable, PrusaSlicerSlicesTheSkullAndTheAtlasToGcode) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "slicing checks PrusaSlicer's reading of the same bytes that the Release suite writes";
#endif
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string aal = "/usr/share/mricron/templates/aal.nii.gz";
  if (!fs::exists(aal)) GTEST_SKIP() << aal << " is absent (Debian mricron-data)";
  const std::string slicer = prusaSlicer();
  if (slicer.empty()) GTEST_SKIP() << "prusa-slicer is absent (scripts/setup.sh installs it)";
  const std::string dir = testing::tempDir();
  const std::string skull = "extract " + philips + " --iso 350 --close-boundary --keep-largest 1 -q -o " + dir;
  ASSERT_EQ(testing::runCli(skull + "/skull.stl").exitCode, 0);
  ASSERT_EQ(testing::runCli(skull + "/skull.3mf").exitCode, 0);
  ASSERT_EQ(testing::runCli("extract " + aal + " -q -o " + dir + "/aal.3mf").exitCode, 0);
  // Thick layers and no infill: the test is whether it slices, not how well.
  const std::string fast =
      " --layer-height 0.3 --first-layer-height 0.3 --fill-density 0% --perimeters 1 --skirts 0 "
      "--top-solid-layers 0 --bottom-solid-layers 0";
  for (const std::string name : {"skull.stl", "skull.3mf", "aal.3mf"}) {
    SCOPED_TRACE(name);
    // The atlas's objects stay where they are (arranged apart, 116 brains' parts do not fit a bed).
    const std::string arrange = name == "aal.3mf" ? " --dont-arrange" : "";
    const std::string gcode = dir + "/" + name + ".gcode";
    const std::string cmd =
        slicer + " --export-gcode" + arrange + fast + " '" + dir + "/" + name + "' -o '" + gcode + "' >/dev/null 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    const std::string text = testing::slurp(gcode);
    EXPECT_GT(countOf(text, ";LAYER_CHANGE"), 250u);  // 133 mm (skull) and 85 mm (atlas) at 0.3 mm
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace isoslab
