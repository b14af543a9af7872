// The simplifier (process/simplifier.h): what it keeps of a surface, checked here from the triangles
// alone: edges, Euler characteristic, borders, the target and the hooks.
#include "process/simplifier.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "test_support.h"

namespace isoslab {
namespace {

struct Flat {
  std::vector<float> xyz;
  std::vector<std::uint32_t> indices;
  std::size_t vertices() const { return xyz.size() / 3; }
};

Flat flatten(const IndexedMesh& mesh) {
  Flat f;
  for (const Vec3f& p : mesh.positions) f.xyz.insert(f.xyz.end(), {p.x, p.y, p.z});
  for (const Triangle& t : mesh.triangles) f.indices.insert(f.indices.end(), t.begin(), t.end());
  return f;
}

Flat extracted(std::array<std::int64_t, 3> dims,
               const std::function<float(std::int64_t, std::int64_t, std::int64_t)>& f) {
  testing::VectorSource source(dims, f);
  return flatten(testing::extract(source, Method::kMarchingCubes, 0.0).mesh);
}

// What the triangles say of themselves, counted by brute force.
struct Shape {
  std::size_t triangles = 0, vertices = 0, edges = 0;
  std::size_t border = 0, nonManifold = 0, sameWay = 0, degenerate = 0, repeated = 0;
  std::set<std::pair<std::uint32_t, std::uint32_t>> borderEdges;  // as the triangles run them
  long euler() const { return long(vertices) - long(edges) + long(triangles); }
};

Shape shapeOf(const Flat& m, std::size_t count) {
  Shape s;
  s.triangles = count / 3;
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::pair<int, int>> edges;  // (uses, from the smaller)
  std::set<std::uint32_t> used;
  std::set<std::array<std::uint32_t, 3>> seen;
  for (std::size_t t = 0; t < s.triangles; ++t) {
    std::array<std::uint32_t, 3> v{m.indices[3 * t], m.indices[3 * t + 1], m.indices[3 * t + 2]};
    for (std::size_t k = 0; k < 3; ++k) {
      used.insert(v[k]);
      const std::uint32_t a = v[k], b = v[(k + 1) % 3];
      auto& e = edges[{std::min(a, b), std::max(a, b)}];
      ++e.first;
      e.second += a < b ? 1 : 0;
    }
    const auto at = [&](std::uint32_t i) {
      return std::array<double, 3>{m.xyz[3 * i], m.xyz[3 * i + 1], m.xyz[3 * i + 2]};
    };
    const auto a = at(v[0]), b = at(v[1]), c = at(v[2]);
    const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    const double wx = c[0] - a[0], wy = c[1] - a[1], wz = c[2] - a[2];
    const double n = std::hypot(uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx);
    s.degenerate += n == 0 ? 1 : 0;
    std::array<std::uint32_t, 3> key = v;
    std::sort(key.begin(), key.end());
    s.repeated += seen.insert(key).second ? 0 : 1;
  }
  for (const auto& [key, e] : edges) {
    if (e.first == 1) {
      ++s.border;
      s.borderEdges.insert(e.second == 1 ? key : std::pair{key.second, key.first});
    }
    s.nonManifold += e.first > 2 ? 1 : 0;
    s.sameWay += e.first == 2 && e.second != 1 ? 1 : 0;
  }
  s.vertices = used.size();
  s.edges = edges.size();
  return s;
}

// A closed, oriented 2-manifold with no flat or repeated triangle, of the given Euler
// characteristic.
void expectClosedSurface(const Shape& s, long euler) {
  EXPECT_EQ(s.border, 0u);
  EXPECT_EQ(s.nonManifold, 0u);
  EXPECT_EQ(s.sameWay, 0u);
  EXPECT_EQ(s.degenerate, 0u);
  EXPECT_EQ(s.repeated, 0u);
  EXPECT_EQ(s.euler(), euler);
}

SimplifyLimits toTarget(std::size_t triangles) {
  SimplifyLimits limits;
  limits.targetTriangles = triangles;
  return limits;
}

// A torus (genus 1) from marching cubes, of radii `ring` and `tube`, centred in the grid.
Flat torus(std::array<std::int64_t, 3> dims = {40, 40, 20}, double ring = 11.0, double tube = 4.0) {
  const double cx = 0.5 * double(dims[0] - 1), cy = 0.5 * double(dims[1] - 1) - 0.2,
               cz = 0.5 * double(dims[2] - 1) + 0.1;
  return extracted(dims, [=](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i), y = double(j), z = double(k);
    return static_cast<float>(tube - std::hypot(std::hypot(x - cx, y - cy) - ring, z - cz));
  });
}

// m, a closed surface of Euler characteristic `euler`, simplified towards `target`: at least 95%
// of its triangles go, and it stays closed and oriented with that characteristic.
void expectSimplifiedClosed(Flat& m, std::size_t target, long euler) {
  const Shape before = shapeOf(m, m.indices.size());
  ASSERT_EQ(before.border, 0u);
  ASSERT_EQ(before.euler(), euler);
  const std::size_t kept = simplifyTriangles(m.indices, m.xyz.data(), m.vertices(), toTarget(target));
  const Shape after = shapeOf(m, kept);
  EXPECT_LT(after.triangles, before.triangles / 20);
  expectClosedSurface(after, euler);
}

TEST(Simplifier, ATorusStaysAClosedOrientedTorusAtTheTarget) {
  Flat m = torus();
  const Shape before = shapeOf(m, m.indices.size());
  ASSERT_EQ(before.border, 0u);
  ASSERT_EQ(before.euler(), 0);
  for (std::size_t target : {before.triangles / 2, before.triangles / 10, std::size_t{200}}) {
    SCOPED_TRACE(target);
    Flat copy = m;
    const std::size_t kept = simplifyTriangles(copy.indices, copy.xyz.data(), copy.vertices(), toTarget(target));
    const Shape after = shapeOf(copy, kept);
    // Each collapse takes two triangles: the target or one below it.
    EXPECT_LE(after.triangles, target);
    EXPECT_GE(after.triangles + 1, target);
    expectClosedSurface(after, 0);
  }
}

// A torus large enough that one call makes about 69,000 collapses (the link test's 16-bit stamps
// start again several times) stays a closed oriented torus. Asked for 300 triangles, it keeps about
// 3,600 (its tests refuse the rest), so the test asks for 95% of them gone.
TEST(Simplifier, ALargeTorusStaysATorusThroughManyTries) {
  Flat m = torus({200, 200, 64}, 62.0, 20.0);
  ASSERT_GT(m.indices.size() / 3, 140000u);
  expectSimplifiedClosed(m, 300, 0);
}

// Two sheets a voxel apart (a thin closed slab): collapses that would join them at an edge are the
// ones meshoptimizer 0.18 makes; the link condition refuses them, down to the last few triangles.
TEST(Simplifier, TwoSheetsCloseTogetherAreNeverJoined) {
  Flat m = extracted({30, 30, 8}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i), y = double(j), z = double(k);
    const double slab = 0.6 - std::abs(z - 3.5 - 0.1 * std::sin(0.4 * x) * std::cos(0.3 * y));
    return static_cast<float>(std::min({slab, 12.0 - std::abs(x - 14.5), 12.0 - std::abs(y - 14.5)}));
  });
  expectSimplifiedClosed(m, 4, 2);
}

