// Tests of the mc33 tables and decider (extract/mc33_table.h): table invariants for every key,
// neighbour agreement, and the topology of single cells against a brute-force sampling of the
// trilinear interpolant, with a count of Chernyaev's 33 configurations.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "extract/mc33_table.h"
#include "extract/mc_table.h"

namespace isoslab {
namespace {

using mc33::Mc33Case;

constexpr int coord(int corner, int axis) {
  return (corner >> axis) & 1;
}

bool isInside(unsigned cas, int c) {
  return ((cas >> c) & 1u) != 0;
}

std::uint16_t crossedEdges(unsigned cas) {
  std::uint16_t mask = 0;
  for (int e = 0; e < 12; ++e) {
    const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
    if (isInside(cas, c[0]) != isInside(cas, c[1])) mask = static_cast<std::uint16_t>(mask | (1u << e));
  }
  return mask;
}

// Corner m of face f = 2 * axis + side in (u, v) order, written out independently of the header.
int faceCorner(int f, int m) {
  const int axis = f / 2;
  const int side = f % 2;
  const int du = (m == 1 || m == 2) ? 1 : 0;
  const int dv = (m == 2 || m == 3) ? 1 : 0;
  return (side << axis) | (du << ((axis + 1) % 3)) | (dv << ((axis + 2) % 3));
}

bool edgeOnFace(int e, int f) {
  const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
  return coord(c[0], f / 2) == f % 2 && coord(c[1], f / 2) == f % 2;
}

// The face both points lie on, or -1 (cell points lie on none).
int commonFace(int p, int q) {
  if (p >= 12 || q >= 12) return -1;
  for (int f = 0; f < 6; ++f) {
    if (edgeOnFace(p, f) && edgeOnFace(q, f)) return f;
  }
  return -1;
}

bool ambiguousFace(unsigned cas, int f) {
  bool s[4];
  for (int m = 0; m < 4; ++m) s[m] = isInside(cas, faceCorner(f, m));
  return s[0] == s[2] && s[1] == s[3] && s[0] != s[1];
}

using EdgePair = std::pair<int, int>;

EdgePair sorted(int a, int b) {
  return {std::min(a, b), std::max(a, b)};
}

// The segments face f must carry: the two crossed edges of an unambiguous face; on an ambiguous
// face, the two edges around each corner the decision cuts off (the inside corners when they are
// not joined, else the outside corners).
std::set<EdgePair> expectedSegments(unsigned cas, int f, bool joined) {
  std::array<int, 4> fe{};
  for (int m = 0; m < 4; ++m) {
    fe[static_cast<std::size_t>(m)] = mc::edgeOf(faceCorner(f, m), faceCorner(f, (m + 1) % 4));
  }
  std::vector<int> crossed;
  for (int m = 0; m < 4; ++m) {
    if (isInside(cas, faceCorner(f, m)) != isInside(cas, faceCorner(f, (m + 1) % 4))) {
      crossed.push_back(fe[static_cast<std::size_t>(m)]);
    }
  }
  std::set<EdgePair> out;
  if (crossed.size() == 2) out.insert(sorted(crossed[0], crossed[1]));
  if (crossed.size() == 4) {
    for (int m = 0; m < 4; ++m) {
      if (isInside(cas, faceCorner(f, m)) != joined) {
        out.insert(sorted(fe[static_cast<std::size_t>((m + 3) % 4)], fe[static_cast<std::size_t>(m)]));
      }
    }
  }
  return out;
}

// Twice the midpoint of edge e.
std::array<int, 3> mid2(int e) {
  const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
  return {coord(c[0], 0) + coord(c[1], 0), coord(c[0], 1) + coord(c[1], 1), coord(c[0], 2) + coord(c[1], 2)};
}

struct Dsu {
  std::vector<int> parent;
  std::vector<int> size;
  explicit Dsu(std::size_t n = 0) { reset(n); }
  // Back to n singletons, keeping the storage.
  void reset(std::size_t n) {
    parent.resize(n);
    size.assign(n, 1);
    std::iota(parent.begin(), parent.end(), 0);
  }
  int find(int a) {
    while (parent[static_cast<std::size_t>(a)] != a) {
      parent[static_cast<std::size_t>(a)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
      a = parent[static_cast<std::size_t>(a)];
    }
    return a;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (size[static_cast<std::size_t>(a)] > size[static_cast<std::size_t>(b)]) std::swap(a, b);
    parent[static_cast<std::size_t>(a)] = b;
    size[static_cast<std::size_t>(b)] += size[static_cast<std::size_t>(a)];
  }
};

// Relabels a partition of the crossed edges by first occurrence (-1 for edges not crossed).
std::array<int, 12> canonicalPartition(const std::array<int, 12>& raw) {
  std::array<int, 12> out{};
  std::map<int, int> names;
  for (std::size_t e = 0; e < 12; ++e) {
    if (raw[e] < 0) {
      out[e] = -1;
      continue;
    }
    const auto [it, fresh] = names.emplace(raw[e], static_cast<int>(names.size()));
    out[e] = it->second;
  }
  return out;
}

// The topology of a key's triangles: surface components and boundary loops as partitions of the
// crossed edges, and per component its Euler characteristic V - E + F and its number of loops.
struct MeshTopology {
  std::array<int, 12> component{};
  std::array<int, 12> loop{};
  int components = 0;
  std::vector<int> euler;
  std::vector<int> loops;
};

MeshTopology meshTopology(const Mc33Case& c, std::uint16_t crossed) {
  const std::size_t points = 12 + c.cellPoints.size();
  Dsu surface(points);
  std::map<EdgePair, int> uses;
  for (const auto& t : c.triangles) {
    for (int k = 0; k < 3; ++k) {
      surface.unite(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]);
      ++uses[sorted(t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)])];
    }
  }
  Dsu boundary(points);
  for (const auto& [edge, n] : uses) {
    if (n == 1) boundary.unite(edge.first, edge.second);
  }
  MeshTopology topo;
  std::array<int, 12> rawComponent{};
  std::array<int, 12> rawLoop{};
  for (int e = 0; e < 12; ++e) {
    const bool x = ((crossed >> e) & 1u) != 0;
    rawComponent[static_cast<std::size_t>(e)] = x ? surface.find(e) : -1;
    rawLoop[static_cast<std::size_t>(e)] = x ? boundary.find(e) : -1;
  }
  topo.component = canonicalPartition(rawComponent);
  topo.loop = canonicalPartition(rawLoop);
  for (int id : topo.component) topo.components = std::max(topo.components, id + 1);
  topo.euler.assign(static_cast<std::size_t>(topo.components), 0);
  topo.loops.assign(static_cast<std::size_t>(topo.components), 0);
  // Map each component root to its index through a crossed edge in it.
  std::map<int, int> index;
  for (int e = 0; e < 12; ++e) {
    if (topo.component[static_cast<std::size_t>(e)] >= 0)
      index[surface.find(e)] = topo.component[static_cast<std::size_t>(e)];
  }
  std::set<int> seenPoints;
  for (const auto& t : c.triangles) {
    for (int p : t) seenPoints.insert(p);
  }
  for (int p : seenPoints) ++topo.euler[static_cast<std::size_t>(index.at(surface.find(p)))];
  for (const auto& [edge, n] : uses) --topo.euler[static_cast<std::size_t>(index.at(surface.find(edge.first)))];
  for (const auto& t : c.triangles) ++topo.euler[static_cast<std::size_t>(index.at(surface.find(t[0])))];
  std::set<std::pair<int, int>> loopOf;
  for (int e = 0; e < 12; ++e) {
    if (topo.component[static_cast<std::size_t>(e)] >= 0) {
      loopOf.insert({topo.component[static_cast<std::size_t>(e)], topo.loop[static_cast<std::size_t>(e)]});
    }
  }
  for (const auto& [comp, loop] : loopOf) ++topo.loops[static_cast<std::size_t>(comp)];
  return topo;
}

