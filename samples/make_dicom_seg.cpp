// Writes an isoslab input that holds integer labels (a label phantom, a NIfTI atlas, a .seg.nrrd) as
// one DICOM Segmentation object with DCMTK's dcmseg: a segment per nonzero label value, in increasing
// order, named and coloured from the input's labels where it has them; a frame per (segment, slice)
// where the slice holds the segment. Test data for the DICOM SEG reader.
//
//   make_dicom_seg [--fractional MAX] [--overlap] [--rotate DEG] [--tilt DEG] [--labelmap]
//                  [--transfer explicit|implicit|deflated] INPUT OUT.dcm
//
// --fractional MAX (1..255): FRACTIONAL/PROBABILITY; a segment's voxels get MAX, ceil(MAX/2) (50%,
// inside) on odd slices; voxels beside it in the slice get floor((MAX-1)/2) (below 50%, outside).
// --overlap: a last segment "union" of every nonzero voxel (given twice, a second, "union 2"). --rotate, --tilt: turn
// the geometry about the patient z axis, then the x axis. --labelmap: Label Map Segmentation Storage (below). Binary
// Pixel Data is packed here, frames following one another bit by bit, LSB first: DCMTK 3.6.7 corrupts frames whose
// rows*cols is not a multiple of 8 (DCMTK bug #1132).
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcistrmf.h>
#include <dcmtk/dcmdata/dcsequen.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmfg/fgfracon.h>
#include <dcmtk/dcmfg/fgpixmsr.h>
#include <dcmtk/dcmfg/fgplanor.h>
#include <dcmtk/dcmfg/fgplanpo.h>
#include <dcmtk/dcmiod/cielabutil.h>
#include <dcmtk/dcmseg/segdoc.h>
#include <dcmtk/dcmseg/segment.h>
#include <dcmtk/oflog/oflog.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/error.h"
#include "io/label_table.h"
#include "io/open_source.h"

namespace {

using isoslab::Error;
using Vec3 = std::array<double, 3>;

void check(const OFCondition& condition, const std::string& what) {
  if (condition.bad()) throw Error(fmt::format("{}: {}", what, condition.text()));
}

// A Decimal String holds at most 16 characters.
std::string ds(double v) {
  if (std::abs(v) < 1e-12) v = 0;
  for (int digits = 15;; --digits) {
    std::string s = fmt::format("{:.{}g}", v, digits);
    if (s.size() <= 16) return s;
  }
}

// An LO value: at most 64 characters, no backslash.
std::string lo(std::string s) {
  std::replace(s.begin(), s.end(), '\\', '/');
  return s.substr(0, 64);
}

// A voxel's label: a whole number from 0.
std::int64_t labelOf(float v, std::int64_t k, const std::string& input) {
  if (!(v >= 0 && v < 2147483648.0f) || v != std::floor(v))
    throw Error(fmt::format("{}: voxel value {} in slice {} is not a label (a whole number from 0)", input, v, k));
  return static_cast<std::int64_t>(v);
}

// Pixel Data written to a file beside the output, which DCMTK copies from when it saves: it is
// never held whole in memory. Binary frames go in bit by bit.
class PixelFile {
 public:
  explicit PixelFile(std::string path) : path_(std::move(path)), file_(std::fopen(path_.c_str(), "wb")) {
    if (file_ == nullptr) fail();
  }
  ~PixelFile() {
    if (file_ != nullptr) std::fclose(file_);
    std::remove(path_.c_str());
  }
  PixelFile(const PixelFile&) = delete;
  PixelFile& operator=(const PixelFile&) = delete;

  void bits(const std::vector<Uint8>& frame) {
    for (const Uint8 v : frame) {
      if (v != 0) byte_ = static_cast<Uint8>(byte_ | (1u << bit_));
      if (++bit_ == 8) flush();
    }
  }
  void bytes(const std::vector<Uint8>& data) {
    if (std::fwrite(data.data(), 1, data.size(), file_) != data.size()) fail();
    size_ += data.size();
  }
  // Completes the last byte, pads to an even length and hands the file to `element`.
  void finish(DcmElement& element) {
    if (bit_ != 0) flush();
    if (size_ % 2 != 0) flush();
    if (std::fclose(std::exchange(file_, nullptr)) != 0) fail();
    if (size_ > 0xFFFFFFFEu) throw Error(fmt::format("Pixel Data of {} bytes is beyond DICOM's 4 GiB", size_));
    check(element.createValueFromTempFile(new DcmInputFileStreamFactory(path_.c_str(), 0), static_cast<Uint32>(size_),
                                          EBO_LittleEndian),
          "Pixel Data");
  }

