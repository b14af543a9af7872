// size-exception: the derivation of the mc33 tables and the topology argument it rests on (the
// long comment below); the steps refer to each other and read as one proof.
// Topologically correct Marching Cubes: the per-cell decider and the triangulation of each key.
//
// E. V. Chernyaev, "Marching cubes 33: construction of topologically correct isosurfaces", CERN
// CN/95-17, 1995: the trilinear interpolant's iso-surface within a cell, its 33 configurations.
// G. M. Nielson and B. Hamann, "The asymptotic decider: resolving the ambiguity in marching cubes",
// IEEE Visualization 1991: ambiguous faces are decided by the bilinear saddle value.
// T. Lewiner, H. Lopes, A. W. Vieira and G. Tavares, "Efficient implementation of marching cubes'
// cases with topological guarantees", Journal of Graphics Tools 8(2), 2003: which interior
// ambiguities occur (cases 4, 6, 7, 10, 12 and 13).
// Nothing here is taken from their tables or code; everything is derived below.
//
// Topology of a cell. Inside I = {F >= 0} and outside O = {F < 0} (F shifted by the threshold). F is
// trilinear, hence harmonic, and bilinear on each face: no component of I or O, in the cube or on a
// face, misses every corner. The cube's surface is cut by the face segments into regions (inside or
// outside) whose corners are linked by cube edges and decided faces; regions and loops form a tree
// (a sphere cut by disjoint loops). Each surface component inside the cube separates the ball, so
// the components of I and O and the surface components between them also form a tree: a surface
// component is the set of loops between one component of I and one of O. All that the interior
// adds is which regions of one state it joins. A join of two regions R1, R2 must keep that graph a
// tree, so R1 and R2 share their neighbour X of the other state; the surface between X and R1 u R2
// is then an annulus (a tunnel). Which joins occur was found by experiment, not proved: on 10^7
// random cells the exact sweep below joined at most one pair per cell, and exactly the pairs R1, R2
// with a common neighbour X such that a corner of R1 u R2 is diagonally opposite a corner outside X.
// These candidates number at most two per case and face bits (one of each state in Chernyaev's
// 13.5, else at most one) and are the interior tests of his 4.1, 6.1, 7.4, 10.1, 12.1 and 13.5.
// cellKey runs the sweep only where a candidate exists and names the candidate it joins (a join
// outside the candidates, never seen, would be dropped). The tests re-check this on 600,000 cells
// (Mc33Decider.KeysFollowTheDefinitionsAndInteriorJoinsAreCandidates) and compare keys, triangles
// and the sweep itself with a brute-force sampling of the field (Mc33Topology).
//
// Interior decision, exact sweep along z. The section z = t is bilinear with corner values linear in
// t. Its inside (outside) components each contain a section corner, and change only where a vertical
// edge crosses 0 (at most 4 values of t) or where the section's saddle quantity
// q(t) = g0 g2 - g1 g3 changes sign (a quadratic: at most 2 roots). Between two consecutive critical
// values, each component of I (or O) restricted to the slab is swept by one section component that
// keeps its set of section corners, and it reaches the cube corners along those vertical edges. So
// the components of I and O are the classes of the union-find over the 8 corners that links, for one
// t inside each interval, the vertical-edge ends of each section component. The critical values and
// signs are evaluated in double: a rounding error can only matter when two critical values (nearly)
// coincide or q (nearly) vanishes at a midpoint, i.e. near a degenerate field; cellKey then still
// returns a valid key.
#include "extract/mc33_table.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace isoslab::mc33 {
namespace {

using mc::kEdgeCorners;

constexpr bool inside(unsigned cas, int c) {
  return ((cas >> c) & 1u) != 0;
}

/// Union-find over the 8 corners whose classes are named by their smallest corner.
struct CornerSets {
  std::array<std::uint8_t, 8> parent{0, 1, 2, 3, 4, 5, 6, 7};
  constexpr int find(int c) const {
    while (parent[static_cast<std::size_t>(c)] != c) c = parent[static_cast<std::size_t>(c)];
    return c;
  }
  constexpr void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a < b) parent[static_cast<std::size_t>(b)] = static_cast<std::uint8_t>(a);
    if (b < a) parent[static_cast<std::size_t>(a)] = static_cast<std::uint8_t>(b);
  }
};