// Everything test 1 asks of one key; returns the failures found, empty when the key is sound.
std::vector<std::string> checkKey(unsigned key) {
  std::vector<std::string> errors;
  auto fail = [&errors, key](const std::string& what) { errors.push_back("key " + std::to_string(key) + ": " + what); };
  const unsigned cas = mc33::keyCase(key);
  const unsigned faces = mc33::keyFaces(key);
  const Mc33Case c = mc33::buildCase(key);
  const std::uint16_t crossed = crossedEdges(cas);
  const int points = 12 + static_cast<int>(c.cellPoints.size());
  // Points: exactly the crossed edges and every cell point, each cell point placed by crossed edges.
  std::uint16_t usedEdges = 0;
  std::set<int> usedCellPoints;
  for (const auto& t : c.triangles) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) fail("degenerate triangle");
    for (int p : t) {
      if (p >= points) fail("point out of range");
      if (p < 12) usedEdges = static_cast<std::uint16_t>(usedEdges | (1u << p));
      if (p >= 12) usedCellPoints.insert(p);
    }
  }
  if (usedEdges != crossed) fail("triangles do not use exactly the crossed edges");
  if (static_cast<int>(usedCellPoints.size()) != points - 12) fail("an unused cell point");
  for (std::uint16_t mask : c.cellPoints) {
    if (mask == 0 || (mask & ~crossed) != 0) fail("a cell point placed by edges that are not crossed");
  }
  // Segments expected on each face.
  std::array<std::set<EdgePair>, 6> expected;
  for (int f = 0; f < 6; ++f) {
    const bool joined = ((faces >> f) & 1u) != 0;
    if (joined && !ambiguousFace(cas, f)) fail("face bit on an unambiguous face");
    expected[static_cast<std::size_t>(f)] = expectedSegments(cas, f, joined);
  }
  std::map<EdgePair, int> directed;
  for (const auto& t : c.triangles) {
    for (int k = 0; k < 3; ++k) ++directed[{t[static_cast<std::size_t>(k)], t[static_cast<std::size_t>((k + 1) % 3)]}];
  }
  std::array<std::set<EdgePair>, 6> drawn;
  for (const auto& [edge, n] : directed) {
    const auto [p, q] = edge;
    if (n != 1) fail("a directed edge used twice");
    const bool reverse = directed.contains({q, p});
    const int f = commonFace(p, q);
    if (f < 0) {
      if (!reverse) fail("an interior edge used by one triangle");
      continue;
    }
    if (!expected[static_cast<std::size_t>(f)].contains(sorted(p, q))) {
      fail("edge " + std::to_string(p) + "-" + std::to_string(q) + " joins two points of face " + std::to_string(f) +
           " but is not one of its segments");
      continue;
    }
    if (reverse) fail("a face segment used by two triangles");
    drawn[static_cast<std::size_t>(f)].insert(sorted(p, q));
    // Orientation: triangles run a segment with the inside corners on its right seen from outside.
    const int axis = f / 2;
    const int side = f % 2;
    const int u = (axis + 1) % 3;
    const int v = (axis + 2) % 3;
    const auto a = mid2(p);
    const auto b = mid2(q);
    std::vector<int> left;
    std::vector<int> right;
    for (int m = 0; m < 4; ++m) {
      const int corner = faceCorner(f, m);
      const int cu = 2 * coord(corner, u) - a[static_cast<std::size_t>(u)];
      const int cv = 2 * coord(corner, v) - a[static_cast<std::size_t>(v)];
      const int du = b[static_cast<std::size_t>(u)] - a[static_cast<std::size_t>(u)];
      const int dv = b[static_cast<std::size_t>(v)] - a[static_cast<std::size_t>(v)];
      const int cross = (du * cv - dv * cu) * (side == 1 ? 1 : -1);
      (cross > 0 ? left : right).push_back(corner);
    }
    for (int corner : left) {
      if (left.size() <= 2 && isInside(cas, corner)) fail("a segment with an inside corner on its outside");
    }
    for (int corner : right) {
      if (right.size() <= 2 && !isInside(cas, corner)) fail("a segment with an outside corner on its inside");
    }
  }
  for (int f = 0; f < 6; ++f) {
    if (drawn[static_cast<std::size_t>(f)] != expected[static_cast<std::size_t>(f)]) {
      fail("face " + std::to_string(f) + " does not carry its segments");
    }
  }
  // Vertex links: a path around each loop point, a cycle around each cell point.
  for (int p = 0; p < points; ++p) {
    std::map<int, std::vector<int>> link;
    for (const auto& t : c.triangles) {
      for (int k = 0; k < 3; ++k) {
        if (t[static_cast<std::size_t>(k)] != p) continue;
        const int x = t[static_cast<std::size_t>((k + 1) % 3)];
        const int y = t[static_cast<std::size_t>((k + 2) % 3)];
        link[x].push_back(y);
        link[y].push_back(x);
      }
    }
    if (link.empty()) continue;
    int ends = 0;
    Dsu dsu(static_cast<std::size_t>(points));
    for (const auto& [x, ys] : link) {
      if (ys.size() > 2) fail("point " + std::to_string(p) + " is not a manifold vertex");
      ends += ys.size() == 1 ? 1 : 0;
      for (int y : ys) dsu.unite(x, y);
    }
    std::set<int> roots;
    for (const auto& [x, ys] : link) roots.insert(dsu.find(x));
    if (roots.size() != 1) fail("point " + std::to_string(p) + " has a pinched link");
    if (ends != (p < 12 ? 2 : 0)) fail("point " + std::to_string(p) + " has a wrong link");
  }
  // Each component is a sphere with holes: V - E + F = 2 - loops.
  const MeshTopology topo = meshTopology(c, crossed);
  for (std::size_t k = 0; k < topo.euler.size(); ++k) {
    if (topo.euler[k] != 2 - topo.loops[k])
      fail("a component with Euler characteristic " + std::to_string(topo.euler[k]));
  }
  // Nothing joined: exactly mc's triangles.
  if (faces == 0 && mc33::keyInterior(key) == 0) {
    bool same = c.triangles.size() == mc::kCaseTable.triangleCount[cas] && c.cellPoints.empty();
    for (std::size_t t = 0; same && t < c.triangles.size(); ++t) {
      for (std::size_t k = 0; k < 3; ++k) same = same && c.triangles[t][k] == mc::kCaseTable.triangles[cas][t][k];
    }
    if (!same) fail("differs from mc::kCaseTable");
  }
  return errors;
}

