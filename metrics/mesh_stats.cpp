#include "metrics/mesh_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"

namespace isoslab {

void MeshStatsSink::begin(const MeshHeader& header) {
  stats_ = MeshStats{};
  window_ = VertexWindow{};
  previousBoundary_.clear();
  currentBoundary_.clear();
  previousFirst_ = currentFirst_ = currentEnd_ = 0;
  ready_.clear();
  held_.clear();
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
    const Vec3f& a = window_.position(t[0]);
    const Vec3f& b = window_.position(t[1]);
    const Vec3f& c = window_.position(t[2]);
    const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
    const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
    const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const double twiceArea = std::sqrt(nx * nx + ny * ny + nz * nz);
    stats_.area += 0.5 * twiceArea;
    if (twiceArea == 0) ++stats_.degenerateTriangles;
    // Divergence theorem: the signed volume of the tetrahedron (origin, a, b, c).
    stats_.volume +=
        (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
         double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) /
        6.0;
    for (int k = 0; k < 3; ++k) {
      const VertexId from = t[static_cast<std::size_t>(k)];
      const VertexId to = t[static_cast<std::size_t>((k + 1) % 3)];
      const VertexId lo = std::min(from, to);
      const VertexId delta = std::max(from, to) - lo;

      if (delta >= (VertexId{1} << 30)) {
        throw Error(
            fmt::format("the topology check supports edges spanning fewer than 2^30 vertex ids, not {}", delta));
      }
      const bool onFace = (boundaryOf(from) & boundaryOf(to)) != 0;
      const EdgeUse use{lo, delta << 2 | static_cast<VertexId>(from < to) << 1 | static_cast<VertexId>(onFace)};
      (lo < chunk.firstVertex ? ready_ : held_).push_back(use);
    }
  }
  stats_.triangles += chunk.triangles.size();
  // No later triangle uses the previous chunk's vertices: their edges are complete.
  settle(previousFirst_, chunk.firstVertex);
  std::swap(ready_, held_);
  held_.clear();
  currentEnd_ = chunk.endVertex();
}

// Tallies the edges in ready_, whose lower ends all lie in [first, end): grouped by lower end with
// a counting sort, then by upper end within each (short) group.
void MeshStatsSink::settle(VertexId first, VertexId end) {
  const std::size_t n = end - first;
  offsets_.assign(n + 1, 0);
  for (const EdgeUse& u : ready_) ++offsets_[u.lo - first + 1];
  for (std::size_t v = 0; v < n; ++v) offsets_[v + 1] += offsets_[v];
  sorted_.resize(ready_.size());
  for (const EdgeUse& u : ready_) sorted_[offsets_[u.lo - first]++] = u.packed;
  ready_.clear();
  std::size_t begin = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const std::size_t stop = offsets_[v];  // advanced to the group's end by the scatter
    std::sort(sorted_.begin() + static_cast<std::ptrdiff_t>(begin),
              sorted_.begin() + static_cast<std::ptrdiff_t>(stop));
    for (std::size_t i = begin; i < stop;) {
      std::size_t j = i + 1;
      while (j < stop && (sorted_[j] >> 2) == (sorted_[i] >> 2)) ++j;
      ++stats_.edges;
      if (j - i == 1) {
        ++stats_.boundaryEdges;
        if ((sorted_[i] & 1) == 0) ++stats_.interiorBoundaryEdges;
      } else if (j - i == 2) {
        if ((sorted_[i] & 2) == (sorted_[i + 1] & 2)) ++stats_.inconsistentEdges;
      } else {
        ++stats_.nonManifoldEdges;
      }
      i = j;
    }
    begin = stop;
  }
}

void MeshStatsSink::finish() {
  settle(currentFirst_, currentEnd_);
  stats_.euler = static_cast<std::int64_t>(stats_.vertices) - static_cast<std::int64_t>(stats_.edges) +
                 static_cast<std::int64_t>(stats_.triangles);
}

}  // namespace isoslab
