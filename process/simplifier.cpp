// Half-edge collapses by quadric error, with the tests that keep a surface a surface (simplifier.h).
#include "process/simplifier.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <span>
#include <stdexcept>
#include <utility>

#include "core/fans.h"
#include "core/scratch.h"

namespace isoslab {
namespace {

constexpr std::uint32_t kDead = 0xffffffffu;
constexpr std::size_t kMaxFan = 64;
// A pass that makes fewer than 1 / kLastPass of the collapses still wanted is the last.
constexpr std::size_t kLastPass = 64;

using Vec3 = std::array<double, 3>;

// The sum over planes of w (n.u + d)^2, with u the offset from the vertex that holds it, |n| = 1 and
// d the vertex's signed distance from the plane: u^T A u + 2 b.u + c (A = sum w n n^T,
// b = sum w d n, c = sum w d^2), with the weights' sum. About the vertex's own position every term
// stays as small as the error it measures, so floats hold it (11 of them a vertex).
struct Quadric {
  float xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0, x = 0, y = 0, z = 0, c = 0, w = 0;

  // A plane through the vertex (d = 0).
  void addPlaneThrough(const Vec3& n, double weight) {
    xx += static_cast<float>(weight * n[0] * n[0]);
    xy += static_cast<float>(weight * n[0] * n[1]);
    xz += static_cast<float>(weight * n[0] * n[2]);
    yy += static_cast<float>(weight * n[1] * n[1]);
    yz += static_cast<float>(weight * n[1] * n[2]);
    zz += static_cast<float>(weight * n[2] * n[2]);
    w += static_cast<float>(weight);
  }
  // The weighted sum of the squared distances from the point at offset u to the planes.
  double sum(const Vec3& u) const {
    return u[0] * (xx * u[0] + 2 * (xy * u[1] + xz * u[2] + x)) + u[1] * (yy * u[1] + 2 * (yz * u[2] + y)) +
           u[2] * (zz * u[2] + 2 * z) + c;
  }
  // Their weighted mean.
  double error(const Vec3& u) const { return w > 0 ? std::max(sum(u), 0.0) / w : 0.0; }
  // Adds q, which is about a point at offset -delta from this one (this vertex is q's at delta).
  void addFrom(const Quadric& q, const Vec3& delta) {
    const double bx = q.x + q.xx * delta[0] + q.xy * delta[1] + q.xz * delta[2];
    const double by = q.y + q.xy * delta[0] + q.yy * delta[1] + q.yz * delta[2];
    const double bz = q.z + q.xz * delta[0] + q.yz * delta[1] + q.zz * delta[2];
    c += static_cast<float>(q.sum(delta));
    x += static_cast<float>(bx), y += static_cast<float>(by), z += static_cast<float>(bz);
    xx += q.xx, xy += q.xy, xz += q.xz, yy += q.yy, yz += q.yz, zz += q.zz, w += q.w;
  }
};

Vec3 sub(const Vec3& a, const Vec3& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
double dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Whether the triangles around v (each given as the pair (u, w) that follows v in it) form one
// closed fan: every edge v-u used once each way, the pairs one cycle through all of them.
bool isDisk(const std::vector<std::array<std::uint32_t, 2>>& pairs) {
  const std::size_t n = pairs.size();
  // More than kMaxFan triangles at a vertex stays put: the test is quadratic, and no surface from a
  // lattice has such a vertex (a hostile mesh might).
  if (n < 3 || n > kMaxFan) return false;
  std::array<std::uint32_t, kMaxFan> next, prev;  // only the first n are read
  for (std::size_t i = 0; i < n; ++i) next[i] = pairs[i][0], prev[i] = pairs[i][1];
  return detail::oneCycle(std::span<const std::uint32_t>(next.data(), n),
                          std::span<const std::uint32_t>(prev.data(), n));
}

// Whether the triangles around v (as for isDisk) are three sheets that meet along a line through v:
// two neighbours (the line's, `ends`) with three triangles each, every other neighbour in two
// triangles wound one each way, and the triangles three fans, each from one end to the other with
// at least two triangles.
bool isLine(const std::vector<std::array<std::uint32_t, 2>>& pairs, std::array<std::uint32_t, 2>& ends) {
  const std::size_t n = pairs.size();
  if (n < 6 || n > kMaxFan) return false;
  std::size_t found = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (pairs[i][0] == pairs[i][1]) return false;
    for (std::size_t side = 0; side < 2; ++side) {
      const std::uint32_t x = pairs[i][side];
      std::size_t uses = 0, first = 0;  // first: x's first appearance is at (i, side)
      for (std::size_t j = 0; j < n; ++j) {
        for (std::size_t s = 0; s < 2; ++s) {
          if (pairs[j][s] != x) continue;
          if (uses++ == 0) first = 2 * j + s;
        }
      }
      if (first != 2 * i + side) continue;  // counted at its first appearance
      if (uses == 3) {
        if (found == 2) return false;
        ends[found++] = x;
      } else if (uses != 2) {
        return false;
      }
    }
  }
  if (found != 2) return false;
  // The fans: from each triangle at ends[0], across the shared neighbours, to one at ends[1].
  std::size_t visited = 0, chains = 0;
  for (std::size_t start = 0; start < n; ++start) {
    if (pairs[start][0] != ends[0] && pairs[start][1] != ends[0]) continue;
    ++chains;
    std::size_t at = start;
    std::uint32_t from = ends[0];
    for (;;) {
      ++visited;
      const std::size_t in = pairs[at][0] == from ? 0 : 1;
      const std::uint32_t next = pairs[at][1 - in];
      if (next == ends[1]) break;
      if (next == ends[0] || visited > n) return false;
      std::size_t other = n;
      for (std::size_t j = 0; j < n; ++j) {
        if (j != at && (pairs[j][0] == next || pairs[j][1] == next)) other = j;
      }
      // A sheet's edge from v is wound one way in each of its two triangles.
      if (other == n || (pairs[other][0] == next) == (in == 1)) return false;
      at = other;
      from = next;
    }
    if (at == start) return false;  // a fan of one triangle: the line's ends would be joined
  }
  return chains == 3 && visited == n;
}

class Simplifier {
 public:
  Simplifier(std::span<std::uint32_t> indices, const float* xyz, std::size_t vertexCount, const SimplifyLimits& limits,
             std::span<std::uint32_t> keptFrom, std::span<std::uint8_t> unchecked)
      : idx_(indices),
        count_(indices.size() / 3 * 3),
        xyz_(xyz),
        vertices_(vertexCount),
        origin_(keptFrom),
        unchecked_(unchecked) {
    live_ = count_ / 3;
    if (!origin_.empty()) {
      for (std::size_t t = 0; t < live_; ++t) origin_[t] = static_cast<std::uint32_t>(t);
    }
    if (!unchecked_.empty()) std::fill(unchecked_.begin(), unchecked_.begin() + static_cast<std::ptrdiff_t>(live_), 0);
    quadrics_.assign(vertexCount, Quadric{});
    for (std::size_t t = 0; t < live_; ++t) {
      const Vec3 a = at(idx_[3 * t]);
      const Vec3 n = cross(sub(at(idx_[3 * t + 1]), a), sub(at(idx_[3 * t + 2]), a));
      const double length = std::sqrt(dot(n, n));
      if (!(length > 0)) continue;
      const Vec3 unit{n[0] / length, n[1] / length, n[2] / length};
      for (std::size_t k = 0; k < 3; ++k) quadrics_[idx_[3 * t + k]].addPlaneThrough(unit, 0.5 * length);
    }
    buildAdjacency();
    free_.assign(vertexCount, 0);
    const std::vector<std::uint8_t>& locked = limits.locked;
    const bool alongLines = limits.alongLines;
    std::vector<std::array<std::uint32_t, 2>> pairs;
    for (std::uint32_t v = 0; v < vertexCount; ++v) {
      if (v < locked.size() && locked[v] != 0) continue;  // stays, whatever its triangles
      pairs.clear();
      for (std::uint32_t i = first_[v]; i < first_[v + 1]; ++i) {
        const std::uint32_t* t = &idx_[3 * around_[i]];
        const std::size_t k = t[0] == v ? 0 : t[1] == v ? 1 : 2;
        pairs.push_back({t[(k + 1) % 3], t[(k + 2) % 3]});
      }
      std::array<std::uint32_t, 2> ends{};
      free_[v] = isDisk(pairs) ? kDisk : alongLines && isLine(pairs, ends) ? kLine : kStays;
      if (free_[v] == kLine) lineEnds_.push_back({v, ends[0], ends[1]});
    }
    if (!lineEnds_.empty()) {
      lineAt_.assign(vertexCount, kDead);
      for (std::uint32_t i = 0; i < lineEnds_.size(); ++i) lineAt_[lineEnds_[i][0]] = i;
    }
    mark_.assign(vertexCount, 0);
    seen_.assign(vertexCount, 0);
  }

