// CropSource (isoslab extract --roi) and SliceSource::skipSlices: a box of a volume gives the mesh
// of a cropped copy of it, whatever reader it comes through; readers that can seek skip the slices
// before the box without reading them (bytes counted in /proc/self/io), per-slice files outside
// the box are never opened (they are deleted before the run), and the slices after the box are
// never asked for.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "io/crop_source.h"
#include "io/dicom_series.h"
#include "io/open_source.h"
#include "io/phantom.h"
#include "io/volume_writer.h"
#include "test_support.h"

namespace isoslab {
namespace {

namespace fs = std::filesystem;

// Counts what is asked of the source it wraps. With `forwardSkips` false it skips the default
// way, reading every skipped slice, as a reader without its own skipSlices() does.
class CountingSource final : public SliceSource {
 public:
  explicit CountingSource(std::unique_ptr<SliceSource> inner, bool forwardSkips = true)
      : inner_(std::move(inner)), forwardSkips_(forwardSkips) {}
  const VolumeInfo& info() const noexcept override { return inner_->info(); }
  bool readSlice(std::span<float> slice) override {
    if (!inner_->readSlice(slice)) return false;
    ++reads_;
    return true;
  }
  std::int64_t skipSlices(std::int64_t n) override {
    const std::int64_t k = forwardSkips_ ? inner_->skipSlices(n) : SliceSource::skipSlices(n);
    skipped_ += k;
    return k;
  }
  std::vector<std::string> warnings() override { return inner_->warnings(); }
  std::int64_t reads() const { return reads_; }
  std::int64_t skipped() const { return skipped_; }

