// Fans of a mesh's vertices (core/fans.h), against a brute force written here.
#include "core/fans.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <random>
#include <vector>

namespace isoslab {
namespace {

// The fans at v: v's triangles, two joined where they share an edge at v (a vertex besides v), by a
// flood over the pairs.
std::uint32_t bruteFans(const std::vector<Triangle>& triangles, VertexId v) {
  std::vector<std::size_t> at;
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (VertexId u : triangles[t]) {
      if (u == v) {
        at.push_back(t);
        break;
      }
    }
  }
  std::vector<bool> reached(at.size(), false);
  std::uint32_t fans = 0;
  for (std::size_t s = 0; s < at.size(); ++s) {
    if (reached[s]) continue;
    ++fans;
    std::vector<std::size_t> todo{s};
    reached[s] = true;
    while (!todo.empty()) {
      const std::size_t i = todo.back();
      todo.pop_back();
      for (std::size_t j = 0; j < at.size(); ++j) {
        if (reached[j]) continue;
        bool joined = false;
        for (VertexId a : triangles[at[i]]) {
          for (VertexId b : triangles[at[j]]) joined = joined || (a == b && a != v);
        }
        if (joined) {
          reached[j] = true;
          todo.push_back(j);
        }
      }
    }
  }
  return fans;
}

// Whether v's triangles are one fan whose every edge at v is in exactly two of them, once each way.
bool bruteClosed(const std::vector<Triangle>& triangles, VertexId v) {
  std::map<VertexId, std::pair<int, int>> edges;  // other end: (uses from v, uses into v)
  for (const Triangle& t : triangles) {
    for (std::size_t k = 0; k < 3; ++k) {
      if (t[k] != v) continue;
      ++edges[t[(k + 1) % 3]].first;
      ++edges[t[(k + 2) % 3]].second;
    }
  }
  if (edges.empty()) return false;
  for (const auto& [end, uses] : edges) {
    if (uses.first != 1 || uses.second != 1) return false;
  }
  return bruteFans(triangles, v) == 1;
}

// oneCycle against its definition, on every pair of (next, prev) arrays of 3 and 4 triangles over
// n + 1 vertex names, and on random ones of 5 to 8: one closed fan wound one way is every name used
// as often as a next as a prev, at most once each, and the triangles joined into one through those
// uses (triangle i to the j whose prev is i's next).
TEST(Fans, OneCycleMatchesItsDefinition) {
  const auto brute = [](const std::vector<VertexId>& next, const std::vector<VertexId>& prev) {
    const std::size_t n = next.size();
    std::map<VertexId, std::pair<int, int>> uses;
    for (std::size_t i = 0; i < n; ++i) ++uses[next[i]].first, ++uses[prev[i]].second;
    for (const auto& [name, count] : uses) {
      if (count.first != 1 || count.second != 1) return false;
    }
    std::vector<std::size_t> group(n);
    for (std::size_t i = 0; i < n; ++i) group[i] = i;
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = 0; j < n; ++j) {
          if (next[i] == prev[j] && group[i] != group[j]) {
            group[i] = group[j] = std::min(group[i], group[j]);
            changed = true;
          }
        }
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (group[i] != 0) return false;
    }
    return true;
  };
  std::size_t closed = 0, tried = 0;
  const auto one = [&](const std::vector<VertexId>& next, const std::vector<VertexId>& prev) {
    const bool want = brute(next, prev);
    ASSERT_EQ(detail::oneCycle(next, prev), want)
        << ::testing::PrintToString(next) << " " << ::testing::PrintToString(prev);
    closed += want ? 1 : 0;
    ++tried;
  };
  for (std::size_t n = 3; n <= 4; ++n) {
    const std::size_t names = n + 1;
    std::size_t all = 1;
    for (std::size_t k = 0; k < 2 * n; ++k) all *= names;
    std::vector<VertexId> next(n), prev(n);
    for (std::size_t code = 0; code < all; ++code) {
      std::size_t c = code;
      for (std::size_t k = 0; k < n; ++k, c /= names) next[k] = static_cast<VertexId>(c % names);
      for (std::size_t k = 0; k < n; ++k, c /= names) prev[k] = static_cast<VertexId>(c % names);
      one(next, prev);
      if (HasFatalFailure()) return;
    }
  }
  // The cycles of n names, each (next, prev) = (c[i + 1], c[i]) in some order of its triangles,
  // then one name changed to another (or a new one).
  std::mt19937 random(11);
  for (int round = 0; round < 20000; ++round) {
    const std::size_t n = 5 + static_cast<std::size_t>(random() % 4);
    std::vector<VertexId> cycle(n), order(n);
    for (std::size_t i = 0; i < n; ++i) cycle[i] = static_cast<VertexId>(i), order[i] = static_cast<VertexId>(i);
    std::shuffle(cycle.begin(), cycle.end(), random);
    std::shuffle(order.begin(), order.end(), random);
    std::vector<VertexId> next(n), prev(n);
    for (std::size_t i = 0; i < n; ++i) next[order[i]] = cycle[(i + 1) % n], prev[order[i]] = cycle[i];
    if (round % 2 == 1) {
      std::vector<VertexId>& side = random() % 2 ? next : prev;
      side[random() % n] = static_cast<VertexId>(random() % (n + 1));
    }
    one(next, prev);
    if (HasFatalFailure()) return;
  }
  EXPECT_GT(closed, 10000u);  // the unspoiled cycles, and some of the exhaustive arrays
  EXPECT_EQ(tried, 4096u + 390625u + 20000u);
}

