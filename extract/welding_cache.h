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

/// Vertex ids by slot, all unset at first. It comes zeroed from calloc and holds id + 1 (0:
/// unset), so the system maps a page only when a slot in it is first set: an array that a surface
/// barely crosses costs next to nothing (filling it with a marker would map every page).
class ZeroedIds {
 public:
  static constexpr VertexId kUnset = std::numeric_limits<VertexId>::max();

  ZeroedIds() = default;
  explicit ZeroedIds(std::size_t n)
      : ids_(static_cast<VertexId*>(std::calloc(std::max<std::size_t>(1, n), sizeof(VertexId)))) {
    if (!ids_) throw std::bad_alloc();
  }
  /// The id in `slot`, kUnset when unset.
  VertexId get(std::size_t slot) const noexcept { return ids_[slot] - 1; }
  /// Sets `slot` to `id` (not kUnset).
  void set(std::size_t slot, VertexId id) noexcept { ids_[slot] = id + 1; }
  void unset(std::size_t slot) noexcept { ids_[slot] = 0; }
  /// Asks the processor's cache for slots [first, end) (a hint only: no fault, no effect on ids).
  void prefetch(std::size_t first, std::size_t end) const noexcept {
    constexpr std::size_t kLine = 64 / sizeof(VertexId);
    for (std::size_t k = first; k < end; k += kLine) __builtin_prefetch(ids_.get() + k);
    if (first < end) __builtin_prefetch(ids_.get() + end - 1);
  }

 private:
  struct Free {
    void operator()(VertexId* p) const noexcept { std::free(p); }
  };
  std::unique_ptr<VertexId[], Free> ids_;
};

class WeldingCache {
 public:
  static constexpr VertexId kNone = ZeroedIds::kUnset;

  /// Sizes the planes: sliceClasses slots per lattice point on planes 0 and 2, centreClasses on 1
  /// (mapped as they are used: ZeroedIds).
  void allocate(std::size_t sliceClasses, std::size_t centreClasses, std::int64_t planeSize) {
    const auto points = static_cast<std::size_t>(planeSize);
    planes_ = {ZeroedIds(sliceClasses * points), ZeroedIds(centreClasses * points), ZeroedIds(sliceClasses * points)};
    allocated_ = true;
  }
  bool allocated() const noexcept { return allocated_; }

  /// The id in `slot` of `plane` (kNone when unset).
  VertexId get(int plane, std::int64_t slot) const noexcept { return planeOf(plane).get(index(slot)); }
  /// Sets `slot` of `plane` to `id` (not kNone); touch() records it for clear().
  void set(int plane, std::int64_t slot, VertexId id) noexcept { planeOf(plane).set(index(slot), id); }
  /// Asks the processor's cache for slots [first, end) of `plane`, to be read soon (a hint only).
  void prefetch(int plane, std::int64_t first, std::int64_t end) const noexcept {
    planeOf(plane).prefetch(index(first), index(end));
  }
  /// Records that `slot` of `plane` was set, for clear().
  void touch(int plane, std::int64_t slot) { touched_[static_cast<std::size_t>(plane)].push_back(slot); }
  const std::vector<std::int64_t>& touched(int plane) const noexcept {
    return touched_[static_cast<std::size_t>(plane)];
  }

  void clear(int plane) noexcept {
    auto& touched = touched_[static_cast<std::size_t>(plane)];
    for (std::int64_t slot : touched) planeOf(plane).unset(index(slot));
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
  static std::size_t index(std::int64_t slot) noexcept { return static_cast<std::size_t>(slot); }
  ZeroedIds& planeOf(int plane) noexcept { return planes_[static_cast<std::size_t>(plane)]; }
  const ZeroedIds& planeOf(int plane) const noexcept { return planes_[static_cast<std::size_t>(plane)]; }

  std::array<ZeroedIds, 3> planes_;
  std::array<std::vector<std::int64_t>, 3> touched_;
  bool allocated_ = false;
};

}  // namespace isoslab
