#include "extract/multi_iso_extractor.h"

#include <algorithm>

namespace isoslab {
namespace {

class MultiIsoExtractor final : public Extractor {
 public:
  MultiIsoExtractor(const ExtractOptions& options, const std::vector<double>& isos, const VolumeInfo& info,
                    const LatticeFrame& frame) {
    for (double iso : isos) {
      ExtractOptions o = options;
      o.iso = iso;
      surfaces_.push_back(Surface{makeExtractor(o, info, frame), {}, 0, 0});
    }
  }

  int slicesBelow() const noexcept override {
    int n = 0;
    for (const Surface& s : surfaces_) n = std::max(n, s.extractor->slicesBelow());
    return n;
  }
  int slicesAbove() const noexcept override {
    int n = 0;
    for (const Surface& s : surfaces_) n = std::max(n, s.extractor->slicesAbove());
    return n;
  }
  std::uint64_t vertexCount() const noexcept override { return vertices_; }
  // Row spans depend on the value: each surface's kernel classifies the rows itself.
  void classifySlice(const float*, std::vector<RowSpan>& rows) const override { rows.clear(); }
  bool cellVolumes() const noexcept override { return false; }
  std::unique_ptr<SlabWorker> makeWorker() const override { return nullptr; }
  std::size_t sliceSlots() const noexcept override { return 0; }

  void extractSlab(const SlabView& slab, MeshChunk& out) override {
    SlabView view = slab;
    view.rows = {};
    for (std::size_t k = 0; k < surfaces_.size(); ++k) {
      Surface& s = surfaces_[k];
      MeshChunk& c = s.chunk;
      c.clear();
      c.slab = slab.z;
      c.firstVertex = static_cast<VertexId>(s.extractor->vertexCount());
      s.extractor->extractSlab(view, c);
      // This surface's vertices follow the ones before it in the joined chunk.
      const VertexId base = out.firstVertex + static_cast<VertexId>(out.positions.size());
      out.positions.insert(out.positions.end(), c.positions.begin(), c.positions.end());
      out.normals.insert(out.normals.end(), c.normals.begin(), c.normals.end());
      out.boundary.insert(out.boundary.end(), c.boundary.begin(), c.boundary.end());
      for (const Triangle& t : c.triangles) {
        Triangle joined{};
        for (std::size_t v = 0; v < 3; ++v) {
          joined[v] = t[v] >= c.firstVertex ? base + (t[v] - c.firstVertex) : s.previousBase + (t[v] - s.previousFirst);
        }
        out.triangles.push_back(joined);
        out.faceLabels.push_back({0, static_cast<std::int32_t>(k + 1)});
      }
      s.previousBase = base;
      s.previousFirst = c.firstVertex;
    }
    vertices_ = out.firstVertex + out.positions.size();
  }

 private:
  struct Surface {
    std::unique_ptr<Extractor> extractor;
    MeshChunk chunk;
    VertexId previousBase = 0;   // where its previous chunk's vertices lie in the joined ids
    VertexId previousFirst = 0;  // its own id of that chunk's first vertex
  };
  std::vector<Surface> surfaces_;
  std::uint64_t vertices_ = 0;
};

}  // namespace

std::unique_ptr<Extractor> makeMultiIsoExtractor(const ExtractOptions& options, const std::vector<double>& isos,
                                                 const VolumeInfo& info, const LatticeFrame& frame) {
  return std::make_unique<MultiIsoExtractor>(options, isos, info, frame);
}

}  // namespace isoslab