TEST(Mc33Table, EveryKeyIsAClosedOrientedManifoldPatchWithTheFaceSegments) {
  const std::vector<unsigned> keys = mc33::allKeys();
  std::size_t maxTriangles = 0;
  std::size_t maxCellPoints = 0;
  int withCellPoints = 0;
  int interior = 0;
  for (unsigned key : keys) {
    const auto errors = checkKey(key);
    for (const auto& e : errors) ADD_FAILURE() << e;
    const Mc33Case c = mc33::buildCase(key);
    maxTriangles = std::max(maxTriangles, c.triangles.size());
    maxCellPoints = std::max(maxCellPoints, c.cellPoints.size());
    withCellPoints += c.cellPoints.empty() ? 0 : 1;
    interior += mc33::keyInterior(key) != 0 ? 1 : 0;
  }
  std::printf(
      "[mc33] %zu valid keys (%d with an interior join), %d use cell points; at most %zu triangles and %zu "
      "cell points per key\n",
      keys.size(), interior, withCellPoints, maxTriangles, maxCellPoints);
  // 256 cases; the ambiguous faces and the interior candidates add the rest, less the face bits of
  // class 13 that need the product of the inside magnitudes both >= and < that of the outside ones.
  std::size_t expected = 0;
  int impossible = 0;
  for (unsigned cas = 0; cas < 256; ++cas) {
    for (unsigned faces = 0; faces < 64; ++faces) {
      if ((faces & ~static_cast<unsigned>(mc33::kAmbiguousFaces[cas])) != 0) continue;
      bool bothJoined = false;
      bool bothSeparated = false;
      for (int axis = 0; axis < 3; ++axis) {
        if (!ambiguousFace(cas, 2 * axis) || !ambiguousFace(cas, 2 * axis + 1)) continue;
        const unsigned pair = (faces >> (2 * axis)) & 3u;
        bothJoined = bothJoined || pair == 3u;
        bothSeparated = bothSeparated || pair == 0u;
      }
      if (bothJoined && bothSeparated) {
        ++impossible;
        EXPECT_FALSE(mc33::isValidKey(cas | faces << 8));
        continue;
      }
      expected += 1 + mc33::interiorCandidates(cas, faces).size();
    }
  }
  EXPECT_EQ(impossible, 36);
  EXPECT_EQ(maxTriangles, static_cast<std::size_t>(mc33::kMaxTriangles));
  EXPECT_EQ(maxCellPoints, static_cast<std::size_t>(mc33::kMaxCellPoints));
  EXPECT_EQ(keys.size(), expected);
  EXPECT_GT(interior, 0);
  for (unsigned key = 0; key < mc33::kKeyCount; ++key) {
    if (!mc33::isValidKey(key)) {
      EXPECT_THROW(mc33::buildCase(key), std::logic_error) << key;
    }
  }
}

TEST(Mc33Table, KeysWithoutAmbiguityAreTheCaseAndMatchMc) {
  for (unsigned cas = 0; cas < 256; ++cas) {
    if (mc33::mayBeAmbiguous(cas)) {
      // Some face or the interior can be decided.
      EXPECT_TRUE(mc33::kAmbiguousFaces[cas] != 0 || !mc33::interiorCandidates(cas, 0).empty()) << cas;
      continue;
    }
    EXPECT_EQ(mc33::kAmbiguousFaces[cas], 0) << cas;
    EXPECT_TRUE(mc33::interiorCandidates(cas, 0).empty()) << cas;
    std::mt19937 rng(cas);
    std::uniform_real_distribution<float> mag(0.001f, 10.0f);
    for (int n = 0; n < 20; ++n) {
      float v[8];
      for (int c = 0; c < 8; ++c) v[c] = isInside(cas, c) ? 1.0f + mag(rng) : 1.0f - mag(rng);
      EXPECT_EQ(mc33::cellKey(v, 1.0f), cas);
    }
  }
  // Case counts by kind (Chernyaev's classes 0, 1, 2, 5, 8, 9, 11, 14 are never ambiguous).
  int plain = 0;
  for (unsigned cas = 0; cas < 256; ++cas) plain += mc33::mayBeAmbiguous(cas) ? 0 : 1;
  EXPECT_EQ(plain, 2 + 16 + 24 + 48 + 6 + 8 + 12 + 12);
}

// Two cells sharing a face draw the same segments on it, whichever keys they have.
TEST(Mc33Table, NeighboursDrawTheSameSegmentsOnASharedFace) {
  // Per (axis, corner states of the face in (u, v) order, decision): the segments as pairs of
  // face-local edge names (corners with the axis bit cleared), directed, for side 0 and side 1.
  std::map<std::tuple<int, int, int>, std::set<EdgePair>> bySide;
  int compared = 0;
  for (unsigned key : mc33::allKeys()) {
    const unsigned cas = mc33::keyCase(key);
    const Mc33Case c = mc33::buildCase(key);
    for (int f = 0; f < 6; ++f) {
      const int axis = f / 2;
      const int side = f % 2;
      int states = 0;
      for (int m = 0; m < 4; ++m) states |= (isInside(cas, faceCorner(f, m)) ? 1 : 0) << m;
      const int decision = static_cast<int>((mc33::keyFaces(key) >> f) & 1u);
      auto local = [axis](int e) {
        const auto& ec = mc::kEdgeCorners[static_cast<std::size_t>(e)];
        return (ec[0] & ~(1 << axis)) * 8 + (ec[1] & ~(1 << axis));
      };
      std::set<EdgePair> segs;
      for (const auto& t : c.triangles) {
        for (int k = 0; k < 3; ++k) {
          const int p = t[static_cast<std::size_t>(k)];
          const int q = t[static_cast<std::size_t>((k + 1) % 3)];
          if (p < 12 && q < 12 && edgeOnFace(p, f) && edgeOnFace(q, f)) {
            // Side 0 is seen from the other cell: reverse it to compare.
            segs.insert(side == 1 ? EdgePair{local(p), local(q)} : EdgePair{local(q), local(p)});
          }
        }
      }
      const auto id = std::make_tuple(axis, states, decision);
      const auto [it, fresh] = bySide.emplace(id, segs);
      if (!fresh) {
        EXPECT_EQ(it->second, segs) << "key " << key << " face " << f;
        ++compared;
      }
    }
  }
  EXPECT_GT(compared, 1000);
  // Cells sharing a face decide it identically from its four values.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> small(-3, 3);
  std::uniform_real_distribution<float> wide(-2.0f, 2.0f);
  int ambiguous = 0;
  for (int n = 0; n < 200000; ++n) {
    const int axis = n % 3;
    float lower[8];
    float upper[8];
    for (int c = 0; c < 8; ++c) {
      lower[c] = n % 2 == 0 ? static_cast<float>(small(rng)) : wide(rng);
      upper[c] = n % 2 == 0 ? static_cast<float>(small(rng)) : wide(rng);
    }
    for (int c = 0; c < 8; ++c) {
      if (coord(c, axis) == 1) upper[c & ~(1 << axis)] = lower[c];
    }
    const float threshold = n % 5 == 0 ? 0.5f : 0.0f;
    const unsigned a = mc33::cellKey(lower, threshold);
    const unsigned b = mc33::cellKey(upper, threshold);
    const unsigned bitLower = (mc33::keyFaces(a) >> (2 * axis + 1)) & 1u;
    const unsigned bitUpper = (mc33::keyFaces(b) >> (2 * axis)) & 1u;
    ASSERT_EQ(bitLower, bitUpper) << "axis " << axis << " cell " << n;
    ambiguous += ambiguousFace(mc33::keyCase(a), 2 * axis + 1) ? 1 : 0;
  }
  EXPECT_GT(ambiguous, 1000);
}

