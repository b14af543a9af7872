#include "extract/slab_field.h"

#include <array>

namespace isoslab {
namespace {

// Central difference along one axis at index g of n points; one-sided at the volume's ends, `pad`
// points in from the lattice's.
template <typename F>
double difference(std::int64_t g, std::int64_t n, std::int64_t pad, F&& value) noexcept {
  if (g <= pad) return value(1) - value(0);
  if (g >= n - 1 - pad) return value(0) - value(-1);
  return 0.5 * (value(1) - value(-1));
}

}  // namespace

Vec3d SlabField::gradient(const LatticeNode& node, std::int64_t i, std::int64_t j) const noexcept {
  if (node.isCentre()) {
    const std::int64_t ci = i + (node.hx - 1) / 2;
    const std::int64_t cj = j + (node.hy - 1) / 2;
    const std::int64_t cz = (node.hz - 1) / 2;  // slab offset 0 or 1
    double c[8];
    for (int k = 0; k < 8; ++k) c[k] = at(ci + (k & 1), cj + ((k >> 1) & 1), cz + ((k >> 2) & 1));
    return {0.25 * ((c[1] - c[0]) + (c[3] - c[2]) + (c[5] - c[4]) + (c[7] - c[6])),
            0.25 * ((c[2] - c[0]) + (c[3] - c[1]) + (c[6] - c[4]) + (c[7] - c[5])),
            0.25 * ((c[4] - c[0]) + (c[5] - c[1]) + (c[6] - c[2]) + (c[7] - c[3]))};
  }
  if (node.isFaceCentre()) {
    // The mean of the face's four corners' gradients: the same whichever of the two cells sharing
    // the face creates the vertex.
    Vec3d g{0, 0, 0};
    for (int k = 0; k < 4; ++k) {
      std::array<int, 3> h{node.hx, node.hy, node.hz};
      int bit = 0;
      for (auto& c : h) {
        if (c & 1) c += ((k >> bit++) & 1) != 0 ? 1 : -1;
      }
      const Vec3d gc = gradient(
          {static_cast<std::int8_t>(h[0]), static_cast<std::int8_t>(h[1]), static_cast<std::int8_t>(h[2])}, i, j);
      for (std::size_t a = 0; a < 3; ++a) g[a] += 0.25 * gc[a];
    }
    return g;
  }
  const std::int64_t gi = i + node.hx / 2;
  const std::int64_t gj = j + node.hy / 2;
  const std::int64_t dz = node.hz / 2;
  return {difference(gi, nx, pad, [&](std::int64_t d) { return static_cast<double>(at(gi + d, gj, dz)); }),
          difference(gj, ny, pad, [&](std::int64_t d) { return static_cast<double>(at(gi, gj + d, dz)); }),
          difference(z + dz, nz, pad, [&](std::int64_t d) { return static_cast<double>(at(gi, gj, dz + d)); })};
}

}  // namespace isoslab
