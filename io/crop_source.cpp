#include "io/crop_source.h"

#include <fmt/format.h>

#include <algorithm>

#include "core/error.h"

namespace isoslab {

std::string latticeBoxText(const LatticeBox& box) {
  return fmt::format("{},{},{},{},{},{}", box.lo[0], box.lo[1], box.lo[2], box.hi[0], box.hi[1], box.hi[2]);
}

LatticeBox clipLatticeBox(const LatticeBox& box, const std::array<std::int64_t, 3>& dims, const std::string& what,
                          bool* clipped) {
  const std::string lattice = fmt::format("the volume's {}x{}x{} lattice points (indices 0..{}, 0..{}, 0..{})", dims[0],
                                          dims[1], dims[2], dims[0] - 1, dims[1] - 1, dims[2] - 1);
  LatticeBox out;
  static constexpr const char* kAxis[3] = {"i", "j", "k"};
  for (std::size_t a = 0; a < 3; ++a) {
    if (box.hi[a] < box.lo[a]) {
      throw Error(fmt::format("{}: `roi` {} is empty: {}1 {} is below {}0 {}", what, latticeBoxText(box), kAxis[a],
                              box.hi[a], kAxis[a], box.lo[a]));
    }
    if (box.hi[a] < 0 || box.lo[a] > dims[a] - 1) {
      throw Error(fmt::format("{}: `roi` {} lies outside {}", what, latticeBoxText(box), lattice));
    }
  }
  for (std::size_t a = 0; a < 3; ++a) {
    out.lo[a] = std::max<std::int64_t>(box.lo[a], 0);
    out.hi[a] = std::min<std::int64_t>(box.hi[a], dims[a] - 1);
  }
  for (std::size_t a = 0; a < 3; ++a) {
    if (out.hi[a] - out.lo[a] < 1) {
      const std::string inside = out == box ? std::string() : fmt::format(" (clipped to {})", latticeBoxText(out));
      throw Error(
          fmt::format("{}: `roi` {}{} holds {} lattice point along {}; a surface needs at least 2 on every "
                      "axis of {}",
                      what, latticeBoxText(box), inside, out.hi[a] - out.lo[a] + 1, kAxis[a], lattice));
    }
  }
  if (clipped != nullptr) *clipped = !(out == box);
  return out;
}

CropSource::CropSource(std::unique_ptr<SliceSource> inner, const LatticeBox& box)
    : inner_(std::move(inner)), box_(box), info_(inner_->info()) {
  const VolumeInfo& in = inner_->info();
  for (std::size_t a = 0; a < 3; ++a) {
    if (box.lo[a] < 0 || box.hi[a] >= in.dims[a] || box.hi[a] - box.lo[a] < 1) {
      throw Error(fmt::format("{}: the box {}..{} on axis {} does not fit {} points with 2 or more inside", in.source,
                              box.lo[a], box.hi[a], a, in.dims[a]));
    }
  }
  info_.dims = box.dims();
  // Lattice point (i, j, k) of the box is point (i + lo0, j + lo1, k + lo2) of the source.
  auto shift = [&](std::array<double, 3> origin, bool alongK) {
    for (std::size_t r = 0; r < 3; ++r) {
      for (std::size_t c = 0; c < (alongK ? 3u : 2u); ++c) {
        origin[r] += in.direction[3 * r + c] * in.spacing[c] * static_cast<double>(box.lo[c]);
      }
    }
    return origin;
  };
  info_.origin = shift(in.origin, true);
  info_.sliceOrigins.clear();
  if (!in.sliceOrigins.empty()) {
    for (std::int64_t k = box.lo[2]; k <= box.hi[2]; ++k)
      info_.sliceOrigins.push_back(shift(in.sliceOrigins[static_cast<std::size_t>(k)], false));
  }
  // The sphere is in the source's lattice coordinates, and the value range may lie outside the box.
  info_.sphere.reset();
  info_.valueRange.reset();
}

void CropSource::reachBox() {
  if (next_ >= box_.lo[2]) return;
  // The slices below the box: skipped, without reading where the inner source can seek.
  next_ += inner_->skipSlices(box_.lo[2] - next_);
  if (next_ < box_.lo[2]) {
    throw Error(fmt::format("{}: the data ends after {} slices, before the box's first slice {}", inner_->info().source,
                            next_, box_.lo[2]));
  }
}

bool CropSource::readSlice(std::span<float> slice) {
  reachBox();
  // The slices above the box are never read.
  if (next_ > box_.hi[2]) return false;
  if (!readSliceInto(*inner_, full_)) return false;
  ++next_;
  const VolumeInfo& in = inner_->info();
  const auto nx = static_cast<std::size_t>(info_.dims[0]);
  for (std::int64_t layer = 0; layer < info_.layers; ++layer) {  // each plane cropped on its own
    for (std::int64_t j = 0; j < info_.dims[1]; ++j) {
      const auto from = full_.begin() + static_cast<std::ptrdiff_t>(layer * in.sliceVoxels() +
                                                                    (j + box_.lo[1]) * in.dims[0] + box_.lo[0]);
      std::copy(from, from + static_cast<std::ptrdiff_t>(nx),
                slice.begin() + static_cast<std::ptrdiff_t>((layer * info_.dims[1] + j) * info_.dims[0]));
    }
  }
  return true;
}

bool CropSource::fetchSlice() {
  reachBox();
  return next_ <= box_.hi[2] && inner_->fetchSlice();
}

std::int64_t CropSource::skipSlices(std::int64_t n) {
  reachBox();
  const std::int64_t want = std::min(n, box_.hi[2] + 1 - next_);
  if (want <= 0) return 0;
  const std::int64_t skipped = inner_->skipSlices(want);
  next_ += skipped;
  return skipped;
}

}  // namespace isoslab
