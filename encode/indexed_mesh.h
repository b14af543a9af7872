// A whole mesh in memory, for tests, decoders and measuring files; the streaming path never builds
// one. MemoryMeshSink collects a stream into it; feedMesh() streams it back out as one chunk.
#pragma once

#include <string>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

struct IndexedMesh {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;          // empty, or one per position
  std::vector<std::uint8_t> boundary;  // empty, or one per position
  std::vector<Triangle> triangles;
  /// .glb chunks: per position, 0 or the identity of a vertex that a neighbouring chunk shares
  /// (its global vertex id + 1), so that decoders join seams by identity, not by position.
  std::vector<std::uint32_t> seamKeys;
  double cellVolume = 0;
  /// A .glb read back: the end of each primitive's (chunk's) triangles, in order; else empty.
  std::vector<std::size_t> partEnds;
  friend bool operator==(const IndexedMesh&, const IndexedMesh&) = default;
};

class MemoryMeshSink final : public MeshSink {
 public:
  void begin(const MeshHeader& header) override {
    header_ = header;
    mesh_ = IndexedMesh{};
  }
  void consume(const MeshChunk& chunk) override {
    mesh_.positions.insert(mesh_.positions.end(), chunk.positions.begin(), chunk.positions.end());
    mesh_.normals.insert(mesh_.normals.end(), chunk.normals.begin(), chunk.normals.end());
    mesh_.boundary.insert(mesh_.boundary.end(), chunk.boundary.begin(), chunk.boundary.end());
    mesh_.triangles.insert(mesh_.triangles.end(), chunk.triangles.begin(), chunk.triangles.end());
    mesh_.cellVolume += chunk.cellVolume;
  }
  void finish() override {}

  const IndexedMesh& mesh() const noexcept { return mesh_; }
  const MeshHeader& header() const noexcept { return header_; }

 private:
  MeshHeader header_;
  IndexedMesh mesh_;
};

/// Sends `mesh` to `sink` as a single chunk: begin, consume, finish.
void feedMesh(const IndexedMesh& mesh, const MeshHeader& header, MeshSink& sink);

}  // namespace isoslab
