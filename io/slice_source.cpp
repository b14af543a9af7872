#include "io/slice_source.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace isoslab {

std::int64_t SliceSource::skipSlices(std::int64_t n) {
  std::int64_t skipped = 0;
  if (lendsSlices()) {
    while (skipped < n && lendSlice() != nullptr) ++skipped;
    return skipped;
  }
  std::vector<float> scratch;
  while (skipped < n && readSliceInto(*this, scratch)) ++skipped;
  return skipped;
}

bool readSliceInto(SliceSource& source, std::vector<float>& slice) {
  if (!source.fetchSlice()) return false;
  slice.resize(static_cast<std::size_t>(source.info().sliceValues()));
  return source.readSlice(slice);
}

void validateGeometry(const VolumeInfo& info, const std::string& what) {
  for (std::size_t a = 0; a < 3; ++a) {
    const double s = info.spacing[a];
    if (!std::isfinite(s)) throw Error(fmt::format("{}: spacing {} along axis {} is not finite", what, s, a));
    if (!(s > 0)) throw Error(fmt::format("{}: spacing {} along axis {} is not positive", what, s, a));
  }
  for (const double o : info.origin) {
    if (!std::isfinite(o)) {
      throw Error(
          fmt::format("{}: origin {},{},{} is not finite", what, info.origin[0], info.origin[1], info.origin[2]));
    }
  }
  for (std::size_t k = 0; k < info.sliceOrigins.size(); ++k) {
    const auto& o = info.sliceOrigins[k];
    if (!std::isfinite(o[0]) || !std::isfinite(o[1]) || !std::isfinite(o[2])) {
      throw Error(fmt::format("{}: the origin {},{},{} of slice {} is not finite", what, o[0], o[1], o[2], k));
    }
  }
  const auto& d = info.direction;
  for (const double v : d) {
    if (!std::isfinite(v)) throw Error(fmt::format("{}: direction has a non-finite entry ({})", what, v));
  }
  // The columns, normalised: their lengths are the reader's business, their angles are not.
  std::array<std::array<double, 3>, 3> c{};
  for (std::size_t a = 0; a < 3; ++a) {
    const double len = std::hypot(d[a], d[3 + a], d[6 + a]);
    if (!(len > 0)) throw Error(fmt::format("{}: direction column {} (axis {}) is zero", what, a, a));
    for (std::size_t r = 0; r < 3; ++r) c[a][r] = d[3 * r + a] / len;
  }
  // Unit columns 1e-6 radians (0.00006 degrees) from collinear, or a volume of the unit cell below
  // 1e-6, cannot come from a scanner: the mesh would be flat.
  constexpr double kTolerance = 1e-6;
  for (std::size_t a = 0; a < 3; ++a) {
    for (std::size_t b = a + 1; b < 3; ++b) {
      const std::array<double, 3> x{c[a][1] * c[b][2] - c[a][2] * c[b][1], c[a][2] * c[b][0] - c[a][0] * c[b][2],
                                    c[a][0] * c[b][1] - c[a][1] * c[b][0]};
      if (std::hypot(x[0], x[1], x[2]) < kTolerance) {
        throw Error(fmt::format("{}: direction columns {} and {} are collinear", what, a, b));
      }
    }
  }
  const double det = c[0][0] * (c[1][1] * c[2][2] - c[1][2] * c[2][1]) -
                     c[1][0] * (c[0][1] * c[2][2] - c[0][2] * c[2][1]) +
                     c[2][0] * (c[0][1] * c[1][2] - c[0][2] * c[1][1]);
  if (std::abs(det) < kTolerance) {
    throw Error(fmt::format("{}: direction columns are coplanar (determinant {:.3g}): the volume is flat", what, det));
  }
}

