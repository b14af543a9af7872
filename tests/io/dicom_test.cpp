// DICOM series written with DCMTK's API from a phantom of known geometry, read back through
// isoslab's DICOM reader; plus the real series in ../shared/data.
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcddirif.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcpixel.h>
#include <dcmtk/dcmdata/dcpixseq.h>
#include <dcmtk/dcmdata/dcpxitem.h>
#include <dcmtk/dcmdata/dcrleerg.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmjpeg/djencode.h>
#include <dcmtk/dcmjpeg/djrplol.h>
#include <dcmtk/dcmjpls/djencode.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <openjpeg.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <numbers>
#include <optional>
#include <random>

#include <sys/wait.h>

#include "core/error.h"
#include "extract/frame.h"
#include "io/crop_source.h"
#include "io/dicom_series.h"
#include "io/open_source.h"
#include "io/phantom.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using Vec3 = std::array<double, 3>;

constexpr std::array<std::int64_t, 3> kDims{40, 36, 30};
const char* kPhantom = "phantom:head?n=40,36,30&seed=5";

// The phantom's values (int16 HU), x fastest.
std::vector<float> phantomValues() {
  auto p = PhantomSource::open(kPhantom);
  std::vector<float> all;
  std::vector<float> slice(static_cast<std::size_t>(kDims[0] * kDims[1]));
  while (p->readSlice(slice)) all.insert(all.end(), slice.begin(), slice.end());
  return all;
}

enum class Codec { kNone, kImplicit, kBigEndian, kDeflated, kRle, kJpegLossless, kJpegLs, kJpeg2000 };

struct SeriesSpec {
  std::string uid = "1.2.826.0.1.3680043.9.7777.1";
  std::array<double, 6> orientation{1, 0, 0, 0, 1, 0};
  std::array<double, 2> pixelSpacing{0.7, 0.6};  // row spacing, column spacing
  std::function<Vec3(int)> position = [](int k) { return Vec3{-10, 20, 30 + 1.5 * k}; };
  bool signedPixels = true;
  int bitsStored = 16;
  bool mono1 = false;
  double slope = 1;
  double intercept = 0;
  Codec codec = Codec::kNone;
  bool shuffledNames = false;
  bool multiFrame = false;
  int slices = static_cast<int>(kDims[2]);
  int samplesPerPixel = 1;  // 3: RGB with the phantom in the green channel
  int stacks = 1;           // multi-frame: the volume repeated as stacks "1", "2", ..., 500 mm apart in x
  // SliceThickness of slice k (single-frame files), when set.
  std::function<double(int)> thickness;
  // GantryDetectorTilt, when set.
  std::optional<double> gantryTilt;
};

void registerEncoders() {
  static std::once_flag once;
  std::call_once(once, [] {
    DcmRLEEncoderRegistration::registerCodecs();
    DJEncoderRegistration::registerCodecs();
    DJLSEncoderRegistration::registerCodecs();
    // Deregistered (and freed) at exit, before the leak checker looks.
    std::atexit([] {
      DJLSEncoderRegistration::cleanup();
      DJEncoderRegistration::cleanup();
      DcmRLEEncoderRegistration::cleanup();
    });
  });
}

std::string ds(const double* v, int n) {
  std::string s;
  for (int i = 0; i < n; ++i) {
    if (i > 0) s.push_back('\\');
    s.append(fmt::format("{:.10g}", v[i]));
  }
  return s;
}

// JPEG 2000 lossless (reversible 5-3 wavelet) codestream of one 16-bit frame, with OpenJPEG.
std::vector<std::uint8_t> encodeJ2k(const std::vector<std::uint16_t>& stored, bool isSigned, int bits) {
  opj_image_cmptparm_t cp{};
  cp.dx = cp.dy = 1;
  cp.w = static_cast<OPJ_UINT32>(kDims[0]);
  cp.h = static_cast<OPJ_UINT32>(kDims[1]);
  cp.prec = static_cast<OPJ_UINT32>(bits);
  cp.sgnd = isSigned ? 1 : 0;
  opj_image_t* image = opj_image_create(1, &cp, OPJ_CLRSPC_GRAY);
  image->x1 = cp.w;
  image->y1 = cp.h;
  for (std::size_t p = 0; p < stored.size(); ++p) {
    image->comps[0].data[p] = isSigned ? static_cast<std::int16_t>(stored[p]) : stored[p];
  }
  opj_cparameters_t params;
  opj_set_default_encoder_parameters(&params);
  params.tcp_numlayers = 1;
  params.tcp_rates[0] = 0;
  params.cp_disto_alloc = 1;
  params.irreversible = 0;
  opj_codec_t* codec = opj_create_compress(OPJ_CODEC_J2K);
  opj_setup_encoder(codec, &params, image);
  struct Out {
    std::vector<std::uint8_t> bytes;
    std::size_t pos = 0;
  } out;
  opj_stream_t* stream = opj_stream_default_create(OPJ_FALSE);
  opj_stream_set_user_data(stream, &out, nullptr);
  opj_stream_set_write_function(stream, [](void* buf, OPJ_SIZE_T n, void* user) -> OPJ_SIZE_T {
    auto* o = static_cast<Out*>(user);
    if (o->bytes.size() < o->pos + n) o->bytes.resize(o->pos + n);
    std::memcpy(o->bytes.data() + o->pos, buf, n);
    o->pos += n;
    return n;
  });
  opj_stream_set_skip_function(stream, [](OPJ_OFF_T n, void* user) -> OPJ_OFF_T {
    auto* o = static_cast<Out*>(user);
    o->pos += static_cast<std::size_t>(n);
    if (o->bytes.size() < o->pos) o->bytes.resize(o->pos);
    return n;
  });
  opj_stream_set_seek_function(stream, [](OPJ_OFF_T n, void* user) -> OPJ_BOOL {
    static_cast<Out*>(user)->pos = static_cast<std::size_t>(n);
    return OPJ_TRUE;
  });
  const bool ok =
      opj_start_compress(codec, image, stream) && opj_encode(codec, stream) && opj_end_compress(codec, stream);
  opj_stream_destroy(stream);
  opj_destroy_codec(codec);
  opj_image_destroy(image);
  EXPECT_TRUE(ok);
  if (out.bytes.size() % 2) out.bytes.push_back(0);
  return out.bytes;
}

