// `isoslab info --histogram` and the iso values chosen for the user: `--iso auto` (Otsu's
// threshold on the streamed histogram) and the CT names `--iso bone` and `--iso skin`.
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.h"

namespace isoslab {
namespace {

namespace fs = std::filesystem;
using testing::runCli;
using testing::slurp;

template <typename T>
void writeRaw(const std::string& path, const std::vector<T>& values) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(T)));
}

// Three 4x4 slices 1 mm apart of a DICOM series of `modality` (SOP class CT or MR), values 0, 100
// and 200.
std::string dicomSeries(const std::string& dir, const std::string& modality) {
  fs::create_directories(dir + "/series");
  for (int k = 0; k < 3; ++k) {
    DcmFileFormat ff;
    DcmDataset* d = ff.getDataset();
    d->putAndInsertString(DCM_SOPClassUID, modality == "CT" ? UID_CTImageStorage : UID_MRImageStorage);
    d->putAndInsertString(DCM_SOPInstanceUID, fmt::format("1.2.826.0.1.3680043.99.17.{}", k + 1).c_str());
    d->putAndInsertString(DCM_StudyInstanceUID, "1.2.826.0.1.3680043.99.17.100");
    d->putAndInsertString(DCM_SeriesInstanceUID, "1.2.826.0.1.3680043.99.17.101");
    d->putAndInsertString(DCM_Modality, modality.c_str());
    d->putAndInsertString(DCM_InstanceNumber, std::to_string(k + 1).c_str());
    d->putAndInsertString(DCM_ImagePositionPatient, fmt::format("0\\0\\{}", k).c_str());
    d->putAndInsertString(DCM_ImageOrientationPatient, "1\\0\\0\\0\\1\\0");
    d->putAndInsertString(DCM_PixelSpacing, "1\\1");
    d->putAndInsertUint16(DCM_Rows, 4);
    d->putAndInsertUint16(DCM_Columns, 4);
    d->putAndInsertUint16(DCM_SamplesPerPixel, 1);
    d->putAndInsertString(DCM_PhotometricInterpretation, "MONOCHROME2");
    d->putAndInsertUint16(DCM_BitsAllocated, 16);
    d->putAndInsertUint16(DCM_BitsStored, 16);
    d->putAndInsertUint16(DCM_HighBit, 15);
    d->putAndInsertUint16(DCM_PixelRepresentation, 0);
    std::vector<Uint16> pixels(16, static_cast<Uint16>(100 * k));
    d->putAndInsertUint16Array(DCM_PixelData, pixels.data(), 16);
    ff.saveFile(fmt::format("{}/series/{}.dcm", dir, k).c_str(), EXS_LittleEndianExplicit);
  }
  return dir + "/series";
}

struct PrintedHistogram {
  std::vector<double> from;
  std::vector<double> to;
  std::vector<std::uint64_t> counts;
  std::string nonFinite;
  std::string otsu;
};

// The bins of `isoslab info --histogram` (the rows between the column heads and the closing note).
PrintedHistogram parseHistogram(const std::string& out) {
  PrintedHistogram h;
  std::istringstream in(out);
  bool rows = false;
  for (std::string line; std::getline(in, line);) {
    if (line.find("bin    from") != std::string::npos) {
      rows = true;
    } else if (line.find("(a bin holds") != std::string::npos) {
      rows = false;
    } else if (rows) {
      std::istringstream row(line);
      std::size_t b = 0;
      double from = 0, to = 0;
      std::uint64_t count = 0;
      row >> b >> from >> to >> count;
      EXPECT_EQ(b, h.counts.size()) << line;
      h.from.push_back(from);
      h.to.push_back(to);
      h.counts.push_back(count);
    } else if (line.rfind("non-finite ", 0) == 0) {
      h.nonFinite = line.substr(11);
    } else if (line.rfind("otsu       ", 0) == 0) {
      h.otsu = line.substr(11);
    }
  }
  return h;
}