void validateFloat32Geometry(const VolumeInfo& info, const std::string& what) {
  // Meshes hold float32 coordinates: the lattice's box must fit float32's range, and neighbouring
  // lattice points must stay apart at that box's magnitude. Both are checked in double on the
  // physical frame (ras and lps have the same magnitudes; voxel coordinates are small).
  const auto& d = info.direction;
  std::array<double, 3> extent{};  // how far each axis reaches from the origin
  for (std::size_t a = 0; a < 3; ++a) {
    const double len = std::hypot(d[a], d[3 + a], d[6 + a]);
    extent[a] = info.spacing[a] * len * static_cast<double>(std::max<std::int64_t>(info.dims[a] - 1, 0));
  }
  const bool hasSliceOrigins = !info.sliceOrigins.empty();
  double originReach = 0;  // the largest |coordinate| of the origin, or of any slice's origin
  for (const double o : info.origin) originReach = std::max(originReach, std::abs(o));
  for (const auto& o : info.sliceOrigins) {
    for (const double v : o) originReach = std::max(originReach, std::abs(v));
  }
  // The largest |coordinate| of any lattice point: at a corner of the box (of a slice's rectangle
  // with per-slice origins), mapped as LatticeFrame::physical() maps it.
  std::array<double, 3> reachOf{};  // per output coordinate
  const std::size_t slices = hasSliceOrigins ? info.sliceOrigins.size() : 2;
  for (std::size_t k = 0; k < slices; ++k) {
    for (int c = 0; c < 4; ++c) {
      for (std::size_t r = 0; r < 3; ++r) {
        double v = hasSliceOrigins ? info.sliceOrigins[k][r] : info.origin[r];
        if (!hasSliceOrigins && k == 1) v += d[3 * r + 2] * info.spacing[2] * static_cast<double>(info.dims[2] - 1);
        if (c & 1) v += d[3 * r] * info.spacing[0] * static_cast<double>(info.dims[0] - 1);
        if (c & 2) v += d[3 * r + 1] * info.spacing[1] * static_cast<double>(info.dims[1] - 1);
        reachOf[r] = std::max(reachOf[r], std::isfinite(v) ? std::abs(v) : HUGE_VAL);
      }
    }
  }
  const double reach = std::max({reachOf[0], reachOf[1], reachOf[2]});
  constexpr double kFloatMax = std::numeric_limits<float>::max();
  if (!(reach <= kFloatMax)) {
    // The term that reaches farthest is the cause: the origin, or one axis's spacing.
    std::size_t axis = 0;
    for (std::size_t a = 1; a < 3; ++a) {
      if (!(extent[a] <= extent[axis])) axis = a;
    }
    if (originReach >= extent[axis]) {
      throw Error(
          fmt::format("{}: {} {:.6g},{:.6g},{:.6g} puts the volume beyond float32's range (the largest "
                      "float32 is {:.3g}): the mesh's coordinates would be infinite",
                      what, info.originField, info.origin[0], info.origin[1], info.origin[2], kFloatMax));
    }
    const std::string reached = std::isfinite(extent[axis]) ? fmt::format("{:.3g}", extent[axis]) : "beyond 1.8e+308";
    throw Error(
        fmt::format("{}: {} {:.6g} along axis {} puts the volume beyond float32's range: its {} points reach "
                    "{} (the largest float32 is {:.3g}), so the mesh's coordinates would be infinite",
                    what, info.spacingFields[axis], info.spacing[axis], axis, info.dims[axis], reached, kFloatMax));
  }
  // Neighbouring lattice points must stay apart in float32: along each axis, the step must span
  // at least one of float32's steps at the box's largest value of some coordinate that the step
  // changes. (Fewer than 16 leave a vertex between two lattice points few places to be, but
  // microscopy in micrometres at stage coordinates lives there and is meshed usefully.)
  constexpr double kSteps = 1;
  std::array<double, 3> resolution{};
  for (std::size_t r = 0; r < 3; ++r) {
    const auto top = static_cast<float>(std::max(reachOf[r], static_cast<double>(std::numeric_limits<float>::min())));
    resolution[r] =
        static_cast<double>(std::nextafter(top, std::numeric_limits<float>::infinity())) - static_cast<double>(top);
  }
  for (std::size_t a = 0; a < 3; ++a) {
    // The step along axis a as a vector; with per-slice origins, the shortest between slices.
    std::array<double, 3> step{};
    for (std::size_t r = 0; r < 3; ++r) step[r] = d[3 * r + a] * info.spacing[a];
    if (a == 2 && hasSliceOrigins) {
      double shortest = HUGE_VAL;
      for (std::size_t k = 1; k < info.sliceOrigins.size(); ++k) {
        const auto& p = info.sliceOrigins[k - 1];
        const auto& q = info.sliceOrigins[k];
        const std::array<double, 3> v{q[0] - p[0], q[1] - p[1], q[2] - p[2]};
        if (const double len = std::hypot(v[0], v[1], v[2]); len < shortest) {
          shortest = len;
          step = v;
        }
      }
    }
    double spans = 0;  // how many float32 steps the lattice step spans, in its best coordinate
    std::size_t best = 0;
    for (std::size_t r = 0; r < 3; ++r) {
      if (const double n = std::abs(step[r]) / resolution[r]; n > spans) {
        spans = n;
        best = r;
      }
    }
    if (!(spans >= kSteps)) {
      const std::string far = originReach >= 0.5 * reachOf[best]
                                  ? fmt::format(" ({} {:.6g},{:.6g},{:.6g} is far from 0)", info.originField,
                                                info.origin[0], info.origin[1], info.origin[2])
                                  : "";
      throw Error(fmt::format(
          "{}: {} gives a step of {:.6g} along axis {}, below float32's resolution at the "
          "volume's coordinates (which reach {:.3g}, where float32 steps by {:.3g}): neighbouring "
          "lattice points would coincide{}",
          what, info.spacingFields[a], std::hypot(step[0], step[1], step[2]), a, reachOf[best], resolution[best], far));
    }
  }
}

}  // namespace isoslab