/// The regions of the cube's surface for a case and face bits: corners of one state linked by cube
/// edges, and on each ambiguous face the joined diagonal (the inside one when its face bit is set,
/// else the outside one).
constexpr CornerSets boundaryRegions(unsigned cas, unsigned faces) {
  CornerSets sets;
  for (const auto& e : kEdgeCorners) {
    if (inside(cas, e[0]) == inside(cas, e[1])) sets.unite(e[0], e[1]);
  }
  for (int f = 0; f < 6; ++f) {
    if (((kAmbiguousFaces[cas] >> f) & 1u) == 0) continue;
    const int c0 = detail::faceCorner(f / 2, f % 2, 0);
    const bool joinInside = ((faces >> f) & 1u) != 0;
    // Corners 0 and 2 of the face are joined when they are the pair the decision joins.
    if (joinInside == inside(cas, c0)) {
      sets.unite(c0, detail::faceCorner(f / 2, f % 2, 2));
    } else {
      sets.unite(detail::faceCorner(f / 2, f % 2, 1), detail::faceCorner(f / 2, f % 2, 3));
    }
  }
  return sets;
}

/// Face bits cellKey can return for a case: bits on ambiguous faces only, and never both faces of
/// one opposite pair joined while both faces of another are separated. Two opposite ambiguous
/// faces hold every corner once, and (all values finite, as a joined face needs) joining both means
/// prod |inside values| >= prod |outside values| over the cube while separating both means the
/// reverse, strictly; the decider is exact, so no rounding breaks this. It removes 18 face
/// combinations from each of the two cases of Chernyaev's class 13.
constexpr bool validFaces(unsigned cas, unsigned faces) {
  const unsigned ambiguous = kAmbiguousFaces[cas];
  if ((faces & ~ambiguous) != 0) return false;
  bool bothJoined = false;
  bool bothSeparated = false;
  for (int axis = 0; axis < 3; ++axis) {
    const unsigned pair = 3u << (2 * axis);
    if ((ambiguous & pair) != pair) continue;
    bothJoined = bothJoined || (faces & pair) == pair;
    bothSeparated = bothSeparated || (faces & pair) == 0;
  }
  return !(bothJoined && bothSeparated);
}

/// Candidate pairs of a case and face bits, as r1 * 8 + r2 (r1 < r2 the smallest corners of the two
/// regions), 0xFF when absent; see the file comment for the rule.
using Candidates = std::array<std::uint8_t, 2>;

constexpr Candidates findCandidates(unsigned cas, unsigned faces) {
  Candidates out{0xFF, 0xFF};
  const CornerSets regions = boundaryRegions(cas, faces);
  // adjacent[r][x]: a loop separates regions r and x (a crossed edge joins them).
  std::array<std::array<bool, 8>, 8> adjacent{};
  for (const auto& e : kEdgeCorners) {
    if (inside(cas, e[0]) == inside(cas, e[1])) continue;
    const int a = regions.find(e[0]);
    const int b = regions.find(e[1]);
    adjacent[static_cast<std::size_t>(a)][static_cast<std::size_t>(b)] = true;
    adjacent[static_cast<std::size_t>(b)][static_cast<std::size_t>(a)] = true;
  }
  int count = 0;
  for (int r1 = 0; r1 < 8; ++r1) {
    for (int r2 = r1 + 1; r2 < 8; ++r2) {
      if (regions.find(r1) != r1 || regions.find(r2) != r2 || inside(cas, r1) != inside(cas, r2)) continue;
      for (int x = 0; x < 8; ++x) {
        if (!adjacent[static_cast<std::size_t>(r1)][static_cast<std::size_t>(x)] ||
            !adjacent[static_cast<std::size_t>(r2)][static_cast<std::size_t>(x)]) {
          continue;
        }
        bool opposite = false;
        for (int c = 0; c < 8; ++c) {
          const int r = regions.find(c);
          if ((r == r1 || r == r2) && regions.find(7 - c) != x) opposite = true;
        }
        if (opposite) {
          if (count >= 2) throw "more than two interior candidates";
          out[static_cast<std::size_t>(count++)] = static_cast<std::uint8_t>(r1 * 8 + r2);
        }
      }
    }
  }
  return out;
}

