// What the extractors consume: one slab of cells, as the slices around it and their row spans.
// The extractor defines these types; stream/ fills them (stream/slab_ring.h).
#pragma once

#include <array>
#include <cstdint>

namespace isoslab {

/// Where one row of voxels changes between inside and outside: the first and last index i >= 1
/// whose state differs from voxel i - 1 (-1 when the row is uniform), and the states at both ends.
/// An extractor derives one per row of a slice (Extractor::classifySlice) to skip uniform spans.
struct RowSpan {
  std::int64_t first = -1;
  std::int64_t last = -1;
  bool left = false;
  bool right = false;
};

/// The slab of cells between slices z and z + 1, as an extractor sees it.
struct SlabView {
  std::int64_t z = 0;
  std::array<std::int64_t, 3> dims{};
  /// Slices z-1, z, z+1, z+2; nullptr where outside the volume or not requested.
  std::array<const float*, 4> slices{};
  /// Their row spans where already classified (by the extractor's classifySlice), else nullptr.
  std::array<const RowSpan*, 4> rows{};
};

}  // namespace isoslab
