#include "extract/slab_field.h"

namespace isoslab {
namespace {

// Central difference along one axis at index g of n points; one-sided at the ends.
template <typename F>
double difference(std::int64_t g, std::int64_t n, F&& value) noexcept {
  if (g == 0) return value(1) - value(0);
  if (g == n - 1) return value(0) - value(-1);
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
  const std::int64_t gi = i + node.hx / 2;
  const std::int64_t gj = j + node.hy / 2;
  const std::int64_t dz = node.hz / 2;
  return {difference(gi, nx, [&](std::int64_t d) { return static_cast<double>(at(gi + d, gj, dz)); }),
          difference(gj, ny, [&](std::int64_t d) { return static_cast<double>(at(gi, gj + d, dz)); }),
          difference(z + dz, nz, [&](std::int64_t d) { return static_cast<double>(at(gi, gj, dz + d)); })};
}

}  // namespace isoslab
