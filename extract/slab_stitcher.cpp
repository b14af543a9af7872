#include "extract/slab_stitcher.h"

#include <limits>
#include <string>

#include "core/error.h"

namespace isoslab {
namespace {
constexpr VertexId kUnset = ZeroedIds::kUnset;
std::size_t index(CacheSlot slot) noexcept {
  return static_cast<std::size_t>(slot);
}
}  // namespace

SlabStitcher::SlabStitcher(std::size_t sliceSlots) : top_(sliceSlots) {}

void SlabStitcher::stitch(SlabPart& part) {
  if (part.chunks.empty()) throw Error("internal error: an empty run of slabs");
  if (part.chunks.front().slab != slab_) {
    throw Error("internal error: slab " + std::to_string(part.chunks.front().slab) + " stitched after slab " +
                std::to_string(slab_ - 1));
  }
  std::uint64_t count = 0;
  for (const MeshChunk& chunk : part.chunks) count += chunk.positions.size();
  if (count >= kForeignVertex || next_ + count > std::numeric_limits<VertexId>::max()) {
    throw Error("the mesh exceeds " + std::to_string(std::numeric_limits<VertexId>::max()) + " vertices");
  }
  const auto first = static_cast<VertexId>(next_);
  resolved_.resize(part.foreign.size());
  for (std::size_t k = 0; k < part.foreign.size(); ++k) {
    const VertexId id = top_.get(index(part.foreign[k]));
    if (id == kUnset) {
      throw Error("internal error: slab " + std::to_string(slab_) + " references a vertex that slab " +
                  std::to_string(slab_ - 1) + " did not create");
    }
    resolved_[k] = id;
  }
  VertexId chunkFirst = first;
  for (MeshChunk& chunk : part.chunks) {
    for (Triangle& t : chunk.triangles) {
      for (VertexId& v : t) v = (v & kForeignVertex) ? resolved_[v & ~kForeignVertex] : first + v;
    }
    chunk.firstVertex = chunkFirst;
    chunkFirst += static_cast<VertexId>(chunk.positions.size());
  }
  for (CacheSlot slot : set_) top_.unset(index(slot));
  set_.clear();
  for (const auto& [slot, local] : part.top) {
    top_.set(index(slot), first + static_cast<VertexId>(local));
    set_.push_back(slot);
  }
  slab_ += static_cast<std::int64_t>(part.chunks.size());
  next_ += count;
}

}  // namespace isoslab