// Writes the phantom as a DICOM series (or one multi-frame file) into `dir`.
void writeSeries(const std::string& dir, const SeriesSpec& spec) {
  registerEncoders();
  const std::vector<float> values = phantomValues();
  const auto plane = static_cast<std::size_t>(kDims[0] * kDims[1]);
  const std::int64_t lo = spec.signedPixels ? -(1 << (spec.bitsStored - 1)) : 0;
  const std::int64_t hi = spec.signedPixels ? (1 << (spec.bitsStored - 1)) - 1 : (1 << spec.bitsStored) - 1;
  std::mt19937 rng(42);
  std::vector<int> order(static_cast<std::size_t>(spec.slices));
  for (int k = 0; k < spec.slices; ++k) order[static_cast<std::size_t>(k)] = k;
  if (spec.shuffledNames) std::shuffle(order.begin(), order.end(), rng);

  auto stored = [&](int k) {
    std::vector<std::uint16_t> out(plane);
    for (std::size_t p = 0; p < plane; ++p) {
      const double v = values[static_cast<std::size_t>(k) * plane + p];
      std::int64_t s = std::llround((v - spec.intercept) / spec.slope);
      EXPECT_EQ(static_cast<double>(s) * spec.slope + spec.intercept, v);  // exactly representable
      EXPECT_TRUE(s >= lo && s <= hi);
      if (spec.mono1) s = lo + hi - s;
      out[p] = static_cast<std::uint16_t>(s & ((1 << spec.bitsStored) - 1));
    }
    return out;
  };
  auto common = [&](DcmDataset* d) {
    d->putAndInsertString(DCM_StudyInstanceUID, "1.2.826.0.1.3680043.9.7777");
    d->putAndInsertString(DCM_SeriesInstanceUID, spec.uid.c_str());
    d->putAndInsertString(DCM_Modality, "CT");
    d->putAndInsertString(DCM_PatientName, "Phantom^Head");
    d->putAndInsertString(DCM_PatientID, "ISOSLAB1");
    d->putAndInsertString(DCM_StudyDate, "20261122");
    d->putAndInsertString(DCM_StudyTime, "120000");
    d->putAndInsertString(DCM_StudyID, "1");
    d->putAndInsertString(DCM_AccessionNumber, "");
    d->putAndInsertString(DCM_SeriesNumber, "1");
    d->putAndInsertUint16(DCM_Rows, static_cast<Uint16>(kDims[1]));
    d->putAndInsertUint16(DCM_Columns, static_cast<Uint16>(kDims[0]));
    d->putAndInsertUint16(DCM_SamplesPerPixel, 1);
    d->putAndInsertString(DCM_PhotometricInterpretation, spec.mono1 ? "MONOCHROME1" : "MONOCHROME2");
    d->putAndInsertUint16(DCM_BitsAllocated, 16);
    d->putAndInsertUint16(DCM_BitsStored, static_cast<Uint16>(spec.bitsStored));
    d->putAndInsertUint16(DCM_HighBit, static_cast<Uint16>(spec.bitsStored - 1));
    d->putAndInsertUint16(DCM_PixelRepresentation, spec.signedPixels ? 1 : 0);
  };
  const double spacing[2] = {spec.pixelSpacing[0], spec.pixelSpacing[1]};
  const double rescale[2] = {spec.slope, spec.intercept};

  if (spec.multiFrame) {
    DcmFileFormat ff;
    DcmDataset* d = ff.getDataset();
    common(d);
    d->putAndInsertString(DCM_SOPClassUID, UID_EnhancedCTImageStorage);
    d->putAndInsertString(DCM_SOPInstanceUID, (spec.uid + ".9").c_str());
    d->putAndInsertString(DCM_NumberOfFrames, std::to_string(spec.slices * spec.stacks).c_str());
    DcmItem* shared = nullptr;
    DcmItem* sub = nullptr;
    d->findOrCreateSequenceItem(DCM_SharedFunctionalGroupsSequence, shared, 0);
    shared->findOrCreateSequenceItem(DCM_PixelMeasuresSequence, sub, 0);
    sub->putAndInsertString(DCM_PixelSpacing, ds(spacing, 2).c_str());
    shared->findOrCreateSequenceItem(DCM_PlaneOrientationSequence, sub, 0);
    sub->putAndInsertString(DCM_ImageOrientationPatient, ds(spec.orientation.data(), 6).c_str());
    shared->findOrCreateSequenceItem(DCM_PixelValueTransformationSequence, sub, 0);
    sub->putAndInsertString(DCM_RescaleSlope, fmt::format("{}", rescale[0]).c_str());
    sub->putAndInsertString(DCM_RescaleIntercept, fmt::format("{}", rescale[1]).c_str());
    std::vector<std::uint16_t> all;
    // Frames in shuffled order too: the reader must sort by position.
    for (int stack = 0; stack < spec.stacks; ++stack) {
      for (int k : order) {
        DcmItem* frame = nullptr;
        d->findOrCreateSequenceItem(DCM_PerFrameFunctionalGroupsSequence, frame, -2);
        frame->findOrCreateSequenceItem(DCM_PlanePositionSequence, sub, 0);
        Vec3 pos = spec.position(k);
        pos[0] += 500.0 * stack;
        sub->putAndInsertString(DCM_ImagePositionPatient, ds(pos.data(), 3).c_str());
        if (spec.stacks > 1) {
          frame->findOrCreateSequenceItem(DCM_FrameContentSequence, sub, 0);
          sub->putAndInsertString(DCM_StackID, std::to_string(stack + 1).c_str());
        }
        const auto s = stored(k);
        all.insert(all.end(), s.begin(), s.end());
      }
    }
    d->putAndInsertUint16Array(DCM_PixelData, all.data(), static_cast<unsigned long>(all.size()));
    // RLE compresses each frame on its own, one fragment per frame, with an empty offset table.
    const E_TransferSyntax xfer = spec.codec == Codec::kRle ? EXS_RLELossless : EXS_LittleEndianExplicit;
    if (xfer != EXS_LittleEndianExplicit) {
      ASSERT_TRUE(d->chooseRepresentation(xfer, nullptr).good());
    }
    ASSERT_TRUE(ff.saveFile((dir + "/enhanced.dcm").c_str(), xfer).good());
    return;
  }

  for (int k : order) {
    DcmFileFormat ff;
    DcmDataset* d = ff.getDataset();
    common(d);
    d->putAndInsertString(DCM_SOPClassUID, UID_CTImageStorage);
    d->putAndInsertString(DCM_SOPInstanceUID, fmt::format("{}.{}", spec.uid, k + 1).c_str());
    d->putAndInsertString(DCM_InstanceNumber, std::to_string(k + 1).c_str());
    d->putAndInsertString(DCM_PixelSpacing, ds(spacing, 2).c_str());
    d->putAndInsertString(DCM_ImageOrientationPatient, ds(spec.orientation.data(), 6).c_str());
    const Vec3 pos = spec.position(k);
    d->putAndInsertString(DCM_ImagePositionPatient, ds(pos.data(), 3).c_str());
    if (spec.thickness) d->putAndInsertString(DCM_SliceThickness, fmt::format("{}", spec.thickness(k)).c_str());
    if (spec.gantryTilt) d->putAndInsertString(DCM_GantryDetectorTilt, fmt::format("{}", *spec.gantryTilt).c_str());
    d->putAndInsertString(DCM_RescaleSlope, fmt::format("{}", rescale[0]).c_str());
    d->putAndInsertString(DCM_RescaleIntercept, fmt::format("{}", rescale[1]).c_str());
    const auto s = stored(k);
    E_TransferSyntax xfer = EXS_LittleEndianExplicit;
    if (spec.codec == Codec::kJpeg2000) {
      const auto code = encodeJ2k(s, spec.signedPixels, spec.bitsStored);
      auto* sequence = new DcmPixelSequence(DCM_PixelSequenceTag);
      sequence->insert(new DcmPixelItem(DCM_PixelItemTag));  // empty offset table
      auto* fragment = new DcmPixelItem(DCM_PixelItemTag);
      fragment->putUint8Array(code.data(), static_cast<unsigned long>(code.size()));
      sequence->insert(fragment);
      auto* pixels = new DcmPixelData(DCM_PixelData);
      pixels->putOriginalRepresentation(EXS_JPEG2000LosslessOnly, nullptr, sequence);
      d->insert(pixels, true);
      xfer = EXS_JPEG2000LosslessOnly;
    } else {
      if (spec.samplesPerPixel == 3) {
        std::vector<std::uint16_t> rgb;
        for (std::uint16_t v : s)
          rgb.insert(rgb.end(), {static_cast<std::uint16_t>(0), v, static_cast<std::uint16_t>(7)});
        d->putAndInsertUint16(DCM_SamplesPerPixel, 3);
        d->putAndInsertUint16(DCM_PlanarConfiguration, 0);
        d->putAndInsertString(DCM_PhotometricInterpretation, "RGB");
        d->putAndInsertUint16Array(DCM_PixelData, rgb.data(), static_cast<unsigned long>(rgb.size()));
      } else {
        d->putAndInsertUint16Array(DCM_PixelData, s.data(), static_cast<unsigned long>(s.size()));
      }
      if (spec.codec == Codec::kImplicit) xfer = EXS_LittleEndianImplicit;
      if (spec.codec == Codec::kBigEndian) xfer = EXS_BigEndianExplicit;
      if (spec.codec == Codec::kDeflated) xfer = EXS_DeflatedLittleEndianExplicit;
      if (spec.codec >= Codec::kRle) {
        xfer = spec.codec == Codec::kRle            ? EXS_RLELossless
               : spec.codec == Codec::kJpegLossless ? EXS_JPEGProcess14SV1
                                                    : EXS_JPEGLSLossless;
        DJ_RPLossless jpegParams;
        ASSERT_TRUE(d->chooseRepresentation(xfer, spec.codec == Codec::kJpegLossless ? &jpegParams : nullptr).good());
        ASSERT_TRUE(d->canWriteXfer(xfer));
      }
    }
    const std::string name =
        spec.shuffledNames ? fmt::format("{}/im{:08x}", dir, rng()) : fmt::format("{}/s{:03d}.dcm", dir, k);
    ASSERT_TRUE(ff.saveFile(name.c_str(), xfer).good()) << name;
  }
}

