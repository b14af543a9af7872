#include "io/dicom_seg.h"

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfcache.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcxfer.h>
#include <dcmtk/dcmiod/cielabutil.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/limits.h"
#include "core/vec3.h"
#include "io/dicom_common.h"
#include "io/dicom_series.h"

namespace isoslab {
namespace {

using namespace dicom;

constexpr const char* kSegmentationStorage = "1.2.840.10008.5.1.4.1.1.66.4";
constexpr const char* kLabelMapStorage = "1.2.840.10008.5.1.4.1.1.66.7";

enum class SegKind { kBinary, kFractional, kLabelMap };

struct Segment {
  std::uint16_t number = 0;
  VolumeInfo::Label label;
};

// Everything known of the file before its pixels are read.
struct SegLayout {
  std::string path;
  SegKind kind = SegKind::kBinary;
  std::uint16_t rows = 0;
  std::uint16_t columns = 0;
  std::uint16_t bitsAllocated = 1;
  std::uint16_t maxFraction = 1;  // fractional: MaximumFractionalValue
  std::uint16_t background = 0;   // label map: PixelPaddingValue, else 0
  std::map<std::uint16_t, Segment> segments;
  std::vector<std::uint16_t> segmentOfFrame;              // binary and fractional
  std::vector<std::vector<std::uint32_t>> framesOfSlice;  // by lattice slice
  VolumeInfo info;
  std::vector<std::string> warnings;

