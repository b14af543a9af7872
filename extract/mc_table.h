// Marching Cubes case tables, generated at compile time (no table is pasted from elsewhere).
//
// Conventions, shared with the rest of extract/:
// - Corner c of a cell sits at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1) from its lowest corner.
// - Edge e joins corners kEdgeCorners[e][0] < kEdgeCorners[e][1]; edges 0-3 run along x, 4-7 along
//   y, 8-11 along z.
// - The case index has bit c set when corner c is inside, that is when its value >= iso.
//
// Generation. For a case, every face of the cube is cut by segments joining the crossed edges of
// that face: one segment when two of its edges are crossed; when all four are (two diagonally
// opposite inside corners, the ambiguous face) the inside corners are separated, one segment
// around each. The rule looks only at the face's own four corners, so the two cells that share a
// face always cut it the same way and the surface has no cracks. Each segment is directed so that
// the inside lies on its left when the face is seen from outside the cube; the segments then link
// into closed loops on the cube's surface, and every loop is fanned into triangles whose normals
// point from the inside (higher values) to the outside (lower values). Each loop is fanned from a
// point chosen so that no diagonal joins two points of one face: diagonals then run through the
// cube's interior, and every edge of the mesh belongs to exactly two triangles.
#pragma once

#include <array>
#include <cstdint>