testing::Extraction extractDicom(const std::string& dir, const std::string& space, const DicomOptions& options = {}) {
  SourceOptions o;
  o.dicom = options;
  auto source = openSource(dir, o);
  ExtractOptions e;
  e.iso = -400;
  const LatticeFrame frame = LatticeFrame::forSpace(source->info(), space);
  auto extractor = makeExtractor(e, source->info(), frame);
  MemoryMeshSink memory;
  MeshStatsSink stats;
  TeeSink tee({&memory, &stats});
  runPipeline(*source, *extractor, tee, MeshHeader{});
  return {memory.mesh(), stats.stats()};
}

// Maps a voxel-space vertex through the series' known geometry.
Vec3 toPatient(const SeriesSpec& spec, const Vec3f& v) {
  const double k = v.z;
  const int k0 = std::min(static_cast<int>(std::floor(k)), spec.slices - 2);
  const double t = k - k0;
  const Vec3 a = spec.position(k0);
  const Vec3 b = spec.position(k0 + 1);
  const auto& o = spec.orientation;
  Vec3 p;
  for (int c = 0; c < 3; ++c) {
    p[static_cast<std::size_t>(c)] = a[static_cast<std::size_t>(c)] +
                                     t * (b[static_cast<std::size_t>(c)] - a[static_cast<std::size_t>(c)]) +
                                     v.x * spec.pixelSpacing[1] * o[static_cast<std::size_t>(c)] +
                                     v.y * spec.pixelSpacing[0] * o[static_cast<std::size_t>(3 + c)];
  }
  return p;
}

