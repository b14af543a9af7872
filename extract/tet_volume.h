// The part of a tetrahedron inside the iso-surface, for the tetrahedral methods' per-cell volume
// (the paper's section F).
#pragma once

#include <array>

namespace isoslab {

/// The inside part of a tetrahedron of `volume` whose node values are `values`, in node case `cas`
/// (bit k set when node k is inside; neither 0 nor 15), in the units of `volume`.
///
/// Linear interpolation makes the surface inside a tetrahedron a plane, so the inside part is a
/// small tetrahedron (one node inside), the rest of the tetrahedron (three inside) or a triangular
/// prism (two and two), cut into three tetrahedra. With s the fraction of an edge from its inside
/// node to its outside node where the surface cuts it: one node a inside: V s_ab s_ac s_ad; three
/// inside: V minus the one-outside part; two (a, b) and two (c, d): V (u v (1 - x) + u x (1 - w) +
/// w x) with u, v, w, x the fractions on a-c, a-d, b-c, b-d (the prism cut into the tetrahedra
/// (a, ac, ad, bd), (a, ac, bc, bd), (a, b, bc, bd), whose volumes in barycentric coordinates are
/// those three terms).
double tetInsideVolume(const std::array<double, 4>& values, double volume, unsigned cas, double iso) noexcept;

}  // namespace isoslab
