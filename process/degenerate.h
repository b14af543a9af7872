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
// stays a 2-manifold point. A cluster that fails keeps its ids, and its members are moved apart
// by a thousandth of their neighbours' distance: the triangles become slivers, not zero-area ones.
//
// A merge moves no position, so the surface's area, volume and shape are unchanged; only triangles
// of zero area go. The cluster of a vertex of chunk z is known once chunk z + 1 has arrived (a triangle of
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
  /// Clusters not merged (merging them would make an edge non-manifold), and the zero-area
  /// triangles they had. Their members but one are moved apart a little instead (`separated`),
  /// so that those triangles become slivers and none keeps two corners at one point.
  std::int64_t refused = 0;
  std::int64_t refusedTriangles = 0;
  std::int64_t separated = 0;
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
    std::vector<VertexId> members;    // sorted; members.front() survives
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
    std::vector<std::pair<std::pair<Triangle, VertexId>, VertexId>> corners;  // ((triangle, member), survivor)
    std::size_t count = 0;
  };
  /// Nothing when the merge would make an edge non-manifold.
  std::optional<Fans> fans(const Cluster& cluster) const;
  /// The triangle as merges so far leave it, or nothing when they make it degenerate.
  std::optional<Triangle> mapped(const Triangle& t) const;
  void emitFront();
  const Vec3f& position(VertexId v) const;
  Vec3f& mutablePosition(VertexId v);
  std::int64_t separate(const Cluster& cluster);

  MeshSink& next_;
  bool remap_ = false;
  std::deque<MeshChunk> pending_;
  std::unordered_map<VertexId, VertexId> parent_;  // union-find over the open clusters' members
  std::map<VertexId, Merge> merged_;               // by member, while a pending triangle may use it
  /// The corners (triangle, member) of kept triangles whose member is in two fans, with the
  /// survivor of each, until the triangle is emitted.
  std::map<std::pair<Triangle, VertexId>, VertexId> corners_;
  DegenerateCounts counts_;
};

}  // namespace isoslab
