// Keeping some connected components of a streamed mesh and dropping the rest, in two passes over
// the same (deterministic) stream:
//
// 1. a ComponentSink measures every component and numbers the parts that the stream grows
//    (ComponentSink::partComponents); selectComponents() picks the kept components by the rules;
// 2. the extraction runs again into a ComponentFilterSink, which runs the same union-find, so its
//    parts get the same serials, and forwards only the kept components' vertices and triangles,
//    renumbered densely in stream order.
//
// Memory: the second pass holds one chunk back (its vertices' components are known only once the
// next chunk, the last that may use them, has been seen), plus a bit per part of the first pass.
// Neither grows with the mesh beyond the parts count, which follows the components and their
// shapes (a part starts where a triangle touches no earlier one).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh_sink.h"
#include "metrics/components.h"

namespace isoslab {

enum class ComponentMeasure { kTriangles, kVolume };

/// Which components to keep. Every rule given applies: first the thresholds, then the seed, then
/// the N largest of what remains.
struct ComponentRules {
  /// Keep the N largest by `measure` (ties go to the lower id); in a stream of several surfaces
  /// (Component::label), the N largest of each.
  std::optional<std::uint64_t> keepLargest;
  ComponentMeasure measure = ComponentMeasure::kTriangles;
  /// Keep those with at least this many triangles.
  std::optional<std::uint64_t> minTriangles;
  /// Keep those enclosing at least this volume (|volume|, output units cubed; meaningful for
  /// closed components).
  std::optional<double> minVolume;
  /// Keep the component whose nearest vertex is nearest to this point (output coordinates).
  std::optional<Vec3f> seed;
  /// The seed must lie within some component's bounds grown by this much, else it is an error.
  double seedReach = 0;

  bool any() const noexcept { return keepLargest || minTriangles || minVolume || seed; }
  /// The rules as options, for messages and reports: "--keep-largest 1 --min-volume 5".
  std::string text() const;
};

/// Per component id, whether the rules keep it. Throws isoslab::Error when a seed lies outside
/// every component (grown by seedReach), naming the seed.
std::vector<bool> selectComponents(const std::vector<Component>& components, const ComponentRules& rules);

/// Per part serial of the first pass, whether its component is kept.
std::vector<bool> keptParts(const ComponentSink& firstPass, const std::vector<bool>& keptComponents);

/// Forwards to `next` only the vertices and triangles of kept parts, renumbered densely in stream
/// order; each chunk leaves one chunk late (and the last at finish()). The header goes on without
/// cellVolumes (the slab volumes were the whole surface's). Throws isoslab::Error when the stream
/// is not the first pass's (it has parts that the first pass did not).
class ComponentFilterSink final : public MeshSink {
 public:
  ComponentFilterSink(MeshSink& next, std::vector<bool> keepPart);

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  std::uint64_t keptTriangles() const noexcept { return keptTriangles_; }
  std::uint64_t droppedTriangles() const noexcept { return droppedTriangles_; }

 private:
  static constexpr VertexId kDropped = 0xffffffffu;

  void emitHeld();

  MeshSink& next_;
  std::vector<bool> keepPart_;
  ComponentSink parts_;
  bool holding_ = false;
  MeshChunk held_, out_;
  // New ids of the held chunk's vertices and of the chunk before it (kDropped when dropped).
  std::vector<VertexId> heldIds_, previousIds_;
  VertexId previousFirst_ = 0;
  VertexId nextId_ = 0;
  std::uint64_t keptTriangles_ = 0, droppedTriangles_ = 0;
};

}  // namespace isoslab
