// The catalogue of broken inputs (issue 13): each case builds one hostile input in its own
// folder, runs the command line on it, and checks the exit code (1 for input errors, 2 for usage
// errors), that stderr is exactly one line "isoslab: error: ..." naming the file, and that no
// output or temporary file is left in the folder. Add a case by adding a row to kCases.
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "test_support.h"

namespace isoslab::testing {
namespace {

namespace fs = std::filesystem;

void write(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f << bytes;
}

std::string voxels(std::size_t n) {
  return std::string(n, '\x01');
}

// A glTF binary of `json` and a BIN chunk of `bin` (padded to 4 bytes).
std::string glb(std::string json, std::string bin) {
  while (json.size() % 4 != 0) json += ' ';
  while (bin.size() % 4 != 0) bin += '\0';
  auto u32 = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  std::string out = "glTF" + u32(2) + u32(static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + bin.size()));
  out += u32(static_cast<std::uint32_t>(json.size())) + u32(0x4E4F534A) + json;
  out += u32(static_cast<std::uint32_t>(bin.size())) + u32(0x004E4942) + bin;
  return out;
}

// One triangle as plain accessors; `accessors` and `views` replace the defaults when given.
std::string plainGlb(const std::string& accessors, const std::string& views, const std::string& attributes = "") {
  std::string bin(36 + 12, '\0');
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::uint32_t idx[3] = {0, 1, 2};
  std::memcpy(bin.data(), pos, 36);
  std::memcpy(bin.data() + 36, idx, 12);
  const std::string json = fmt::format(
      R"({{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":48}}],"bufferViews":{},"accessors":{},)"
      R"("meshes":[{{"primitives":[{{"attributes":{{"POSITION":0{}}},"indices":1}}]}}]}})",
      views.empty() ? R"([{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":12}])" : views,
      accessors.empty()
          ? R"([{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},{"bufferView":1,"componentType":5125,"count":3,"type":"SCALAR"}])"
          : accessors,
      attributes);
  return glb(json, bin);
}

std::string plyHeader(const std::string& format, const std::string& body) {
  return "ply\nformat " + format + " 1.0\n" + body + "end_header\n";
}

// A 4x4 slice of 16-bit CT, with the geometry given as DICOM strings.
void writeDicomSlice(const std::string& path, int k, const std::string& position, const std::string& orientation,
                     const std::string& frames = "", int nesting = 0,
                     E_TransferSyntax syntax = EXS_LittleEndianExplicit) {
  DcmFileFormat ff;
  DcmDataset* d = ff.getDataset();
  d->putAndInsertString(DCM_SOPClassUID, UID_CTImageStorage);
  d->putAndInsertString(DCM_SOPInstanceUID, fmt::format("1.2.826.0.1.3680043.99.1.{}", k + 1).c_str());
  d->putAndInsertString(DCM_StudyInstanceUID, "1.2.826.0.1.3680043.99.2");
  d->putAndInsertString(DCM_SeriesInstanceUID, "1.2.826.0.1.3680043.99.3");
  d->putAndInsertString(DCM_Modality, "CT");
  d->putAndInsertString(DCM_InstanceNumber, std::to_string(k + 1).c_str());
  d->putAndInsertString(DCM_ImagePositionPatient, position.c_str());
  d->putAndInsertString(DCM_ImageOrientationPatient, orientation.c_str());
  d->putAndInsertString(DCM_PixelSpacing, "1\\1");
  d->putAndInsertUint16(DCM_Rows, 4);
  d->putAndInsertUint16(DCM_Columns, 4);
  d->putAndInsertUint16(DCM_SamplesPerPixel, 1);
  d->putAndInsertString(DCM_PhotometricInterpretation, "MONOCHROME2");
  d->putAndInsertUint16(DCM_BitsAllocated, 16);
  d->putAndInsertUint16(DCM_BitsStored, 16);
  d->putAndInsertUint16(DCM_HighBit, 15);
  d->putAndInsertUint16(DCM_PixelRepresentation, 0);
  if (!frames.empty()) d->putAndInsertString(DCM_NumberOfFrames, frames.c_str());
  DcmItem* item = d;
  for (int level = 0; level < nesting; ++level) {
    DcmItem* inner = nullptr;
    item->findOrCreateSequenceItem(DCM_ReferencedImageSequence, inner, 0);
    item = inner;
  }
  std::vector<Uint16> pixels(16, static_cast<Uint16>(100 * k));
  d->putAndInsertUint16Array(DCM_PixelData, pixels.data(), 16);
  ff.saveFile(path.c_str(), syntax);
}

