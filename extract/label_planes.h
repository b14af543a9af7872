// The label kernel's planes (extract/label_extractor.cpp): what a layer leaves for the layer
// above (a TopCell a crossed cell), uninitialised planes, and a row's staged output. Internal to
// extract/.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "core/mesh_sink.h"

namespace isoslab::label_planes {

// What the layer above reads of a cell, by slot (slotOf(cell, k), below kTopSlots): its top edges'
// vertices (edges 2, 3, 6, 7: k = 0..3), then the vertices of its split faces x = 0 (k = 4..7) and
// y = 0 (k = 8..11), by the position of an edge in the face. The slots name vertices for the
// stitcher of a threaded run; the plane itself keeps a TopCell a cell, from which every slot's id
// follows.
constexpr std::size_t kTopSlots = 12;

// A crossed cell as the layer above reads it (8 bytes, so that a slice's plane stays in cache):
// its first vertex; each top edge's copy (2 bits a slot) and which top edges are crossed; its
// copies' count (bits 0-2), and for the split faces x = 0 and y = 0 (f = 0, 1) whether it owns one
// (bit 3 + f) and whether the split is of kind 1 (bit 5 + f; else kind 2, faceSplit()).
struct TopCell {
  VertexId first;
  std::uint8_t copies;
  std::uint8_t crossed;
  std::uint8_t meta;
  std::uint8_t unused;
};
static_assert(sizeof(TopCell) == 8);

// The vertex of slot k of a crossed cell: a top edge's copy, or a split face's vertex (its two
// vertices follow the copies and the split faces before it, the first holding positions 3, 0 for
// a split of kind 1 and 0, 1 for kind 2).
constexpr VertexId topVertex(const TopCell& c, std::size_t k) noexcept {
  if (k < 4) return c.first + ((c.copies >> (2 * k)) & 3u);
  const std::size_t f = (k - 4) / 4, position = (k - 4) % 4;
  VertexId id = c.first + (c.meta & 7u) + (f == 1 && (c.meta & 8u) != 0 ? 2u : 0u);
  const bool kindOne = (c.meta >> (5 + f) & 1u) != 0;
  const bool second = kindOne ? (position == 1 || position == 2) : position >= 2;
  return id + (second ? 1u : 0u);
}

// Items left uninitialised: an item is read only where a crossed cell wrote it in the same pass
// (or, for the top plane, the layer before), so stale values are never read; pages that no
// crossed cell touches are never mapped.
template <class T>
class Plane {
 public:
  void allocate(std::size_t n) { items_.reset(new T[std::max<std::size_t>(1, n)]); }
  T& operator[](std::size_t k) noexcept { return items_[k]; }
  const T& operator[](std::size_t k) const noexcept { return items_[k]; }

 private:
  std::unique_ptr<T[]> items_;
};

// A row's output, written through raw pointers and appended to the chunk once a row: at most
// kCellVertices vertices and kCellTriangles triangles a crossed cell (four copies, three split
// faces' two vertices each, three fanned quads' centres; three quads of at most eight triangles).
constexpr std::size_t kCellVertices = 13;
constexpr std::size_t kCellTriangles = 24;
// A vertex's MeshChunk::boundary bits. A type of its own, not a char type, so that the compiler
// need not assume that a store of them changes anything else (a char may alias any object).
enum class FaceBits : std::uint8_t {};

struct RowStage {
  Plane<Vec3f> positions;
  Plane<FaceBits> boundary;
  Plane<Triangle> triangles;
  Plane<LabelPair> faceLabels;
  std::size_t vertices = 0, faces = 0, capacity = 0;

  void reserve(std::size_t cells) {
    if (cells <= capacity) return;
    positions.allocate(cells * kCellVertices);
    boundary.allocate(cells * kCellVertices);
    triangles.allocate(cells * kCellTriangles);
    faceLabels.allocate(cells * kCellTriangles);
    capacity = cells;
  }
  void addVertex(const Vec3f& p, FaceBits volumeFaces) {
    positions[vertices] = p;
    boundary[vertices++] = volumeFaces;
  }
  void addTriangle(const Triangle& t, const LabelPair& sides) {
    triangles[faces] = t;
    faceLabels[faces++] = sides;
  }
  // Appends the row to the chunk and empties it.
  void flush(MeshChunk& out) {
    out.positions.insert(out.positions.end(), &positions[0], &positions[0] + vertices);
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(&boundary[0]);
    out.boundary.insert(out.boundary.end(), bytes, bytes + vertices);
    out.triangles.insert(out.triangles.end(), &triangles[0], &triangles[0] + faces);
    out.faceLabels.insert(out.faceLabels.end(), &faceLabels[0], &faceLabels[0] + faces);
    vertices = faces = 0;
  }
};

}  // namespace isoslab::label_planes