TEST(Mc33Decider, FaceDecisionIsTheExactAsymptoticDecider) {
  // Inside pair (a00, a11): joined iff a00 a11 >= a10 a01.
  EXPECT_TRUE(mc33::faceJoinsInside(1, -1, 1, -1));  // saddle value exactly 0: inside
  EXPECT_TRUE(mc33::faceJoinsInside(2, -1, 1, -1));
  EXPECT_FALSE(mc33::faceJoinsInside(1, -2, 1, -1));
  // Inside pair (a10, a01).
  EXPECT_TRUE(mc33::faceJoinsInside(-1, 1, -1, 1));
  EXPECT_FALSE(mc33::faceJoinsInside(-2, 1, -1, 1));
  EXPECT_TRUE(mc33::faceJoinsInside(-1, 3, -1, 0.5));
  // A corner exactly at the threshold is inside; its product is 0.
  EXPECT_FALSE(mc33::faceJoinsInside(0, -1, 1, -1));
  // Unambiguous faces never join.
  EXPECT_FALSE(mc33::faceJoinsInside(1, 1, -1, -1));
  EXPECT_FALSE(mc33::faceJoinsInside(1, 1, 1, 1));
  // (1 + e)(1 - e) = 1 - e^2 rounds to 1 = 1 * 1 in double, but is smaller: separated.
  const double e = std::ldexp(1.0, -30);
  EXPECT_FALSE(mc33::faceJoinsInside(1 + e, -1, 1 - e, -1));
  EXPECT_TRUE(mc33::faceJoinsInside(1 + e, -1, 1 + e, -1));
  EXPECT_TRUE(mc33::faceJoinsInside(-1, 1 + e, -(1 - e), 1));
  // NaN or infinite values: not joined.
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(mc33::faceJoinsInside(inf, -1, inf, -1));
  EXPECT_FALSE(mc33::faceJoinsInside(1, -1, 1, nan));
  EXPECT_FALSE(mc33::faceJoinsInside(2, -1, 2, -inf));
}

// ---- Brute-force reference -------------------------------------------------------------------

// The trilinear field of shifted corner values d at (x, y, z), as lerps exact at the corners.
double lerp(double a, double b, double t) {
  return (1.0 - t) * a + t * b;
}

// Sampling the field on an (N+1)^3 grid. Along x the field is linear on every row (j, k), so the
// samples of a row form at most two runs of one state, split where the linear function changes
// sign; the rows are labelled by run (6-connectivity), so the whole grid costs O(N^2).
struct SampledTopology {
  bool reliable = true;
  std::array<int, 12> component{};  // per crossed edge: its (inside, outside) component pair
  std::array<int, 12> loop{};       // per crossed edge: its (inside, outside) surface-region pair
  std::array<int, 8> corners{};     // per corner: its component of the inside or the outside
  int components = 0;
};

// Relabels a partition of the corners by first occurrence.
std::array<int, 8> cornerPartition(const std::array<int, 8>& raw) {
  std::array<int, 8> out{};
  std::map<int, int> names;
  for (std::size_t c = 0; c < 8; ++c) out[c] = names.emplace(raw[c], static_cast<int>(names.size())).first->second;
  return out;
}

// Storage reused from one cell to the next (one per thread).
struct SamplerBuffers {
  std::vector<char> state0;
  std::vector<int> split;
  Dsu volume;
  Dsu surface;
};

SampledTopology sampleCell(const double* d, int n) {
  thread_local SamplerBuffers buffers;
  SampledTopology out;
  const int m = n + 1;
  const std::size_t rows = static_cast<std::size_t>(m) * static_cast<std::size_t>(m);
  // Per row (j, k): the state at x = 0 and the first sample of the other state (m when uniform).
  std::vector<char>& state0 = buffers.state0;
  std::vector<int>& split = buffers.split;
  state0.resize(rows);
  split.resize(rows);
  const double inverse = 1.0 / n;
  auto row = [m](int j, int k) {
    return static_cast<std::size_t>(k) * static_cast<std::size_t>(m) + static_cast<std::size_t>(j);
  };
  for (int k = 0; k < m; ++k) {
    const double z = static_cast<double>(k) / n;
    for (int j = 0; j < m; ++j) {
      const double y = static_cast<double>(j) / n;
      const double a = lerp(lerp(d[0], d[2], y), lerp(d[4], d[6], y), z);
      const double b = lerp(lerp(d[1], d[3], y), lerp(d[5], d[7], y), z);
      const std::size_t r = row(j, k);
      state0[r] = a >= 0 ? 1 : 0;
      if ((a >= 0) == (b >= 0)) {
        split[r] = m;
      } else {
        // The first sample on b's side: from the root a / (a - b), corrected on the sampled values.
        const bool s0 = a >= 0;
        auto sampleState = [&](int i) { return lerp(a, b, static_cast<double>(i) * inverse) >= 0; };
        int i = std::clamp(static_cast<int>(a / (a - b) * n) + 1, 1, n);
        while (i > 1 && sampleState(i - 1) != s0) --i;
        while (i < n && sampleState(i) == s0) ++i;
        split[r] = i;
      }
    }
  }
  auto stateAt = [&](int i, int j, int k) {
    const std::size_t r = row(j, k);
    return i < split[r] ? state0[r] != 0 : state0[r] == 0;
  };
  // 3D labels: node 2r is the run holding x = 0, node 2r + 1 the other run.
  Dsu& volume = buffers.volume;
  volume.reset(2 * rows);
  auto runNode = [&](int i, int j, int k) {
    const std::size_t r = row(j, k);
    return static_cast<int>(2 * r + (i < split[r] ? 0 : 1));
  };
  auto joinRows = [&](Dsu& dsu, int j0, int k0, int j1, int k1) {
    const std::size_t r0 = row(j0, k0);
    const std::size_t r1 = row(j1, k1);
    // Runs overlap where some x has the same state in both rows: check the runs' extents.
    for (int a = 0; a < 2; ++a) {
      for (int b = 0; b < 2; ++b) {
        const int lo0 = a == 0 ? 0 : split[r0];
        const int hi0 = a == 0 ? split[r0] : m;
        const int lo1 = b == 0 ? 0 : split[r1];
        const int hi1 = b == 0 ? split[r1] : m;
        if (lo0 >= hi0 || lo1 >= hi1 || std::max(lo0, lo1) >= std::min(hi0, hi1)) continue;
        const bool s0 = a == 0 ? state0[r0] != 0 : state0[r0] == 0;
        const bool s1 = b == 0 ? state0[r1] != 0 : state0[r1] == 0;
        if (s0 == s1) dsu.unite(static_cast<int>(2 * r0) + a, static_cast<int>(2 * r1) + b);
      }
    }
  };
  for (int k = 0; k < m; ++k) {
    for (int j = 0; j < m; ++j) {
      if (j + 1 < m) joinRows(volume, j, k, j + 1, k);
      if (k + 1 < m) joinRows(volume, j, k, j, k + 1);
    }
  }
  // Surface labels: rows on the faces y = 0, N and z = 0, N by run (nodes 2r, 2r + 1); the other
  // rows meet the surface only at their ends, nodes 2 * rows + 2r (x = 0) and + 1 (x = N).
  Dsu& surface = buffers.surface;
  surface.reset(4 * rows);
  auto onSurfaceRow = [n](int j, int k) { return j == 0 || j == n || k == 0 || k == n; };
  auto surfaceNode = [&](int i, int j, int k) {
    if (onSurfaceRow(j, k)) return runNode(i, j, k);
    return static_cast<int>(2 * rows + 2 * row(j, k) + (i == 0 ? 0 : 1));
  };
  for (int t = 0; t + 1 < m; ++t) {
    for (int side : {0, n}) {
      joinRows(surface, side, t, side, t + 1);  // face y = side, along z
      joinRows(surface, t, side, t + 1, side);  // face z = side, along y
    }
  }
  for (int i : {0, n}) {
    for (int k = 0; k < m; ++k) {
      for (int j = 0; j < m; ++j) {
        if (j + 1 < m && stateAt(i, j, k) == stateAt(i, j + 1, k))
          surface.unite(surfaceNode(i, j, k), surfaceNode(i, j + 1, k));
        if (k + 1 < m && stateAt(i, j, k) == stateAt(i, j, k + 1))
          surface.unite(surfaceNode(i, j, k), surfaceNode(i, j, k + 1));
      }
    }
  }
  // Each crossed cube edge: the samples on either side of its (single) change of state.
  std::array<int, 12> rawComponent{};
  std::array<int, 12> rawLoop{};
  std::map<std::pair<int, int>, int> pairs;
  std::map<std::pair<int, int>, int> loopPairs;
  for (int e = 0; e < 12; ++e) {
    const auto& c = mc::kEdgeCorners[static_cast<std::size_t>(e)];
    if ((d[c[0]] >= 0) == (d[c[1]] >= 0)) {
      rawComponent[static_cast<std::size_t>(e)] = rawLoop[static_cast<std::size_t>(e)] = -1;
      continue;
    }
    const int axis = e / 4;
    std::array<int, 3> p{coord(c[0], 0) * n, coord(c[0], 1) * n, coord(c[0], 2) * n};
    std::array<int, 3> inSample{};
    std::array<int, 3> outSample{};
    int changes = 0;
    for (int s = 0; s < n; ++s) {
      std::array<int, 3> a = p;
      std::array<int, 3> b = p;
      a[static_cast<std::size_t>(axis)] = s;
      b[static_cast<std::size_t>(axis)] = s + 1;
      const bool sa = stateAt(a[0], a[1], a[2]);
      const bool sb = stateAt(b[0], b[1], b[2]);
      if (sa == sb) continue;
      ++changes;
      inSample = sa ? a : b;
      outSample = sa ? b : a;
    }
    if (changes != 1) {
      out.reliable = false;
      return out;
    }
    const std::pair<int, int> key{volume.find(runNode(inSample[0], inSample[1], inSample[2])),
                                  volume.find(runNode(outSample[0], outSample[1], outSample[2]))};
    const std::pair<int, int> loopKey{surface.find(surfaceNode(inSample[0], inSample[1], inSample[2])),
                                      surface.find(surfaceNode(outSample[0], outSample[1], outSample[2]))};
    rawComponent[static_cast<std::size_t>(e)] = pairs.emplace(key, static_cast<int>(pairs.size())).first->second;
    rawLoop[static_cast<std::size_t>(e)] = loopPairs.emplace(loopKey, static_cast<int>(loopPairs.size())).first->second;
  }
  out.component = canonicalPartition(rawComponent);
  out.loop = canonicalPartition(rawLoop);
  out.components = static_cast<int>(pairs.size());
  std::array<int, 8> rawCorners{};
  for (int c = 0; c < 8; ++c) {
    rawCorners[static_cast<std::size_t>(c)] = volume.find(runNode(coord(c, 0) * n, coord(c, 1) * n, coord(c, 2) * n));
  }
  out.corners = cornerPartition(rawCorners);
  return out;
}

