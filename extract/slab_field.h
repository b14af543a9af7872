// The scalar field around one slab: node positions and gradients in lattice coordinates, from the
// slices z - 1 .. z + 2 that the slab view holds.
#pragma once

#include <array>
#include <cstdint>

#include "extract/cell_schemes.h"
#include "extract/frame.h"

namespace isoslab {

struct SlabField {
  /// Slices z - 1, z, z + 1, z + 2 (SlabView::slices).
  std::array<const float*, 4> slices{};
  std::int64_t nx = 0, ny = 0, nz = 0;
  std::int64_t z = 0;
  /// Lattice points on each side of every axis that lie outside the volume (1 with
  /// ExtractOptions::closeBoundary): differences are one-sided at the volume's own faces.
  std::int64_t pad = 0;

  /// Value at global lattice point (gi, gj) of slice z + dz, dz in -1..2.
  float at(std::int64_t gi, std::int64_t gj, std::int64_t dz) const noexcept {
    return slices[static_cast<std::size_t>(dz + 1)][gj * nx + gi];
  }

  /// Lattice position of `node` of cell (i, j, z).
  Vec3d position(const LatticeNode& node, std::int64_t i, std::int64_t j) const noexcept {
    return {static_cast<double>(i) + 0.5 * node.hx, static_cast<double>(j) + 0.5 * node.hy,
            static_cast<double>(z) + 0.5 * node.hz};
  }

  /// Gradient of the field at `node` of cell (i, j, z), with respect to lattice coordinates.
  /// Corners: central differences, one-sided at the volume's faces. Cube centres: the gradient of
  /// the trilinear interpolant of the centre's cell, taken at the centre (the mean of the cell's
  /// four edge differences per axis). Face centres: the mean of the face's four corners' gradients.
  Vec3d gradient(const LatticeNode& node, std::int64_t i, std::int64_t j) const noexcept;
};

}  // namespace isoslab
