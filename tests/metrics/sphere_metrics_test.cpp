#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "encode/indexed_mesh.h"
#include "metrics/mesh_stats.h"
#include "metrics/sphere_metrics.h"

namespace isoslab {
namespace {

SphereReport measure(const IndexedMesh& mesh, const Sphere& sphere) {
  MeshStatsSink stats;
  SphereErrorSink errors(sphere);
  TeeSink tee({&stats, &errors});
  feedMesh(mesh, MeshHeader{}, tee);
  return sphereReport(sphere, stats.stats(), errors);
}

IndexedMesh scaled(IndexedMesh m, double r, const std::array<double, 3>& c) {
  double len = 0;
  for (const Vec3f& p : m.positions)
    len = std::max(len, std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z));
  for (Vec3f& p : m.positions) {
    p = {static_cast<float>(c[0] + p.x * r / len), static_cast<float>(c[1] + p.y * r / len),
         static_cast<float>(c[2] + p.z * r / len)};
  }
  return m;
}

IndexedMesh octahedron() {
  IndexedMesh m;
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  return m;
}

IndexedMesh cube() {
  IndexedMesh m;
  for (int c = 0; c < 8; ++c) m.positions.push_back({(c & 1) ? 1.f : -1.f, (c & 2) ? 1.f : -1.f, (c & 4) ? 1.f : -1.f});
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({VertexId(q[0]), VertexId(q[1]), VertexId(q[2])});
    m.triangles.push_back({VertexId(q[0]), VertexId(q[2]), VertexId(q[3])});
  }
  return m;
}

IndexedMesh icosahedron() {
  const float p = static_cast<float>(std::numbers::phi);
  IndexedMesh m;
  m.positions = {{-1, p, 0},  {1, p, 0},  {-1, -p, 0}, {1, -p, 0}, {0, -1, p},  {0, 1, p},
                 {0, -1, -p}, {0, 1, -p}, {p, 0, -1},  {p, 0, 1},  {-p, 0, -1}, {-p, 0, 1}};
  m.triangles = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  return m;
}

constexpr double kTol = 2e-6;  // float positions

TEST(SphereMetrics, InscribedOctahedron) {
  const double r = 10;
  const SphereReport s = measure(scaled(octahedron(), r, {3, 4, 5}), Sphere{{3, 4, 5}, r});
  EXPECT_EQ(s.vertex.count, 24u);
  EXPECT_NEAR(s.vertex.maxAbs, 0.0, kTol);  // every corner on the sphere
  // Face centroids at r / sqrt(3).
  EXPECT_NEAR(s.centroid.mean(), 1 / std::sqrt(3.0) - 1, kTol);
  EXPECT_NEAR(s.centroid.sum, 8 * (1 / std::sqrt(3.0) - 1), 8 * kTol);
  // Area 4 sqrt(3) r^2, volume 4/3 r^3.
  EXPECT_NEAR(s.areaError, std::sqrt(3.0) / std::numbers::pi - 1, kTol);
  EXPECT_NEAR(s.volumeError, 1 / std::numbers::pi - 1, kTol);
}

TEST(SphereMetrics, InscribedCube) {
  const double r = 7;
  const SphereReport s = measure(scaled(cube(), r, {0, 0, 0}), Sphere{{0, 0, 0}, r});
  EXPECT_NEAR(s.vertex.maxAbs, 0.0, kTol);
  // A triangle of a face (three of its four corners) has its centroid at a sqrt(11)/3 with a = r/sqrt(3).
  EXPECT_NEAR(s.centroid.mean(), std::sqrt(11.0) / (3 * std::sqrt(3.0)) - 1, kTol);
  EXPECT_NEAR(s.centroid.maxAbs, 1 - std::sqrt(11.0) / (3 * std::sqrt(3.0)), kTol);
  EXPECT_NEAR(s.areaError, 2 / std::numbers::pi - 1, kTol);                       // 8 r^2
  EXPECT_NEAR(s.volumeError, 2 / (std::sqrt(3.0) * std::numbers::pi) - 1, kTol);  // 8 r^3 / 3 sqrt(3)
}

TEST(SphereMetrics, InscribedIcosahedron) {
  const double r = 5;
  const SphereReport s = measure(scaled(icosahedron(), r, {1, 1, 1}), Sphere{{1, 1, 1}, r});
  EXPECT_NEAR(s.vertex.maxAbs, 0.0, kTol);
  // Edge a = r / sin(2 pi / 5); area 5 sqrt(3) a^2; volume 5/12 (3 + sqrt 5) a^3; inradius
  // phi^2 a / (2 sqrt 3) at the face centroids.
  const double a = r / std::sin(2 * std::numbers::pi / 5);
  const double phi = std::numbers::phi;
  EXPECT_NEAR(s.centroid.mean(), phi * phi * a / (2 * std::sqrt(3.0)) / r - 1, kTol);
  EXPECT_NEAR(s.areaError, 5 * std::sqrt(3.0) * a * a / (4 * std::numbers::pi * r * r) - 1, kTol);
  EXPECT_NEAR(s.volumeError, 5.0 / 12 * (3 + std::sqrt(5.0)) * a * a * a / (4.0 / 3 * std::numbers::pi * r * r * r) - 1,
              kTol);
}

TEST(SphereMetrics, PaperSumsMatchAHandComputation) {
  // One triangle with corners at 1.1 r, 0.9 r and r from the centre (r = 10): corner errors
  // +0.1, -0.1 and 0; the centroid (11, 9, 10) / 3 lies at sqrt(302) / 3.
  IndexedMesh m;
  m.positions = {{11, 0, 0}, {0, 9, 0}, {0, 0, 10}};
  m.triangles = {{0, 1, 2}};
  const SphereReport s = measure(m, Sphere{{0, 0, 0}, 10});
  EXPECT_EQ(s.vertex.count, 3u);
  EXPECT_NEAR(s.vertex.sum, 0.0, 1e-12);
  EXPECT_NEAR(s.vertex.meanAbs(), 0.2 / 3, 1e-12);
  EXPECT_NEAR(s.vertex.rms(), std::sqrt(0.02 / 3), 1e-12);
  EXPECT_NEAR(s.vertex.maxAbs, 0.1, 1e-12);
  EXPECT_NEAR(s.centroid.sum, std::sqrt(302.0) / 3 / 10 - 1, 1e-12);
}

}  // namespace
}  // namespace isoslab