TEST(InfoHistogram, CountsEveryValueWithNanAndInfinitiesApart) {
  const std::string dir = testing::tempDir();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> values;
  for (int n = 0; n < 6 * 5 * 4; ++n) values.push_back(static_cast<float>((n * 37) % 101) - 20.0F);
  values[3] = nan;
  values[50] = nan;
  values[77] = nan;
  values[10] = -inf;
  values[11] = -inf;
  values[99] = inf;
  writeRaw(dir + "/v.raw", values);
  const auto r = runCli("info " + dir + "/v.raw --raw-dims 6,5,4 --raw-type f32 --histogram --bins 5");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  const PrintedHistogram h = parseHistogram(r.out);
  ASSERT_EQ(h.counts.size(), 5u) << r.out;
  // By brute force: the finite values' range split in five, the last bin closed.
  double lo = 1e300, hi = -1e300;
  for (const float v : values) {
    if (std::isfinite(v)) lo = std::min(lo, static_cast<double>(v)), hi = std::max(hi, static_cast<double>(v));
  }
  EXPECT_EQ(h.from.front(), lo);
  EXPECT_EQ(h.to.back(), hi);
  for (std::size_t b = 0; b < 5; ++b) {
    std::uint64_t count = 0;
    for (const float v : values) {
      if (std::isfinite(v) && v >= h.from[b] && (v < h.to[b] || (b == 4 && v == hi))) ++count;
    }
    EXPECT_EQ(h.counts[b], count) << b;
  }
  EXPECT_EQ(h.nonFinite, "NaN 3, -inf 2, +inf 1");
  EXPECT_NE(r.out.find("range      -inf .. inf\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("histogram  5 bins of 20 over -20 .. 80 (the finite values' range); 1 pass over the input\n"),
            std::string::npos)
      << r.out;
  EXPECT_FALSE(h.otsu.empty());

  // --bins needs --histogram, and at least one bin.
  auto bad = runCli("info " + dir + "/v.raw --raw-dims 6,5,4 --raw-type f32 --bins 5");
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_EQ(bad.err, "isoslab: error: --bins requires --histogram (see isoslab info --help)\n");
  bad = runCli("info " + dir + "/v.raw --raw-dims 6,5,4 --raw-type f32 --histogram --bins 0");
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_EQ(bad.err, "isoslab: error: --bins: '0' is not a whole number from 1 to 16777216\n");
}

TEST(InfoHistogram, ListsOneHistogramPerDicomSeries) {
  const std::string dir = testing::tempDir();
  const std::string series = dicomSeries(dir, "CT");
  const auto r = runCli("info " + series + " --histogram --bins 4");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(
      r.out.find("  value range    0 .. 200 (after rescale)\n"
                 "  histogram      4 bins of 50 over 0 .. 200 (the finite values' range); 1 pass over the input\n"),
      std::string::npos)
      << r.out;
  // 0 | 100, 200: bin 1 (50 .. 100) is empty, and the iso value is its middle.
  EXPECT_NE(r.out.find("  otsu           75 (over these bins: bins 1 .. 3 are at or above it"), std::string::npos)
      << r.out;
}

TEST(IsoAuto, TakesOtsusThresholdAndSaysSo) {
  const std::string dir = testing::tempDir();
  const std::string sphere = "'phantom:sphere?n=24&r=7&field=binary'";
  const auto r = runCli("extract " + sphere + " --iso auto -o " + dir + "/auto.ply --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  // 0 and 100: every split between them ties, and the iso value is the middle of the empty bins.
  EXPECT_EQ(
      r.err.rfind("isoslab: --iso auto: Otsu threshold 50 over 256 bins of 0 .. 100 (1 pass over the input)\n", 0), 0u)
      << r.err;
  EXPECT_NE(r.err.find(" at iso 50 (--iso auto): "), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["iso"], 50.0);
  EXPECT_EQ(report["iso_source"], "auto (Otsu, 256 bins)");
  EXPECT_EQ(report["iso_histogram"]["passes"], 1);
  EXPECT_EQ(report["iso_histogram"]["range_from"], "reader");
  EXPECT_EQ(report["iso_histogram"]["first_inside_bin"], 1);
  ASSERT_EQ(runCli("extract " + sphere + " --iso 50 -q -o " + dir + "/fifty.ply").exitCode, 0);
  EXPECT_EQ(slurp(dir + "/auto.ply"), slurp(dir + "/fifty.ply"));

  // Many distinct float values: the range from a first pass, then a second one bins; any case.
  std::vector<float> noisy;
  std::uint32_t state = 1;
  for (int n = 0; n < 64 * 64 * 24; ++n) {
    state = state * 1664525u + 1013904223u;
    const float noise = static_cast<float>(state >> 8) / 16777216.0F;
    const bool inside = (n % 64 - 32) * (n % 64 - 32) + (n / 64 % 64 - 32) * (n / 64 % 64 - 32) < 400;
    noisy.push_back((inside ? 1000.0F : 0.0F) + 100.0F * noise);
  }
  writeRaw(dir + "/noisy.raw", noisy);
  const auto two = runCli("extract " + dir + "/noisy.raw --raw-dims 64,64,24 --raw-type f32 --iso AUTO -o " + dir +
                          "/n.ply --report " + dir + "/n.json");
  ASSERT_EQ(two.exitCode, 0) << two.err;
  EXPECT_NE(two.err.find("(2 passes over the input)\n"), std::string::npos) << two.err;
  const auto noisyReport = nlohmann::json::parse(slurp(dir + "/n.json"));
  EXPECT_EQ(noisyReport["iso_histogram"]["passes"], 2);
  EXPECT_EQ(noisyReport["iso_histogram"]["range_from"], "data");
  EXPECT_GT(noisyReport["iso"].get<double>(), 100.0);
  EXPECT_LT(noisyReport["iso"].get<double>(), 1000.0);
  EXPECT_GT(noisyReport["triangles"].get<int>(), 0);
}

TEST(IsoAuto, RefusesAVolumeOfOneValue) {
  const std::string dir = testing::tempDir();
  writeRaw(dir + "/flat.raw", std::vector<std::uint8_t>(64, 9));
  const auto r = runCli("extract " + dir + "/flat.raw --raw-dims 4,4,4 --iso auto -o " + dir + "/out.ply");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err, "isoslab: error: " + dir +
                       "/flat.raw: --iso auto: no threshold separates the values: every finite value is 9\n");
  EXPECT_EQ(testing::fileCount(dir), 1);
}

TEST(IsoNames, AreRefusedForAnotherModality) {
  const std::string dir = testing::tempDir();
  const std::string series = dicomSeries(dir, "MR");
  const auto r = runCli("extract " + series + " --iso skin -o " + dir + "/out.ply");
  EXPECT_EQ(r.exitCode, 1);
  EXPECT_EQ(r.err, "isoslab: error: " + series +
                       ": --iso skin means -400 HU, a CT value, but the input's modality is MR; give the iso value as "
                       "a number\n");
  EXPECT_FALSE(fs::exists(dir + "/out.ply"));
  EXPECT_EQ(runCli("extract " + series + " --iso 150 -q -o " + dir + "/out.ply").exitCode, 0);
}

TEST(IsoNames, AreTakenAsHounsfieldUnitsWithoutAModality) {
  const std::string dir = testing::tempDir();
  std::vector<std::int16_t> hu;
  for (int n = 0; n < 8 * 8 * 8; ++n) hu.push_back(static_cast<std::int16_t>(n % 8 > 1 && n % 8 < 6 ? 40 : -1000));
  writeRaw(dir + "/ct.raw", hu);
  const std::string raw = dir + "/ct.raw --raw-dims 8,8,8 --raw-type i16";
  const auto r = runCli("extract " + raw + " --iso Skin -o " + dir + "/out.ply --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_EQ(r.err.rfind("isoslab: --iso skin: -400, taken as Hounsfield units (the input names no modality)\n", 0), 0u)
      << r.err;
  EXPECT_NE(r.err.find(" at iso -400 (--iso skin): "), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["iso"], -400.0);
  EXPECT_EQ(report["iso_source"], "skin (-400 HU)");
  EXPECT_EQ(report["iso_note"], "--iso skin: -400, taken as Hounsfield units (the input names no modality)");
  // --quiet keeps the note off stderr; a number is a number, as before.
  EXPECT_EQ(runCli("extract " + raw + " --iso skin -q -o " + dir + "/out.ply").err, "");
  const auto number = runCli("extract " + raw + " --iso 20.5 -o " + dir + "/out.ply --report " + dir + "/r.json");
  ASSERT_EQ(number.exitCode, 0) << number.err;
  EXPECT_EQ(number.err.rfind("isoslab: mc at iso 20.5: ", 0), 0u) << number.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(dir + "/r.json"))["iso_source"], "value");

  const auto bad = runCli("extract " + raw + " --iso bones -o " + dir + "/out.ply");
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_EQ(bad.err, "isoslab: error: --iso: 'bones' is not a number, auto, bone or skin\n");
}

TEST(IsoNames, BoneOnACtSeries) {
  const std::string dir = testing::tempDir();
  const std::string series = dicomSeries(dir, "CT");
  auto r = runCli("extract " + series + " --iso bone -o " + dir + "/out.ply");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("isoslab: --iso bone: 300 HU (the input is CT)\n"), std::string::npos) << r.err;

  const std::string philips = testing::sharedData("ct-philips-head");
  if (philips.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  r = runCli("extract " + philips + " --iso bone --threads 2 -o " + dir + "/skull.stl --report " + dir + "/r.json");
  ASSERT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.err.find("isoslab: --iso bone: 300 HU (the input is CT)\n"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("isoslab: mc at iso 300 (--iso bone): "), std::string::npos) << r.err;
  const auto report = nlohmann::json::parse(slurp(dir + "/r.json"));
  EXPECT_EQ(report["iso"], 300.0);
  EXPECT_EQ(report["iso_source"], "bone (300 HU)");
  EXPECT_GT(report["triangles"].get<std::int64_t>(), 100000);
}

}  // namespace
}  // namespace isoslab
