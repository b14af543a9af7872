#include "io/slice_source.h"

#include <fmt/format.h>

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
  slice.resize(static_cast<std::size_t>(source.info().sliceVoxels()));
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

}  // namespace isoslab
