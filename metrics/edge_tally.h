// The edges of a streamed mesh, tallied as triangles arrive and settled as soon as no later
// triangle can use them: an edge's lower end lies in some chunk, and once the chunk after that one
// has been consumed (see the streaming contract in core/mesh_sink.h), every use of the edge is
// known. Memory follows the two live chunks' edge uses, never the mesh.
//
// Use per chunk: add() every edge use of the chunk's triangles, then settle() the previous chunk's
// vertex range; after the last chunk, settle() the last chunk's range. Not thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

class EdgeTally {
 public:
  /// One edge, settled.
  struct Edge {
    VertexId lo = 0;  // its lower vertex id
    VertexId hi = 0;  // its upper vertex id
    /// Triangles that use it: 1 on a boundary, 2 inside a manifold surface, more at a fin.
    std::size_t uses = 0;
    /// Both ends lie on one face of the volume (their BoundaryFace bits share a bit).
    bool onVolumeFace = false;
    /// Two uses traverse it in the same direction (a winding flip); false unless uses == 2.
    bool inconsistent = false;
  };

  void clear();
  /// Records one triangle's use of the edge from -> to; `chunkFirst` is the first vertex of the
  /// chunk that holds the triangle. Throws isoslab::Error for an edge spanning 2^30 ids or more.
  void add(VertexId from, VertexId to, bool onVolumeFace, VertexId chunkFirst);
  /// Settles the edges whose lower ends lie in [first, end), the chunk before the one whose uses
  /// were just added (or the last chunk, at the end), calling visit(const Edge&) once per edge in
  /// ascending (lo, hi) order.
  template <class Visit>
  void settle(VertexId first, VertexId end, Visit&& visit);

 private:
  // One triangle's use of the edge lo-hi: packed = (hi - lo) << 2 | forward << 1 | onVolumeFace,
  // where forward means the triangle runs lo -> hi.
  struct EdgeUse {
    VertexId lo;
    VertexId packed;
  };
  void group(VertexId first, VertexId end);

  std::vector<EdgeUse> ready_;  // uses whose lower end is in the previous chunk: complete
  std::vector<EdgeUse> held_;   // uses whose lower end is in the current chunk
  std::vector<VertexId> sorted_;
  std::vector<std::size_t> offsets_;
};

template <class Visit>
void EdgeTally::settle(VertexId first, VertexId end, Visit&& visit) {
  group(first, end);
  std::size_t begin = 0;
  for (std::size_t v = 0; v < offsets_.size() - 1; ++v) {
    const std::size_t stop = offsets_[v];  // advanced to the group's end by the scatter
    for (std::size_t i = begin; i < stop;) {
      std::size_t j = i + 1;
      while (j < stop && (sorted_[j] >> 2) == (sorted_[i] >> 2)) ++j;
      Edge e;
      e.lo = first + static_cast<VertexId>(v);
      e.hi = e.lo + (sorted_[i] >> 2);
      e.uses = j - i;
      e.onVolumeFace = (sorted_[i] & 1) != 0;
      e.inconsistent = j - i == 2 && (sorted_[i] & 2) == (sorted_[i + 1] & 2);
      visit(e);
      i = j;
    }
    begin = stop;
  }
  // The current chunk's uses are complete after the next chunk.
  std::swap(ready_, held_);
  held_.clear();
}

}  // namespace isoslab
