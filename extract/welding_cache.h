// The welding caches: the vertex id of every lattice edge that the current slab has cut, in three
// anchor planes (0: slice z, 1: the cube-centre plane z + 1/2, 2: slice z + 1), indexed by slot
// (EdgeRef::slot). Each plane remembers which slots it set, so that clearing costs what the slab
// used, not the plane's size. Rolling makes slice z + 1's plane the next slab's slice z.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

class WeldingCache {
 public:
  static constexpr VertexId kNone = std::numeric_limits<VertexId>::max();

  /// Sizes the planes: sliceClasses slots per lattice point on planes 0 and 2, centreClasses on 1.
  void allocate(std::size_t sliceClasses, std::size_t centreClasses, std::int64_t planeSize) {
    const auto points = static_cast<std::size_t>(planeSize);
    planes_[0].assign(sliceClasses * points, kNone);
    planes_[1].assign(centreClasses * points, kNone);
    planes_[2].assign(sliceClasses * points, kNone);
    allocated_ = true;
  }
  bool allocated() const noexcept { return allocated_; }

  /// The id in `slot` of `plane` (kNone when unset).
  VertexId& id(int plane, std::int64_t slot) noexcept {
    return planes_[static_cast<std::size_t>(plane)][static_cast<std::size_t>(slot)];
  }
  /// Records that `slot` of `plane` was set, for clear().
  void touch(int plane, std::int64_t slot) { touched_[static_cast<std::size_t>(plane)].push_back(slot); }
  const std::vector<std::int64_t>& touched(int plane) const noexcept {
    return touched_[static_cast<std::size_t>(plane)];
  }

  void clear(int plane) noexcept {
    auto& ids = planes_[static_cast<std::size_t>(plane)];
    auto& touched = touched_[static_cast<std::size_t>(plane)];
    for (std::int64_t slot : touched) ids[static_cast<std::size_t>(slot)] = kNone;
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
  std::array<std::vector<VertexId>, 3> planes_;
  std::array<std::vector<std::int64_t>, 3> touched_;
  bool allocated_ = false;
};

}  // namespace isoslab