  std::size_t run(const SimplifyLimits& limits) {
    if (!limits.replay.empty()) return replay(limits);
    choosing_ = limits.carryKeys;
    record_ = limits.record;
    const double limit = takeLimits(limits);

    for (std::uint32_t pass = 1; live_ > limits.targetTriangles && pass < 0xffff; ++pass) {
      // A pass that makes only a sliver of the collapses still wanted is the last: what is left are
      // candidates that the tests refuse, tried again every pass for a handful more (a noisy
      // surface that its bound stops short of the target spent half its passes so).
      const std::size_t wanted = (live_ - limits.targetTriangles + 1) / 2;
      if (record_ != nullptr) record_->push_back({SimplifyStep::kPassMark, pass});
      const std::size_t made = collapsePass(pass, limits.targetTriangles, limit);
      if (made == 0 || made * kLastPass < wanted) break;
      compact();
      buildAdjacency();
    }
    compact();
    return count_;
  }

  // The recorded collapses again (SimplifyLimits::replay). A vertex is `dirty` where its triangles
  // or its quadric may differ from the recorded run's at the same point: at first those that do
  // not move (a frozen patch's outline among them; not those that only renames move), then the
  // ends and neighbours of every recorded collapse that is not made again, or that a dirty vertex
  // made, and every corner of a rename's triangles where one of them is dirty. A clean vertex's
  // collapse makes the triangles that the recorded run made, which its check passed.
  std::size_t replay(const SimplifyLimits& limits) {
    record_ = limits.record;
    renameFolds_ = limits.renameFolds;
    const double limit = takeLimits(limits);
    dirty_.assign(vertices_, 0);
    const std::vector<std::uint8_t>& locked = limits.locked;
    for (std::size_t v = 0; v < vertices_; ++v) {
      dirty_[v] = free_[v] == kStays && !(v < locked.size() && locked[v] == SimplifyLimits::kRenamedOnly) ? 1 : 0;
    }
    const std::span<const SimplifyStep> steps = limits.replay;
    std::uint32_t pass = 0;
    for (std::size_t i = 0; i < steps.size();) {
      if (steps[i].isPass()) {
        if (pass > 0) {
          compact();
          buildAdjacency();
        }
        pass = steps[i++].to;
        if (pass >= 0xffff) break;  // not a log that run() made (its passes stop before 2^16 - 1)
        continue;
      }
      for (; i < steps.size() && !steps[i].isPass(); ++i) {
        const std::uint32_t from = steps[i].from, to = steps[i].target();
        if (from >= vertices_ || to >= vertices_ || from == to) continue;
        if (steps[i].isRename()) {
          rename(from, to, pass);
          continue;
        }
        const bool clean = dirty_[from] == 0;
        bool made = false;
        if (mark_[from] != pass && mark_[to] != pass && onLineOrDisk(from, to)) {
          const double error = quadrics_[from].error(sub(at(to), at(from)));
          if (clean || error <= limit) made = collapse(from, to, pass, static_cast<float>(error), clean);
        }
        if (made && clean) continue;
        // Not made, or made from a different fan: `to` and the vertices around `from` differ from
        // the recorded run's.
        dirty_[to] = 1;
        for (std::uint32_t a = first_[from]; a < first_[from + 1]; ++a) {
          const std::uint32_t* t = &idx_[3 * around_[a]];
          if (t[0] == kDead) continue;
          for (std::size_t k = 0; k < 3; ++k) dirty_[t[k]] = 1;
        }
      }
    }
    compact();
    // A kept triangle on a clean vertex is in that vertex's fan as the recorded run left it: it
    // stands as that run's checks passed it (a triangle that they refused had every corner frozen).
    if (!unchecked_.empty()) {
      for (std::size_t t = 0; t < count_ / 3; ++t) {
        const std::uint32_t* c = &idx_[3 * t];
        if (dirty_[c[0]] == 0 || dirty_[c[1]] == 0 || dirty_[c[2]] == 0) unchecked_[t] = 0;
      }
    }
    return count_;
  }

