// The tetrahedron kernel's case table and the cube decompositions of the tetrahedral methods,
// generated at compile time and checked by tests/extract/tables_test.cpp.
//
// Canonical tetrahedron: nodes 0..3 at (0,0,0), (1,0,0), (0,1,0), (0,0,1), positive signed
// volume. Its edges: kTetEdges[e] = {a, b}. A case sets bit n when node n is inside (value >= iso);
// it has one triangle when one node differs from the other three, two when two differ from two.
// Triangles are counter-clockwise seen from the outside nodes, so that their normals point from
// higher to lower values. Any tetrahedron with positive signed volume is an affine image of the
// canonical one with positive determinant, which keeps that orientation: the extractors order each
// tetrahedron's nodes so that its signed volume is positive, and then use this table as it is.
#pragma once

#include <array>
#include <cstdint>

namespace isoslab::tet {

inline constexpr std::array<std::array<std::uint8_t, 2>, 6> kTetEdges = {
    {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}};

constexpr int tetEdgeOf(int a, int b) {
  for (int e = 0; e < 6; ++e) {
    if ((kTetEdges[static_cast<std::size_t>(e)][0] == a && kTetEdges[static_cast<std::size_t>(e)][1] == b) ||
        (kTetEdges[static_cast<std::size_t>(e)][0] == b && kTetEdges[static_cast<std::size_t>(e)][1] == a)) {
      return e;
    }
  }
  return -1;
}

struct TetCaseTable {
  std::array<std::uint8_t, 16> triangleCount{};
  std::array<std::array<std::array<std::uint8_t, 3>, 2>, 16> triangles{};
};

namespace detail {

constexpr std::array<std::array<int, 3>, 4> kCanonical = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};

// Twice the midpoint of edge e.
constexpr std::array<int, 3> midpoint2(int e) {
  const auto& a = kCanonical[kTetEdges[static_cast<std::size_t>(e)][0]];
  const auto& b = kCanonical[kTetEdges[static_cast<std::size_t>(e)][1]];
  return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}

// Orders triangle (e0, e1, e2) so that its normal points from the inside nodes to the outside ones.
constexpr std::array<std::uint8_t, 3> orient(int cas, int e0, int e1, int e2) {
  const auto p = midpoint2(e0);
  const auto q = midpoint2(e1);
  const auto r = midpoint2(e2);
  const std::array<int, 3> u{q[0] - p[0], q[1] - p[1], q[2] - p[2]};
  const std::array<int, 3> v{r[0] - p[0], r[1] - p[1], r[2] - p[2]};
  const std::array<int, 3> n{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  // Direction from the inside nodes' centroid to the outside nodes' centroid (scaled by counts).
  std::array<int, 3> in{};
  std::array<int, 3> out{};
  int nIn = 0;
  for (int k = 0; k < 4; ++k) {
    auto& acc = ((cas >> k) & 1) ? in : out;
    nIn += (cas >> k) & 1;
    for (int a = 0; a < 3; ++a) acc[a] += kCanonical[static_cast<std::size_t>(k)][a];
  }
  const int nOut = 4 - nIn;
  int dot = 0;
  for (int a = 0; a < 3; ++a) dot += n[a] * (out[a] * nIn - in[a] * nOut);
  if (dot == 0) throw "degenerate orientation";
  if (dot > 0) return {static_cast<std::uint8_t>(e0), static_cast<std::uint8_t>(e1), static_cast<std::uint8_t>(e2)};
  return {static_cast<std::uint8_t>(e0), static_cast<std::uint8_t>(e2), static_cast<std::uint8_t>(e1)};
}

constexpr TetCaseTable buildTetCaseTable() {
  TetCaseTable t{};
  for (int cas = 1; cas < 15; ++cas) {
    int in[4] = {};
    int out[4] = {};
    int nIn = 0;
    int nOut = 0;
    for (int k = 0; k < 4; ++k) {
      if ((cas >> k) & 1) {
        in[nIn++] = k;
      } else {
        out[nOut++] = k;
      }
    }
    if (nIn == 1 || nOut == 1) {
      const int lone = nIn == 1 ? in[0] : out[0];
      const int* others = nIn == 1 ? out : in;
      t.triangleCount[cas] = 1;
      t.triangles[cas][0] =
          orient(cas, tetEdgeOf(lone, others[0]), tetEdgeOf(lone, others[1]), tetEdgeOf(lone, others[2]));
    } else {
      // Quad a-c, a-d, b-d, b-c (consecutive edges share a node), split along its first diagonal.
      const int a = in[0], b = in[1], c = out[0], d = out[1];
      const int q0 = tetEdgeOf(a, c), q1 = tetEdgeOf(a, d), q2 = tetEdgeOf(b, d), q3 = tetEdgeOf(b, c);
      t.triangleCount[cas] = 2;
      t.triangles[cas][0] = orient(cas, q0, q1, q2);
      t.triangles[cas][1] = orient(cas, q0, q2, q3);
    }
  }
  return t;
}

}  // namespace detail

inline constexpr TetCaseTable kTetCases = detail::buildTetCaseTable();

}  // namespace isoslab::tet