// An open surface keeps its border: every border edge of the input, run the same way, and no new
// one.
TEST(Simplifier, AnOpenSurfaceKeepsItsBorderEdgeForEdge) {
  Flat m = extracted({24, 24, 12}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i), y = double(j), z = double(k);
    return static_cast<float>(5.0 + std::sin(0.3 * x) + std::cos(0.25 * y) - z);
  });
  const Shape before = shapeOf(m, m.indices.size());
  ASSERT_GT(before.border, 40u);
  const std::size_t kept = simplifyTriangles(m.indices, m.xyz.data(), m.vertices(), toTarget(0));
  const Shape after = shapeOf(m, kept);
  EXPECT_LT(after.triangles, before.triangles / 4);
  EXPECT_EQ(after.borderEdges, before.borderEdges);
  EXPECT_EQ(after.nonManifold, 0u);
  EXPECT_EQ(after.sameWay, 0u);
  EXPECT_EQ(after.euler(), before.euler());
}

// The error limit stops collapses on a curved surface but not on a flat one; the check sees every
// collapse above its threshold, and a check that refuses everything leaves the input as it was.
TEST(Simplifier, TheErrorLimitAndTheCheckHoldCollapsesBack) {
  const Flat m = torus();
  const std::size_t all = m.indices.size() / 3;
  Flat limited = m;
  SimplifyLimits limits = toTarget(0);
  limits.maxError = 0.05;
  const std::size_t kept = simplifyTriangles(limited.indices, limited.xyz.data(), limited.vertices(), limits);
  EXPECT_LT(kept / 3, all);
  EXPECT_GT(kept / 3, all / 4);  // a torus of radius 4 does not go flat within 0.05

  Flat refused = m;
  std::size_t asked = 0;
  limits = toTarget(0);
  limits.checkAbove = 0;
  limits.check = [&](const std::vector<std::array<std::uint32_t, 3>>& made) {
    EXPECT_GE(made.size(), 1u);
    ++asked;
    return false;
  };
  EXPECT_EQ(simplifyTriangles(refused.indices, refused.xyz.data(), refused.vertices(), limits), m.indices.size());
  EXPECT_EQ(refused.indices, m.indices);
  EXPECT_GT(asked, all / 4);
}

