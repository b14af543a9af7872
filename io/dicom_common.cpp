// Shared by the DICOM readers (io/dicom_series.cpp, io/dicom_seg.cpp): DCMTK set-up, strict
// reading of values, and a frame's geometry from plain or functional-group attributes.
#include "io/dicom_common.h"

#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcelem.h>
#include <dcmtk/dcmdata/dcrledrg.h>
#include <dcmtk/dcmdata/dcsequen.h>
#include <dcmtk/dcmjpeg/djdecode.h>
#include <dcmtk/dcmjpls/djdecode.h>
#include <dcmtk/oflog/oflog.h>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <mutex>

#include "core/error.h"

namespace isoslab::dicom {

void initDcmtk() {
  static std::once_flag once;
  std::call_once(once, [] {
    // DCMTK's own log lines would be library noise; its conditions are reported by isoslab.
    OFLog::configure(OFLogger::OFF_LOG_LEVEL);
    DcmRLEDecoderRegistration::registerCodecs();
    DJDecoderRegistration::registerCodecs();
    DJLSDecoderRegistration::registerCodecs();
    // Deregistered at exit, before DCMTK's own list goes: the codecs and their list entries are
    // freed rather than left to the leak checker (this code is in the DICOM module, which is
    // loaded after the checker registered its own exit handler, so this one runs first).
    std::atexit([] {
      DJLSDecoderRegistration::cleanup();
      DJDecoderRegistration::cleanup();
      DcmRLEDecoderRegistration::cleanup();
    });
  });
}

std::string getString(DcmItem* item, const DcmTagKey& tag) {
  OFString s;
  if (item != nullptr && item->findAndGetOFStringArray(tag, s).good()) return std::string(s.c_str());
  return {};
}

bool getDoubles(DcmItem* item, const DcmTagKey& tag, double* out, int n) {
  if (item == nullptr) return false;
  for (int i = 0; i < n; ++i) {
    Float64 v = 0;
    if (item->findAndGetFloat64(tag, v, static_cast<unsigned long>(i)).bad()) return false;
    out[i] = v;
  }
  return true;
}

std::uint16_t getU16(DcmItem* item, const DcmTagKey& tag, std::uint16_t fallback) {
  Uint16 v = 0;
  return item->findAndGetUint16(tag, v).good() ? v : fallback;
}

// The first item of sequence `seq` inside `group`, or null.
DcmItem* subItem(DcmItem* group, const DcmTagKey& seq) {
  DcmItem* item = nullptr;
  if (group == nullptr || group->findAndGetSequenceItem(seq, item, 0).bad()) return nullptr;
  return item;
}

// A decimal element (DS or FD) read as `n` numbers: empty when the element is absent or empty, an
// error naming the file when it holds text, fewer values, or NaN or infinity. (Taking text as
// absent would put a default, such as a RescaleSlope of 1, in its place without a word.)
std::optional<std::array<double, 6>> getDecimals(DcmItem* item, const DcmTagKey& tag, int n, const std::string& path) {
  DcmElement* element = nullptr;
  if (item == nullptr || item->findAndGetElement(tag, element).bad() || element == nullptr ||
      element->getLength() == 0) {
    return std::nullopt;
  }
  std::array<double, 6> v{};
  for (int i = 0; i < n; ++i) {
    Float64 x = 0;
    bool ok = element->getFloat64(x, static_cast<unsigned long>(i)).good();
    if (ok && element->ident() == EVR_DS) {
      // DCMTK takes the leading number of a decimal string ("1\n2" as 1): the whole value must be one.
      OFString one;
      ok = element->getOFString(one, static_cast<unsigned long>(i), OFTrue).good();
      const char* begin = one.c_str();
      char* end = nullptr;
      x = std::strtod(begin, &end);
      while (ok && end != nullptr && *end == ' ') ++end;
      ok =
          ok && end != begin && end != nullptr && *end == '\0' && std::isspace(static_cast<unsigned char>(*begin)) == 0;
    }
    if (!ok || !std::isfinite(x)) {
      OFString raw;
      element->getOFStringArray(raw);
      std::string text(raw.c_str());
      if (text.size() > 64) text = text.substr(0, 64) + "...";
      const unsigned long values = element->getVM();
      throw Error(fmt::format("{}: {} '{}' is not {}{}", path, DcmTag(tag).getTagName(), text,
                              n == 1 ? std::string("a finite number") : fmt::format("{} finite numbers", n),
                              values < static_cast<unsigned long>(n) ? fmt::format(" (it has {})", values) : ""));
    }
    v[static_cast<std::size_t>(i)] = x;
  }
  return v;
}

FrameGeometry frameGeometry(DcmItem* plain, DcmItem* perFrame, DcmItem* shared, const std::string& path) {
  FrameGeometry g;
  auto position = [&](DcmItem* item) -> std::optional<Vec3d> {
    if (auto v = getDecimals(item, DCM_ImagePositionPatient, 3, path)) return Vec3d{(*v)[0], (*v)[1], (*v)[2]};
    return std::nullopt;
  };
  auto spacing = [&](DcmItem* item) -> std::optional<std::array<double, 2>> {
    if (auto v = getDecimals(item, DCM_PixelSpacing, 2, path)) return std::array<double, 2>{(*v)[0], (*v)[1]};
    return std::nullopt;
  };
  for (DcmItem* level : {shared, perFrame}) {  // per-frame values override shared ones
    if (level == nullptr) continue;
    if (auto v = position(subItem(level, DCM_PlanePositionSequence))) g.position = v;
    if (auto v = getDecimals(subItem(level, DCM_PlaneOrientationSequence), DCM_ImageOrientationPatient, 6, path)) {
      g.orientation = v;
    }
    DcmItem* measures = subItem(level, DCM_PixelMeasuresSequence);
    if (auto v = spacing(measures)) g.spacing = v;
    if (double t = 0; getDoubles(measures, DCM_SliceThickness, &t, 1)) g.thickness = t;
    DcmItem* transform = subItem(level, DCM_PixelValueTransformationSequence);
    if (auto v = getDecimals(transform, DCM_RescaleSlope, 1, path)) g.slope = (*v)[0];
    if (auto v = getDecimals(transform, DCM_RescaleIntercept, 1, path)) g.intercept = (*v)[0];
  }
  if (plain != nullptr) {
    if (auto v = position(plain); v && !g.position) g.position = v;
    if (auto v = getDecimals(plain, DCM_ImageOrientationPatient, 6, path); v && !g.orientation) g.orientation = v;
    if (auto v = spacing(plain); v && !g.spacing) g.spacing = v;
    if (double t = 0; !g.thickness && getDoubles(plain, DCM_SliceThickness, &t, 1)) g.thickness = t;
    if (auto v = getDecimals(plain, DCM_RescaleSlope, 1, path)) g.slope = (*v)[0];
    if (auto v = getDecimals(plain, DCM_RescaleIntercept, 1, path)) g.intercept = (*v)[0];
  }
  if (g.spacing && !((*g.spacing)[0] > 0 && (*g.spacing)[1] > 0)) {
    throw Error(fmt::format("{}: PixelSpacing {:g}\\{:g} is not positive", path, (*g.spacing)[0], (*g.spacing)[1]));
  }
  if (g.orientation) {
    const auto& o = *g.orientation;
    const Vec3d row{o[0], o[1], o[2]};
    const Vec3d col{o[3], o[4], o[5]};
    const double rowLength = norm(row);
    const double colLength = norm(col);
    const Vec3d n = cross(row, col);
    // The sine of the angle between the directions: 1 for a proper orientation.
    const double sine = rowLength > 0 && colLength > 0 ? norm(n) / (rowLength * colLength) : 0;
    if (!(rowLength > 1e-6) || !(colLength > 1e-6) || !(sine > 1e-3)) {
      throw Error(fmt::format("{}: ImageOrientationPatient {:g}\\{:g}\\{:g}\\{:g}\\{:g}\\{:g} is degenerate: {}", path,
                              o[0], o[1], o[2], o[3], o[4], o[5],
                              !(rowLength > 1e-6)   ? "the row direction is zero"
                              : !(colLength > 1e-6) ? "the column direction is zero"
                                                    : "the row and column directions are parallel"));
    }
  }
  return g;
}

// Whether two ImageOrientationPatient values are the same: each direction cosine within 1e-4.
bool sameOrientation(const std::array<double, 6>& a, const std::array<double, 6>& b) {
  for (std::size_t k = 0; k < 6; ++k) {
    if (std::abs(a[k] - b[k]) > 1e-4) return false;
  }
  return true;
}

// Whether two PixelSpacing values are the same to the precision DICOM writes them with.
bool sameSpacing(const std::array<double, 2>& a, const std::array<double, 2>& b) {
  for (std::size_t i = 0; i < 2; ++i) {
    if (std::abs(a[i] - b[i]) > 1e-4 * std::max(std::abs(a[i]), std::abs(b[i]))) return false;
  }
  return true;
}
}  // namespace isoslab::dicom
