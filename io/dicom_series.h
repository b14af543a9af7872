// DICOM input: series discovery from headers only, and a slice source that decodes one frame at a
// time. Uses DCMTK (dcmdata with its RLE, JPEG and JPEG-LS decoders) and OpenJPEG for JPEG 2000.
//
// Geometry: slices are sorted by the projection of ImagePositionPatient on the slice normal
// (row x column direction of ImageOrientationPatient); InstanceNumber only when positions are
// missing. Every slice keeps its own origin (VolumeInfo::sliceOrigins), so uneven spacing and
// gantry tilt are exact. Pixel values: BitsStored is honoured (masked, or sign-extended for
// signed data); MONOCHROME1 is inverted within the stored range (v' = min + max - v) so that higher
// values are brighter in every series; then each slice's RescaleSlope and RescaleIntercept apply,
// so CT values are in HU.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

struct DicomOptions {
  /// Series to read: its SeriesInstanceUID, or its index in scan order (as "isoslab info" lists).
  /// Empty: the series with the most images.
  std::string series;
  /// Turn series warnings (a slice may be missing, duplicates) into errors; notes stay notes.
  bool strict = false;
  /// Skip unreadable or corrupt files with a warning instead of failing.
  bool skipBad = false;
  /// Sample to use from colour images; -1 means colour images are an error.
  int channel = -1;
};

/// One image plane of a series: a single-frame file, or one frame of a multi-frame file.
struct DicomSlice {
  std::string path;
  std::uint32_t frame = 0;
  std::optional<std::array<double, 3>> position;  // ImagePositionPatient
  std::int32_t instanceNumber = 0;
  double slope = 1;
  double intercept = 0;
  std::optional<double> thickness;  // SliceThickness, mm
};

struct DicomSeries {
  std::string uid;
  std::string description;
  std::string modality;
  std::string transferSyntax;  // name, e.g. "Little Endian Explicit"
  std::string transferSyntaxUid;
  std::uint16_t rows = 0;
  std::uint16_t columns = 0;
  std::uint16_t bitsAllocated = 0;
  std::uint16_t bitsStored = 0;
  std::uint16_t highBit = 0;
  std::uint16_t pixelRepresentation = 0;  // 1: signed
  std::uint16_t samplesPerPixel = 1;
  std::uint16_t planarConfiguration = 0;
  std::string photometric;
  std::array<double, 2> pixelSpacing{1, 1};  // row spacing (between rows), column spacing
  std::array<double, 6> orientation{1, 0, 0, 0, 1, 0};
  bool multiFrame = false;
  /// GantryDetectorTilt of the first image, in degrees, when present.
  std::optional<double> gantryTilt;
  std::vector<DicomSlice> slices;  // sorted
  /// Problems that may make the volume wrong (a slice may be missing, duplicates); --strict makes
  /// the first one an error.
  std::vector<std::string> warnings;
  /// Facts worth knowing that do not make the volume wrong (uneven spacing that the slices'
  /// thickness covers); never an error.
  std::vector<std::string> notes;
  /// Distances between consecutive slice origins along the normal, after sorting.
  std::vector<double> gaps;
};

struct DicomScan {
  std::vector<DicomSeries> series;
  /// Files that are not DICOM images (non-DICOM files, directories, private objects), counted.
  int skipped = 0;
  /// DICOM Segmentation objects found (also counted in `skipped`): label volumes of their own,
  /// read by io/dicom_seg.h, never part of a series.
  std::vector<std::string> segmentations;
  std::vector<std::string> warnings;
};

/// True if `path` is a DICOM file by its preamble ("DICM" at offset 128) or is named DICOMDIR.
bool looksLikeDicom(const std::string& path);

/// True if `path` is a folder holding at least one file that looksLikeDicom (searched recursively),
/// or a DICOM file.
bool isDicomInput(const std::string& path);

/// Reads the headers of `inputs` (folders searched recursively, DICOMDIRs, files), groups images by
/// SeriesInstanceUID and sorts each series. Pixel data stays on disk. Throws isoslab::Error for
/// corrupt files (unless skipBad), for series mixing sizes, orientations or pixel types (naming
/// the files), and, when strict, for any series warning.
DicomScan scanDicom(const std::vector<std::string>& inputs, const DicomOptions& options);

/// The angle in degrees between the slice normal (row x column of ImageOrientationPatient) and the
/// line from the first slice's position to the last one's: the gantry tilt the geometry shows.
/// Empty when positions are missing or the series has fewer than two slices.
std::optional<double> geometricTilt(const DicomSeries& series);

/// The LPS box, in mm, around the corner pixel centres of every slice: xmin ymin zmin xmax ymax
/// zmax. Empty when positions are missing.
std::optional<std::array<double, 6>> patientExtent(const DicomSeries& series);

/// Picks the series named by options.series, or the largest one (`chosenNote` then says so).
const DicomSeries& chooseSeries(const DicomScan& scan, const DicomOptions& options, std::string* chosenNote);

/// Opens one series as a slice source in patient coordinates (LPS, mm).
std::unique_ptr<SliceSource> openDicomSeries(const DicomSeries& series, const DicomOptions& options);

}  // namespace isoslab
