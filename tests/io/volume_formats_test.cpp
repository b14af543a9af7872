// NRRD, MetaImage, NIfTI and image stacks: every variant of a phantom must give the raw path's
// mesh bit for bit (voxel space), geometry must land where the header says, and bad files must
// fail with one clear message.
#include <gtest/gtest.h>
#include <zlib.h>

#include <OpenImageIO/imageio.h>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "core/error.h"
#include "extract/frame.h"
#include "io/crop_source.h"
#include "io/open_source.h"
#include "io/pad_source.h"
#include "io/phantom.h"
#include "io/volume_writer.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

constexpr std::array<std::int64_t, 3> kDims{22, 20, 18};

std::string phantomFor(VoxelType t) {
  // 8-bit types hold the binary sphere; wider ones the distance field (values up to 1000).
  const bool narrow = t == VoxelType::kU8 || t == VoxelType::kI8;
  return fmt::format("phantom:sphere?n=22,20,18&r=6.3&field={}&type={}", narrow ? "binary" : "distance",
                     voxelTypeName(t));
}

double isoFor(VoxelType t) {
  return (t == VoxelType::kU8 || t == VoxelType::kI8) ? 50.0 : 937.0;
}

IndexedMesh voxelMesh(SliceSource& source, double iso) {
  ExtractOptions o;
  o.iso = iso;
  auto ex = makeExtractor(o, source.info(), LatticeFrame::voxel());
  MemoryMeshSink sink;
  runPipeline(source, *ex, sink, MeshHeader{});
  return sink.mesh();
}

IndexedMesh reference(VoxelType t) {
  auto p = PhantomSource::open(phantomFor(t));
  return voxelMesh(*p, isoFor(t));
}

IndexedMesh fromFile(const std::string& path, double iso, std::vector<std::string>* notes = nullptr) {
  auto s = openSource(path, {}, notes);
  return voxelMesh(*s, iso);
}

// The phantom's voxels of type t in the given byte order.
std::vector<char> voxels(VoxelType t, ByteOrder order) {
  auto p = PhantomSource::open(phantomFor(t));
  std::vector<float> slice(static_cast<std::size_t>(kDims[0] * kDims[1]));
  std::vector<std::byte> bytes(slice.size() * voxelSize(t));
  std::vector<char> all;
  while (p->readSlice(slice)) {
    convertFromFloat(slice, t, bytes);
    if (order != hostByteOrder()) {
      for (std::size_t i = 0; i < bytes.size(); i += voxelSize(t))
        std::reverse(bytes.begin() + static_cast<std::ptrdiff_t>(i),
                     bytes.begin() + static_cast<std::ptrdiff_t>(i + voxelSize(t)));
    }
    all.insert(all.end(), reinterpret_cast<char*>(bytes.data()), reinterpret_cast<char*>(bytes.data() + bytes.size()));
  }
  return all;
}

std::vector<char> gzipped(const std::vector<char>& data, int windowBits = 15 + 16) {
  z_stream z{};
  deflateInit2(&z, 6, Z_DEFLATED, windowBits, 8, Z_DEFAULT_STRATEGY);
  std::vector<char> out(deflateBound(&z, data.size()) + 64);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  deflate(&z, Z_FINISH);
  const std::size_t used = z.total_out;
  deflateEnd(&z);
  return std::vector<char>(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(used));
}

void writeFile(const std::string& path, const std::string& head, const std::vector<char>& data = {}) {
  std::ofstream f(path, std::ios::binary);
  f << head;
  f.write(data.data(), static_cast<std::streamsize>(data.size()));
}

const VoxelType kTypes[] = {VoxelType::kU8,  VoxelType::kI8,  VoxelType::kU16, VoxelType::kI16,
                            VoxelType::kU32, VoxelType::kI32, VoxelType::kF32, VoxelType::kF64};

TEST(VolumeFormats, EveryTypeOrderAndCompressionThroughTheWriters) {
  const std::string dir = testing::tempDir();
  for (VoxelType t : kTypes) {
    const IndexedMesh want = reference(t);
    ASSERT_GT(want.triangles.size(), 100u);
    for (const char* ext : {".nii", ".nii.gz", ".nrrd", ".mha"}) {
      for (bool compress : {false, true}) {
        for (ByteOrder order : {ByteOrder::kLittle, ByteOrder::kBig}) {
          auto p = PhantomSource::open(phantomFor(t));
          VolumeWriteOptions w;
          w.type = t;
          w.compress = compress;
          w.byteOrder = order;
          const std::string path = dir + "/v" + ext;
          writeVolume(*p, path, w);
          EXPECT_TRUE(fromFile(path, isoFor(t)) == want) << voxelTypeName(t) << ext << " compress " << compress;
        }
      }
    }
  }
}