// Three slices 1 mm apart; `bad` (one of them) gets `position` and `orientation`.
std::string dicomSeries(const std::string& dir, const std::string& position, const std::string& orientation) {
  fs::create_directories(dir + "/series");
  for (int k = 0; k < 3; ++k) {
    writeDicomSlice(fmt::format("{}/series/{}.dcm", dir, k), k, k == 1 ? position : fmt::format("0\\0\\{}", k),
                    k == 1 ? orientation : "1\\0\\0\\0\\1\\0");
  }
  return dir + "/series/1.dcm";
}

struct Case {
  const char* name;
  // Builds the input in `dir` and returns the path that the message must name.
  std::function<std::string(const std::string& dir)> build;
  // The arguments, with {in} for the input and {dir} for the folder.
  const char* args;
  int exitCode = 1;
};

const std::string kMha = "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n";
const std::string kNrrd = "NRRD0004\ntype: uint8\nencoding: raw\n";

const Case kCases[] = {
    // --- Crashes ---------------------------------------------------------------------------------
    {"MetaImageZeroChannels",
     [](const std::string& d) {
       write(d + "/v.mha", kMha + "ElementNumberOfChannels = 0\nElementDataFile = LOCAL\n" + voxels(64));
       return d + "/v.mha";
     },
     "extract {in} -o {dir}/out.ply"},
    {"MetaImageNegativeChannels",
     [](const std::string& d) {
       write(d + "/v.mha", kMha + "ElementNumberOfChannels = -3\nElementDataFile = LOCAL\n" + voxels(64));
       return d + "/v.mha";
     },
     "extract {in} -o {dir}/out.stl"},
    {"MetaImageHugeChannels",
     [](const std::string& d) {
       write(d + "/v.mha", kMha + "ElementNumberOfChannels = 1e12\nElementDataFile = LOCAL\n" + voxels(64));
       return d + "/v.mha";
     },
     "extract {in} -o {dir}/out.obj"},
    {"MetaImageTextChannels",
     [](const std::string& d) {
       write(d + "/v.mha", kMha + "ElementNumberOfChannels = many\nElementDataFile = LOCAL\n" + voxels(64));
       return d + "/v.mha";
     },
     "extract {in} -o {dir}/out.ply"},
    {"NrrdZeroComponents",
     [](const std::string& d) {
       write(d + "/v.nrrd", kNrrd + "dimension: 4\nsizes: 0 16 16 16\n\n" + voxels(4096));
       return d + "/v.nrrd";
     },
     "extract {in} -o {dir}/out.ply"},
    {"NrrdHugeComponents",
     [](const std::string& d) {
       write(d + "/v.nrrd", kNrrd + "dimension: 4\nsizes: 1e300 4 4 4\n\n" + voxels(64));
       return d + "/v.nrrd";
     },
     "extract {in} -o {dir}/out.glb"},
    {"NrrdFractionalComponents",
     [](const std::string& d) {
       write(d + "/v.nrrd", kNrrd + "dimension: 4\nsizes: 2.5 4 4 4\n\n" + voxels(160));
       return d + "/v.nrrd";
     },
     "extract {in} -o {dir}/out.drc"},
    {"GlbByteOffsetNear2To64",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb("", R"([{"buffer":0,"byteOffset":18446744073709551612,"byteLength":36},)"
                                        R"({"buffer":0,"byteOffset":36,"byteLength":12}])"));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbByteLengthNear2To64",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb("", R"([{"buffer":0,"byteOffset":4,"byteLength":18446744073709551615},)"
                                        R"({"buffer":0,"byteOffset":36,"byteLength":12}])"));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.obj"},
    {"GlbAccessorHugeCount",
     [](const std::string& d) {
       write(d + "/m.glb",
             plainGlb(R"([{"bufferView":0,"componentType":5126,"count":4611686018427387904,"type":"VEC3"},)"
                      R"({"bufferView":1,"componentType":5125,"count":3,"type":"SCALAR"}])",
                      ""));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.stl"},
    {"GlbAccessorOffsetNear2To64",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb(R"([{"bufferView":0,"byteOffset":18446744073709551615,"componentType":5126,)"
                                    R"("count":3,"type":"VEC3"},)"
                                    R"({"bufferView":1,"componentType":5125,"count":3,"type":"SCALAR"}])",
                                    ""));
       return d + "/m.glb";
     },
     "metrics {in}"},
    {"GlbZeroStride",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb("", R"([{"buffer":0,"byteLength":36,"byteStride":0},)"
                                        R"({"buffer":0,"byteOffset":36,"byteLength":12}])"));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbCountIsText",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb(R"([{"bufferView":0,"componentType":5126,"count":"three","type":"VEC3"},)"
                                    R"({"bufferView":1,"componentType":5125,"count":3,"type":"SCALAR"}])",
                                    ""));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbBufferViewsIsText",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb("", R"("views")"));
       return d + "/m.glb";
     },
     "metrics {in}"},
    {"GlbJsonIsAnArray",
     [](const std::string& d) {
       write(d + "/m.glb", glb("[1,2,3]", ""));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbJsonInvalid",
     [](const std::string& d) {
       write(d + "/m.glb", glb("{\"asset\":\n{", ""));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbJsonLengthBeyondFile",
     [](const std::string& d) {
       std::string g = plainGlb("", "");
       const std::uint32_t huge = 0xFFFFFFF0u;
       std::memcpy(g.data() + 12, &huge, 4);
       write(d + "/m.glb", g);
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbBinLengthBeyondFile",
     [](const std::string& d) {
       std::string g = plainGlb("", "");
       std::uint32_t jsonLength = 0;
       std::memcpy(&jsonLength, g.data() + 12, 4);
       const std::uint32_t huge = 0xFFFFFFF0u;
       std::memcpy(g.data() + 20 + jsonLength, &huge, 4);
       write(d + "/m.glb", g);
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbTruncatedHeader",
     [](const std::string& d) {
       write(d + "/m.glb", std::string("glTF\x02\0\0\0", 8));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbSeamKeysFewerThanVertices",
     [](const std::string& d) {
       write(d + "/m.glb", plainGlb(R"([{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},)"
                                    R"({"bufferView":1,"componentType":5125,"count":3,"type":"SCALAR"},)"
                                    R"({"bufferView":1,"componentType":5123,"count":1,"type":"VEC2"}])",
                                    "", R"(,"_ISOSLAB_SEAM":2)"));
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbFloatIndexNaN",
     [](const std::string& d) {
       std::string g = plainGlb(R"([{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},)"
                                R"({"bufferView":1,"componentType":5126,"count":3,"type":"SCALAR"}])",
                                "");
       const float nan = std::numeric_limits<float>::quiet_NaN();
       std::uint32_t jsonLength = 0;
       std::memcpy(&jsonLength, g.data() + 12, 4);
       std::memcpy(g.data() + 20 + jsonLength + 8 + 36, &nan, 4);
       write(d + "/m.glb", g);
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.ply"},
    {"GlbIndexOutOfRange",
     [](const std::string& d) {
       std::string g = plainGlb("", "");
       const std::uint32_t far = 7;
       std::uint32_t jsonLength = 0;
       std::memcpy(&jsonLength, g.data() + 12, 4);
       std::memcpy(g.data() + 20 + jsonLength + 8 + 40, &far, 4);
       write(d + "/m.glb", g);
       return d + "/m.glb";
     },
     "decode {in} -o {dir}/out.stl"},
    {"DicomDeeplyNestedSequences",
     [](const std::string& d) {
       writeDicomSlice(d + "/deep.dcm", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "", 10000);
       return d + "/deep.dcm";
     },
     "extract {in} -q -o {dir}/out.ply"},
    {"DicomDeeplyNestedImplicitLittleEndian",
     [](const std::string& d) {
       writeDicomSlice(d + "/deep.dcm", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "", 10000, EXS_LittleEndianImplicit);
       return d + "/deep.dcm";
     },
     "info {in}"},
    {"DicomDeeplyNestedBigEndian",
     [](const std::string& d) {
       writeDicomSlice(d + "/deep.dcm", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "", 10000, EXS_BigEndianExplicit);
       return d + "/deep.dcm";
     },
     "extract {in} -q -o {dir}/out.glb"},
    {"DicomNestingJustOverTheLimit",
     [](const std::string& d) {
       writeDicomSlice(d + "/deep.dcm", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "", 65);
       return d + "/deep.dcm";
     },
     "extract {in} -q -o {dir}/out.ply"},
    {"PlyNormalsFewerThanVertices",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("ascii",
                                     "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                                     "property float nx\nproperty float ny\nproperty float nz\n"
                                     "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                                     "element face 1\nproperty list uchar int vertex_indices\n") +
                               "0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0\n1 1 0\n3 0 1 2\n");
       return d + "/m.ply";
     },
     "decode {in} -o {dir}/out.ply"},
    {"PlyNormalsFewerThanVerticesToObj",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("ascii",
                                     "element vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
                                     "property float nx\nproperty float ny\nproperty float nz\n"
                                     "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
                                     "element face 1\nproperty list uchar int vertex_indices\n") +
                               "0 0 0 0 0 1\n1 0 0\n0 1 0\n3 0 1 2\n");
       return d + "/m.ply";
     },
     "decode {in} -o {dir}/out.obj"},
    // --- Hangs and runaway memory ----------------------------------------------------------------
    {"DicomPositionNaN", [](const std::string& d) { return dicomSeries(d, "0\\0\\nan", "1\\0\\0\\0\\1\\0"); },
     "extract {dir}/series -q -o {dir}/out.ply"},
    {"DicomPositionInfinite", [](const std::string& d) { return dicomSeries(d, "0\\0\\1e999", "1\\0\\0\\0\\1\\0"); },
     "extract {dir}/series -q -o {dir}/out.ply"},
    {"DicomOrientationNaN", [](const std::string& d) { return dicomSeries(d, "0\\0\\1", "1\\0\\0\\0\\nan\\0"); },
     "extract {dir}/series -q -o {dir}/out.stl"},
    {"DicomOrientationInfinite", [](const std::string& d) { return dicomSeries(d, "0\\0\\1", "1e999\\0\\0\\0\\1\\0"); },
     "info {dir}/series"},
    {"DicomHugeNumberOfFrames",
     [](const std::string& d) {
       writeDicomSlice(d + "/frames.dcm", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "2147483647");
       return d + "/frames.dcm";
     },
     "extract {in} -q -o {dir}/out.ply"},
    {"NrrdPatternOf4e9Names",
     [](const std::string& d) {
       write(d + "/v.nhdr", kNrrd + "dimension: 3\nsizes: 4 4 4\ndata file: s%03d.raw 0 4000000000 1\n\n");
       return d + "/v.nhdr";
     },
     "extract {in} -o {dir}/out.ply"},
    {"NrrdPatternNearLongLimits",
     [](const std::string& d) {
       write(d + "/v.nhdr",
             kNrrd + "dimension: 3\nsizes: 4 4 4\ndata file: s%d.raw -9223372036854775807 9223372036854775807 1\n\n");
       return d + "/v.nhdr";
     },
     "extract {in} -o {dir}/out.ply"},
    {"MetaImagePatternOf4e9Names",
     [](const std::string& d) {
       write(d + "/v.mhd", kMha + "ElementDataFile = s%d.raw 1 4000000000 1\n");
       return d + "/v.mhd";
     },
     "extract {in} -o {dir}/out.ply"},
    {"PlyElementWithoutPropertiesHugeCount",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("binary_little_endian", "element vertex 1000000000000000000\n"));
       return d + "/m.ply";
     },
     "metrics {in}"},
    {"PlyUnknownElementWithoutProperties",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("ascii", "element junk 18446744073709551615\n"));
       return d + "/m.ply";
     },
     "decode {in} -o {dir}/out.obj"},
    {"PlyVertexCountBeyondFile",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("binary_little_endian",
                                     "element vertex 100000000000\nproperty float x\nproperty float y\n"
                                     "property float z\n") +
                               std::string(24, '\0'));
       return d + "/m.ply";
     },
     "decode {in} -o {dir}/out.ply"},
    {"PlyListCountBeyondFile",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("ascii",
                                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                     "element face 1\nproperty list uint int vertex_indices\n") +
                               "0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n");
       return d + "/m.ply";
     },
     "metrics {in}"},
    {"PlyListCountNegative",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("ascii",
                                     "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                     "element face 1\nproperty list int int vertex_indices\n") +
                               "0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n");
       return d + "/m.ply";
     },
     "decode {in} -o {dir}/out.stl"},
    {"FifoAsVolumeInput",
     [](const std::string& d) {
       ::mkfifo((d + "/v.nrrd").c_str(), 0600);
       return d + "/v.nrrd";
     },
     "extract {in} -o {dir}/out.ply"},
    {"FifoAsRawInput",
     [](const std::string& d) {
       ::mkfifo((d + "/v.raw").c_str(), 0600);
       return d + "/v.raw";
     },
     "extract {in} --raw-dims 4,4,4 -o {dir}/out.ply"},
    {"FifoAsMeshInput",
     [](const std::string& d) {
       ::mkfifo((d + "/m.ply").c_str(), 0600);
       return d + "/m.ply";
     },
     "metrics {in}"},
    {"FifoAsInfoInput",
     [](const std::string& d) {
       ::mkfifo((d + "/slice.dcm").c_str(), 0600);
       return d + "/slice.dcm";
     },
     "info {in}"},
    {"FifoAsSecondRawSliceFile",
     [](const std::string& d) {
       write(d + "/s0.raw", voxels(16));
       ::mkfifo((d + "/s1.raw").c_str(), 0600);
       write(d + "/s2.raw", voxels(16));
       return d + "/s1.raw";
     },
     "extract {dir}/s%d.raw --raw-dims 4,4 -o {dir}/out.ply"},
    {"DicomdirDeeplyNested",
     [](const std::string& d) {
       writeDicomSlice(d + "/DICOMDIR", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "", 10000);
       return d + "/DICOMDIR";
     },
     "info {in}"},
    {"DevZeroAsVolumeInput",
     [](const std::string& d) {
       fs::create_symlink("/dev/zero", d + "/zero.mha");
       return d + "/zero.mha";
     },
     "extract {in} -o {dir}/out.ply"},
    {"DevZeroAsRawInput", [](const std::string&) { return std::string("/dev/zero"); },
     "extract {in} --raw-dims 4,4,4 -o {dir}/out.ply"},
    {"DevZeroAsMeshInput", [](const std::string&) { return std::string("/dev/zero"); }, "decode {in} -o {dir}/out.ply"},
    {"DevZeroAsNrrdDataFile",
     [](const std::string& d) {
       write(d + "/v.nhdr", kNrrd + "dimension: 3\nsizes: 4 4 4\ndata file: /dev/zero\n\n");
       return std::string("/dev/zero");
     },
     "extract {dir}/v.nhdr -o {dir}/out.ply"},
    {"MetaImageHugeDims",
     [](const std::string& d) {
       write(d + "/v.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 4000000000 4000000000 4000000000\n"
             "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" +
                 voxels(64));
       return d + "/v.mha";
     },
     "extract {in} -o {dir}/out.ply"},
    {"MetaImageSliceOverLimit",
     [](const std::string& d) {
       write(d + "/v.mha",
             "ObjectType = Image\nNDims = 3\nDimSize = 100000 100000 2\n"
             "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" +
                 voxels(64));
       return d + "/v.mha";
     },
     "extract {in} -o {dir}/out.ply"},
    {"PhantomSliceOverLimit", [](const std::string&) { return std::string("phantom:sphere?n=100000,100000,2"); },
     "extract '{in}' -o {dir}/out.ply"},
    {"PlyAsciiVertexCountBeyondFile",
     [](const std::string& d) {
       write(d + "/m.ply", plyHeader("ascii",
                                     "element vertex 99999999999\nproperty float x\nproperty float y\n"
                                     "property float z\n") +
                               "0 0 0\n");
       return d + "/m.ply";
     },
     "metrics {in}"},
    {"NrrdHeaderOverLimit",
     [](const std::string& d) {
       write(d + "/v.nrrd", kNrrd + "content: " + std::string(17 * 1024 * 1024, 'x'));
       return d + "/v.nrrd";
     },
     "extract {in} -o {dir}/out.ply"},
    {"MetaImageListOverLimit",
     [](const std::string& d) {
       std::string names;
       for (int k = 0; k < 1000001; ++k) names += "a\n";
       write(d + "/v.mhd", kMha + "ElementDataFile = LIST\n" + names);
       return d + "/v.mhd";
     },
     "extract {in} -o {dir}/out.ply"},
    {"NrrdNegativeSizes",
     [](const std::string& d) {
       write(d + "/v.nrrd", kNrrd + "dimension: 3\nsizes: 4 -4 4\n\n" + voxels(64));
       return d + "/v.nrrd";
     },
     "extract {in} -o {dir}/out.ply"},
    // --- Silently wrong output: DICOM, image stacks and messages (helper 1) ---------------------
    // (end of helper 1 section)
    // --- Silently wrong output: NRRD, MetaImage, NIfTI, raw, gzip, --iso and meshes (helper 2) ---
    // (end of helper 2 section)
    // --- Fuzz regressions ---------------------------------------------------------------------------
    // (end of fuzz section)
    // --- Usage errors ------------------------------------------------------------------------------
    {"UsageUnknownOption",
     [](const std::string& d) {
       write(d + "/v.nrrd", kNrrd + "dimension: 3\nsizes: 4 4 4\n\n" + voxels(64));
       return std::string("--no-such-option");
     },
     "extract {dir}/v.nrrd --no-such-option -o {dir}/out.ply", 2},
};

