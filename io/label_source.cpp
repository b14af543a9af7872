#include "io/label_source.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

#include "core/error.h"
#include "core/float_runs.h"

namespace isoslab {

LabelSource::LabelSource(std::unique_ptr<SliceSource> inner, std::string what,
                         std::optional<std::set<std::int32_t>> keep)
    : inner_(std::move(inner)), what_(std::move(what)), keep_(std::move(keep)), dense_(65536 + 32768) {
  if (keep_) {
    keepDense_ = ZeroedArray<std::uint8_t>(dense_.size());
    for (std::int32_t l : *keep_) {
      if (l >= kDenseLow && l - kDenseLow < static_cast<std::int32_t>(dense_.size())) {
        keepDense_[static_cast<std::size_t>(l - kDenseLow)] = 1;
      }
    }
  }
}

void LabelSource::count(std::int32_t label, std::int64_t n) {
  const std::int64_t k = std::int64_t{label} - kDenseLow;
  if (k >= 0 && k < static_cast<std::int64_t>(dense_.size())) {
    dense_[static_cast<std::size_t>(k)] += n;
    denseFirst_ = std::min(denseFirst_, static_cast<std::size_t>(k));
    denseEnd_ = std::max(denseEnd_, static_cast<std::size_t>(k) + 1);
  } else {
    sparse_[label] += n;
  }
}

bool LabelSource::readSlice(std::span<float> slice) {
  if (!inner_->readSlice(slice)) return false;
  const VolumeInfo& in = inner_->info();
  const std::int64_t nx = in.dims[0];
  const std::int64_t voxels = in.sliceVoxels();
  const bool counted = slice_ >= countFirst_ && slice_ < countEnd_;
  for (int layer = 0; layer < in.layers; ++layer) {
    const std::span<float> plane =
        slice.subspan(static_cast<std::size_t>(layer * voxels), static_cast<std::size_t>(voxels));
    // Runs of equal values: a run is checked, counted and selected once.
    std::int64_t i = 0;
    while (i < voxels) {
      const float v = plane[static_cast<std::size_t>(i)];
      const std::int64_t end = runEnd(plane.data(), i + 1, voxels, v);
      if (!(std::abs(v) <= kLargestLabel) || std::trunc(v) != v) {
        const bool large = std::abs(v) > kLargestLabel && std::isfinite(v);
        // A large value as read (a float), not as the file has it: 16777217 is read as 16777216.
        const std::string value =
            std::isnan(v) ? "NaN"
            : large       ? fmt::format("16777216 or more in magnitude (read as {:.0f})", static_cast<double>(v))
                          : fmt::format("{}", v);
        const std::string why = large ? "beyond the labels read exactly (whole numbers up to 16777215 in magnitude)"
                                      : "which is not a label (a label map holds whole numbers)";
        throw Error(fmt::format("{}: voxel ({}, {}, {}){} holds {}, {}; for a scalar volume give --iso", what_, i % nx,
                                i / nx, slice_, in.layers > 1 ? fmt::format(" of layer {}", layer) : std::string(),
                                value, why));
      }
      const std::int32_t label = layeredLabel(layer, static_cast<std::int32_t>(v));
      if (counted) count(label, end - i);
      if (keep_ && v != 0) {
        const std::int64_t k = std::int64_t{label} - kDenseLow;
        const bool kept = k >= 0 && k < static_cast<std::int64_t>(keepDense_.size())
                              ? keepDense_[static_cast<std::size_t>(k)] != 0
                              : keep_->count(label) != 0;
        if (!kept) std::fill(plane.begin() + i, plane.begin() + end, 0.0f);
      }
      i = end;
    }
  }
  ++slice_;
  return true;
}

std::int64_t LabelSource::skipSlices(std::int64_t n) {
  const std::int64_t skipped = inner_->skipSlices(n);
  slice_ += skipped;
  return skipped;
}

std::map<std::int32_t, std::int64_t> LabelSource::voxelCounts() const {
  std::map<std::int32_t, std::int64_t> counts = sparse_;
  for (std::size_t k = denseFirst_; k < denseEnd_; ++k) {
    if (dense_[k] != 0) counts[static_cast<std::int32_t>(k) + kDenseLow] += dense_[k];
  }
  return counts;
}

std::string LabelSource::countsText() const {
  std::string text;
  for (const auto& [label, n] : voxelCounts()) text += fmt::format("{} {}\n", label, n);
  return text;
}

void LabelSource::addCounts(const std::string& text) {
  std::istringstream in(text);
  std::int64_t label = 0;
  std::int64_t n = 0;
  while (in >> label >> n) {
    if (label < -static_cast<std::int64_t>(kLargestLabel) ||
        label > layeredLabel(kMaxLayers - 1, static_cast<std::int32_t>(kLargestLabel)) || n < 0) {
      throw Error(what_ + ": a rank's label counts are damaged");
    }
    count(static_cast<std::int32_t>(label), n);
  }
}

}  // namespace isoslab