// True when a face saddle or a critical point of the field inside the cell has a value within
// eps of 0: there the sampled topology may differ from the exact one.
bool nearDegenerate(const double* d, double eps) {
  for (int f = 0; f < 6; ++f) {
    const double a = d[faceCorner(f, 0)];
    const double b = d[faceCorner(f, 1)];
    const double c = d[faceCorner(f, 2)];
    const double e = d[faceCorner(f, 3)];
    const double den = a + c - b - e;
    if (den != 0 && (a >= 0) == (c >= 0) && (b >= 0) == (e >= 0) && (a >= 0) != (b >= 0) &&
        std::abs((a * c - b * e) / den) < eps) {
      return true;
    }
  }
  // F = k0 + kx x + ky y + kz z + kxy xy + kyz yz + kxz xz + kxyz xyz.
  const double k0 = d[0];
  const double kx = d[1] - d[0];
  const double ky = d[2] - d[0];
  const double kz = d[4] - d[0];
  const double kxy = d[0] - d[1] - d[2] + d[3];
  const double kyz = d[0] - d[2] - d[4] + d[6];
  const double kxz = d[0] - d[1] - d[4] + d[5];
  const double kxyz = -d[0] + d[1] + d[2] - d[3] + d[4] - d[5] - d[6] + d[7];
  auto field = [&](double x, double y, double z) {
    return k0 + kx * x + ky * y + kz * z + kxy * x * y + kyz * y * z + kxz * x * z + kxyz * x * y * z;
  };
  std::vector<std::array<double, 3>> critical;
  double scale = 0;
  for (int c = 0; c < 8; ++c) scale = std::max(scale, std::abs(d[c]));
  if (std::abs(kxyz) > 1e-9 * scale) {
    // F = h XYZ + p X + q Y + r Z + s with X = x + kyz/h, Y = y + kxz/h, Z = z + kxy/h; grad F = 0
    // gives YZ = -p/h, XZ = -q/h, XY = -r/h.
    const double h = kxyz;
    const double p = kx - kxz * kxy / h;
    const double q = ky - kyz * kxy / h;
    const double r = kz - kyz * kxz / h;
    const double w = -p * q * r / (h * h * h);
    if (w > 0 && p != 0 && q != 0 && r != 0) {
      for (double sign : {1.0, -1.0}) {
        const double xyz = sign * std::sqrt(w);
        critical.push_back({xyz / (-p / h) - kyz / h, xyz / (-q / h) - kxz / h, xyz / (-r / h) - kxy / h});
      }
    }
  } else {
    // grad F is linear: [0 kxy kxz; kxy 0 kyz; kxz kyz 0] (x y z) = -(kx ky kz).
    const double m[3][3] = {{0, kxy, kxz}, {kxy, 0, kyz}, {kxz, kyz, 0}};
    const double rhs[3] = {-kx, -ky, -kz};
    const double det = 2 * kxy * kxz * kyz;
    if (std::abs(det) > 1e-12 * scale * scale * scale) {
      std::array<double, 3> x{};
      for (int col = 0; col < 3; ++col) {
        double mm[3][3];
        for (int a = 0; a < 3; ++a) {
          for (int b = 0; b < 3; ++b) mm[a][b] = b == col ? rhs[a] : m[a][b];
        }
        x[static_cast<std::size_t>(col)] = (mm[0][0] * (mm[1][1] * mm[2][2] - mm[1][2] * mm[2][1]) -
                                            mm[0][1] * (mm[1][0] * mm[2][2] - mm[1][2] * mm[2][0]) +
                                            mm[0][2] * (mm[1][0] * mm[2][1] - mm[1][1] * mm[2][0])) /
                                           det;
      }
      critical.push_back(x);
    }
  }
  for (const auto& pt : critical) {
    if (pt[0] > 0 && pt[0] < 1 && pt[1] > 0 && pt[1] < 1 && pt[2] > 0 && pt[2] < 1 &&
        std::abs(field(pt[0], pt[1], pt[2])) < eps) {
      return true;
    }
  }
  return false;
}

// ---- Chernyaev's configurations --------------------------------------------------------------

