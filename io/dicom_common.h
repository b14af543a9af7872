// What the DICOM readers share (io/dicom_series.cpp, io/dicom_seg.cpp): DCMTK's set-up, strict
// reading of attribute values, and one frame's geometry. Internal: not installed.
#pragma once

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcitem.h>

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "core/vec3.h"

namespace isoslab::dicom {

/// Registers the RLE, JPEG and JPEG-LS decoders and silences DCMTK's logger, once per process.
void initDcmtk();

/// The attribute's whole value as text, or empty when absent.
std::string getString(DcmItem* item, const DcmTagKey& tag);
/// The first `n` values as numbers; false when any is missing.
bool getDoubles(DcmItem* item, const DcmTagKey& tag, double* out, int n);
std::uint16_t getU16(DcmItem* item, const DcmTagKey& tag, std::uint16_t fallback = 0);
/// The first item of sequence `seq` inside `group`, or null.
DcmItem* subItem(DcmItem* group, const DcmTagKey& seq);

/// A decimal element (DS or FD) read as `n` numbers: empty when the element is absent or empty, an
/// error naming the file when it holds text, fewer values, or NaN or infinity. (Taking text as
/// absent would put a default, such as a RescaleSlope of 1, in its place without a word.)
std::optional<std::array<double, 6>> getDecimals(DcmItem* item, const DcmTagKey& tag, int n, const std::string& path);

/// Geometry and rescale of one frame, from a plain image or the functional groups of a
/// multi-frame image (per-frame group first, then the shared group). Text, NaN or infinity in any
/// of these is an error naming `path`, as are a PixelSpacing that is not positive and an
/// ImageOrientationPatient whose row and column directions are zero or parallel.
struct FrameGeometry {
  std::optional<Vec3d> position;
  std::optional<std::array<double, 6>> orientation;
  std::optional<std::array<double, 2>> spacing;
  std::optional<double> thickness;
  double slope = 1;
  double intercept = 0;
};
FrameGeometry frameGeometry(DcmItem* plain, DcmItem* perFrame, DcmItem* shared, const std::string& path);

/// What makes a file unsafe to parse, or empty: sequences nested deeper than DCMTK's recursive
/// parser can take (io/dicom_series.cpp; checked on the raw bytes before any loadFile).
std::string nestingDepthProblem(const std::string& path);

/// Whether two ImageOrientationPatient values are the same: each direction cosine within 1e-4.
bool sameOrientation(const std::array<double, 6>& a, const std::array<double, 6>& b);
/// Whether two PixelSpacing values are the same to the precision DICOM writes them with.
bool sameSpacing(const std::array<double, 2>& a, const std::array<double, 2>& b);

}  // namespace isoslab::dicom