 private:
  // A replay's rename (SimplifyStep::kRename): `from` becomes `to` in its triangles, and those on
  // both die, as the recorded collapse left them. Where a dirty vertex is among them, the triangles
  // may not be as recorded: their corners are dirty too, and a triangle that the rename turns over
  // or flattens (which the recorded collapse's test would have refused) is reported
  // (SimplifyLimits::renameFolds).
  void rename(std::uint32_t from, std::uint32_t to, std::uint32_t pass) {
    bool dirty = dirty_[from] != 0 || dirty_[to] != 0;
    for (std::uint32_t i = first_[from]; i < first_[from + 1]; ++i) {
      const std::uint32_t* t = &idx_[3 * around_[i]];
      if (t[0] != kDead) dirty = dirty || dirty_[t[0]] != 0 || dirty_[t[1]] != 0 || dirty_[t[2]] != 0;
    }
    const Vec3 p = at(from), q = at(to);
    for (std::uint32_t i = first_[from]; i < first_[from + 1]; ++i) {
      std::uint32_t* t = &idx_[3 * around_[i]];
      if (t[0] == kDead) continue;
      if (dirty) dirty_[t[0]] = dirty_[t[1]] = dirty_[t[2]] = 1;
      if (t[0] == to || t[1] == to || t[2] == to) {
        t[0] = t[1] = t[2] = kDead;
        --live_;
        continue;
      }
      const std::size_t at0 = t[0] == from ? 0 : t[1] == from ? 1 : 2;
      if (dirty && renameFolds_ != nullptr) {
        const Vec3 px = at(t[(at0 + 1) % 3]), py = at(t[(at0 + 2) % 3]);
        const Vec3 before = cross(sub(px, p), sub(py, p)), after = cross(sub(px, q), sub(py, q));
        const double b2 = dot(before, before);
        if (b2 > 0 && !(dot(before, after) > 0 && dot(after, after) > 1e-12 * b2)) *renameFolds_ = true;
      }
      // A line vertex beside `from` has `to` for its neighbour on the line now.
      for (std::size_t k = 1; k < 3; ++k) {
        const std::uint32_t v = t[(at0 + k) % 3];
        if (free_[v] != kLine) continue;
        std::array<std::uint32_t, 3>& ends = lineEnds_[lineAt_[v]];
        for (std::size_t e = 1; e < 3; ++e) ends[e] = ends[e] == from ? to : ends[e];
      }
      t[at0] = to;
      if (!unchecked_.empty()) unchecked_[around_[i]] = 1;
    }
    if (dirty) dirty_[to] = 1;
    mark_[from] = mark_[to] = static_cast<std::uint16_t>(pass);
  }

