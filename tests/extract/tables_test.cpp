#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "extract/case_lists.h"
#include "extract/cell_schemes.h"
#include "extract/mc_table.h"
#include "extract/tet_table.h"

namespace isoslab {
namespace {

int coord(int corner, int axis) {
  return (corner >> axis) & 1;
}

// Edges of face (axis, side).
std::set<int> faceEdges(int axis, int side) {
  std::set<int> edges;
  for (int e = 0; e < 12; ++e) {
    const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
    if (coord(c[0], axis) == side && coord(c[1], axis) == side) edges.insert(e);
  }
  return edges;
}

TEST(McTable, EdgesAreTheTwelveCubeEdges) {
  std::set<std::pair<int, int>> seen;
  for (const auto& e : mc::kEdgeCorners) {
    EXPECT_LT(e[0], e[1]);
    EXPECT_EQ(__builtin_popcount(e[0] ^ e[1]), 1);
    seen.insert({e[0], e[1]});
  }
  EXPECT_EQ(seen.size(), 12u);
}

TEST(McTable, TrianglesUseExactlyTheCrossedEdges) {
  for (int cas = 0; cas < 256; ++cas) {
    std::uint16_t crossed = 0;
    for (int e = 0; e < 12; ++e) {
      const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
      if (((cas >> c[0]) & 1) != ((cas >> c[1]) & 1)) crossed |= static_cast<std::uint16_t>(1u << e);
    }
    EXPECT_EQ(mc::kCaseTable.edgeMask[cas], crossed) << "case " << cas;
  }
  EXPECT_EQ(mc::kCaseTable.triangleCount[0], 0);
  EXPECT_EQ(mc::kCaseTable.triangleCount[255], 0);
  // The classic counts: one triangle for one corner, two for an edge or a face's worth.
  EXPECT_EQ(mc::kCaseTable.triangleCount[1], 1);
  EXPECT_EQ(mc::kCaseTable.triangleCount[3], 2);
  EXPECT_EQ(mc::kCaseTable.triangleCount[0x0f], 2);
}

// Within a cell, each piece of surface is a disk bounded by segments on the faces: a face segment
// is used by one triangle, an interior diagonal by two with opposite directions, and no triangle
// edge joins two points of one face unless it is a face segment.
TEST(McTable, EveryCaseIsAnOrientedSurfaceWithBoundaryOnTheFaces) {
  for (int cas = 1; cas < 255; ++cas) {
    std::map<std::pair<int, int>, int> directed;
    const int n = mc::kCaseTable.triangleCount[cas];
    for (int t = 0; t < n; ++t) {
      const auto& tri = mc::kCaseTable.triangles[cas][static_cast<std::size_t>(t)];
      for (int k = 0; k < 3; ++k) ++directed[{tri[k], tri[(k + 1) % 3]}];
    }
    for (const auto& [edge, uses] : directed) {
      EXPECT_EQ(uses, 1) << "case " << cas;
      const bool reverse = directed.contains({edge.second, edge.first});
      bool onFace = false;
      for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
          const auto f = faceEdges(axis, side);
          onFace |= f.contains(edge.first) && f.contains(edge.second);
        }
      }
      EXPECT_NE(reverse, onFace) << "case " << cas << " edge " << edge.first << "-" << edge.second;
    }
  }
}

