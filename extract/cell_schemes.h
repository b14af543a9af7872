// Decompositions of a lattice cell into tetrahedra, for the tetrahedral methods. Built in code from
// their definitions (see cell_schemes.cpp) and tested in tests/extract/tables_test.cpp.
//
// A node is a lattice point given in half-voxel units relative to the cell's lowest corner: the
// corners have offsets 0 or 2 per axis, cube centres odd offsets on all three axes (1 for the
// cell's own centre, 3 for the centre of the next cell along that axis), face centres odd offsets on
// exactly two axes. Nodes 0..7 are always the corners, numbered as in mc_table.h.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace isoslab {

struct LatticeNode {
  std::int8_t hx = 0;
  std::int8_t hy = 0;
  std::int8_t hz = 0;
  int oddAxes() const noexcept { return (hx & 1) + (hy & 1) + (hz & 1); }
  /// A cube centre: odd on all three axes.
  bool isCentre() const noexcept { return oddAxes() == 3; }
  /// A face centre: odd on exactly two axes.
  bool isFaceCentre() const noexcept { return oddAxes() == 2; }
};

struct Tetrahedron {
  /// Node indices, ordered so that the signed volume is positive.
  std::array<std::uint8_t, 4> nodes{};
};

/// How a cell picks its variant of the decomposition.
enum class VariantRule : std::uint8_t {
  kSingle,    // one decomposition everywhere (mt6)
  kParity,    // variant (i + j + k) & 1 (mt5)
  kBoundary,  // variant = bits of the volume faces the cell touches (bcc12): 1 x-min, 2 x-max,
              // 4 y-min, 8 y-max, 16 z-min, 32 z-max
};

/// Where the values of the nodes beyond the eight corners come from.
enum class NodeValues : std::uint8_t {
  kCorners,           // there are none (mt5, mt6)
  kNeighbourCentres,  // cube centres of the cell and of its +x, +y, +z neighbours (bcc12)
  kOwnCentres,        // the cell's own face and cube centres, means of its corners (mt24)
};

struct CellScheme {
  std::string name;
  std::vector<LatticeNode> nodes;
  VariantRule rule = VariantRule::kSingle;
  NodeValues values = NodeValues::kCorners;
  std::vector<std::vector<Tetrahedron>> variants;
};

/// Five tetrahedra: four corner tetrahedra and a central one of twice their volume. Variant 0 (even
/// i+j+k) cuts off corners 1, 2, 4, 7; variant 1 cuts off 0, 3, 5, 6, so that every face diagonal
/// joins lattice points of even i+j+k and neighbouring cells agree.
CellScheme makeTetra5Scheme();

/// Six tetrahedra around the main diagonal from corner 0 to corner 7: one per path 0 -> one step ->
/// two steps -> 7 along the axes. Every face is split along the diagonal through its lowest corner.
CellScheme makeTetra6Scheme();

/// Chan and Purisima's body-centred cubic tessellation: for each of the cell's +x, +y, +z faces,
/// the four tetrahedra joining the cell's centre and the neighbour's centre with one face edge; a
/// face on the volume boundary is instead covered by the two tetrahedra of the pyramid from the
/// cell's centre to that face, split along the face's diagonal through its lowest corner (as mt6
/// splits it). Nodes 8..11: own centre, +x, +y and +z neighbour centres.
CellScheme makeBcc12Scheme();

/// Twenty-four tetrahedra: the cube is cut into six pyramids from its centre, one on each face,
/// and each pyramid into four tetrahedra through its face centre (cube centre, face centre and the
/// two ends of one face edge). A face centre's value is the mean of the face's four corners and the
/// cube centre's the mean of the eight, so neighbouring cells cut their shared face into the same
/// four triangles with the same values. Nodes 8..13: the x-min, x-max, y-min, y-max, z-min and
/// z-max face centres (node 8 + 2 * axis + side); node 14: the cube centre.
CellScheme makeTetra24Scheme();

/// Six times the signed volume of the tetrahedron, in half-voxel units cubed (1 voxel^3 = 8).
int signedVolume6(const LatticeNode& a, const LatticeNode& b, const LatticeNode& c, const LatticeNode& d) noexcept;

}  // namespace isoslab