const testing::Extraction& reference() {
  static const testing::Extraction ref = testing::extract(kPhantom, Method::kMarchingCubes, -400);
  return ref;
}

// Extracts `spec`'s series in voxel space (must equal the phantom bit for bit) and in LPS (must
// equal the known transform of the voxel mesh, to float precision).
void checkSeries(const SeriesSpec& spec, const std::string& dir) {
  const testing::Extraction voxel = extractDicom(dir, "voxel");
  ASSERT_GT(voxel.mesh.triangles.size(), 1000u);
  EXPECT_TRUE(voxel.mesh.positions == reference().mesh.positions);
  EXPECT_TRUE(voxel.mesh.triangles == reference().mesh.triangles);
  const testing::Extraction lps = extractDicom(dir, "physical");
  ASSERT_EQ(lps.mesh.positions.size(), voxel.mesh.positions.size());
  EXPECT_TRUE(lps.mesh.triangles == voxel.mesh.triangles);
  double worst = 0;
  for (std::size_t v = 0; v < voxel.mesh.positions.size(); ++v) {
    const Vec3 want = toPatient(spec, voxel.mesh.positions[v]);
    const Vec3f& got = lps.mesh.positions[v];
    worst = std::max({worst, std::abs(got.x - want[0]), std::abs(got.y - want[1]), std::abs(got.z - want[2])});
  }
  // Float32 outputs: half an ulp at 100 mm is 4e-6 mm; the voxel positions add their own rounding.
  EXPECT_LT(worst, 2e-5);
  EXPECT_GT(lps.stats.volume, 0.0);  // normals still point outward
  EXPECT_EQ(lps.stats.inconsistentEdges, 0u);
}

TEST(Dicom, ShuffledNamesAndInterleavedSeriesGiveThePhantomsMesh) {
  const std::string dir = testing::tempDir();
  SeriesSpec main;
  main.shuffledNames = true;
  writeSeries(dir, main);
  SeriesSpec other;
  other.uid = "1.2.826.0.1.3680043.9.7777.2";
  other.shuffledNames = true;
  other.slices = 6;
  other.position = [](int k) { return Vec3{0, 0, 100.0 + 3 * k}; };
  writeSeries(dir, other);
  {
    std::ofstream junk(dir + "/notes.txt");
    junk << "not DICOM\n";
  }
  const DicomScan scan = scanDicom({dir}, {});
  ASSERT_EQ(scan.series.size(), 2u);
  EXPECT_EQ(scan.skipped, 1);
  std::string note;
  const DicomSeries& chosen = chooseSeries(scan, {}, &note);
  EXPECT_EQ(chosen.uid, main.uid);
  EXPECT_EQ(note,
            fmt::format("2 series found; using series 0 ({}, 30 images), the largest; choose with `series`", main.uid));
  checkSeries(main, dir);
  DicomOptions pick;
  pick.series = "1";
  EXPECT_EQ(chooseSeries(scan, pick, nullptr).uid, other.uid);
  pick.series = main.uid;
  EXPECT_EQ(chooseSeries(scan, pick, nullptr).uid, main.uid);
  pick.series = "7";
  try {
    chooseSeries(scan, pick, nullptr);
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "`series`: no series '7' (give a SeriesInstanceUID or an index 0..1; see isoslab info)");
  }
  // A list of files is an input too.
  std::vector<std::string> some;
  for (const std::string& f : {dir + "/notes.txt"}) some.push_back(f);
  for (const auto& e : fs::directory_iterator(dir)) {
    if (some.size() < 4 && e.path().filename().string().rfind("im", 0) == 0) some.push_back(e.path().string());
  }
  EXPECT_EQ(scanDicom(some, {}).skipped, 1);
  std::size_t listed = 0;
  for (const DicomSeries& s : scanDicom(some, {}).series) listed += s.slices.size();
  EXPECT_EQ(listed, 3u);
}

TEST(Dicom, ADicomdirListsTheSeriesFiles) {
  const std::string dir = testing::tempDir();
  const std::string staging = testing::tempDir();
  SeriesSpec spec;
  writeSeries(staging, spec);
  fs::create_directories(dir + "/DATA");
  DicomDirInterface dicomdir;
  dicomdir.enableInventMode(OFTrue);
  dicomdir.enableInventPatientIDMode(OFTrue);
  ASSERT_TRUE(
      dicomdir.createNewDicomDir(DicomDirInterface::AP_GeneralPurpose, (dir + "/DICOMDIR").c_str(), "ISOSLAB").good());
  for (int k = 0; k < spec.slices; ++k) {
    const std::string name = fmt::format("DATA/IM{:04d}", k);
    fs::copy_file(fmt::format("{}/s{:03d}.dcm", staging, k), dir + "/" + name);
    const OFCondition added = dicomdir.addDicomFile(name.c_str(), dir.c_str());
    ASSERT_TRUE(added.good()) << name << ": " << added.text();
  }
  ASSERT_TRUE(dicomdir.writeDicomDir().good());
  const DicomScan scan = scanDicom({dir + "/DICOMDIR"}, {});
  ASSERT_EQ(scan.series.size(), 1u);
  EXPECT_EQ(scan.series.front().slices.size(), static_cast<std::size_t>(spec.slices));
  const testing::Extraction x = extractDicom(dir + "/DICOMDIR", "voxel");
  EXPECT_TRUE(x.mesh.positions == reference().mesh.positions);
}