// Two cells sharing a face cut it with the same segments (in opposite directions): no cracks.
TEST(McTable, NeighboursAgreeOnEveryFaceIncludingAmbiguousOnes) {
  auto segments = [](int cas, int axis, int side) {
    std::set<std::pair<int, int>> segs;  // directed, as pairs of face-local edge keys
    const auto f = faceEdges(axis, side);
    const int n = mc::kCaseTable.triangleCount[cas];
    for (int t = 0; t < n; ++t) {
      const auto& tri = mc::kCaseTable.triangles[cas][static_cast<std::size_t>(t)];
      for (int k = 0; k < 3; ++k) {
        const int a = tri[k], b = tri[(k + 1) % 3];
        if (!f.contains(a) || !f.contains(b)) continue;
        // Key an edge by its corners with the face axis bit cleared, so both cells agree.
        auto key = [axis](int e) {
          const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
          return (c[0] & ~(1 << axis)) * 8 + (c[1] & ~(1 << axis));
        };
        segs.insert({key(a), key(b)});
      }
    }
    return segs;
  };
  int ambiguous = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int lower = 0; lower < 256; ++lower) {
      for (int upper = 0; upper < 256; ++upper) {
        // The lower cell's side-1 corners are the upper cell's side-0 corners.
        bool match = true;
        for (int c = 0; c < 8; ++c) {
          if (coord(c, axis) == 1 && ((lower >> c) & 1) != ((upper >> (c & ~(1 << axis))) & 1)) match = false;
        }
        if (!match) continue;
        const auto a = segments(lower, axis, 1);
        const auto b = segments(upper, axis, 0);
        std::set<std::pair<int, int>> reversed;
        for (const auto& s : b) reversed.insert({s.second, s.first});
        ASSERT_EQ(a, reversed) << "axis " << axis << " cases " << lower << " " << upper;
        ambiguous += a.size() == 2 ? 1 : 0;
      }
    }
  }
  EXPECT_GT(ambiguous, 0);
}