// Bipyramids (apexes with 3 to 20 triangles, every vertex one closed fan), then each spoiled once:
// a triangle turned over, dropped, repeated, or a fin on an edge. `closed` and the fan counts
// against the brute force, vertex by vertex.
TEST(Fans, ClosedFansMatchABruteForceOnSpoiledBipyramids) {
  for (VertexId n = 3; n <= 20; ++n) {
    std::vector<Triangle> pyramid;
    const VertexId top = n, bottom = n + 1;
    for (VertexId i = 0; i < n; ++i) {
      pyramid.push_back({top, i, (i + 1) % n});
      pyramid.push_back({bottom, (i + 1) % n, i});
    }
    for (int spoil = 0; spoil < 5; ++spoil) {
      std::vector<Triangle> triangles = pyramid;
      const std::size_t t = (n * 7 + static_cast<std::size_t>(spoil)) % triangles.size();
      if (spoil == 1) std::swap(triangles[t][1], triangles[t][2]);
      if (spoil == 2) triangles.erase(triangles.begin() + static_cast<std::ptrdiff_t>(t));
      if (spoil == 3) triangles.push_back(triangles[t]);
      if (spoil == 4) triangles.push_back({triangles[t][1], triangles[t][0], n + 2});
      ScratchVector<std::uint8_t> closed;
      const ScratchVector<std::uint32_t> fans = fanCounts(triangles, n + 3, 0, &closed);
      for (VertexId v = 0; v < n + 3; ++v) {
        SCOPED_TRACE(testing::Message() << n << " " << spoil << " " << v);
        EXPECT_EQ(fans[v], bruteFans(triangles, v));
        // Up to 16 triangles at a vertex are tested; more are left to the general count.
        std::size_t at = 0;
        for (const Triangle& tri : triangles) at += (tri[0] == v || tri[1] == v || tri[2] == v) ? 1 : 0;
        EXPECT_EQ(closed[v] != 0, at <= 16 && bruteClosed(triangles, v));
        if (spoil == 0 && at > 0 && at <= 16) {
          EXPECT_EQ(closed[v], 1);
        }
      }
    }
  }
}

TEST(Fans, CountsMatchABruteForceOnRandomMeshes) {
  std::mt19937 random(7);
  for (int round = 0; round < 300; ++round) {
    const VertexId base = round % 3 == 0 ? 0 : 1000 + static_cast<VertexId>(round);
    const auto vertices = static_cast<VertexId>(4 + round % 20);
    std::uniform_int_distribution<VertexId> pick(base, base + vertices - 1);
    std::vector<Triangle> triangles;
    // A closed octahedron's worth of structure sometimes, random triangles always (pinches, fins,
    // isolated vertices: anything).
    for (int t = 0; t < 5 + round % 40; ++t) {
      Triangle tri{pick(random), pick(random), pick(random)};
      if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) continue;
      triangles.push_back(tri);
    }
    const ScratchVector<std::uint32_t> fans = fanCounts(triangles, vertices, base);
    std::vector<VertexId> some;
    for (VertexId v = base; v < base + vertices; ++v) {
      ASSERT_EQ(fans[v - base], bruteFans(triangles, v)) << round << " " << v;
      if ((v + round) % 3 != 0) some.push_back(v);
    }
    const std::vector<std::uint32_t> listed = fanCountsAt(triangles, some);
    ASSERT_EQ(listed.size(), some.size());
    for (std::size_t i = 0; i < some.size(); ++i) EXPECT_EQ(listed[i], fans[some[i] - base]) << round;
  }
  EXPECT_TRUE(fanCountsAt(std::vector<Triangle>{{0, 1, 2}}, std::vector<VertexId>{}).empty());
}

// A bowtie: two triangles that share only vertex 0 give it two fans; a third triangle that joins
// them along edges at 0 makes one.
TEST(Fans, ABowtieHasTwoFansAtItsKnot) {
  std::vector<Triangle> triangles{{0, 1, 2}, {0, 3, 4}};
  EXPECT_EQ(fanCounts(triangles, 5)[0], 2u);
  EXPECT_EQ(fanCountsAt(triangles, std::vector<VertexId>{0, 4}), (std::vector<std::uint32_t>{2, 1}));
  triangles.push_back({0, 2, 3});
  EXPECT_EQ(fanCounts(triangles, 5)[0], 1u);
  EXPECT_EQ(fanCountsAt(triangles, std::vector<VertexId>{0}), (std::vector<std::uint32_t>{1}));
}

// A hub of many triangles (its ends sorted by std::sort, not by insertion): a closed fan of 20 and
// a second sheet of 2 touching it only at the hub.
TEST(Fans, AHubOfManyTrianglesCountsBothSheets) {
  std::vector<Triangle> triangles;
  for (VertexId i = 1; i <= 20; ++i) triangles.push_back({0, i, i % 20 + 1});
  triangles.push_back({0, 21, 22});
  triangles.push_back({0, 22, 23});
  EXPECT_EQ(fanCounts(triangles, 24)[0], 2u);
  EXPECT_EQ(bruteFans(triangles, 0), 2u);
  EXPECT_EQ(fanCountsAt(triangles, std::vector<VertexId>{0, 5, 22}), (std::vector<std::uint32_t>{2, 1, 1}));
  triangles.push_back({0, 23, 21});  // the second sheet closed: still apart from the first
  EXPECT_EQ(fanCounts(triangles, 24)[0], 2u);
  triangles.push_back({0, 20, 21});  // joined to the first along edge 0-21... and 0-20
  EXPECT_EQ(fanCounts(triangles, 24)[0], bruteFans(triangles, 0));
  EXPECT_EQ(fanCounts(triangles, 24)[0], 1u);
}

}  // namespace
}  // namespace isoslab