/// kCandidates[cas * 64 + faces].
constexpr std::array<Candidates, 256 * 64> kCandidates = [] {
  std::array<Candidates, 256 * 64> table{};
  for (unsigned cas = 0; cas < 256; ++cas) {
    for (unsigned faces = 0; faces < 64; ++faces) {
      table[cas * 64 + faces] = validFaces(cas, faces) ? findCandidates(cas, faces) : Candidates{0xFF, 0xFF};
    }
  }
  return table;
}();

int candidateCount(unsigned cas, unsigned faces) {
  const Candidates& c = kCandidates[cas * 64 + faces];
  return (c[0] != 0xFF ? 1 : 0) + (c[1] != 0xFF ? 1 : 0);
}

/// The sweep (file comment): unites the corners of each component of the inside and the outside.
void sweepInto(const double* d, CornerSets& sets) noexcept {
  // Section corners in cyclic order (x, y) = (0,0), (1,0), (1,1), (0,1); their bottom cube corners.
  constexpr int kBottom[4] = {0, 1, 3, 2};
  for (int k = 0; k < 4; ++k) {
    if ((d[kBottom[k]] >= 0) == (d[kBottom[k] + 4] >= 0)) sets.unite(kBottom[k], kBottom[k] + 4);
  }
  double levels[8];
  int n = 0;
  levels[n++] = 0.0;
  levels[n++] = 1.0;
  auto addLevel = [&levels, &n](double t) {
    if (t > 0.0 && t < 1.0) levels[n++] = t;
  };
  double a[4];
  double b[4];
  for (int k = 0; k < 4; ++k) {
    const double lo = d[kBottom[k]];
    const double hi = d[kBottom[k] + 4];
    a[k] = lo;
    b[k] = hi - lo;
    if ((lo >= 0) != (hi >= 0)) addLevel(lo / (lo - hi));
  }
  // q(t) = g0 g2 - g1 g3 with g_k = a_k + b_k t.
  const double q0 = a[0] * a[2] - a[1] * a[3];
  const double q1 = (a[0] * b[2] + a[2] * b[0]) - (a[1] * b[3] + a[3] * b[1]);
  const double q2 = b[0] * b[2] - b[1] * b[3];
  if (q2 != 0.0) {
    const double disc = q1 * q1 - 4.0 * q2 * q0;
    if (disc >= 0.0) {
      const double s = std::sqrt(disc);
      const double m = -0.5 * (q1 + (q1 >= 0.0 ? s : -s));
      if (m != 0.0) {
        addLevel(m / q2);
        addLevel(q0 / m);
      }
    }
  } else if (q1 != 0.0) {
    addLevel(-q0 / q1);
  }
  for (int i = 1; i < n; ++i) {  // insertion sort of at most 8 values
    for (int j = i; j > 0 && levels[j] < levels[j - 1]; --j) std::swap(levels[j], levels[j - 1]);
  }
  for (int i = 0; i + 1 < n; ++i) {
    if (!(levels[i + 1] > levels[i])) continue;
    const double t = 0.5 * (levels[i] + levels[i + 1]);
    double g[4];
    bool in[4];
    int end[4];  // the cube corner the section corner reaches along its vertical edge
    for (int k = 0; k < 4; ++k) {
      const double lo = d[kBottom[k]];
      const double hi = d[kBottom[k] + 4];
      g[k] = (1.0 - t) * lo + t * hi;
      in[k] = g[k] >= 0;
      end[k] = (lo >= 0) == in[k] ? kBottom[k] : kBottom[k] + 4;
    }
    for (int k = 0; k < 4; ++k) {
      if (in[k] == in[(k + 1) % 4]) sets.unite(end[k], end[(k + 1) % 4]);
    }
    if (in[0] == in[2] && in[1] == in[3] && in[0] != in[1]) {
      const double p = g[0] * g[2] - g[1] * g[3];
      const bool insideJoined = in[0] ? p >= 0 : p <= 0;
      if (insideJoined == in[0]) {
        sets.unite(end[0], end[2]);
      } else {
        sets.unite(end[1], end[3]);
      }
    }
  }
}

