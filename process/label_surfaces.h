// Splits a label complex (extract/label_extractor.h) into one mesh stream per label, as the
// chunks pass: a label's surface is the complex's triangles with that label on a side, turned to
// face out of it, over its own vertices numbered densely in order of first use. Each stream keeps
// the streaming contract (core/mesh_sink.h). Measures the interfaces between labels meanwhile.
//
// Memory: per label, its sink and its part of the current chunk; per vertex of the last two
// chunks, the labels that used it and its number in each.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/mesh_sink.h"
#include "core/zeroed_array.h"

namespace isoslab {

class LabelSplitSink final : public MeshSink {
 public:
  /// The sink of a label's surface, asked when its first triangle arrives; nullptr drops the label.
  /// The sink gets begin() with the complex's header (labels false, iso the label's value), its
  /// chunks, and finish() at this sink's finish(), in label order.
  using SinkFor = std::function<MeshSink*(std::int32_t label)>;

  /// `perLabel` false: only the per-label counts, area, volume and interfaces, without building
  /// each label's chunks (no sinks get them, and vertices, bounds and topology stay 0): for a run
  /// that writes the complex and reports nothing per label. `topology` (needs perLabel): each
  /// label's edges, boundary, non-manifold and inconsistent edges, and Euler characteristic.
  /// `measures` false: each label's triangles are counted, but no area, volume or interface is
  /// measured (for a run that reports nothing per label).
  explicit LabelSplitSink(SinkFor sinkFor, bool perLabel = true, bool topology = true, bool measures = true);

  /// Several iso values in one pass: surface k's header (label k, from 1) names isos[k - 1] as its
  /// iso value, not k.
  void setIsoValues(std::vector<double> isos) { isos_ = std::move(isos); }

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  struct Interface {
    std::uint64_t triangles = 0;
    double area = 0;
  };
  /// After finish(): per pair of labels (smaller first; 0 is the background and the volume's
  /// outside), the triangles and area of the interface between them.
  const std::map<std::pair<std::int32_t, std::int32_t>, Interface>& interfaces() const noexcept { return interfaces_; }
  /// After finish(): per label, the splits and pinches the kernel reported (MeshChunk::labelSplits,
  /// labelPinches).
  const std::map<std::int32_t, std::uint64_t>& splits() const noexcept { return splits_; }
  const std::map<std::int32_t, std::uint64_t>& pinches() const noexcept { return pinches_; }
  /// Per label, measured as the triangles pass (in double, from the float positions): its
  /// surface's edges, vertices, triangles, area, enclosed volume (divergence theorem, outward
  /// faces) and bounds (xmin ymin zmin xmax ymax zmax). Memory: the last two chunks' edge uses,
  /// whatever the number of labels.
  /// A label's edges, each settled once no later triangle can use it (the streaming contract).
  struct Topology {
    std::uint64_t edges = 0;
    std::uint64_t boundaryEdges = 0;      // used once
    std::uint64_t nonManifoldEdges = 0;   // used more than twice
    std::uint64_t inconsistentEdges = 0;  // used twice in one direction
    std::int64_t euler = 0;               // vertices - edges + triangles
  };
  struct Measures {
    Topology topology;
    std::uint64_t vertices = 0;
    std::uint64_t triangles = 0;
    double area = 0;
    double volume = 0;
    std::array<double, 6> bounds{};
  };
  /// After finish(), by label.
  std::map<std::int32_t, Measures> measures() const;
  /// The labels that had a surface, ascending.
  std::vector<std::int32_t> labels() const;

 private:
  struct Stream {
    std::int32_t label = 0;
    MeshSink* sink = nullptr;
    VertexId next = 0;
    std::uint32_t pending = 0;  // this chunk's sides, then their offset (consume)
    Measures measures;
    Topology topology;
  };
  struct EdgeUse {  // 16 bytes, three a triangle of the complex
    VertexId lo = 0, hi = 0;
    // The sides' streams + 1 (0: none), the front's with bit 31 set when the triangle runs lo -> hi.
    std::uint32_t frontForward = 0, back = 0;
  };
  void tally(const std::array<std::uint32_t, 2>& streams, const Triangle& t);
  void settle(VertexId before);
  // A label's number for a complex vertex of the window.
  struct Use {
    std::uint32_t stream = 0;
    VertexId id = 0;
    std::uint32_t next = 0;  // the next use of the same vertex, + 1 (0: none)
  };
  struct Window {
    VertexId first = 0;
    std::vector<std::uint32_t> head;  // per vertex: its first use, + 1 (0: none)
    std::vector<Use> uses;
  };

  std::uint32_t streamOf(std::int32_t label);
  void countTriangles(const MeshChunk& chunk);
  VertexId idFor(std::uint32_t stream, VertexId v, const MeshChunk& chunk);

  SinkFor sinkFor_;
  std::vector<double> isos_;
  bool perLabel_ = true;
  bool topology_ = true;
  bool measures_ = true;
  MeshHeader header_;
  std::vector<Stream> streams_;
  // label -> stream + 1 (0: not seen yet; kNoStream: dropped): by value for labels in
  // [0, kDirectLabels), in the map for the others.
  static constexpr std::int32_t kDirectLabels = 1 << 16;
  ZeroedArray<std::uint32_t> direct_;  // pages only where labels are
  std::unordered_map<std::int32_t, std::uint32_t> index_;
  std::vector<std::uint32_t> touched_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> sides_;  // (stream, triangle << 1 | back)
  std::vector<std::uint32_t> ordered_;
  MeshChunk scratch_;  // the chunk of one label, built and sent in turn
  std::vector<EdgeUse> edgeUses_;
  std::vector<EdgeUse> settling_;  // settle(): the complete uses, by lower end
  std::vector<std::size_t> offsets_;
  Window previous_, current_;
  std::vector<Vec3f> previousPositions_;  // the previous chunk's
  std::vector<std::uint8_t> previousBoundary_;
  std::map<std::pair<std::int32_t, std::int32_t>, Interface> interfaces_;
  std::map<std::int32_t, std::uint64_t> splits_, pinches_;
};

}  // namespace isoslab