// An outside reader of every writer: VTK 9.1's NIfTI, NRRD and MetaImage readers (Debian's
// python3-vtk9, tests/io/vtk_volume_readers.py) must read the files written here, compressed or
// not, in either byte order, as the raw voxels written beside them, with their dimensions and
// spacing.
TEST(VolumeFormats, VtkReadersReadTheWrittenFiles) {
  if (std::system("/usr/bin/python3 -c 'import vtkmodules.vtkIOImage' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "Debian's python3-vtk9 is absent";
  const std::string dir = testing::tempDir();
  std::ofstream manifest(dir + "/manifest.txt");
  const std::pair<VoxelType, const char*> types[] = {{VoxelType::kU8, "u1"},  {VoxelType::kI16, "i2"},
                                                     {VoxelType::kU16, "u2"}, {VoxelType::kI32, "i4"},
                                                     {VoxelType::kF32, "f4"}, {VoxelType::kF64, "f8"}};
  for (const auto& [t, dtype] : types) {
    const std::string spec = phantomFor(t) + "&spacing=0.5,0.75,1.25";
    const std::string reference = fmt::format("{}.raw", voxelTypeName(t));
    {
      auto p = PhantomSource::open(spec);
      VolumeWriteOptions w;
      w.type = t;
      writeVolume(*p, dir + "/" + reference, w);  // raw, little-endian
    }
    for (const char* ext : {".nii", ".nii.gz", ".nrrd", ".mha"}) {
      for (bool compress : {false, true}) {
        for (ByteOrder order : {ByteOrder::kLittle, ByteOrder::kBig}) {
          const std::string ending(ext);
          if (ending.starts_with(".nii") && (compress || order == ByteOrder::kBig)) continue;  // by name; host order
          auto p = PhantomSource::open(spec);
          VolumeWriteOptions w;
          w.type = t;
          w.compress = compress;
          w.byteOrder = order;
          const std::string name = fmt::format("{}_{}_{}{}", voxelTypeName(t), compress ? "z" : "raw",
                                               order == ByteOrder::kBig ? "be" : "le", ext);
          writeVolume(*p, dir + "/" + name, w);
          manifest << fmt::format("{} {} {} {} {} {} 0.5 0.75 1.25\n", name, dtype, reference, kDims[0], kDims[1],
                                  kDims[2]);
        }
      }
    }
  }
  manifest.close();
  const std::string cmd =
      "/usr/bin/python3 " ISOSLAB_TESTS_DIR "/io/vtk_volume_readers.py " + dir + " > " + dir + "/vtk.txt 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << testing::slurp(dir + "/vtk.txt");
}

TEST(VolumeFormats, DetachedListAndPatternData) {
  const std::string dir = testing::tempDir();
  const VoxelType t = VoxelType::kI16;
  const IndexedMesh want = reference(t);
  const auto big = voxels(t, ByteOrder::kBig);
  const auto little = voxels(t, ByteOrder::kLittle);
  const std::string sizes = fmt::format("{} {} {}", kDims[0], kDims[1], kDims[2]);
  // NRRD .nhdr with a detached gzip file, big-endian.
  writeFile(dir + "/d.raw.gz", "", gzipped(big));
  writeFile(dir + "/d.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: " + sizes +
                                 "\nendian: big\nencoding: gzip\nspacings: 1 1 1\ndata file: d.raw.gz\n");
  EXPECT_TRUE(fromFile(dir + "/d.nhdr", 937) == want);
  // NRRD with one file per slice: LIST and a pattern.
  const std::size_t slice = little.size() / static_cast<std::size_t>(kDims[2]);
  std::string list;
  for (int k = 0; k < kDims[2]; ++k) {
    writeFile(fmt::format("{}/s{:02d}.raw", dir, k), "",
              std::vector<char>(little.begin() + static_cast<std::ptrdiff_t>(slice * static_cast<std::size_t>(k)),
                                little.begin() + static_cast<std::ptrdiff_t>(slice * static_cast<std::size_t>(k + 1))));
    list += fmt::format("s{:02d}.raw\n", k);
  }
  writeFile(dir + "/list.nhdr", "NRRD0004\ntype: int16\ndimension: 3\nsizes: " + sizes +
                                    "\nendian: little\nencoding: raw\ndata file: LIST\n" + list);
  EXPECT_TRUE(fromFile(dir + "/list.nhdr", 937) == want);
  writeFile(dir + "/pattern.nhdr", "NRRD0004\ntype: int16\ndimension: 3\nsizes: " + sizes +
                                       "\nendian: little\nencoding: raw\ndata file: s%02d.raw 0 17 1\n");
  EXPECT_TRUE(fromFile(dir + "/pattern.nhdr", 937) == want);
  // MetaImage: .mhd with a detached zlib file, LIST and pattern.
  writeFile(dir + "/d.zraw", "", gzipped(big, 15));
  writeFile(
      dir + "/d.mhd",
      "ObjectType = Image\nNDims = 3\nDimSize = " + sizes +
          "\nElementType = MET_SHORT\nElementByteOrderMSB = True\nCompressedData = True\nElementDataFile = d.zraw\n");
  EXPECT_TRUE(fromFile(dir + "/d.mhd", 937) == want);
  writeFile(dir + "/list.mhd", "ObjectType = Image\nNDims = 3\nDimSize = " + sizes +
                                   "\nElementType = MET_SHORT\nElementDataFile = LIST\n" + list);
  EXPECT_TRUE(fromFile(dir + "/list.mhd", 937) == want);
  writeFile(dir + "/pattern.mhd", "ObjectType = Image\nNDims = 3\nDimSize = " + sizes +
                                      "\nElementType = MET_SHORT\nElementDataFile = s%02d.raw 0 17 1\n");
  EXPECT_TRUE(fromFile(dir + "/pattern.mhd", 937) == want);
}

// A NIfTI-2 header for the phantom's int16 voxels: pixdim spacing, optional qform and sform.
std::string nifti2(double qb, double qc, double qd, std::array<double, 3> qoffset, int qcode,
                   const std::array<std::array<double, 4>, 3>& srow, int scode) {
  std::string h(544, '\0');
  auto put = [&h](std::size_t at, auto v) { std::memcpy(h.data() + at, &v, sizeof v); };
  put(0, std::int32_t{540});
  std::memcpy(h.data() + 4, "n+2\0\r\n\032\n", 8);
  put(12, std::int16_t{4});
  put(14, std::int16_t{16});
  put(16, std::int64_t{3});
  for (std::size_t a = 0; a < 3; ++a) put(24 + 8 * a, static_cast<std::int64_t>(kDims[a]));
  put(104, 1.0);
  put(112, 0.8);
  put(120, 0.9);
  put(128, 1.5);
  put(168, std::int64_t{544});
  put(176, 2.0);   // scl_slope
  put(184, -5.0);  // scl_inter
  put(344, std::int32_t{qcode});
  put(348, std::int32_t{scode});
  put(352, qb);
  put(360, qc);
  put(368, qd);
  for (std::size_t a = 0; a < 3; ++a) put(376 + 8 * a, qoffset[a]);
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 4; ++c) put(400 + 32 * r + 8 * c, srow[r][c]);
  }
  return h;
}

