#include "process/label_surfaces.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "core/error.h"
#include "core/volume_info.h"

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

LabelSplitSink::LabelSplitSink(SinkFor sinkFor, bool perLabel, bool topology, bool measures)
    : sinkFor_(std::move(sinkFor)), perLabel_(perLabel), topology_(perLabel && topology), measures_(measures) {}

void LabelSplitSink::begin(const MeshHeader& header) {
  header_ = header;
  header_.labels = false;
}

std::uint32_t LabelSplitSink::streamOf(std::int32_t label) {
  std::uint32_t* entry = nullptr;
  if (label >= 0 && label < kDirectLabels) {
    if (direct_.empty()) direct_ = ZeroedArray<std::uint32_t>(kDirectLabels);
    entry = &direct_[static_cast<std::size_t>(label)];
  } else {
    entry = &index_.try_emplace(label, 0).first->second;
  }
  if (*entry == 0) {
    *entry = kNoStream;
    MeshSink* sink = sinkFor_(label);
    if (sink != nullptr) {
      *entry = static_cast<std::uint32_t>(streams_.size()) + 1;
      Stream& s = streams_.emplace_back();
      s.label = label;
      s.sink = sink;
      MeshHeader h = header_;
      h.iso = labelValue(label);  // a layered label (core/volume_info.h) as its value
      if (label >= 1 && static_cast<std::size_t>(label) <= isos_.size())
        h.iso = isos_[static_cast<std::size_t>(label) - 1];
      sink->begin(h);
    }
  }
  return *entry == kNoStream ? kNoStream : *entry - 1;
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
  scratch_.positions.push_back(p);
  scratch_.boundary.push_back(here ? chunk.boundary[v - chunk.firstVertex] : previousBoundary_[v - previous_.first]);
  Measures& m = s.measures;
  const std::array<double, 3> c{p.x, p.y, p.z};
  for (std::size_t a = 0; a < 3; ++a) {
    if (m.vertices == 0 || c[a] < m.bounds[a]) m.bounds[a] = c[a];
    if (m.vertices == 0 || c[a] > m.bounds[a + 3]) m.bounds[a + 3] = c[a];
  }
  ++m.vertices;
  return id;
}

// Each label's triangles, counted by runs of equal sides (a quad's two triangles, a row of faces).
void LabelSplitSink::countTriangles(const MeshChunk& chunk) {
  for (std::size_t t = 0; t < chunk.triangles.size();) {
    const LabelPair sides = chunk.faceLabels[t];
    std::size_t end = t + 1;
    while (end < chunk.triangles.size() && chunk.faceLabels[end][0] == sides[0] &&
           chunk.faceLabels[end][1] == sides[1]) {
      ++end;
    }
    for (const std::int32_t label : sides) {
      if (label == 0) continue;
      const std::uint32_t k = streamOf(label);
      if (k != kNoStream) streams_[k].measures.triangles += end - t;
    }
    t = end;
  }
}

