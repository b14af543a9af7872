// The fans of a triangle mesh's vertices: a vertex's triangles fall into fans, the groups joined
// through edges at the vertex. A manifold vertex has one fan; a vertex where two sheets touch (a
// pinch), or where a mesh cut into chunks leaves several groups, has more. Draco's Edgebreaker
// coder gives each fan a point of its own, and a decimation must not create pinches.
#pragma once

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <span>
#include <utility>
#include <vector>

#include "core/mesh_sink.h"
#include "core/scratch.h"

namespace isoslab {

/// Per vertex base .. base + vertexCount - 1, the number of fans of its triangles (0 when no triangle
/// uses it); the triangles use only those vertices.
inline ScratchVector<std::uint32_t> fanCounts(std::span<const Triangle> triangles, std::size_t vertexCount,
                                              VertexId base = 0) {
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
  ScratchVector<std::uint32_t> fans(vertexCount, 0);
  ScratchVector<std::uint32_t> parent;
  ScratchVector<std::pair<VertexId, std::uint32_t>> ends;  // (the other end of an edge at v, corner slot)
  for (std::size_t v = 0; v < vertexCount; ++v) {
    const std::uint32_t n = first[v + 1] - first[v];
    if (n == 0) continue;
    parent.resize(n);
    std::iota(parent.begin(), parent.end(), 0u);
    const auto find = [&](std::uint32_t x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    ends.clear();
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t c = corners[first[v] + i];
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
    fans[v] = count;
  }
  return fans;
}

}  // namespace isoslab
