#include "metrics/mesh_stats.h"

#include <algorithm>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"
#include "core/interrupt.h"
#include "metrics/triangle_measure.h"

namespace isoslab {

void MeshStatsSink::begin(const MeshHeader& header) {
  stats_ = MeshStats{};
  front_.reset();
  edges_.clear();
  haveBounds_ = false;
  if (header.cellVolumes) stats_.cellVolume = 0.0;
}

void MeshStatsSink::consume(const MeshChunk& chunk) {
  front_.advance(chunk);
  const VertexId previousFirst = front_.previousFirst();

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

  // metrics and decode hand over a whole mesh as one chunk.
  for (std::size_t n = 0; n < chunk.triangles.size(); ++n) {
    throwIfInterruptedEvery(n);
    const Triangle& t = chunk.triangles[n];
    for (VertexId v : t) {
      if (v < previousFirst || v >= chunk.endVertex()) {
        throw Error(
            fmt::format("slab {}: a triangle uses vertex {}, outside this chunk and the previous one", chunk.slab, v));
      }
    }
    const TriangleMeasure m = measureTriangle(front_.position(t[0]), front_.position(t[1]), front_.position(t[2]));
    stats_.area += 0.5 * m.twiceArea;
    if (m.twiceArea == 0) ++stats_.degenerateTriangles;
    stats_.volume += m.volume;
    for (int k = 0; k < 3; ++k) {
      const VertexId from = t[static_cast<std::size_t>(k)];
      const VertexId to = t[static_cast<std::size_t>((k + 1) % 3)];
      edges_.add(from, to, (front_.boundary(from) & front_.boundary(to)) != 0, chunk.firstVertex);
    }
  }
  stats_.triangles += chunk.triangles.size();
  // No later triangle uses the previous chunk's vertices: their edges are complete.
  edges_.settle(previousFirst, chunk.firstVertex, [this](const EdgeTally::Edge& e) { tally(e); });
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
  edges_.settle(front_.currentFirst(), front_.currentEnd(), [this](const EdgeTally::Edge& e) { tally(e); });
  stats_.euler = static_cast<std::int64_t>(stats_.vertices) - static_cast<std::int64_t>(stats_.edges) +
                 static_cast<std::int64_t>(stats_.triangles);
}

}  // namespace isoslab