  // The limits' squared error bound (returned), sample bound and check, for run() and replay().
  double takeLimits(const SimplifyLimits& limits) {
    const double limit = limits.maxError * limits.maxError;
    sampleLimit_ = 4 * limit;  // twice the error, squared
    if (limits.check) {
      check_ = &limits.check;
      checkAbove_ = limits.checkAbove * limits.checkAbove;
    }
    return limit;
  }

  // Whether `from` may move onto `to` by its kind: a disk onto any neighbour (the link test finds
  // one that is none), a line vertex onto a neighbour on its line.
  bool onLineOrDisk(std::uint32_t from, std::uint32_t to) const {
    if (free_[from] == kDisk) return true;
    if (free_[from] != kLine) return false;
    const std::array<std::uint32_t, 3>& ends = lineEnds_[lineAt_[from]];
    return ends[1] == to || ends[2] == to;
  }

  // The triangles around each vertex: around_[first_[v] .. first_[v + 1]).
  void buildAdjacency() {
    first_.assign(vertices_ + 1, 0);
    const std::size_t triangles = count_ / 3;
    for (std::size_t i = 0; i < 3 * triangles; ++i) ++first_[idx_[i] + 1];
    for (std::size_t v = 0; v < vertices_; ++v) first_[v + 1] += first_[v];
    around_.resize(3 * triangles);
    // Each vertex's start advances as its list fills, to the next vertex's start: shifted back after.
    for (std::size_t t = 0; t < triangles; ++t) {
      for (std::size_t k = 0; k < 3; ++k) around_[first_[idx_[3 * t + k]]++] = static_cast<std::uint32_t>(t);
    }
    for (std::size_t v = vertices_; v > 0; --v) first_[v] = first_[v - 1];
    first_[0] = 0;
  }

  void compact() {
    std::size_t kept = 0;
    // Each triangle's new place, for the keys that the next pass takes over (without lines only).
    const bool carry = choosing_ && lineEnds_.empty();
    if (carry) moved_.resize(count_ / 3);
    for (std::size_t t = 0; t < count_ / 3; ++t) {
      if (carry) moved_[t] = idx_[3 * t] == kDead ? kDead : static_cast<std::uint32_t>(kept);
      if (idx_[3 * t] == kDead) continue;
      if (kept != t) {
        std::memmove(&idx_[3 * kept], &idx_[3 * t], 3 * sizeof(std::uint32_t));
        if (!origin_.empty()) origin_[kept] = origin_[t];
        if (!unchecked_.empty()) unchecked_[kept] = unchecked_[t];
      }
      ++kept;
    }
    count_ = 3 * kept;
  }

