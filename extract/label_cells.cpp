#include "extract/label_cells.h"

#include <algorithm>
#include <bit>

#include "core/float_runs.h"

namespace isoslab {
namespace {

// The edge (kLabelEdgeCorners) that joins two corners of a cell.
constexpr int edgeOf(int a, int b) noexcept {
  for (int e = 0; e < 12; ++e) {
    const auto& c = kLabelEdgeCorners[static_cast<std::size_t>(e)];
    if ((c[0] == a && c[1] == b) || (c[0] == b && c[1] == a)) return e;
  }
  return -1;
}

// Per face (kLabelFaceCorners), its edges in cyclic order: edge k joins corners k and k + 1.
constexpr std::array<std::array<int, 4>, 6> makeFaceEdges() noexcept {
  std::array<std::array<int, 4>, 6> out{};
  for (std::size_t f = 0; f < 6; ++f) {
    for (std::size_t k = 0; k < 4; ++k) out[f][k] = edgeOf(kLabelFaceCorners[f][k], kLabelFaceCorners[f][(k + 1) % 4]);
  }
  return out;
}
constexpr std::array<std::array<int, 4>, 6> kFaceEdges = makeFaceEdges();

constexpr int find(std::array<int, 12>& parent, int e) noexcept {
  while (parent[static_cast<std::size_t>(e)] != e) {
    auto& p = parent[static_cast<std::size_t>(e)];
    p = parent[static_cast<std::size_t>(p)];
    e = p;
  }
  return e;
}

constexpr void join(std::array<int, 12>& parent, int a, int b) noexcept {
  a = find(parent, a);
  b = find(parent, b);
  if (a < b) parent[static_cast<std::size_t>(b)] = a;
  if (b < a) parent[static_cast<std::size_t>(a)] = b;
}

// kSpread[m]: bit 3c set for each bit c of the corner mask m (a rank of 1 at those corners).
constexpr std::array<std::uint32_t, 256> kSpread = [] {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t m = 0; m < 256; ++m) {
    for (std::uint32_t c = 0; c < 8; ++c) t[m] |= ((m >> c) & 1u) << (3 * c);
  }
  return t;
}();

// kBase3[m]: the sum of 3^c over the bits c of the corner mask m, so that a cell of three labels
// whose ranks 1 and 2 hold the corners m1 and m2 is pattern kBase3[m1] + 2 * kBase3[m2] of 3^8.
constexpr std::array<std::uint16_t, 256> kBase3 = [] {
  std::array<std::uint16_t, 256> t{};
  for (std::uint32_t m = 0; m < 256; ++m) {
    std::uint32_t sum = 0, power = 1;
    for (std::uint32_t c = 0; c < 8; ++c, power *= 3) sum += ((m >> c) & 1u) * power;
    t[m] = static_cast<std::uint16_t>(sum);
  }
  return t;
}();
constexpr std::size_t kThreeLabelPatterns = 6561;  // 3^8

// A pattern key's first slot in a table of `size` (a power of two) slots: Fibonacci hashing, with
// the high bits folded in.
std::size_t slotOfKey(std::uint32_t key, std::size_t size) noexcept {
  std::uint32_t h = key * 0x9e3779b1u;
  h ^= h >> 15;
  return h & (size - 1);
}

constexpr int faceSplitOf(const std::array<std::int32_t, 4>& f) noexcept {
  if (f[0] == f[1] || f[1] == f[2] || f[2] == f[3] || f[3] == f[0]) return 0;  // fewer than four crossed
  const bool even = f[0] == f[2];
  const bool odd = f[1] == f[3];
  if (even && odd) return connectsBefore(f[0], f[1]) ? 2 : 1;
  if (even) return 2;  // corners 0 and 2 connect: copies around 1 and 3
  if (odd) return 1;
  return 0;  // four labels: one edge with four quads, two per label
}

constexpr CellGroups groupsOf(const std::array<std::int32_t, 8>& labels) noexcept {
  CellGroups out;
  out.edge.fill(0xff);
  std::array<int, 12> parent{};
  std::array<bool, 12> crossed{};
  bool any = false;
  for (int e = 0; e < 12; ++e) {
    const auto& c = kLabelEdgeCorners[static_cast<std::size_t>(e)];
    parent[static_cast<std::size_t>(e)] = e;
    crossed[static_cast<std::size_t>(e)] =
        labels[static_cast<std::size_t>(c[0])] != labels[static_cast<std::size_t>(c[1])];
    any = any || crossed[static_cast<std::size_t>(e)];
  }
  if (!any) return out;
  for (const auto& corners : kLabelFaceCorners) {
    std::array<std::int32_t, 4> f{};
    for (std::size_t k = 0; k < 4; ++k) {
      f[k] = labels[static_cast<std::size_t>(corners[k])];
    }
    const auto face = static_cast<std::size_t>(&corners - kLabelFaceCorners.data());
    const auto& edges = kFaceEdges[face];
    const int split = faceSplitOf(f);
    out.faceSplits = static_cast<std::uint16_t>(out.faceSplits | (split << (2 * face)));
    if (split == 1) {  // around corner 0 (edges 3, 0) and corner 2 (edges 1, 2)
      join(parent, edges[3], edges[0]);
      join(parent, edges[1], edges[2]);
    } else if (split == 2) {  // around corner 1 (edges 0, 1) and corner 3 (edges 2, 3)
      join(parent, edges[0], edges[1]);
      join(parent, edges[2], edges[3]);
    } else {
      int first = -1;
      for (int e : edges) {
        if (!crossed[static_cast<std::size_t>(e)]) continue;
        if (first < 0) {
          first = e;
        } else {
          join(parent, first, e);
        }
      }
    }
  }
  // Roots are each group's lowest edge, so numbering roots in edge order numbers the groups so.
  std::array<std::uint8_t, 12> copyOfRoot{};
  copyOfRoot.fill(0xff);
  for (int e = 0; e < 12; ++e) {
    if (!crossed[static_cast<std::size_t>(e)]) continue;
    const auto root = static_cast<std::size_t>(find(parent, e));
    if (copyOfRoot[root] == 0xff) copyOfRoot[root] = out.count++;
    out.edge[static_cast<std::size_t>(e)] = copyOfRoot[root];
  }
  constexpr std::array<std::size_t, 4> kTop{2, 3, 6, 7};
  for (std::size_t k = 0; k < 4; ++k) {
    if (out.edge[kTop[k]] == 0xff) continue;
    out.topCrossed = static_cast<std::uint8_t>(out.topCrossed | (1u << k));
    out.topCopies = static_cast<std::uint8_t>(out.topCopies | (out.edge[kTop[k]] << (2 * k)));
  }
  return out;
}

}  // namespace

