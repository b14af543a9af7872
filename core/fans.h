// The fans of a triangle mesh's vertices: a vertex's triangles fall into fans, the groups joined
// through edges at the vertex. A manifold vertex has one fan; a vertex where two sheets touch (a
// pinch), or where a mesh cut into chunks leaves several groups, has more. Draco's Edgebreaker
// coder gives each fan a point of its own, and a decimation must not create pinches.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <numeric>
#include <span>
#include <utility>
#include <vector>

#include "core/mesh_sink.h"
#include "core/scratch.h"

namespace isoslab {

namespace detail {

/// Whether the triangles around a vertex v, each given as the two corners after v, (next[i],
/// prev[i]) of (v, next[i], prev[i]), are one closed fan wound one way: from each triangle to the
/// one triangle whose prev is its next (the edge back from next to v), round one cycle through all
/// of them. Then each edge at v is in exactly two of the triangles, once each way. O(n^2).
inline bool oneCycle(std::span<const VertexId> next, std::span<const VertexId> prev) {
  const auto n = static_cast<std::uint32_t>(next.size());
  if (n < 3 || prev.size() != n) return false;
  // Each step goes to the first triangle whose prev is the current next. The walk must come back to
  // triangle 0 at step n and not before, so it has visited every triangle once: then no next has a
  // second match (were prev[j2] == prev[j1] with j1 < j2 both matches of some next, the step into j2
  // would have found j1 first), and each edge is in exactly two triangles.
  std::uint32_t at = 0;
  for (std::uint32_t step = 1; step <= n; ++step) {
    const VertexId x = next[at];
    std::uint32_t j = 0;
    while (j < n && prev[j] != x) ++j;
    if (j == n) return false;
    at = j;
    if (at == 0) return step == n;
  }
  return false;
}

/// Whether one vertex's triangles, given as its corners (3 t + k, the vertex at corner k of triangle
/// t), are one closed fan wound one way: from each triangle (v, x, y) to the one triangle that has
/// the edge back from x to v, (v, w, x), round a cycle through all of them. Then each edge at the
/// vertex is in exactly two of its triangles, once each way. Up to 16 triangles (more: false).
inline bool closedFan(std::span<const Triangle> triangles, std::span<const std::uint32_t> corners) {
  const auto n = static_cast<std::uint32_t>(corners.size());
  if (n < 3 || n > 16) return false;
  // Each triangle's corners after the vertex, (x, y) of (v, x, y).
  std::array<VertexId, 16> next{}, prev{};
  for (std::uint32_t i = 0; i < n; ++i) {
    const Triangle& t = triangles[corners[i] / 3];
    const std::uint32_t k = corners[i] % 3;
    next[i] = t[k == 2 ? 0 : k + 1];
    prev[i] = t[k == 0 ? 2 : k - 1];
  }
  return oneCycle(std::span<const VertexId>(next.data(), n), std::span<const VertexId>(prev.data(), n));
}

/// The fans of one vertex's triangles, given as its corners (3 t + k, the vertex at corner k of
/// triangle t), by union-find over the edges at the vertex (callers try closedFan first, which
/// settles most vertices). `parent` and `ends` are working arrays that the calls share.
inline std::uint32_t fansAmong(std::span<const Triangle> triangles, std::span<const std::uint32_t> corners,
                               ScratchVector<std::uint32_t>& parent,
                               ScratchVector<std::pair<VertexId, std::uint32_t>>& ends) {
  const auto n = static_cast<std::uint32_t>(corners.size());
  if (n == 0) return 0;
  parent.resize(n);
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  // (the other end of an edge at the vertex, corner slot)
  ends.clear();
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t c = corners[i];
    const Triangle& t = triangles[c / 3];
    ends.emplace_back(t[(c % 3 + 1) % 3], i);
    ends.emplace_back(t[(c % 3 + 2) % 3], i);
  }
  // A vertex has a few triangles: an insertion sort (a sort where it has many).
  if (ends.size() > 32) {
    std::sort(ends.begin(), ends.end());
  } else {
    for (std::size_t e = 1; e < ends.size(); ++e) {
      const auto x = ends[e];
      std::size_t m = e;
      for (; m > 0 && x < ends[m - 1]; --m) ends[m] = ends[m - 1];
      ends[m] = x;
    }
  }
  for (std::size_t e = 1; e < ends.size(); ++e) {
    if (ends[e].first == ends[e - 1].first) parent[find(ends[e].second)] = find(ends[e - 1].second);
  }
  std::uint32_t count = 0;
  for (std::uint32_t i = 0; i < n; ++i) count += find(i) == i ? 1 : 0;
  return count;
}

}  // namespace detail