TEST(VolumeFormats, Nifti2ScalingAndTheQformSformPrecedence) {
  const std::string dir = testing::tempDir();
  // Stored values s give s * 2 - 5; the phantom's values v are stored as (v + 5) / 2 for even v.
  auto p = PhantomSource::open("phantom:head?n=22,20,18&noise=0");
  std::vector<float> slice(static_cast<std::size_t>(kDims[0] * kDims[1]));
  std::vector<char> data;
  std::vector<float> expected;
  while (p->readSlice(slice)) {
    for (float v : slice) {
      const auto s = static_cast<std::int16_t>(std::lround((static_cast<double>(v) + 5) / 2));
      data.insert(data.end(), reinterpret_cast<const char*>(&s), reinterpret_cast<const char*>(&s) + 2);
      expected.push_back(static_cast<float>(s * 2.0 - 5.0));
    }
  }
  const std::array<std::array<double, 4>, 3> sform{{{0, -0.9, 0, 10}, {0.8, 0, 0, 20}, {0, 0, 1.5, 30}}};
  const std::array<std::array<double, 4>, 3> none{};
  // 90 degrees about z: quaternion (cos 45, 0, 0, sin 45).
  const double s45 = std::sqrt(0.5);
  writeFile(dir + "/s.nii", nifti2(0, 0, s45, {1, 2, 3}, 1, sform, 1), data);
  writeFile(dir + "/q.nii", nifti2(0, 0, s45, {1, 2, 3}, 1, none, 0), data);
  for (const char* name : {"/s.nii", "/q.nii"}) {
    auto source = openSource(dir + name, {});
    EXPECT_EQ(source->info().reader, "nifti2");
    std::vector<float> got(slice.size());
    ASSERT_TRUE(source->readSlice(got));
    EXPECT_TRUE(std::equal(got.begin(), got.end(), expected.begin())) << name;
    const LatticeFrame frame = LatticeFrame::physical(source->info());
    // Lattice point (i, j, k) in RAS from the header, then to LPS.
    for (const std::array<double, 3>& ijk : {std::array<double, 3>{0, 0, 0}, {3, 5, 7}, {21, 19, 17}}) {
      const auto lps = frame.map(ijk[0], ijk[1], ijk[2]);
      std::array<double, 3> ras{};
      if (std::string(name) == "/s.nii") {
        for (std::size_t r = 0; r < 3; ++r)
          ras[r] = sform[r][0] * ijk[0] + sform[r][1] * ijk[1] + sform[r][2] * ijk[2] + sform[r][3];
      } else {
        ras = {1 - 0.9 * ijk[1], 2 + 0.8 * ijk[0], 3 + 1.5 * ijk[2]};  // R(90 about z) * diag(0.8, 0.9, 1.5)
      }
      EXPECT_NEAR(lps[0], -ras[0], 1e-9) << name;
      EXPECT_NEAR(lps[1], -ras[1], 1e-9) << name;
      EXPECT_NEAR(lps[2], ras[2], 1e-9) << name;
    }
  }
}

using Affine = std::array<std::array<double, 4>, 3>;  // RAS rows: x y z = row . (i, j, k, 1)