// The 24 rotations of the cube as corner permutations.
std::vector<std::array<int, 8>> rotations() {
  std::vector<std::array<int, 8>> out;
  std::array<int, 3> perm{0, 1, 2};
  do {
    const int inversions = (perm[0] > perm[1]) + (perm[0] > perm[2]) + (perm[1] > perm[2]);
    for (int flips = 0; flips < 8; ++flips) {
      if ((inversions + __builtin_popcount(static_cast<unsigned>(flips))) % 2 != 0) continue;
      std::array<int, 8> map{};
      for (int c = 0; c < 8; ++c) {
        int image = 0;
        for (int a = 0; a < 3; ++a) {
          image |= (coord(c, perm[static_cast<std::size_t>(a)]) ^ ((flips >> a) & 1)) << a;
        }
        map[static_cast<std::size_t>(c)] = image;
      }
      out.push_back(map);
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return out;
}

unsigned mapCase(unsigned cas, const std::array<int, 8>& map) {
  unsigned out = 0;
  for (int c = 0; c < 8; ++c) {
    if (isInside(cas, c)) out |= 1u << map[static_cast<std::size_t>(c)];
  }
  return out;
}

// Chernyaev's base case (Lorensen's numbering) of each of the 256 cases, under the 24 rotations
// and complement, as in Lorensen and Cline and in Chernyaev: 11 and 14 are mirror images (checked
// in Mc33Topology), as are 12.2 and 12.3, so with reflections only 31 configurations would remain.
// Representatives: 11 holds the corners {0, 1, 3, 4}, 14 the corners {0, 1, 3, 7}.
std::array<int, 256> baseCases() {
  const std::array<unsigned, 15> reps = {0x00, 0x01, 0x03, 0x09, 0x81, 0x07, 0x83, 0x16,
                                         0x0F, 0x17, 0xC3, 0x1B, 0x87, 0x69, 0x8B};
  std::array<int, 256> base{};
  base.fill(-1);
  for (const auto& r : rotations()) {
    for (int k = 0; k < 15; ++k) {
      for (unsigned image :
           {mapCase(reps[static_cast<std::size_t>(k)], r), 255u ^ mapCase(reps[static_cast<std::size_t>(k)], r)}) {
        if (base[image] >= 0 && base[image] != k) ADD_FAILURE() << "case " << image << " in two classes";
        base[image] = k;
      }
    }
  }
  return base;
}

// A tested cell's configuration: its case with the diagonal each ambiguous face connects, brought
// to a canonical form over the rotations and complement (with at most four inside corners), and
// the sampled topology (components, loops per component).
struct Configuration {
  int base = 0;
  std::string name;
  std::vector<int> canonical;
};

Configuration classify(unsigned key, const MeshTopology& topo, const std::array<int, 256>& base,
                       const std::vector<std::array<int, 8>>& rots) {
  const unsigned cas = mc33::keyCase(key);
  std::vector<EdgePair> connected;  // per ambiguous face, the diagonal its decision connects
  for (int f = 0; f < 6; ++f) {
    if (!ambiguousFace(cas, f)) continue;
    const bool joined = ((mc33::keyFaces(key) >> f) & 1u) != 0;
    const int c0 = faceCorner(f, 0);
    const bool pair02 = joined == isInside(cas, c0);
    connected.push_back(pair02 ? sorted(c0, faceCorner(f, 2)) : sorted(faceCorner(f, 1), faceCorner(f, 3)));
  }
  Configuration out;
  out.base = base[cas];
  int joinedCount = -1;
  for (const auto& r : rots) {
    for (int complement = 0; complement < 2; ++complement) {
      unsigned image = mapCase(cas, r);
      if (complement != 0) image ^= 255u;
      if (__builtin_popcount(image) > 4) continue;
      std::vector<int> form{static_cast<int>(image)};
      std::vector<int> pairs;
      int joined = 0;
      for (const auto& [a, b] : connected) {
        const int ma = r[static_cast<std::size_t>(a)];
        const int mb = r[static_cast<std::size_t>(b)];
        pairs.push_back(std::min(ma, mb) * 8 + std::max(ma, mb));
        joined += isInside(image, ma) ? 1 : 0;
      }
      std::sort(pairs.begin(), pairs.end());
      form.insert(form.end(), pairs.begin(), pairs.end());
      if (out.canonical.empty() || form < out.canonical) {
        out.canonical = form;
        joinedCount = joined;
      }
    }
  }
  std::vector<int> loops = topo.loops;
  std::sort(loops.begin(), loops.end());
  out.canonical.push_back(-1);
  out.canonical.push_back(topo.components);
  out.canonical.insert(out.canonical.end(), loops.begin(), loops.end());
  const int ambiguous = static_cast<int>(connected.size());
  const int j = std::min(joinedCount, ambiguous - joinedCount);  // joins counted up to complement
  const int comps = topo.components;
  const int maxLoops = loops.empty() ? 0 : loops.back();
  switch (out.base) {
    case 3:
      out.name = comps == 2 ? "3.1" : "3.2";
      break;
    case 4:
      out.name = comps == 2 ? "4.1.1" : "4.1.2";
      break;
    case 6:
      out.name = comps == 2 ? "6.1.1" : (maxLoops == 2 ? "6.1.2" : "6.2");
      break;
    case 7:
      out.name = joinedCount < 3 ? "7." + std::to_string(joinedCount + 1) : (comps == 2 ? "7.4.1" : "7.4.2");
      break;
    case 10:
      out.name = j == 1 ? "10.2" : (comps == 2 ? "10.1.1" : "10.1.2");
      break;
    case 12:
      // 12.2 and 12.3 are mirror images: named by the canonical form (the smaller one is 12.2).
      out.name = j == 1 ? "12.2/3" : (comps == 2 ? "12.1.1" : "12.1.2");
      break;
    case 13:
      if (j < 3) {
        out.name = "13." + std::to_string(j + 1);
      } else {
        out.name = comps == 1 ? "13.4" : (comps == 3 ? "13.5.1" : "13.5.2");
      }
      break;
    default:
      out.name = std::to_string(out.base);
  }
  return out;
}

// Random corner values for a cell: a case drawn per base case, magnitudes from several laws.
struct CellMaker {
  std::mt19937_64 rng{20240611};
  std::array<std::vector<unsigned>, 15> casesOf;
  explicit CellMaker(const std::array<int, 256>& base) {
    for (unsigned cas = 0; cas < 256; ++cas) casesOf[static_cast<std::size_t>(base[cas])].push_back(cas);
  }
  double uniform() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng); }
  double symmetric() { return 2.0 * uniform() - 1.0; }
  // Fills v for a case of base case k and returns the threshold.
  float draw(int k, float* v) {
    const auto& list = casesOf[static_cast<std::size_t>(k)];
    const unsigned cas = list[rng() % list.size()];
    const float threshold = std::array<float, 4>{0.0f, 0.5f, 100.25f, -3.0f}[rng() % 4];
    const int law = static_cast<int>(rng() % 5);
    const double level = 0.2 + uniform();
    const double other = 0.2 + uniform();
    const double spread = std::array<double, 3>{0.05, 0.15, 0.3}[rng() % 3];
    for (int c = 0; c < 8; ++c) {
      double m = 0;
      switch (law) {
        case 0:
          m = 0.02 + uniform();
          break;
        case 1:
          m = std::exp(-6.0 * uniform());
          break;
        case 2:
          // Near-symmetric magnitudes: faces and body near their saddles, where tunnels open.
          m = level * (1.0 + spread * symmetric());
          break;
        case 3:
          m = (isInside(cas, c) ? level : other) * (1.0 + spread * symmetric());
          break;
        default:
          m = 0.05 + std::pow(uniform(), 3.0);
      }
      v[c] = static_cast<float>(static_cast<double>(threshold) + (isInside(cas, c) ? m : -m));
    }
    return threshold;
  }
  // Cell `index`: one in four of any base case, the others of a base case with an ambiguity (3, 4,
  // 6, 7, 10, 12, 13); one in four of those is redrawn (up to 64 times) until its interior joins,
  // so that the rare tunnels (6.1.2, 10.1.2, 12.1.2, 13.5.2) are tested often.
  float make(int index, float* v) {
    static constexpr int kAmbiguous[7] = {3, 4, 6, 7, 10, 12, 13};
    if (index % 4 == 0) return draw(static_cast<int>(rng() % 15), v);
    const int k = kAmbiguous[rng() % 7];
    float threshold = draw(k, v);
    if (index % 4 == 1) {
      for (int attempt = 0; attempt < 64 && mc33::keyInterior(mc33::cellKey(v, threshold)) == 0; ++attempt) {
        threshold = draw(k, v);
      }
    }
    return threshold;
  }
};

