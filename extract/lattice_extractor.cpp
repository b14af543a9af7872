// The two drivers of the lattice kernel (lattice_kernel.h): the sequential extractor, whose slabs
// follow each other, and the slab worker, whose slabs stand alone for parallel extraction.
#include "extract/lattice_extractor.h"

#include "extract/lattice_kernel.h"
#include "extract/slab_run.h"

namespace isoslab {
namespace {

// A slab worker derives everything from its slab's own slices (nothing carries over from the slab
// before) and leaves the vertices on slice z, which the slab below creates, to the stitcher: the
// same cells are visited and the same vertices created in the same order as in the sequential
// extractor, so that stitched ids equal its ids.
class LatticeSlabWorker final : public SlabWorker {
 public:
  explicit LatticeSlabWorker(const LatticeKernel& like)
      : kernel_(like.options(), like.dims(), like.frame(), like.copyScheme()) {}

  // The first slab stands alone; the others follow it, carrying the caches and the row spans, so
  // that vertex ids run on over the whole run.
  void extract(std::span<const SlabView> slabs, SlabPart& part,
               const std::function<void(const SlabView&)>& before) override {
    extractRun(kernel_, slabs, part, before);
  }

 private:
  LatticeKernel kernel_;
};

class SequentialExtractor final : public Extractor {
 public:
  SequentialExtractor(const ExtractOptions& options, const std::array<std::int64_t, 3>& dims, const LatticeFrame& frame,
                      std::unique_ptr<CellScheme> scheme)
      : kernel_(options, dims, frame, std::move(scheme)) {}

  int slicesBelow() const noexcept override { return kernel_.options().normals ? 1 : 0; }
  int slicesAbove() const noexcept override { return (kernel_.options().normals || kernel_.needsCentres()) ? 1 : 0; }
  std::uint64_t vertexCount() const noexcept override { return kernel_.vertexCount(); }
  bool cellVolumes() const noexcept override { return kernel_.cellVolumes(); }
  std::size_t sliceSlots() const noexcept override { return kernel_.sliceSlots(); }
  void classifySlice(const float* slice, std::vector<RowSpan>& rows) const override {
    kernel_.classifySlice(slice, rows);
  }
  std::unique_ptr<SlabWorker> makeWorker() const override { return std::make_unique<LatticeSlabWorker>(kernel_); }

  void extractSlab(const SlabView& slab, MeshChunk& out) override {
    kernel_.extractSlab(slab, out, nullptr);
    kernel_.rollCaches();
  }

 private:
  LatticeKernel kernel_;
};

}  // namespace

std::unique_ptr<Extractor> makeLatticeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                                const LatticeFrame& frame, std::unique_ptr<CellScheme> scheme) {
  std::array<std::int64_t, 3> dims = info.dims;
  if (options.closeBoundary) {
    for (auto& d : dims) d += 2;
  }
  return std::make_unique<SequentialExtractor>(options, dims, frame, std::move(scheme));
}

}  // namespace isoslab