// DCMTK and Open MPI come from modules loaded only when needed (core/modules.h): the dynamic
// loader's own log (LD_DEBUG=files, on the program's stderr) names the libraries it maps. A run on
// a phantom maps neither; a DICOM series maps the DICOM module and DCMTK, and still not MPI.
TEST(Dicom, DcmtkAndMpiAreLoadedOnlyWhenNeeded) {
  const std::string series = testing::tempDir();
  writeSeries(series, SeriesSpec{});
  const std::string dir = testing::tempDir();
  ::setenv("LD_DEBUG", "files", 1);
  const auto plain = testing::runCli("extract 'phantom:sphere?n=16' -o " + dir + "/p.ply -q");
  const auto dicom = testing::runCli("extract " + series + " --iso 300 -o " + dir + "/d.ply -q");
  ::unsetenv("LD_DEBUG");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  ASSERT_EQ(dicom.exitCode, 0) << dicom.err;
  EXPECT_NE(plain.err.find("file=libdraco"), std::string::npos) << "no loader log";  // the log is there
  for (const char* library : {"libisoslab_dicom.so", "libdcmdata", "libisoslab_mpi.so", "libmpi"}) {
    EXPECT_EQ(plain.err.find(library), std::string::npos) << library;
  }
  EXPECT_NE(dicom.err.find("libisoslab_dicom.so"), std::string::npos);
  EXPECT_NE(dicom.err.find("libdcmdata"), std::string::npos);
  EXPECT_EQ(dicom.err.find("libmpi"), std::string::npos);
}

// A program whose DICOM module is missing (copied away from it, say) says so in one line, and
// leaves no output.
TEST(Dicom, AMissingModuleIsOneLine) {
  const std::string series = testing::tempDir();
  writeSeries(series, SeriesSpec{});
  const std::string dir = testing::tempDir();
  std::filesystem::copy_file(ISOSLAB_CLI_PATH, dir + "/isoslab");
  const std::string cmd = "env -u ISOSLAB_DICOM_MODULE " + dir + "/isoslab extract " + series + " --iso 300 -o " + dir +
                          "/d.ply -q >" + dir + "/out 2>" + dir + "/err </dev/null";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_NE(WEXITSTATUS(status), 0);
  EXPECT_EQ(testing::slurp(dir + "/err"),
            "isoslab: error: DICOM files need the DICOM module libisoslab_dicom.so, which was not found\n");
  EXPECT_EQ(testing::slurp(dir + "/out"), "");
  EXPECT_FALSE(std::filesystem::exists(dir + "/d.ply"));
}

TEST(Dicom, AMultiFrameFileWithTwoStacksBecomesTwoSeries) {
  SeriesSpec spec;
  spec.multiFrame = true;
  spec.stacks = 2;
  const std::string dir = testing::tempDir();
  writeSeries(dir, spec);
  const DicomScan scan = scanDicom({dir}, {});
  ASSERT_EQ(scan.series.size(), 2u);
  EXPECT_EQ(scan.series[0].uid, spec.uid + "/stack 1");
  EXPECT_EQ(scan.series[1].uid, spec.uid + "/stack 2");
  for (const char* pick : {"0", "1"}) {
    DicomOptions o;
    o.series = pick;
    const testing::Extraction x = extractDicom(dir, "voxel", o);
    EXPECT_TRUE(x.mesh.positions == reference().mesh.positions) << pick;
  }
}

// --roi: a box of the series skips the slices before it (single-frame files unopened, the frames
// of a compressed multi-frame file decoded in order) and gives the mesh of reading every slice.
TEST(Dicom, ABoxSkipsToItsSlicesInEveryLayout) {
  struct Layout {
    Codec codec;
    bool multiFrame;
    int stacks;
  };
  for (const Layout layout : {Layout{Codec::kNone, false, 1}, Layout{Codec::kRle, false, 1},
                              Layout{Codec::kNone, true, 2}, Layout{Codec::kRle, true, 2}}) {
    SeriesSpec spec;
    spec.codec = layout.codec;
    spec.multiFrame = layout.multiFrame;
    spec.stacks = layout.stacks;
    spec.shuffledNames = true;
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    const DicomScan scan = scanDicom({dir}, {});
    const LatticeBox box{{3, 4, 9}, {35, 30, 20}};
    for (const DicomSeries& series : scan.series) {
      CropSource skipping(openDicomSeries(series, {}), box);
      // The reference reads every slice up to the box (SliceSource's own skipSlices).
      struct Reading final : SliceSource {
        explicit Reading(std::unique_ptr<SliceSource> s) : inner(std::move(s)) {}
        const VolumeInfo& info() const noexcept override { return inner->info(); }
        bool readSlice(std::span<float> slice) override { return inner->readSlice(slice); }
        std::unique_ptr<SliceSource> inner;
      };
      CropSource reading(std::make_unique<Reading>(openDicomSeries(series, {})), box);
      const testing::Extraction a = testing::extract(skipping, Method::kMarchingCubes, -400);
      const testing::Extraction b = testing::extract(reading, Method::kMarchingCubes, -400);
      EXPECT_GT(a.mesh.triangles.size(), 500u);
      EXPECT_TRUE(a.mesh == b.mesh) << static_cast<int>(layout.codec) << " multi-frame " << layout.multiFrame;
    }
    // The whole series too: frames stored out of order were once decoded with the previous
    // frame's fragment hint ("Illegal call" from DCMTK's RLE decoder).
    DicomOptions first;
    first.series = "0";
    EXPECT_TRUE(extractDicom(dir, "voxel", first).mesh.positions == reference().mesh.positions);
  }
}

TEST(Dicom, ColourImagesNeedAChannel) {
  SeriesSpec rgb;
  rgb.samplesPerPixel = 3;
  rgb.slices = 30;
  const std::string dir = testing::tempDir();
  writeSeries(dir, rgb);
  try {
    extractDicom(dir, "voxel");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              dir + "/s000.dcm: colour images (RGB, 3 samples per pixel); choose a channel with `channel` 0..2");
  }
  DicomOptions green;
  green.channel = 1;
  const testing::Extraction x = extractDicom(dir, "voxel", green);
  EXPECT_TRUE(x.mesh.positions == reference().mesh.positions);
}