// ---- Triangulation ------------------------------------------------------------------------------

/// Twice the midpoint of edge e.
std::array<int, 3> edgeMid2(int e) {
  const auto& c = kEdgeCorners[static_cast<std::size_t>(e)];
  std::array<int, 3> p{};
  for (int a = 0; a < 3; ++a) p[static_cast<std::size_t>(a)] = ((c[0] >> a) & 1) + ((c[1] >> a) & 1);
  return p;
}

int distance2(int e0, int e1) {
  const auto p = edgeMid2(e0);
  const auto q = edgeMid2(e1);
  int s = 0;
  for (std::size_t a = 0; a < 3; ++a) s += (p[a] - q[a]) * (p[a] - q[a]);
  return s;
}

/// Directs the segments of face f (mc_table's rule, with the inside on the left seen from outside),
/// linking next[from] = to. On an ambiguous face the segments cut off the inside corners, or the
/// outside corners when `joinInside`.
void linkFace(unsigned cas, int f, bool joinInside, std::array<int, 12>& next) {
  const int axis = f / 2;
  const int side = f % 2;
  const int u = (axis + 1) % 3;
  const int v = (axis + 2) % 3;
  std::array<int, 4> fc{};
  std::array<int, 4> fe{};
  for (int m = 0; m < 4; ++m) fc[static_cast<std::size_t>(m)] = detail::faceCorner(axis, side, m);
  for (int m = 0; m < 4; ++m) {
    fe[static_cast<std::size_t>(m)] =
        mc::edgeOf(fc[static_cast<std::size_t>(m)], fc[static_cast<std::size_t>((m + 1) % 4)]);
  }
  auto in = [cas, &fc](int m) { return inside(cas, fc[static_cast<std::size_t>(m % 4)]); };
  struct Segment {
    int e0, e1;
    std::array<int, 3> r;  // a point on the inside of the segment, times 6
  };
  std::vector<Segment> segments;
  std::vector<int> crossed;
  for (int m = 0; m < 4; ++m) {
    if (in(m) != in(m + 1)) crossed.push_back(m);
  }
  if (crossed.empty()) return;
  auto corner6 = [](int c) { return std::array<int, 3>{6 * (c & 1), 6 * ((c >> 1) & 1), 6 * ((c >> 2) & 1)}; };
  if (crossed.size() == 2) {
    std::array<int, 3> r{};
    int count = 0;
    for (int m = 0; m < 4; ++m) {
      if (!in(m)) continue;
      ++count;
      const auto p = corner6(fc[static_cast<std::size_t>(m)]);
      for (std::size_t a = 0; a < 3; ++a) r[a] += p[a];
    }
    for (std::size_t a = 0; a < 3; ++a) r[a] /= count;
    segments.push_back({fe[static_cast<std::size_t>(crossed[0])], fe[static_cast<std::size_t>(crossed[1])], r});
  } else {
    // Around each corner the decision leaves on its own: its two face edges.
    std::array<int, 3> centre = corner6(fc[0]);
    centre[static_cast<std::size_t>(u)] = 3;
    centre[static_cast<std::size_t>(v)] = 3;
    for (int m = 0; m < 4; ++m) {
      if (in(m) == joinInside) continue;
      const auto r = joinInside ? centre : corner6(fc[static_cast<std::size_t>(m)]);
      segments.push_back({fe[static_cast<std::size_t>((m + 3) % 4)], fe[static_cast<std::size_t>(m)], r});
    }
  }
  for (const Segment& s : segments) {
    const auto p = edgeMid2(s.e0);
    const auto q = edgeMid2(s.e1);
    std::array<int, 3> d{};
    std::array<int, 3> w{};
    for (std::size_t a = 0; a < 3; ++a) {
      d[a] = 3 * (q[a] - p[a]);
      w[a] = s.r[a] - 3 * p[a];
    }
    const int crossAxis = d[static_cast<std::size_t>(u)] * w[static_cast<std::size_t>(v)] -
                          d[static_cast<std::size_t>(v)] * w[static_cast<std::size_t>(u)];
    const int outward = side == 1 ? crossAxis : -crossAxis;
    if (outward == 0) throw std::logic_error("mc33: degenerate face segment");
    const int from = outward > 0 ? s.e0 : s.e1;
    const int to = outward > 0 ? s.e1 : s.e0;
    if (next[static_cast<std::size_t>(from)] != -1) throw std::logic_error("mc33: two segments leave one edge");
    next[static_cast<std::size_t>(from)] = to;
  }
}

