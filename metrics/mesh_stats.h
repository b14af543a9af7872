// A sink that measures the mesh streaming past: counts, area, enclosed volume, bounds, and the
// edge topology (boundary, non-manifold and inconsistently wound edges, Euler characteristic).
//
// Edges are tallied as chunks arrive and settled as soon as no later triangle can use them (once
// one endpoint is retired, see mesh_sink.h), so memory follows the slab, not the mesh.
// Every quantity is computed in double from the float positions that writers store, so that
// measuring a written file gives the same numbers.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/mesh_sink.h"
#include "metrics/chunk_front.h"
#include "metrics/edge_tally.h"

namespace isoslab {

struct MeshStats {
  std::uint64_t vertices = 0;
  std::uint64_t triangles = 0;
  /// Triangles of zero area (coincident or collinear corners), e.g. from values equal to iso.
  std::uint64_t degenerateTriangles = 0;
  std::uint64_t edges = 0;
  /// Edges used by one triangle only.
  std::uint64_t boundaryEdges = 0;
  /// Boundary edges that do not lie on a face of the volume (a surface cut by the volume's box has
  /// boundary edges on the box; any other is a hole).
  std::uint64_t interiorBoundaryEdges = 0;
  /// Edges used by more than two triangles.
  std::uint64_t nonManifoldEdges = 0;
  /// Edges used by two triangles that traverse it in the same direction (a winding flip).
  std::uint64_t inconsistentEdges = 0;
  std::int64_t euler = 0;
  double area = 0;
  /// Enclosed volume by the divergence theorem (meaningful for closed meshes).
  double volume = 0;
  /// Inside volume summed per tetrahedron, for tetrahedral methods.
  std::optional<double> cellVolume;
  /// xmin ymin zmin xmax ymax zmax of the vertices; zeros for an empty mesh.
  std::array<double, 6> bounds{};

  bool closed() const noexcept { return boundaryEdges == 0 && nonManifoldEdges == 0; }
  bool manifold() const noexcept { return nonManifoldEdges == 0; }
  bool oriented() const noexcept { return inconsistentEdges == 0; }
};

class MeshStatsSink final : public MeshSink {
 public:
  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  /// Complete after finish().
  const MeshStats& stats() const noexcept { return stats_; }

 private:
  void tally(const EdgeTally::Edge& edge);

  MeshStats stats_;
  ChunkFront front_;
  EdgeTally edges_;
  bool haveBounds_ = false;
};

}  // namespace isoslab