TEST(McTable, CornerCaseNormalPointsAwayFromTheInsideCorner) {
  // Case 1: corner 0 inside. Triangle on edge midpoints; its normal must point to (+,+,+).
  const auto& tri = mc::kCaseTable.triangles[1][0];
  double p[3][3];
  for (int k = 0; k < 3; ++k) {
    const auto& c = mc::kEdgeCorners[tri[k]];
    for (int a = 0; a < 3; ++a) p[k][a] = 0.5 * (coord(c[0], a) + coord(c[1], a));
  }
  const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
  const double v[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
  const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  EXPECT_GT(n[0] + n[1] + n[2], 0);
}

TEST(TetTable, CasesHaveOneOrTwoTrianglesFacingTheOutsideNodes) {
  const double node[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int cas = 0; cas < 16; ++cas) {
    const int inside = __builtin_popcount(static_cast<unsigned>(cas));
    const int expected = (inside == 0 || inside == 4) ? 0 : (inside == 2 ? 2 : 1);
    ASSERT_EQ(tet::kTetCases.triangleCount[cas], expected) << cas;
    for (int t = 0; t < expected; ++t) {
      const auto& tri = tet::kTetCases.triangles[cas][static_cast<std::size_t>(t)];
      double p[3][3];
      for (int k = 0; k < 3; ++k) {
        const auto& e = tet::kTetEdges[tri[k]];
        // Both endpoints of a used edge differ in state.
        EXPECT_NE((cas >> e[0]) & 1, (cas >> e[1]) & 1);
        for (int a = 0; a < 3; ++a) p[k][a] = 0.5 * (node[e[0]][a] + node[e[1]][a]);
      }
      const double u[3] = {p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
      const double v[3] = {p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
      const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
      // Every outside node lies on the normal's side of the triangle's plane.
      for (int k = 0; k < 4; ++k) {
        const double d = (node[k][0] - p[0][0]) * n[0] + (node[k][1] - p[0][1]) * n[1] + (node[k][2] - p[0][2]) * n[2];
        if ((cas >> k) & 1) {
          EXPECT_LT(d, 1e-12) << "case " << cas;
        } else {
          EXPECT_GT(d, -1e-12) << "case " << cas;
        }
      }
    }
  }
}

// Tetrahedra of a scheme, in half-voxel coordinates relative to cell (ci, cj, ck).
struct PlacedTet {
  std::array<std::array<double, 3>, 4> p;
};

std::vector<PlacedTet> place(const CellScheme& s, const std::vector<Tetrahedron>& tets, int ci, int cj, int ck) {
  std::vector<PlacedTet> out;
  for (const Tetrahedron& t : tets) {
    PlacedTet pt;
    for (int k = 0; k < 4; ++k) {
      const LatticeNode& n = s.nodes[t.nodes[static_cast<std::size_t>(k)]];
      pt.p[static_cast<std::size_t>(k)] = {ci + 0.5 * n.hx, cj + 0.5 * n.hy, ck + 0.5 * n.hz};
    }
    out.push_back(pt);
  }
  return out;
}

bool contains(const PlacedTet& t, const std::array<double, 3>& q) {
  auto det = [](const std::array<double, 3>& a, const std::array<double, 3>& b, const std::array<double, 3>& c,
                const std::array<double, 3>& d) {
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
  };
  const double total = det(t.p[0], t.p[1], t.p[2], t.p[3]);
  double sum = 0;
  for (int k = 0; k < 4; ++k) {
    auto r = t.p;
    r[static_cast<std::size_t>(k)] = q;
    const double part = det(r[0], r[1], r[2], r[3]);
    if (part / total < 0) return false;
    sum += part;
  }
  return std::abs(sum - total) < 1e-9;
}

int sv6(const CellScheme& s, const Tetrahedron& t) {
  return signedVolume6(s.nodes[t.nodes[0]], s.nodes[t.nodes[1]], s.nodes[t.nodes[2]], s.nodes[t.nodes[3]]);
}

TEST(CellSchemes, Mt5AndMt6FillTheCubeWithPositiveTetrahedra) {
  for (const CellScheme& s : {makeTetra5Scheme(), makeTetra6Scheme()}) {
    for (const auto& variant : s.variants) {
      int sum = 0;
      for (const Tetrahedron& t : variant) {
        EXPECT_GT(sv6(s, t), 0) << s.name;
        sum += sv6(s, t);
      }
      EXPECT_EQ(sum, 48) << s.name;  // 6 x (2 half-units)^3
      // Random points of the cube lie in exactly one tetrahedron.
      std::mt19937 rng(5);
      std::uniform_real_distribution<double> u(0.001, 0.999);
      const auto placed = place(s, variant, 0, 0, 0);
      for (int n = 0; n < 2000; ++n) {
        const std::array<double, 3> q{u(rng), u(rng), u(rng)};
        int in = 0;
        for (const auto& t : placed) in += contains(t, q) ? 1 : 0;
        ASSERT_EQ(in, 1) << s.name;
      }
    }
  }
  EXPECT_EQ(makeTetra5Scheme().variants[0].size(), 5u);
  EXPECT_EQ(makeTetra6Scheme().variants[0].size(), 6u);
}

TEST(CellSchemes, Mt6TetrahedraAllShareTheMainDiagonal) {
  const CellScheme s = makeTetra6Scheme();
  for (const Tetrahedron& t : s.variants[0]) {
    const std::set<int> nodes(t.nodes.begin(), t.nodes.end());
    EXPECT_TRUE(nodes.contains(0) && nodes.contains(7));
  }
}

// The diagonals a scheme draws on the face (axis, side) of a cell, in global half-unit coordinates.
std::set<std::pair<std::array<int, 3>, std::array<int, 3>>> faceDiagonals(const CellScheme& s,
                                                                          const std::vector<Tetrahedron>& tets,
                                                                          int axis, int side, std::array<int, 3> cell) {
  std::set<std::pair<std::array<int, 3>, std::array<int, 3>>> out;
  for (const Tetrahedron& t : tets) {
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        const LatticeNode& na = s.nodes[t.nodes[static_cast<std::size_t>(a)]];
        const LatticeNode& nb = s.nodes[t.nodes[static_cast<std::size_t>(b)]];
        const int ha[3] = {na.hx, na.hy, na.hz};
        const int hb[3] = {nb.hx, nb.hy, nb.hz};
        if (ha[axis] != 2 * side || hb[axis] != 2 * side) continue;
        int differ = 0;
        for (int k = 0; k < 3; ++k) differ += ha[k] != hb[k] ? 1 : 0;
        if (differ != 2) continue;
        std::array<int, 3> ga{}, gb{};
        for (int k = 0; k < 3; ++k) {
          ga[static_cast<std::size_t>(k)] = 2 * cell[static_cast<std::size_t>(k)] + ha[k];
          gb[static_cast<std::size_t>(k)] = 2 * cell[static_cast<std::size_t>(k)] + hb[k];
        }
        out.insert({std::min(ga, gb), std::max(ga, gb)});
      }
    }
  }
  return out;
}

TEST(CellSchemes, NeighbouringCellsSplitSharedFacesTheSameWay) {
  for (const CellScheme& s : {makeTetra5Scheme(), makeTetra6Scheme()}) {
    for (int axis = 0; axis < 3; ++axis) {
      for (int parity = 0; parity < 2; ++parity) {
        const auto& lower = s.variants[s.rule == VariantRule::kParity ? static_cast<std::size_t>(parity) : 0];
        const auto& upper = s.variants[s.rule == VariantRule::kParity ? static_cast<std::size_t>(1 - parity) : 0];
        std::array<int, 3> next{0, 0, 0};
        next[static_cast<std::size_t>(axis)] = 1;
        const auto a = faceDiagonals(s, lower, axis, 1, {0, 0, 0});
        const auto b = faceDiagonals(s, upper, axis, 0, next);
        EXPECT_EQ(a.size(), 1u) << s.name;
        EXPECT_EQ(a, b) << s.name << " axis " << axis << " parity " << parity;
      }
    }
  }
}

TEST(CellSchemes, Bcc12TetrahedraAreCongruentAndTwelvePerInteriorCell) {
  const CellScheme s = makeBcc12Scheme();
  ASSERT_EQ(s.variants.size(), 64u);
  EXPECT_EQ(s.variants[0].size(), 12u);
  int sum = 0;
  for (const Tetrahedron& t : s.variants[0]) {
    EXPECT_EQ(sv6(s, t), 4);  // a twelfth of the cell: 6 x 8 / 12
    sum += sv6(s, t);
    std::multiset<int> lengths;  // squared edge lengths in half-units
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        const LatticeNode& na = s.nodes[t.nodes[static_cast<std::size_t>(a)]];
        const LatticeNode& nb = s.nodes[t.nodes[static_cast<std::size_t>(b)]];
        lengths.insert((na.hx - nb.hx) * (na.hx - nb.hx) + (na.hy - nb.hy) * (na.hy - nb.hy) +
                       (na.hz - nb.hz) * (na.hz - nb.hz));
      }
    }
    // Centre-centre and face edge: 2 (a voxel); the four centre-corner edges: sqrt(3) half-units.
    EXPECT_EQ(lengths, (std::multiset<int>{3, 3, 3, 3, 4, 4}));
  }
  EXPECT_EQ(sum, 48);
}

