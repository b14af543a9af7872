// DICOM Segmentation objects (issue 35): files written by samples/make_dicom_seg with DCMTK's
// dcmseg API from the label phantoms, read back by isoslab, against the phantom meshed directly
// and against what DCMTK itself reads from the file (segment labels, frame positions).
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcsequen.h>
#include <dcmtk/dcmseg/segdoc.h>
#include <dcmtk/dcmseg/segment.h>
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>

#include "io/label_table.h"
#include "job/extract_job.h"
#include "test_support.h"

namespace isoslab {
namespace {

// Writes a SEG of `input` with samples/make_dicom_seg and its `options`.
std::string makeSeg(const std::string& input, const std::string& options, const std::string& path) {
  const std::string command = std::string(ISOSLAB_MAKE_DICOM_SEG) + " " + options + " '" + input + "' " + path;
  EXPECT_EQ(std::system((command + " 2>&1").c_str()), 0) << command;
  return path;
}

ExtractReport meshLabels(const std::string& input, const std::string& dir, int channel = -1,
                         OutputSpace space = OutputSpace::kPhysical) {
  std::filesystem::create_directories(dir);
  ExtractSettings s;
  s.inputs = {input};
  s.output = dir + "/{label}.ply";
  s.space = space;
  s.source.dicom.channel = channel;
  return runExtract(s);
}

// The segment labels that DCMTK's own reader finds, by segment number.
std::map<std::int32_t, std::string> dcmtkSegmentLabels(const std::string& path) {
  DcmSegmentation* seg = nullptr;
  EXPECT_TRUE(DcmSegmentation::loadFile(path.c_str(), seg).good()) << path;
  std::map<std::int32_t, std::string> out;
  if (seg == nullptr) return out;
  for (std::size_t n = 1; n <= seg->getNumberOfSegments(); ++n) {
    OFString label;
    seg->getSegment(n)->getSegmentLabel(label);
    out[static_cast<std::int32_t>(n)] = label.c_str();
  }
  delete seg;
  return out;
}

// Same labels, voxels, triangles and interfaces; volume and area within `relative` (positions
// written with few digits move the lattice a little).
void expectSameSurfaces(const ExtractReport& seg, const ExtractReport& phantom, const std::string& what,
                        double relative = 1e-6) {
  ASSERT_EQ(seg.labels.size(), phantom.labels.size()) << what;
  for (std::size_t n = 0; n < seg.labels.size(); ++n) {
    const ExtractLabel& a = seg.labels[n];
    const ExtractLabel& b = phantom.labels[n];
    EXPECT_EQ(a.value, b.value) << what;
    EXPECT_EQ(a.voxels, b.voxels) << what << " label " << a.value;
    EXPECT_EQ(a.stats.triangles, b.stats.triangles) << what << " label " << a.value;
    EXPECT_NEAR(a.stats.volume, b.stats.volume, relative * std::abs(b.stats.volume)) << what;
    EXPECT_NEAR(a.stats.area, b.stats.area, relative * b.stats.area) << what;
    EXPECT_EQ(a.splits, b.splits) << what;
  }
  ASSERT_EQ(seg.interfaces.size(), phantom.interfaces.size()) << what;
  for (std::size_t n = 0; n < seg.interfaces.size(); ++n) {
    EXPECT_EQ(seg.interfaces[n].triangles, phantom.interfaces[n].triangles) << what;
  }
}

// Rows x Columns = 143, not a multiple of 8: frames start inside bytes (DCMTK 3.6.7 misreads them).
constexpr const char* kNested = "phantom:nested?n=13,11,9&spacing=0.7,0.9,1.6";

TEST(DicomSeg, EveryEncodingGivesThePhantomsSurfacesNamesAndColours) {
  const std::string dir = testing::tempDir();
  const ExtractReport phantom = meshLabels(kNested, dir + "/p");
  struct Case {
    const char* options;
    const char* reader;
  };
  for (const std::string options :
       {"", "--fractional 255", "--fractional 8", "--labelmap", "--transfer deflated", "--transfer implicit"}) {
    const std::string seg = makeSeg(kNested, options, dir + "/s.dcm");
    const ExtractReport r = meshLabels(seg, dir + "/o");
    EXPECT_EQ(r.reader, "dicom-seg") << options;
    expectSameSurfaces(r, phantom, options);
    for (std::size_t a = 0; a < 6 && !r.labels.empty(); ++a) {
      EXPECT_NEAR(r.labels[0].stats.bounds[a], phantom.labels[0].stats.bounds[a], 1e-4) << options;
    }
    if (options != "--labelmap") {  // DCMTK 3.6.7 does not know the label map class
      const auto names = dcmtkSegmentLabels(seg);
      for (const ExtractLabel& l : r.labels) EXPECT_EQ(l.name, names.at(l.value)) << options;
    }
    for (const ExtractLabel& l : r.labels) {
      const auto want = defaultLabelColor(l.value);  // what the sample wrote, through CIELab
      for (std::size_t c = 0; c < 3; ++c) EXPECT_NEAR(l.color[c], want[c], 1) << options << " label " << l.value;
      EXPECT_TRUE(l.colorFromTable) << options;
    }
    std::filesystem::remove(seg);
  }
}

TEST(DicomSeg, SixteenBitLabelMapsAndManySegments) {
  const std::string dir = testing::tempDir();
  const std::string input = "phantom:checker?n=24,20,12&b=2&labels=300";
  const ExtractReport phantom = meshLabels(input, dir + "/p");
  for (const std::string options : {"--labelmap", ""}) {
    const ExtractReport r = meshLabels(makeSeg(input, options, dir + "/s.dcm"), dir + "/o");
    ASSERT_EQ(r.labels.size(), 300u) << options;
    expectSameSurfaces(r, phantom, options);
  }
}

// An oblique frame of reference: every label's box is the phantom's, mapped through the geometry
// that DCMTK reads from the file (shared orientation, lowest frame position).
TEST(DicomSeg, ObliqueFramesLandWhereTheFileSays) {
  const std::string dir = testing::tempDir();
  const std::string seg = makeSeg(kNested, "--rotate 30 --tilt 20", dir + "/s.dcm");
  const ExtractReport r = meshLabels(seg, dir + "/o");
  const ExtractReport voxel = meshLabels(kNested, dir + "/v", -1, OutputSpace::kVoxel);
  expectSameSurfaces(r, meshLabels(kNested, dir + "/p"), "oblique");
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(seg.c_str()).good());
  DcmItem* shared = nullptr;
  ASSERT_TRUE(ff.getDataset()->findAndGetSequenceItem(DCM_SharedFunctionalGroupsSequence, shared, 0).good());
  DcmItem* orient = nullptr;
  ASSERT_TRUE(shared->findAndGetSequenceItem(DCM_PlaneOrientationSequence, orient, 0).good());
  std::array<double, 6> o{};
  for (unsigned long c = 0; c < 6; ++c)
    ASSERT_TRUE(orient->findAndGetFloat64(DCM_ImageOrientationPatient, o[c], c).good());
  const std::array<double, 3> row{o[0], o[1], o[2]}, col{o[3], o[4], o[5]};
  const std::array<double, 3> normal{row[1] * col[2] - row[2] * col[1], row[2] * col[0] - row[0] * col[2],
                                     row[0] * col[1] - row[1] * col[0]};
  EXPECT_GT(std::abs(normal[0]) + std::abs(normal[1]), 0.2);  // neither axial nor along an axis
  DcmSequenceOfItems* frames = nullptr;
  ASSERT_TRUE(ff.getDataset()->findAndGetSequence(DCM_PerFrameFunctionalGroupsSequence, frames).good());
  std::array<double, 3> origin{};
  double lowest = 1e300;
  for (unsigned long f = 0; f < frames->card(); ++f) {
    DcmItem* plane = nullptr;
    ASSERT_TRUE(frames->getItem(f)->findAndGetSequenceItem(DCM_PlanePositionSequence, plane, 0).good());
    std::array<double, 3> p{};
    for (unsigned long c = 0; c < 3; ++c)
      ASSERT_TRUE(plane->findAndGetFloat64(DCM_ImagePositionPatient, p[c], c).good());
    const double along = p[0] * normal[0] + p[1] * normal[1] + p[2] * normal[2];
    if (along < lowest) lowest = along, origin = p;
  }
  const std::array<double, 3> spacing{0.7, 0.9, 1.6};
  // The file holds frames from the phantom's first slice with a label: k0, the lowest voxel box.
  double k0 = 1e300;
  for (const ExtractLabel& l : voxel.labels) k0 = std::min(k0, l.stats.bounds[2] + 0.5);
  for (std::size_t n = 0; n < r.labels.size(); ++n) {
    // The voxel-space box's eight corners, mapped.
    const auto& vb = voxel.labels[n].stats.bounds;
    std::array<double, 6> box{1e300, 1e300, 1e300, -1e300, -1e300, -1e300};
    for (int corner = 0; corner < 8; ++corner) {
      const double i = vb[(corner & 1) ? 3 : 0], j = vb[(corner & 2) ? 4 : 1], k = vb[(corner & 4) ? 5 : 2] - k0;
      for (std::size_t a = 0; a < 3; ++a) {
        const double x = origin[a] + i * spacing[0] * row[a] + j * spacing[1] * col[a] + k * spacing[2] * normal[a];
        box[a] = std::min(box[a], x);
        box[a + 3] = std::max(box[a + 3], x);
      }
    }
    // A rotated sphere's box is inside the rotated box of its axis-aligned box; both share the centre.
    for (std::size_t a = 0; a < 3; ++a) {
      EXPECT_NEAR(r.labels[n].stats.bounds[a] + r.labels[n].stats.bounds[a + 3], box[a] + box[a + 3], 1e-3)
          << "label " << r.labels[n].value << " axis " << a;
      EXPECT_GE(r.labels[n].stats.bounds[a], box[a] - 1e-4);
      EXPECT_LE(r.labels[n].stats.bounds[a + 3], box[a + 3] + 1e-4);
    }
  }
}

TEST(DicomSeg, OverlappingSegmentsGoToLayers) {
  const std::string dir = testing::tempDir();
  const std::string seg = makeSeg(kNested, "--overlap", dir + "/s.dcm");
  // A threshold reads one layer's values: a channel must choose it.
  const auto refused = testing::runCli("extract " + seg + " --iso 1 -o " + dir + "/x.ply -q");
  EXPECT_EQ(refused.exitCode, 1);
  EXPECT_EQ(refused.err, "isoslab: error: " + seg +
                             ": 2 segmentation layers (segments of different layers overlap); a run meshes one: "
                             "choose it with --channel 0..1\n");
  EXPECT_EQ(testing::fileCount(dir), 1);
  const ExtractReport phantom = meshLabels(kNested, dir + "/p");
  expectSameSurfaces(meshLabels(seg, dir + "/o0", 0), phantom, "layer 0");
  const ExtractReport top = meshLabels(seg, dir + "/o1", 1);
  ASSERT_EQ(top.labels.size(), 1u);
  EXPECT_EQ(top.labels[0].name, "union");
  EXPECT_EQ(top.labels[0].layer, 1);
  std::int64_t all = 0;
  for (const ExtractLabel& l : phantom.labels) all += l.voxels;
  EXPECT_EQ(top.labels[0].voxels, all);
  // Every layer in one pass: each label's file holds the bytes of its own layer's run.
  const ExtractReport both = meshLabels(seg, dir + "/all");
  EXPECT_EQ(both.layers, 2);
  ASSERT_EQ(both.labels.size(), phantom.labels.size() + 1);
  EXPECT_EQ(both.labels.back().name, "union");
  EXPECT_EQ(both.labels.back().layer, 1);
  EXPECT_EQ(both.labels.back().voxels, all);
  EXPECT_EQ(testing::fileCount(dir + "/all"), testing::fileCount(dir + "/o0") + testing::fileCount(dir + "/o1"));
  for (const ExtractLabel& l : both.labels) {
    const std::string own = fmt::format("{}/o{}/{}.ply", dir, l.layer, l.value);
    EXPECT_TRUE(std::filesystem::exists(own)) << own;
    EXPECT_TRUE(testing::slurp(fmt::format("{}/all/{}.ply", dir, l.value)) == testing::slurp(own)) << l.name;
  }
  const auto past = testing::runCli("extract " + seg + " --channel 2 -o " + dir + "/{name}.ply -q");
  EXPECT_EQ(past.err, "isoslab: error: " + seg + ": --channel 2 is past the segmentation's 2 layers\n");
  const auto info = testing::runCli("info " + seg);
  EXPECT_NE(info.out.find("labels     3 (a label map"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("a binary DICOM Segmentation of 4 segments in"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("layer 0 of 2 holds 3"), std::string::npos) << info.out;
}

// Three segments on one voxel (a box, "union" and "union 2"): every pair overlaps, so three
// layers, the box's own layer holding no union.
TEST(DicomSeg, ThreeSegmentsOnAVoxelGiveThreeLayers) {
  const std::string dir = testing::tempDir();
  const std::string seg = makeSeg("phantom:boxes?n=12", "--overlap --overlap", dir + "/s.dcm");
  const auto refused = testing::runCli("extract " + seg + " --iso 1 -o " + dir + "/x.ply -q");
  EXPECT_NE(refused.err.find(": 3 segmentation layers"), std::string::npos) << refused.err;
  const std::vector<std::vector<std::string>> layers{{"label 1", "label 2", "label 3"}, {"union"}, {"union 2"}};
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const ExtractReport r = meshLabels(seg, dir + "/o" + std::to_string(l), static_cast<int>(l));
    std::vector<std::string> names;
    for (const ExtractLabel& label : r.labels) names.push_back(label.name);
    EXPECT_EQ(names, layers[l]) << "layer " << l;
  }
  // In one pass, the three layers' labels in layer order.
  const ExtractReport all = meshLabels(seg, dir + "/all");
  std::vector<std::string> names;
  for (const ExtractLabel& label : all.labels) names.push_back(label.name);
  EXPECT_EQ(names, (std::vector<std::string>{"label 1", "label 2", "label 3", "union", "union 2"}));
}

// Without SpacingBetweenSlices, positions rounded to 0.01 mm on 0.625 mm slices, some slices left
// out: the step comes from the span, not from the smallest rounded gap.
TEST(DicomSeg, RoundedPositionsWithoutSpacingBetweenSlicesStayOnTheLattice) {
  const std::string dir = testing::tempDir();
  const std::string input = "phantom:nested?n=13,11,20&spacing=0.7,0.9,0.625";
  const std::string seg = makeSeg(input, "", dir + "/s.dcm");
  DcmFileFormat ff;
  ASSERT_TRUE(ff.loadFile(seg.c_str()).good());
  DcmDataset* ds = ff.getDataset();
  DcmItem* shared = nullptr;
  ASSERT_TRUE(ds->findAndGetSequenceItem(DCM_SharedFunctionalGroupsSequence, shared, 0).good());
  DcmItem* measures = nullptr;
  ASSERT_TRUE(shared->findAndGetSequenceItem(DCM_PixelMeasuresSequence, measures, 0).good());
  delete measures->remove(DCM_SpacingBetweenSlices);
  DcmSequenceOfItems* frames = nullptr;
  ASSERT_TRUE(ds->findAndGetSequence(DCM_PerFrameFunctionalGroupsSequence, frames).good());
  for (unsigned long f = 0; f < frames->card(); ++f) {
    DcmItem* plane = nullptr;
    ASSERT_TRUE(frames->getItem(f)->findAndGetSequenceItem(DCM_PlanePositionSequence, plane, 0).good());
    std::string rounded;
    for (unsigned long c = 0; c < 3; ++c) {
      Float64 v = 0;
      ASSERT_TRUE(plane->findAndGetFloat64(DCM_ImagePositionPatient, v, c).good());
      rounded += (c > 0 ? "\\" : "") + fmt::format("{:.2f}", v);
    }
    plane->putAndInsertString(DCM_ImagePositionPatient, rounded.c_str());
  }
  ASSERT_TRUE(ff.saveFile(seg.c_str(), EXS_LittleEndianExplicit).good());
  expectSameSurfaces(meshLabels(seg, dir + "/o"), meshLabels(input, dir + "/p"), "rounded", 0.01);
}

TEST(DicomSeg, AFolderHoldingOneSegmentationReadsIt) {
  const std::string dir = testing::tempDir();
  std::filesystem::create_directories(dir + "/in");
  makeSeg("phantom:boxes?n=12", "", dir + "/in/seg.dcm");
  const ExtractReport r = meshLabels(dir + "/in", dir + "/o");
  EXPECT_EQ(r.labels.size(), 3u);
}

}  // namespace
}  // namespace isoslab
