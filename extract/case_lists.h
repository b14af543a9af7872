// The case lists of a lattice method: for each cell variant (Marching Cubes has one; the
// tetrahedral schemes one per decomposition variant), the distinct lattice edges its triangles can
// cut and, per node case, the triangles as indices into them. Built once per extractor; the
// tetrahedral cases on first use (bcc12's interior variant has 4096, most never seen).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <vector>

#include "extract/cell_schemes.h"

namespace isoslab {

/// A lattice edge as seen from a cell: its two nodes (a is the lower endpoint, ordered by z, then
/// y, then x), and where its vertex id lives: anchor plane 0 (slice z), 1 (the cube-centre plane)
/// or 2 (slice z+1), and the offset of its slot in that plane's welding cache relative to the
/// cell's (i, j). A plane's cache interleaves its edge classes (slot = (j * nx + i) * classes +
/// class), so that a cell's edges share cache lines.
struct EdgeRef {
  std::uint8_t a = 0;
  std::uint8_t b = 0;
  std::uint8_t plane = 0;
  /// On plane 0, whether the slab below has this edge too (as a plane-2 edge of the same class):
  /// true for edges in slice z, false for those rising from it.
  bool shared = false;
  /// No other cell has this edge: it runs through the cell's interior (mt6's main diagonal, mt24's
  /// edges from the cube centre), so its vertex needs no welding-cache slot.
  bool cellOnly = false;
  /// mc33: 1 + m for the cell's point m (placed at the mean of some of the cell's cut points;
  /// a and b are unused), 0 for a lattice edge.
  std::uint8_t cellPoint = 0;
  std::size_t edgeClass = 0;
  std::int64_t cell = 0;    // lattice offset of the lower endpoint's anchor from the cell's (i, j)
  std::int64_t stride = 0;  // classes of the plane
  std::int64_t offset = 0;  // cell * stride + edgeClass

  /// The edge's slot in its plane's cache for cell (i, j) of a lattice nx points wide.
  std::int64_t slot(std::int64_t i, std::int64_t j, std::int64_t nx) const noexcept {
    return offset + (j * nx + i) * stride;
  }
};

struct TetRef {
  std::array<std::uint8_t, 4> nodes{};
  double volume = 0;  // in voxel units
};

/// The most distinct edges one case can cut (bcc12's interior cell has fewer lattice edges).
constexpr std::size_t kMaxCaseEdges = 64;

/// The most points inside one cell that an mc33 case uses (mc33_table.h).
constexpr std::size_t kMaxCellPoints = 2;

/// One cell variant: its tetrahedra (none for Marching Cubes), edges and cases.
struct CaseList {
  std::vector<TetRef> tets;
  std::uint32_t nodeMask = 0;  // nodes whose values the variant reads
  double volume = 0;
  /// The distinct edges of the cell (Marching Cubes) or of its tetrahedra.
  std::vector<EdgeRef> edges;
  /// Per tetrahedron, its six edges as indices into `edges`.
  std::vector<std::array<std::uint8_t, 6>> tetEdges;
  /// Per node case: the distinct edges its triangles cut, in order of first use (indices into
  /// `edges`), and the triangles in the order the tetrahedra emit them, as indices into that list.
  /// A cell then looks each vertex up once, however many triangles share it.
  struct CaseSpan {
    std::int32_t firstEdge = -1;  // into caseEdges; -1: not built yet
    std::int32_t firstTriangle = 0;
    std::uint8_t edgeCount = 0;
    std::uint8_t triangleCount = 0;
  };
  std::vector<CaseSpan> cases;
  std::vector<std::uint8_t> caseEdges;
  std::vector<std::array<std::uint8_t, 3>> caseTriangles;

  /// Records a case's triangles (given as indices into `edges`).
  void addCase(unsigned key, const std::vector<std::array<std::uint8_t, 3>>& triangles);
  /// Builds case `key` from the tetrahedra unless it is built already.
  void ensureCase(unsigned key) {
    if (cases[key].firstEdge < 0) buildCase(key);
  }

 private:
  void buildCase(unsigned key);
};

/// The nodes, edge classes and case lists of a method on a lattice nx points wide.
class CellCases {
 public:
  /// `scheme` null means Marching Cubes, and `mc33` adds its topologically correct variant.
  /// Throws std::logic_error for a scheme variant with more than kMaxCaseEdges edges (a table
  /// defect, caught by the tests).
  CellCases(const CellScheme* scheme, std::int64_t nx, bool mc33 = false);

  const std::vector<LatticeNode>& nodes() const noexcept { return nodes_; }
  /// Marching Cubes as one variant whose cases come from mc_table.h.
  const CaseList& marchingCubes() const noexcept { return mc_; }
  /// mc33's cases by mc33::cellKey: the 12 cube edges, then its cell points; built on first use.
  const CaseList& marchingCubes33() const noexcept { return mc33_; }
  void ensureMc33Case(unsigned key) {
    if (mc33_.cases[key].firstEdge < 0) buildMc33Case(key);
  }
  /// Per cell point of case `key` (built), the cube edges whose cut points' mean places it.
  const std::uint16_t* mc33CellPoints(unsigned key) const noexcept { return mc33Points_[key].data(); }
  std::vector<CaseList>& variants() noexcept { return variants_; }
  const std::vector<CaseList>& variants() const noexcept { return variants_; }
  /// Edge classes anchored on the slice planes (0 and 2) and on the centre plane (1).
  std::size_t sliceClasses() const noexcept { return evenClasses_.size(); }
  std::size_t centreClasses() const noexcept { return oddClasses_.size(); }

 private:
  EdgeRef makeEdge(int a, int b, bool cellOnly = false);
  void buildMc33Case(unsigned key);
  void markSharedEdges();

  std::int64_t nx_ = 0;
  std::vector<LatticeNode> nodes_;
  CaseList mc_;
  CaseList mc33_;
  std::vector<std::array<std::uint16_t, kMaxCellPoints>> mc33Points_;
  std::vector<CaseList> variants_;
  /// Edge classes by the lower endpoint's parity in x and y and the edge's direction: (anchor
  /// lattice point, parity) names one half-lattice point, so (anchor, parity, direction) names one
  /// edge. Numbered in order of first use.
  std::map<std::array<int, 5>, std::size_t> evenClasses_;
  std::map<std::array<int, 5>, std::size_t> oddClasses_;
};

}  // namespace isoslab