TEST(CellSchemes, Bcc12TilesABlockOfCellsExactlyOnce) {
  const CellScheme s = makeBcc12Scheme();
  const int n = 3;  // 3 x 3 x 3 cells, every kind of boundary
  std::vector<PlacedTet> all;
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const int mask = (i == 0 ? 1 : 0) | (i == n - 1 ? 2 : 0) | (j == 0 ? 4 : 0) | (j == n - 1 ? 8 : 0) |
                         (k == 0 ? 16 : 0) | (k == n - 1 ? 32 : 0);
        for (const Tetrahedron& t : s.variants[static_cast<std::size_t>(mask)]) EXPECT_GT(sv6(s, t), 0);
        const auto placed = place(s, s.variants[static_cast<std::size_t>(mask)], i, j, k);
        all.insert(all.end(), placed.begin(), placed.end());
      }
    }
  }
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0.0005, n - 0.0005);
  for (int m = 0; m < 3000; ++m) {
    const std::array<double, 3> q{u(rng), u(rng), u(rng)};
    int in = 0;
    for (const auto& t : all) in += contains(t, q) ? 1 : 0;
    ASSERT_EQ(in, 1) << q[0] << " " << q[1] << " " << q[2];
  }
}

// An edge marked cellOnly takes no welding slot, so no other cell may have it: in a block of
// cells, each cellOnly edge of a cell is an edge of no other cell's tetrahedra.
TEST(CaseLists, CellOnlyEdgesBelongToOneCell) {
  for (const CellScheme& s : {makeTetra5Scheme(), makeTetra6Scheme(), makeBcc12Scheme(), makeTetra24Scheme()}) {
    const CellCases cases(&s, 8);
    using Point = std::array<int, 3>;
    std::map<std::pair<Point, Point>, std::set<int>> cellsOf;  // global edge -> cells having it
    std::set<std::pair<Point, Point>> cellOnly;
    int onlyCount = 0;
    for (int c = 0; c < 27; ++c) {
      const int ci = c % 3, cj = c / 3 % 3, ck = c / 9;
      const auto& v = cases.variants()[0];  // bcc12's interior variant: every face shared
      for (const EdgeRef& e : v.edges) {
        auto global = [&](int n) {
          const LatticeNode& node = cases.nodes()[static_cast<std::size_t>(n)];
          return Point{2 * ci + node.hx, 2 * cj + node.hy, 2 * ck + node.hz};
        };
        const std::pair<Point, Point> edge{std::min(global(e.a), global(e.b)), std::max(global(e.a), global(e.b))};
        cellsOf[edge].insert(c);
        if (e.cellOnly) cellOnly.insert(edge), ++onlyCount;
      }
    }
    for (const auto& edge : cellOnly) EXPECT_EQ(cellsOf[edge].size(), 1u) << s.name;
    const int perCell = onlyCount / 27;
    EXPECT_EQ(perCell, s.name == "mt6" ? 1 : s.name == "mt24" ? 14 : 0) << s.name;
  }
}

