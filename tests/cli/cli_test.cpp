#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using testing::slurp;

using testing::runCli;

// A DICOM series' geometry as its headers give it, read with DCMTK itself: the expected numbers of
// `info` and of the spacing notes, recomputed rather than copied from isoslab's output.
struct HeaderGeometry {
  struct Slice {
    std::string path;
    std::array<double, 3> position{};
    double thickness = 0;
  };
  std::vector<Slice> slices;  // sorted along the slice normal
  std::array<double, 6> orientation{};
  std::array<double, 2> pixelSpacing{};
  double columns = 0, rows = 0;
  double gantryTilt = 0;
  std::vector<double> gaps;  // along the normal, in slice order

  std::array<double, 3> normal() const {
    const auto& o = orientation;
    return {o[1] * o[5] - o[2] * o[4], o[2] * o[3] - o[0] * o[5], o[0] * o[4] - o[1] * o[3]};
  }
  double along(const std::array<double, 3>& p) const {
    const auto n = normal();
    return p[0] * n[0] + p[1] * n[1] + p[2] * n[2];
  }
  // The angle between the normal and the step from the first slice to the last, in degrees.
  double stepTilt() const {
    const auto n = normal();
    const auto& a = slices.front().position;
    const auto& b = slices.back().position;
    const std::array<double, 3> d{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double c =
        along(d) / std::sqrt((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
    return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / std::numbers::pi;
  }
  // x, y, z minima then maxima over every slice's four corner pixel centres.
  std::array<double, 6> extent() const {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    std::array<double, 6> box{kInf, kInf, kInf, -kInf, -kInf, -kInf};
    const auto& o = orientation;
    for (const Slice& s : slices) {
      for (double i : {0.0, columns - 1}) {
        for (double j : {0.0, rows - 1}) {
          for (std::size_t a = 0; a < 3; ++a) {
            const double x = s.position[a] + i * pixelSpacing[1] * o[a] + j * pixelSpacing[0] * o[a + 3];
            box[a] = std::min(box[a], x);
            box[a + 3] = std::max(box[a + 3], x);
          }
        }
      }
    }
    return box;
  }
};

HeaderGeometry headerGeometry(const std::string& dir) {
  HeaderGeometry g;
  for (const auto& entry : fs::directory_iterator(dir)) {
    DcmFileFormat ff;
    if (ff.loadFile(entry.path().c_str()).bad()) continue;
    DcmDataset& d = *ff.getDataset();
    HeaderGeometry::Slice s;
    s.path = entry.path().string();
    bool image = true;
    for (unsigned long a = 0; a < 3; ++a)
      image = image && d.findAndGetFloat64(DCM_ImagePositionPatient, s.position[a], a).good();
    if (!image) continue;
    for (unsigned long a = 0; a < 6; ++a)
      EXPECT_TRUE(d.findAndGetFloat64(DCM_ImageOrientationPatient, g.orientation[a], a).good());
    for (unsigned long a = 0; a < 2; ++a)
      EXPECT_TRUE(d.findAndGetFloat64(DCM_PixelSpacing, g.pixelSpacing[a], a).good());
    Uint16 rows = 0, columns = 0;
    EXPECT_TRUE(d.findAndGetUint16(DCM_Rows, rows).good());
    EXPECT_TRUE(d.findAndGetUint16(DCM_Columns, columns).good());
    g.rows = rows;
    g.columns = columns;
    EXPECT_TRUE(d.findAndGetFloat64(DCM_SliceThickness, s.thickness).good());
    if (d.findAndGetFloat64(DCM_GantryDetectorTilt, g.gantryTilt).bad()) g.gantryTilt = 0;
    g.slices.push_back(s);
  }
  std::sort(g.slices.begin(), g.slices.end(),
            [&](const auto& a, const auto& b) { return g.along(a.position) < g.along(b.position); });
  for (std::size_t k = 1; k < g.slices.size(); ++k)
    g.gaps.push_back(g.along(g.slices[k].position) - g.along(g.slices[k - 1].position));
  return g;
}

// The numbers of the line of `out` that starts with `prefix`, up to a '(' if any.
std::vector<double> numbersOnLine(const std::string& out, const std::string& prefix) {
  std::vector<double> numbers;
  const std::size_t at = out.find("\n" + prefix);
  if (at == std::string::npos) return numbers;
  std::string line = out.substr(at + 1, out.find('\n', at + 1) - at - 1);
  line = line.substr(prefix.size(),
                     line.find('(') == std::string::npos ? std::string::npos : line.find('(') - prefix.size());
  // Every decimal number in the line, signed or not (std::regex's iterator trips GCC 12's
  // -Wmaybe-uninitialized in the sanitizer build).
  const auto digit = [](char c) { return c >= '0' && c <= '9'; };
  for (const char* p = line.c_str(); *p != '\0';) {
    if (digit(*p) || ((*p == '-' || *p == '+') && digit(p[1]))) {
      char* end = nullptr;
      numbers.push_back(std::strtod(p, &end));
      p = end;
    } else {
      ++p;
    }
  }
  return numbers;
}

// Expects `got` to be `want` as printed with %g (6 significant digits).
void expectPrinted(const std::vector<double>& got, const std::vector<double>& want, const std::string& what) {
  ASSERT_EQ(got.size(), want.size()) << what;
  for (std::size_t k = 0; k < want.size(); ++k)
    EXPECT_NEAR(got[k], want[k], 1e-5 * std::max(1.0, std::abs(want[k]))) << what << " number " << k;
}

// The note on the one run of gaps wider than 1.5 times the median spacing that the slices'
// thickness covers, in the words of scanDicom (io/dicom_series.cpp).
std::string coveredGapsNote(const HeaderGeometry& g) {
  std::vector<double> sorted = g.gaps;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  std::size_t first = g.gaps.size(), end = 0;
  for (std::size_t k = 0; k < g.gaps.size(); ++k) {
    if (g.gaps[k] <= 1.5 * median) continue;
    EXPECT_TRUE(first == g.gaps.size() || k == end) << "more than one run of wide gaps";
    first = std::min(first, k);
    end = k + 1;
  }
  EXPECT_LT(first, end);
  if (first >= end) return "";
  double narrowest = g.gaps[first], widest = g.gaps[first];
  double thin = g.slices[first].thickness, thick = thin;
  for (std::size_t k = first; k < end; ++k) {
    narrowest = std::min(narrowest, g.gaps[k]);
    widest = std::max(widest, g.gaps[k]);
    // Every gap equals the mean thickness of its two slices (within 1%).
    const double t = (g.slices[k].thickness + g.slices[k + 1].thickness) / 2;
    EXPECT_NEAR(g.gaps[k], t, 0.01 * t) << k;
  }
  for (std::size_t k = first; k <= end; ++k) {
    thin = std::min(thin, g.slices[k].thickness);
    thick = std::max(thick, g.slices[k].thickness);
  }
  auto range = [](double lo, double hi) {
    const std::string a = fmt::format("{:.3g}", lo);
    const std::string b = fmt::format("{:.3g}", hi);
    return a == b ? a : a + " to " + b;
  };
  return fmt::format(
      "uneven slice spacing: {} gaps of {} mm from {} to {} (median spacing {:.3g} mm) equal the slice "
      "thickness ({} mm): no slice is missing",
      end - first, range(narrowest, widest), g.slices[first].path, g.slices[end].path, median, range(thin, thick));
}

TEST(Cli, ExtractWritesMeshAndReport) {
  const std::string dir = testing::tempDir();
  const auto r = runCli("extract 'phantom:sphere?n=64&r=20&field=distance' --iso 800 -o " + dir + "/s.ply --report " +
                        dir + "/r.json --quiet");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err, "");
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  for (const char* key :
       {"method", "iso", "dims", "spacing", "vertices", "triangles", "bounds", "area", "volume", "boundary_edges",
        "nonmanifold_edges", "euler", "seconds", "peak_rss_mib", "output", "degenerate_triangles", "volume_cells"}) {
    EXPECT_TRUE(report.contains(key)) << key;
  }
  for (const char* key : {"read", "extract", "write", "total"}) EXPECT_TRUE(report["seconds"].contains(key)) << key;
  EXPECT_FALSE(report["seconds"].contains("decimation"));  // only a decimated run has its parts
  EXPECT_EQ(report["method"], "mc");
  EXPECT_EQ(report["euler"], 2);
  EXPECT_EQ(report["boundary_edges"], 0);
  EXPECT_EQ(report["bounds"].size(), 6u);
  EXPECT_NEAR(report["bounds"][0].get<double>(), 31.5 - 20, 0.05);
  EXPECT_EQ(report["output"]["bytes"].get<std::int64_t>(), static_cast<std::int64_t>(fs::file_size(dir + "/s.ply")));
  EXPECT_EQ(testing::fileCount(dir), 2);
}

TEST(Cli, ReportListsTheComponentsAndMetricsOfTheWrittenMeshAgrees) {
  const std::string dir = testing::tempDir();
  for (const char* close : {"", " --close-boundary"}) {
    SCOPED_TRACE(close);
    const auto r = runCli("extract 'phantom:head?n=48,40,36' --iso -400 -q -o " + dir + "/h.ply --report " + dir +
                          "/r.json" + close);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
    const auto& c = report["components"];
    ASSERT_EQ(c["count"], 1);
    EXPECT_EQ(c["closed"], *close ? 1 : 0);
    ASSERT_EQ(c["largest"].size(), 1u);
    EXPECT_EQ(c["largest"][0]["id"], 0);
    EXPECT_EQ(c["largest"][0]["triangles"], report["triangles"]);
    EXPECT_EQ(c["largest"][0]["closed"], report["closed"]);
    EXPECT_NEAR(c["largest"][0]["area"].get<double>(), report["area"].get<double>(),
                1e-9 * report["area"].get<double>());
    EXPECT_EQ(c["largest"][0]["bounds"], report["bounds"]);
    const auto m = runCli("metrics " + dir + "/h.ply");
    ASSERT_EQ(m.exitCode, 0) << m.err;
    // The file is one chunk: the same components, their sums rounded in another order.
    auto fromFile = nlohmann::json::parse(m.out)["components"];
    EXPECT_NEAR(fromFile["largest"][0]["area"].get<double>(), c["largest"][0]["area"].get<double>(),
                1e-9 * c["largest"][0]["area"].get<double>());
    EXPECT_NEAR(fromFile["largest"][0]["volume"].get<double>(), c["largest"][0]["volume"].get<double>(),
                1e-9 * std::abs(c["largest"][0]["volume"].get<double>()));
    fromFile["largest"][0]["area"] = c["largest"][0]["area"];
    fromFile["largest"][0]["volume"] = c["largest"][0]["volume"];
    EXPECT_EQ(fromFile, c);
  }
}

TEST(Cli, PhantomStreamedFromMemoryOrFromItsRawFileGivesTheSameBytes) {
  const std::string dir = testing::tempDir();
  const std::string spec = "'phantom:head?n=48,40,36'";
  const auto p = runCli("phantom " + spec + " -o " + dir + "/head.raw");
  ASSERT_EQ(p.exitCode, 0) << p.err;
  EXPECT_EQ(p.out,
            dir + "/head.raw: 138240 bytes; read it back with --raw-dims 48,40,36 --raw-type i16 --spacing 1,1,1\n");
  for (const char* method : {"mc", "mt5", "mt6", "bcc12"}) {
    const std::string m = std::string(" --method ") + method;
    ASSERT_EQ(runCli("extract " + spec + " --iso -400 --normals -q -o " + dir + "/a.ply" + m).exitCode, 0);
    ASSERT_EQ(runCli("extract " + dir + "/head.raw --raw-dims 48,40,36 --raw-type i16 --iso -400 --normals -q -o " +
                     dir + "/b.ply" + m)
                  .exitCode,
              0);
    const std::string a = slurp(dir + "/a.ply");
    EXPECT_GT(a.size(), 10000u);
    EXPECT_EQ(a, slurp(dir + "/b.ply")) << method;
  }
}

struct BadCase {
  std::string args;
  std::string error;
};

TEST(Cli, BadInputGivesOneLineANonZeroExitAndNoOutput) {
  const std::string dir = testing::tempDir();
  {
    std::ofstream f(dir + "/short.raw", std::ios::binary);
    f << std::string(100, '\0');
  }
  const std::string out = " -o " + dir + "/out.ply";
  const std::vector<BadCase> cases = {
      {"extract " + dir + "/short.raw --raw-dims 8,8,8 --iso 1" + out,
       dir + "/short.raw: holds 100 bytes, but dims 8x8x8 of u8 after a 0-byte header need 512"},
      {"extract " + dir + "/short.raw --raw-dims 0,8,8 --iso 1" + out,
       dir + "/short.raw: dims 0x8x8 are invalid: every axis needs at least 2 points"},
      {"extract " + dir + "/short.raw --raw-dims 8,-3,8 --iso 1" + out,
       dir + "/short.raw: dims 8x-3x8 are invalid: every axis needs at least 2 points"},
      {"extract " + dir + "/short.raw --raw-dims 4000000000,4000000000,4000000000 --iso 1" + out,
       dir + "/short.raw: dims 4000000000x4000000000x4000000000 are invalid: an axis exceeds 2147483647 points"},
      {"extract " + dir + "/short.raw --raw-dims 2000000000,2000000000,2000000000 --iso 1" + out,
       dir + "/short.raw: dims 2000000000x2000000000x2000000000 are invalid: the voxel count overflows"},
      {"extract " + dir + "/missing.raw --raw-dims 8,8,8 --iso 1" + out,
       dir + "/missing.raw: cannot open: No such file or directory"},
      {"extract " + dir + "/missing.raw --iso 1" + out, dir + "/missing.raw: cannot open: No such file or directory"},
      // A second word after a phantom: a phantom is never one of a list.
      {"extract 'phantom:sphere?n=16' 1" + out,
       "phantom:sphere?n=16: a phantom is a volume by itself: give it as the only input"},
      {"extract " + dir + "/short.raw --iso 1" + out,
       dir + "/short.raw: unrecognised input format; for raw data give --raw-dims X,Y[,Z] and --raw-type"},
      {"extract 'phantom:sphere?n=16' -o " + dir + "/no/such/folder/out.ply",
       dir + "/no/such/folder/out.ply: cannot create the output: the folder '" + dir +
           "/no/such/folder' does not exist"},
      {"extract 'phantom:sphere?n=16'" + out.substr(0, out.size() - 3) + "xyz",
       dir + "/out.xyz: unknown mesh format '.xyz' (use .ply, .stl, .obj, .glb, .drc or .3mf)"},
  };
  for (const BadCase& c : cases) {
    const auto r = runCli(c.args);
    EXPECT_EQ(r.exitCode, 1) << c.args;
    EXPECT_EQ(r.err, "isoslab: error: " + c.error + "\n") << c.args;
    EXPECT_EQ(testing::fileCount(dir), 1) << c.args;  // only short.raw
  }
}

TEST(Cli, UsageErrorsExitWithTwoAndOneLine) {
  const std::string dir = testing::tempDir();
  {
    std::ofstream f(dir + "/v.raw", std::ios::binary);
    for (int v = 0; v < 64; ++v) f.put(static_cast<char>(v * 3));  // 4x4x4 u8, values 0 .. 189
  }
  const std::string raw = dir + "/v.raw --raw-dims 4,4,4";
  const std::string out = " -o " + dir + "/out.ply";
  const std::vector<BadCase> cases = {
      {"extract", "INPUT is required (see isoslab extract --help)"},
      {"extract 'phantom:sphere?n=16'", "--output is required (see isoslab extract --help)"},
      {"extract 'phantom:sphere?n=16' --method mt7" + out,
       "--method: unknown method 'mt7' (use mc, mt5, mt6, bcc12, mt24 or mc33)"},
      {"extract 'phantom:sphere?n=16' --space lsp" + out,
       "--space: unknown space 'lsp' (use physical, lps, ras or voxel)"},
      {"extract " + dir + "/v.raw --raw-dims 4,4,x --iso 1" + out,
       "--raw-dims: '4,4,x' is not a comma-separated list of numbers"},
      {"extract " + dir + "/v.raw --raw-dims 4 --iso 1" + out, "--raw-dims: '4' needs X,Y or X,Y,Z"},
      {"extract " + dir + "/v.raw --raw-dims 4,4.5,4 --iso 1" + out, "--raw-dims: '4,4.5,4' must hold whole numbers"},
      {"extract " + raw + " --raw-type u12 --iso 1" + out,
       "--raw-type: unknown voxel type 'u12' (use u8 i8 u16 i16 u32 i32 f32 f64)"},
      {"extract " + raw + " --raw-endian middle --iso 1" + out,
       "--raw-endian: unknown byte order 'middle' (use little or big)"},
      {"extract " + raw + " --spacing 1,1 --iso 1" + out, "--spacing: '1,1' needs three values"},
      {"extract " + raw + " --iso 1 --sphere 1,2,3" + out, "--sphere: '1,2,3' needs cx,cy,cz,r with r > 0"},
      {"extract " + raw + out,
       dir + "/v.raw: --iso is required for this input, whose values range from 0 to 189; --iso auto takes Otsu's "
             "threshold"},
      {"extract " + raw + " --iso abc" + out, "--iso: 'abc' is not a number, auto, bone or skin"},
      {"phantom 'sphere?n=8' -o " + dir + "/p.raw", "sphere?n=8: not a phantom spec (phantom:NAME?key=value&...)"},
      {"extrct 'phantom:sphere?n=16'" + out, "unknown command 'extrct'; did you mean 'extract'?"},
      // CLI11 takes the next word as a value whatever it is: a report named --quiet, say.
      {"extract 'phantom:sphere?n=16' --report --quiet" + out,
       "--report needs a value, not the option --quiet (see isoslab extract --help)"},
      {"extract 'phantom:sphere?n=16' -o --threads=2",
       "--output needs a value, not the option --threads (see isoslab "
       "extract --help)"},
      {"metrics " + dir + "/v.raw --report --sphere 1,2,3,4",
       "--report needs a value, not the option --sphere (see isoslab metrics --help)"},
      {"extract 'phantom:sphere?n=16' --threads --quiet" + out, "--threads needs a value, not the option --quiet"},
      {"inf x", "unknown command 'inf'; did you mean 'info'?"},
      {"frobnicate",
       "unknown command 'frobnicate' (use extract, metrics, compare, decode, render, view, batch, info or phantom)"},
      {"--bogus", "A subcommand is required (see isoslab --help)"},
      {"info " + dir + "/v.raw --raw-dims 4,4,4 --spacing 1,nan,1",
       "--spacing: '1,nan,1' is not a comma-separated "
       "list of numbers"},
      {"metrics " + dir + "/v.raw --sphere 1,2,3,0", "--sphere: '1,2,3,0' needs cx,cy,cz,r with r > 0"},
      {"compare --suite spheres52 --out " + dir + "/c",
       "--suite: unknown suite 'spheres52' (use spheres51, paper, cubes or figures)"},
      {"compare --methods mc,mt7 --out " + dir + "/c",
       "--methods: unknown method 'mt7' (use mc, mt5, mt6, bcc12, mt24 or mc33)"},
      {"compare --radii 5,inf --out " + dir + "/c", "--radii: '5,inf' is not a comma-separated list of numbers"},
      {"compare --radii 5,0 --out " + dir + "/c", "--radii: '5,0' needs radii above 0"},
      {"compare --centre 0.5,0.5 --out " + dir + "/c", "--centre: '0.5,0.5' needs three values"},
  };
  for (const BadCase& c : cases) {
    const auto r = runCli(c.args);
    EXPECT_EQ(r.exitCode, 2) << c.args;
    EXPECT_EQ(r.err, "isoslab: error: " + c.error + "\n") << c.args;
    EXPECT_EQ(r.out, "") << c.args;
    EXPECT_EQ(testing::fileCount(dir), 1) << c.args;  // only v.raw
  }
  EXPECT_EQ(runCli("--help").exitCode, 0);
}

TEST(Cli, IsoslabAlonePrintsItsUsageOnStderr) {
  const auto r = runCli("");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err.rfind("isoslab: streaming iso-surface extraction from volumetric scanner data\n"
                        "Usage: isoslab [OPTIONS] SUBCOMMAND\n",
                        0),
            0u)
      << r.err;
  EXPECT_NE(r.err.find("\n  extract "), std::string::npos) << r.err;
  EXPECT_EQ(r.err, runCli("--help").out);
}

TEST(Cli, AMissingIsoForCtSuggestsHounsfieldValues) {
  const std::string dir = testing::tempDir();
  {
    std::ofstream f(dir + "/ct.raw", std::ios::binary);
    for (int v = 0; v < 64; ++v) {
      const auto hu = static_cast<std::int16_t>(v < 32 ? -1024 : 40 + v);
      f.write(reinterpret_cast<const char*>(&hu), 2);
    }
  }
  const auto r = runCli("extract " + dir + "/ct.raw --raw-dims 4,4,4 --raw-type i16 -o " + dir + "/out.ply");
  EXPECT_EQ(r.exitCode, 2);
  const std::string hint =
      "; for CT in Hounsfield units try about 300..400 for bone, -500..-200 for skin or 40 for soft tissue; --iso "
      "auto takes Otsu's threshold\n";
  EXPECT_EQ(r.err, "isoslab: error: " + dir + "/ct.raw: --iso is required for this input, whose values range from " +
                       "-1024 to 103" + hint);
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const auto d = runCli("extract " + philips + " -q -o " + dir + "/out.ply");
  EXPECT_EQ(d.exitCode, 2);
  EXPECT_EQ(d.err, "isoslab: error: " + philips +
                       ": --iso is required for this input, whose values range from -1024 to 1033" + hint);
  EXPECT_EQ(testing::fileCount(dir), 1);
}

TEST(Cli, MethodAndSpaceNamesAreCaseInsensitive) {
  const std::string dir = testing::tempDir();
  const std::string spec = "'phantom:sphere?n=24&r=8' -q";
  ASSERT_EQ(
      runCli("extract " + spec + " --method MT6 --space RAS -o " + dir + "/a.ply --report " + dir + "/a.json").exitCode,
      0);
  ASSERT_EQ(runCli("extract " + spec + " --method mt6 --space ras -o " + dir + "/b.ply").exitCode, 0);
  EXPECT_EQ(slurp(dir + "/a.ply"), slurp(dir + "/b.ply"));
  const auto report = nlohmann::json::parse(slurp(dir + "/a.json"));
  EXPECT_EQ(report["method"], "mt6");
  EXPECT_EQ(report["space"], "ras");
  EXPECT_EQ(runCli("extract " + spec + " --method Bcc12 --space Voxel --raw-endian BIG -o " + dir + "/c.ply").exitCode,
            0);
}

TEST(Cli, AnIsoOutsideTheValueRangeWarnsEvenWhenQuietAndInTheReport) {
  const std::string dir = testing::tempDir();
  const std::string box = "extract 'phantom:box?n=12' -q -o " + dir + "/b.ply --report " + dir + "/r.json";
  struct Case {
    std::string iso;
    std::string warning;
  };
  const std::vector<Case> cases = {
      {"150",
       "--iso 150 is above the input's value range 0 .. 100: no voxel is inside, so the surface is empty "
       "(0 triangles)"},
      {"0",
       "--iso 0 is not above the input's smallest value (range 0 .. 100): every voxel is inside, so the surface "
       "is empty (0 triangles)"},
      {"-3.5",
       "--iso -3.5 is not above the input's smallest value (range 0 .. 100): every voxel is inside, so the "
       "surface is empty (0 triangles)"},
  };
  for (const Case& c : cases) {
    for (const char* threads : {"1", "3"}) {
      const auto r = runCli(box + " --iso " + c.iso + " --threads " + threads + " --sequential-voxels 0");
      ASSERT_EQ(r.exitCode, 0) << r.err;
      EXPECT_EQ(r.err, "isoslab: warning: " + c.warning + "\n");
      const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
      EXPECT_EQ(report["triangles"], 0);
      EXPECT_EQ(report["closed"], true);
      EXPECT_EQ(report["value_range"], nlohmann::json::array({0, 100}));
      EXPECT_EQ(report["warnings"], nlohmann::json::array({c.warning}));
    }
  }
  const auto ok = runCli(box + " --iso 50");
  ASSERT_EQ(ok.exitCode, 0);
  EXPECT_EQ(ok.err, "");
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["warnings"], nlohmann::json::array());
  EXPECT_EQ(report["value_range"], nlohmann::json::array({0, 100}));
  EXPECT_GT(report["triangles"].get<int>(), 0);
}

