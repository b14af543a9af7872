// A box cut out of another source: lattice points lo .. hi - 1 on each axis, with the geometry
// that keeps them where they were (the origin moves by the cut, per-slice origins too).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

class CropSource final : public SliceSource {
 public:
  /// Throws isoslab::Error when the box is empty, smaller than 2 points on an axis, or outside
  /// the source's dims.
  CropSource(std::unique_ptr<SliceSource> inner, const std::array<std::int64_t, 3>& lo,
             const std::array<std::int64_t, 3>& hi);
  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> slice) override;
  std::vector<std::string> warnings() override { return inner_->warnings(); }

 private:
  std::unique_ptr<SliceSource> inner_;
  std::array<std::int64_t, 3> lo_;
  VolumeInfo info_;
  std::vector<float> full_;
  std::int64_t next_ = 0;  // slices of the inner source read so far
};

}  // namespace isoslab