// A NIfTI-1 file (348-byte header, the 4-byte extension flag, then the data) for the phantom's
// int16 voxels: pixdim 0.8 0.9 1.5 with qfac `qfac`, the qform quaternion (b, c, d) and offset, and
// the sform rows, each with its code.
void writeNifti1(const std::string& path, double qfac, const std::array<double, 3>& quatern,
                 const std::array<double, 3>& qoffset, int qcode, const Affine& srow, int scode) {
  std::string h(352, '\0');
  auto put = [&h](std::size_t at, auto v) { std::memcpy(h.data() + at, &v, sizeof v); };
  put(0, std::int32_t{348});
  put(40, std::int16_t{3});
  for (std::size_t a = 0; a < 3; ++a) put(42 + 2 * a, static_cast<std::int16_t>(kDims[a]));
  put(70, std::int16_t{4});  // DT_INT16
  put(72, std::int16_t{16});
  const float pixdim[4] = {static_cast<float>(qfac), 0.8f, 0.9f, 1.5f};
  for (std::size_t a = 0; a < 4; ++a) put(76 + 4 * a, pixdim[a]);
  put(108, 352.0f);
  put(252, static_cast<std::int16_t>(qcode));
  put(254, static_cast<std::int16_t>(scode));
  for (std::size_t a = 0; a < 3; ++a) put(256 + 4 * a, static_cast<float>(quatern[a]));
  for (std::size_t a = 0; a < 3; ++a) put(268 + 4 * a, static_cast<float>(qoffset[a]));
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 4; ++c) put(280 + 16 * r + 4 * c, static_cast<float>(srow[r][c]));
  }
  std::memcpy(h.data() + 344, "n+1\0", 4);
  writeFile(path, h, voxels(VoxelType::kI16, ByteOrder::kLittle));
}

// The qform of these tests: 30 degrees about x, quaternion (cos 15, sin 15, 0, 0), with qfac -1
// and offset (-5, 7, 11). Worked by hand: R = [1 0 0; 0 cos30 -sin30; 0 sin30 cos30], and the
// axes are R's columns times (0.8, 0.9, -1.5).
constexpr double kDeg = std::numbers::pi / 180;
const std::array<double, 3> kQuatern{std::sin(15 * kDeg), 0, 0};
const std::array<double, 3> kQoffset{-5, 7, 11};
const Affine kQform{{{0.8, 0, 0, -5},
                     {0, 0.9 * std::cos(30 * kDeg), 1.5 * std::sin(30 * kDeg), 7},
                     {0, 0.9 * std::sin(30 * kDeg), -1.5 * std::cos(30 * kDeg), 11}}};

// The largest distance between two affines over the phantom's eight corner voxels.
double cornerDistance(const Affine& a, const Affine& b) {
  double worst = 0;
  for (int corner = 0; corner < 8; ++corner) {
    double sum = 0;
    for (std::size_t r = 0; r < 3; ++r) {
      double d = a[r][3] - b[r][3];
      for (std::size_t c = 0; c < 3; ++c) {
        const double index = (corner >> c) & 1 ? static_cast<double>(kDims[c] - 1) : 0.0;
        d += index * (a[r][c] - b[r][c]);
      }
      sum += d * d;
    }
    worst = std::max(worst, std::sqrt(sum));
  }
  return worst;
}

// The VolumeInfo of `affine` (RAS) in LPS: spacing, unit direction columns, origin.
void expectGeometry(const VolumeInfo& info, const Affine& affine, const std::string& what) {
  const double flip[3] = {-1, -1, 1};
  for (std::size_t a = 0; a < 3; ++a) {
    const double length = std::hypot(affine[0][a], affine[1][a], affine[2][a]);
    EXPECT_NEAR(info.spacing[a], length, 1e-6) << what << " axis " << a;
    for (std::size_t r = 0; r < 3; ++r) {
      EXPECT_NEAR(info.direction[3 * r + a], flip[r] * affine[r][a] / length, 1e-6) << what << " " << r << a;
    }
    EXPECT_NEAR(info.origin[a], flip[a] * affine[a][3], 1e-5) << what;
  }
  const LatticeFrame frame = LatticeFrame::physical(info);
  const auto p = frame.map(21, 19, 17);
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_NEAR(p[r], flip[r] * (affine[r][0] * 21 + affine[r][1] * 19 + affine[r][2] * 17 + affine[r][3]), 1e-4)
        << what;
  }
}