 private:
  std::unique_ptr<SliceSource> inner_;
  bool forwardSkips_;
  std::int64_t reads_ = 0;
  std::int64_t skipped_ = 0;
};

constexpr std::array<std::int64_t, 3> kDims{128, 96, 64};
const LatticeBox kBox{{10, 20, 30}, {100, 80, 39}};  // 10 slices of 64

// A ball inside the box; every value outside the box is NaN, so that any of them reaching the mesh
// would show (a NaN corner is outside, and its edges' vertices would move).
float field(std::int64_t i, std::int64_t j, std::int64_t k) {
  for (std::size_t a = 0; a < 3; ++a) {
    const std::int64_t v = a == 0 ? i : a == 1 ? j : k;
    if (v < kBox.lo[a] || v > kBox.hi[a]) return std::numeric_limits<float>::quiet_NaN();
  }
  const auto x = static_cast<double>(i) - 50.5, y = static_cast<double>(j) - 47.25, z = static_cast<double>(k) - 35;
  return static_cast<float>(20.0 - std::hypot(x, y, z * 4));
}

testing::VectorSource volume() {
  return testing::VectorSource(kDims, field);
}

// Writes the volume with isoslab's own writer (f32); the format comes from the name.
std::string writeVolumeFile(const std::string& path, bool compress = false) {
  testing::VectorSource v = volume();
  VolumeWriteOptions w;
  w.type = VoxelType::kF32;
  w.compress = compress;
  writeVolume(v, path, w);
  return path;
}

SourceOptions rawOptions() {
  SourceOptions o;
  o.raw = RawOptions{};
  o.raw->dims = kDims;
  o.raw->type = VoxelType::kF32;
  o.raw->spacing = {0.5, 0.75, 2};
  return o;
}

// The mesh of kBox cut from `source` equals the mesh of a cropped copy with the same geometry.
void expectCropMatchesCopy(std::unique_ptr<SliceSource> source, Method method = Method::kMarchingCubes) {
  CropSource crop(std::move(source), kBox);
  EXPECT_EQ(crop.info().dims, kBox.dims());
  testing::VectorSource copy(kBox.dims(), [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return field(i + kBox.lo[0], j + kBox.lo[1], k + kBox.lo[2]);
  });
  copy.mutableInfo() = crop.info();
  const testing::Extraction a = testing::extract(crop, method, 0, true);
  const testing::Extraction b = testing::extract(copy, method, 0, true);
  EXPECT_GT(a.stats.triangles, 1000u);
  EXPECT_TRUE(a.mesh == b.mesh) << methodName(method);
  EXPECT_EQ(a.stats.interiorBoundaryEdges, 0u);
  for (const Vec3f& p : a.mesh.positions) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  EXPECT_TRUE(crop.warnings().empty()) << crop.warnings().front();
}

// Bytes this process has read through read(2) and friends so far, or -1 where Linux does not say.
std::int64_t bytesRead() {
  std::ifstream io("/proc/self/io");
  for (std::string key; io >> key;) {
    std::int64_t value = 0;
    io >> value;
    if (key == "rchar:") return value;
  }
  return -1;
}

TEST(CropSource, EveryMethodGivesTheCroppedCopysMesh) {
  for (Method m : testing::kAllMethods) {
    auto v = std::make_unique<testing::VectorSource>(kDims, field);
    v->mutableInfo().origin = {-3.25, 7, 11.5};
    v->mutableInfo().spacing = {0.5, 0.75, 2};
    expectCropMatchesCopy(std::move(v), m);
  }
}

TEST(CropSource, KeepsThePhysicalPlaceAndIndicesStartAtTheBoxCorner) {
  auto v = std::make_unique<testing::VectorSource>(kDims, field);
  VolumeInfo& in = v->mutableInfo();
  in.origin = {1, 2, 3};
  in.spacing = {0.5, 0.75, 2};
  in.sliceOrigins.resize(static_cast<std::size_t>(kDims[2]));
  for (std::size_t k = 0; k < in.sliceOrigins.size(); ++k)
    in.sliceOrigins[k] = {1 + 0.1 * static_cast<double>(k), 2, 3 + 2.0 * static_cast<double>(k)};
  CropSource crop(std::move(v), kBox);
  const VolumeInfo& out = crop.info();  // `in` still names the source, which the crop owns
  EXPECT_EQ(out.origin, (std::array<double, 3>{1 + 0.5 * 10, 2 + 0.75 * 20, 3 + 2.0 * 30}));
  ASSERT_EQ(out.sliceOrigins.size(), 10u);
  EXPECT_EQ(out.sliceOrigins[0], (std::array<double, 3>{in.sliceOrigins[30][0] + 5, 2 + 15, in.sliceOrigins[30][2]}));
  EXPECT_EQ(out.sliceOrigins[9][2], in.sliceOrigins[39][2]);
}

TEST(CropSource, ClippingAndItsErrorsNameTheInputAndTheBox) {
  bool clipped = false;
  EXPECT_EQ(clipLatticeBox({{-5, 0, 3}, {200, 95, 9}}, kDims, "v.raw", &clipped),
            (LatticeBox{{0, 0, 3}, {127, 95, 9}}));
  EXPECT_TRUE(clipped);
  EXPECT_EQ(clipLatticeBox(kBox, kDims, "v.raw", &clipped), kBox);
  EXPECT_FALSE(clipped);
  auto message = [](const LatticeBox& box) {
    try {
      clipLatticeBox(box, kDims, "v.raw");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message({{0, 0, 64}, {10, 10, 70}}),
            "v.raw: `roi` 0,0,64,10,10,70 lies outside the volume's 128x96x64 lattice points (indices 0..127, "
            "0..95, 0..63)");
  EXPECT_EQ(message({{-9, 0, 0}, {-1, 10, 10}}).find("v.raw: `roi` -9,0,0,-1,10,10 lies outside"), 0u);
  EXPECT_EQ(message({{0, 0, 5}, {10, 10, 5}}),
            "v.raw: `roi` 0,0,5,10,10,5 holds 1 lattice point along k; a surface needs at least 2 on every axis "
            "of the volume's 128x96x64 lattice points (indices 0..127, 0..95, 0..63)");
  EXPECT_NE(message({{127, 0, 0}, {300, 10, 10}}).find("(clipped to 127,0,0,127,10,10) holds 1 lattice point along i"),
            std::string::npos);
  EXPECT_EQ(message({{0, 9, 0}, {10, 8, 10}}), "v.raw: `roi` 0,9,0,10,8,10 is empty: j1 8 is below j0 9");
  EXPECT_THROW(CropSource(std::make_unique<testing::VectorSource>(kDims, field), {{0, 0, 0}, {128, 10, 10}}), Error);
}

TEST(CropSource, SlicesAfterTheBoxAreNeverAskedFor) {
  auto counting = std::make_unique<CountingSource>(std::make_unique<testing::VectorSource>(kDims, field));
  CountingSource* counter = counting.get();
  CropSource crop(std::move(counting), kBox);
  std::vector<float> slice(static_cast<std::size_t>(crop.info().sliceVoxels()));
  EXPECT_EQ(crop.skipSlices(2), 2);
  int read = 0;
  while (crop.readSlice(slice)) ++read;
  EXPECT_EQ(read, 8);
  EXPECT_EQ(crop.skipSlices(5), 0);
  EXPECT_EQ(counter->skipped(), 32);
  EXPECT_EQ(counter->reads(), 8);
}

TEST(SkipSlices, TheDefaultReadsAndEveryReaderStopsAtTheEnd) {
  const std::string dir = testing::tempDir();
  std::vector<std::unique_ptr<SliceSource>> sources;
  sources.push_back(std::make_unique<testing::VectorSource>(kDims, field));
  sources.push_back(PhantomSource::open("phantom:sphere?n=128,96,64"));
  sources.push_back(openSource(writeVolumeFile(dir + "/v.raw"), rawOptions()));
  sources.push_back(openSource(writeVolumeFile(dir + "/v.nii"), SourceOptions{}));
  sources.push_back(openSource(writeVolumeFile(dir + "/v.nii.gz"), SourceOptions{}));
  for (auto& s : sources) {
    std::vector<float> slice(static_cast<std::size_t>(s->info().sliceVoxels()));
    EXPECT_EQ(s->skipSlices(0), 0) << s->info().reader;
    EXPECT_EQ(s->skipSlices(60), 60) << s->info().reader;
    EXPECT_TRUE(s->readSlice(slice));
    EXPECT_EQ(s->skipSlices(10), 3) << s->info().reader;
    EXPECT_FALSE(s->readSlice(slice));
    EXPECT_EQ(s->skipSlices(1), 0);
    EXPECT_TRUE(s->warnings().empty()) << s->info().reader;
  }
}

TEST(SkipSlices, RawNiftiNrrdAndMetaImageGiveTheCroppedCopy) {
  const std::string dir = testing::tempDir();
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/v.raw"), rawOptions()));
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/v.nii"), SourceOptions{}));
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/v.nrrd"), SourceOptions{}));
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/v.mha"), SourceOptions{}));
  // Compressed streams are inflated past the skipped slices, and never read to their end: no
  // warning or error comes from the data after the box.
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/v.nii.gz"), SourceOptions{}));
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/z.nrrd", true), SourceOptions{}));
  expectCropMatchesCopy(openSource(writeVolumeFile(dir + "/z.mha", true), SourceOptions{}));
  // A raw gzip file (as the engine data comes), with a header skipped before the voxels.
  const std::string plain = testing::slurp(dir + "/v.raw");
  gzFile gz = gzopen((dir + "/v.raw.gz").c_str(), "wb");
  gzwrite(gz, "HEADER", 6);
  gzwrite(gz, plain.data(), static_cast<unsigned>(plain.size()));
  gzclose(gz);
  SourceOptions o = rawOptions();
  o.raw->headerBytes = 6;
  expectCropMatchesCopy(openSource(dir + "/v.raw.gz", o));
}

TEST(SkipSlices, RawAndNiftiSeekPastTheSlicesBeforeTheBox) {
  if (bytesRead() < 0) GTEST_SKIP() << "/proc/self/io is not readable";
  const std::string dir = testing::tempDir();
  constexpr std::int64_t kSliceBytes = kDims[0] * kDims[1] * 4;  // 48 KiB
  for (const std::string& name : {std::string("v.raw"), std::string("v.nii")}) {
    const std::string path = writeVolumeFile(dir + "/" + name);
    const SourceOptions o = name == "v.raw" ? rawOptions() : SourceOptions{};
    // Skipping by reading: the 30 slices before the box and its 10.
    std::int64_t before = bytesRead();
    {
      CropSource crop(std::make_unique<CountingSource>(openSource(path, o), false), kBox);
      testing::extract(crop, Method::kMarchingCubes, 0);
    }
    const std::int64_t reading = bytesRead() - before;
    // Skipping by seeking: the box's 10 slices (and the NIfTI header), with stdio's buffering.
    before = bytesRead();
    {
      CropSource crop(openSource(path, o), kBox);
      testing::extract(crop, Method::kMarchingCubes, 0);
    }
    const std::int64_t seeking = bytesRead() - before;
    EXPECT_GE(reading, 40 * kSliceBytes) << name;
    EXPECT_GE(seeking, 10 * kSliceBytes) << name;
    EXPECT_LT(seeking, 11 * kSliceBytes) << name;
  }
}

TEST(SkipSlices, PerSliceFilesOutsideTheBoxAreNeverOpened) {
  const std::string dir = testing::tempDir();
  const std::string plain = testing::slurp(writeVolumeFile(dir + "/v.raw"));
  const auto sliceBytes = static_cast<std::size_t>(kDims[0] * kDims[1] * 4);
  fs::create_directory(dir + "/slices");
  for (std::int64_t k = 0; k < kDims[2]; ++k) {
    std::ofstream(dir + "/slices/s" + std::to_string(k) + ".raw", std::ios::binary)
        .write(plain.data() + static_cast<std::size_t>(k) * sliceBytes, static_cast<std::streamsize>(sliceBytes));
  }
  SourceOptions o = rawOptions();
  o.raw->dims[2] = 0;
  for (const std::string& input : {dir + "/slices", dir + "/slices/s%d.raw"}) {
    auto source = openSource(input, o);
    ASSERT_EQ(source->info().dims[2], kDims[2]);
    // Opened and measured; the files the box does not need go now.
    for (std::int64_t k = 0; k < kDims[2]; ++k) {
      if (k < kBox.lo[2] || k > kBox.hi[2]) fs::remove(dir + "/slices/s" + std::to_string(k) + ".raw");
    }
    expectCropMatchesCopy(std::move(source));
    if (input == dir + "/slices") {
      for (std::int64_t k = 0; k < kDims[2]; ++k) {
        std::ofstream(dir + "/slices/s" + std::to_string(k) + ".raw", std::ios::binary)
            .write(plain.data() + static_cast<std::size_t>(k) * sliceBytes, static_cast<std::streamsize>(sliceBytes));
      }
    }
  }
}

// The Philips head series: a box of 20 slices reads the pixel data of those 20 files only. The
// series' headers are scanned through links to its files; the links of every other slice are then
// removed, so opening one of them would fail the run.
TEST(SkipSlices, DicomReadsOnlyTheBoxsSlices) {
  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const std::string dir = testing::tempDir();
  for (const auto& e : fs::directory_iterator(philips)) {
    if (e.path().filename() != "DIRFILE") fs::create_symlink(e.path(), dir + "/" + e.path().filename().string());
  }
  const DicomScan scan = scanDicom({dir}, DicomOptions{});
  ASSERT_EQ(scan.series.size(), 1u);
  const DicomSeries& series = scan.series.front();
  ASSERT_EQ(series.slices.size(), 140u);
  const LatticeBox box{{100, 120, 60}, {400, 380, 79}};
  // The same box read the slow way first, from every file: the reference mesh.
  testing::Extraction reference;
  {
    CropSource crop(std::make_unique<CountingSource>(openDicomSeries(series, DicomOptions{}), false), box);
    reference = testing::extract(crop, Method::kMarchingCubes, 350);
  }
  for (std::size_t k = 0; k < series.slices.size(); ++k) {
    if (k < 60 || k > 79) fs::remove(series.slices[k].path);
  }
  auto counting = std::make_unique<CountingSource>(openDicomSeries(series, DicomOptions{}));
  CountingSource* counter = counting.get();
  CropSource crop(std::move(counting), box);
  const testing::Extraction x = testing::extract(crop, Method::kMarchingCubes, 350);
  EXPECT_EQ(counter->reads(), 20);
  EXPECT_EQ(counter->skipped(), 60);
  EXPECT_GT(x.stats.triangles, 10000u);
  EXPECT_TRUE(x.mesh == reference.mesh);
  EXPECT_TRUE(crop.warnings().empty());
}

}  // namespace
}  // namespace isoslab
