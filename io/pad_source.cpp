#include "io/pad_source.h"

#include <fmt/format.h>

#include <algorithm>
#include <limits>

#include "core/error.h"

namespace isoslab {

PadSource::PadSource(std::unique_ptr<SliceSource> inner, float fill)
    : inner_(std::move(inner)), info_(inner_->info()), fill_(fill) {
  const VolumeInfo& in = inner_->info();
  for (std::size_t a = 0; a < 3; ++a) info_.dims[a] = in.dims[a] + 2;
  validateDims(info_.dims, in.source);
  // One step back along each axis; per-slice origins extend by their end steps.
  for (std::size_t r = 0; r < 3; ++r) {
    for (std::size_t c = 0; c < 3; ++c) info_.origin[r] -= in.direction[3 * r + c] * in.spacing[c];
  }
  if (!in.sliceOrigins.empty()) {
    const auto& o = in.sliceOrigins;
    const std::size_t n = o.size();
    auto shifted = [&](const std::array<double, 3>& p, const std::array<double, 3>& step) {
      std::array<double, 3> q{};
      for (std::size_t r = 0; r < 3; ++r) {
        q[r] = p[r] - in.direction[3 * r] * in.spacing[0] - in.direction[3 * r + 1] * in.spacing[1] + step[r];
      }
      return q;
    };
    auto delta = [](const std::array<double, 3>& a, const std::array<double, 3>& b) {
      return std::array<double, 3>{a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    };
    info_.sliceOrigins.clear();
    const auto firstStep = n > 1 ? delta(o[0], o[1]) : std::array<double, 3>{};
    const auto lastStep = n > 1 ? delta(o[n - 1], o[n - 2]) : std::array<double, 3>{};
    info_.sliceOrigins.push_back(shifted(o[0], firstStep));
    for (const auto& p : o) info_.sliceOrigins.push_back(shifted(p, {0, 0, 0}));
    info_.sliceOrigins.push_back(shifted(o[n - 1], lastStep));
  }
  info_.sphere.reset();
}

bool PadSource::fetchSlice() {
  if (next_ >= info_.dims[2]) return false;
  return next_ == info_.dims[2] - 1 || inner_->fetchSlice();
}

bool PadSource::readSlice(std::span<float> slice) {
  if (next_ >= info_.dims[2]) return false;
  const bool padSlice = next_ == 0 || next_ == info_.dims[2] - 1;
  if (padSlice) {
    std::fill(slice.begin(), slice.end(), fill_);
  } else {
    if (!readSliceInto(*inner_, inner_slice_)) return false;
    const std::int64_t nx = info_.dims[0];
    const std::int64_t ny = info_.dims[1];
    const std::int64_t innerNx = nx - 2;
    for (std::int64_t layer = 0; layer < info_.layers; ++layer) {  // each plane padded on its own
      const auto from = inner_slice_.begin() + layer * innerNx * (ny - 2);
      const auto to = slice.begin() + layer * info_.sliceVoxels();
      std::fill_n(to, nx, fill_);  // the first and last rows, and each row's ends
      std::fill_n(to + (ny - 1) * nx, nx, fill_);
      for (std::int64_t j = 1; j + 1 < ny; ++j) {
        to[j * nx] = fill_;
        std::copy_n(from + (j - 1) * innerNx, innerNx, to + j * nx + 1);
        to[j * nx + nx - 1] = fill_;
      }
    }
  }
  ++next_;
  return true;
}

}  // namespace isoslab