// To a tenth, recording the collapses into `steps` and counting the checks asked (each passes),
// which every collapse above a small error asks.
SimplifyLimits recording(std::size_t all, std::size_t& asked, LazyScratchVector<SimplifyStep>& steps) {
  SimplifyLimits limits = toTarget(all / 10);
  limits.checkAbove = 0.01;
  limits.check = [&asked](const std::vector<std::array<std::uint32_t, 3>>&) {
    ++asked;
    return true;
  };
  steps.reserve(all / 2);
  limits.record = &steps;
  return limits;
}

// A replay makes a recorded run's collapses again. On the same input it makes them all, asks the
// check nothing (the recorded run's check passed those triangles) and leaves nothing to measure.
// With a patch left out (a repair's frozen triangles), the patch's outline stays as it is, the
// surface stays closed and oriented elsewhere, and away from the patch the recorded run's triangles
// come back: only collapses near the patch are asked again.
TEST(Simplifier, AReplayMakesTheRecordedCollapsesAgainAwayFromWhatIsLeftOut) {
  const Flat m = torus();
  const std::size_t all = m.indices.size() / 3;
  std::size_t asked = 0;
  LazyScratchVector<SimplifyStep> steps;
  SimplifyLimits limits = recording(all, asked, steps);
  Flat recorded = m;
  std::vector<std::uint8_t> unchecked(all, 2);
  const std::size_t kept =
      simplifyTriangles(recorded.indices, recorded.xyz.data(), recorded.vertices(), limits, {}, unchecked);
  const std::size_t askedFirst = asked;
  ASSERT_GT(askedFirst, 100u);
  // Each collapse takes two triangles; each pass begins with its mark, numbered from 1.
  std::vector<std::uint32_t> passes;
  for (const SimplifyStep& s : steps) {
    if (s.isPass()) passes.push_back(s.to);
  }
  ASSERT_EQ(steps.size() - passes.size(), (all - kept / 3) / 2);
  ASSERT_GT(passes.size(), 1u);
  for (std::size_t p = 0; p < passes.size(); ++p) EXPECT_EQ(passes[p], p + 1);
  ASSERT_TRUE(steps.front().isPass());
  ASSERT_GT(std::count(unchecked.begin(), unchecked.begin() + long(kept / 3), 1), 0);
  recorded.indices.resize(kept);

  limits.record = nullptr;
  limits.replay = steps;
  asked = 0;
  Flat again = m;
  std::vector<std::uint8_t> none(all, 2);
  const std::size_t keptAgain = simplifyTriangles(again.indices, again.xyz.data(), again.vertices(), limits, {}, none);
  again.indices.resize(keptAgain);
  EXPECT_EQ(again.indices, recorded.indices);
  EXPECT_EQ(asked, 0u);
  EXPECT_EQ(std::count(none.begin(), none.begin() + long(keptAgain / 3), 0), long(keptAgain / 3));

  // The patch: the triangles within two rings of one vertex.
  std::set<std::uint32_t> ring{m.indices[0]};
  std::vector<bool> out(all, false);
  for (int step = 0; step < 2; ++step) {
    std::set<std::uint32_t> next = ring;
    for (std::size_t t = 0; t < all; ++t) {
      const std::uint32_t* c = &m.indices[3 * t];
      if (!ring.count(c[0]) && !ring.count(c[1]) && !ring.count(c[2])) continue;
      out[t] = true;
      next.insert(c, c + 3);
    }
    ring = next;
  }
  Flat patched = m;
  patched.indices.clear();
  for (std::size_t t = 0; t < all; ++t) {
    if (!out[t]) patched.indices.insert(patched.indices.end(), &m.indices[3 * t], &m.indices[3 * t + 3]);
  }
  const Shape input = shapeOf(patched, patched.indices.size());
  ASSERT_GT(input.border, 10u);
  asked = 0;
  const std::size_t keptPatched = simplifyTriangles(patched.indices, patched.xyz.data(), patched.vertices(), limits);
  const Shape after = shapeOf(patched, keptPatched);
  EXPECT_EQ(after.borderEdges, input.borderEdges);
  EXPECT_EQ(after.nonManifold, 0u);
  EXPECT_EQ(after.sameWay, 0u);
  EXPECT_EQ(after.degenerate, 0u);
  EXPECT_EQ(after.repeated, 0u);
  EXPECT_EQ(after.euler(), input.euler());
  EXPECT_LT(after.triangles, input.triangles / 8);
  EXPECT_LT(asked, askedFirst / 10);
  std::set<std::array<std::uint32_t, 3>> before;
  for (std::size_t i = 0; i < recorded.indices.size(); i += 3) {
    before.insert({recorded.indices[i], recorded.indices[i + 1], recorded.indices[i + 2]});
  }
  std::size_t same = 0;
  for (std::size_t i = 0; i < keptPatched; i += 3) {
    same += before.count({patched.indices[i], patched.indices[i + 1], patched.indices[i + 2]});
  }
  EXPECT_GT(same, after.triangles * 9 / 10);

  // A log whose second pass is numbered 2^16 - 1 (no run makes one) is replayed up to that mark:
  // the first pass's collapses alone.
  std::vector<SimplifyStep> cut(steps.begin(), steps.end());
  const auto second = std::find_if(cut.begin() + 1, cut.end(), [](const SimplifyStep& s) { return s.isPass(); });
  ASSERT_NE(second, cut.end());
  const auto firstPass = static_cast<std::size_t>(second - cut.begin()) - 1;
  second->to = 0xffff;
  limits.replay = cut;
  Flat partial = m;
  const std::size_t keptPartial = simplifyTriangles(partial.indices, partial.xyz.data(), partial.vertices(), limits);
  EXPECT_EQ(keptPartial / 3, all - 2 * firstPass);
  expectClosedSurface(shapeOf(partial, keptPartial), 0);
}

