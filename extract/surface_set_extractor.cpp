#include "extract/surface_set_extractor.h"

#include <algorithm>

#include "extract/label_extractor.h"

namespace isoslab {
namespace {

// One surface of a set, or one layer's label complex.
struct Member {
  std::unique_ptr<Extractor> extractor;
  std::size_t offset = 0;  // where its values start in each slice (a layer's plane)
  int layer = -1;          // >= 0: a label complex, its labels of this layer; else one surface
  std::int32_t label = 0;  // a surface's label: every triangle is {0, label}
  std::size_t slots = 0;   // its first welding-cache slot among the set's
};

SlabView memberView(const SlabView& slab, const Member& m) {
  SlabView view = slab;
  view.rows = {};
  for (const float*& s : view.slices) {
    if (s != nullptr) s += m.offset;
  }
  return view;
}

// Appends `c`, a chunk of member `m`, to `out`: its vertices after those there, its triangles'
// ids through `id`, their sides named as the set names them.
template <class MapId>
void appendChunk(const Member& m, const MeshChunk& c, MeshChunk& out, const MapId& id) {
  out.positions.insert(out.positions.end(), c.positions.begin(), c.positions.end());
  out.normals.insert(out.normals.end(), c.normals.begin(), c.normals.end());
  out.boundary.insert(out.boundary.end(), c.boundary.begin(), c.boundary.end());
  out.triangles.reserve(out.triangles.size() + c.triangles.size());
  for (const Triangle& t : c.triangles) out.triangles.push_back(Triangle{id(t[0]), id(t[1]), id(t[2])});
  out.cellVolume += c.cellVolume;
  if (m.layer < 0) {
    out.faceLabels.insert(out.faceLabels.end(), c.triangles.size(), LabelPair{0, m.label});
    return;
  }
  const auto key = [&m](std::int32_t value) { return value == 0 ? 0 : layeredLabel(m.layer, value); };
  for (const LabelPair& p : c.faceLabels) out.faceLabels.push_back(LabelPair{key(p[0]), key(p[1])});
  for (const std::int32_t l : c.labelSplits) out.labelSplits.push_back(key(l));
  for (const std::int32_t l : c.labelPinches) out.labelPinches.push_back(key(l));
}

// The members' slab workers side by side, their parts joined as SurfaceSet::extractSlab joins
// chunks, so that stitching gives its ids.
class SetWorker final : public SlabWorker {
 public:
  SetWorker(const std::vector<Member>& members, std::vector<std::unique_ptr<SlabWorker>> workers)
      : members_(members), workers_(std::move(workers)), parts_(members.size()) {}

  void extract(std::span<const SlabView> slabs, SlabPart& out,
               const std::function<void(const SlabView&)>& before) override {
    if (before) {
      for (const SlabView& s : slabs) before(s);
    }
    const std::size_t n = slabs.size();
    const std::size_t count = members_.size();
    views_.resize(n);
    for (std::size_t k = 0; k < count; ++k) {
      for (std::size_t j = 0; j < n; ++j) views_[j] = memberView(slabs[j], members_[k]);
      workers_[k]->extract(views_, parts_[k], nullptr);
    }
    // Each member's first local id in each chunk, its own and the joined one.
    starts_.assign(count * n, 0);
    joined_.assign(count * n, 0);
    VertexId running = 0;
    for (std::size_t j = 0; j < n; ++j) {
      for (std::size_t k = 0; k < count; ++k) {
        const auto size = static_cast<VertexId>(parts_[k].chunks[j].positions.size());
        joined_[k * n + j] = running;
        running += size;
        if (j + 1 < n) starts_[k * n + j + 1] = starts_[k * n + j] + size;
      }
    }
    out.chunks.resize(n);
    for (std::size_t j = 0; j < n; ++j) {
      out.chunks[j].clear();
      out.chunks[j].slab = slabs[j].z;
    }
    out.foreign.clear();
    out.top.clear();
    for (std::size_t k = 0; k < count; ++k) {
      const Member& m = members_[k];
      SlabPart& part = parts_[k];
      const auto foreignBase = static_cast<VertexId>(out.foreign.size());
      for (const CacheSlot slot : part.foreign) {
        out.foreign.push_back(CacheSlot{static_cast<std::int64_t>(slot) + static_cast<std::int64_t>(m.slots)});
      }
      const VertexId* starts = starts_.data() + k * n;
      const VertexId* joined = joined_.data() + k * n;
      std::size_t j = 0;  // the chunk being joined: its own vertices are the usual case
      const auto id = [&](VertexId v) -> VertexId {
        if ((v & kForeignVertex) != 0) return kForeignVertex | (foreignBase + (v & ~kForeignVertex));
        std::size_t at = j;
        if (v < starts[at] || (at + 1 < n && v >= starts[at + 1])) {
          at = static_cast<std::size_t>(std::upper_bound(starts, starts + n, v) - starts) - 1;
        }
        return joined[at] + (v - starts[at]);
      };
      for (j = 0; j < n; ++j) appendChunk(m, part.chunks[j], out.chunks[j], id);
      j = n - 1;
      for (const auto& [slot, local] : part.top) {
        out.top.emplace_back(CacheSlot{static_cast<std::int64_t>(slot) + static_cast<std::int64_t>(m.slots)},
                             LocalVertex{id(static_cast<VertexId>(local))});
      }
    }
  }