namespace isoslab::mc {

/// kEdgeCorners[e]: the two corners of edge e, lower index first.
inline constexpr std::array<std::array<std::uint8_t, 2>, 12> kEdgeCorners = [] {
  std::array<std::array<std::uint8_t, 2>, 12> edges{};
  int n = 0;
  for (int axis = 0; axis < 3; ++axis) {
    for (int c = 0; c < 8; ++c) {
      if (((c >> axis) & 1) == 0) {
        edges[static_cast<std::size_t>(n++)] = {static_cast<std::uint8_t>(c),
                                                static_cast<std::uint8_t>(c | (1 << axis))};
      }
    }
  }
  return edges;
}();

/// The edge joining corners a and b, or -1 if they are not adjacent.
constexpr int edgeOf(int a, int b) {
  for (int e = 0; e < 12; ++e) {
    const int c0 = kEdgeCorners[static_cast<std::size_t>(e)][0];
    const int c1 = kEdgeCorners[static_cast<std::size_t>(e)][1];
    if ((c0 == a && c1 == b) || (c0 == b && c1 == a)) return e;
  }
  return -1;
}

/// Room for triangles per case; the generator fails to compile if a case needs more.
inline constexpr int kMaxTriangles = 5;

/// Per case: the number of triangles and, for each, three edge indices (counter-clockwise seen
/// from outside, i.e. from the lower values).
struct CaseTable {
  std::array<std::uint8_t, 256> triangleCount{};
  std::array<std::array<std::array<std::uint8_t, 3>, kMaxTriangles>, 256> triangles{};
  /// Bit e set when edge e is crossed in that case (derived from the triangles).
  std::array<std::uint16_t, 256> edgeMask{};
};

namespace detail {

constexpr int coord(int corner, int axis) {
  return (corner >> axis) & 1;
}

/// True if edges e0 and e1 lie on a common face of the cube.
constexpr bool shareFace(int e0, int e1) {
  for (int axis = 0; axis < 3; ++axis) {
    const int v = coord(kEdgeCorners[e0][0], axis);
    if (coord(kEdgeCorners[e0][1], axis) == v && coord(kEdgeCorners[e1][0], axis) == v &&
        coord(kEdgeCorners[e1][1], axis) == v) {
      return true;
    }
  }
  return false;
}

/// Directs the segments of one face of the cube in case `cas` (the face at `side` 0 or 1 along
/// `axis`), linking next[from] = to for each, with the inside on its left seen from outside.
constexpr void linkFaceSegments(int cas, int axis, int side, std::array<int, 12>& next) {
  auto inside = [cas](int c) { return ((cas >> c) & 1) != 0; };
  const int u = (axis + 1) % 3;
  const int v = (axis + 2) % 3;
  // Face corners in cyclic order (u, v) = (0,0), (1,0), (1,1), (0,1).
  std::array<int, 4> fc{};
  constexpr int kCu[4] = {0, 1, 1, 0};
  constexpr int kCv[4] = {0, 0, 1, 1};
  for (int m = 0; m < 4; ++m) fc[m] = (side << axis) | (kCu[m] << u) | (kCv[m] << v);
  // Face edge m joins fc[m] and fc[m+1].
  std::array<int, 4> fe{};
  for (int m = 0; m < 4; ++m) fe[m] = edgeOf(fc[m], fc[(m + 1) % 4]);
  int crossed[4] = {};
  int nCrossed = 0;
  for (int m = 0; m < 4; ++m) {
    if (inside(fc[m]) != inside(fc[(m + 1) % 4])) crossed[nCrossed++] = m;
  }
  if (nCrossed == 0) return;
  // Segments as (face edge, face edge, representative inside point scaled by 6).
  struct Segment {
    int e0, e1;
    std::array<int, 3> r;
  };
  Segment segs[2] = {};
  int nSegs = 0;
  if (nCrossed == 2) {
    std::array<int, 3> r{};
    int count = 0;
    for (int m = 0; m < 4; ++m) {
      if (!inside(fc[m])) continue;
      ++count;
      for (int a = 0; a < 3; ++a) r[a] += coord(fc[m], a);
    }
    for (int a = 0; a < 3; ++a) r[a] = r[a] * 6 / count;
    segs[nSegs++] = {fe[crossed[0]], fe[crossed[1]], r};
  } else {
    for (int m = 0; m < 4; ++m) {
      if (!inside(fc[m])) continue;
      std::array<int, 3> r{};
      for (int a = 0; a < 3; ++a) r[a] = coord(fc[m], a) * 6;
      segs[nSegs++] = {fe[(m + 3) % 4], fe[m], r};
    }
  }
  for (int s = 0; s < nSegs; ++s) {
    std::array<int, 3> p{};
    std::array<int, 3> q{};
    for (int a = 0; a < 3; ++a) {
      p[a] = 3 * (coord(kEdgeCorners[segs[s].e0][0], a) + coord(kEdgeCorners[segs[s].e0][1], a));
      q[a] = 3 * (coord(kEdgeCorners[segs[s].e1][0], a) + coord(kEdgeCorners[segs[s].e1][1], a));
    }
    std::array<int, 3> d{q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    std::array<int, 3> w{segs[s].r[0] - p[0], segs[s].r[1] - p[1], segs[s].r[2] - p[2]};
    const int crossAxis = d[u] * w[v] - d[v] * w[u];
    const int outward = side == 1 ? crossAxis : -crossAxis;
    if (outward == 0) throw "degenerate segment";
    const int from = outward > 0 ? segs[s].e0 : segs[s].e1;
    const int to = outward > 0 ? segs[s].e1 : segs[s].e0;
    if (next[from] != -1) throw "two segments leave one edge";
    next[from] = to;
  }
}

/// Links the directed segments `next` into loops and fans each into triangles of case `cas`.
constexpr void fanLoops(int cas, const std::array<int, 12>& next, CaseTable& table) {
  std::array<bool, 12> used{};
  int nTris = 0;
  for (int first = 0; first < 12; ++first) {
    if (next[first] < 0 || used[first]) continue;
    int loop[12] = {};
    int len = 0;
    for (int e = first; !used[e]; e = next[e]) {
      if (next[e] < 0) throw "open loop";
      used[e] = true;
      loop[len++] = e;
    }
    // Fan from the first loop point whose diagonals all cross the cube's interior. A diagonal
    // between two points of one face would lie in that face, where the neighbouring cell may
    // draw it too, and the edge would then have four triangles.
    int start = -1;
    for (int s = 0; s < len && start < 0; ++s) {
      bool interior = true;
      for (int i = 2; i + 1 < len; ++i) {
        if (shareFace(loop[s], loop[(s + i) % len])) interior = false;
      }
      if (interior) start = s;
    }
    if (start < 0) throw "a loop has no fan with interior diagonals";
    for (int i = 1; i + 1 < len; ++i) {
      if (nTris >= kMaxTriangles) throw "kMaxTriangles is too small";
      table.triangles[cas][nTris++] = {static_cast<std::uint8_t>(loop[start]),
                                       static_cast<std::uint8_t>(loop[(start + i + 1) % len]),
                                       static_cast<std::uint8_t>(loop[(start + i) % len])};
    }
  }
  table.triangleCount[cas] = static_cast<std::uint8_t>(nTris);
  for (int t = 0; t < nTris; ++t) {
    for (int k = 0; k < 3; ++k) table.edgeMask[cas] |= static_cast<std::uint16_t>(1u << table.triangles[cas][t][k]);
  }
}

constexpr CaseTable buildCaseTable() {
  CaseTable table{};
  for (int cas = 0; cas < 256; ++cas) {
    std::array<int, 12> next{};
    for (int& n : next) n = -1;
    for (int axis = 0; axis < 3; ++axis) {
      for (int side = 0; side < 2; ++side) linkFaceSegments(cas, axis, side, next);
    }
    fanLoops(cas, next, table);
  }
  return table;
}

}  // namespace detail

inline constexpr CaseTable kCaseTable = detail::buildCaseTable();

}  // namespace isoslab::mc