// A replay on part of the input (a local repair, process/decimation.cpp): the triangles on a zone
// of vertices, closed under the collapses that joined them, with the collapses made among the
// zone's vertices and, as renames, those among the vertices around it (their triangles on the zone
// took part). It makes the recorded run's triangles on the zone again, in order, asks the check
// nothing and leaves nothing to measure. With the vertices around the zone taken for ordinary
// fixed ones instead (dirty, as a frozen patch's outline is), the replay measures again near them.
TEST(Simplifier, AReplayOnAZoneWithRenamesAroundItMakesTheRecordedTriangles) {
  const Flat m = torus();
  const std::size_t all = m.indices.size() / 3;
  std::size_t asked = 0;
  LazyScratchVector<SimplifyStep> steps;
  SimplifyLimits limits = recording(all, asked, steps);
  Flat recorded = m;
  recorded.indices.resize(simplifyTriangles(recorded.indices, recorded.xyz.data(), recorded.vertices(), limits));
  ASSERT_GT(asked, 100u);
  // Where each vertex ended: itself, or along its collapses.
  std::vector<std::uint32_t> root(m.vertices());
  for (std::uint32_t v = 0; v < root.size(); ++v) root[v] = v;
  for (const SimplifyStep& s : steps) {
    if (!s.isPass()) root[s.from] = s.to;
  }
  for (std::uint32_t& r : root) {
    while (root[r] != r) r = root[r];
  }
  // The zone: the result's vertices within one ring of a vertex of its first triangle, and every
  // vertex that ended on one of them.
  std::set<std::uint32_t> ends{recorded.indices[0]};
  for (std::size_t i = 0; i < recorded.indices.size(); i += 3) {
    const std::uint32_t* c = &recorded.indices[i];
    if (c[0] == recorded.indices[0] || c[1] == recorded.indices[0] || c[2] == recorded.indices[0])
      ends.insert(c, c + 3);
  }
  const auto inZone = [&](std::uint32_t v) { return ends.count(root[v]) > 0; };
  Flat zone = m;
  zone.indices.clear();
  std::set<std::uint32_t> around;  // the ends of the vertices around the zone
  std::vector<std::uint8_t> locked(m.vertices(), 0);
  for (std::size_t t = 0; t < all; ++t) {
    const std::uint32_t* c = &m.indices[3 * t];
    if (!inZone(c[0]) && !inZone(c[1]) && !inZone(c[2])) continue;
    zone.indices.insert(zone.indices.end(), c, c + 3);
    for (std::size_t k = 0; k < 3; ++k) {
      if (!inZone(c[k])) around.insert(root[c[k]]);
    }
  }
  std::vector<SimplifyStep> local;
  std::size_t renames = 0, collapses = 0;
  for (const SimplifyStep& s : steps) {
    if (s.isPass()) {
      local.push_back(s);
    } else if (inZone(s.from)) {
      local.push_back(s);
      ++collapses;
    } else if (around.count(root[s.from]) > 0) {
      local.push_back({s.from, s.to | SimplifyStep::kRename});
      ++renames;
    }
  }
  for (std::uint32_t v = 0; v < m.vertices(); ++v) {
    if (!inZone(v) && around.count(root[v]) > 0) locked[v] = SimplifyLimits::kRenamedOnly;
  }
  ASSERT_GT(collapses, 20u);
  ASSERT_GT(renames, 10u);
  std::vector<std::uint32_t> expected;
  for (std::size_t i = 0; i < recorded.indices.size(); i += 3) {
    const std::uint32_t* c = &recorded.indices[i];
    if (inZone(c[0]) || inZone(c[1]) || inZone(c[2])) expected.insert(expected.end(), c, c + 3);
  }
  limits.record = nullptr;
  limits.replay = local;
  limits.locked = locked;
  for (const std::uint8_t mark : {SimplifyLimits::kRenamedOnly, std::uint8_t{1}}) {
    SCOPED_TRACE(int(mark));
    for (std::uint8_t& l : limits.locked) l = l != 0 ? mark : 0;
    Flat again = zone;
    asked = 0;
    std::vector<std::uint8_t> unchecked(again.indices.size() / 3, 2);
    again.indices.resize(simplifyTriangles(again.indices, again.xyz.data(), again.vertices(), limits, {}, unchecked));
    const auto flagged = std::count(unchecked.begin(), unchecked.begin() + long(again.indices.size() / 3), 1);
    if (mark == SimplifyLimits::kRenamedOnly) {
      EXPECT_EQ(again.indices, expected);
      EXPECT_EQ(asked, 0u);
      EXPECT_EQ(flagged, 0);
    } else {
      EXPECT_GT(asked + std::size_t(flagged), 0u);
    }
  }
}