#if defined(__SANITIZE_ADDRESS__)
constexpr int kFine = 40;
constexpr int kCoarse = 27;
#else
constexpr int kFine = 64;
constexpr int kCoarse = 41;
#endif
constexpr int kCells = 12000;
// Saddle values (relative to the largest corner value) below which a cell is skipped, and below
// which it is sampled three times finer.
constexpr double kSkip = 2e-4;
constexpr double kDelicate = 3e-3;

TEST(Mc33Topology, SingleCellsMatchBruteForceSamplingAndCoverThe33Configurations) {
  const auto start = std::chrono::steady_clock::now();
  const std::array<int, 256> base = baseCases();
  for (unsigned cas = 0; cas < 256; ++cas) ASSERT_GE(base[cas], 0) << cas;
  const auto rots = rotations();
  ASSERT_EQ(rots.size(), 24u);
  // 14 is 11 reflected in the plane x = y (corners 1 and 2 swap, 5 and 6 swap).
  const std::array<int, 8> reflection = {0, 2, 1, 3, 4, 6, 5, 7};
  EXPECT_EQ(base[mapCase(0x1B, reflection)], 14);
  CellMaker maker(base);
  std::map<int, std::set<std::vector<int>>> orbits;  // per base case, the configurations seen
  std::map<std::vector<int>, std::string> orbitName;
  std::map<std::vector<int>, int> orbitHits;
  std::map<unsigned, MeshTopology> meshes;
  int skippedNear = 0;
  int delicate = 0;
  int sweepMismatches = 0;
  int skipped = 0;
  int tested = 0;
  int mismatches = 0;
  for (int n = 0; n < kCells; ++n) {
    float v[8];
    const float threshold = maker.make(n, v);
    double d[8];
    double scale = 0;
    for (int c = 0; c < 8; ++c) {
      d[c] = static_cast<double>(v[c]) - static_cast<double>(threshold);
      scale = std::max(scale, std::abs(d[c]));
    }
    const unsigned key = mc33::cellKey(v, threshold);
    ASSERT_EQ(key, mc33::cellKey(v, threshold));
    ASSERT_TRUE(mc33::isValidKey(key));
    if (nearDegenerate(d, kSkip * scale)) {
      ++skipped;
      ++skippedNear;
      continue;
    }
    // Within kDelicate of a saddle, necks and gaps are thin: sample three times finer.
    const int refine = nearDegenerate(d, kDelicate * scale) ? 3 : 1;
    delicate += refine > 1 ? 1 : 0;
    const SampledTopology fine = sampleCell(d, refine * kFine);
    const SampledTopology coarse = sampleCell(d, refine * kCoarse);
    if (!fine.reliable || !coarse.reliable || fine.component != coarse.component || fine.loop != coarse.loop) {
      ++skipped;
      continue;
    }
    ++tested;
    // The sweep alone finds the sampled components of the inside and the outside.
    std::array<int, 8> sweep{};
    const auto labels = mc33::sweepComponents(d);
    for (std::size_t c = 0; c < 8; ++c) sweep[c] = labels[c];
    if (cornerPartition(sweep) != fine.corners) {
      ++sweepMismatches;
      if (sweepMismatches <= 5) ADD_FAILURE() << "cell " << n << ": the sweep's components differ from sampling";
    }
    const unsigned cas = mc33::keyCase(key);
    auto cached = meshes.find(key);
    if (cached == meshes.end())
      cached = meshes.emplace(key, meshTopology(mc33::buildCase(key), crossedEdges(cas))).first;
    const MeshTopology& mesh = cached->second;
    const bool same = mesh.component == fine.component && mesh.loop == fine.loop && mesh.components == fine.components;
    if (!same) {
      ++mismatches;
      if (mismatches <= 10) {
        std::string values;
        for (double x : d) values += " " + std::to_string(x);
        ADD_FAILURE() << "cell " << n << " key " << key << " (case " << cas << ", faces " << mc33::keyFaces(key)
                      << ", interior " << mc33::keyInterior(key) << "): mesh has " << mesh.components
                      << " components, sampling " << fine.components << "; values" << values;
      }
      continue;
    }
    for (std::size_t k = 0; k < mesh.euler.size(); ++k) ASSERT_EQ(mesh.euler[k], 2 - mesh.loops[k]);
    const Configuration config = classify(key, mesh, base, rots);
    orbits[config.base].insert(config.canonical);
    orbitName[config.canonical] = config.name;
    ++orbitHits[config.canonical];
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_EQ(sweepMismatches, 0);
  // 12.2 and 12.3 (mirror images, distinct under rotations and complement): the smaller canonical
  // form is called 12.2.
  int mirror = 0;
  for (const auto& form : orbits[12]) {
    if (orbitName[form] == "12.2/3") orbitName[form] = mirror++ == 0 ? "12.2" : "12.3";
  }
  std::map<std::string, int> hits;
  for (const auto& [form, count] : orbitHits) hits[orbitName[form]] += count;
  const std::vector<std::string> names = {
      "0",      "1",      "2",    "3.1",   "3.2",   "4.1.1", "4.1.2", "5",      "6.1.1",  "6.1.2",  "6.2",
      "7.1",    "7.2",    "7.3",  "7.4.1", "7.4.2", "8",     "9",     "10.1.1", "10.1.2", "10.2",   "11",
      "12.1.1", "12.1.2", "12.2", "12.3",  "13.1",  "13.2",  "13.3",  "13.4",   "13.5.1", "13.5.2", "14"};
  ASSERT_EQ(names.size(), 33u);
  std::string table;
  for (std::size_t k = 0; k < names.size(); ++k) {
    table += names[k] + ":" + std::to_string(hits[names[k]]) + (k % 8 == 7 ? "\n" : "  ");
    EXPECT_GT(hits[names[k]], 0) << "configuration " << names[k] << " never tested";
  }
  EXPECT_EQ(hits.size(), 33u) << "configurations outside Chernyaev's 33";
  // Distinct configurations per base case (Chernyaev): 1,1,1,2,2,1,3,5,1,1,3,1,4,6,1 = 33.
  const std::array<std::size_t, 15> perBase = {1, 1, 1, 2, 2, 1, 3, 5, 1, 1, 3, 1, 4, 6, 1};
  for (int k = 0; k < 15; ++k) EXPECT_EQ(orbits[k].size(), perBase[static_cast<std::size_t>(k)]) << "base case " << k;
  std::printf("[mc33] configurations tested:\n%s\n", table.c_str());
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "[mc33] %d cells: %d compared with sampling at N = %d and %d (%d of them near a saddle at 3N), %d skipped "
      "(%.2f%%; %d near a saddle), %.1f s\n",
      kCells, tested, kFine, kCoarse, delicate, skipped, 100.0 * skipped / kCells, skippedNear, seconds);
  EXPECT_GE(tested, 10000);
  EXPECT_LT(skipped, kCells / 50);
}

