// The last two chunks of a mesh stream, as the measuring sinks need them: positions and volume-face
// flags by vertex id, and the ids' ranges. advance() checks that chunks continue the vertex ids.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/mesh_sink.h"

namespace isoslab {

class ChunkFront {
 public:
  void reset() { *this = ChunkFront{}; }

  /// The chunk becomes the current one. Throws isoslab::Error when its ids do not start where the
  /// previous chunk's ended.
  void advance(const MeshChunk& chunk) {
    if (chunk.firstVertex != currentEnd_) {
      throw Error("slab " + std::to_string(chunk.slab) + ": the chunk's vertices start at id " +
                  std::to_string(chunk.firstVertex) + ", not at " + std::to_string(currentEnd_) +
                  " where the previous chunk's ended");
    }
    window_.push(chunk);
    std::swap(previousBoundary_, currentBoundary_);
    currentBoundary_ = chunk.boundary;
    previousFirst_ = currentFirst_;
    currentFirst_ = chunk.firstVertex;
    currentEnd_ = chunk.endVertex();
  }

  const Vec3f& position(VertexId v) const noexcept { return window_.position(v); }
  /// The vertex's BoundaryFace bits (0 when the chunk carries none).
  std::uint8_t boundary(VertexId v) const noexcept {
    if (v >= currentFirst_) return currentBoundary_.empty() ? 0 : currentBoundary_[v - currentFirst_];
    return previousBoundary_.empty() ? 0 : previousBoundary_[v - previousFirst_];
  }
  VertexId previousFirst() const noexcept { return previousFirst_; }
  VertexId currentFirst() const noexcept { return currentFirst_; }
  VertexId currentEnd() const noexcept { return currentEnd_; }

 private:
  VertexWindow window_;
  std::vector<std::uint8_t> previousBoundary_, currentBoundary_;
  VertexId previousFirst_ = 0, currentFirst_ = 0, currentEnd_ = 0;
};

}  // namespace isoslab