 private:
  void flush() {
    if (std::fputc(byte_, file_) == EOF) fail();
    ++size_;
    byte_ = 0;
    bit_ = 0;
  }
  [[noreturn]] void fail() const { throw Error(fmt::format("{}: cannot write", path_)); }
  std::string path_;
  std::FILE* file_;
  std::uint64_t size_ = 0;
  Uint8 byte_ = 0;
  unsigned bit_ = 0;
};

struct Options {
  int fractional = 0;  // MaximumFractionalValue, 0 for binary
  int overlap = 0;     // "union" segments added
  bool labelmap = false;
  double rotate = 0, tilt = 0;
  E_TransferSyntax transfer = EXS_LittleEndianExplicit;
  std::string input, output;
};

// Returns false on a usage error.
bool parse(int argc, char** argv, Options& o) {
  static const std::map<std::string, E_TransferSyntax> transfers{{"explicit", EXS_LittleEndianExplicit},
                                                                 {"implicit", EXS_LittleEndianImplicit},
                                                                 {"deflated", EXS_DeflatedLittleEndianExplicit}};
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--overlap") {
      ++o.overlap;
    } else if (a == "--labelmap") {
      o.labelmap = true;
    } else if (a.rfind("--", 0) != 0) {
      positional.push_back(a);
    } else if (++i < argc) {
      const std::string v = argv[i];
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      const bool number = !v.empty() && *end == '\0';
      if (a == "--fractional" && number && x >= 1 && x <= 255 && x == std::floor(x)) {
        o.fractional = static_cast<int>(x);
      } else if ((a == "--rotate" || a == "--tilt") && number && std::abs(x) <= 360) {
        (a == "--rotate" ? o.rotate : o.tilt) = x;
      } else if (a == "--transfer" && transfers.count(v) != 0) {
        o.transfer = transfers.at(v);
      } else {
        return false;
      }
    } else {
      return false;
    }
  }
  if (positional.size() != 2 || (o.labelmap && (o.fractional > 0 || o.overlap > 0))) return false;
  o.input = positional[0];
  o.output = positional[1];
  return true;
}

