#include "process/label_surfaces.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace isoslab {
namespace {
constexpr std::uint32_t kNoStream = std::numeric_limits<std::uint32_t>::max();

// A triangle's area and its signed volume term (the tetrahedron to the origin), in double.
std::pair<double, double> measure(const Vec3f& a, const Vec3f& b, const Vec3f& c) noexcept {
  const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
  const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
  const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  const double volume =
      (double(a.x) * (double(b.y) * c.z - double(b.z) * c.y) - double(a.y) * (double(b.x) * c.z - double(b.z) * c.x) +
       double(a.z) * (double(b.x) * c.y - double(b.y) * c.x)) /
      6.0;
  return {0.5 * std::sqrt(nx * nx + ny * ny + nz * nz), volume};
}
}  // namespace

LabelSplitSink::LabelSplitSink(SinkFor sinkFor) : sinkFor_(std::move(sinkFor)) {}

void LabelSplitSink::begin(const MeshHeader& header) {
  header_ = header;
  header_.labels = false;
}

std::uint32_t LabelSplitSink::streamOf(std::int32_t label) {
  const auto [it, inserted] = index_.try_emplace(label, kNoStream);
  if (inserted) {
    MeshSink* sink = sinkFor_(label);
    if (sink != nullptr) {
      it->second = static_cast<std::uint32_t>(streams_.size());
      Stream& s = streams_.emplace_back();
      s.label = label;
      s.sink = sink;
      MeshHeader h = header_;
      h.iso = label;
      sink->begin(h);
    }
  }
  return it->second;
}

VertexId LabelSplitSink::idFor(std::uint32_t stream, VertexId v, const MeshChunk& chunk) {
  Window& w = v >= current_.first ? current_ : previous_;
  std::uint32_t* link = &w.head[v - w.first];
  while (*link != 0) {
    Use& u = w.uses[*link - 1];
    if (u.stream == stream) return u.id;
    link = &u.next;
  }
  Stream& s = streams_[stream];
  const VertexId id = s.next++;
  *link = static_cast<std::uint32_t>(w.uses.size()) + 1;
  w.uses.push_back(Use{stream, id, 0});
  // The position from the window's chunk: the current one, or the previous (kept in previous_).
  const bool here = v >= chunk.firstVertex;
  const Vec3f& p = here ? chunk.positions[v - chunk.firstVertex] : previousPositions_[v - previous_.first];
  s.chunk.positions.push_back(p);
  Measures& m = s.measures;
  const std::array<double, 3> c{p.x, p.y, p.z};
  for (std::size_t a = 0; a < 3; ++a) {
    if (m.vertices == 0 || c[a] < m.bounds[a]) m.bounds[a] = c[a];
    if (m.vertices == 0 || c[a] > m.bounds[a + 3]) m.bounds[a + 3] = c[a];
  }
  ++m.vertices;
  s.chunk.boundary.push_back(here ? chunk.boundary[v - chunk.firstVertex] : previousBoundary_[v - previous_.first]);
  return id;
}

void LabelSplitSink::consume(const MeshChunk& chunk) {
  std::swap(previous_, current_);
  current_.first = chunk.firstVertex;
  current_.head.assign(chunk.positions.size(), 0);
  current_.uses.clear();
  for (std::int32_t l : chunk.labelSplits) ++splits_[l];
  for (std::int32_t l : chunk.labelPinches) ++pinches_[l];
  std::pair<std::int32_t, std::int32_t> lastPair{0, 0};
  Interface* lastInterface = nullptr;
  for (std::size_t t = 0; t < chunk.triangles.size(); ++t) {
    const Triangle& tri = chunk.triangles[t];
    const LabelPair sides = chunk.faceLabels[t];
    const std::pair<std::int32_t, std::int32_t> key = std::minmax(sides[0], sides[1]);
    if (lastInterface == nullptr || key != lastPair) {
      lastInterface = &interfaces_[key];
      lastPair = key;
    }
    const auto position = [&](VertexId v) -> const Vec3f& {
      return v >= chunk.firstVertex ? chunk.positions[v - chunk.firstVertex] : previousPositions_[v - previous_.first];
    };
    const auto [area, volume] = measure(position(tri[0]), position(tri[1]), position(tri[2]));
    ++lastInterface->triangles;
    lastInterface->area += area;
    for (int side = 0; side < 2; ++side) {
      const std::int32_t label = sides[static_cast<std::size_t>(side)];
      if (label == 0) continue;
      const std::uint32_t k = streamOf(label);
      if (k == kNoStream) continue;
      Stream& s = streams_[k];
      if (!s.touched) {
        s.touched = true;
        s.chunk.clear();
        s.chunk.slab = chunk.slab;
        s.chunk.firstVertex = s.next;
        touched_.push_back(k);
      }
      const VertexId a = idFor(k, tri[0], chunk);
      const VertexId b = idFor(k, tri[1], chunk);
      const VertexId c = idFor(k, tri[2], chunk);
      // The back label's face as it is; the front label's reversed.
      s.chunk.triangles.push_back(side == 1 ? Triangle{a, b, c} : Triangle{a, c, b});
      ++s.measures.triangles;
      s.measures.area += area;
      s.measures.volume += side == 1 ? volume : -volume;
    }
  }
  std::sort(touched_.begin(), touched_.end());
  for (std::uint32_t k : touched_) {
    Stream& s = streams_[k];
    s.touched = false;
    s.sink->consume(s.chunk);
  }
  touched_.clear();
  previousPositions_ = chunk.positions;
  previousBoundary_ = chunk.boundary;
}

void LabelSplitSink::finish() {
  std::vector<std::uint32_t> order(streams_.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return streams_[a].label < streams_[b].label; });
  for (std::uint32_t k : order) streams_[k].sink->finish();
}

std::map<std::int32_t, LabelSplitSink::Measures> LabelSplitSink::measures() const {
  std::map<std::int32_t, Measures> out;
  for (const Stream& s : streams_) out[s.label] = s.measures;
  return out;
}

std::vector<std::int32_t> LabelSplitSink::labels() const {
  std::vector<std::int32_t> out;
  for (const Stream& s : streams_) out.push_back(s.label);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace isoslab