// A pass after one that made few collapses takes over its candidates and finds again only those
// around them (SimplifyLimits::carryKeys): the same candidates in the same order as finding them
// all, so the same collapses, checks and result. A bumpy ball whose error bound stops it far above
// the target: its last passes make few collapses each (asserted from the log).
TEST(Simplifier, CandidatesTakenOverFromTheLastPassGiveTheSameCollapses) {
  const Flat m = extracted({34, 34, 34}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i) - 16.5, y = double(j) - 16.2, z = double(k) - 16.8;
    return static_cast<float>(13.0 - std::sqrt(x * x + y * y + z * z) + 0.7 * std::sin(1.3 * x) * std::cos(1.1 * y) +
                              0.5 * std::sin(0.9 * z));
  });
  const std::size_t all = m.indices.size() / 3;
  std::array<Flat, 2> out{m, m};
  std::array<LazyScratchVector<SimplifyStep>, 2> logs;
  std::array<std::size_t, 2> asked{};
  for (std::size_t run = 0; run < 2; ++run) {
    SimplifyLimits limits = toTarget(all / 20);
    limits.maxError = 0.08;
    limits.checkAbove = 0.04;
    limits.check = [&](const std::vector<std::array<std::uint32_t, 3>>& made) {
      ++asked[run];
      return made.size() % 5 != 0;  // refuse some, as a distance check would
    };
    limits.carryKeys = run == 0;
    logs[run].reserve(all / 2);
    limits.record = &logs[run];
    out[run].indices.resize(simplifyTriangles(out[run].indices, out[run].xyz.data(), out[run].vertices(), limits));
  }
  EXPECT_EQ(out[0].indices, out[1].indices);
  EXPECT_EQ(asked[0], asked[1]);
  EXPECT_GT(asked[0], 100u);
  ASSERT_EQ(logs[0].size(), logs[1].size());
  EXPECT_TRUE(
      std::equal(logs[0].begin(), logs[0].end(), logs[1].begin(),
                 [](const SimplifyStep& a, const SimplifyStep& b) { return a.from == b.from && a.to == b.to; }));
  // Stopped by the bound, with passes that follow one of few collapses (fewer than 1/16 of the
  // triangles left): those took the candidates over.
  EXPECT_GT(out[0].indices.size() / 3, all / 10);
  std::vector<std::size_t> perPass;
  for (const SimplifyStep& s : logs[0]) {
    if (s.isPass()) {
      perPass.push_back(0);
    } else {
      ++perPass.back();
    }
  }
  std::size_t live = all, carried = 0;
  for (std::size_t p = 0; p + 1 < perPass.size(); ++p) {
    live -= 2 * perPass[p];
    carried += 16 * perPass[p] < live ? 1 : 0;
  }
  EXPECT_GE(carried, 1u);
}

}  // namespace
}  // namespace isoslab
