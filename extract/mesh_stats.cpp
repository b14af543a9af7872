#include "extract/mesh_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace isoslab {

void MeshStatsSink::begin(const MeshHeader& header) {
  stats_ = MeshStats{};
  if (header.cellVolumes) stats_.cellVolume = 0.0;
}

void MeshStatsSink::consume(const MeshChunk& chunk) {
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
      const VertexId hi = std::max(from, to);
      const bool onFace = (boundaryOf(from) & boundaryOf(to)) != 0;
      pending_.push_back(
          {(std::uint64_t{lo} << 32) | hi, static_cast<std::uint8_t>(from < to), static_cast<std::uint8_t>(onFace)});
    }
  }
  stats_.triangles += chunk.triangles.size();
  // Triangles from now on use only this chunk's and the next chunk's vertices.
  settle(chunk.firstVertex);
}

void MeshStatsSink::settle(VertexId retiredBelow) {
  std::sort(pending_.begin(), pending_.end(), [](const EdgeUse& x, const EdgeUse& y) { return x.key < y.key; });
  std::size_t kept = 0;
  for (std::size_t i = 0; i < pending_.size();) {
    std::size_t end = i + 1;
    while (end < pending_.size() && pending_[end].key == pending_[i].key) ++end;
    const auto lo = static_cast<VertexId>(pending_[i].key >> 32);
    if (lo < retiredBelow) {
      const std::size_t uses = end - i;
      ++stats_.edges;
      if (uses == 1) {
        ++stats_.boundaryEdges;
        if (!pending_[i].onVolumeFace) ++stats_.interiorBoundaryEdges;
      } else if (uses == 2) {
        if (pending_[i].forward == pending_[i + 1].forward) ++stats_.inconsistentEdges;
      } else {
        ++stats_.nonManifoldEdges;
      }
    } else {
      for (std::size_t k = i; k < end; ++k) pending_[kept++] = pending_[k];
    }
    i = end;
  }
  pending_.resize(kept);
}

void MeshStatsSink::finish() {
  settle(std::numeric_limits<VertexId>::max());
  stats_.euler = static_cast<std::int64_t>(stats_.vertices) - static_cast<std::int64_t>(stats_.edges) +
                 static_cast<std::int64_t>(stats_.triangles);
}

}  // namespace isoslab