void LabelSplitSink::consume(const MeshChunk& chunk) {
  if (perLabel_) {
    std::swap(previous_, current_);
    current_.first = chunk.firstVertex;
    current_.head.assign(chunk.positions.size(), 0);
    current_.uses.clear();
  }
  for (std::int32_t l : chunk.labelSplits) ++splits_[l];
  for (std::int32_t l : chunk.labelPinches) ++pinches_[l];
  // First the measures and each side's stream; then each touched stream's chunk in turn, built in
  // one scratch chunk, so that a label costs no buffer of its own.
  std::pair<std::int32_t, std::int32_t> lastPair{0, 0};
  Interface* lastInterface = nullptr;
  sides_.clear();
  // Without per-label chunks or measures, only each label's triangles are counted.
  if (!perLabel_ && !measures_) countTriangles(chunk);
  const std::size_t walked = perLabel_ || measures_ ? chunk.triangles.size() : 0;
  for (std::size_t t = 0; t < walked; ++t) {
    const Triangle& tri = chunk.triangles[t];
    const LabelPair sides = chunk.faceLabels[t];
    double area = 0, volume = 0;
    if (measures_) {
      const std::pair<std::int32_t, std::int32_t> key = std::minmax(sides[0], sides[1]);
      if (lastInterface == nullptr || key != lastPair) {
        lastInterface = &interfaces_[key];
        lastPair = key;
      }
      const auto position = [&](VertexId v) -> const Vec3f& {
        return v >= chunk.firstVertex ? chunk.positions[v - chunk.firstVertex]
                                      : previousPositions_[v - previous_.first];
      };
      std::tie(area, volume) = measure(position(tri[0]), position(tri[1]), position(tri[2]));
      ++lastInterface->triangles;
      lastInterface->area += area;
    }
    std::array<std::uint32_t, 2> streams{kNoStream, kNoStream};
    for (std::uint32_t side = 0; side < 2; ++side) {
      const std::int32_t label = sides[side];
      if (label == 0) continue;
      const std::uint32_t k = streamOf(label);
      streams[side] = k;
      if (k == kNoStream) continue;
      Stream& s = streams_[k];
      if (perLabel_) {
        if (s.pending++ == 0) touched_.push_back(k);
        sides_.push_back({k, static_cast<std::uint32_t>(t) << 1 | side});
      }
      ++s.measures.triangles;
      s.measures.area += area;
      s.measures.volume += side == 1 ? volume : -volume;
    }
    if (topology_ && (streams[0] != kNoStream || streams[1] != kNoStream)) tally(streams, tri);
  }
  // The sides by stream (a counting sort over the touched streams, in order).
  std::sort(touched_.begin(), touched_.end());
  std::uint32_t offset = 0;
  for (std::uint32_t k : touched_) {
    const std::uint32_t n = streams_[k].pending;
    streams_[k].pending = offset;
    offset += n;
  }
  ordered_.resize(sides_.size());
  for (const auto& [k, ts] : sides_) ordered_[streams_[k].pending++] = ts;
  std::uint32_t at = 0;
  for (std::uint32_t k : touched_) {
    Stream& s = streams_[k];
    scratch_.clear();
    scratch_.slab = chunk.slab;
    scratch_.firstVertex = s.next;
    for (; at < s.pending; ++at) {
      const std::uint32_t t = ordered_[at] >> 1;
      const bool back = (ordered_[at] & 1) != 0;
      const Triangle& tri = chunk.triangles[t];
      const VertexId a = idFor(k, tri[0], chunk);
      const VertexId b = idFor(k, tri[1], chunk);
      const VertexId c = idFor(k, tri[2], chunk);
      // The back label's face as it is; the front label's reversed.
      scratch_.triangles.push_back(back ? Triangle{a, b, c} : Triangle{a, c, b});
    }
    s.pending = 0;
    s.sink->consume(scratch_);
  }
  touched_.clear();
  if (topology_) settle(chunk.firstVertex);
  if (!perLabel_) previous_.first = chunk.firstVertex;  // the window of the chunk just consumed
  if (perLabel_ || measures_) {  // what the next chunk's triangles may read of this one's vertices
    previousPositions_ = chunk.positions;
    previousBoundary_ = chunk.boundary;
  }
}

// Each edge use of a complex triangle (in complex ids, which map one to one to each label's), with
// the streams of its two sides, for the labels' topology: an edge is settled once its lower end's
// chunk is behind the stream. The back side keeps the triangle's direction, the front reverses it.
void LabelSplitSink::tally(const std::array<std::uint32_t, 2>& streams, const Triangle& t) {
  for (std::size_t e = 0; e < 3; ++e) {
    const VertexId a = t[e], b = t[(e + 1) % 3];
    edgeUses_.push_back(
        EdgeUse{std::min(a, b), std::max(a, b), (streams[0] + 1) | (a < b ? 1u << 31 : 0u), streams[1] + 1});
  }
}