void run(const Options& o) {
  // Pass 1: the label values.
  std::set<std::int64_t> values;
  {
    auto source = isoslab::openSource(o.input, {});
    std::vector<float> slice(static_cast<std::size_t>(source->info().sliceVoxels()));
    float last = 0;
    for (std::int64_t k = 0; source->readSlice(slice); ++k) {
      for (const float v : slice) {
        if (v != last && v != 0) values.insert(labelOf(v, k, o.input));
        last = v;
      }
    }
  }
  const std::vector<std::int64_t> labels(values.begin(), values.end());
  const std::size_t segments = labels.size() + static_cast<std::size_t>(o.overlap);
  if (labels.empty()) throw Error(fmt::format("{}: no voxel holds a nonzero label", o.input));
  if (segments > 65535) throw Error(fmt::format("{}: {} segments; DICOM allows 65535", o.input, segments));

  auto source = isoslab::openSource(o.input, {});
  const isoslab::VolumeInfo& info = source->info();
  if (info.dims[0] > 65535 || info.dims[1] > 65535)
    throw Error(fmt::format("{}: slices beyond 65535 x 65535", o.input));
  const auto cols = static_cast<Uint16>(info.dims[0]), rows = static_cast<Uint16>(info.dims[1]);
  IODGeneralEquipmentModule::EquipmentInfo equipment("isoslab", "make_dicom_seg", "1", "0.1");
  ContentIdentificationMacro content("1", "LABELS", lo(o.input), "isoslab");
  DcmSegmentation* created = nullptr;
  check(o.fractional > 0
            ? DcmSegmentation::createFractionalSegmentation(created, rows, cols, DcmSegTypes::SFT_PROBABILITY,
                                                            static_cast<Uint16>(o.fractional), equipment, content)
            : DcmSegmentation::createBinarySegmentation(created, rows, cols, equipment, content),
        "creating the segmentation");
  std::unique_ptr<DcmSegmentation> seg(created);
  char uid[100];
  check(seg->getPatient().setPatientName("Isoslab^Phantom"), "PatientName");
  check(seg->getPatient().setPatientID("ISOSLAB"), "PatientID");
  check(seg->getFrameOfReference().setFrameOfReferenceUID(dcmGenerateUniqueIdentifier(uid, SITE_INSTANCE_UID_ROOT)),
        "FrameOfReferenceUID");
  check(seg->getSegmentationSeriesModule().setSeriesNumber("1"), "SeriesNumber");
  check(seg->getSeries().setSeriesDescription(lo(o.input)), "SeriesDescription");

  // Segments, numbered 1, 2, ... in label order.
  for (std::size_t s = 0; s < segments; ++s) {
    const bool isUnion = s >= labels.size();
    const auto value = static_cast<std::int32_t>(isUnion ? 0 : labels[s]);
    std::string name = !isUnion             ? fmt::format("label {}", value)
                       : s == labels.size() ? std::string("union")
                                            : fmt::format("union {}", s - labels.size() + 1);
    std::array<std::uint8_t, 3> rgb =
        isUnion ? std::array<std::uint8_t, 3>{200, 200, 200} : isoslab::defaultLabelColor(value);
    for (const auto& label : info.labels) {
      if (isUnion || label.value != value) continue;
      if (!label.name.empty()) name = label.name;
      if (label.color) rgb = *label.color;
    }
    DcmSegment* segment = nullptr;
    const CodeSequenceMacro tissue("85756007", "SCT", "Tissue");
    check(DcmSegment::create(segment, lo(name), tissue, tissue, DcmSegTypes::SAT_MANUAL), "segment " + name);
    std::unique_ptr<DcmSegment> owned(segment);
    std::array<double, 3> lab{};
    IODCIELabUtil::rgb2DicomLab(lab[0], lab[1], lab[2], rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0);
    auto scaled = [](double x) { return static_cast<Uint16>(std::lround(std::clamp(x, 0.0, 65535.0))); };
    check(segment->setRecommendedDisplayCIELabValue(scaled(lab[0]), scaled(lab[1]), scaled(lab[2])), "CIELab");
    Uint16 assigned = 0;
    check(seg->addSegment(owned.release(), assigned), "segment " + name);
    if (assigned != s + 1) throw Error(fmt::format("segment {} was numbered {}", name, assigned));
  }

  // Geometry, turned by --rotate about z, then by --tilt about x.
  const double rz = o.rotate * std::numbers::pi / 180, rx = o.tilt * std::numbers::pi / 180;
  auto turn = [&](const Vec3& p) {
    const double x = std::cos(rz) * p[0] - std::sin(rz) * p[1], y = std::sin(rz) * p[0] + std::cos(rz) * p[1];
    return Vec3{x, std::cos(rx) * y - std::sin(rx) * p[2], std::sin(rx) * y + std::cos(rx) * p[2]};
  };
  const auto& d = info.direction;
  const Vec3 row = turn({d[0], d[3], d[6]}), column = turn({d[1], d[4], d[7]});
  auto position = [&](std::int64_t k) {
    if (!info.sliceOrigins.empty()) return turn(info.sliceOrigins[static_cast<std::size_t>(k)]);
    const double step = static_cast<double>(k) * info.spacing[2];
    return turn({info.origin[0] + step * d[2], info.origin[1] + step * d[5], info.origin[2] + step * d[8]});
  };
  FGPixelMeasures measures;
  check(measures.setPixelSpacing((ds(info.spacing[1]) + "\\" + ds(info.spacing[0])).c_str()), "PixelSpacing");
  check(measures.setSliceThickness(ds(info.spacing[2]).c_str()), "SliceThickness");
  check(measures.setSpacingBetweenSlices(ds(info.spacing[2]).c_str()), "SpacingBetweenSlices");
  check(seg->addForAllFrames(measures), "PixelMeasures");
  FGPlaneOrientationPatient orientation;
  check(orientation.setImageOrientationPatient(ds(row[0]).c_str(), ds(row[1]).c_str(), ds(row[2]).c_str(),
                                               ds(column[0]).c_str(), ds(column[1]).c_str(), ds(column[2]).c_str()),
        "ImageOrientationPatient");
  check(seg->addForAllFrames(orientation), "PlaneOrientation");
  dcmGenerateUniqueIdentifier(uid, SITE_INSTANCE_UID_ROOT);  // the dimension organization
  auto dimension = [&](const DcmTagKey& tag, const DcmTagKey& group, const char* name) {
    check(seg->getDimensions().addDimensionIndex(tag, uid, group, name), name);
  };
  if (!o.labelmap) dimension(DCM_ReferencedSegmentNumber, DCM_SegmentIdentificationSequence, "ReferencedSegmentNumber");
  dimension(DCM_ImagePositionPatient, DCM_PlanePositionSequence, "ImagePositionPatient");

  // Pass 2: frames, slice by slice (so slice-major, not segment-major); in a slice, its segments in order.
  std::optional<PixelFile> pixels;  // binary and label map Pixel Data; dcmseg writes fractional frames right
  if (o.fractional == 0) pixels.emplace(o.output + ".pixels.tmp");
  const bool wide = segments > 255;
  const auto n = static_cast<std::size_t>(info.sliceVoxels());
  std::vector<float> slice(n);
  std::vector<Uint16> number(n);  // segment number of each voxel, 0 for background
  std::vector<Uint8> frame(n);
  std::int64_t slices = 0;
  for (std::int64_t k = 0; source->readSlice(slice); ++k, ++slices) {
    std::vector<bool> present(segments + 1, false);
    float last = 0;
    Uint16 lastNumber = 0;
    for (std::size_t p = 0; p < n; ++p) {
      if (slice[p] != last) {
        last = slice[p];
        const auto it = std::lower_bound(labels.begin(), labels.end(), labelOf(last, k, o.input));
        lastNumber = last == 0 ? 0 : static_cast<Uint16>(it - labels.begin() + 1);
      }
      number[p] = lastNumber;
      present[lastNumber] = true;
    }
    const bool any = std::any_of(number.begin(), number.end(), [](Uint16 v) { return v != 0; });
    for (std::size_t u = labels.size() + 1; u <= segments; ++u) present[u] = any;
    const Vec3 at = position(k);
    FGPlanePosPatient plane;
    check(plane.setImagePositionPatient(ds(at[0]).c_str(), ds(at[1]).c_str(), ds(at[2]).c_str()), "position");
    FGFrameContent frameContent;
    const OFVector<FGBase*> groups{&plane, &frameContent};
    if (o.labelmap) {  // a zero frame for the per-frame groups; the labels go to the file
      check(frameContent.setDimensionIndexValues(static_cast<Uint32>(k + 1), 0), "frame content");
      check(seg->addFrame(frame.data(), 1, groups), fmt::format("slice {}", k));
      std::vector<Uint8> bytes;  // little endian
      for (const Uint16 v : number) {
        bytes.push_back(static_cast<Uint8>(v & 0xFF));
        if (wide) bytes.push_back(static_cast<Uint8>(v >> 8));
      }
      pixels->bytes(bytes);
      continue;
    }
    const auto full = static_cast<Uint8>(o.fractional), half = static_cast<Uint8>((o.fractional + 1) / 2),
               below = static_cast<Uint8>(o.fractional > 0 ? (o.fractional - 1) / 2 : 0);
    for (std::size_t s = 1; s <= segments; ++s) {
      if (!present[s]) continue;
      const bool isUnion = s > labels.size();
      auto inside = [&](std::size_t p) { return isUnion ? number[p] != 0 : number[p] == s; };
      auto beside = [&](std::size_t p) {  // in the slice
        const std::size_t i = p % cols, j = p / cols;
        return (i > 0 && inside(p - 1)) || (i + 1 < cols && inside(p + 1)) || (j > 0 && inside(p - cols)) ||
               (j + 1 < rows && inside(p + cols));
      };
      for (std::size_t p = 0; p < n; ++p)
        frame[p] =
            inside(p) ? (o.fractional == 0 ? 1 : (k % 2 == 1 ? half : full)) : (below > 0 && beside(p) ? below : 0);
      check(frameContent.setDimensionIndexValues(static_cast<Uint32>(s), 0), "frame content");
      check(frameContent.setDimensionIndexValues(static_cast<Uint32>(k + 1), 1), "frame content");
      check(seg->addFrame(frame.data(), static_cast<Uint16>(s), groups), fmt::format("slice {} segment {}", k, s));
      if (pixels) pixels->bits(frame);
    }
  }
  // dcmseg refuses more segments than frames: a label map gets zero frames to match, dropped below.
  for (std::int64_t extra = slices; o.labelmap && extra < static_cast<std::int64_t>(segments); ++extra) {
    FGFrameContent frameContent;
    check(frameContent.setDimensionIndexValues(static_cast<Uint32>(extra + 1), 0), "frame content");
    const OFVector<FGBase*> groups{&frameContent};
    check(seg->addFrame(frame.data(), 1, groups), "padding frame");
  }

  DcmFileFormat file;
  DcmDataset& data = *file.getDataset();
  check(seg->writeDataset(data), o.output);
  check(data.putAndInsertString(DCM_SegmentsOverlap, o.overlap > 0 ? "YES" : "NO"), "SegmentsOverlap");
  DcmElement* pixelData = nullptr;
  check(data.findAndGetElement(DCM_PixelData, pixelData), "Pixel Data");
  if (o.labelmap) {
    // Label Map Segmentation (Supplement 243, PS3.3 2024+; also how highdicom writes it): the same
    // IOD under its own SOP Class, Segmentation Type LABELMAP, 8 or 16 bits unsigned, MONOCHROME2
    // (no palette here), one frame per slice whose pixels are segment numbers; background is the
    // Pixel Padding Value, 0 here. Per-frame groups carry no Segment Identification, and the
    // dimensions do not include the segment number.
    const char* labelMapStorage = "1.2.840.10008.5.1.4.1.1.66.7";
    check(file.getMetaInfo()->putAndInsertString(DCM_MediaStorageSOPClassUID, labelMapStorage), "meta header");
    for (const auto& [tag, value] : {std::pair<DcmTagKey, std::string>{DCM_SOPClassUID, labelMapStorage},
                                     {DCM_SegmentationType, "LABELMAP"},
                                     {DCM_PhotometricInterpretation, "MONOCHROME2"},
                                     {DCM_NumberOfFrames, std::to_string(slices)}})
      check(data.putAndInsertString(tag, value.c_str()), "label map");
    const Uint16 bits = wide ? 16 : 8;
    for (const auto& [tag, value] : {std::pair<DcmTagKey, Uint16>{DCM_BitsAllocated, bits},
                                     {DCM_BitsStored, bits},
                                     {DCM_HighBit, static_cast<Uint16>(bits - 1)},
                                     {DCM_PixelPaddingValue, 0}})
      check(data.putAndInsertUint16(tag, value), "label map");
    DcmSequenceOfItems* perFrame = nullptr;
    check(data.findAndGetSequence(DCM_PerFrameFunctionalGroupsSequence, perFrame), "per-frame groups");
    while (perFrame->card() > static_cast<unsigned long>(slices)) delete perFrame->remove(perFrame->card() - 1);
    for (unsigned long f = 0; f < perFrame->card(); ++f)
      perFrame->getItem(f)->findAndDeleteElement(DCM_SegmentIdentificationSequence);
    check(pixelData->setVR(wide ? EVR_OW : EVR_OB), "Pixel Data");
  }
  if (pixels) pixels->finish(*pixelData);
  check(file.saveFile(o.output.c_str(), o.transfer), o.output);
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  if (!parse(argc, argv, options)) {
    std::fprintf(stderr,
                 "usage: make_dicom_seg [--fractional MAX] [--overlap] [--rotate DEG] [--tilt DEG] [--labelmap]\n"
                 "                      [--transfer explicit|implicit|deflated] INPUT OUT.dcm\n"
                 "(--labelmap goes with neither --fractional nor --overlap)\n");
    return 2;
  }
  OFLog::configure(OFLogger::OFF_LOG_LEVEL);  // failures are reported below, one line each
  try {
    run(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_dicom_seg: %s\n", e.what());
    return 1;
  }
  return 0;
}
