// Precision measures from V. Skala and A. Brus, "Two methods for iso-surface extraction from
// volumetric data and their comparison", sections C to F.
#include "metrics/sphere_metrics.h"

#include <cmath>
#include <numbers>

#include "core/interrupt.h"

namespace isoslab {

void ErrorStats::add(double e) noexcept {
  ++count;
  sum += e;
  sumAbs += std::abs(e);
  sumSquares += e * e;
  maxAbs = std::max(maxAbs, std::abs(e));
}

double ErrorStats::rms() const noexcept {
  return count ? std::sqrt(sumSquares / static_cast<double>(count)) : 0.0;
}

void SphereErrorSink::begin(const MeshHeader&) {
  vertex_ = ErrorStats{};
  centroid_ = ErrorStats{};
}

void SphereErrorSink::consume(const MeshChunk& chunk) {
  window_.push(chunk);
  const auto& c = sphere_.centre;
  const double r = sphere_.radius;
  auto error = [&](double x, double y, double z) {
    const double dx = x - c[0], dy = y - c[1], dz = z - c[2];
    return (std::sqrt(dx * dx + dy * dy + dz * dz) - r) / r;
  };
  for (std::size_t n = 0; n < chunk.triangles.size(); ++n) {
    throwIfInterruptedEvery(n);
    const Triangle& t = chunk.triangles[n];
    double g[3] = {0, 0, 0};
    for (VertexId v : t) {
      const Vec3f& p = window_.position(v);
      vertex_.add(error(p.x, p.y, p.z));
      g[0] += p.x;
      g[1] += p.y;
      g[2] += p.z;
    }
    centroid_.add(error(g[0] / 3.0, g[1] / 3.0, g[2] / 3.0));
  }
}

SphereReport sphereReport(const Sphere& sphere, const MeshStats& stats, const SphereErrorSink& errors) {
  SphereReport r;
  r.sphere = sphere;
  r.triangles = stats.triangles;
  r.vertices = stats.vertices;
  r.vertex = errors.vertexErrors();
  r.centroid = errors.centroidErrors();
  const double area = 4.0 * std::numbers::pi * sphere.radius * sphere.radius;
  const double volume = area * sphere.radius / 3.0;
  r.areaError = (stats.area - area) / area;
  r.volumeError = (stats.volume - volume) / volume;
  if (stats.cellVolume) r.volumeCellsError = (*stats.cellVolume - volume) / volume;
  return r;
}

}  // namespace isoslab