  // One pass: the candidates by error, each made where nothing around it has changed. Returns
  // the collapses made.
  std::size_t collapsePass(std::uint32_t pass, std::size_t target, double limit) {
    const std::size_t triangles = count_ / 3;
    // After a pass that made few collapses, its keys are taken over: only those around its
    // collapses are new (carryKeys). The same keys in the same order either way.
    const bool carry =
        choosing_ && pass > 1 && lineEnds_.empty() && !moved_.empty() && 16 * touched_.size() < triangles;
    if (carry) {
      carryKeys(pass, limit);
    } else {
      allKeys(limit);
    }
    touched_.clear();
    if (keys_.empty()) return 0;
    // Most collapses remove two triangles: the pass goes as far as the error of the collapse that
    // would meet the target, and half as far again (the skipped ones come back in the next pass),
    // or further while it has made fewer than a quarter of those collapses (cheap ones that the
    // tests refuse would otherwise stall it).
    const std::size_t goal = (live_ - target + 1) / 2;
    float passLimit = INFINITY;
    // Near the target, the last few go in one pass, in order.
    if (goal < keys_.size() && 16 * goal > live_) {
      const auto bits = static_cast<std::uint32_t>(keys_[goal] >> 32);
      std::memcpy(&passLimit, &bits, sizeof passLimit);
      passLimit *= 1.5f;
    }
    std::size_t made = 0;
    for (const std::uint64_t key : keys_) {
      if (live_ <= target) break;
      float error = 0;
      const auto bits = static_cast<std::uint32_t>(key >> 32);
      std::memcpy(&error, &bits, sizeof error);
      if (error > passLimit && 4 * made >= goal) break;
      // The edge as its triangle holds it now: a triangle that a collapse has rewritten holds that
      // collapse's `to`, which waits for the next pass, or has died.
      const auto corner = static_cast<std::uint32_t>(key & 0xffffffffu) >> 1;
      const std::uint32_t t = corner / 3, k = corner % 3;
      if (idx_[3 * t] == kDead) continue;
      std::uint32_t from = idx_[3 * t + k], to = idx_[3 * t + (k + 1) % 3];
      if (key & 1u) std::swap(from, to);
      if (mark_[from] == pass || mark_[to] == pass) continue;
      if (collapse(from, to, pass, error)) ++made;
    }
    return made;
  }

  // The key of the candidate edge from corner k of triangle t (a to b, a < b), if either end may
  // move and the error is within the limit: its error's bits, the corner, and 1 when b moves.
  bool edgeKey(std::size_t t, std::size_t k, double limit, std::uint64_t& key) const {
    const std::uint32_t a = idx_[3 * t + k], b = idx_[3 * t + (k + 1) % 3];
    // Each edge between two triangles once (where it runs from the smaller id); a border edge's
    // ends do not move.
    if (a > b || (free_[a] != kDisk && free_[b] != kDisk)) return false;
    const Vec3 ab = sub(at(b), at(a));
    const double abError = free_[a] == kDisk ? quadrics_[a].error(ab) : INFINITY;
    const double baError = free_[b] == kDisk ? quadrics_[b].error({-ab[0], -ab[1], -ab[2]}) : INFINITY;
    const double e = std::min(abError, baError);
    if (!(e <= limit)) return false;
    const auto error = static_cast<float>(e);
    std::uint32_t bits = 0;
    std::memcpy(&bits, &error, sizeof bits);
    key = static_cast<std::uint64_t>(bits) << 32 | (3 * t + k) << 1 | (abError <= baError ? 0u : 1u);
    return true;
  }

  // Every candidate, sorted.
  void allKeys(double limit) {
    keys_.clear();
    const std::size_t triangles = count_ / 3;
    // Each edge once, and two a line vertex: about 3/2 a triangle. Reserved, not grown, so that the
    // array has no untouched tail (a huge page of it would be resident: core/scratch.h).
    keys_.reserve(3 * triangles / 2 + 2 * lineEnds_.size() + 64);
    for (std::size_t t = 0; t < triangles; ++t) {
      for (std::size_t k = 0; k < 3; ++k) {
        std::uint64_t key = 0;
        if (edgeKey(t, k, limit, key)) keys_.push_back(key);
      }
    }
    // A line vertex's collapses onto its neighbours on the line, each named by a corner of a
    // triangle on the edge, as above.
    for (const auto& [v, e0, e1] : lineEnds_) {
      if (free_[v] != kLine) continue;  // collapsed away
      for (const std::uint32_t e : {e0, e1}) {
        const double error = quadrics_[v].error(sub(at(e), at(v)));
        if (!(error <= limit)) continue;
        for (std::uint32_t i = first_[v]; i < first_[v + 1]; ++i) {
          const std::uint32_t t = around_[i];
          const std::uint32_t k = idx_[3 * t] == v ? 0 : idx_[3 * t + 1] == v ? 1 : 2;
          std::uint32_t corner = kDead, swap = 0;
          if (idx_[3 * t + (k + 1) % 3] == e) corner = 3 * t + k;
          if (idx_[3 * t + (k + 2) % 3] == e) corner = 3 * t + (k + 2) % 3, swap = 1;
          if (corner == kDead) continue;
          const auto bits32 = static_cast<float>(error);
          std::uint32_t bits = 0;
          std::memcpy(&bits, &bits32, sizeof bits);
          keys_.push_back(static_cast<std::uint64_t>(bits) << 32 | corner << 1 | swap);
          break;
        }
      }
    }
    sortKeys();
  }