class BadInput : public ::testing::TestWithParam<Case> {};

TEST_P(BadInput, FailsCleanlyWithOneLineNamingTheFile) {
  const Case& c = GetParam();
  const std::string dir = tempDir();
  const std::string named = c.build(dir);
  std::set<std::string> before;
  for (const auto& e : fs::directory_iterator(dir)) before.insert(e.path().filename().string());
  std::string args = c.args;
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"{in}", named}, {"{dir}", dir}}) {
    for (std::size_t at = args.find(key); at != std::string::npos; at = args.find(key, at + value.size()))
      args.replace(at, key.size(), value);
  }
  const CliResult r = runCli(args);
  EXPECT_EQ(r.exitCode, c.exitCode) << args << "\n" << r.err;
  EXPECT_EQ(r.err.rfind("isoslab: error: ", 0), 0u) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
  EXPECT_NE(r.err.find(named), std::string::npos) << "does not name " << named << ": " << r.err;
  std::set<std::string> after;
  for (const auto& e : fs::directory_iterator(dir)) after.insert(e.path().filename().string());
  EXPECT_EQ(after, before) << "an output or temporary file was left in " << dir;
}

// The limits are limits, not guesses: an input just within each is read.
TEST(BadInputLimits, NestingAtTheLimitIsRead) {
  const std::string dir = tempDir();
  writeDicomSlice(dir + "/a.dcm", 0, "0\\0\\0", "1\\0\\0\\0\\1\\0", "", 64);
  writeDicomSlice(dir + "/b.dcm", 1, "0\\0\\1", "1\\0\\0\\0\\1\\0", "", 64, EXS_LittleEndianImplicit);
  const CliResult r = runCli("info " + dir);
  EXPECT_EQ(r.exitCode, 0) << r.err;
  EXPECT_NE(r.out.find("0 files skipped"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("images         2"), std::string::npos) << r.out;
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadInput, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& param) { return std::string(param.param.name); });

}  // namespace
}  // namespace isoslab::testing