/// Per vertex base .. base + vertexCount - 1, the number of fans of its triangles (0 when no triangle
/// uses it); the triangles use only those vertices. With `closed`, also 1 per vertex whose triangles
/// are one closed fan wound one way (detail::closedFan), else 0.
inline ScratchVector<std::uint32_t> fanCounts(std::span<const Triangle> triangles, std::size_t vertexCount,
                                              VertexId base = 0, ScratchVector<std::uint8_t>* closed = nullptr) {
  // The corners at each vertex, in order (counting sort by vertex).
  ScratchVector<std::uint32_t> first(vertexCount + 1, 0);
  for (const Triangle& t : triangles) {
    for (VertexId v : t) ++first[v - base + 1];
  }
  for (std::size_t v = 0; v < vertexCount; ++v) first[v + 1] += first[v];
  ScratchVector<std::uint32_t> corners(first[vertexCount]);
  ScratchVector<std::uint32_t> fill(first.begin(), first.end() - 1);
  for (std::uint32_t t = 0; t < triangles.size(); ++t) {
    for (std::uint32_t k = 0; k < 3; ++k) corners[fill[triangles[t][k] - base]++] = 3 * t + k;
  }
  ScratchVector<std::uint32_t>().swap(fill);  // freed (`= {}` would only empty it)
  ScratchVector<std::uint32_t> fans(vertexCount, 0);
  ScratchVector<std::uint32_t> parent;
  ScratchVector<std::pair<VertexId, std::uint32_t>> ends;
  if (closed != nullptr) closed->assign(vertexCount, 0);
  for (std::size_t v = 0; v < vertexCount; ++v) {
    const auto around = std::span<const std::uint32_t>(corners).subspan(first[v], first[v + 1] - first[v]);
    if (detail::closedFan(triangles, around)) {
      fans[v] = 1;
      if (closed != nullptr) (*closed)[v] = 1;
    } else {
      fans[v] = detail::fansAmong(triangles, around, parent, ends);
    }
  }
  return fans;
}

/// The number of fans of each of `vertices` (sorted and distinct), in their order: one pass over
/// the triangles, for a few vertices of a large mesh.
inline std::vector<std::uint32_t> fanCountsAt(std::span<const Triangle> triangles, std::span<const VertexId> vertices) {
  std::vector<std::uint32_t> fans(vertices.size(), 0);
  if (vertices.empty()) return fans;
  // Each listed vertex's corners, in triangle order.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> found;  // (slot in `vertices`, corner)
  const VertexId low = vertices.front(), high = vertices.back();
  for (std::uint32_t t = 0; t < triangles.size(); ++t) {
    for (std::uint32_t k = 0; k < 3; ++k) {
      const VertexId v = triangles[t][k];
      if (v < low || v > high) continue;
      const auto it = std::lower_bound(vertices.begin(), vertices.end(), v);
      if (it != vertices.end() && *it == v)
        found.emplace_back(static_cast<std::uint32_t>(it - vertices.begin()), 3 * t + k);
    }
  }
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::uint32_t> corners;
  ScratchVector<std::uint32_t> parent;
  ScratchVector<std::pair<VertexId, std::uint32_t>> ends;
  for (std::size_t i = 0; i < found.size();) {
    std::size_t j = i;
    corners.clear();
    for (; j < found.size() && found[j].first == found[i].first; ++j) corners.push_back(found[j].second);
    fans[found[i].first] =
        detail::closedFan(triangles, corners) ? 1 : detail::fansAmong(triangles, corners, parent, ends);
    i = j;
  }
  return fans;
}

}  // namespace isoslab