  std::int64_t framePixels() const { return std::int64_t{rows} * columns; }
};

Vec3d unit(const Vec3d& v) {
  const double n = norm(v);
  return {v[0] / n, v[1] / n, v[2] / n};
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw Error(fmt::format("{}: {}", path, what));
}

std::array<std::uint8_t, 3> labToSrgb(std::uint16_t L, std::uint16_t a, std::uint16_t b) {
  double rgb[3] = {0, 0, 0};
  IODCIELabUtil::dicomLab2RGB(rgb[0], rgb[1], rgb[2], L, a, b);
  std::array<std::uint8_t, 3> out{};
  for (std::size_t c = 0; c < 3; ++c) {
    out[c] = static_cast<std::uint8_t>(std::lround(std::clamp(rgb[c], 0.0, 1.0) * 255.0));
  }
  return out;
}

void readSegments(DcmDataset* ds, SegLayout& s) {
  DcmSequenceOfItems* sequence = nullptr;
  if (ds->findAndGetSequence(DCM_SegmentSequence, sequence).bad() || sequence == nullptr || sequence->card() == 0) {
    fail(s.path, "the DICOM Segmentation has no SegmentSequence items");
  }
  for (unsigned long n = 0; n < sequence->card(); ++n) {
    DcmItem* item = sequence->getItem(n);
    Uint16 number = 0;
    if (item->findAndGetUint16(DCM_SegmentNumber, number).bad() || number == 0) {
      fail(s.path, fmt::format("SegmentSequence item {} has no SegmentNumber of 1 or more", n + 1));
    }
    if (s.segments.count(number) != 0) fail(s.path, fmt::format("SegmentNumber {} is given twice", number));
    Segment segment;
    segment.number = number;
    segment.label.value = number;
    segment.label.name = getString(item, DCM_SegmentLabel);
    if (segment.label.name.empty()) segment.label.name = std::to_string(number);
    Uint16 lab[3] = {0, 0, 0};
    bool hasLab = true;
    for (unsigned long c = 0; c < 3; ++c) {
      hasLab = hasLab && item->findAndGetUint16(DCM_RecommendedDisplayCIELabValue, lab[c], c).good();
    }
    if (hasLab) segment.label.color = labToSrgb(lab[0], lab[1], lab[2]);
    s.segments.emplace(number, std::move(segment));
  }
}

// The pixel module: what the segmentation type allows, and a length that holds every frame.
void readPixelModule(DcmDataset* ds, std::int64_t frames, SegLayout& s) {
  s.rows = getU16(ds, DCM_Rows);
  s.columns = getU16(ds, DCM_Columns);
  if (s.rows == 0 || s.columns == 0) fail(s.path, fmt::format("Rows {} and Columns {}: no pixels", s.rows, s.columns));
  if (s.framePixels() > limits::kMaxSliceVoxels) {
    fail(s.path, fmt::format("Rows {} x Columns {} exceeds the limit of {} voxels a slice", s.rows, s.columns,
                             limits::kMaxSliceVoxels));
  }
  s.bitsAllocated = getU16(ds, DCM_BitsAllocated);
  const std::uint16_t samples = getU16(ds, DCM_SamplesPerPixel, 1);
  const std::uint16_t sign = getU16(ds, DCM_PixelRepresentation);
  const std::string type = getString(ds, DCM_SegmentationType);
  const bool labelMapClass = getString(ds, DCM_SOPClassUID) == kLabelMapStorage;
  if (labelMapClass != (type == "LABELMAP")) {
    fail(s.path, fmt::format("SegmentationType '{}' does not belong to the SOP class {}", type,
                             labelMapClass ? "Label Map Segmentation Storage" : "Segmentation Storage"));
  }
  std::string need;
  if (type == "BINARY") {
    s.kind = SegKind::kBinary;
    if (s.bitsAllocated != 1) need = "BitsAllocated 1";
  } else if (type == "FRACTIONAL") {
    s.kind = SegKind::kFractional;
    if (s.bitsAllocated != 8) need = "BitsAllocated 8";
    s.maxFraction = getU16(ds, DCM_MaximumFractionalValue);
    if (s.maxFraction == 0 || s.maxFraction > 255) {
      fail(s.path, fmt::format("MaximumFractionalValue {} is not 1 to 255", s.maxFraction));
    }
  } else if (type == "LABELMAP") {
    s.kind = SegKind::kLabelMap;
    if (s.bitsAllocated != 8 && s.bitsAllocated != 16) need = "BitsAllocated 8 or 16";
    s.background = getU16(ds, DCM_PixelPaddingValue, 0);
  } else {
    fail(s.path, fmt::format("SegmentationType '{}' is not BINARY, FRACTIONAL or LABELMAP", type.substr(0, 40)));
  }
  if (need.empty() && (samples != 1 || sign != 0)) need = "SamplesPerPixel 1 and PixelRepresentation 0";
  if (!need.empty()) {
    fail(s.path, fmt::format("a {} segmentation needs {} (it has BitsAllocated {}, SamplesPerPixel {}, "
                             "PixelRepresentation {})",
                             type, need, s.bitsAllocated, samples, sign));
  }
  DcmElement* pixels = nullptr;
  if (ds->findAndGetElement(DCM_PixelData, pixels).bad() || pixels == nullptr) fail(s.path, "no Pixel Data");
  const std::uint64_t bits =
      static_cast<std::uint64_t>(s.framePixels()) * s.bitsAllocated * static_cast<std::uint64_t>(frames);
  const std::uint64_t bytes = (bits + 7) / 8;
  const Uint32 length = pixels->getLengthField();
  if (length == DCM_UndefinedLength || !(length == bytes || (bytes % 2 == 1 && length == bytes + 1))) {
    fail(s.path,
         fmt::format("the Pixel Data holds {} bytes, but Rows {}, Columns {}, BitsAllocated {} and "
                     "NumberOfFrames {} need {}; the frames do not match the pixel module",
                     length == DCM_UndefinedLength ? std::string("an undefined number of") : std::to_string(length),
                     s.rows, s.columns, s.bitsAllocated, frames, bytes));
  }
}

// A frame's segment: SegmentIdentificationSequence > ReferencedSegmentNumber, per frame or shared.
std::uint16_t frameSegment(DcmItem* perFrame, DcmItem* shared, std::uint32_t f, const SegLayout& s) {
  Uint16 number = 0;
  bool found = false;
  for (DcmItem* level : {perFrame, shared}) {
    DcmItem* id = subItem(level, DCM_SegmentIdentificationSequence);
    if (id != nullptr && id->findAndGetUint16(DCM_ReferencedSegmentNumber, number).good()) {
      found = true;
      break;
    }
  }
  if (!found) fail(s.path, fmt::format("frame {} names no segment (ReferencedSegmentNumber)", f + 1));
  if (s.segments.count(number) == 0) {
    fail(s.path, fmt::format("frame {} names segment {}, which the SegmentSequence does not describe", f + 1, number));
  }
  return number;
}

// The slice lattice of the frames' positions: one orientation and pixel spacing for all, and every
// position on a line of planes SpacingBetweenSlices (else the smallest gap) apart.
void placeFrames(DcmDataset* ds, std::int64_t frames, SegLayout& s) {
  DcmItem* shared = subItem(ds, DCM_SharedFunctionalGroupsSequence);
  DcmSequenceOfItems* perFrames = nullptr;
  ds->findAndGetSequence(DCM_PerFrameFunctionalGroupsSequence, perFrames);
  const unsigned long items = perFrames != nullptr ? perFrames->card() : 0;
  if (items != static_cast<unsigned long>(frames)) {
    fail(s.path, fmt::format("{} per-frame functional group items for NumberOfFrames {}", items, frames));
  }
  std::vector<Vec3d> positions(static_cast<std::size_t>(frames));
  std::array<double, 6> orientation{};
  std::array<double, 2> pixelSpacing{};
  std::optional<double> thickness;
  for (std::uint32_t f = 0; f < static_cast<std::uint32_t>(frames); ++f) {
    throwIfInterruptedEvery(f);
    DcmItem* perFrame = perFrames->getItem(f);
    const FrameGeometry g = frameGeometry(nullptr, perFrame, shared, s.path);
    if (!g.position || !g.orientation || !g.spacing) {
      fail(s.path, fmt::format("frame {} has no {}", f + 1,
                               !g.position      ? "ImagePositionPatient (PlanePositionSequence)"
                               : !g.orientation ? "ImageOrientationPatient (PlaneOrientationSequence)"
                                                : "PixelSpacing (PixelMeasuresSequence)"));
    }
    if (f == 0) {
      orientation = *g.orientation;
      pixelSpacing = *g.spacing;
      thickness = g.thickness;
    } else if (!sameOrientation(orientation, *g.orientation) || !sameSpacing(pixelSpacing, *g.spacing)) {
      fail(s.path, fmt::format("frame {} has another {} than frame 1; the frames do not share one geometry", f + 1,
                               sameSpacing(pixelSpacing, *g.spacing) ? "ImageOrientationPatient" : "PixelSpacing"));
    }
    positions[f] = *g.position;
    if (s.kind != SegKind::kLabelMap) s.segmentOfFrame.push_back(frameSegment(perFrame, shared, f, s));
  }
  const Vec3d row = unit(Vec3d{orientation[0], orientation[1], orientation[2]});
  const Vec3d col = unit(Vec3d{orientation[3], orientation[4], orientation[5]});
  const Vec3d normal = unit(cross(row, col));
  // Distinct planes along the normal; positions are often written to 0.01 mm.
  const double tolerance = std::min(0.01, 0.05 * std::min(pixelSpacing[0], pixelSpacing[1]));
  std::vector<double> planes;
  for (const Vec3d& p : positions) planes.push_back(dot(p, normal));
  std::sort(planes.begin(), planes.end());
  planes.erase(std::unique(planes.begin(), planes.end(), [&](double a, double b) { return b - a <= tolerance; }),
               planes.end());
  // The step: SpacingBetweenSlices where given, else from the planes themselves: each gap counted
  // as a whole number of the smallest gap (segments skip the slices they do not touch), the step
  // then the span over that count, so that rounded positions do not add up to an error.
  double step = 0;
  std::string stepField = "ImagePositionPatient";
  std::optional<std::array<double, 6>> between =
      getDecimals(subItem(shared, DCM_PixelMeasuresSequence), DCM_SpacingBetweenSlices, 1, s.path);
  if (!between) {
    between =
        getDecimals(subItem(perFrames->getItem(0), DCM_PixelMeasuresSequence), DCM_SpacingBetweenSlices, 1, s.path);
  }
  if (between && (*between)[0] > 0) {
    step = (*between)[0];
    stepField = "SpacingBetweenSlices";
  } else if (planes.size() > 1) {
    double smallest = planes[1] - planes[0];
    for (std::size_t k = 2; k < planes.size(); ++k) smallest = std::min(smallest, planes[k] - planes[k - 1]);
    double count = 0;
    for (std::size_t k = 1; k < planes.size(); ++k) {
      count += std::max(1.0, std::round((planes[k] - planes[k - 1]) / smallest));
    }
    step = (planes.back() - planes.front()) / count;
  } else if (thickness && *thickness > 0) {
    step = *thickness;
    stepField = "SliceThickness";
  }
  if (planes.size() == 1 && !(step > 0)) {
    fail(s.path,
         "every frame lies in one plane and neither SpacingBetweenSlices nor SliceThickness gives the "
         "slices' spacing");
  }
  if (!(step > 2 * tolerance)) {
    fail(s.path, fmt::format("a slice spacing of {:g} mm ({}) is below what the positions resolve", step, stepField));
  }
  // The first plane's frame gives the origin; every frame must lie on the lattice from it, and
  // the lattice may not be mostly slices that no frame backs.
  const std::size_t first = static_cast<std::size_t>(
      std::min_element(positions.begin(), positions.end(),
                       [&](const Vec3d& a, const Vec3d& b) { return dot(a, normal) < dot(b, normal); }) -
      positions.begin());
  const Vec3d origin = positions[first];
  const double lattice = (planes.back() - planes.front()) / step;
  const double most = std::max(4096.0, 64.0 * static_cast<double>(planes.size()));
  if (!(lattice < most)) {
    fail(s.path, fmt::format("the frames' {} planes span {:g} mm, {:.0f} slices of {:g} mm ({}): too few frames for "
                             "so many slices",
                             planes.size(), planes.back() - planes.front(), lattice, step, stepField));
  }
  const auto slices = static_cast<std::int64_t>(std::llround(lattice)) + 1;
  s.framesOfSlice.assign(static_cast<std::size_t>(slices), {});
  std::vector<double> planeOfSlice(static_cast<std::size_t>(slices), std::numeric_limits<double>::quiet_NaN());
  const double inPlane = std::max(tolerance, 1e-3 * std::max(pixelSpacing[0], pixelSpacing[1]));
  for (std::uint32_t f = 0; f < static_cast<std::uint32_t>(frames); ++f) {
    const Vec3d& p = positions[f];
    const Vec3d d{p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]};
    const double along = dot(d, normal) / step;
    const auto k = static_cast<std::int64_t>(std::llround(along));
    const double shift = static_cast<double>(k) * step;
    const Vec3d off{d[0] - normal[0] * shift, d[1] - normal[1] * shift, d[2] - normal[2] * shift};
    if (std::abs(along - static_cast<double>(k)) * step > std::max(tolerance, 0.02 * step) ||
        std::abs(dot(off, row)) > inPlane || std::abs(dot(off, col)) > inPlane) {
      fail(s.path, fmt::format("frame {}'s ImagePositionPatient {:g}\\{:g}\\{:g} is not on the slice lattice of frame "
                               "{} ({:g} mm apart by {}); the frames do not match one geometry",
                               f + 1, p[0], p[1], p[2], first + 1, step, stepField));
    }
    // Two planes apart on one slice: a step far larger than the frames' own gaps.
    double& plane = planeOfSlice[static_cast<std::size_t>(k)];
    if (std::isnan(plane)) plane = dot(p, normal);
    if (std::abs(plane - dot(p, normal)) > tolerance) {
      fail(s.path, fmt::format("frames {:g} mm apart fall on one slice of {:g} mm ({}); the frames do not match one "
                               "geometry",
                               std::abs(plane - dot(p, normal)), step, stepField));
    }
    s.framesOfSlice[static_cast<std::size_t>(k)].push_back(f);
  }
  for (std::size_t k = 0; k < s.framesOfSlice.size(); ++k) {
    std::map<std::uint16_t, std::uint32_t> seen;
    for (const std::uint32_t f : s.framesOfSlice[k]) {
      const std::uint16_t segment = s.kind == SegKind::kLabelMap ? 0 : s.segmentOfFrame[f];
      if (const auto [it, fresh] = seen.emplace(segment, f); !fresh) {
        fail(s.path, fmt::format("frames {} and {} lie at one position{}", it->second + 1, f + 1,
                                 s.kind == SegKind::kLabelMap ? std::string(" (a label map has one frame a slice)")
                                                              : fmt::format(" for segment {}", segment)));
      }
    }
  }
  // Segments may skip the slices they do not touch, but frames of which no two lie on neighbouring
  // slices of SpacingBetweenSlices suggest a spacing of half the frames' (the surfaces would then
  // be slabs a slice thick, with every other slice empty).
  if (stepField == "SpacingBetweenSlices" && planes.size() >= 3) {
    // Every gap between two slices with frames exactly two slices (key slices further apart, or
    // gaps that vary, are an annotation's, not a spacing's).
    bool halved = true;
    std::size_t last = 0;
    for (std::size_t k = 1; k < s.framesOfSlice.size() && halved; ++k) {
      if (s.framesOfSlice[k].empty()) continue;
      halved = k - last == 2;
      last = k;
    }
    if (halved) {
      s.warnings.push_back(fmt::format(
          "{}: no two of its {} frame planes lie on neighbouring slices of its SpacingBetweenSlices ({:g} mm): every "
          "other slice is empty, and each segment's surface is slabs a slice thick; is the spacing right?",
          s.path, planes.size(), step));
    }
  }
  VolumeInfo& info = s.info;
  info.dims = {s.columns, s.rows, std::max<std::int64_t>(slices, 1)};
  info.spacing = {pixelSpacing[1], pixelSpacing[0], step};
  info.origin = origin;
  info.direction = {row[0], col[0], normal[0], row[1], col[1], normal[1], row[2], col[2], normal[2]};
  info.spacingFields = {"PixelSpacing", "PixelSpacing", stepField};
  info.originField = "ImagePositionPatient";
}

// Reads one frame's pixels into `out` as 0/1 (binary, fractional at >= 50%) or segment numbers.
class FrameReader {
 public:
  FrameReader(const SegLayout& s, DcmElement* pixels) : s_(s), pixels_(pixels) {}