TEST(VolumeFormats, NiftiShearedSformWarnsAndQformGivesTheRigidGeometry) {
  const std::string dir = testing::tempDir();
  const std::string path = dir + "/tilt.nii";
  // As dcm2niix writes a tilted-gantry series without tilt correction: the slice axis leans 20
  // degrees towards j, so the sform's third column is not perpendicular to the second.
  const Affine sheared{
      {{0.8, 0, 0, 10}, {0, 0.9, 1.5 * std::sin(20 * kDeg), 20}, {0, 0, 1.5 * std::cos(20 * kDeg), 30}}};
  writeNifti1(path, -1, kQuatern, kQoffset, 1, sheared, 1);
  const std::string what = fmt::format(
      "{}: the sform is not orthogonal: its axes are sheared by up to 20 degrees (a tilted-gantry series gives "
      "this), and the rigid qform places the volume's corners up to {:.3g} mm away",
      path, cornerDistance(sheared, kQform));
  {
    std::vector<std::string> notes;
    auto source = openSource(path, {}, &notes);
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_EQ(notes.front(), "warning: " + what +
                                 "; isoslab applies the sform as it is, shear included (`nifti_xform` qform takes "
                                 "the rigid qform)");
    expectGeometry(source->info(), sheared, "sform");
    // The direction keeps the shear: unit columns, 70 degrees apart.
    const auto& d = source->info().direction;
    EXPECT_NEAR(d[1] * d[2] + d[4] * d[5] + d[7] * d[8], std::cos(70 * kDeg), 1e-6);
    EXPECT_TRUE(voxelMesh(*source, 937) == reference(VoxelType::kI16));
  }
  SourceOptions qform;
  qform.niftiXform = NiftiXform::kQform;
  {
    std::vector<std::string> notes;
    auto source = openSource(path, qform, &notes);
    ASSERT_EQ(notes.size(), 1u);
    EXPECT_EQ(notes.front(), "warning: " + what + "; isoslab uses the qform, as `nifti_xform` asks");
    expectGeometry(source->info(), kQform, "qform");
    const VolumeInfo& info = source->info();
    // By hand, in LPS: origin (5, -7, 11); columns (-1, 0, 0), (0, -cos30, sin30), (0, -sin30, -cos30).
    const double c30 = std::cos(30 * kDeg), s30 = std::sin(30 * kDeg);
    const std::array<double, 9> direction{-1, 0, 0, 0, -c30, -s30, 0, s30, -c30};
    for (std::size_t n = 0; n < 9; ++n) EXPECT_NEAR(info.direction[n], direction[n], 1e-6) << n;
    EXPECT_EQ(info.origin, (std::array<double, 3>{5, -7, 11}));
    for (std::size_t a = 0; a < 3; ++a) EXPECT_NEAR(info.spacing[a], (std::array{0.8, 0.9, 1.5})[a], 1e-6);
  }
  // Through the program: info and extract print the warning; --nifti-xform qform moves the origin.
  const auto info = testing::runCli("info " + path);
  ASSERT_EQ(info.exitCode, 0) << info.err;
  EXPECT_NE(info.out.find("origin     -10 -20 30\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("\nwarning    " + what + "; isoslab applies the sform as it is"), std::string::npos)
      << info.out;
  const auto rigid = testing::runCli("info " + path + " --nifti-xform qform");
  ASSERT_EQ(rigid.exitCode, 0) << rigid.err;
  EXPECT_NE(rigid.out.find("origin     5 -7 11\n"), std::string::npos) << rigid.out;
  const auto extract = testing::runCli("extract " + path + " --nifti-xform qform --iso 937 -q -o " + dir + "/m.ply");
  ASSERT_EQ(extract.exitCode, 0) << extract.err;
  EXPECT_EQ(extract.err, "isoslab: warning: " + what + "; isoslab uses the qform, as --nifti-xform asks\n");
  const auto bad = testing::runCli("info " + path + " --nifti-xform rigid");
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_NE(bad.err.find("--nifti-xform"), std::string::npos) << bad.err;
}

TEST(VolumeFormats, NiftiSformAndQformThatDisagreeWarnAndAMissingTransformIsAnError) {
  const std::string dir = testing::tempDir();
  // The qform's axes, moved by (3, 4, 0): 5 mm apart everywhere.
  Affine moved = kQform;
  moved[0][3] += 3;
  moved[1][3] += 4;
  writeNifti1(dir + "/moved.nii", -1, kQuatern, kQoffset, 1, moved, 1);
  std::vector<std::string> notes;
  auto source = openSource(dir + "/moved.nii", {}, &notes);
  EXPECT_EQ(notes, std::vector<std::string>{"warning: " + dir +
                                            "/moved.nii: the sform and the qform disagree: they place the volume's "
                                            "corners up to 5 mm apart; isoslab uses the sform (`nifti_xform` qform "
                                            "takes the qform)"});
  expectGeometry(source->info(), moved, "moved sform");
  // Agreeing transforms (float32 rounding apart) say nothing.
  writeNifti1(dir + "/same.nii", -1, kQuatern, kQoffset, 2, kQform, 1);
  notes.clear();
  openSource(dir + "/same.nii", {}, &notes);
  EXPECT_TRUE(notes.empty()) << notes.front();
  // A transform asked for but absent.
  writeNifti1(dir + "/sonly.nii", 1, {0, 0, 0}, {0, 0, 0}, 0, moved, 1);
  writeNifti1(dir + "/qonly.nii", -1, kQuatern, kQoffset, 1, Affine{}, 0);
  SourceOptions qform;
  qform.niftiXform = NiftiXform::kQform;
  SourceOptions sform;
  sform.niftiXform = NiftiXform::kSform;
  auto errorOf = [](const std::string& path, const SourceOptions& options) {
    try {
      openSource(path, options);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorOf(dir + "/sonly.nii", qform),
            dir + "/sonly.nii: `nifti_xform` qform: the file has no qform (qform_code is 0)");
  EXPECT_EQ(errorOf(dir + "/qonly.nii", sform),
            dir + "/qonly.nii: `nifti_xform` sform: the file has no sform (sform_code is 0)");
  expectGeometry(openSource(dir + "/qonly.nii", {})->info(), kQform, "qform by default");
  const auto r = testing::runCli("info " + dir + "/sonly.nii --nifti-xform qform");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err,
            "isoslab: error: " + dir + "/sonly.nii: --nifti-xform qform: the file has no qform (qform_code is 0)\n");
}

TEST(VolumeFormats, NrrdDirectionsAndOriginPlaceTheVertices) {
  const std::string dir = testing::tempDir();
  const auto data = voxels(VoxelType::kI16, ByteOrder::kLittle);
  const std::string sizes = fmt::format("{} {} {}", kDims[0], kDims[1], kDims[2]);
  writeFile(dir + "/r.nrrd",
            "NRRD0004\ntype: short\ndimension: 3\nsizes: " + sizes +
                "\nspace: left-posterior-superior\nspace directions: (0,0.5,0) (-0.7,0,0) (0,0.2,1.1)\n"
                "space origin: (5,-6,7.5)\nendian: little\nencoding: raw\n\n",
            data);
  auto source = openSource(dir + "/r.nrrd", {});
  const testing::Extraction x = testing::extract(*source, Method::kMarchingCubes, 937);
  const IndexedMesh voxel = reference(VoxelType::kI16);
  ASSERT_EQ(x.mesh.positions.size(), voxel.positions.size());
  double worst = 0;
  for (std::size_t v = 0; v < voxel.positions.size(); ++v) {
    const Vec3f& q = voxel.positions[v];
    const double want[3] = {5 - 0.7 * q.y, -6 + 0.5 * q.x + 0.2 * q.z, 7.5 + 1.1 * q.z};
    const Vec3f& p = x.mesh.positions[v];
    worst = std::max({worst, std::abs(p.x - want[0]), std::abs(p.y - want[1]), std::abs(p.z - want[2])});
  }
  EXPECT_LT(worst, 1e-5);  // float32 output
  EXPECT_EQ(source->info().frame, "lps");
}

// Image stacks written with OpenImageIO.
void writeImages(const std::string& dir, const std::string& pattern, OIIO::TypeDesc type, int channels,
                 bool multipage) {
  auto p = PhantomSource::open(phantomFor(VoxelType::kU16));
  std::vector<float> slice(static_cast<std::size_t>(kDims[0] * kDims[1]));
  std::unique_ptr<OIIO::ImageOutput> out;
  for (int k = 0; p->readSlice(slice); ++k) {
    std::vector<std::uint16_t> px;
    for (float v : slice) {
      for (int c = 0; c < channels; ++c) px.push_back(static_cast<std::uint16_t>(std::lround(v)));
    }
    OIIO::ImageSpec spec(static_cast<int>(kDims[0]), static_cast<int>(kDims[1]), channels, type);
    const std::string path = multipage ? dir + "/" + pattern : dir + "/" + fmt::format(fmt::runtime(pattern), k);
    if (!multipage || k == 0) {
      out = OIIO::ImageOutput::create(path);
      ASSERT_TRUE(out && out->open(path, spec)) << OIIO::geterror();
    } else {
      ASSERT_TRUE(out->open(path, spec, OIIO::ImageOutput::AppendSubimage)) << out->geterror();
    }
    if (type == OIIO::TypeDesc::FLOAT) {
      // Float pixels are written as the values themselves (integers would be normalised).
      std::vector<float> f(px.begin(), px.end());
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, f.data()));
    } else {
      ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT16, px.data()));
    }
    if (!multipage) out->close();
  }
  if (multipage) out->close();
}