// Every cell of two labels, by the mask of the later-connecting label's corners: made by
// groupCell's own code when the program is compiled.
constexpr std::array<CellGroups, 256> kTwoLabelGroups = [] {
  std::array<CellGroups, 256> table{};
  for (int mask = 0; mask < 256; ++mask) {
    std::array<std::int32_t, 8> labels{};
    for (int c = 0; c < 8; ++c) labels[static_cast<std::size_t>(c)] = (mask >> c) & 1;
    table[static_cast<std::size_t>(mask)] = groupsOf(labels);
  }
  return table;
}();

int faceSplit(const std::array<std::int32_t, 4>& f) noexcept {
  return faceSplitOf(f);
}

CellGroups groupCell(const std::array<std::int32_t, 8>& labels) noexcept {
  return groupsOf(labels);
}

namespace {

// kEdgeEnds[e]: the corner mask of edge e's two ends.
constexpr std::array<std::uint8_t, 12> kEdgeEnds = [] {
  std::array<std::uint8_t, 12> t{};
  for (std::size_t e = 0; e < 12; ++e) {
    t[e] = static_cast<std::uint8_t>((1u << kLabelEdgeCorners[e][0]) | (1u << kLabelEdgeCorners[e][1]));
  }
  return t;
}();

// forEachPinch without the std::function: a fresh pattern of the cell cache pays for this, a few
// thousand a run on an atlas. The faces' splits are the groups' (computed once, not per label),
// and a label's quads are a 12-bit mask of the crossed edges with an end at one of its corners.
template <class Pinched>
void pinchesOf(const std::array<std::int32_t, 8>& labels, const CellGroups& groups, Pinched&& pinched) {
  std::uint32_t crossed = 0;
  for (std::size_t e = 0; e < 12; ++e) crossed |= static_cast<std::uint32_t>(groups.edge[e] != 0xff) << e;
  std::uint32_t seen = 0;
  for (std::size_t c = 0; c < 8; ++c) {
    if (((seen >> c) & 1u) != 0) continue;
    const std::int32_t l = labels[c];
    std::uint32_t corners = 0;
    for (std::size_t d = c; d < 8; ++d) corners |= static_cast<std::uint32_t>(labels[d] == l) << d;
    seen |= corners;
    // A label at one corner only never pinches: its three quads meet at that corner, and every face
    // at it joins the two that it holds (whole, or split around that very corner), so they are one
    // fan.
    if (std::has_single_bit(corners)) continue;
    // Per label: its quads (crossed edges touching it), joined where they share an edge copy; each
    // vertex copy should hold one group.
    std::uint32_t touch = 0;
    for (std::size_t e = 0; e < 12; ++e) {
      touch |= static_cast<std::uint32_t>((kEdgeEnds[e] & corners) != 0) << e;
    }
    touch &= crossed;
    const auto touches = [touch](int e) { return ((touch >> e) & 1u) != 0; };
    std::array<int, 12> parent{};
    for (int e = 0; e < 12; ++e) parent[static_cast<std::size_t>(e)] = e;
    for (std::size_t face = 0; face < 6; ++face) {
      const auto& edges = kFaceEdges[face];
      const int split = groups.faceSplitOf(static_cast<int>(face));
      if (split == 0) {  // one edge copy: the label's two quads in it (if any)
        int a = -1;
        for (int e : edges) {
          if (!touches(e)) continue;
          if (a < 0) {
            a = e;
          } else {
            join(parent, a, e);
          }
        }
        continue;
      }
      const std::array<std::array<int, 2>, 2> pairs =
          split == 1 ? std::array<std::array<int, 2>, 2>{{{edges[3], edges[0]}, {edges[1], edges[2]}}}
                     : std::array<std::array<int, 2>, 2>{{{edges[0], edges[1]}, {edges[2], edges[3]}}};
      for (const auto& p : pairs) {
        if (touches(p[0]) && touches(p[1])) join(parent, p[0], p[1]);
      }
    }
    std::array<int, 4> fans{};
    for (int e = 0; e < 12; ++e) {
      if (touches(e) && find(parent, e) == e) ++fans[groups.edge[static_cast<std::size_t>(e)]];
    }
    for (int f : fans) {
      if (f > 1) pinched(l, f - 1);
    }
  }
}

}  // namespace