  // The last pass's keys (sorted), less those with an end that a collapse of that pass moved or
  // moved onto, each renamed to its triangle's new place (compact() keeps the triangles' order, so
  // they stay sorted); then the edges at the vertices that it moved others onto, found again,
  // sorted and merged in. An edge with neither end changed is in the same triangle, at the same
  // corner, with the same quadrics at its ends: the key that allKeys() would make. Without lines.
  void carryKeys(std::uint32_t pass, double limit) {
    const auto last = static_cast<std::uint16_t>(pass - 1);
    std::size_t kept = 0;
    for (const std::uint64_t key : keys_) {
      const auto corner = static_cast<std::uint32_t>(key & 0xffffffffu) >> 1;
      const std::uint32_t t = moved_[corner / 3], k = corner % 3;
      if (t == kDead) continue;
      if (mark_[idx_[3 * t + k]] == last || mark_[idx_[3 * t + (k + 1) % 3]] == last) continue;
      keys_[kept++] = (key & 0xffffffff00000000ull) | static_cast<std::uint64_t>(3 * t + k) << 1 | (key & 1u);
    }
    keys_.resize(kept);
    fresh_.clear();
    fresh_.reserve(touched_.size() * kMaxFan + 64);
    for (const std::uint32_t v : touched_) {
      for (std::uint32_t i = first_[v]; i < first_[v + 1]; ++i) {
        const std::uint32_t t = around_[i];
        for (std::size_t k = 0; k < 3; ++k) {
          const std::uint32_t a = idx_[3 * t + k], b = idx_[3 * t + (k + 1) % 3];
          if (a != v && b != v) continue;
          // An edge between two such vertices is found from its smaller end's triangles.
          const std::uint32_t other = a == v ? b : a;
          if (mark_[other] == last && other < v) continue;
          std::uint64_t key = 0;
          if (edgeKey(t, k, limit, key)) fresh_.push_back(key);
        }
      }
    }
    std::sort(fresh_.begin(), fresh_.end());
    spare_.resize(keys_.size() + fresh_.size());
    std::merge(keys_.begin(), keys_.end(), fresh_.begin(), fresh_.end(), spare_.begin());
    keys_.swap(spare_);
  }

  // The keys in order of error (their upper 32 bits, the bits of a float that is not negative),
  // each error's keys in order of candidate (their lower bits, which they arrive in): a stable
  // radix sort of the upper bits, 11, 11 and 10 at a time.
  void sortKeys() {
    spare_.resize(keys_.size());
    for (int shift = 32; shift < 64; shift += 11) {
      std::array<std::size_t, 2048> count{};
      for (const std::uint64_t key : keys_) ++count[(key >> shift) & 2047];
      std::size_t sum = 0;
      for (std::size_t& c : count) sum += std::exchange(c, sum);
      for (const std::uint64_t key : keys_) spare_[count[(key >> shift) & 2047]++] = key;
      keys_.swap(spare_);
    }
  }