  void read(std::uint32_t f, std::vector<std::uint16_t>& out) {
    const auto n = static_cast<std::uint64_t>(s_.framePixels());
    out.resize(n);
    const std::uint64_t firstBit = f * n * s_.bitsAllocated;
    const std::uint64_t firstByte = firstBit / 8;
    const std::uint64_t shift = firstBit % 8;
    const std::uint64_t bytes = (shift + n * s_.bitsAllocated + 7) / 8;
    buffer_.resize(bytes);
    const OFCondition c = pixels_->getPartialValue(buffer_.data(), static_cast<Uint32>(firstByte),
                                                   static_cast<Uint32>(bytes), &cache_, gLocalByteOrder);
    if (c.bad()) fail(s_.path, fmt::format("cannot read frame {}: {}", f + 1, c.text()));
    switch (s_.kind) {
      case SegKind::kBinary:
        for (std::uint64_t p = 0; p < n; ++p) out[p] = (buffer_[(shift + p) / 8] >> ((shift + p) % 8)) & 1u;
        break;
      case SegKind::kFractional:
        for (std::uint64_t p = 0; p < n; ++p) out[p] = 2u * buffer_[p] >= s_.maxFraction ? 1 : 0;
        break;
      case SegKind::kLabelMap:
        for (std::uint64_t p = 0; p < n; ++p) {
          out[p] = s_.bitsAllocated == 8 ? buffer_[p]
                                         : static_cast<std::uint16_t>(buffer_[2 * p] | (buffer_[2 * p + 1] << 8));
        }
        break;
    }
  }