void forEachPinch(const std::array<std::int32_t, 8>& labels, const CellGroups& groups,
                  const std::function<void(std::int32_t, int)>& pinched) {
  pinchesOf(labels, groups, pinched);
}

void appendSplits(const std::array<std::int32_t, 8>& labels, const CellGroups& g, std::vector<std::int32_t>& splits) {
  for (std::size_t c = 0; c < 8; ++c) {
    const std::int32_t l = labels[c];
    bool earlier = l == 0;
    for (std::size_t d = 0; d < c && !earlier; ++d) earlier = labels[d] == l;
    if (earlier) continue;
    std::uint8_t in = 0;
    for (std::size_t e = 0; e < 12; ++e) {
      if (g.edge[e] == 0xff) continue;
      const auto& ends = kLabelEdgeCorners[e];
      if (labels[static_cast<std::size_t>(ends[0])] == l || labels[static_cast<std::size_t>(ends[1])] == l) {
        in = static_cast<std::uint8_t>(in | (1u << g.edge[e]));
      }
    }
    for (int k = std::popcount(in); k > 1; --k) splits.push_back(l);
  }
}

const CellGroups& LabelCellCache::manyLabels(const CellLabels& cell, std::uint32_t isA, std::uint32_t isB,
                                             std::vector<std::int32_t>& pinches) {
  // The distinct labels in connection order, and the pattern's key: each corner's rank among them
  // (3 bits a corner).
  const std::array<std::int32_t, 8>& labels = cell.value;
  std::array<std::int32_t, 8> distinct{};
  std::uint32_t key = 0;
  const std::uint32_t rest = ~(isA | isB) & 0xffu;
  const std::int32_t c = labels[static_cast<std::size_t>(std::countr_zero(rest))];
  const std::uint32_t isC = cell.corners(c);
  if ((isA | isB | isC) == 0xffu) {
    // Three labels, the usual case: sorted as three, the key from their corners' masks.
    std::array<std::pair<std::int32_t, std::uint32_t>, 3> t{{{labels[0], isA}, {labels[0], isB}, {c, isC}}};
    t[1].first = labels[static_cast<std::size_t>(std::countr_zero(isB))];
    const auto before = [](const auto& x, const auto& y) { return connectsBefore(x.first, y.first); };
    if (before(t[1], t[0])) std::swap(t[0], t[1]);
    if (before(t[2], t[1])) std::swap(t[1], t[2]);
    if (before(t[1], t[0])) std::swap(t[0], t[1]);
    for (std::size_t k = 0; k < 3; ++k) distinct[k] = t[k].first;
    // Three labels' patterns are few enough (3^8) to be found by index, with no hashing.
    if (threeLabels_.empty()) threeLabels_.assign(kThreeLabelPatterns, 0);
    std::uint32_t& index = threeLabels_[kBase3[t[1].second] + 2u * kBase3[t[2].second]];
    if (index == 0) {
      index = static_cast<std::uint32_t>(patterns_.size()) + 1;
      makePattern(kSpread[t[1].second] + 2 * kSpread[t[2].second], distinct.front() == 0);
    }
    return found(patterns_[index - 1], distinct, pinches);
  } else {
    // Four or more: an insertion into at most eight, then each corner's rank.
    std::size_t n = 0;
    for (const std::int32_t l : labels) {
      std::size_t at = 0;
      while (at < n && distinct[at] != l && connectsBefore(distinct[at], l)) ++at;
      if (at < n && distinct[at] == l) continue;
      for (std::size_t k = n; k > at; --k) distinct[k] = distinct[k - 1];
      distinct[at] = l;
      ++n;
    }
    for (std::size_t corner = 0; corner < 8; ++corner) {
      std::uint32_t rank = 0;
      while (distinct[rank] != labels[corner]) ++rank;
      key |= rank << (3 * corner);
    }
  }
  if (slots_.size() < 2 * (hashed_ + 1)) {  // grow, keeping every pattern's index
    std::vector<std::pair<std::uint32_t, std::uint32_t>> old(std::max<std::size_t>(1024, 2 * slots_.size()));
    old.swap(slots_);
    for (const auto& entry : old) {
      if (entry.first == 0) continue;
      std::size_t at = slotOfKey(entry.first, slots_.size());
      while (slots_[at].first != 0) at = (at + 1) & (slots_.size() - 1);
      slots_[at] = entry;
    }
  }
  std::size_t at = slotOfKey(key + 1, slots_.size());
  while (slots_[at].first != 0 && slots_[at].first != key + 1) at = (at + 1) & (slots_.size() - 1);
  if (slots_[at].first == 0) {
    slots_[at] = {key + 1, static_cast<std::uint32_t>(patterns_.size())};
    ++hashed_;
    makePattern(key, distinct.front() == 0);
  }
  return found(patterns_[slots_[at].second], distinct, pinches);
}

