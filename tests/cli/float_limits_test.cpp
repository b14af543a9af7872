// Issue 33, class 1: finite input geometry whose mapped output overflows float32 (or whose step
// is below float32's resolution there) must be refused by extract before the first slice; whatever is
// accepted must give a mesh whose every coordinate and normal, and every report number, is
// finite. A property test: random geometries at the float limits in every reader that carries
// geometry (raw, phantom, NRRD, MetaImage, NIfTI, DICOM, image stacks), each run through the
// program and judged by reading its PLY and its report here.
#include <OpenImageIO/imageio.h>
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "test_support.h"

namespace isoslab::testing {
namespace {

namespace fs = std::filesystem;

constexpr int kN = 5;  // lattice points per axis

// A ball of 200 in a field of 0 (iso 100): every reader's volume holds a closed surface.
std::vector<std::uint8_t> ballVoxels() {
  std::vector<std::uint8_t> v;
  for (int k = 0; k < kN; ++k) {
    for (int j = 0; j < kN; ++j) {
      for (int i = 0; i < kN; ++i) {
        const double r = std::hypot(i - 2.0, j - 2.0, k - 2.0);
        v.push_back(r < 1.6 ? 200 : 0);
      }
    }
  }
  return v;
}

void write(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

std::string voxelBytes() {
  const auto v = ballVoxels();
  return std::string(reinterpret_cast<const char*>(v.data()), v.size());
}

struct Geometry {
  std::array<double, 3> spacing{1, 1, 1};
  std::array<double, 3> origin{0, 0, 0};
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major, unit columns
};

class Generator {
 public:
  explicit Generator(std::uint64_t seed) : rng_(seed) {}

  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  bool chance(double p) { return uniform(0, 1) < p; }

  // A spacing: ordinary, near float32's largest (where the box's corners cross it), or anywhere
  // from `minExp` to `maxExp`.
  double spacing(double minExp, double maxExp) {
    if (chance(0.4)) return std::pow(10.0, uniform(-2, 1));
    if (chance(0.6)) return std::pow(10.0, uniform(36, 38.2));
    return std::pow(10.0, uniform(minExp, maxExp));
  }
  double origin(double maxExp) {
    if (chance(0.5)) return 0;
    if (chance(0.5)) return uniform(-500, 500);
    return (chance(0.5) ? -1 : 1) * std::pow(10.0, uniform(-3, maxExp));
  }

  Geometry geometry(double minExp, double maxExp, bool rotate) {
    Geometry g;
    for (auto& s : g.spacing) s = spacing(minExp, maxExp);
    for (auto& o : g.origin) o = origin(maxExp);
    if (rotate && chance(0.5)) {
      // A rotation from a random unit quaternion.
      std::normal_distribution<double> n;
      double q[4] = {n(rng_), n(rng_), n(rng_), n(rng_)};
      const double len = std::hypot(std::hypot(q[0], q[1]), std::hypot(q[2], q[3]));
      for (double& c : q) c /= len;
      const double a = q[0], b = q[1], c = q[2], d = q[3];
      g.direction = {a * a + b * b - c * c - d * d, 2 * (b * c - a * d),           2 * (b * d + a * c),
                     2 * (b * c + a * d),           a * a - b * b + c * c - d * d, 2 * (c * d - a * b),
                     2 * (b * d - a * c),           2 * (c * d + a * b),           a * a - b * b - c * c + d * d};
    }
    return g;
  }

 private:
  std::mt19937_64 rng_;
};

// One input: the path the program reads, its extra options, and the path an error must name.
struct Input {
  std::string path;
  std::string options;
};

Input rawInput(const std::string& dir, const Geometry& g) {
  write(dir + "/v.raw", voxelBytes());
  return {dir + "/v.raw", fmt::format("--raw-dims {0},{0},{0} --raw-type u8 --spacing {1:.17g},{2:.17g},{3:.17g}", kN,
                                      g.spacing[0], g.spacing[1], g.spacing[2])};
}

Input phantomInput(const Geometry& g) {
  return {
      fmt::format("phantom:sphere?n={}&spacing={:.17g},{:.17g},{:.17g}", 8, g.spacing[0], g.spacing[1], g.spacing[2]),
      ""};
}

Input nrrdInput(const std::string& dir, const Geometry& g) {
  std::string axes;
  for (int a = 0; a < 3; ++a) {
    axes += fmt::format(" ({:.17g},{:.17g},{:.17g})", g.direction[a] * g.spacing[a], g.direction[3 + a] * g.spacing[a],
                        g.direction[6 + a] * g.spacing[a]);
  }
  write(dir + "/v.nrrd", fmt::format("NRRD0004\ntype: uint8\nencoding: raw\ndimension: 3\nsizes: {0} {0} {0}\n"
                                     "space: left-posterior-superior\nspace directions:{1}\n"
                                     "space origin: ({2:.17g},{3:.17g},{4:.17g})\n\n",
                                     kN, axes, g.origin[0], g.origin[1], g.origin[2]) +
                             voxelBytes());
  return {dir + "/v.nrrd", ""};
}

Input metaImageInput(const std::string& dir, const Geometry& g) {
  std::string matrix;
  for (const double v : g.direction) matrix += fmt::format(" {:.17g}", v);
  write(dir + "/v.mha",
        fmt::format("ObjectType = Image\nNDims = 3\nDimSize = {0} {0} {0}\nElementType = MET_UCHAR\n"
                    "ElementSpacing = {1:.17g} {2:.17g} {3:.17g}\nOffset = {4:.17g} {5:.17g} {6:.17g}\n"
                    "TransformMatrix ={7}\nElementDataFile = LOCAL\n",
                    kN, g.spacing[0], g.spacing[1], g.spacing[2], g.origin[0], g.origin[1], g.origin[2], matrix) +
            voxelBytes());
  return {dir + "/v.mha", ""};
}

// NIfTI-1: float32 fields, so the geometry is rounded to float32 (and must be finite there); the
// sform carries direction, spacing and origin, or (half the time) pixdim and the qform's offset.
Input niftiInput(const std::string& dir, const Geometry& g, bool sform) {
  std::string h(352, '\0');
  auto put = [&h]<typename T>(std::size_t at, T v) { std::memcpy(h.data() + at, &v, sizeof v); };
  put(0, std::int32_t{348});
  const std::int16_t dim[8] = {3, kN, kN, kN, 1, 1, 1, 1};
  for (std::size_t i = 0; i < 8; ++i) put(40 + 2 * i, dim[i]);
  put(70, std::int16_t{2});  // DT_UINT8
  put(72, std::int16_t{8});
  const float pixdim[8] = {
      1, static_cast<float>(g.spacing[0]), static_cast<float>(g.spacing[1]), static_cast<float>(g.spacing[2]), 1, 1, 1,
      1};
  for (std::size_t i = 0; i < 8; ++i) put(76 + 4 * i, pixdim[i]);
  put(108, 352.0f);
  put(252, static_cast<std::int16_t>(sform ? 0 : 1));
  put(254, static_cast<std::int16_t>(sform ? 1 : 0));
  for (std::size_t r = 0; r < 3; ++r) put(268 + 4 * r, static_cast<float>(g.origin[r]));
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 3; ++c)
      put(280 + 16 * r + 4 * c, static_cast<float>(g.direction[3 * r + c] * g.spacing[c]));
    put(280 + 16 * r + 12, static_cast<float>(g.origin[r]));
  }
  std::memcpy(h.data() + 344, "n+1", 4);
  write(dir + "/v.nii", h + voxelBytes());
  return {dir + "/v.nii", ""};
}

// DICOM: decimal strings of 16 characters at most, so 6 significant digits; axis-aligned rows and
// columns (a rounded rotation would not be orthonormal), slices along the normal.
Input dicomInput(const std::string& dir, const Geometry& g) {
  fs::create_directories(dir + "/series");
  const auto ball = ballVoxels();
  for (int k = 0; k < kN; ++k) {
    DcmFileFormat ff;
    DcmDataset* d = ff.getDataset();
    d->putAndInsertString(DCM_SOPClassUID, UID_CTImageStorage);
    d->putAndInsertString(DCM_SOPInstanceUID, fmt::format("1.2.826.0.1.3680043.99.7.{}", k + 1).c_str());
    d->putAndInsertString(DCM_StudyInstanceUID, "1.2.826.0.1.3680043.99.8");
    d->putAndInsertString(DCM_SeriesInstanceUID, "1.2.826.0.1.3680043.99.9");
    d->putAndInsertString(DCM_Modality, "CT");
    d->putAndInsertString(DCM_InstanceNumber, std::to_string(k + 1).c_str());
    const double z = g.origin[2] + k * g.spacing[2];
    d->putAndInsertString(DCM_ImagePositionPatient,
                          fmt::format("{:.6g}\\{:.6g}\\{:.6g}", g.origin[0], g.origin[1], z).c_str());
    d->putAndInsertString(DCM_ImageOrientationPatient, "1\\0\\0\\0\\1\\0");
    d->putAndInsertString(DCM_PixelSpacing, fmt::format("{:.6g}\\{:.6g}", g.spacing[1], g.spacing[0]).c_str());
    d->putAndInsertUint16(DCM_Rows, kN);
    d->putAndInsertUint16(DCM_Columns, kN);
    d->putAndInsertUint16(DCM_SamplesPerPixel, 1);
    d->putAndInsertString(DCM_PhotometricInterpretation, "MONOCHROME2");
    d->putAndInsertUint16(DCM_BitsAllocated, 16);
    d->putAndInsertUint16(DCM_BitsStored, 16);
    d->putAndInsertUint16(DCM_HighBit, 15);
    d->putAndInsertUint16(DCM_PixelRepresentation, 0);
    std::vector<Uint16> pixels(ball.begin() + k * kN * kN, ball.begin() + (k + 1) * kN * kN);
    d->putAndInsertUint16Array(DCM_PixelData, pixels.data(), static_cast<unsigned long>(pixels.size()));
    ff.saveFile(fmt::format("{}/series/{}.dcm", dir, k).c_str(), EXS_LittleEndianExplicit);
  }
  return {dir + "/series", ""};
}

Input stackInput(const std::string& dir, const Geometry& g) {
  fs::create_directories(dir + "/stack");
  const auto ball = ballVoxels();
  for (int k = 0; k < kN; ++k) {
    const std::string path = fmt::format("{}/stack/s{}.png", dir, k);
    auto out = OIIO::ImageOutput::create(path);
    OIIO::ImageSpec spec(kN, kN, 1, OIIO::TypeDesc::UINT8);
    out->open(path, spec);
    out->write_image(OIIO::TypeDesc::UINT8, ball.data() + k * kN * kN);
    out->close();
  }
  return {dir + "/stack", fmt::format("--spacing {:.17g},{:.17g},{:.17g}", g.spacing[0], g.spacing[1], g.spacing[2])};
}

// The vertices' coordinates (and normals) of a binary little-endian PLY of float properties.
std::vector<float> plyVertexFloats(const std::string& path) {
  const std::string data = slurp(path);
  const std::size_t end = data.find("end_header\n");
  if (end == std::string::npos) return {};
  std::istringstream header(data.substr(0, end));
  std::string line;
  std::uint64_t vertices = 0;
  int floats = 0;
  bool inVertex = false;
  while (std::getline(header, line)) {
    std::istringstream s(line);
    std::string word, a, b;
    s >> word >> a >> b;
    if (word == "element") {
      inVertex = a == "vertex";
      if (inVertex) vertices = std::stoull(b);
    } else if (word == "property" && inVertex) {
      EXPECT_EQ(a, "float") << line;
      ++floats;
    }
  }
  std::vector<float> out(vertices * static_cast<std::uint64_t>(floats));
  const std::size_t at = end + 11;
  if (at + out.size() * 4 > data.size()) {
    ADD_FAILURE() << path << " is shorter than its vertices";
    return {};
  }
  std::memcpy(out.data(), data.data() + at, out.size() * 4);
  return out;
}

struct Tally {
  int accepted = 0;
  int refused = 0;
};

// Runs the program on `input` with random options and judges the result.
void judge(const Input& input, const std::string& dir, Generator& gen, Tally& tally, const std::string& what) {
  const char* spaces[] = {"physical", "ras", "lps", "voxel"};
  std::string options = input.options;
  options += fmt::format(" --space {}", spaces[static_cast<int>(gen.uniform(0, 4)) % 4]);
  if (gen.chance(0.5)) options += " --normals";
  if (gen.chance(0.3)) options += " --close-boundary";
  const std::string iso = input.path.rfind("phantom:", 0) == 0 ? "" : " --iso 100";
  const CliResult r =
      runCli(fmt::format("extract '{}' {}{} -q -o {}/m.ply --report {}/r.json", input.path, options, iso, dir, dir));
  const std::string context = what + " " + options;
  if (r.exitCode == 1) {
    ++tally.refused;
    if (std::getenv("ISOSLAB_SHOW_REFUSALS") != nullptr) std::fprintf(stderr, "%s", r.err.c_str());
    EXPECT_EQ(r.err.rfind("isoslab: error: ", 0), 0u) << context << "\n" << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << context << " not one line: " << r.err;
    EXPECT_NE(r.err.find(input.path), std::string::npos) << context << " does not name the input: " << r.err;
    EXPECT_FALSE(fs::exists(dir + "/m.ply")) << context;
    EXPECT_FALSE(fs::exists(dir + "/r.json")) << context;
    return;
  }
  ASSERT_EQ(r.exitCode, 0) << context << "\n" << r.err;
  ++tally.accepted;
  for (const float v : plyVertexFloats(dir + "/m.ply")) {
    ASSERT_TRUE(std::isfinite(v)) << context << ": a vertex coordinate or normal is " << v;
  }
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  // nlohmann reads non-finite numbers written as null: the measures must all be numbers.
  for (const char* key : {"area", "volume"}) {
    ASSERT_TRUE(report.at(key).is_number()) << context << ": " << key << " is " << report.at(key);
    EXPECT_TRUE(std::isfinite(report.at(key).get<double>())) << context;
  }
  for (const char* key : {"bounds", "volume_bounds"}) {
    ASSERT_EQ(report.at(key).size(), 6u) << context << ": " << key << " is " << report.at(key);
    for (const auto& v : report.at(key)) {
      ASSERT_TRUE(v.is_number()) << context << ": " << key << " is " << report.at(key);
      EXPECT_TRUE(std::isfinite(v.get<double>())) << context;
    }
  }
  EXPECT_GT(report.at("triangles").get<std::int64_t>(), 0) << context;
  fs::remove(dir + "/m.ply");
  fs::remove(dir + "/r.json");
}

TEST(FloatLimits, EveryReaderRefusesOrWritesFiniteGeometry) {
  const std::uint64_t seed = 33;
  Generator gen(seed);
  Tally tally;
  constexpr int kTrials = 8;
  for (int t = 0; t < kTrials; ++t) {
    // Double fields (raw, phantom, NRRD, MetaImage) reach double's range; NIfTI-1 and DICOM's
    // 6-digit strings stay within float32's.
    const Geometry wide = gen.geometry(-300, 308, true);
    const Geometry narrow = gen.geometry(-44, 38.5, true);
    const std::string dir = tempDir();
    const auto sub = [&](const std::string& name) {
      const std::string d = dir + "/" + name;
      fs::create_directories(d);
      return d;
    };
    const std::string label = fmt::format("seed {} trial {}", seed, t);
    std::string d = sub("raw");
    judge(rawInput(d, wide), d, gen, tally, label + " raw");
    d = sub("phantom");
    judge(phantomInput(wide), d, gen, tally, label + " phantom");
    d = sub("nrrd");
    judge(nrrdInput(d, wide), d, gen, tally, label + " nrrd");
    d = sub("mha");
    judge(metaImageInput(d, wide), d, gen, tally, label + " mha");
    d = sub("nifti");
    judge(niftiInput(d, narrow, t % 2 == 0), d, gen, tally, label + " nifti");
    d = sub("dicom");
    Geometry axisAligned = narrow;
    axisAligned.direction = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    judge(dicomInput(d, axisAligned), d, gen, tally, label + " dicom");
    d = sub("stack");
    judge(stackInput(d, wide), d, gen, tally, label + " stack");
  }
  // Both sides of the rule were exercised.
  EXPECT_GT(tally.accepted, kTrials) << "accepted " << tally.accepted << ", refused " << tally.refused;
  EXPECT_GT(tally.refused, kTrials) << "accepted " << tally.accepted << ", refused " << tally.refused;
}

// The rule's edges, derived by hand: float32's largest value is 3.4028235e38.
TEST(FloatLimits, TheBoxAndTheStepAreJudgedAtFloat32sLimits) {
  const std::string dir = tempDir();
  write(dir + "/v.raw", voxelBytes());
  auto run = [&](const std::string& spacing) {
    return runCli(
        fmt::format("extract {}/v.raw --raw-dims {},{},{} --raw-type u8 --spacing {} --iso 100 -q -o {}/m.ply", dir, kN,
                    kN, kN, spacing, dir));
  };
  // 4 steps of 8.5e37 reach 3.4e38, inside float32; 4 of 8.6e37 reach 3.44e38, beyond it.
  CliResult r = run("8.5e37,1e37,1e37");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  fs::remove(dir + "/m.ply");
  r = run("8.6e37,1e37,1e37");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err, fmt::format("isoslab: error: {}/v.raw: --spacing 8.6e+37 along axis 0 puts the volume beyond "
                               "float32's range: its 5 points reach 3.44e+38 (the largest float32 is 3.4e+38), so the "
                               "mesh's coordinates would be infinite\n",
                               dir));
  // Axes are judged each in the coordinates it moves: x reaching 3.4e38 does not crowd y's steps.
  r = run("8.5e37,1,1");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  fs::remove(dir + "/m.ply");
  // A step of 1e-46 is below float32's smallest step (2^-149, 1.4e-45): the points would coincide.
  r = run("1e-46,1,1");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_NE(r.err.find("--spacing gives a step of 1e-46 along axis 0, below float32's resolution"), std::string::npos)
      << r.err;
  // 3e-45 is two of them: accepted (in the physical frame; --space voxel is never judged).
  r = run("3e-45,1,1");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  fs::remove(dir + "/m.ply");
  r = run("1e-46,1,1 --space voxel");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  fs::remove(dir + "/m.ply");
  r = run("8.6e37,1,1 --space voxel");
  EXPECT_EQ(r.exitCode, 0) << r.err;
  fs::remove(dir + "/m.ply");
  EXPECT_FALSE(fs::exists(dir + "/m.ply.tmp"));
}

}  // namespace
}  // namespace isoslab::testing