  // Moves `from` onto `to` if the tests allow; marks what changed.
  // `passed`: a replayed collapse that the check passed when it was recorded (the same triangles).
  bool collapse(std::uint32_t from, std::uint32_t to, std::uint32_t pass, float error, bool passed = false) {
    // Neither end has changed in this pass, so their lists of triangles are whole (a triangle of
    // theirs may have lost a neighbour to a collapse, which rewrote it in place, or died). The link
    // condition: the ends share only the two vertices opposite the edge. `to`'s neighbours are
    // stamped; each of `from`'s that has the stamp is shared, and is stamped again when counted.
    if (stamp_ > 0xffff - 2) {  // the stamps are 16 bits: start again from a cleared array
      std::fill(seen_.begin(), seen_.end(), std::uint16_t{0});
      stamp_ = 0;
    }
    stamp_ += 2;
    const auto inTo = static_cast<std::uint16_t>(stamp_ - 1), counted = static_cast<std::uint16_t>(stamp_);
    for (std::uint32_t i = first_[to]; i < first_[to + 1]; ++i) {
      const std::uint32_t* t = &idx_[3 * around_[i]];
      if (t[0] == kDead) continue;
      for (std::size_t k = 0; k < 3; ++k) seen_[t[k]] = inTo;
    }
    // A disk's edge has two triangles, a line's three: the vertices opposite it, which must be
    // all that the ends share.
    const bool line = free_[from] == kLine;
    const std::size_t expect = line ? 3 : 2;
    std::array<std::uint32_t, 3> shared{};
    std::size_t common = 0, onEdge = 0;
    for (std::uint32_t i = first_[from]; i < first_[from + 1]; ++i) {
      const std::uint32_t* t = &idx_[3 * around_[i]];
      if (t[0] == kDead) continue;
      onEdge += (t[0] == to || t[1] == to || t[2] == to) ? 1 : 0;
      for (std::size_t k = 0; k < 3; ++k) {
        const std::uint32_t v = t[k];
        if (v == from || v == to || seen_[v] != inTo) continue;
        if (common == expect) return false;
        shared[common++] = v;
        seen_[v] = counted;
      }
    }
    if (common != expect || onEdge != expect) return false;
    const auto isShared = [&](std::uint32_t v) {
      return std::find(shared.begin(), shared.begin() + static_cast<std::ptrdiff_t>(common), v) !=
             shared.begin() + static_cast<std::ptrdiff_t>(common);
    };
    // The triangles that stay: none made twice, none turned over or flattened.
    const Vec3 p = at(from), q = at(to);
    const bool asked = check_ != nullptr && error > checkAbove_;
    made_.clear();

    for (std::uint32_t i = first_[from]; i < first_[from + 1]; ++i) {
      const std::uint32_t* t = &idx_[3 * around_[i]];
      if (t[0] == kDead || t[0] == to || t[1] == to || t[2] == to) continue;
      const std::size_t k = t[0] == from ? 0 : t[1] == from ? 1 : 2;
      const std::uint32_t x = t[(k + 1) % 3], y = t[(k + 2) % 3];
      if (isShared(x) && isShared(y)) return false;
      const Vec3 px = at(x), py = at(y);
      const Vec3 before = cross(sub(px, p), sub(py, p));
      const Vec3 after = cross(sub(px, q), sub(py, q));
      const double b2 = dot(before, before);
      if (b2 > 0 && !(dot(before, after) > 0 && dot(after, after) > 1e-12 * b2)) return false;
      // The new triangle's centroid and the midpoint of its edge from `to` stay within twice the
      // error of the planes that `from` has gathered: the quadric at `to` alone does not see a
      // triangle that tilts away from them towards a neighbour (a cap's triangle stretched to a
      // vertex one voxel above it, say).
      const Vec3 toX = sub(px, p), toY = sub(py, p), toQ = sub(q, p);
      const Quadric& planes = quadrics_[from];
      const Vec3 middle{0.5 * (toQ[0] + toX[0]), 0.5 * (toQ[1] + toX[1]), 0.5 * (toQ[2] + toX[2])};
      const Vec3 centroid{(toQ[0] + toX[0] + toY[0]) / 3, (toQ[1] + toX[1] + toY[1]) / 3,
                          (toQ[2] + toX[2] + toY[2]) / 3};
      if (planes.error(middle) > sampleLimit_ || planes.error(centroid) > sampleLimit_) return false;
      if (asked && !passed) made_.push_back({to, x, y});
    }
    if (asked && !passed && !(*check_)(made_)) return false;
    for (std::uint32_t i = first_[from]; i < first_[from + 1]; ++i) {
      std::uint32_t* t = &idx_[3 * around_[i]];
      if (t[0] == kDead) continue;
      if (t[0] == to || t[1] == to || t[2] == to) {
        t[0] = t[1] = t[2] = kDead;
        --live_;
      } else {
        for (std::size_t k = 0; k < 3; ++k) t[k] = t[k] == from ? to : t[k];
        // Checked, the new triangle's centroid and its edges from `to` were measured; its third
        // edge is the old triangle's, known as that one was.
        if (!asked && !unchecked_.empty()) unchecked_[around_[i]] = 1;
      }
    }
    quadrics_[to].addFrom(quadrics_[from], sub(q, p));
    if (line) {
      // The line now runs from `from`'s other neighbour on it to `to`.
      const std::array<std::uint32_t, 3>& mine = lineEnds_[lineAt_[from]];
      const std::uint32_t other = mine[1] == to ? mine[2] : mine[1];
      const auto relink = [&](std::uint32_t v, std::uint32_t was, std::uint32_t now) {
        if (free_[v] != kLine) return;
        std::array<std::uint32_t, 3>& ends = lineEnds_[lineAt_[v]];
        for (std::size_t k = 1; k < 3; ++k) ends[k] = ends[k] == was ? now : ends[k];
      };
      relink(to, from, other);
      relink(other, from, to);
      free_[from] = kStays;
    }
    // `to` has gained triangles that its list lacks, and its quadric has changed: it waits for the
    // next pass, as does `from`, which is gone.
    mark_[from] = mark_[to] = static_cast<std::uint16_t>(pass);
    if (choosing_) touched_.push_back(to);
    if (record_ != nullptr) record_->push_back({from, to});
    return true;
  }