TEST(Dicom, TiltedObliqueAndUnevenSeriesArePlacedExactly) {
  SeriesSpec tilted;  // gantry tilt: the origins shear along the column direction
  const double tilt = 18.5 * std::numbers::pi / 180;
  tilted.orientation = {1, 0, 0, 0, std::cos(tilt), -std::sin(tilt)};
  tilted.position = [tilt](int k) { return Vec3{-12, -20 + 2.0 * k * std::tan(tilt), 5 + 2.0 * k}; };
  SeriesSpec oblique;
  const double a = 0.4;
  oblique.orientation = {std::cos(a), std::sin(a), 0, 0, 0, -1};  // near-sagittal, rotated
  // Slices advance along the normal, row x column = (-sin a, cos a, 0).
  oblique.position = [a](int k) { return Vec3{-1.2 * k * std::sin(a), 1.2 * k * std::cos(a) + 7, 40}; };
  SeriesSpec uneven;
  uneven.position = [](int k) { return Vec3{3, 4, k < 10 ? 2.0 * k : 20 + 3.5 * (k - 10)}; };
  for (const SeriesSpec* spec : {&tilted, &oblique, &uneven}) {
    const std::string dir = testing::tempDir();
    writeSeries(dir, *spec);
    checkSeries(*spec, dir);
  }
}

TEST(Dicom, PixelEncodingsAndRescaleGiveTheSameMesh) {
  SeriesSpec mono1;
  mono1.mono1 = true;
  SeriesSpec unsigned12;  // like Philips CT: 12 bits stored, unsigned, intercept
  unsigned12.signedPixels = false;
  unsigned12.bitsStored = 12;
  unsigned12.intercept = -1200;
  SeriesSpec slope;
  slope.slope = 0.5;
  slope.intercept = -1024;
  SeriesSpec multi;
  multi.multiFrame = true;
  for (const SeriesSpec* spec : {&mono1, &unsigned12, &slope, &multi}) {
    const std::string dir = testing::tempDir();
    writeSeries(dir, *spec);
    checkSeries(*spec, dir);
  }
}

TEST(Dicom, CompressedCopiesGiveExactlyTheSameMesh) {
  for (Codec codec : {Codec::kImplicit, Codec::kBigEndian, Codec::kDeflated, Codec::kRle, Codec::kJpegLossless,
                      Codec::kJpegLs, Codec::kJpeg2000}) {
    for (bool isSigned : {true, false}) {
      SeriesSpec spec;
      spec.codec = codec;
      spec.signedPixels = isSigned;
      if (!isSigned) spec.intercept = -1200;
      const std::string dir = testing::tempDir();
      writeSeries(dir, spec);
      const testing::Extraction voxel = extractDicom(dir, "voxel");
      EXPECT_TRUE(voxel.mesh.positions == reference().mesh.positions)
          << static_cast<int>(codec) << " signed " << isSigned;
      EXPECT_TRUE(voxel.mesh.triangles == reference().mesh.triangles) << static_cast<int>(codec);
    }
  }
}

