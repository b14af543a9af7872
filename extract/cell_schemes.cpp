// Tetrahedral decompositions of the cubic cell.
//
// mt5 and mt6: the classic 5- and 6-tetrahedra splits compared by V. Skala and A. Brus, "Two methods
// for iso-surface extraction from volumetric data and their comparison".
// bcc12: C.-S. Chan and E. O. Purisima, "A new tetrahedral tesselation scheme for isosurface
// generation", Computers & Graphics 22(1), 1998.
#include "extract/cell_schemes.h"

#include <algorithm>
#include <utility>

namespace isoslab {
namespace {

LatticeNode cornerNode(int c) {
  return {static_cast<std::int8_t>(2 * (c & 1)), static_cast<std::int8_t>(2 * ((c >> 1) & 1)),
          static_cast<std::int8_t>(2 * ((c >> 2) & 1))};
}

// Adds tetrahedron (a, b, c, d) with its nodes reordered to a positive signed volume.
void addTet(CellScheme& s, std::vector<Tetrahedron>& list, int a, int b, int c, int d) {
  const auto& n = s.nodes;
  if (signedVolume6(n[static_cast<std::size_t>(a)], n[static_cast<std::size_t>(b)], n[static_cast<std::size_t>(c)],
                    n[static_cast<std::size_t>(d)]) < 0) {
    std::swap(c, d);
  }
  list.push_back({{static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b), static_cast<std::uint8_t>(c),
                   static_cast<std::uint8_t>(d)}});
}

// The corners of the cell's face (axis, side) in cyclic order (u, v) = (0,0), (1,0), (1,1), (0,1),
// with u = (axis + 1) % 3 and v = (axis + 2) % 3.
std::array<int, 4> faceRing(int axis, int side) {
  const int u = 1 << ((axis + 1) % 3);
  const int v = 1 << ((axis + 2) % 3);
  const int base = side << axis;
  return {base, base | u, base | u | v, base | v};
}

void addCorners(CellScheme& s) {
  for (int c = 0; c < 8; ++c) s.nodes.push_back(cornerNode(c));
}

}  // namespace

int signedVolume6(const LatticeNode& a, const LatticeNode& b, const LatticeNode& c, const LatticeNode& d) noexcept {
  const int ux = b.hx - a.hx, uy = b.hy - a.hy, uz = b.hz - a.hz;
  const int vx = c.hx - a.hx, vy = c.hy - a.hy, vz = c.hz - a.hz;
  const int wx = d.hx - a.hx, wy = d.hy - a.hy, wz = d.hz - a.hz;
  return ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx);
}

CellScheme makeTetra5Scheme() {
  CellScheme s;
  s.name = "mt5";
  s.rule = VariantRule::kParity;
  addCorners(s);
  s.variants.resize(2);
  for (int parity = 0; parity < 2; ++parity) {
    // Corners whose bit count has the cell's parity are the central tetrahedron's.
    std::vector<int> central;
    std::vector<int> cut;
    for (int c = 0; c < 8; ++c) {
      const int bits = (c & 1) + ((c >> 1) & 1) + ((c >> 2) & 1);
      ((bits & 1) == parity ? central : cut).push_back(c);
    }
    for (int c : cut) addTet(s, s.variants[static_cast<std::size_t>(parity)], c, c ^ 1, c ^ 2, c ^ 4);
    addTet(s, s.variants[static_cast<std::size_t>(parity)], central[0], central[1], central[2], central[3]);
  }
  return s;
}

CellScheme makeTetra6Scheme() {
  CellScheme s;
  s.name = "mt6";
  s.rule = VariantRule::kSingle;
  addCorners(s);
  s.variants.resize(1);
  std::array<int, 3> axes{0, 1, 2};
  do {
    const int first = 1 << axes[0];
    const int second = first | (1 << axes[1]);
    addTet(s, s.variants[0], 0, first, second, 7);
  } while (std::next_permutation(axes.begin(), axes.end()));
  return s;
}

CellScheme makeBcc12Scheme() {
  CellScheme s;
  s.name = "bcc12";
  s.rule = VariantRule::kBoundary;
  s.values = NodeValues::kNeighbourCentres;
  addCorners(s);
  constexpr int kOwnCentre = 8;
  s.nodes.push_back({1, 1, 1});  // 8: own centre
  s.nodes.push_back({3, 1, 1});  // 9: +x neighbour's centre
  s.nodes.push_back({1, 3, 1});  // 10: +y
  s.nodes.push_back({1, 1, 3});  // 11: +z
  s.variants.resize(64);
  for (int mask = 0; mask < 64; ++mask) {
    auto& list = s.variants[static_cast<std::size_t>(mask)];
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = 0; side < 2; ++side) {
        const bool onBoundary = ((mask >> (2 * axis + side)) & 1) != 0;
        // The -axis face belongs to the previous cell unless it is on the volume boundary.
        if (side == 0 && !onBoundary) continue;
        const std::array<int, 4> fc = faceRing(axis, side);
        if (onBoundary) {
          // Pyramid from the own centre, split along the diagonal fc[0]-fc[2].
          addTet(s, list, kOwnCentre, fc[0], fc[1], fc[2]);
          addTet(s, list, kOwnCentre, fc[0], fc[2], fc[3]);
        } else {
          const int neighbour = 9 + axis;
          for (int m = 0; m < 4; ++m) addTet(s, list, kOwnCentre, neighbour, fc[m], fc[(m + 1) % 4]);
        }
      }
    }
  }
  return s;
}

CellScheme makeTetra24Scheme() {
  CellScheme s;
  s.name = "mt24";
  s.rule = VariantRule::kSingle;
  s.values = NodeValues::kOwnCentres;
  addCorners(s);
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      std::array<std::int8_t, 3> h{1, 1, 1};
      h[static_cast<std::size_t>(axis)] = static_cast<std::int8_t>(2 * side);
      s.nodes.push_back({h[0], h[1], h[2]});  // 8 + 2 * axis + side
    }
  }
  constexpr int kCubeCentre = 14;
  s.nodes.push_back({1, 1, 1});
  s.variants.resize(1);
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const std::array<int, 4> fc = faceRing(axis, side);
      const int faceCentre = 8 + 2 * axis + side;
      for (int m = 0; m < 4; ++m) addTet(s, s.variants[0], kCubeCentre, faceCentre, fc[m], fc[(m + 1) % 4]);
    }
  }
  return s;
}

}  // namespace isoslab
