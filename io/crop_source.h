// A box cut out of another source (isoslab extract --roi): the lattice points of a LatticeBox, with
// the geometry that keeps them where they were (the origin moves by the cut, per-slice origins
// too), so that physical coordinates are the source's own. Lattice indices start again at 0 at the
// box's lower corner, as in a cropped copy of the volume.
//
// Only the box's slices are taken from the source: the slices before it are skipped with
// SliceSource::skipSlices() (readers that can seek neither read nor decode them), and the slices
// after it are never asked for. Only the box's rows and columns are copied out of each slice.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

/// `box`, a request in lattice indices of a volume of `dims`, clipped to the lattice. Throws
/// isoslab::Error "WHAT: ..." naming `what` (the input), the box and the lattice when the box
/// holds no lattice point or fewer than 2 on an axis once clipped (a surface needs a cell).
/// `clipped` (when given) is set to whether clipping took points away.
LatticeBox clipLatticeBox(const LatticeBox& box, const std::array<std::int64_t, 3>& dims, const std::string& what,
                          bool* clipped = nullptr);

/// "i0,j0,k0,i1,j1,k1", as --roi takes a box.
std::string latticeBoxText(const LatticeBox& box);

class CropSource final : public SliceSource {
 public:
  /// Throws isoslab::Error when `box` does not lie inside the source's lattice or has fewer than 2
  /// points on an axis (clipLatticeBox() makes any box fit or says why it cannot).
  CropSource(std::unique_ptr<SliceSource> inner, const LatticeBox& box);
  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> slice) override;
  bool fetchSlice() override;
  std::int64_t skipSlices(std::int64_t n) override;
  /// The inner source's warnings. Its slices past the box are never read, so warnings that need
  /// the end of the data (the bytes left over in a compressed stream) are not found.
  std::vector<std::string> warnings() override { return inner_->warnings(); }

  const LatticeBox& box() const noexcept { return box_; }

 private:
  /// Brings the inner source to the box's first slice (once).
  void reachBox();

  std::unique_ptr<SliceSource> inner_;
  LatticeBox box_;
  VolumeInfo info_;
  std::vector<float> full_;  // the inner source's slice, allocated once its first slice is fetched
  std::int64_t next_ = 0;    // the inner source's next slice
};

}  // namespace isoslab