  Vec3 at(std::uint32_t v) const { return {xyz_[3 * v], xyz_[3 * v + 1], xyz_[3 * v + 2]}; }

  std::span<std::uint32_t> idx_;
  std::size_t count_;  // the indices in use, from the front of idx_
  const float* xyz_;
  std::size_t vertices_;
  std::span<std::uint32_t> origin_;    // each triangle's index in the input, when asked for
  std::span<std::uint8_t> unchecked_;  // 1 for a triangle that a collapse changed unchecked
  std::size_t live_ = 0;
  // The working arrays, made for each call and freed after it; the large ones in huge pages
  // (core/scratch.h), which fault in 2 MiB at a time.
  ScratchVector<Quadric> quadrics_;
  // Per vertex: kStays, kDisk (one closed fan) or kLine (inside a line where three sheets meet);
  // the line vertices with their two neighbours on the line, kept as collapses change them.
  static constexpr std::uint8_t kStays = 0, kDisk = 1, kLine = 2;
  ScratchVector<std::uint8_t> free_;
  std::vector<std::array<std::uint32_t, 3>> lineEnds_;
  ScratchVector<std::uint32_t> lineAt_;  // each vertex's entry in lineEnds_ (kDead: none)
  // Per vertex: the last pass that changed it (passes stop before 2^16), and the link test's stamps.
  ScratchVector<std::uint16_t> mark_, seen_;
  ScratchVector<std::uint8_t> dirty_;  // replaying: 1 where the recorded run's fan may differ
  LazyScratchVector<SimplifyStep>* record_ = nullptr;
  bool* renameFolds_ = nullptr;
  ScratchVector<std::uint32_t> first_, around_;
  LazyScratchVector<std::uint64_t> keys_, spare_;  // reserved for every edge, used for fewer
  // carryKeys(): its new keys; each triangle's new place after compact() (kDead: gone); the last
  // pass's collapses' `to`s (run() with SimplifyLimits::carryKeys only).
  LazyScratchVector<std::uint64_t> fresh_;
  ScratchVector<std::uint32_t> moved_;
  std::vector<std::uint32_t> touched_;
  bool choosing_ = false;
  const std::function<bool(const std::vector<std::array<std::uint32_t, 3>>&)>* check_ = nullptr;
  double checkAbove_ = INFINITY;
  double sampleLimit_ = INFINITY;
  std::vector<std::array<std::uint32_t, 3>> made_;
  std::uint32_t stamp_ = 0;
};

}  // namespace

std::size_t simplifyTriangles(std::span<std::uint32_t> indices, const float* xyz, std::size_t vertexCount,
                              const SimplifyLimits& limits, std::span<std::uint32_t> keptFrom,
                              std::span<std::uint8_t> unchecked) {
  const std::size_t triangles = indices.size() / 3;
  if ((!keptFrom.empty() && keptFrom.size() < triangles) || (!unchecked.empty() && unchecked.size() < triangles)) {
    throw std::invalid_argument("simplifyTriangles: an output array is shorter than the triangles");
  }
  if (vertexCount >= SimplifyStep::kRename &&
      std::any_of(limits.replay.begin(), limits.replay.end(), [](const SimplifyStep& s) { return s.isRename(); })) {
    throw std::invalid_argument("simplifyTriangles: a replay with renames needs fewer than 2^31 vertices");
  }
  if (triangles <= limits.targetTriangles && limits.replay.empty()) {
    for (std::size_t t = 0; t < std::min(triangles, keptFrom.size()); ++t) keptFrom[t] = static_cast<std::uint32_t>(t);
    std::fill(unchecked.begin(), unchecked.end(), 0);
    return 3 * triangles;
  }
  Simplifier simplifier(indices, xyz, vertexCount, limits, keptFrom, unchecked);
  return simplifier.run(limits);
}

std::size_t simplifyTriangles(std::vector<std::uint32_t>& indices, const float* xyz, std::size_t vertexCount,
                              const SimplifyLimits& limits, std::vector<std::uint32_t>* keptFrom) {
  if (keptFrom != nullptr) keptFrom->resize(indices.size() / 3);
  const std::size_t kept =
      simplifyTriangles(std::span<std::uint32_t>(indices), xyz, vertexCount, limits,
                        keptFrom != nullptr ? std::span<std::uint32_t>(*keptFrom) : std::span<std::uint32_t>());
  indices.resize(kept);
  if (keptFrom != nullptr) keptFrom->resize(kept / 3);
  return kept;
}

}  // namespace isoslab
