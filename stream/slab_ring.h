// The slab ring: the few consecutive slices that the current slab of cells needs, and nothing more.
//
// A slab z is the layer of cells between slices z and z+1. Extractors read slices z and z+1, and,
// for central-difference gradients or the next slab's BCC cube centres, slices z-1 and z+2: at most
// four slices, so memory depends on the slice size and never on the number of slices. Values
// derived per slab (such as BCC cube-centre values) are held by the extractor that derives them,
// two slabs deep.
//
// Contract: acquire(k) hands out the slot for slice k and evicts slice k - capacity (adopt(k, v)
// does the same with a buffer filled elsewhere, and hands back the evicted one). A pointer returned
// by slice(k) stays valid until slice k is evicted, i.e. until acquire(k + capacity). Slices must
// be acquired in increasing order. Not thread-safe.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <span>
#include <vector>

#include "extract/slab_view.h"

namespace isoslab {

/// A slice's values: owned, or lent by the source.
struct SliceBuffer {
  std::vector<float> values;
  const float* lent = nullptr;  // the values when a source lends them (values is then unused)

  const float* data() const noexcept { return lent != nullptr ? lent : values.data(); }
};

class SlabRing {
 public:
  SlabRing(std::int64_t sliceVoxels, int capacity)
      : sliceVoxels_(static_cast<std::size_t>(sliceVoxels)),
        capacity_(capacity),
        storage_(static_cast<std::size_t>(capacity)),  // allocated on first use: lent slices need none
        resident_(static_cast<std::size_t>(capacity), -1) {
    assert(capacity >= 2);
  }

  int capacity() const noexcept { return capacity_; }

  /// The slot to fill with slice k. Evicts slice k - capacity().
  std::span<float> acquire(std::int64_t k) {
    SliceBuffer& b = claim(k);
    b.values.resize(sliceVoxels_);
    return b.values;
  }

  /// Makes `values`, lent by the source, slice k (evicting slice k - capacity()).
  void lend(std::int64_t k, const float* values) { claim(k).lent = values; }

  /// Makes `filled` (one slice's values) slice k, evicting slice k - capacity(), whose buffer is
  /// returned for reuse.
  SliceBuffer adopt(std::int64_t k, SliceBuffer filled) {
    assert(filled.lent != nullptr || filled.values.size() == sliceVoxels_);
    std::swap(claim(k), filled);
    return filled;
  }

  /// Slice k, or nullptr if it is not resident.
  const float* slice(std::int64_t k) const noexcept {
    if (k < 0) return nullptr;
    const std::size_t slot = slotOf(k);
    return resident_[slot] == k ? storage_[slot].data() : nullptr;
  }

  /// Bytes of slice storage, once every slot holds a slice of its own.
  std::size_t bytes() const noexcept { return storage_.size() * sliceVoxels_ * sizeof(float); }

 private:
  SliceBuffer& claim(std::int64_t k) {
    assert(k > newest_);
    newest_ = k;
    const std::size_t slot = slotOf(k);
    resident_[slot] = k;
    storage_[slot].lent = nullptr;
    return storage_[slot];
  }

  std::size_t slotOf(std::int64_t k) const noexcept { return static_cast<std::size_t>(k % capacity_); }

  std::size_t sliceVoxels_;
  int capacity_;
  std::vector<SliceBuffer> storage_;
  std::vector<std::int64_t> resident_;
  std::int64_t newest_ = -1;
};

}  // namespace isoslab
