// The area and the signed enclosed volume of one triangle, as every measuring sink computes them
// (in double, from the float positions that writers store).
#pragma once

#include <cmath>

#include "core/mesh_sink.h"

namespace isoslab {

struct TriangleMeasure {
  /// Twice the area: the length of the cross product of two edges (0 for a degenerate triangle).
  double twiceArea = 0;
  /// Divergence theorem: the signed volume of the tetrahedron (origin, a, b, c). Summed over a
  /// closed, consistently wound surface it is the enclosed volume.
  double volume = 0;
};

inline TriangleMeasure measureTriangle(const Vec3f& a, const Vec3f& b, const Vec3f& c) noexcept {
  const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
  const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
  const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  TriangleMeasure m;
  m.twiceArea = std::sqrt(nx * nx + ny * ny + nz * nz);
  m.volume =
      (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
       double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) /
      6.0;
  return m;
}

}  // namespace isoslab
