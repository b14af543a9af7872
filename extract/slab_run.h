// What every slab worker does with a run of slabs (Extractor::makeWorker): the first slab stands
// alone, naming the vertices that the slab below creates by their slots; the others follow it,
// carrying its caches, so that vertex ids run on over the run; the last slab's top vertices go to
// the stitcher. Internal to extract/.
#pragma once

#include <functional>
#include <span>

#include "extract/extractor.h"

namespace isoslab {

/// `Kernel` has resetVertexCount(), extractSlab(slab, chunk, foreign or nullptr), rollCaches() and
/// takeTop(top).
template <class Kernel>
void extractRun(Kernel& kernel, std::span<const SlabView> slabs, SlabPart& part,
                const std::function<void(const SlabView&)>& before) {
  part.chunks.resize(slabs.size());
  part.foreign.clear();
  part.top.clear();
  kernel.resetVertexCount();
  for (std::size_t k = 0; k < slabs.size(); ++k) {
    MeshChunk& chunk = part.chunks[k];
    chunk.clear();
    chunk.slab = slabs[k].z;
    chunk.firstVertex = 0;
    if (before) before(slabs[k]);
    kernel.extractSlab(slabs[k], chunk, k == 0 ? &part.foreign : nullptr);
    if (k + 1 < slabs.size()) kernel.rollCaches();
  }
  kernel.takeTop(part.top);
}

}  // namespace isoslab
