// Connected components of a streamed mesh by union-find over the live front (see components.h).
// Union-find with path halving (Tarjan, "Efficiency of a good but not linear set union
// algorithm", 1975); the front is rebased after every chunk, so ids stay small and dense.
#include "metrics/components.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "core/error.h"
#include "core/interrupt.h"
#include "metrics/triangle_measure.h"

namespace isoslab {
namespace {

void extend(std::array<double, 6>& bounds, const Vec3f& p) {
  const double c[3] = {p.x, p.y, p.z};
  for (std::size_t a = 0; a < 3; ++a) {
    bounds[a] = std::min(bounds[a], c[a]);
    bounds[a + 3] = std::max(bounds[a + 3], c[a]);
  }
}

// Adds the measures of `from` to `into` (the records of two parts that a triangle joins).
void merge(Component& into, const Component& from) {
  into.firstVertex = std::min(into.firstVertex, from.firstVertex);
  into.triangles += from.triangles;
  into.area += from.area;
  into.volume += from.volume;
  for (std::size_t a = 0; a < 3; ++a) {
    into.bounds[a] = std::min(into.bounds[a], from.bounds[a]);
    into.bounds[a + 3] = std::max(into.bounds[a + 3], from.bounds[a + 3]);
  }
  into.boundaryEdges += from.boundaryEdges;
  into.interiorBoundaryEdges += from.interiorBoundaryEdges;
  into.nonManifoldEdges += from.nonManifoldEdges;
  into.seedDistance = std::min(into.seedDistance, from.seedDistance);
}

}  // namespace

void ComponentSink::begin(const MeshHeader&) {
  front_.reset();
  edges_.clear();
  frontFirst_ = 0;
  clearLive();
  chunks_ = 0;
  finished_.clear();
  summary_ = ComponentSummary{};
  firstVertices_.clear();
  peakLive_ = 0;
  partParent_.clear();
  partCount_ = 0;
  finishedSerial_.clear();
  partComponents_.clear();
  settledFirst_ = 0;
  settledParts_.clear();
}

void ComponentSink::clearLive() {
  parent_.clear();
  record_.clear();
  live_.clear();
  inUse_.clear();
  freeRecords_.clear();
  touched_.clear();
  serial_.clear();
  liveCount_ = 0;
}

std::uint32_t ComponentSink::rootPart(std::uint32_t serial) noexcept {
  while (partParent_[serial] != serial) {
    partParent_[serial] = partParent_[partParent_[serial]];
    serial = partParent_[serial];
  }
  return serial;
}

// The part serial of each vertex first .. end - 1, all of them in the front.
void ComponentSink::label(VertexId first, VertexId end) {
  settledFirst_ = first;
  settledParts_.clear();
  if (!labelVertices_) return;
  for (VertexId v = first; v < end; ++v) {
    const std::uint32_t r = record_[find(slotOf(v))];
    settledParts_.push_back(r == kNoRecord ? kNoPart : serial_[r]);
  }
}

std::uint32_t ComponentSink::find(std::uint32_t slot) noexcept {
  while (parent_[slot] != slot) {
    parent_[slot] = parent_[parent_[slot]];
    slot = parent_[slot];
  }
  return slot;
}

// Joins the parts rooted at a and b under a; their records, if both have one, merge into a's.
void ComponentSink::join(std::uint32_t a, std::uint32_t b) {
  if (a == b) return;
  parent_[b] = a;
  const std::uint32_t from = std::exchange(record_[b], kNoRecord);
  if (from == kNoRecord) return;
  if (record_[a] == kNoRecord) {
    record_[a] = from;
    return;
  }
  merge(live_[record_[a]], live_[from]);
  if (!labelVertices_ && !summarize_) partParent_[serial_[from]] = serial_[record_[a]];
  inUse_[from] = 0;
  freeRecords_.push_back(from);
  --liveCount_;
}

void ComponentSink::consume(const MeshChunk& chunk) {
  front_.advance(chunk);
  const VertexId previousFirst = front_.previousFirst();
  const VertexId currentFirst = front_.currentFirst();
  const VertexId currentEnd = front_.currentEnd();

  // The front gains the chunk's vertices, each a part of its own without a record.
  for (VertexId v = currentFirst; v < currentEnd; ++v) {
    parent_.push_back(slotOf(v));
    record_.push_back(kNoRecord);
  }

  // metrics hands over a whole mesh as one chunk.
  for (std::size_t n = 0; n < chunk.triangles.size(); ++n) {
    throwIfInterruptedEvery(n);
    const Triangle& t = chunk.triangles[n];
    for (VertexId v : t) {
      if (v < previousFirst || v >= currentEnd) {
        throw Error(
            fmt::format("slab {}: a triangle uses vertex {}, outside this chunk and the previous one", chunk.slab, v));
      }
    }
    const std::uint32_t root = find(slotOf(t[0]));
    join(root, find(slotOf(t[1])));
    join(root, find(slotOf(t[2])));
    const Vec3f& a = front_.position(t[0]);
    const Vec3f& b = front_.position(t[1]);
    const Vec3f& c = front_.position(t[2]);
    if (record_[root] == kNoRecord) {
      if (freeRecords_.empty()) {
        freeRecords_.push_back(static_cast<std::uint32_t>(live_.size()));
        live_.emplace_back();
        inUse_.push_back(0);
        touched_.push_back(0);
        serial_.push_back(0);
      }
      record_[root] = freeRecords_.back();
      freeRecords_.pop_back();
      Component& fresh = live_[record_[root]];
      fresh = Component{};
      fresh.firstVertex = t[0];
      fresh.bounds = {a.x, a.y, a.z, a.x, a.y, a.z};
      const std::uint32_t serial = partCount_;
      if (serial == kNoPart) throw Error("the mesh has more parts than component labels can count (2^32 - 1)");
      ++partCount_;
      if (!labelVertices_ && !summarize_) partParent_.push_back(serial);
      serial_[record_[root]] = serial;
      inUse_[record_[root]] = 1;
      ++liveCount_;
    }
    Component& part = live_[record_[root]];
    part.firstVertex = std::min({part.firstVertex, t[0], t[1], t[2]});
    if (!chunk.faceLabels.empty()) part.label = chunk.faceLabels[n][1];
    ++part.triangles;
    const TriangleMeasure m = measureTriangle(a, b, c);
    part.area += 0.5 * m.twiceArea;
    part.volume += m.volume;
    extend(part.bounds, a);
    extend(part.bounds, b);
    extend(part.bounds, c);
    if (seed_) {
      for (const Vec3f* p : {&a, &b, &c}) {
        const double dx = double{p->x} - seed_->x;
        const double dy = double{p->y} - seed_->y;
        const double dz = double{p->z} - seed_->z;
        part.seedDistance = std::min(part.seedDistance, dx * dx + dy * dy + dz * dz);  // squared until finish()
      }
    }
    for (std::size_t k = 0; k < 3; ++k) {
      const VertexId from = t[k];
      const VertexId to = t[(k + 1) % 3];
      edges_.add(from, to, (front_.boundary(from) & front_.boundary(to)) != 0, currentFirst);
    }
  }
  peakLive_ = std::max(peakLive_, liveCount_);
  // The previous chunk's edges are complete, and so is every part that this chunk did not reach.
  edges_.settle(previousFirst, currentFirst, [this](const EdgeTally::Edge& e) { settleEdge(e); });
  label(previousFirst, currentFirst);
  retire();
}

void ComponentSink::settleEdge(const EdgeTally::Edge& e) {
  const std::uint32_t r = record_[find(slotOf(e.lo))];
  assert(r != kNoRecord);
  Component& part = live_[r];
  if (e.uses == 1) {
    ++part.boundaryEdges;
    if (!e.onVolumeFace) ++part.interiorBoundaryEdges;
  } else if (e.uses > 2) {
    ++part.nonManifoldEdges;
  }
}

// Moves the components that the current chunk did not reach to the finished list, then drops the
// previous chunk from the front: each part still live gets a root among the current chunk's
// vertices (the first of them that it holds).
void ComponentSink::retire() {
  ++chunks_;
  const std::uint32_t offset = slotOf(front_.currentFirst());
  const auto count = static_cast<std::uint32_t>(parent_.size()) - offset;
  roots_.resize(count);
  for (std::uint32_t s = 0; s < count; ++s) {
    roots_[s] = find(offset + s);
    if (record_[roots_[s]] != kNoRecord) touched_[record_[roots_[s]]] = chunks_;
  }
  for (std::uint32_t r = 0; r < live_.size(); ++r) {
    if (inUse_[r] && touched_[r] != chunks_) {
      if (!labelVertices_) settle(r);
      inUse_[r] = 0;
      freeRecords_.push_back(r);
      --liveCount_;
    }
  }
  remap_.assign(offset, kNoRecord);
  nextParent_.resize(count);
  nextRecord_.assign(count, kNoRecord);
  for (std::uint32_t s = 0; s < count; ++s) {
    const std::uint32_t r = roots_[s];
    if (r >= offset) {
      nextParent_[s] = r - offset;
      if (r == offset + s) nextRecord_[s] = record_[r];
    } else if (remap_[r] == kNoRecord) {
      remap_[r] = s;
      nextParent_[s] = s;
      nextRecord_[s] = record_[r];
    } else {
      nextParent_[s] = remap_[r];
    }
  }
  std::swap(parent_, nextParent_);
  std::swap(record_, nextRecord_);
  frontFirst_ = front_.currentFirst();
}

void ComponentSink::settle(std::uint32_t r) {
  const Component& c = live_[r];
  if (!summarize_) {
    finished_.push_back(c);
    finishedSerial_.push_back(serial_[r]);
    return;
  }
  ++summary_.count;
  summary_.closed += c.closed() ? 1 : 0;
  firstVertices_.push_back(c.firstVertex);
  // The largest, in the order that the report lists them (firstVertex orders as the id does).
  const auto before = [](const Component& a, const Component& b) {
    return a.triangles != b.triangles ? a.triangles > b.triangles : a.firstVertex < b.firstVertex;
  };
  std::vector<Component>& largest = summary_.largest;
  const auto at = std::upper_bound(largest.begin(), largest.end(), c, before);
  if (static_cast<std::size_t>(at - largest.begin()) >= listed_) return;
  largest.insert(at, c);
  if (largest.size() > listed_) largest.pop_back();
}

void ComponentSink::finish() {
  edges_.settle(front_.currentFirst(), front_.currentEnd(), [this](const EdgeTally::Edge& e) { settleEdge(e); });
  label(front_.currentFirst(), front_.currentEnd());
  if (labelVertices_) {
    clearLive();
    return;
  }
  for (std::uint32_t r = 0; r < live_.size(); ++r) {
    if (inUse_[r]) settle(r);
  }
  if (summarize_) {
    // A component's id is its rank by first vertex (each vertex is in one component).
    std::sort(firstVertices_.begin(), firstVertices_.end());
    for (Component& c : summary_.largest) {
      c.id = static_cast<std::uint64_t>(std::lower_bound(firstVertices_.begin(), firstVertices_.end(), c.firstVertex) -
                                        firstVertices_.begin());
      if (seed_) c.seedDistance = std::sqrt(c.seedDistance);
    }
    firstVertices_ = {};
    partParent_ = {};
    clearLive();
    return;
  }
  // Sorts by firstVertex in place (the list can be long: a foam has hundreds of thousands), through
  // the permutation's cycles: position i receives the record at order[i].
  const auto n = static_cast<std::uint32_t>(finished_.size());
  std::vector<std::uint32_t> order(n);
  for (std::uint32_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return finished_[a].firstVertex < finished_[b].firstVertex; });
  std::vector<bool> placed(n, false);
  for (std::uint32_t i = 0; i < n; ++i) {
    if (placed[i]) continue;
    const Component first = finished_[i];
    const std::uint32_t firstSerial = finishedSerial_[i];
    for (std::uint32_t j = i;;) {
      placed[j] = true;
      const std::uint32_t k = order[j];
      if (k == i) {
        finished_[j] = first;
        finishedSerial_[j] = firstSerial;
        break;
      }
      finished_[j] = finished_[k];
      finishedSerial_[j] = finishedSerial_[k];
      j = k;
    }
  }
  partComponents_.assign(partParent_.size(), kNoPart);
  for (std::uint32_t id = 0; id < n; ++id) {
    Component& c = finished_[id];
    c.id = id;
    if (seed_) c.seedDistance = std::sqrt(c.seedDistance);
    partComponents_[finishedSerial_[id]] = id;
  }
  for (std::uint32_t s = 0; s < partComponents_.size(); ++s) partComponents_[s] = partComponents_[rootPart(s)];
  finishedSerial_ = {};
  partParent_ = {};
  clearLive();
}

}  // namespace isoslab
