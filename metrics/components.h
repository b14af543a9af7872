// A sink that finds the connected components of the mesh streaming past (triangles joined through
// shared vertices) and measures each one, with memory that follows the live front of the stream
// and the number of components, never the mesh.
//
// Union-find runs over the front only: the vertices of the last two chunks, since a triangle uses
// only vertices of its own chunk and the one before (core/mesh_sink.h). Each root of the front
// that some triangle uses owns a component record. After a chunk, a component none of whose
// vertices lies in that chunk can grow no more: its edges have all been settled (EdgeTally), so
// it is final, and its record moves to the finished list. The front then drops the older chunk.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "core/mesh_sink.h"
#include "metrics/chunk_front.h"
#include "metrics/edge_tally.h"

namespace isoslab {

struct Component {
  /// The component's number: its rank by firstVertex, so the same for every thread count and for
  /// any split of the stream into chunks (`isoslab metrics` of a written PLY gives the same ids).
  std::uint64_t id = 0;
  /// The smallest vertex id that a triangle of the component uses.
  VertexId firstVertex = 0;
  /// In a stream of several surfaces (several iso values in one pass: MeshChunk::faceLabels), the
  /// surface of its triangles (their back side's label); 0 for a single surface.
  std::int32_t label = 0;
  std::uint64_t triangles = 0;
  double area = 0;
  /// Enclosed volume by the divergence theorem, signed as MeshStats::volume.
  double volume = 0;
  /// xmin ymin zmin xmax ymax zmax of its triangles' vertices.
  std::array<double, 6> bounds{};
  /// Its edges used by one triangle, those of them not on a face of the volume, and those used by
  /// more than two (as in MeshStats).
  std::uint64_t boundaryEdges = 0;
  std::uint64_t interiorBoundaryEdges = 0;
  std::uint64_t nonManifoldEdges = 0;
  /// The distance from the seed point (ComponentSink::setSeed) to its nearest vertex; +inf without
  /// a seed.
  double seedDistance = std::numeric_limits<double>::infinity();

  bool closed() const noexcept { return boundaryEdges == 0 && nonManifoldEdges == 0; }
  friend bool operator==(const Component&, const Component&) = default;
};

/// What a report says of the components: how many, how many are closed, and the largest few by
/// triangle count (ties by id), each with its id.
struct ComponentSummary {
  std::uint64_t count = 0;
  std::uint64_t closed = 0;
  std::vector<Component> largest;
};

class ComponentSink final : public MeshSink {
 public:
  /// No part: a vertex that no triangle uses.
  static constexpr std::uint32_t kNoPart = 0xffffffffu;

  /// Measures, for each component, the distance from `seed` to its nearest vertex (in begin()).
  void setSeed(std::optional<Vec3f> seed) { seed_ = seed; }
  /// Labelling, for the second pass of a component filter: consume() and finish() label the
  /// vertices that they settle (settledParts()), and parts() counts the parts; components() and
  /// partComponents() stay empty, so memory is the front's alone.
  void labelVertices(bool on) { labelVertices_ = on; }

  void begin(const MeshHeader& header) override;
  /// Throws isoslab::Error when the chunk breaks the streaming contract.
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  /// Keeps only what a report says (ComponentSummary, `listed` components), not every component:
  /// a foam has hundreds of thousands, 120 bytes each, where this keeps 4 bytes each (their first
  /// vertices, which number the listed ones). Set before begin(); components() and
  /// partComponents() then stay empty.
  void summarize(std::size_t listed) {
    summarize_ = true;
    listed_ = listed;
  }
  /// With summarize(): the summary, complete after finish().
  const ComponentSummary& summary() const noexcept { return summary_; }

  /// Every component, by id (ascending firstVertex); complete after finish().
  const std::vector<Component>& components() const noexcept { return finished_; }
  /// The most components that were live (not yet final) at once: what memory follows.
  std::size_t peakLive() const noexcept { return peakLive_; }

  /// Parts: a triangle that joins no part yet starts one and gives it the next serial, so two runs
  /// over the same stream number their parts alike (the second pass of a component filter relies on
  /// this). After finish(), the component id of every part serial; parts() serials in all.
  const std::vector<std::uint32_t>& partComponents() const noexcept { return partComponents_; }
  std::uint32_t parts() const noexcept { return partCount_; }

  /// With labelVertices(true): after consume(), the part serial (or kNoPart) of each vertex of the
  /// chunk before it, whose uses are then all known; after finish(), those of the last chunk. Any
  /// serial of a part's history may stand for it: they all map to one component.
  VertexId settledFirst() const noexcept { return settledFirst_; }
  const std::vector<std::uint32_t>& settledParts() const noexcept { return settledParts_; }

 private:
  static constexpr std::uint32_t kNoRecord = 0xffffffffu;

  std::uint32_t find(std::uint32_t slot) noexcept;
  std::uint32_t slotOf(VertexId v) const noexcept { return v - frontFirst_; }
  void join(std::uint32_t a, std::uint32_t b);
  void settleEdge(const EdgeTally::Edge& e);
  void retire();
  // A component that can grow no more: to the finished list, or into the summary.
  void settle(std::uint32_t record);
  void clearLive();
  void label(VertexId first, VertexId end);
  std::uint32_t rootPart(std::uint32_t serial) noexcept;

  ChunkFront front_;
  EdgeTally edges_;
  // The front: union-find over vertex ids frontFirst_ .. frontFirst_ + parent_.size() - 1 (the
  // previous and the current chunk), indexed by slot = id - frontFirst_. record_[root] is the index
  // in live_ of the component that the root stands for, or kNoRecord (a vertex no triangle uses).
  VertexId frontFirst_ = 0;
  std::vector<std::uint32_t> parent_;
  std::vector<std::uint32_t> record_;
  std::vector<Component> live_;      // records; merged-away ones are recycled through freeRecords_
  std::vector<std::uint8_t> inUse_;  // per record of live_: 1 while it stands for a component
  std::vector<std::uint32_t> freeRecords_;
  std::vector<std::uint32_t> touched_;  // per record: the chunk count when a vertex of it was last seen
  std::uint32_t chunks_ = 0;
  std::vector<Component> finished_;
  // summarize(): the summary so far, the largest ones by (triangles descending, firstVertex), and
  // every settled component's first vertex.
  bool summarize_ = false;
  std::size_t listed_ = 0;
  ComponentSummary summary_;
  std::vector<VertexId> firstVertices_;
  // Part serials: serial_[record] is the serial that a live record stands for (a root of
  // partParent_, the union-find over serials); finishedSerial_ runs beside finished_.
  std::vector<std::uint32_t> serial_, partParent_, finishedSerial_, partComponents_;
  std::uint32_t partCount_ = 0;
  std::optional<Vec3f> seed_;
  bool labelVertices_ = false;
  VertexId settledFirst_ = 0;
  std::vector<std::uint32_t> settledParts_;
  // Scratch of retire().
  std::vector<std::uint32_t> roots_, remap_, nextParent_, nextRecord_;
  std::size_t liveCount_ = 0;
  std::size_t peakLive_ = 0;
};

}  // namespace isoslab