TEST(ImageStacks, TiffPngMultiPageAndColourGiveTheRawMesh) {
  const IndexedMesh want = reference(VoxelType::kU16);
  struct Case {
    const char* pattern;
    OIIO::TypeDesc type;
    int channels;
    bool multipage;
    const char* input;
  };
  const Case cases[] = {{"slice{:03d}.tif", OIIO::TypeDesc::UINT16, 1, false, ""},
                        {"slice{:03d}.png", OIIO::TypeDesc::UINT16, 1, false, "slice%03d.png"},
                        {"grey{:03d}.png", OIIO::TypeDesc::UINT16, 3, false, "grey*.png"},
                        {"stack.tif", OIIO::TypeDesc::UINT16, 1, true, "stack.tif"},
                        {"float{:02d}.tif", OIIO::TypeDesc::FLOAT, 1, false, ""}};
  for (const Case& c : cases) {
    const std::string dir = testing::tempDir();
    writeImages(dir, c.pattern, c.type, c.channels, c.multipage);
    const std::string input = std::string(c.input).empty() ? dir : dir + "/" + c.input;
    std::vector<std::string> notes;
    EXPECT_TRUE(fromFile(input, 937, &notes) == want) << c.pattern;
    ASSERT_FALSE(notes.empty());
    EXPECT_EQ(notes.front().rfind("image stack of 18 slices, 22x20", 0), 0u) << notes.front();
  }
}