void LabelSplitSink::settle(VertexId before) {
  // The uses whose lower end lies before `before` are complete: moved, bucketed by their lower end
  // (a counting sort over the lower ends' range), into settling_; the others stay, in order.
  VertexId low = before, high = 0;
  std::size_t complete = 0;
  for (const EdgeUse& u : edgeUses_) {
    if (u.lo < before) {
      low = std::min(low, u.lo);
      high = std::max(high, u.lo);
      ++complete;
    }
  }
  if (complete == 0) return;
  offsets_.assign(static_cast<std::size_t>(high - low) + 2, 0);
  for (const EdgeUse& u : edgeUses_) {
    if (u.lo < before) ++offsets_[u.lo - low + 1];
  }
  for (std::size_t k = 1; k < offsets_.size(); ++k) offsets_[k] += offsets_[k - 1];
  settling_.resize(complete);
  std::size_t kept = 0;
  for (const EdgeUse& u : edgeUses_) {
    if (u.lo < before) {
      settling_[offsets_[u.lo - low]++] = u;
    } else {
      edgeUses_[kept++] = u;
    }
  }
  edgeUses_.resize(kept);
  // Each bucket holds one vertex's few edge uses: an insertion sort by hi, then per edge the uses
  // of each label (a stream on either side) and how many run forward in that label's surface.
  struct LabelUses {
    std::uint32_t stream;
    int uses, forward;
  };
  std::array<LabelUses, 16> labels{};
  for (std::size_t first = 0; first < settling_.size();) {
    std::size_t last = first + 1;
    while (last < settling_.size() && settling_[last].lo == settling_[first].lo) ++last;
    for (std::size_t k = first + 1; k < last; ++k) {
      const EdgeUse u = settling_[k];
      std::size_t m = k;
      for (; m > first && u.hi < settling_[m - 1].hi; --m) settling_[m] = settling_[m - 1];
      settling_[m] = u;
    }
    for (std::size_t k = first; k < last;) {
      std::size_t n = 0;
      std::size_t end = k;
      for (; end < last && settling_[end].hi == settling_[k].hi; ++end) {
        const EdgeUse& u = settling_[end];
        for (std::uint32_t side = 0; side < 2; ++side) {
          const std::uint32_t stream = (side == 0 ? u.frontForward & ~(1u << 31) : u.back) - 1;
          if (stream == kNoStream) continue;
          std::size_t at = 0;
          while (at < n && labels[at].stream != stream) ++at;
          if (at == n) {
            if (n == labels.size()) throw Error("an edge of the label complex has more than 16 labels around it");
            labels[n++] = LabelUses{stream, 0, 0};
          }
          ++labels[at].uses;
          labels[at].forward += ((u.frontForward >> 31) != 0) == (side == 1) ? 1 : 0;
        }
      }
      for (std::size_t at = 0; at < n; ++at) {
        Topology& t = streams_[labels[at].stream].topology;
        ++t.edges;
        if (labels[at].uses == 1) ++t.boundaryEdges;
        if (labels[at].uses > 2) ++t.nonManifoldEdges;
        if (labels[at].uses == 2 && labels[at].forward != 1) ++t.inconsistentEdges;
      }
      k = end;
    }
    first = last;
  }
}

void LabelSplitSink::finish() {
  settle(std::numeric_limits<VertexId>::max());
  std::vector<std::uint32_t> order(streams_.size());
  for (std::uint32_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](auto a, auto b) { return streams_[a].label < streams_[b].label; });
  for (std::uint32_t k : order) streams_[k].sink->finish();
}

std::map<std::int32_t, LabelSplitSink::Measures> LabelSplitSink::measures() const {
  std::map<std::int32_t, Measures> out;
  for (const Stream& s : streams_) {
    Measures m = s.measures;
    m.topology = s.topology;
    m.topology.euler = static_cast<std::int64_t>(m.vertices) - static_cast<std::int64_t>(m.topology.edges) +
                       static_cast<std::int64_t>(m.triangles);
    out[s.label] = m;
  }
  return out;
}

std::vector<std::int32_t> LabelSplitSink::labels() const {
  std::vector<std::int32_t> out;
  for (const Stream& s : streams_) out.push_back(s.label);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace isoslab
