#include "process/degenerate.h"

#include <algorithm>
#include <array>
#include <utility>

#include "core/interrupt.h"

namespace isoslab {
namespace {

bool repeats(const Triangle& t) noexcept {
  return t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
}

}  // namespace

void DegenerateCollapseSink::begin(const MeshHeader& header) {
  next_.begin(header);
}

void DegenerateCollapseSink::consume(const MeshChunk& chunk) {
  pending_.push_back(chunk);
  joinZeroEdges(pending_.back());
  // A cluster whose members all lie before this chunk is complete: later triangles use only this
  // chunk's vertices and newer ones.
  settle(chunk.firstVertex);
  // A chunk leaves once no open cluster has a member in it (its triangles use its own and the
  // previous chunk's vertices, and the previous one has left); the newest waits for the next.
  VertexId lowestOpen = pending_.back().endVertex();
  for (const auto& entry : parent_) lowestOpen = std::min(lowestOpen, entry.first);
  while (pending_.size() > 1 && pending_.front().endVertex() <= lowestOpen) emitFront();
}

void DegenerateCollapseSink::finish() {
  if (!pending_.empty()) settle(pending_.back().endVertex());
  while (!pending_.empty()) emitFront();
  next_.finish();
}

const Vec3f& DegenerateCollapseSink::position(VertexId v) const {
  return const_cast<DegenerateCollapseSink*>(this)->mutablePosition(v);
}

Vec3f& DegenerateCollapseSink::mutablePosition(VertexId v) {
  for (auto it = pending_.rbegin(); it != pending_.rend(); ++it) {
    if (v >= it->firstVertex) return it->positions[v - it->firstVertex];
  }
  return pending_.front().positions.front();  // unreachable: a complete cluster's chunks are pending
}

VertexId DegenerateCollapseSink::find(VertexId v) {
  auto it = parent_.find(v);
  if (it == parent_.end()) return v;
  VertexId root = v;
  while (true) {
    const auto up = parent_.find(root);
    if (up == parent_.end() || up->second == root) break;
    root = up->second;
  }
  // Path compression.
  while (v != root) {
    VertexId& p = parent_[v];
    const VertexId nextUp = p;
    p = root;
    v = nextUp;
  }
  return root;
}

void DegenerateCollapseSink::joinZeroEdges(const MeshChunk& chunk) {
  for (std::size_t k = 0; k < chunk.triangles.size(); ++k) {
    throwIfInterruptedEvery(k);
    const Triangle& t = chunk.triangles[k];
    for (int e = 0; e < 3; ++e) {
      const VertexId a = t[e];
      const VertexId b = t[(e + 1) % 3];
      if (a == b || !(position(a) == position(b))) continue;
      const VertexId ra = find(a);
      const VertexId rb = find(b);
      parent_.try_emplace(a, a);
      parent_.try_emplace(b, b);
      if (ra == rb) continue;
      // The smaller id is the root, and the survivor.
      parent_.try_emplace(ra, ra);
      parent_.try_emplace(rb, rb);
      parent_[std::max(ra, rb)] = std::min(ra, rb);
    }
  }
}

std::optional<Triangle> DegenerateCollapseSink::mapped(const Triangle& t) const {
  if (merged_.empty()) return t;
  Triangle out = t;
  std::array<VertexId, 3> cluster{};
  std::array<bool, 3> merged{};
  for (std::size_t k = 0; k < 3; ++k) {
    const auto it = merged_.find(t[k]);
    if (it == merged_.end()) continue;
    out[k] = it->second.survivor;
    cluster[k] = it->second.cluster;
    merged[k] = true;
  }
  for (std::size_t k = 0; k < 3; ++k) {
    const std::size_t j = (k + 1) % 3;
    if (merged[k] && merged[j] && cluster[k] == cluster[j]) return std::nullopt;
  }
  if (!corners_.empty()) {
    for (std::size_t k = 0; k < 3; ++k) {
      const auto it = corners_.find({t, t[k]});
      if (it != corners_.end()) out[k] = it->second;
    }
  }
  if (repeats(out)) return std::nullopt;
  return out;
}

void DegenerateCollapseSink::settle(VertexId before) {
  if (parent_.empty()) return;
  // The open clusters, by root (their smallest member), with their members.
  std::vector<std::pair<VertexId, VertexId>> byRoot;  // (root, member)
  byRoot.reserve(parent_.size());
  std::vector<VertexId> keys;
  keys.reserve(parent_.size());
  for (const auto& entry : parent_) keys.push_back(entry.first);
  for (VertexId v : keys) byRoot.emplace_back(find(v), v);
  std::sort(byRoot.begin(), byRoot.end());
  std::vector<Cluster> complete;
  for (std::size_t i = 0; i < byRoot.size();) {
    std::size_t j = i;
    while (j < byRoot.size() && byRoot[j].first == byRoot[i].first) ++j;
    if (byRoot[j - 1].second < before) {  // members sorted: the last is the largest
      Cluster& c = complete.emplace_back();
      for (std::size_t k = i; k < j; ++k) {
        c.members.push_back(byRoot[k].second);
        parent_.erase(byRoot[k].second);
      }
    }
    i = j;
  }
  if (complete.empty()) return;
  // Merges see the ones made before them (a triangle that an earlier merge dropped is no longer
  // in a fan), so they go in one order however the stream is cut: by largest member, the order
  // in which clusters complete.
  std::sort(complete.begin(), complete.end(),
            [](const Cluster& a, const Cluster& b) { return a.members.back() < b.members.back(); });
  // Every pending triangle that uses a member, from the chunk of the smallest member on.
  std::unordered_map<VertexId, std::size_t> owner;
  VertexId lowest = complete.front().members.front();
  VertexId highest = 0;
  for (std::size_t c = 0; c < complete.size(); ++c) {
    for (VertexId v : complete[c].members) owner.emplace(v, c);
    lowest = std::min(lowest, complete[c].members.front());
    highest = std::max(highest, complete[c].members.back());
  }
  for (const MeshChunk& chunk : pending_) {
    if (chunk.endVertex() <= lowest) continue;  // its triangles use vertices before `lowest` only
    for (const Triangle& t : chunk.triangles) {
      std::size_t last = complete.size();
      for (VertexId v : t) {
        if (v < lowest || v > highest) continue;
        const auto it = owner.find(v);
        if (it == owner.end() || it->second == last) continue;
        complete[it->second].triangles.push_back(t);
        last = it->second;  // a triangle with two members of one cluster is listed once
      }
    }
  }
  for (Cluster& c : complete) {
    // A triangle whose corners belong to two members of one cluster, but not adjacently, could be
    // listed twice above; once is enough.
    std::sort(c.triangles.begin(), c.triangles.end());
    c.triangles.erase(std::unique(c.triangles.begin(), c.triangles.end()), c.triangles.end());
    if (const auto merge = fans(c)) {
      for (std::size_t k = 0; k < c.members.size(); ++k) {
        merged_.emplace(c.members[k], Merge{merge->survivors[k], c.members.front()});
      }
      for (const auto& [corner, survivor] : merge->corners) corners_.emplace(corner, survivor);
      ++counts_.clusters;
      counts_.vertices += static_cast<std::int64_t>(c.members.size() - std::max<std::size_t>(merge->count, 1));
      counts_.splits += merge->count > 1 ? 1 : 0;
    } else {
      ++counts_.refused;
      for (const Triangle& t : c.triangles) {
        int inside = 0;
        for (VertexId v : t) inside += std::binary_search(c.members.begin(), c.members.end(), v) ? 1 : 0;
        counts_.refusedTriangles += inside >= 2 ? 1 : 0;
      }
      counts_.separated += separate(c);
    }
  }
}

// A refused cluster: every member but the first moves a little towards the mean of its neighbours
// outside the cluster (a thousandth of the way, more if float cannot tell the points apart), so that
// no triangle keeps two corners at one point. Ids and topology stay; the zero-area triangles become
// slivers. Returns the members moved.
std::int64_t DegenerateCollapseSink::separate(const Cluster& cluster) {
  const Vec3f at = position(cluster.members.front());
  // Where no neighbour of a member lies off the point, the way to any corner of the cluster's
  // triangles that does.
  std::optional<Vec3f> anyOff;
  for (const Triangle& t : cluster.triangles) {
    for (const VertexId v : t) {
      if (!anyOff && !(position(v) == at)) anyOff = position(v);
    }
  }
  if (!anyOff) return 0;
  std::vector<Vec3f> placed{at};
  std::int64_t moved = 0;
  for (std::size_t k = 1; k < cluster.members.size(); ++k) {
    const VertexId m = cluster.members[k];
    // The mean of its neighbours as they now lie (members moved before it included).
    double d[3] = {0, 0, 0};
    int count = 0;
    std::optional<Vec3f> off;
    for (const Triangle& t : cluster.triangles) {
      if (std::find(t.begin(), t.end(), m) == t.end()) continue;
      for (const VertexId v : t) {
        if (v == m) continue;
        const Vec3f& p = position(v);
        if (!off && !(p == at)) off = p;
        d[0] += p.x;
        d[1] += p.y;
        d[2] += p.z;
        ++count;
      }
    }
    if (count > 0) {
      d[0] = d[0] / count - at.x;
      d[1] = d[1] / count - at.y;
      d[2] = d[2] / count - at.z;
    }
    if (d[0] == 0 && d[1] == 0 && d[2] == 0) {
      const Vec3f& p = off ? *off : *anyOff;
      d[0] = double(p.x) - at.x;
      d[1] = double(p.y) - at.y;
      d[2] = double(p.z) - at.z;
    }
    for (const double step : {1e-3, 1e-2, 1e-1}) {
      const Vec3f q{static_cast<float>(at.x + step * d[0]), static_cast<float>(at.y + step * d[1]),
                    static_cast<float>(at.z + step * d[2])};
      if (std::find(placed.begin(), placed.end(), q) != placed.end()) continue;
      mutablePosition(m) = q;
      placed.push_back(q);
      ++moved;
      break;
    }
  }
  return moved;
}

// The cluster's triangles that keep one member, each seen from that member as the fan edge
// (a, b). Every neighbour must start one fan edge at most and end one at most (else an edge of the
// merged point would have more than two triangles); the fan edges then form chains, each a fan of
// its own vertex (the smallest member in it that no earlier chain took). A chain that is open is a
// border, allowed only where the members already had one. A member whose kept triangles lie in two
// chains goes to each chain's vertex triangle by triangle.
std::optional<DegenerateCollapseSink::Fans> DegenerateCollapseSink::fans(const Cluster& cluster) const {
  const auto memberIndex = [&](VertexId v) -> std::ptrdiff_t {
    const auto it = std::lower_bound(cluster.members.begin(), cluster.members.end(), v);
    return it != cluster.members.end() && *it == v ? it - cluster.members.begin() : -1;
  };
  struct FanEdge {
    VertexId a = 0;
    VertexId b = 0;
    std::ptrdiff_t member = 0;
    Triangle triangle{};
    bool operator<(const FanEdge& o) const { return a < o.a; }
  };
  std::vector<FanEdge> link;
  std::vector<std::pair<VertexId, VertexId>> directed;  // edges at members, before the merge
  for (const Triangle& original : cluster.triangles) {
    const auto t = mapped(original);
    if (!t) continue;  // dropped by an earlier cluster's merge
    int inside = 0;
    std::size_t at = 0;
    for (std::size_t k = 0; k < 3; ++k) {
      const VertexId u = (*t)[k];
      const VertexId v = (*t)[(k + 1) % 3];
      if (memberIndex(u) >= 0) {
        ++inside;
        at = k;
      }
      if (memberIndex(u) >= 0 || memberIndex(v) >= 0) directed.emplace_back(u, v);
    }
    if (inside == 1) link.push_back({(*t)[(at + 1) % 3], (*t)[(at + 2) % 3], memberIndex((*t)[at]), original});
  }
  std::sort(directed.begin(), directed.end());
  bool border = false;
  for (const auto& [u, v] : directed) {
    if (!std::binary_search(directed.begin(), directed.end(), std::pair{v, u})) border = true;
  }
  std::sort(link.begin(), link.end());
  std::vector<VertexId> ends;
  ends.reserve(link.size());
  for (std::size_t k = 0; k < link.size(); ++k) {
    if (k > 0 && link[k].a == link[k - 1].a) return std::nullopt;  // a neighbour twice
    ends.push_back(link[k].b);
  }
  std::sort(ends.begin(), ends.end());
  if (std::adjacent_find(ends.begin(), ends.end()) != ends.end()) return std::nullopt;
  // Walk the chains: open ones from their starts first, then the closed ones.
  const auto edgeFrom = [&](VertexId v) -> std::ptrdiff_t {
    const auto it = std::lower_bound(link.begin(), link.end(), FanEdge{v, 0, 0, {}});
    return it != link.end() && it->a == v ? it - link.begin() : -1;
  };
  std::vector<int> chainOf(link.size(), -1);
  int chains = 0;
  const auto walk = [&](std::ptrdiff_t e) {
    for (; e >= 0 && chainOf[static_cast<std::size_t>(e)] < 0; e = edgeFrom(link[static_cast<std::size_t>(e)].b)) {
      chainOf[static_cast<std::size_t>(e)] = chains;
    }
    ++chains;
  };
  for (std::size_t e = 0; e < link.size(); ++e) {
    if (std::binary_search(ends.begin(), ends.end(), link[e].a)) continue;
    if (!border) return std::nullopt;
    walk(static_cast<std::ptrdiff_t>(e));
  }
  for (std::size_t e = 0; e < link.size(); ++e) {
    if (chainOf[e] < 0) walk(static_cast<std::ptrdiff_t>(e));
  }
  // Each chain's vertex: its smallest member that no earlier chain took.
  const std::size_t n = cluster.members.size();
  std::vector<std::vector<bool>> inChain(static_cast<std::size_t>(chains), std::vector<bool>(n, false));
  std::vector<int> memberChains(n, 0);
  for (std::size_t e = 0; e < link.size(); ++e) {
    auto slot = inChain[static_cast<std::size_t>(chainOf[e])][static_cast<std::size_t>(link[e].member)];
    if (!slot) ++memberChains[static_cast<std::size_t>(link[e].member)];
    slot = true;
  }
  Fans out;
  out.count = static_cast<std::size_t>(chains);
  // Chains in an order that does not depend on how neighbours are named (earlier merges rename
  // them): by their members, then by their smallest triangle as it came.
  std::vector<Triangle> firstTriangle(static_cast<std::size_t>(chains), Triangle{~VertexId{0}, 0, 0});
  for (std::size_t e = 0; e < link.size(); ++e) {
    Triangle& f = firstTriangle[static_cast<std::size_t>(chainOf[e])];
    f = std::min(f, link[e].triangle);
  }
  std::vector<std::size_t> order(static_cast<std::size_t>(chains));
  for (std::size_t c = 0; c < order.size(); ++c) order[c] = c;
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    if (inChain[x] != inChain[y])
      return std::lexicographical_compare(inChain[y].begin(), inChain[y].end(), inChain[x].begin(), inChain[x].end());
    return firstTriangle[x] < firstTriangle[y];
  });
  std::vector<bool> taken(n, false);
  std::vector<VertexId> chainVertex(static_cast<std::size_t>(chains));
  for (const std::size_t c : order) {
    std::size_t m = 0;
    while (m < n && (taken[m] || !inChain[c][m])) ++m;
    if (m == n) return std::nullopt;  // more fans than vertices to give them
    taken[m] = true;
    chainVertex[c] = cluster.members[m];
  }
  out.survivors.assign(n, cluster.members.front());
  for (std::size_t e = 0; e < link.size(); ++e) {
    const auto m = static_cast<std::size_t>(link[e].member);
    const VertexId v = chainVertex[static_cast<std::size_t>(chainOf[e])];
    if (memberChains[m] > 1) {
      out.corners.emplace_back(std::pair{link[e].triangle, cluster.members[m]}, v);
    }
    out.survivors[m] = v;
  }
  return out;
}

void DegenerateCollapseSink::emitFront() {
  MeshChunk out = std::move(pending_.front());
  pending_.pop_front();
  const bool labels = !out.faceLabels.empty();
  std::size_t kept = 0;
  for (std::size_t k = 0; k < out.triangles.size(); ++k) {
    const Triangle t = out.triangles[k];
    const auto m = mapped(t);
    if (!corners_.empty()) {
      for (const VertexId v : t) corners_.erase({t, v});
    }
    if (!m) {
      ++counts_.triangles;
      continue;
    }
    out.triangles[kept] = remap_ ? *m : t;
    if (labels) out.faceLabels[kept] = out.faceLabels[k];
    ++kept;
  }
  out.triangles.resize(kept);
  if (labels) out.faceLabels.resize(kept);
  next_.consume(out);
  // Later triangles use this chunk's vertices and newer ones only.
  merged_.erase(merged_.begin(), merged_.lower_bound(out.firstVertex));
}

}  // namespace isoslab