using Triangle = std::array<std::uint8_t, 3>;

Triangle tri(int a, int b, int c) {
  return {static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(b), static_cast<std::uint8_t>(c)};
}

/// A disc: fanned from the first loop point whose diagonals all cross the cube's interior (mc's
/// rule), else from a new cell point at the mean of the loop's edges.
void fanDisc(const std::vector<int>& loop, Mc33Case& out) {
  const int len = static_cast<int>(loop.size());
  auto at = [&loop, len](int i) { return loop[static_cast<std::size_t>(i % len)]; };
  for (int s = 0; s < len; ++s) {
    bool interior = true;
    for (int i = 2; i + 1 < len; ++i) {
      if (mc::detail::shareFace(at(s), at(s + i))) interior = false;
    }
    if (!interior) continue;
    for (int i = 1; i + 1 < len; ++i) out.triangles.push_back(tri(at(s), at(s + i + 1), at(s + i)));
    return;
  }
  const int point = kCellPoint + static_cast<int>(out.cellPoints.size());
  std::uint16_t mask = 0;
  for (int e : loop) mask = static_cast<std::uint16_t>(mask | (1u << e));
  out.cellPoints.push_back(mask);
  for (int i = 0; i < len; ++i) out.triangles.push_back(tri(point, at(i + 1), at(i)));
}

