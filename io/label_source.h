// A label volume read through another source: every value checked to be a whole number (a label),
// the labels not selected set to the background (0), and each label's voxels counted as the
// slices stream past (the volume is never held).
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/zeroed_array.h"
#include "io/slice_source.h"

namespace isoslab {

class LabelSource final : public SliceSource {
 public:
  /// `what` names the input in messages. `keep`: the labels to keep, all others become 0; empty
  /// optional: keep every label. In a layered source (VolumeInfo::layers) labels are counted and
  /// kept by their layeredLabel().
  LabelSource(std::unique_ptr<SliceSource> inner, std::string what, std::optional<std::set<std::int32_t>> keep);

  const VolumeInfo& info() const noexcept override { return inner_->info(); }
  /// Reads the inner slice, then checks and counts it. Throws isoslab::Error "WHAT: voxel (i, j, k)
  /// holds V, which is not a label ..." at the first value that is not a whole number within
  /// ±kLargestLabel (NaN and infinities included).
  bool readSlice(std::span<float> slice) override;
  bool fetchSlice() override { return inner_->fetchSlice(); }
  std::int64_t skipSlices(std::int64_t n) override;
  std::vector<std::string> warnings() override { return inner_->warnings(); }

  /// Voxels per label over the slices read so far, before selection (the background included).
  std::map<std::int32_t, std::int64_t> voxelCounts() const;
  /// Counts only slices first .. end - 1 (a rank's own, where ranks read a slice beyond their
  /// range); every slice read is still checked.
  void countOnly(std::int64_t first, std::int64_t end) noexcept {
    countFirst_ = first;
    countEnd_ = end;
  }
  /// voxelCounts() as text ("label count" pairs), and those of another LabelSource added in.
  std::string countsText() const;
  void addCounts(const std::string& text);

 private:
  void count(std::int32_t label, std::int64_t n);

  std::unique_ptr<SliceSource> inner_;
  std::string what_;
  std::optional<std::set<std::int32_t>> keep_;
  std::int64_t slice_ = 0;
  std::int64_t countFirst_ = 0;
  std::int64_t countEnd_ = std::numeric_limits<std::int64_t>::max();
  // Counts of labels -32768 .. 65535 (every 8- and 16-bit label) by index, the rest in a map.
  static constexpr std::int32_t kDenseLow = -32768;
  ZeroedArray<std::int64_t> dense_;                   // pages only where labels are counted
  std::size_t denseFirst_ = SIZE_MAX, denseEnd_ = 0;  // the entries counted lie in [first, end)
  std::map<std::int32_t, std::int64_t> sparse_;
  ZeroedArray<std::uint8_t> keepDense_;  // per dense label: 1 kept
};

}  // namespace isoslab