 private:
  const std::vector<Member>& members_;
  std::vector<std::unique_ptr<SlabWorker>> workers_;
  std::vector<SlabPart> parts_;
  std::vector<SlabView> views_;
  std::vector<VertexId> starts_;  // [member][chunk]
  std::vector<VertexId> joined_;
};

class SurfaceSet final : public Extractor {
 public:
  explicit SurfaceSet(std::vector<Member> members) : members_(std::move(members)), states_(members_.size()) {
    std::size_t slots = 0;
    for (Member& m : members_) {
      m.slots = slots;
      slots += m.extractor->sliceSlots();
      below_ = std::max(below_, m.extractor->slicesBelow());
      above_ = std::max(above_, m.extractor->slicesAbove());
    }
    slots_ = slots;
  }

  int slicesBelow() const noexcept override { return below_; }
  int slicesAbove() const noexcept override { return above_; }
  std::uint64_t vertexCount() const noexcept override { return vertices_; }
  // Row spans differ by member: each member's kernel classifies its rows itself.
  void classifySlice(const float*, std::vector<RowSpan>& rows) const override { rows.clear(); }
  bool cellVolumes() const noexcept override { return false; }
  std::size_t sliceSlots() const noexcept override { return slots_; }

  std::unique_ptr<SlabWorker> makeWorker() const override {
    std::vector<std::unique_ptr<SlabWorker>> workers;
    for (const Member& m : members_) {
      workers.push_back(m.extractor->makeWorker());
      if (!workers.back()) return nullptr;
    }
    return std::make_unique<SetWorker>(members_, std::move(workers));
  }

  void extractSlab(const SlabView& slab, MeshChunk& out) override {
    for (std::size_t k = 0; k < members_.size(); ++k) {
      Member& m = members_[k];
      State& s = states_[k];
      MeshChunk& c = s.chunk;
      c.clear();
      c.slab = slab.z;
      c.firstVertex = static_cast<VertexId>(m.extractor->vertexCount());
      m.extractor->extractSlab(memberView(slab, m), c);
      // This member's vertices follow the ones before it in the joined chunk; its triangles reach
      // back only into its own previous chunk.
      const VertexId base = out.firstVertex + static_cast<VertexId>(out.positions.size());
      appendChunk(m, c, out, [&](VertexId v) {
        return v >= c.firstVertex ? base + (v - c.firstVertex) : s.previousBase + (v - s.previousFirst);
      });
      s.previousBase = base;
      s.previousFirst = c.firstVertex;
    }
    vertices_ = out.firstVertex + out.positions.size();
  }

 private:
  struct State {
    MeshChunk chunk;
    VertexId previousBase = 0;   // where its previous chunk's vertices lie in the joined ids
    VertexId previousFirst = 0;  // its own id of that chunk's first vertex
  };
  std::vector<Member> members_;
  std::vector<State> states_;
  std::size_t slots_ = 0;
  int below_ = 0;
  int above_ = 0;
  std::uint64_t vertices_ = 0;
};

}  // namespace

std::unique_ptr<Extractor> makeMultiIsoExtractor(const ExtractOptions& options, const std::vector<double>& isos,
                                                 const VolumeInfo& info, const LatticeFrame& frame) {
  std::vector<Member> members;
  for (std::size_t k = 0; k < isos.size(); ++k) {
    ExtractOptions o = options;
    o.iso = isos[k];
    Member m;
    m.extractor = makeExtractor(o, info, frame);
    m.label = static_cast<std::int32_t>(k + 1);
    members.push_back(std::move(m));
  }
  return std::make_unique<SurfaceSet>(std::move(members));
}

std::unique_ptr<Extractor> makeLayeredLabelExtractor(const VolumeInfo& info, const LatticeFrame& frame) {
  if (info.layers <= 1) return makeLabelExtractor(info, frame);
  const auto plane = static_cast<std::size_t>((info.dims[0] + 2) * (info.dims[1] + 2));
  std::vector<Member> members;
  for (int layer = 0; layer < info.layers; ++layer) {
    Member m;
    m.extractor = makeLabelExtractor(info, frame);
    m.offset = static_cast<std::size_t>(layer) * plane;
    m.layer = layer;
    members.push_back(std::move(m));
  }
  return std::make_unique<SurfaceSet>(std::move(members));
}

}  // namespace isoslab