// mt24 (the paper's 24 tetrahedra per cube, after Baxter et al.): 24 tetrahedra of equal volume
// tile the cube, and a 2 x 2 x 2 block of cells exactly once.
TEST(CellSchemes, Mt24TilesTheCubeAndABlockOfCells) {
  const CellScheme s = makeTetra24Scheme();
  ASSERT_EQ(s.variants.size(), 1u);
  ASSERT_EQ(s.variants[0].size(), 24u);
  ASSERT_EQ(s.nodes.size(), 15u);
  int sum = 0;
  for (const Tetrahedron& t : s.variants[0]) {
    EXPECT_EQ(sv6(s, t), 2);  // a 24th of the cell: 6 x 8 / 24
    sum += sv6(s, t);
  }
  EXPECT_EQ(sum, 48);
  std::vector<PlacedTet> all;
  for (int c = 0; c < 8; ++c) {
    const auto placed = place(s, s.variants[0], c & 1, (c >> 1) & 1, (c >> 2) & 1);
    all.insert(all.end(), placed.begin(), placed.end());
  }
  std::mt19937 rng(24);
  std::uniform_real_distribution<double> u(0.0005, 1.9995);
  for (int m = 0; m < 3000; ++m) {
    const std::array<double, 3> q{u(rng), u(rng), u(rng)};
    int in = 0;
    for (const auto& t : all) in += contains(t, q) ? 1 : 0;
    ASSERT_EQ(in, 1) << q[0] << " " << q[1] << " " << q[2];
  }
}

// The triangles (tetrahedron faces) a scheme draws on the face (axis, side) of a cell, each as its
// three nodes in global half-unit coordinates.
std::set<std::set<std::array<int, 3>>> faceTriangles(const CellScheme& s, int axis, int side, std::array<int, 3> cell) {
  std::set<std::set<std::array<int, 3>>> out;
  for (const Tetrahedron& t : s.variants[0]) {
    for (int skip = 0; skip < 4; ++skip) {
      std::set<std::array<int, 3>> tri;
      for (int k = 0; k < 4; ++k) {
        if (k == skip) continue;
        const LatticeNode& n = s.nodes[t.nodes[static_cast<std::size_t>(k)]];
        const std::array<int, 3> h{n.hx, n.hy, n.hz};
        if (h[static_cast<std::size_t>(axis)] != 2 * side) break;
        std::array<int, 3> g{};
        for (std::size_t a = 0; a < 3; ++a) g[a] = 2 * cell[a] + h[a];
        tri.insert(g);
      }
      if (tri.size() == 3) out.insert(tri);
    }
  }
  return out;
}

