#include "io/crop_source.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/error.h"

namespace isoslab {

CropSource::CropSource(std::unique_ptr<SliceSource> inner, const std::array<std::int64_t, 3>& lo,
                       const std::array<std::int64_t, 3>& hi)
    : inner_(std::move(inner)), lo_(lo), info_(inner_->info()) {
  const VolumeInfo& in = inner_->info();
  for (std::size_t a = 0; a < 3; ++a) {
    if (lo[a] < 0 || hi[a] > in.dims[a] || hi[a] - lo[a] < 2) {
      throw Error(fmt::format("{}: the box {}..{} on axis {} does not fit {} points with 2 or more inside", in.source,
                              lo[a], hi[a], a, in.dims[a]));
    }
    info_.dims[a] = hi[a] - lo[a];
  }
  // Lattice point (i, j, k) of the box is point (i + lo0, j + lo1, k + lo2) of the source.
  auto shift = [&](std::array<double, 3> origin, bool alongK) {
    for (std::size_t r = 0; r < 3; ++r) {
      for (std::size_t c = 0; c < (alongK ? 3u : 2u); ++c) {
        origin[r] += in.direction[3 * r + c] * in.spacing[c] * static_cast<double>(lo[c]);
      }
    }
    return origin;
  };
  info_.origin = shift(in.origin, true);
  info_.sliceOrigins.clear();
  if (!in.sliceOrigins.empty()) {
    for (std::int64_t k = lo[2]; k < hi[2]; ++k)
      info_.sliceOrigins.push_back(shift(in.sliceOrigins[static_cast<std::size_t>(k)], false));
  }
  info_.sphere.reset();
  info_.valueRange.reset();
  full_.resize(static_cast<std::size_t>(in.sliceVoxels()));
}

bool CropSource::readSlice(std::span<float> slice) {
  const VolumeInfo& in = inner_->info();
  if (next_ >= lo_[2] + info_.dims[2]) return false;
  // The slices below the box are read and dropped.
  do {
    if (!inner_->readSlice(full_)) return false;
    ++next_;
  } while (next_ <= lo_[2]);
  const auto nx = static_cast<std::size_t>(info_.dims[0]);
  for (std::int64_t j = 0; j < info_.dims[1]; ++j) {
    const auto from = full_.begin() + static_cast<std::ptrdiff_t>((j + lo_[1]) * in.dims[0] + lo_[0]);
    std::copy(from, from + static_cast<std::ptrdiff_t>(nx),
              slice.begin() + static_cast<std::ptrdiff_t>(j) * static_cast<std::ptrdiff_t>(nx));
  }
  return true;
}

}  // namespace isoslab
