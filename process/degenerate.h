// Collapsing degenerate triangles in the stream, for printable outputs (.stl, .3mf).
//
// Marching methods put a vertex on every lattice edge that the surface crosses. Where a sample
// equals the iso value exactly, every crossed edge at that sample puts its vertex on the sample:
// several vertices at one position, and the triangles between them have zero area. Viewers do not
// mind; slicers do (PrusaSlicer removes them as "degenerate facets", a repair). This sink merges
// each such cluster of coincident vertices (vertices joined by edges of zero length) into one and
// drops the triangles that it makes degenerate, when the result stays manifold: the merged
// vertex's triangles must form fans (closed disks, or open ones where the surface already had a
// border) with every neighbour once on each side. Where two sheets of the surface touch at the
// point (a saddle exactly at the iso value), the fans are two or more: each gets a vertex of its
// own (a split, as label surfaces split where voxels touch at a corner), so that every vertex
// stays a 2-manifold point. A cluster that fails stays as it is and is counted.
//
// No position moves, so the surface's area, volume and shape are unchanged; only triangles of zero
// area go. The cluster of a vertex of chunk z is known once chunk z + 1 has arrived (a triangle of
// a later chunk cannot reference it), so the sink holds two or three chunks.
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <unordered_map>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

struct DegenerateCounts {
  /// Clusters of coincident vertices merged, the vertices merged away and the triangles dropped.
  std::int64_t clusters = 0;
  std::int64_t vertices = 0;
  std::int64_t triangles = 0;
  /// Merged clusters whose triangles form several fans, each with its own vertex.
  std::int64_t splits = 0;
  /// Clusters left as they were (merging them would make an edge or a vertex non-manifold), and
  /// the degenerate triangles they keep.
  std::int64_t refused = 0;
  std::int64_t refusedTriangles = 0;
};

class DegenerateCollapseSink final : public MeshSink {
 public:
  /// `remap`: the triangles passed on name each cluster's surviving vertex (its smallest id),
  /// which may lie further back than the previous chunk, so only for a sink that holds the whole
  /// mesh (the 3MF writer). Without it the triangles keep their ids: the merged vertices have the
  /// same position, so a sink that reads positions (the STL writer) writes the same file.
  DegenerateCollapseSink(MeshSink& next, bool remap) : next_(next), remap_(remap) {}

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  /// Complete after finish().
  const DegenerateCounts& counts() const noexcept { return counts_; }

 private:
  struct Cluster {
    std::vector<VertexId> members;  // sorted; members.front() survives
    std::vector<Triangle> triangles;  // every pending triangle that uses a member
  };

  /// Where a member of a merged cluster went: its fan's vertex, and the cluster (its smallest
  /// member), by which a triangle with two corners in one cluster is known as degenerate.
  struct Merge {
    VertexId survivor = 0;
    VertexId cluster = 0;
  };

  VertexId find(VertexId v);
  void joinZeroEdges(const MeshChunk& chunk);
  void settle(VertexId before);
  /// How a cluster merges: the survivor of each member (in members' order), and for a member in
  /// two fans, the survivor of its corner in each of its kept triangles.
  struct Fans {
    std::vector<VertexId> survivors;
    std::vector<std::pair<Triangle, std::pair<VertexId, VertexId>>> corners;  // (member, survivor)
    std::size_t count = 0;
  };
  /// Nothing when the merge would make an edge non-manifold.
  std::optional<Fans> fans(const Cluster& cluster) const;
  /// The triangle as merges so far leave it, or nothing when they make it degenerate.
  std::optional<Triangle> mapped(const Triangle& t) const;
  void emitFront();
  const Vec3f& position(VertexId v) const;

  MeshSink& next_;
  bool remap_ = false;
  std::deque<MeshChunk> pending_;
  std::unordered_map<VertexId, VertexId> parent_;  // union-find over the open clusters' members
  std::map<VertexId, Merge> merged_;  // by member, while a pending triangle may use it
  /// Kept triangles whose member is in two fans: (member, survivor), until emitted.
  std::map<Triangle, std::pair<VertexId, VertexId>> corners_;
  DegenerateCounts counts_;
};

}  // namespace isoslab
