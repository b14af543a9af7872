// The parts of DICOM input that need no DCMTK, so that detecting a DICOM input and describing a
// scanned series never load the DICOM module (io/dicom_module.h).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>

#include "core/error.h"
#include "core/vec3.h"
#include "io/dicom_series.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

bool looksLikeDicom(const std::string& path) {
  if (fs::path(path).filename() == "DICOMDIR") return true;
  std::ifstream f(path, std::ios::binary);
  char magic[132] = {};
  if (!f.read(magic, 132)) return false;
  return std::memcmp(magic + 128, "DICM", 4) == 0;
}

bool isDicomInput(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    for (fs::recursive_directory_iterator it(path, ec), end; it != end; it.increment(ec)) {
      if (ec) break;
      if (it->is_regular_file(ec) && looksLikeDicom(it->path().string())) return true;
    }
    return false;
  }
  return fs::is_regular_file(path, ec) && looksLikeDicom(path);
}

std::optional<double> geometricTilt(const DicomSeries& series) {
  if (series.slices.size() < 2 || !series.slices.front().position || !series.slices.back().position) {
    return std::nullopt;
  }
  const auto& o = series.orientation;
  const Vec3d normal = cross({o[0], o[1], o[2]}, {o[3], o[4], o[5]});
  const Vec3d& a = *series.slices.front().position;
  const Vec3d& b = *series.slices.back().position;
  const Vec3d step{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double lengths = std::sqrt(dot(normal, normal) * dot(step, step));
  if (!(lengths > 0)) return std::nullopt;
  // Slices are sorted along the normal, so the angle is below 90 degrees; the clamp guards acos
  // against rounding.
  const double c = std::clamp(dot(normal, step) / lengths, -1.0, 1.0);
  return std::acos(c) * 180 / std::numbers::pi;
}

std::optional<std::array<double, 6>> patientExtent(const DicomSeries& series) {
  std::array<double, 6> box{kInf, kInf, kInf, -kInf, -kInf, -kInf};
  const auto& o = series.orientation;
  // ImagePositionPatient is the centre of the first pixel; the row direction runs along a row
  // (columns apart by the column spacing), the column direction down a column.
  const double across = (series.columns - 1.0) * series.pixelSpacing[1];
  const double down = (series.rows - 1.0) * series.pixelSpacing[0];
  for (const DicomSlice& slice : series.slices) {
    if (!slice.position) return std::nullopt;
    for (const double i : {0.0, across}) {
      for (const double j : {0.0, down}) {
        for (std::size_t c = 0; c < 3; ++c) {
          const double v = (*slice.position)[c] + i * o[c] + j * o[3 + c];
          box[c] = std::min(box[c], v);
          box[3 + c] = std::max(box[3 + c], v);
        }
      }
    }
  }
  if (series.slices.empty()) return std::nullopt;
  return box;
}

const DicomSeries& chooseSeries(const DicomScan& scan, const DicomOptions& options, std::string* chosenNote) {
  if (scan.series.empty()) throw Error("no DICOM image series found");
  if (!options.series.empty()) {
    for (const DicomSeries& s : scan.series) {
      if (s.uid == options.series) return s;
    }
    char* end = nullptr;
    const long index = std::strtol(options.series.c_str(), &end, 10);
    if (end == options.series.c_str() + options.series.size() && index >= 0 &&
        static_cast<std::size_t>(index) < scan.series.size()) {
      return scan.series[static_cast<std::size_t>(index)];
    }
    throw Error(fmt::format("`series`: no series '{}' (give a SeriesInstanceUID or an index 0..{}; see isoslab info)",
                            options.series, scan.series.size() - 1));
  }
  std::size_t best = 0;
  for (std::size_t i = 1; i < scan.series.size(); ++i) {
    if (scan.series[i].slices.size() > scan.series[best].slices.size()) best = i;
  }
  if (chosenNote != nullptr && scan.series.size() > 1) {
    const std::size_t images = scan.series[best].slices.size();
    *chosenNote = fmt::format("{} series found; using series {} ({}, {} image{}), the largest; choose with `series`",
                              scan.series.size(), best, scan.series[best].uid, images, images == 1 ? "" : "s");
  }
  return scan.series[best];
}

}  // namespace isoslab