std::string openError(const std::string& dir, const DicomOptions& options = {}) {
  try {
    extractDicom(dir, "physical", options);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Dicom, BadInputsNameTheFileAndTheProblem) {
  SeriesSpec spec;
  spec.slices = 4;
  {
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    fs::resize_file(dir + "/s002.dcm", fs::file_size(dir + "/s002.dcm") / 2);
    EXPECT_NE(openError(dir).find(dir + "/s002.dcm: "), std::string::npos) << openError(dir);
  }
  {
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    std::ofstream f(dir + "/s001.dcm", std::ios::binary | std::ios::trunc);
    f << std::string(128, '\0') << "DICM" << std::string(300, 'x');
    f.close();
    EXPECT_EQ(openError(dir).rfind(dir + "/s001.dcm: not a readable DICOM file: ", 0), 0u) << openError(dir);
    DicomOptions skip;
    skip.skipBad = true;
    EXPECT_EQ(scanDicom({dir}, skip).series.front().slices.size(), 3u);
  }
  {
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    DcmFileFormat ff;
    ASSERT_TRUE(ff.loadFile((dir + "/s003.dcm").c_str()).good());
    ff.getDataset()->putAndInsertUint16(DCM_Rows, 20);
    ff.getDataset()->putAndInsertUint16(DCM_Columns, 20);
    std::vector<Uint16> pixels(400, 0);  // as many as 20x20 needs (issue 33: the length is checked first)
    ff.getDataset()->putAndInsertUint16Array(DCM_PixelData, pixels.data(), 400);
    ASSERT_TRUE(ff.saveFile((dir + "/s003.dcm").c_str(), EXS_LittleEndianExplicit).good());
    EXPECT_EQ(
        openError(dir),
        fmt::format("series {}: {}/s003.dcm has 20x20 pixels but {}/s000.dcm has 40x36 (mixed sizes in one series)",
                    spec.uid, dir, dir));
  }
  {
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    DcmFileFormat ff;
    ASSERT_TRUE(ff.loadFile((dir + "/s001.dcm").c_str()).good());
    std::vector<Uint16> few(100, 0);
    ff.getDataset()->putAndInsertUint16Array(DCM_PixelData, few.data(), 100);
    ASSERT_TRUE(ff.saveFile((dir + "/s001.dcm").c_str(), EXS_LittleEndianExplicit).good());
    EXPECT_EQ(openError(dir),
              dir +
                  "/s001.dcm: the pixel data holds 200 bytes, but Rows 36, Columns 40, SamplesPerPixel 1 "
                  "and BitsAllocated 16 need 2880; the length and those tags disagree");
  }
  {
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    DcmFileFormat ff;
    ASSERT_TRUE(ff.loadFile((dir + "/s000.dcm").c_str()).good());
    auto* sequence = new DcmPixelSequence(DCM_PixelSequenceTag);
    sequence->insert(new DcmPixelItem(DCM_PixelItemTag));
    auto* fragment = new DcmPixelItem(DCM_PixelItemTag);
    const Uint8 bytes[4] = {0, 0, 1, 0xb3};
    fragment->putUint8Array(bytes, 4);
    sequence->insert(fragment);
    auto* pixels = new DcmPixelData(DCM_PixelData);
    pixels->putOriginalRepresentation(EXS_MPEG2MainProfileAtMainLevel, nullptr, sequence);
    ff.getDataset()->insert(pixels, true);
    ASSERT_TRUE(ff.saveFile((dir + "/s000.dcm").c_str(), EXS_MPEG2MainProfileAtMainLevel).good());
    EXPECT_EQ(
        openError(dir),
        dir + "/s000.dcm: unsupported transfer syntax 'MPEG2 Main Profile @ Main Level' (1.2.840.10008.1.2.4.100)");
  }
  {
    const std::string dir = testing::tempDir();
    SeriesSpec gap = spec;
    gap.slices = 6;
    gap.position = [](int k) { return Vec3{0, 0, k < 3 ? 2.0 * k : 2.0 * k + 4}; };
    writeSeries(dir, gap);
    const DicomScan scan = scanDicom({dir}, {});
    ASSERT_EQ(scan.series.front().warnings.size(), 1u);
    EXPECT_EQ(
        scan.series.front().warnings.front(),
        fmt::format("gap of 6 mm between {0}/s002.dcm and {0}/s003.dcm (median spacing 2 mm): a slice may be missing",
                    dir));
    DicomOptions strict;
    strict.strict = true;
    EXPECT_EQ(openError(dir, strict),
              fmt::format("series {}: {} (`strict`)", gap.uid, scan.series.front().warnings.front()));
  }
}

TEST(Dicom, GapsTheSliceThicknessCoversAreNotesAndOthersWarnings) {
  DicomOptions strict;
  strict.strict = true;
  {
    // Like the GE series: thin slices, then thick ones spaced by their thickness.
    SeriesSpec spec;
    spec.position = [](int k) { return Vec3{3, 4, k < 20 ? 2.0 * k : 39 + 5.0 * (k - 20)}; };
    spec.thickness = [](int k) { return k < 20 ? 2.0 : 5.0; };
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    const DicomScan scan = scanDicom({dir}, strict);  // notes never fail --strict
    const DicomSeries& s = scan.series.front();
    EXPECT_TRUE(s.warnings.empty());
    ASSERT_EQ(s.notes.size(), 1u);
    EXPECT_EQ(s.notes.front(), fmt::format("uneven slice spacing: 9 gaps of 5 mm from {0}/s020.dcm to {0}/s029.dcm "
                                           "(median spacing 2 mm) equal the slice thickness (5 mm): no slice is "
                                           "missing",
                                           dir));
    ASSERT_EQ(s.slices.size(), 30u);
    EXPECT_EQ(s.slices[19].thickness, 2.0);
    EXPECT_EQ(s.slices[20].thickness, 5.0);
    std::vector<std::string> notes;
    openSource(dir, {}, &notes);
    EXPECT_EQ(notes, s.notes);  // not "warning: "
    checkSeries(spec, dir);
  }
  auto scanOf = [](const SeriesSpec& spec) {
    const std::string dir = testing::tempDir();
    writeSeries(dir, spec);
    return std::pair(dir, scanDicom({dir}, {}).series.front());
  };
  SeriesSpec spec;
  spec.slices = 8;
  {
    // Overlapping slices: one gap wider than 1.5 times the median but within the thickness.
    SeriesSpec overlap = spec;
    overlap.position = [](int k) { return Vec3{0, 0, k <= 4 ? 2.0 * k : 2.0 * k + 1.5}; };
    overlap.thickness = [](int) { return 4.0; };
    const auto [dir, s] = scanOf(overlap);
    EXPECT_TRUE(s.warnings.empty());
    ASSERT_EQ(s.notes.size(), 1u);
    EXPECT_EQ(s.notes.front(), fmt::format("uneven slice spacing: a gap of 3.5 mm between {0}/s004.dcm and "
                                           "{0}/s005.dcm (median spacing 2 mm) is within the slice thickness (4 mm): "
                                           "no slice is missing",
                                           dir));
  }
  {
    // A gap wider than both 1.5 times the median and the thickness: a slice may be missing.
    SeriesSpec missing = spec;
    missing.position = [](int k) { return Vec3{0, 0, k < 3 ? 2.0 * k : 2.0 * k + 4}; };
    missing.thickness = [](int) { return 2.0; };
    const auto [dir, s] = scanOf(missing);
    EXPECT_TRUE(s.notes.empty());
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_EQ(s.warnings.front(), fmt::format("gap of 6 mm between {0}/s002.dcm and {0}/s003.dcm (median spacing 2 "
                                              "mm, slice thickness 2 mm): a slice may be missing",
                                              dir));
    EXPECT_EQ(openError(dir, strict), fmt::format("series {}: {} (`strict`)", missing.uid, s.warnings.front()));
  }
  {
    // Two wide gaps in a row, between slices of different thickness.
    SeriesSpec missing = spec;
    missing.slices = 10;
    missing.position = [](int k) { return Vec3{0, 0, k < 3 ? 2.0 * k : k == 3 ? 10.0 : k == 4 ? 18.0 : 2.0 * k + 10}; };
    missing.thickness = [](int k) { return k < 4 ? 2.0 : 2.5; };
    const auto [dir, s] = scanOf(missing);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_EQ(s.warnings.front(), fmt::format("2 gaps of 6 to 8 mm from {0}/s002.dcm to {0}/s004.dcm (median spacing "
                                              "2 mm, slice thickness 2 to 2.5 mm): slices may be missing",
                                              dir));
  }
}

TEST(Dicom, GantryTiltAndPatientExtentFromTheHeadersAndTheGeometry) {
  const double degrees = 18.5;
  const double tilt = degrees * std::numbers::pi / 180;
  SeriesSpec tilted;
  tilted.orientation = {1, 0, 0, 0, std::cos(tilt), -std::sin(tilt)};
  // The gantry tilts the image planes; the table still moves along z.
  tilted.position = [](int k) { return Vec3{-12, -20, 5 + 2.0 * k}; };
  tilted.gantryTilt = degrees;
  const std::string dir = testing::tempDir();
  writeSeries(dir, tilted);
  const DicomSeries s = scanDicom({dir}, {}).series.front();
  EXPECT_EQ(s.gantryTilt, degrees);
  ASSERT_TRUE(geometricTilt(s).has_value());
  EXPECT_NEAR(*geometricTilt(s), degrees, 1e-6);
  // Corner pixel centres: 39 columns of 0.6 mm along the row, 35 rows of 0.7 mm down the column.
  const auto box = patientExtent(s);
  ASSERT_TRUE(box.has_value());
  const double down = 35 * 0.7;
  const std::array<double, 6> want{-12,   -20, 5 - down * std::sin(tilt), -12 + 39 * 0.6, -20 + down * std::cos(tilt),
                                   5 + 58};
  for (std::size_t c = 0; c < 6; ++c) EXPECT_NEAR((*box)[c], want[c], 1e-6) << c;
  checkSeries(tilted, dir);  // the sheared lattice is placed exactly

  SeriesSpec plain;
  plain.slices = 4;
  const std::string flat = testing::tempDir();
  writeSeries(flat, plain);
  const DicomSeries p = scanDicom({flat}, {}).series.front();
  EXPECT_FALSE(p.gantryTilt.has_value());
  EXPECT_NEAR(geometricTilt(p).value(), 0.0, 1e-6);
  DicomSeries one = p;
  one.slices.resize(1);
  EXPECT_FALSE(geometricTilt(one).has_value());
  EXPECT_EQ(patientExtent(one), (std::array<double, 6>{-10, 20, 30, -10 + 39 * 0.6, 20 + 35 * 0.7, 30}));
  one.slices.front().position.reset();
  EXPECT_FALSE(patientExtent(one).has_value());
}

TEST(DicomRealData, PhilipsHeadSkipsDirfileAndSpansItsSlices) {
  const std::string dir = testing::sharedData("ct-philips-head");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/ct-philips-head is absent";
  const DicomScan scan = scanDicom({dir}, {});
  ASSERT_EQ(scan.series.size(), 1u);
  EXPECT_EQ(scan.series.front().slices.size(), 140u);
  EXPECT_GE(scan.skipped, 1);  // DIRFILE (and the licence text)
  // The z range of the slices, read from the files' ImagePositionPatient with DCMTK itself (the
  // series is axial, so z is the third component).
  double zMin = std::numeric_limits<double>::infinity();
  double zMax = -zMin;
  int images = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    DcmFileFormat ff;
    if (ff.loadFile(entry.path().c_str()).bad()) continue;
    Float64 z = 0;
    if (ff.getDataset()->findAndGetFloat64(DCM_ImagePositionPatient, z, 2).bad()) continue;
    zMin = std::min(zMin, z);
    zMax = std::max(zMax, z);
    ++images;
  }
  ASSERT_EQ(images, 140);
  for (double iso : {-400.0, 350.0}) {
    auto source = openSource(dir, {});
    const LatticeFrame frame = LatticeFrame::physical(source->info());
    const auto box = frame.bounds(source->info().dims);
    const testing::Extraction x = testing::extract(*source, Method::kMarchingCubes, iso);
    EXPECT_GT(x.stats.triangles, 500000u);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(x.stats.bounds[static_cast<std::size_t>(a)], box[static_cast<std::size_t>(a)] - 1e-3);
      EXPECT_LE(x.stats.bounds[static_cast<std::size_t>(a + 3)], box[static_cast<std::size_t>(a + 3)] + 1e-3);
    }
    // The head fills the first and last slices, so the mesh reaches within a slice of both.
    EXPECT_NEAR(x.stats.bounds[2], zMin, 1.0);
    EXPECT_NEAR(x.stats.bounds[5], zMax, 1.0);
    EXPECT_EQ(x.stats.interiorBoundaryEdges, 0u);
    EXPECT_EQ(x.stats.nonManifoldEdges, 0u);
  }
}

