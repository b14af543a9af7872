// Three-vectors of doubles for geometry (directions, positions, gradients), with the few
// operations the readers and the frame need.
#pragma once

#include <array>
#include <cmath>

namespace isoslab {

using Vec3d = std::array<double, 3>;

inline double dot(const Vec3d& a, const Vec3d& b) noexcept {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
inline Vec3d cross(const Vec3d& a, const Vec3d& b) noexcept {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline double norm(const Vec3d& a) noexcept {
  return std::sqrt(dot(a, a));
}

}  // namespace isoslab
