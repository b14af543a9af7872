// Joins the parts that detached workers extract (Extractor::makeWorker) into the chunks the
// sequential extractor would have produced: same vertex ids, same order, same bytes. Parts must
// come in slab order. Memory: one welding-cache plane of ids, whatever the number of workers.
#pragma once

#include <cstdint>
#include <vector>

#include "extract/extractor.h"
#include "extract/welding_cache.h"

namespace isoslab {

class SlabStitcher {
 public:
  explicit SlabStitcher(std::size_t sliceSlots);

  /// Gives the chunks of `part`, the next run of slabs, their firstVertex and global ids. Throws isoslab::Error if the
  /// mesh would exceed 2^32 - 1 vertices, or (an internal error) if a reference cannot be resolved.
  void stitch(SlabPart& part);

  std::uint64_t vertexCount() const noexcept { return next_; }

 private:
  ZeroedIds top_;               // global ids of the last slab's vertices on its slice z + 1 (mapped as used)
  std::vector<CacheSlot> set_;  // slots of top_ in use
  std::vector<VertexId> resolved_;
  std::uint64_t next_ = 0;
  std::int64_t slab_ = 0;
};

}  // namespace isoslab