// The boundary regions of a key (corners linked by cube edges and the face decisions), computed
// here from the face segments' definition rather than taken from the library.
std::array<int, 8> boundaryRegions(unsigned cas, unsigned faces) {
  Dsu dsu(8);
  for (const auto& e : mc::kEdgeCorners) {
    if (isInside(cas, e[0]) == isInside(cas, e[1])) dsu.unite(e[0], e[1]);
  }
  for (int f = 0; f < 6; ++f) {
    if (!ambiguousFace(cas, f)) continue;
    const bool joined = ((faces >> f) & 1u) != 0;
    const bool insideAt0 = isInside(cas, faceCorner(f, 0));
    if (joined == insideAt0) {
      dsu.unite(faceCorner(f, 0), faceCorner(f, 2));
    } else {
      dsu.unite(faceCorner(f, 1), faceCorner(f, 3));
    }
  }
  std::array<int, 8> out{};
  for (int c = 0; c < 8; ++c) out[static_cast<std::size_t>(c)] = dsu.find(c);
  return cornerPartition(out);
}

// On many cells (no sampling): the key's case and face bits are the definitions', and whatever the
// exact sweep joins beyond the faces is at most one of the key's interior candidates, the one its
// interior code names.
TEST(Mc33Decider, KeysFollowTheDefinitionsAndInteriorJoinsAreCandidates) {
  const std::array<int, 256> base = baseCases();
  CellMaker maker(base);
#if defined(__SANITIZE_ADDRESS__)
  constexpr int kDraws = 100000;
#else
  constexpr int kDraws = 600000;
#endif
  int joins = 0;
  std::set<unsigned> seen;
  for (int n = 0; n < kDraws; ++n) {
    float v[8];
    const float threshold = maker.draw(static_cast<int>(maker.rng() % 15), v);
    const unsigned key = mc33::cellKey(v, threshold);
    ASSERT_TRUE(mc33::isValidKey(key));
    seen.insert(key);
    unsigned cas = 0;
    double d[8];
    for (int c = 0; c < 8; ++c) {
      cas |= (v[c] >= threshold ? 1u : 0u) << c;
      d[c] = static_cast<double>(v[c]) - static_cast<double>(threshold);
    }
    ASSERT_EQ(mc33::keyCase(key), cas);
    unsigned faces = 0;
    for (int f = 0; f < 6; ++f) {
      if (mc33::faceJoinsInside(d[faceCorner(f, 0)], d[faceCorner(f, 1)], d[faceCorner(f, 2)], d[faceCorner(f, 3)])) {
        faces |= 1u << f;
      }
    }
    ASSERT_EQ(mc33::keyFaces(key), faces);
    // Components of the sweep, merged with the boundary regions.
    const std::array<int, 8> regions = boundaryRegions(cas, faces);
    const auto labels = mc33::sweepComponents(d);
    Dsu merged(8);
    for (int c = 0; c < 8; ++c) {
      merged.unite(c, labels[static_cast<std::size_t>(c)]);
      for (int c2 = 0; c2 < 8; ++c2) {
        if (regions[static_cast<std::size_t>(c)] == regions[static_cast<std::size_t>(c2)]) merged.unite(c, c2);
      }
    }
    std::set<EdgePair> joined;  // region pairs the interior joins, by smallest corner
    for (int c = 0; c < 8; ++c) {
      for (int c2 = c + 1; c2 < 8; ++c2) {
        const bool firstOfRegion = std::find(regions.begin(), regions.begin() + c,
                                             regions[static_cast<std::size_t>(c)]) == regions.begin() + c;
        const bool firstOfRegion2 = std::find(regions.begin(), regions.begin() + c2,
                                              regions[static_cast<std::size_t>(c2)]) == regions.begin() + c2;
        if (firstOfRegion && firstOfRegion2 &&
            regions[static_cast<std::size_t>(c)] != regions[static_cast<std::size_t>(c2)] &&
            merged.find(c) == merged.find(c2)) {
          joined.insert({c, c2});
        }
      }
    }
    ASSERT_LE(joined.size(), 1u) << "cell " << n;
    const auto candidates = mc33::interiorCandidates(cas, faces);
    const unsigned code = mc33::keyInterior(key);
    if (joined.empty()) {
      ASSERT_EQ(code, 0u) << "cell " << n;
      continue;
    }
    ++joins;
    ASSERT_GE(code, 1u) << "cell " << n << ": the interior joins corners " << joined.begin()->first << " and "
                        << joined.begin()->second << " (case " << cas << ", faces " << faces << ")";
    const auto& named = candidates[code - 1];
    ASSERT_EQ(EdgePair(named[0], named[1]), *joined.begin()) << "cell " << n;
  }
  std::printf("[mc33] %d cells, %d with an interior join, %zu distinct keys of %zu valid ones\n", kDraws, joins,
              seen.size(), mc33::allKeys().size());
  EXPECT_GT(joins, kDraws / 200);
#if !defined(__SANITIZE_ADDRESS__)
  // Every valid key occurs (and buildCase refuses the others): exactly the reachable keys.
  EXPECT_EQ(seen.size(), mc33::allKeys().size());
#endif
}

TEST(Mc33Decider, NonFiniteValuesGiveValidKeysWithoutInteriorJoins) {
  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> value(-2.0f, 2.0f);
  std::set<unsigned> keys;
  for (int n = 0; n < 200000; ++n) {
    float v[8];
    for (float& x : v) x = value(rng);
    const int specials = 1 + static_cast<int>(rng() % 3);
    for (int s = 0; s < specials; ++s) v[rng() % 8] = std::array<float, 3>{nan, inf, -inf}[rng() % 3];
    const float threshold = n % 50 == 0 ? std::array<float, 3>{nan, inf, -inf}[rng() % 3] : 0.0f;
    const unsigned key = mc33::cellKey(v, threshold);
    ASSERT_EQ(key, mc33::cellKey(v, threshold));
    ASSERT_TRUE(mc33::isValidKey(key));
    ASSERT_EQ(mc33::keyInterior(key), 0u);
    unsigned cas = 0;
    for (int c = 0; c < 8; ++c) cas |= (v[c] >= threshold ? 1u : 0u) << c;  // NaN is outside
    ASSERT_EQ(mc33::keyCase(key), cas);
    for (int f = 0; f < 6; ++f) {
      bool finite = std::isfinite(threshold);
      for (int m = 0; m < 4; ++m) finite = finite && std::isfinite(v[faceCorner(f, m)]);
      if (!finite) {
        ASSERT_EQ((mc33::keyFaces(key) >> f) & 1u, 0u);
      }
    }
    keys.insert(key);
  }
  for (unsigned key : keys) {
    const auto errors = checkKey(key);
    for (const auto& e : errors) ADD_FAILURE() << e;
  }
  EXPECT_GT(keys.size(), 100u);
  // A NaN threshold leaves every corner outside.
  const float ones[8] = {1, 1, 1, 1, 1, 1, 1, 1};
  EXPECT_EQ(mc33::cellKey(ones, nan), 0u);
}

}  // namespace
}  // namespace isoslab