TEST(Cli, AnEmptySurfaceForAnyOtherReasonWarns) {
  const std::string dir = testing::tempDir();
  {
    std::ofstream f(dir + "/nan.raw", std::ios::binary);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (int v = 0; v < 27; ++v) f.write(reinterpret_cast<const char*>(&nan), 4);
  }
  const auto r = runCli("extract " + dir + "/nan.raw --raw-dims 3,3,3 --raw-type f32 --iso 1 -q -o " + dir +
                        "/n.ply --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err, "isoslab: warning: 0 triangles: the input holds no values but NaN\n");
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_TRUE(report["value_range"].is_null());
  EXPECT_EQ(report["warnings"], nlohmann::json::array({"0 triangles: the input holds no values but NaN"}));
}

TEST(Cli, ARawFileLongerThanItsDimsNeedWarns) {
  const std::string dir = testing::tempDir();
  {
    std::ofstream f(dir + "/v.raw", std::ios::binary);
    for (int v = 0; v < 4 * 4 * 5; ++v) f.put(static_cast<char>(v));
  }
  const std::string warning = dir +
                              "/v.raw: holds 80 bytes, 16 more than dims 4x4x4 of u8 need; the extra bytes are "
                              "ignored; dims 4x4x5 would use them all";
  const auto r =
      runCli("extract " + dir + "/v.raw --raw-dims 4,4,4 --iso 30 -q -o " + dir + "/v.ply --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err, "isoslab: warning: " + warning + "\n");
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["warnings"], nlohmann::json::array({warning}));
  EXPECT_EQ(report["value_range"], nlohmann::json::array({0, 63}));
  const auto info = runCli("info " + dir + "/v.raw --raw-dims 4,4,4");
  EXPECT_NE(info.out.find("\nwarning    " + warning + "\n"), std::string::npos) << info.out;

  const std::string engine = testing::sharedData("engine/engine_256x256x128_uint8.raw.gz");
  if (engine.empty()) GTEST_SKIP() << "../shared/data/engine is absent";
  const auto e = runCli("extract " + engine + " --raw-dims 256,256,127 --iso 90 -q -o " + dir + "/e.ply --report " +
                        dir + "/e.json");
  ASSERT_EQ(e.exitCode, 0) << e.err;
  const std::string inflated = engine +
                               ": holds 8388608 bytes once inflated, 65536 more than dims 256x256x127 of u8 need; "
                               "the extra bytes are ignored; dims 256x256x128 would use them all";
  EXPECT_EQ(e.err, "isoslab: warning: " + inflated + "\n");
  EXPECT_EQ(nlohmann::json::parse(slurp(dir + "/e.json"))["warnings"], nlohmann::json::array({inflated}));
}

TEST(Cli, SliceFilesOfTheWrongTypeWarnAndNameTheTypeThatFits) {
  const std::string cthead = testing::sharedData("cthead");
  if (cthead.empty()) GTEST_SKIP() << "../shared/data/cthead is absent";
  const std::string dir = testing::tempDir();
  const auto r =
      runCli("extract " + cthead + " --raw-dims 256,256 --iso 100 -q -o " + dir + "/c.ply --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const std::string warning = cthead +
                              "/CThead.1: holds 131072 bytes, 65536 more than one 256x256 slice of u8 needs, as do "
                              "all 113 slice files; the extra bytes are ignored; a 2-byte type (u16 or i16) would "
                              "use them all";
  EXPECT_EQ(r.err, "isoslab: warning: " + warning + "\n");
  EXPECT_EQ(nlohmann::json::parse(slurp(dir + "/r.json"))["warnings"], nlohmann::json::array({warning}));
  const auto right =
      runCli("extract " + cthead + " --raw-dims 256,256 --raw-type u16 --raw-endian big --iso 600 -q -o " + dir +
             "/d.ply --report " + dir + "/d.json");
  ASSERT_EQ(right.exitCode, 0) << right.err;
  EXPECT_EQ(right.err, "");
  const auto report = nlohmann::json::parse(slurp(dir + "/d.json"));
  EXPECT_EQ(report["value_range"], nlohmann::json::array({0, 3272}));
}

TEST(Cli, AFullDiskLeavesNoPartialFile) {
  // ulimit -f makes writes past 64 KiB fail with EFBIG, as a full disk would fail them.
  const std::string dir = testing::tempDir();
  const std::string cmd = std::string("bash -c \"ulimit -f 64; exec ") + ISOSLAB_CLI_PATH +
                          " extract 'phantom:sphere?n=96&r=40' -q -o " + dir + "/big.ply\" 2>" + dir + "/err";
  const int status = std::system(cmd.c_str());
  EXPECT_NE(status, 0);
  std::ifstream f(dir + "/err");
  std::string line;
  std::getline(f, line);
  EXPECT_EQ(line, "isoslab: error: " + dir + "/big.ply: cannot write: File too large");
  EXPECT_FALSE(fs::exists(dir + "/big.ply"));
  EXPECT_EQ(testing::fileCount(dir), 1);  // only the captured stderr
}

// A PLY whose faces fit under the file-size limit but whose whole file does not: the room made
// before the faces (fallocate, which does not check the limit) must not let it pass.
TEST(Cli, AFileSizeLimitStopsAPlyWhoseFacesFitUnderIt) {
  const std::string dir = testing::tempDir();
  const std::string cmd = std::string("bash -c \"ulimit -f 1000; exec ") + ISOSLAB_CLI_PATH +
                          " extract 'phantom:sphere?n=100&r=40' --normals -q -o " + dir + "/big.ply\" 2>" + dir +
                          "/err";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  EXPECT_EQ(slurp(dir + "/err"), "isoslab: error: " + dir + "/big.ply: cannot write: File too large\n");
  EXPECT_FALSE(fs::exists(dir + "/big.ply"));
  EXPECT_EQ(testing::fileCount(dir), 1);  // only the captured stderr
  // Under the limit the same run writes the file, and the report's binary PLY size is its size.
  const auto r =
      runCli("extract 'phantom:sphere?n=100&r=40' --normals -q -o " + dir + "/ok.ply --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["output"]["ratio_to_binary_ply"].get<double>(), 1.0);
}

// Where the file system cannot move the faces (tmpfs), they are copied up; a copy that the limit
// stops says why (not the reason the move was refused).
TEST(Cli, ACopyThatTheLimitStopsSaysWhy) {
  if (!fs::is_directory("/dev/shm")) GTEST_SKIP() << "no /dev/shm";
  const std::string dir = "/dev/shm/isoslab-limit-" + std::to_string(::getpid());
  fs::create_directories(dir);
  const std::string cmd = std::string("bash -c \"ulimit -f 130; exec ") + ISOSLAB_CLI_PATH +
                          " extract 'phantom:sphere?n=40&r=15' -q -o " + dir + "/x.ply\" 2>" + dir + "/err";
  EXPECT_NE(std::system(cmd.c_str()), 0);
  EXPECT_EQ(slurp(dir + "/err"), "isoslab: error: " + dir + "/x.ply: cannot write: File too large\n");
  EXPECT_EQ(testing::fileCount(dir), 1);
  fs::remove_all(dir);
}

TEST(Cli, DicomFolderChoosesTheLargestSeriesAndSaysSo) {
  const std::string dir = testing::sharedData("ct-ge-tilt");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/ct-ge-tilt is absent";
  const std::string out = testing::tempDir();
  const auto r = runCli("extract " + dir + " --iso 300 --space ras -o " + out + "/ge.stl --report " + out + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("isoslab: skipped 1 file that is not a DICOM image\n"), std::string::npos) << r.err;
  // The 7 mm steps after 4 mm ones match the slices' SliceThickness: a note, not a warning.
  const HeaderGeometry g = headerGeometry(dir);
  ASSERT_EQ(g.slices.size(), 28u);
  const std::string note = coveredGapsNote(g);
  ASSERT_NE(note, "");
  EXPECT_NE(r.err.find("isoslab: " + note + "\n"), std::string::npos) << r.err << note;
  EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(slurp(out + "/r.json"));
  EXPECT_EQ(report["reader"], "dicom");
  EXPECT_EQ(report["space"], "ras");
  EXPECT_EQ(report["warnings"], nlohmann::json::array());
  const auto info = runCli("info " + dir);
  EXPECT_EQ(info.exitCode, 0);
  EXPECT_NE(info.out.find("1 DICOM series; 1 file skipped (not DICOM images)\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("  value range    -1500 .. 2121 (after rescale)\n"), std::string::npos) << info.out;
  // --strict fails on warnings only, so this series (no slice missing) passes it.
  const auto strict = runCli("extract " + dir + " --iso 300 --strict -q -o " + out + "/x.ply");
  EXPECT_EQ(strict.exitCode, 0) << strict.err;
  EXPECT_TRUE(fs::exists(out + "/x.ply"));
}

// Every number of `info`'s geometry lines against the headers read with DCMTK: spacing, thickness,
// tilt (from the header and from the positions), the first slice and the extent.
TEST(Cli, InfoShowsTheTiltFirstPositionExtentAndThicknessOfDicomSeries) {
  struct Case {
    std::string folder;
    int skipped;
  };
  for (const Case& c : {Case{"ct-ge-tilt", 1}, Case{"ct-philips-head", 2}}) {
    SCOPED_TRACE(c.folder);
    const std::string dir = testing::sharedData(c.folder);
    if (dir.empty()) GTEST_SKIP() << "../shared/data/" << c.folder << " is absent";
    const HeaderGeometry g = headerGeometry(dir);
    ASSERT_GT(g.slices.size(), 2u);
    const auto r = runCli("info " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find(fmt::format("1 DICOM series; {} file{} skipped (not DICOM images)\n", c.skipped,
                                     c.skipped == 1 ? "" : "s")),
              std::string::npos)
        << r.out;
    std::vector<double> gaps = g.gaps;
    std::sort(gaps.begin(), gaps.end());
    expectPrinted(numbersOnLine(r.out, "  slice spacing  "), {gaps.front(), gaps[gaps.size() / 2], gaps.back()},
                  "slice spacing");
    double thin = g.slices.front().thickness, thick = thin;
    for (const auto& s : g.slices) thin = std::min(thin, s.thickness), thick = std::max(thick, s.thickness);
    EXPECT_NE(
        r.out.find(fmt::format("  thickness      {} mm (SliceThickness)\n",
                               thin == thick ? fmt::format("{:g}", thin) : fmt::format("{:g} .. {:g}", thin, thick))),
        std::string::npos)
        << r.out;
    EXPECT_NE(
        r.out.find(fmt::format("  gantry tilt    {:g} degrees (GantryDetectorTilt); {:.2f} degrees between the slice "
                               "normal and the slice steps\n",
                               g.gantryTilt, g.stepTilt())),
        std::string::npos)
        << r.out;
    const auto& p = g.slices.front().position;
    expectPrinted(numbersOnLine(r.out, "  first slice    "), {p[0], p[1], p[2]}, "first slice");
    EXPECT_NE(r.out.find("(ImagePositionPatient of " + g.slices.front().path + ")\n"), std::string::npos) << r.out;
    const auto box = g.extent();
    expectPrinted(numbersOnLine(r.out, "  extent         "), {box[0], box[3], box[1], box[4], box[2], box[5]},
                  "extent");
    EXPECT_NE(r.out.find("(LPS mm, corner pixel centres)\n"), std::string::npos) << r.out;
    if (c.folder == "ct-ge-tilt") {
      // The data's README: 18.5 degrees, slices 4 mm then 7 mm apart, one gap of 1.08 mm.
      EXPECT_NEAR(g.stepTilt(), 18.5, 0.01);
      EXPECT_NE(r.out.find("  note           " + coveredGapsNote(g) + "\n"), std::string::npos) << r.out;
    }
    EXPECT_EQ(r.out.find("warning"), std::string::npos) << r.out;
  }
}

// --close-boundary caps at the --roi box's faces: a box through the middle of a sphere gives one
// closed piece, whose volume is the sphere's inside the box (a half ball: 2/3 pi r^3, within the
// extraction's error), and the same bytes for 1 and 3 threads.
TEST(Cli, CloseBoundaryCapsAtTheRoiFaces) {
  const std::string dir = testing::tempDir();
  std::string first;
  for (int threads : {1, 3}) {
    const auto r = testing::runCli(
        fmt::format("extract 'phantom:sphere?n=48&r=15&c=24,24,24&field=distance' --iso 850 --roi 0,0,24,47,47,47 "
                    "--close-boundary --threads {} --sequential-voxels 0 -q -o {}/h{}.ply --report {}/r{}.json",
                    threads, dir, threads, dir, threads));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto report = nlohmann::json::parse(slurp(fmt::format("{}/r{}.json", dir, threads)));
    EXPECT_EQ(report["boundary_edges"], 0);
    EXPECT_EQ(report["nonmanifold_edges"], 0);
    EXPECT_EQ(report["euler"], 2);
    EXPECT_EQ(report["components"]["count"], 1);
    EXPECT_NEAR(report["volume"].get<double>() / (2.0 / 3.0 * 3.14159265358979 * 15 * 15 * 15), 1.0, 0.01);
    const std::string bytes = slurp(fmt::format("{}/h{}.ply", dir, threads));
    if (threads == 1)
      first = bytes;
    else
      EXPECT_TRUE(bytes == first);
  }
}

// Every method and format, at 1, 2 and 4 threads. The volume is small, so it takes the threaded
// path through the hidden --sequential-voxels 0; its 39 slabs go in runs of 4 slabs at 2 threads
// and of 2 at 4 (four runs a thread at most), so runs start and end at different slabs.
TEST(Cli, OutputBytesAreTheSameForEveryThreadCount) {
  const std::string dir = testing::tempDir();
  for (const std::string& method : methodNames()) {
    for (const char* ext : {"ply", "glb", "stl", "obj", "drc"}) {
      std::string first;
      for (int threads : {1, 2, 4}) {
        const std::string out = fmt::format("{}/t{}.{}", dir, threads, ext);
        const auto r =
            testing::runCli(fmt::format("extract 'phantom:head?n=48,44,40&noise=60' --iso 0 --normals -q "
                                        "--chunk-triangles 3000 --method {} --threads {} --sequential-voxels 0 -o {}",
                                        method, threads, out));
        ASSERT_EQ(r.exitCode, 0) << r.err;
        const std::string bytes = slurp(out);
        EXPECT_GT(bytes.size(), 10000u);
        if (threads == 1) {
          first = bytes;
        } else {
          EXPECT_TRUE(bytes == first) << method << " " << ext << " threads " << threads;
        }
      }
    }
  }
}

TEST(Cli, InfoPrintsGeometryAndRange) {
  const auto r = runCli("info 'phantom:box?n=10,12,14&lo=2,2,2&hi=5,5,5'");
  ASSERT_EQ(r.exitCode, 0);
  EXPECT_NE(r.out.find("dims       10 x 12 x 14\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("range      0 .. 100\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("type       u8\n"), std::string::npos) << r.out;
}

TEST(Cli, KeepLargestKeepsOneComponentInTwoPasses) {
  const std::string dir = testing::tempDir();
  const std::string input = "'phantom:head?n=48,44,40&noise=60'";
  std::string first;
  for (int threads : {1, 3}) {
    const auto r =
        testing::runCli(fmt::format("extract {} --iso 0 --close-boundary --keep-largest 1 --threads {} "
                                    "--sequential-voxels 0 -q -o {}/k{}.ply --report {}/k{}.json",
                                    input, threads, dir, threads, dir, threads));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err, "");
    const auto report = nlohmann::json::parse(slurp(fmt::format("{}/k{}.json", dir, threads)));
    const auto& components = report["components"];
    const auto& filter = report["component_filter"];
    ASSERT_GT(components["count"].get<int>(), 1) << "the noise should leave islands";
    EXPECT_EQ(filter["rules"], "--keep-largest 1");
    EXPECT_EQ(filter["passes"], 2);
    EXPECT_EQ(filter["kept"]["count"], 1);
    EXPECT_EQ(filter["dropped"]["count"].get<int>(), components["count"].get<int>() - 1);
    EXPECT_EQ(components["largest"][0]["kept"], true);
    EXPECT_EQ(components["largest"][1]["kept"], false);
    // The output is the largest component, closed, and nothing else.
    EXPECT_EQ(report["triangles"], components["largest"][0]["triangles"]);
    EXPECT_EQ(report["triangles"], filter["kept"]["triangles"]);
    EXPECT_EQ(report["boundary_edges"], 0);
    EXPECT_NEAR(report["volume"].get<double>(), components["largest"][0]["volume"].get<double>(),
                1e-9 * std::abs(report["volume"].get<double>()));
    const auto m = testing::runCli(fmt::format("metrics {}/k{}.ply", dir, threads));
    ASSERT_EQ(m.exitCode, 0) << m.err;
    EXPECT_EQ(nlohmann::json::parse(m.out)["components"]["count"], 1);
    const std::string bytes = slurp(fmt::format("{}/k{}.ply", dir, threads));
    if (threads == 1)
      first = bytes;
    else
      EXPECT_TRUE(bytes == first);
  }
  // Keeping every component gives the plain run's file.
  ASSERT_EQ(testing::runCli(fmt::format("extract {} --iso 0 --normals -q -o {}/all.ply", input, dir)).exitCode, 0);
  ASSERT_EQ(testing::runCli(fmt::format("extract {} --iso 0 --normals --min-triangles 1 -q -o {}/kept.ply", input, dir))
                .exitCode,
            0);
  EXPECT_TRUE(slurp(dir + "/all.ply") == slurp(dir + "/kept.ply"));
}

TEST(Cli, SeedOutsideEveryComponentLeavesNoOutput) {
  const std::string dir = testing::tempDir();
  const auto r = testing::runCli(
      fmt::format("extract 'phantom:sphere?n=32&r=8&c=16,16,16' --iso 900 --seed 30,30,30 --space voxel -o {}/s.glb "
                  "--report {}/s.json",
                  dir, dir));
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err,
            "isoslab: error: --seed 30,30,30 lies outside every component's bounds (grown by 1.73205): the one "
            "component lies within x 6 .. 26, y 6 .. 26, z 6 .. 26\n");
  EXPECT_EQ(testing::fileCount(dir), 0);
  // Within a voxel of its bounds, the seed picks the sphere.
  const auto near = testing::runCli(fmt::format(
      "extract 'phantom:sphere?n=32&r=8&c=16,16,16' --iso 900 --seed 25,16,16 --space voxel -q -o {}/s.glb", dir));
  EXPECT_EQ(near.exitCode, 0) << near.err;
}

TEST(Cli, SmoothingIsTheSameForEveryThreadCountAndKeepsTheMeshClosed) {
  const std::string dir = testing::tempDir();
  for (const char* ext : {"ply", "glb"}) {
    std::string first;
    for (int threads : {1, 3}) {
      const std::string out = fmt::format("{}/s{}.{}", dir, threads, ext);
      const auto r = testing::runCli(fmt::format(
          "extract 'phantom:head?n=48,44,40&noise=60' --iso 0 --normals --close-boundary --keep-largest 2 "
          "--smooth 12 --chunk-triangles 3000 -q --threads {} --sequential-voxels 0 -o {} --report {}/r.json",
          threads, out, dir));
      ASSERT_EQ(r.exitCode, 0) << r.err;
      const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
      EXPECT_EQ(report["boundary_edges"], 0);
      EXPECT_EQ(report["nonmanifold_edges"], 0);
      const std::string bytes = slurp(out);
      if (threads == 1)
        first = bytes;
      else
        EXPECT_TRUE(bytes == first) << ext;
    }
  }
}

TEST(Cli, SmoothingOptionsOutOfRangeAreUsageErrors) {
  const std::string dir = testing::tempDir();
  const std::string input = "'phantom:sphere?n=24' --iso 900 -o " + dir + "/s.ply";
  auto r = testing::runCli("extract " + input + " --smooth 501");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: --smooth: '501' is not a whole number from 0 to 500\n");
  r = testing::runCli("extract " + input + " --smooth 5 --pass-band 2");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: --pass-band must be above 0 and below 2\n");
  r = testing::runCli("extract " + input + " --smooth 5 --smooth-method taubin --pass-band 1.99");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(testing::fileCount(dir), 1);
}

TEST(Cli, DecimationIsTheSameForEveryThreadCountAndJoinsAtChunkSeams) {
  const std::string dir = testing::tempDir();
  std::string first;
  for (int threads : {1, 3}) {
    const std::string out = fmt::format("{}/d{}.glb", dir, threads);
    const auto r = testing::runCli(fmt::format(
        "extract 'phantom:torus?n=64,64,48&R=18&r=7' --iso 900 --normals --close-boundary --smooth 5 --decimate 0.25 "
        "--chunk-triangles 2000 -q --threads {} --sequential-voxels 0 -o {} --report {}/r.json",
        threads, out, dir));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
    EXPECT_EQ(report["boundary_edges"], 0);
    EXPECT_EQ(report["nonmanifold_edges"], 0);
    EXPECT_GE(report["output"]["chunks"].get<double>(), 2);
    EXPECT_LT(report["decimation"]["kept_fraction"].get<double>(), 0.4);
    const std::string bytes = slurp(out);
    if (threads == 1) {
      first = bytes;
      // The decoded chunks weld into one closed torus: no crack at a chunk seam.
      ASSERT_EQ(testing::runCli(fmt::format("decode {} -o {}/d.ply", out, dir)).exitCode, 0);
      const auto m = testing::runCli(fmt::format("metrics {}/d.ply", dir));
      const auto metrics = nlohmann::json::parse(m.out);
      EXPECT_EQ(metrics["boundary_edges"], 0);
      EXPECT_EQ(metrics["euler"], 0);
      EXPECT_EQ(metrics["triangles"], report["triangles"]);
    } else {
      EXPECT_TRUE(bytes == first);
    }
  }
}

TEST(Cli, DecimationOptionsOutOfRangeAreUsageErrors) {
  const std::string dir = testing::tempDir();
  const std::string input = "'phantom:sphere?n=24' --iso 900 -o " + dir + "/s.ply";
  auto r = testing::runCli("extract " + input + " --decimate 0");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: --decimate must be above 0 and at most 1\n");
  r = testing::runCli("extract " + input + " --decimate 1.5");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: --decimate must be above 0 and at most 1\n");
  r = testing::runCli("extract " + input + " --max-error -0.5");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, "isoslab: error: --max-error must be 0 or more\n");
  EXPECT_EQ(testing::fileCount(dir), 0);
}

// A decimation that keeps well over the fraction asked for says so, with the fraction kept (from
// the report's counts), the error bound and what else limits it, even with -q; one that gets there
// says nothing.
TEST(Cli, DecimationStoppedShortOfItsFractionWarns) {
  const std::string dir = testing::tempDir();
  const std::string input =
      "extract 'phantom:head?n=40,36,40&noise=40' --iso 0 -q -o " + dir + "/m.ply --report " + dir + "/r.json";
  for (const auto& [options, bound] : {std::pair<std::string, std::string>{"", "default error bound (0.5 voxels"},
                                       {" --max-error 2", "error bound (2 voxels"},
                                       {" --max-error 1", "error bound (1 voxel"}}) {
    SCOPED_TRACE(options);
    const auto r = testing::runCli(input + " --decimate 0.01" + options);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
    const auto& d = report["decimation"];
    const double kept = d["triangles_after"].get<double>() / d["triangles_before"].get<double>();
    ASSERT_GT(kept, 0.012);
    const std::string text = fmt::format(
        "--decimate 0.01 kept {:.1f}% of the triangles, more than asked: a collapse is made only within the {}; "
        "--max-error sets it) and where the mesh stays closed and manifold",
        100 * kept, bound);
    EXPECT_EQ(r.err, "isoslab: warning: " + text + "\n");
    EXPECT_EQ(report["warnings"], nlohmann::json::array({text}));
  }
  const auto met = testing::runCli(input + " --decimate 0.5");
  ASSERT_EQ(met.exitCode, 0) << met.err;
  EXPECT_EQ(met.err, "");
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_LE(report["decimation"]["kept_fraction"].get<double>(), 0.6);
  EXPECT_EQ(report["warnings"], nlohmann::json::array());
}

TEST(Cli, SmoothingAndDecimationWriteEveryFormat) {
  const std::string dir = testing::tempDir();
  for (const char* ext : {"ply", "stl", "obj", "glb", "drc"}) {
    const std::string out = fmt::format("{}/m.{}", dir, ext);
    const auto r = testing::runCli(fmt::format(
        "extract 'phantom:head?n=40,36,40&noise=40' --iso 0 --method bcc12 --close-boundary --min-triangles "
        "50 --smooth 4 --smooth-method taubin --decimate 0.3 --normals -q -o {} --report {}/r.json",
        out, dir));
    ASSERT_EQ(r.exitCode, 0) << ext << ": " << r.err;
    const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
    const auto m = testing::runCli("metrics " + out);
    ASSERT_EQ(m.exitCode, 0) << ext << ": " << m.err;
    const auto metrics = nlohmann::json::parse(m.out);
    EXPECT_EQ(metrics["triangles"], report["triangles"]) << ext;
    EXPECT_EQ(report["boundary_edges"], 0) << ext;
    EXPECT_LT(report["decimation"]["kept_fraction"].get<double>(), 0.5) << ext;
    // Where the decimation's time went: the parts of the calls within them, no crossing search on
    // an iso surface, and the distance measured for the report.
    const auto& seconds = report["seconds"]["decimation"];
    const auto part = [&](const char* key) { return seconds.at(key).get<double>(); };
    EXPECT_GT(part("simplifier"), 0.0) << ext;
    EXPECT_GE(part("calls") * (1 + 1e-9), part("simplifier") + part("checks") + part("crossing")) << ext;
    EXPECT_EQ(part("crossing"), 0.0) << ext;
    EXPECT_GT(part("grids"), 0.0) << ext;
    EXPECT_GT(part("measure"), 0.0) << ext;
    // STL stores triangles alone, so its reader welds by position; the others keep the vertices.
    if (std::string(ext) != "stl") {
      EXPECT_EQ(metrics["boundary_edges"], 0) << ext;
    }
  }
}

}  // namespace
}  // namespace isoslab