 private:
  const SegLayout& s_;
  DcmElement* pixels_;
  DcmFileCache cache_;
  std::vector<std::uint8_t> buffer_;
};

// Segments that share a voxel, as pairs (lower number first): one pass over the slices that hold
// frames of two or more segments, a slice of owners at a time. A pixel that a second segment covers
// keeps its list of segments aside, so that three or more on one pixel give every pair.
std::set<std::pair<std::uint16_t, std::uint16_t>> overlaps(const SegLayout& s, FrameReader& reader) {
  constexpr std::size_t kMostPairs = 1u << 20;
  std::set<std::pair<std::uint16_t, std::uint16_t>> pairs;
  std::vector<std::uint16_t> owner;
  std::vector<std::uint16_t> mask;
  std::unordered_map<std::size_t, std::vector<std::uint16_t>> shared;  // pixel -> every segment on it
  for (const auto& frames : s.framesOfSlice) {
    throwIfInterrupted();
    if (frames.size() < 2) continue;
    owner.assign(static_cast<std::size_t>(s.framePixels()), 0);
    shared.clear();
    for (const std::uint32_t f : frames) {
      reader.read(f, mask);
      const std::uint16_t segment = s.segmentOfFrame[f];
      for (std::size_t p = 0; p < mask.size(); ++p) {
        if (mask[p] == 0) continue;
        if (owner[p] == 0) {
          owner[p] = segment;
          continue;
        }
        std::vector<std::uint16_t>& on = shared[p];
        if (on.empty()) on.push_back(owner[p]);
        for (const std::uint16_t other : on) pairs.emplace(std::min(other, segment), std::max(other, segment));
        on.push_back(segment);
        if (pairs.size() > kMostPairs) {
          fail(s.path, fmt::format("more than {} pairs of segments overlap", kMostPairs));
        }
      }
    }
  }
  return pairs;
}

// Layers: each segment the lowest layer that none of the segments it overlaps (and that come
// before it) holds.
std::map<std::uint16_t, int> layersOf(const SegLayout& s,
                                      const std::set<std::pair<std::uint16_t, std::uint16_t>>& pairs, int& layers) {
  std::map<std::uint16_t, std::vector<std::uint16_t>> before;  // segment -> the smaller ones it overlaps
  for (const auto& [a, b] : pairs) before[b].push_back(a);
  std::map<std::uint16_t, int> layerOf;
  layers = 1;
  std::vector<bool> taken;
  for (const auto& [number, segment] : s.segments) {
    taken.assign(static_cast<std::size_t>(layers) + 1, false);
    if (const auto it = before.find(number); it != before.end()) {
      for (const std::uint16_t other : it->second) taken[static_cast<std::size_t>(layerOf[other])] = true;
    }
    int l = 0;
    while (taken[static_cast<std::size_t>(l)]) ++l;
    layerOf[number] = l;
    layers = std::max(layers, l + 1);
  }
  return layerOf;
}

class DicomSegSource final : public SliceSource {
 public:
  /// `planeOf`: the plane of a slice that each segment read goes to (every other is left out).
  DicomSegSource(std::unique_ptr<DcmFileFormat> file, SegLayout layout, DcmElement* pixels,
                 std::map<std::uint16_t, int> planeOf)
      : file_(std::move(file)), layout_(std::move(layout)), reader_(layout_, pixels), planeOf_(std::move(planeOf)) {}