TEST(DicomRealData, GeTiltIsSortedWarnsOfGapsAndShearsItsSlices) {
  const std::string dir = testing::sharedData("ct-ge-tilt");
  if (dir.empty()) GTEST_SKIP() << "../shared/data/ct-ge-tilt is absent";
  const DicomScan scan = scanDicom({dir}, {});
  ASSERT_EQ(scan.series.size(), 1u);
  const DicomSeries& s = scan.series.front();
  ASSERT_EQ(s.slices.size(), 28u);
  for (double g : s.gaps) EXPECT_GT(g, 0.5);  // strictly increasing along the normal
  // 4 mm slices, then 7 mm ones 7 mm apart: their thickness covers the wider gaps.
  EXPECT_TRUE(s.warnings.empty());
  ASSERT_EQ(s.notes.size(), 1u);
  EXPECT_EQ(s.notes.front(), fmt::format("uneven slice spacing: 13 gaps of 7 mm from {0}/15.dcm to {0}/28.dcm (median "
                                         "spacing 4 mm) equal the slice thickness (7 mm): no slice is missing",
                                         dir));
  EXPECT_EQ(s.slices.front().thickness, 4.0);
  EXPECT_EQ(s.slices.back().thickness, 7.0);
  EXPECT_EQ(s.gantryTilt, 18.5);
  EXPECT_NEAR(geometricTilt(s).value(), 18.5, 0.01);
  // A vertex on an in-slice edge of slice k lies in slice k's plane.
  const testing::Extraction voxel = extractDicom(dir, "voxel");
  const testing::Extraction lps = extractDicom(dir, "physical");
  ASSERT_EQ(voxel.mesh.positions.size(), lps.mesh.positions.size());
  const auto& o = s.orientation;
  const Vec3 normal{o[1] * o[5] - o[2] * o[4], o[2] * o[3] - o[0] * o[5], o[0] * o[4] - o[1] * o[3]};
  int checked = 0;
  for (std::size_t v = 0; v < voxel.mesh.positions.size(); ++v) {
    const float k = voxel.mesh.positions[v].z;
    if (k != std::floor(k)) continue;
    const Vec3& origin = *s.slices[static_cast<std::size_t>(k)].position;
    const Vec3f& p = lps.mesh.positions[v];
    const double off = (p.x - origin[0]) * normal[0] + (p.y - origin[1]) * normal[1] + (p.z - origin[2]) * normal[2];
    EXPECT_LT(std::abs(off), 1e-3);
    ++checked;
  }
  EXPECT_GT(checked, 10000);
}

}  // namespace
}  // namespace isoslab