std::string openError(const std::string& input) {
  try {
    fromFile(input, 1);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(VolumeFormats, BadFilesGiveOneClearMessage) {
  const std::string dir = testing::tempDir();
  auto p = PhantomSource::open(phantomFor(VoxelType::kI16));
  VolumeWriteOptions w;
  w.type = VoxelType::kI16;
  writeVolume(*p, dir + "/t.nii.gz", w);
  fs::resize_file(dir + "/t.nii.gz", fs::file_size(dir + "/t.nii.gz") / 2);
  EXPECT_EQ(openError(dir + "/t.nii.gz").rfind(dir + "/t.nii.gz: the compressed data is truncated after ", 0), 0u)
      << openError(dir + "/t.nii.gz");
  const auto data = voxels(VoxelType::kI16, ByteOrder::kLittle);
  const std::string sizes = fmt::format("{} {} {}", kDims[0], kDims[1], kDims[2]);
  writeFile(dir + "/short.raw", "", std::vector<char>(data.begin(), data.begin() + 1000));
  writeFile(dir + "/short.nhdr", "NRRD0004\ntype: short\ndimension: 3\nsizes: " + sizes +
                                     "\nendian: little\nencoding: raw\ndata file: short.raw\n");
  EXPECT_EQ(openError(dir + "/short.nhdr"),
            dir + "/short.raw: holds 1000 bytes, but dims 22x20x18 of i16 after a 0-byte header need 15840");
  writeFile(dir + "/bz.nrrd", "NRRD0004\ntype: short\ndimension: 3\nsizes: " + sizes + "\nencoding: bzip2\n\n");
  EXPECT_EQ(openError(dir + "/bz.nrrd"), dir + "/bz.nrrd: NRRD encoding 'bzip2' is not supported (raw or gzip)");
  writeFile(dir + "/bad.nii", std::string(400, '\x07'));
  EXPECT_EQ(openError(dir + "/bad.nii"),
            dir + "/bad.nii: not a NIfTI file: sizeof_hdr is 117901063, not 348 (NIfTI-1) or 540 (NIfTI-2)");
  EXPECT_EQ(openError(dir + "/none%03d.png"),
            dir + "/none%03d.png: the pattern matches no file (tried indices 0 and 1)");
  EXPECT_EQ(openError(dir + "/none*.png"), dir + "/none*.png: the pattern matches no file");
  // One slice of another size.
  const std::string stack = testing::tempDir();
  writeImages(stack, "s{:02d}.png", OIIO::TypeDesc::UINT16, 1, false);
  {
    OIIO::ImageSpec spec(8, 8, 1, OIIO::TypeDesc::UINT16);
    std::vector<std::uint16_t> px(64, 0);
    auto out = OIIO::ImageOutput::create(stack + "/s05.png");
    out->open(stack + "/s05.png", spec);
    out->write_image(OIIO::TypeDesc::UINT16, px.data());
    out->close();
  }
  EXPECT_EQ(openError(stack),
            stack + "/s05.png: 8x8 with 1 channels, but " + stack + "/s00.png is 22x20 with 1 channels");
}

TEST(ImageStacks, RealPaletteTiffStackMatchesTheRawHead) {
  const std::string tiff = testing::sharedData("cthead8-tiff");
  const std::string raw = testing::sharedData("cthead");
  if (tiff.empty() || raw.empty()) GTEST_SKIP() << "../shared/data/cthead8-tiff or cthead is absent";
  SourceOptions t;
  t.spacing = std::array<double, 3>{1, 1, 2};
  auto stack = openSource(tiff, t);
  EXPECT_EQ(stack->info().dims, (std::array<std::int64_t, 3>{256, 256, 99}));
  const testing::Extraction a = testing::extract(*stack, Method::kMarchingCubes, 40);
  EXPECT_GT(a.stats.triangles, 300000u);
  EXPECT_EQ(a.stats.interiorBoundaryEdges, 0u);
  SourceOptions r;
  r.raw = RawOptions{};
  r.raw->dims = {256, 256, 0};
  r.raw->type = VoxelType::kU16;
  r.raw->byteOrder = ByteOrder::kBig;
  r.raw->spacing = {1, 1, 2};
  auto slices = openSource(raw, r);
  // The stack is requantised to 8 bits (x 255 / 3272): iso 40 there is about 513 here.
  const testing::Extraction b = testing::extract(*slices, Method::kMarchingCubes, 513);
  for (int axis : {0, 1, 3, 4}) {
    EXPECT_NEAR(a.stats.bounds[static_cast<std::size_t>(axis)], b.stats.bounds[static_cast<std::size_t>(axis)], 2.0)
        << axis;
  }
  EXPECT_NEAR(a.stats.bounds[2], b.stats.bounds[2], 2.0 * 2);
}

// Compressed data is read to the end of its stream, where zlib checks the CRC-32 and the length:
// valid .nrrd (gzip), .mha (zlib) and .nii.gz files read, and one flipped trailer byte is an error.
TEST(VolumeFormats, CompressedStreamsAreCheckedAtTheirEnd) {
  const std::string dir = testing::tempDir();
  std::vector<char> data(4 * 4 * 4);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>(i);
  const std::string nrrd = "NRRD0004\ntype: uint8\nencoding: gzip\ndimension: 3\nsizes: 4 4 4\n\n";
  writeFile(dir + "/ok.nrrd", nrrd, gzipped(data));
  std::vector<char> bad = gzipped(data);
  bad[bad.size() - 8] = static_cast<char>(bad[bad.size() - 8] ^ 1);  // the CRC-32
  writeFile(dir + "/bad.nrrd", nrrd, bad);
  const std::string mha =
      "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n"
      "CompressedData = True\nElementDataFile = LOCAL\n";
  writeFile(dir + "/ok.mha", mha, gzipped(data, 15));
  writeVolume(*PhantomSource::open("phantom:sphere?n=6,5,4"), dir + "/ok.nii.gz", VolumeWriteOptions{});
  for (const char* name : {"/ok.nrrd", "/ok.mha", "/ok.nii.gz"}) {
    auto source = openSource(dir + name, {});
    std::vector<float> slice(static_cast<std::size_t>(source->info().sliceVoxels()));
    int slices = 0;
    while (source->readSlice(slice)) ++slices;
    EXPECT_EQ(slices, source->info().dims[2]) << name;
    if (std::string(name) == "/ok.nrrd") {
      EXPECT_EQ(slice.back(), 63.0F);
    }
  }
  auto source = openSource(dir + "/bad.nrrd", {});
  std::vector<float> slice(16);
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(source->readSlice(slice));
  try {
    source->readSlice(slice);
    ADD_FAILURE() << "a bad CRC was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir + "/bad.nrrd: corrupt gzip data: incorrect data check");
  }
}

// Issue 33, class 7: fetchSlice reads a slice's bytes ahead of readSlice, once; a fetched slice is
// the one read or skipped next, through CropSource and PadSource too; and a compressed stream that
// ends early fails in fetchSlice, before any caller has sized a slice buffer.
TEST(VolumeFormats, FetchedSlicesAreTheOnesReadOrSkippedNext) {
  const std::string dir = testing::tempDir();
  std::vector<char> data(4 * 4 * 5);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>(i / 16);  // slice k holds k
  const std::string nrrd = "NRRD0004\ntype: uint8\nencoding: gzip\ndimension: 3\nsizes: 4 4 5\n\n";
  writeFile(dir + "/v.nrrd", nrrd, gzipped(data));
  writeFile(dir + "/plain.nrrd", "NRRD0004\ntype: uint8\nencoding: raw\ndimension: 3\nsizes: 4 4 5\n\n", data);
  for (const char* name : {"/v.nrrd", "/plain.nrrd"}) {
    auto source = openSource(dir + name, {});
    std::vector<float> slice(16, -1.0F);
    EXPECT_TRUE(source->fetchSlice());
    EXPECT_TRUE(source->fetchSlice());
    ASSERT_TRUE(source->readSlice(slice));
    EXPECT_EQ(slice.front(), 0.0F) << name;
    EXPECT_TRUE(source->fetchSlice());
    EXPECT_EQ(source->skipSlices(2), 2) << name;  // the fetched slice 1, and slice 2
    ASSERT_TRUE(readSliceInto(*source, slice));
    EXPECT_EQ(slice.back(), 3.0F) << name;
    ASSERT_TRUE(source->fetchSlice());
    ASSERT_TRUE(source->readSlice(slice));
    EXPECT_EQ(slice.back(), 4.0F) << name;
    EXPECT_FALSE(source->fetchSlice());
    EXPECT_FALSE(source->readSlice(slice));
  }
  // Cropped to slices 1..3 and padded: NaN, 1, 2, 3, NaN.
  auto padded = std::make_unique<PadSource>(
      std::make_unique<CropSource>(openSource(dir + "/v.nrrd", {}), LatticeBox{{0, 0, 1}, {3, 3, 3}}));
  std::vector<float> slice;
  std::vector<float> centres;
  while (readSliceInto(*padded, slice)) centres.push_back(slice[slice.size() / 2 + 2]);
  ASSERT_EQ(centres.size(), 5u);
  EXPECT_TRUE(std::isnan(centres[0]));
  EXPECT_EQ(centres[1], 1.0F);
  EXPECT_EQ(centres[3], 3.0F);
  EXPECT_TRUE(std::isnan(centres[4]));

  // 16 MiB of zeros where a 10000 x 10000 slice of floats needs 400 MB: fetchSlice says where the
  // data ended.
  writeFile(dir + "/cut.nrrd", "NRRD0004\ntype: float\nencoding: gzip\ndimension: 3\nsizes: 10000 10000 3\n\n",
            gzipped(std::vector<char>(std::size_t{1} << 24)));
  auto cut = openSource(dir + "/cut.nrrd", {});
  try {
    cut->fetchSlice();
    ADD_FAILURE() << "a stream that ends early was fetched";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir + "/cut.nrrd: data ends after 16777216 of 1200000000 bytes");
  }
}

// The geometry check is shared by every source, and legitimate geometry passes it: a sheared but
// non-singular frame, a left-handed one and tiny spacing.
TEST(VolumeFormats, TheGeometryCheckAcceptsShearAndHandednessButNotDegeneracy) {
  VolumeInfo info;
  info.dims = {4, 4, 4};
  info.spacing = {1e-3, 1, 5};
  info.direction = {1, 0, 0.34, 0, -1, 0, 0, 0, 0.94};
  EXPECT_NO_THROW(validateGeometry(info, "v"));
  info.spacing[1] = std::nan("");
  EXPECT_THROW(validateGeometry(info, "v"), Error);
  try {
    validateGeometry(info, "v");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "v: spacing nan along axis 1 is not finite");
  }
  info.spacing[1] = 1;
  info.direction = {1, 0, 1, 0, 1, 1, 0, 0, 0};  // columns in the plane z = 0
  EXPECT_THROW(validateGeometry(info, "v"), Error);
}

}  // namespace
}  // namespace isoslab
