// The precision measures of Skala and Brus against an analytic sphere, computed as triangles
// stream past (no stored mesh):
// - radius error per vertex (their section C): e = (|v - c| - r) / r for each of the 3T triangle
//   corners (a vertex counts once per triangle that uses it, as in the paper);
// - radius error per triangle centroid (section D): the same for each triangle's centroid;
// - area and volume errors (sections E and F) come from MeshStats (see sphereReport()).
// Everything is computed in double from the float positions that writers store, so measuring a
// written file reproduces the numbers.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "core/mesh_sink.h"
#include "metrics/mesh_stats.h"

namespace isoslab {

struct Sphere {
  std::array<double, 3> centre{};
  double radius = 1;
};

/// Sum, mean, mean |e|, RMS and max |e| of a set of relative errors.
struct ErrorStats {
  std::uint64_t count = 0;
  double sum = 0;
  double sumAbs = 0;
  double sumSquares = 0;
  double maxAbs = 0;

  void add(double e) noexcept;
  double mean() const noexcept { return count ? sum / static_cast<double>(count) : 0.0; }
  double meanAbs() const noexcept { return count ? sumAbs / static_cast<double>(count) : 0.0; }
  double rms() const noexcept;
};

class SphereErrorSink final : public MeshSink {
 public:
  explicit SphereErrorSink(const Sphere& sphere) : sphere_(sphere) {}
  void begin(const MeshHeader&) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override {}

  const ErrorStats& vertexErrors() const noexcept { return vertex_; }
  const ErrorStats& centroidErrors() const noexcept { return centroid_; }

 private:
  Sphere sphere_;
  VertexWindow window_;
  ErrorStats vertex_;
  ErrorStats centroid_;
};

/// All of the paper's measures for one mesh.
struct SphereReport {
  Sphere sphere;
  std::uint64_t triangles = 0;
  std::uint64_t vertices = 0;
  ErrorStats vertex;
  ErrorStats centroid;
  double areaError = 0;                    // (S - 4 pi r^2) / 4 pi r^2
  double volumeError = 0;                  // (V - 4/3 pi r^3) / (4/3 pi r^3), V by the divergence theorem
  std::optional<double> volumeCellsError;  // the same with the per-tetrahedron volume
};

SphereReport sphereReport(const Sphere& sphere, const MeshStats& stats, const SphereErrorSink& errors);

}  // namespace isoslab
