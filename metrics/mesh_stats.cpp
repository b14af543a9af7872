#include "metrics/mesh_stats.h"

#include <algorithm>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"
#include "metrics/triangle_measure.h"

namespace isoslab {

void MeshStatsSink::begin(const MeshHeader& header) {
  stats_ = MeshStats{};
  window_ = VertexWindow{};
  previousBoundary_.clear();
  currentBoundary_.clear();
  previousFirst_ = currentFirst_ = currentEnd_ = 0;
  edges_.clear();
  haveBounds_ = false;
  if (header.cellVolumes) stats_.cellVolume = 0.0;
}

void MeshStatsSink::consume(const MeshChunk& chunk) {
  if (chunk.firstVertex != currentEnd_) {
    throw Error(fmt::format("slab {}: the chunk's vertices start at id {}, not at {} where the previous chunk's ended",
                            chunk.slab, chunk.firstVertex, currentEnd_));
  }
  window_.push(chunk);
  std::swap(previousBoundary_, currentBoundary_);
  currentBoundary_ = chunk.boundary;
  previousFirst_ = currentFirst_;
  currentFirst_ = chunk.firstVertex;
  auto boundaryOf = [&](VertexId v) -> std::uint8_t {
    if (v >= currentFirst_) return currentBoundary_.empty() ? 0 : currentBoundary_[v - currentFirst_];
    return previousBoundary_.empty() ? 0 : previousBoundary_[v - previousFirst_];
  };

  stats_.vertices += chunk.positions.size();
  for (const Vec3f& p : chunk.positions) {
    const double c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      if (!haveBounds_ || c[a] < stats_.bounds[static_cast<std::size_t>(a)])
        stats_.bounds[static_cast<std::size_t>(a)] = c[a];
      if (!haveBounds_ || c[a] > stats_.bounds[static_cast<std::size_t>(a + 3)])
        stats_.bounds[static_cast<std::size_t>(a + 3)] = c[a];
    }
    haveBounds_ = true;
  }
  if (stats_.cellVolume) *stats_.cellVolume += chunk.cellVolume;

  for (const Triangle& t : chunk.triangles) {
    for (VertexId v : t) {
      if (v < previousFirst_ || v >= chunk.endVertex()) {
        throw Error(
            fmt::format("slab {}: a triangle uses vertex {}, outside this chunk and the previous one", chunk.slab, v));
      }
    }
    const TriangleMeasure m = measureTriangle(window_.position(t[0]), window_.position(t[1]), window_.position(t[2]));
    stats_.area += 0.5 * m.twiceArea;
    if (m.twiceArea == 0) ++stats_.degenerateTriangles;
    stats_.volume += m.volume;
    for (int k = 0; k < 3; ++k) {
      const VertexId from = t[static_cast<std::size_t>(k)];
      const VertexId to = t[static_cast<std::size_t>((k + 1) % 3)];
      edges_.add(from, to, (boundaryOf(from) & boundaryOf(to)) != 0, chunk.firstVertex);
    }
  }
  stats_.triangles += chunk.triangles.size();
  // No later triangle uses the previous chunk's vertices: their edges are complete.
  edges_.settle(previousFirst_, chunk.firstVertex, [this](const EdgeTally::Edge& e) { tally(e); });
  currentEnd_ = chunk.endVertex();
}

void MeshStatsSink::tally(const EdgeTally::Edge& e) {
  ++stats_.edges;
  if (e.uses == 1) {
    ++stats_.boundaryEdges;
    if (!e.onVolumeFace) ++stats_.interiorBoundaryEdges;
  } else if (e.uses == 2) {
    if (e.inconsistent) ++stats_.inconsistentEdges;
  } else {
    ++stats_.nonManifoldEdges;
  }
}

void MeshStatsSink::finish() {
  edges_.settle(currentFirst_, currentEnd_, [this](const EdgeTally::Edge& e) { tally(e); });
  stats_.euler = static_cast<std::int64_t>(stats_.vertices) - static_cast<std::int64_t>(stats_.edges) +
                 static_cast<std::int64_t>(stats_.triangles);
}

}  // namespace isoslab