/// An annulus between loops a and b (each directed with the inside on its left): a band walking
/// forward on a and backward on b, made of triangles (a[i+1], a[i], b[j]) and (b[j], b[j-1], a[i])
/// whose rungs a[i]-b[j] never join two points of one face. Where the band cannot step from one
/// valid rung to the next, a hub bridges the gap: a cell point P fanned over the arcs a[i..i'] and
/// b[j'..j] between the valid rungs a[i]-b[j] and a[i']-b[j'] (triangles (a[i], b[j], P),
/// (a[x+1], a[x], P), (b[y], b[y-1], P) and (a[i'], P, b[j'])). Among all bands, the one with the
/// fewest hubs, then the smallest sum of squared rung lengths, then the first start, is taken.
///
/// The band is a monotone path of rungs (di, dj) from (0, 0) to (n, m), rung (di, dj) joining
/// a[i0 + di] and b[j0 - dj]; (0, 0) and (n, m) are both the start rung. Each loop point must meet
/// the other loop along one run of rungs, or an edge would be used twice: with x0 (y0) the last di
/// (dj) the path reaches while dj (di) is still 0, the path may not come back to dj = m (di = n)
/// before di > x0 (dj > y0). The search tries every start and every such (x0, y0).
// size-exception: one exhaustive search over starts and (x0, y0) limits, with the ordering of its
// candidates; it runs once, when the tables are generated.
void bandAnnulus(const std::vector<int>& a, const std::vector<int>& b, Mc33Case& out) {
  const int n = static_cast<int>(a.size());
  const int m = static_cast<int>(b.size());
  auto ai = [&a, n](int i) { return a[static_cast<std::size_t>(((i % n) + n) % n)]; };
  auto bj = [&b, m](int j) { return b[static_cast<std::size_t>(((j % m) + m) % m)]; };
  constexpr long kHubCost = 1L << 20;
  constexpr long kNone = -1;
  struct Step {
    int fromI, fromJ;  // the previous rung of the best path, -1 at the start
  };
  const std::size_t cols = static_cast<std::size_t>(m + 1);
  auto at = [cols](int di, int dj) { return static_cast<std::size_t>(di) * cols + static_cast<std::size_t>(dj); };
  long bestCost = kNone;
  int bestI0 = 0;
  int bestJ0 = 0;
  std::vector<Step> bestSteps;
  std::vector<long> cost(static_cast<std::size_t>(n + 1) * cols);
  std::vector<Step> steps(cost.size());
  for (int i0 = 0; i0 < n; ++i0) {
    for (int j0 = 0; j0 < m; ++j0) {
      if (mc::detail::shareFace(ai(i0), bj(j0))) continue;
      for (int shape = 0; shape < n + m - 1; ++shape) {
        // (x0, y0) = (0, 0), then (1..n-1, 0), then (0, 1..m-1).
        const int x0 = shape < n ? shape : 0;
        const int y0 = shape < n ? 0 : shape - n + 1;
        auto valid = [&](int di, int dj) {
          if ((di == 0 && dj > y0) || (dj == 0 && di > x0) || (di == n && dj <= y0) || (dj == m && di <= x0)) {
            return false;
          }
          return !mc::detail::shareFace(ai(i0 + di), bj(j0 - dj));
        };
        auto length = [&](int di, int dj) { return static_cast<long>(distance2(ai(i0 + di), bj(j0 - dj))); };
        std::fill(cost.begin(), cost.end(), kNone);
        cost[at(0, 0)] = length(0, 0);
        steps[at(0, 0)] = {-1, -1};
        // Rungs in order of di + dj: every move increases it.
        for (int sum = 0; sum < n + m; ++sum) {
          for (int di = std::max(0, sum - m); di <= std::min(n, sum); ++di) {
            const int dj = sum - di;
            const long here = cost[at(di, dj)];
            if (here == kNone) continue;
            for (int ti = di; ti <= n && ti - di < n; ++ti) {
              for (int tj = dj; tj <= m && tj - dj < m; ++tj) {
                const int span = (ti - di) + (tj - dj);
                if (span == 0 || !(ti == n && tj == m ? true : valid(ti, tj))) continue;
                const long c = here + (span == 1 ? 0 : kHubCost) + length(ti, tj);
                long& there = cost[at(ti, tj)];
                if (there == kNone || c < there) {
                  there = c;
                  steps[at(ti, tj)] = {di, dj};
                }
              }
            }
          }
        }
        const long total = cost[at(n, m)];
        if (total != kNone && (bestCost == kNone || total < bestCost)) {
          bestCost = total;
          bestI0 = i0;
          bestJ0 = j0;
          bestSteps = steps;
        }
      }
    }
  }
  if (bestCost == kNone) throw std::logic_error("mc33: no band for a tunnel");
  std::vector<std::pair<int, int>> path;
  for (int di = n, dj = m; di >= 0;) {
    path.push_back({di, dj});
    const Step s = bestSteps[at(di, dj)];
    di = s.fromI;
    dj = s.fromJ;
  }
  std::reverse(path.begin(), path.end());
  const int i0 = bestI0;
  const int j0 = bestJ0;
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const auto [di, dj] = path[k];
    const auto [ti, tj] = path[k + 1];
    if (ti - di + tj - dj == 1) {
      if (ti > di) {
        out.triangles.push_back(tri(ai(i0 + di + 1), ai(i0 + di), bj(j0 - dj)));
      } else {
        out.triangles.push_back(tri(bj(j0 - dj), bj(j0 - dj - 1), ai(i0 + di)));
      }
      continue;
    }
    const int hub = kCellPoint + static_cast<int>(out.cellPoints.size());
    std::uint16_t mask = 0;
    for (int x = di; x <= ti; ++x) mask = static_cast<std::uint16_t>(mask | (1u << ai(i0 + x)));
    for (int y = dj; y <= tj; ++y) mask = static_cast<std::uint16_t>(mask | (1u << bj(j0 - y)));
    out.cellPoints.push_back(mask);
    out.triangles.push_back(tri(ai(i0 + di), bj(j0 - dj), hub));
    for (int x = di; x < ti; ++x) out.triangles.push_back(tri(ai(i0 + x + 1), ai(i0 + x), hub));
    for (int y = dj; y < tj; ++y) out.triangles.push_back(tri(bj(j0 - y), bj(j0 - y - 1), hub));
    out.triangles.push_back(tri(ai(i0 + ti), hub, bj(j0 - tj)));
  }
}

}  // namespace