TEST(CellSchemes, Mt24NeighboursCutSharedFacesIntoTheSameTriangles) {
  const CellScheme s = makeTetra24Scheme();
  for (int axis = 0; axis < 3; ++axis) {
    std::array<int, 3> next{0, 0, 0};
    next[static_cast<std::size_t>(axis)] = 1;
    const auto lower = faceTriangles(s, axis, 1, {0, 0, 0});
    const auto upper = faceTriangles(s, axis, 0, next);
    EXPECT_EQ(lower.size(), 4u) << "axis " << axis;
    EXPECT_EQ(lower, upper) << "axis " << axis;
    // Each triangle joins the face centre with one face edge.
    for (const auto& tri : lower) {
      int centres = 0;
      for (const auto& p : tri) centres += (p[0] & 1) + (p[1] & 1) + (p[2] & 1) == 2 ? 1 : 0;
      EXPECT_EQ(centres, 1);
    }
  }
}

TEST(CellSchemes, Mt24EachTetrahedronHasOneEdgeBetweenTwoCentres) {
  const CellScheme s = makeTetra24Scheme();
  std::set<std::pair<int, int>> pyramids;
  for (const Tetrahedron& t : s.variants[0]) {
    int centreEdges = 0;
    for (int a = 0; a < 4; ++a) {
      for (int b = a + 1; b < 4; ++b) {
        const LatticeNode& na = s.nodes[t.nodes[static_cast<std::size_t>(a)]];
        const LatticeNode& nb = s.nodes[t.nodes[static_cast<std::size_t>(b)]];
        if (na.oddAxes() == 0 || nb.oddAxes() == 0) continue;
        ++centreEdges;
        // Cube centre to face centre: half a voxel.
        EXPECT_EQ(na.isCentre() + nb.isCentre(), 1);
        EXPECT_EQ(na.isFaceCentre() + nb.isFaceCentre(), 1);
        const int d2 =
            (na.hx - nb.hx) * (na.hx - nb.hx) + (na.hy - nb.hy) * (na.hy - nb.hy) + (na.hz - nb.hz) * (na.hz - nb.hz);
        EXPECT_EQ(d2, 1);
        pyramids.insert({std::min(t.nodes[static_cast<std::size_t>(a)], t.nodes[static_cast<std::size_t>(b)]),
                         std::max(t.nodes[static_cast<std::size_t>(a)], t.nodes[static_cast<std::size_t>(b)])});
      }
    }
    EXPECT_EQ(centreEdges, 1);
  }
  EXPECT_EQ(pyramids.size(), 6u);  // one centre-centre edge per pyramid, shared by its 4 tetrahedra
}

// Welding: within a slab, two edges of the cells of a lattice get the same cache slot (plane and
// slot) exactly when they are the same lattice edge, for every method. mt24's face centres share
// planes with corners, so its edge classes must tell their kinds apart.
TEST(CaseLists, EdgeSlotsNameLatticeEdgesOneToOne) {
  const std::int64_t nx = 7;
  for (const CellScheme& s : {makeTetra5Scheme(), makeTetra6Scheme(), makeBcc12Scheme(), makeTetra24Scheme()}) {
    const CellCases cases(&s, nx);
    using Point = std::array<int, 3>;
    std::map<std::pair<int, std::int64_t>, std::pair<Point, Point>> bySlot;
    std::map<std::pair<Point, Point>, std::pair<int, std::int64_t>> byEdge;
    for (std::int64_t j = 1; j < 4; ++j) {
      for (std::int64_t i = 1; i < 4; ++i) {
        for (const CaseList& v : cases.variants()) {
          for (const EdgeRef& e : v.edges) {
            if (e.cellOnly) continue;  // no slot (CaseLists.CellOnlyEdgesBelongToOneCell)
            auto global = [&](int n) {
              const LatticeNode& node = cases.nodes()[static_cast<std::size_t>(n)];
              return Point{static_cast<int>(2 * i) + node.hx, static_cast<int>(2 * j) + node.hy, node.hz};
            };
            const std::pair<Point, Point> edge{global(e.a), global(e.b)};
            const std::pair<int, std::int64_t> slot{e.plane, e.slot(i, j, nx)};
            const auto [a, newSlot] = bySlot.emplace(slot, edge);
            EXPECT_EQ(a->second, edge) << s.name << ": two edges in one slot";
            const auto [b, newEdge] = byEdge.emplace(edge, slot);
            EXPECT_EQ(b->second, slot) << s.name << ": one edge in two slots";
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace isoslab
