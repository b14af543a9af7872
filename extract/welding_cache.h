// The welding caches: the vertex id of every lattice edge that the current slab has cut, in three
// anchor planes (0: slice z, 1: the cube-centre plane z + 1/2, 2: slice z + 1), indexed by slot
// (EdgeRef::slot). Each plane remembers which slots it set, so that clearing costs what the slab
// used, not the plane's size. Rolling makes slice z + 1's plane the next slab's slice z.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

class WeldingCache {
 public:
  static constexpr VertexId kNone = std::numeric_limits<VertexId>::max();

  /// Sizes the planes: sliceClasses slots per lattice point on planes 0 and 2, centreClasses on 1.
  /// The planes hold id + 1, so that 0 means unset and they can come zeroed from calloc: the
  /// system then maps a page only when a slot in it is first set, and a plane the surface barely
  /// crosses costs next to nothing (a memset of every plane would fault in all their pages).
  void allocate(std::size_t sliceClasses, std::size_t centreClasses, std::int64_t planeSize) {
    const auto points = static_cast<std::size_t>(planeSize);
    const std::array<std::size_t, 3> sizes{sliceClasses * points, centreClasses * points, sliceClasses * points};
    for (std::size_t p = 0; p < 3; ++p) {
      planes_[p].reset(static_cast<VertexId*>(std::calloc(std::max<std::size_t>(1, sizes[p]), sizeof(VertexId))));
      if (!planes_[p]) throw std::bad_alloc();
    }
    allocated_ = true;
  }
  bool allocated() const noexcept { return allocated_; }

  /// The id in `slot` of `plane` (kNone when unset).
  VertexId get(int plane, std::int64_t slot) const noexcept { return at(plane, slot) - 1; }
  /// Sets `slot` of `plane` to `id` (not kNone); touch() records it for clear().
  void set(int plane, std::int64_t slot, VertexId id) noexcept { at(plane, slot) = id + 1; }
  /// Records that `slot` of `plane` was set, for clear().
  void touch(int plane, std::int64_t slot) { touched_[static_cast<std::size_t>(plane)].push_back(slot); }
  const std::vector<std::int64_t>& touched(int plane) const noexcept {
    return touched_[static_cast<std::size_t>(plane)];
  }

  void clear(int plane) noexcept {
    auto& touched = touched_[static_cast<std::size_t>(plane)];
    for (std::int64_t slot : touched) at(plane, slot) = 0;
    touched.clear();
  }
  void clearAll() noexcept {
    for (int p = 0; p < 3; ++p) clear(p);
  }
  /// After slab z: slice z + 1's ids become slice z's of slab z + 1.
  void roll() noexcept {
    clear(0);
    std::swap(planes_[0], planes_[2]);
    std::swap(touched_[0], touched_[2]);
    clear(1);
  }

 private:
  struct Free {
    void operator()(VertexId* p) const noexcept { std::free(p); }
  };
  VertexId& at(int plane, std::int64_t slot) const noexcept {
    return planes_[static_cast<std::size_t>(plane)][static_cast<std::size_t>(slot)];
  }

  std::array<std::unique_ptr<VertexId[], Free>, 3> planes_;
  std::array<std::vector<std::int64_t>, 3> touched_;
  bool allocated_ = false;
};

}  // namespace isoslab