bool faceJoinsInside(double a00, double a10, double a11, double a01) noexcept {
  if (!std::isfinite(a00) || !std::isfinite(a10) || !std::isfinite(a11) || !std::isfinite(a01)) return false;
  const bool in00 = a00 >= 0;
  if ((a11 >= 0) != in00 || (a10 >= 0) == in00 || (a01 >= 0) == in00) return false;
  // Saddle value (a00 a11 - a10 a01) / (a00 + a11 - a10 - a01): the denominator has the sign of the
  // inside pair's values, so the saddle is >= 0 iff inside product - outside product >= 0. Each
  // product is its rounded value plus the exact rounding error (fma); comparing the rounded values
  // first, then the errors, gives the exact sign.
  double ph = a00 * a11;
  double pl = std::fma(a00, a11, -ph);
  double qh = a10 * a01;
  double ql = std::fma(a10, a01, -qh);
  if (!in00) {
    std::swap(ph, qh);
    std::swap(pl, ql);
  }
  return ph > qh || (ph == qh && pl >= ql);
}

std::array<std::uint8_t, 8> sweepComponents(const double* shifted) noexcept {
  CornerSets sets;
  sweepInto(shifted, sets);
  std::array<std::uint8_t, 8> label{};
  for (int c = 0; c < 8; ++c) label[static_cast<std::size_t>(c)] = static_cast<std::uint8_t>(sets.find(c));
  return label;
}

unsigned cellKey(const float* v, float threshold) noexcept {
  unsigned cas = 0;
  for (int c = 0; c < 8; ++c) {
    if (v[c] >= threshold) cas |= 1u << c;
  }
  if (!kMayBeAmbiguous[cas]) return cas;
  double d[8];
  bool finite = true;
  for (int c = 0; c < 8; ++c) {
    d[c] = static_cast<double>(v[c]) - static_cast<double>(threshold);
    finite = finite && std::isfinite(d[c]);
  }
  unsigned faces = 0;
  const unsigned ambiguous = kAmbiguousFaces[cas];
  for (int f = 0; f < 6; ++f) {
    if (((ambiguous >> f) & 1u) == 0) continue;
    const int axis = f / 2;
    const int side = f % 2;
    if (faceJoinsInside(d[detail::faceCorner(axis, side, 0)], d[detail::faceCorner(axis, side, 1)],
                        d[detail::faceCorner(axis, side, 2)], d[detail::faceCorner(axis, side, 3)])) {
      faces |= 1u << f;
    }
  }
  // Exact face decisions never give a combination that no field has (validFaces); should one
  // occur, the cell keeps mc's topology rather than reach a key without triangles.
  if (!validFaces(cas, faces)) return cas;
  unsigned key = cas | (faces << 8);
  const Candidates& candidates = kCandidates[cas * 64 + faces];
  if (candidates[0] == 0xFF || !finite) return key;
  CornerSets sets;
  sweepInto(d, sets);
  for (unsigned k = 0; k < 2; ++k) {
    const unsigned pair = candidates[k];
    if (pair != 0xFF && sets.find(static_cast<int>(pair / 8)) == sets.find(static_cast<int>(pair % 8))) {
      return key | ((k + 1) << 14);
    }
  }
  return key;
}

