// Another source with one more lattice point on each side of every axis, holding NaN (outside for
// every method): the field taken as outside beyond the volume's faces, so that the surface closes
// there (--close-boundary; ExtractOptions::closeBoundary tells the kernel where the real volume
// is). Lattice point (i + 1, j + 1, k + 1) of the padded source is point (i, j, k) of the inner one,
// and the geometry keeps it where it was.
#pragma once

#include <limits>
#include <memory>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

class PadSource final : public SliceSource {
 public:
  /// `fill`: the padding's value (NaN; the label complex pads with 0, the background).
  explicit PadSource(std::unique_ptr<SliceSource> inner, float fill = std::numeric_limits<float>::quiet_NaN());
  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> slice) override;
  /// Fetches the inner source's next slice, also ahead of the first padding slice: the padding is
  /// handed out only once the inner data has begun.
  bool fetchSlice() override;
  std::vector<std::string> warnings() override { return inner_->warnings(); }

 private:
  std::unique_ptr<SliceSource> inner_;
  VolumeInfo info_;
  std::vector<float> inner_slice_;  // allocated once the inner source's first slice is fetched
  std::int64_t next_ = 0;           // padded slices handed out
  float fill_ = 0;
};

}  // namespace isoslab