  const VolumeInfo& info() const noexcept override { return layout_.info; }
  std::vector<std::string> warnings() override { return layout_.warnings; }

  bool readSlice(std::span<float> slice) override {
    if (next_ >= static_cast<std::int64_t>(layout_.framesOfSlice.size())) return false;
    std::fill(slice.begin(), slice.end(), 0.0f);
    for (const std::uint32_t f : layout_.framesOfSlice[static_cast<std::size_t>(next_)]) {
      if (layout_.kind != SegKind::kLabelMap) {
        const std::uint16_t segment = layout_.segmentOfFrame[f];
        const auto plane = planeOf_.find(segment);
        if (plane == planeOf_.end()) continue;
        reader_.read(f, mask_);
        float* out = slice.data() + static_cast<std::size_t>(plane->second) * mask_.size();
        for (std::size_t p = 0; p < mask_.size(); ++p) {
          if (mask_[p] != 0) out[p] = segment;
        }
        continue;
      }
      reader_.read(f, mask_);
      for (std::size_t p = 0; p < mask_.size(); ++p) {
        const std::uint16_t v = mask_[p];
        if (v == layout_.background) continue;
        if (layout_.segments.count(v) == 0) {
          fail(layout_.path, fmt::format("frame {} holds pixel value {} at column {}, row {}, which is neither a "
                                         "SegmentNumber nor the background {}",
                                         f + 1, v, p % layout_.columns, p / layout_.columns, layout_.background));
        }
        slice[p] = v;
      }
    }
    ++next_;
    return true;
  }