bool isValidKey(unsigned key) noexcept {
  if (key >= kKeyCount) return false;
  const unsigned cas = keyCase(key);
  const unsigned faces = keyFaces(key);
  return validFaces(cas, faces) && static_cast<int>(keyInterior(key)) <= candidateCount(cas, faces);
}

std::vector<unsigned> allKeys() {
  std::vector<unsigned> keys;
  for (unsigned key = 0; key < kKeyCount; ++key) {
    if (isValidKey(key)) keys.push_back(key);
  }
  return keys;
}

std::vector<std::array<std::uint8_t, 2>> interiorCandidates(unsigned cas, unsigned faces) {
  std::vector<std::array<std::uint8_t, 2>> out;
  if (cas >= 256 || faces >= 64) return out;
  for (std::uint8_t pair : kCandidates[cas * 64 + faces]) {
    if (pair != 0xFF) out.push_back({static_cast<std::uint8_t>(pair / 8), static_cast<std::uint8_t>(pair % 8)});
  }
  return out;
}

Mc33Case buildCase(unsigned key) {
  if (!isValidKey(key)) throw std::logic_error("mc33: key " + std::to_string(key) + " is never returned by cellKey");
  const unsigned cas = keyCase(key);
  const unsigned faces = keyFaces(key);
  const unsigned interior = keyInterior(key);
  CornerSets sets = boundaryRegions(cas, faces);
  if (interior > 0) {
    const unsigned pair = kCandidates[cas * 64 + faces][interior - 1];
    sets.unite(static_cast<int>(pair / 8), static_cast<int>(pair % 8));
  }
  std::array<int, 12> next{};
  next.fill(-1);
  for (int f = 0; f < 6; ++f) linkFace(cas, f, ((faces >> f) & 1u) != 0, next);
  // Loops in the order of mc_table's fanLoops, each with the (inside, outside) components it parts.
  std::vector<std::vector<int>> loops;
  std::vector<std::pair<int, int>> parts;
  std::array<bool, 12> used{};
  for (int first = 0; first < 12; ++first) {
    if (next[static_cast<std::size_t>(first)] < 0 || used[static_cast<std::size_t>(first)]) continue;
    std::vector<int> loop;
    for (int e = first; !used[static_cast<std::size_t>(e)]; e = next[static_cast<std::size_t>(e)]) {
      if (next[static_cast<std::size_t>(e)] < 0) throw std::logic_error("mc33: open loop");
      used[static_cast<std::size_t>(e)] = true;
      loop.push_back(e);
    }
    std::pair<int, int> part{-1, -1};
    for (int e : loop) {
      const auto& c = kEdgeCorners[static_cast<std::size_t>(e)];
      const int in = inside(cas, c[0]) ? c[0] : c[1];
      const int out = inside(cas, c[0]) ? c[1] : c[0];
      const std::pair<int, int> p{sets.find(in), sets.find(out)};
      if (part.first >= 0 && p != part) throw std::logic_error("mc33: a loop parts two pairs of components");
      part = p;
    }
    loops.push_back(std::move(loop));
    parts.push_back(part);
  }
  Mc33Case out;
  std::vector<bool> done(loops.size(), false);
  for (std::size_t l = 0; l < loops.size(); ++l) {
    if (done[l]) continue;
    std::vector<std::size_t> component;
    for (std::size_t k = l; k < loops.size(); ++k) {
      if (parts[k] == parts[l]) {
        component.push_back(k);
        done[k] = true;
      }
    }
    if (component.size() == 1) {
      fanDisc(loops[l], out);
    } else if (component.size() == 2) {
      bandAnnulus(loops[component[0]], loops[component[1]], out);
    } else {
      throw std::logic_error("mc33: a component with three or more loops in key " + std::to_string(key));
    }
  }
  return out;
}

}  // namespace isoslab::mc33