void LabelCellCache::makePattern(std::uint32_t key, bool background) {
  // Ranks keep the connection order (0 stays the background's rank only when 0 is there, and the
  // rule only compares labels), so the pattern's copies are the cell's.
  Pattern& made = patterns_.emplace_back();
  std::array<std::int32_t, 8> pattern{};
  for (std::size_t corner = 0; corner < 8; ++corner) {
    const auto rank = static_cast<std::int32_t>((key >> (3 * corner)) & 7u);
    pattern[corner] = background ? rank : rank + 1;
  }
  made.groups = groupCell(pattern);
  pinchesOf(pattern, made.groups, [&](std::int32_t label, int extra) {
    made.pinches.emplace_back(static_cast<std::uint8_t>(background ? label : label - 1), extra);
  });
}

const CellGroups& LabelCellCache::found(const Pattern& p, const std::array<std::int32_t, 8>& distinct,
                                        std::vector<std::int32_t>& pinches) {
  for (const auto& [rank, extra] : p.pinches) {
    for (int k = 0; k < extra; ++k) pinches.push_back(distinct[rank]);
  }
  return p.groups;
}

void classifyLabelRows(const float* slice, std::int64_t nx, std::int64_t ny, std::vector<RowSpan>& rows) {
  rows.resize(static_cast<std::size_t>(ny));
  for (std::int64_t j = 0; j < ny; ++j) {
    const float* r = slice + j * nx;
    RowSpan span;
    const std::int64_t i = runEnd(r, 1, nx, r[0]);  // the first sample unlike the first
    if (i < nx) {
      span.first = i;
      span.last = runStart(r, 0, nx - 1, r[nx - 1]) + 1;  // after the last sample unlike the last
    }
    rows[static_cast<std::size_t>(j)] = span;
  }
}

}  // namespace isoslab