  std::int64_t skipSlices(std::int64_t n) override {
    const std::int64_t skipped = std::min(n, static_cast<std::int64_t>(layout_.framesOfSlice.size()) - next_);
    next_ += skipped;
    return skipped;
  }

 private:
  std::unique_ptr<DcmFileFormat> file_;
  SegLayout layout_;
  FrameReader reader_;
  std::map<std::uint16_t, int> planeOf_;
  std::vector<std::uint16_t> mask_;
  std::int64_t next_ = 0;
};

}  // namespace

bool isDicomSegmentation(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec) || !looksLikeDicom(path)) return false;
  if (!nestingDepthProblem(path).empty()) return false;  // the series scan says what is wrong
  initDcmtk();
  DcmFileFormat ff;
  if (ff.loadFile(path.c_str(), EXS_Unknown, EGL_noChange, 256).bad()) return false;
  const std::string sop = getString(ff.getDataset(), DCM_SOPClassUID);
  return sop == kSegmentationStorage || sop == kLabelMapStorage;
}

std::unique_ptr<SliceSource> openDicomSegmentation(const std::string& path, int layer,
                                                   std::vector<std::string>* notes) {
  if (const std::string problem = nestingDepthProblem(path); !problem.empty()) throw Error(problem);
  initDcmtk();
  auto file = std::make_unique<DcmFileFormat>();
  if (const OFCondition c = file->loadFile(path.c_str(), EXS_Unknown, EGL_noChange, 4096); c.bad()) {
    fail(path, fmt::format("not a readable DICOM file: {}", c.text()));
  }
  DcmDataset* ds = file->getDataset();
  SegLayout s;
  s.path = path;
  const DcmXfer xfer(ds->getOriginalXfer());
  if (xfer.isEncapsulated() || xfer.getByteOrder() == EBO_BigEndian) {
    fail(path, fmt::format("a DICOM Segmentation in {} is not read (uncompressed or deflated little endian only)",
                           xfer.getXferName()));
  }
  Sint32 frames = 0;
  if (ds->findAndGetSint32(DCM_NumberOfFrames, frames).bad() || frames < 1 || frames > limits::kMaxFrames) {
    fail(path, fmt::format("NumberOfFrames {} is not 1 to {}", frames, limits::kMaxFrames));
  }
  readSegments(ds, s);
  readPixelModule(ds, frames, s);
  placeFrames(ds, frames, s);
  DcmElement* pixels = nullptr;
  ds->findAndGetElement(DCM_PixelData, pixels);
  FrameReader reader(s, pixels);

  // Layers: segments that overlap never share one.
  std::map<std::uint16_t, int> layerOf;
  int layers = 1;
  if (s.kind != SegKind::kLabelMap) layerOf = layersOf(s, overlaps(s, reader), layers);
  const bool everyLayer = layers > 1 && layer == kEveryLayer;
  if (everyLayer && layers > kMaxLayers) {
    fail(path, fmt::format("{} segmentation layers; one pass reads at most {}: choose one with `channel`", layers,
                           kMaxLayers));
  }
  if (layers > 1 && layer < 0 && !everyLayer) {
    fail(path, fmt::format("{} segmentation layers (segments of different layers overlap); a run meshes one: "
                           "choose it with `channel` 0..{}",
                           layers, layers - 1));
  }
  if (layer >= layers) {
    fail(path,
         fmt::format("`channel` {} is past the segmentation's {} layer{}", layer, layers, layers == 1 ? "" : "s"));
  }
  const int chosen = std::max(layer, 0);
  std::map<std::uint16_t, int> planeOf;  // the segments read, and the plane of each
  VolumeInfo& info = s.info;
  std::uint16_t largest = 0;
  for (auto& [number, segment] : s.segments) {
    segment.label.layer = layerOf.count(number) != 0 ? layerOf[number] : 0;
    if (segment.label.layer != chosen && !everyLayer) continue;
    planeOf[number] = everyLayer ? segment.label.layer : 0;
    info.labels.push_back(segment.label);
    largest = std::max(largest, number);
  }
  if (everyLayer) info.layers = layers;
  info.labelMap = true;
  info.type = largest > 255 ? VoxelType::kU16 : VoxelType::kU8;
  info.valueRange = std::array<double, 2>{0, static_cast<double>(largest)};
  info.frame = "lps";
  info.reader = "dicom-seg";
  info.source = path;
  info.modality = "SEG";
  if (notes != nullptr) {
    const char* kind = s.kind == SegKind::kBinary       ? "binary"
                       : s.kind == SegKind::kFractional ? "fractional"
                                                        : "label map";
    notes->push_back(fmt::format("{}: a {} DICOM Segmentation of {} segment{} in {} frame{}{}", path, kind,
                                 s.segments.size(), s.segments.size() == 1 ? "" : "s", frames, frames == 1 ? "" : "s",
                                 everyLayer   ? fmt::format("; {} layers, read in one pass", layers)
                                 : layers > 1 ? fmt::format("; layer {} of {} holds {}", chosen, layers, planeOf.size())
                                              : std::string()));
  }
  return std::make_unique<DicomSegSource>(std::move(file), std::move(s), pixels, std::move(planeOf));
}

}  // namespace isoslab
