// Picks a mesh writer by the output's extension.
#pragma once

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/mesh_sink.h"

namespace isoslab {

/// A writer whose bytes() can be asked after finish().
class MeshFileSink : public MeshSink {
 public:
  virtual std::int64_t bytes() const noexcept = 0;
  /// Format-specific numbers for the report (for Draco: chunks, encode seconds, ...), after finish().
  virtual std::vector<std::pair<std::string, double>> details() const { return {}; }
};

struct WriterOptions {
  /// Draco: compression level 0 (fastest) .. 10 (smallest).
  int dracoLevel = 7;
  /// Draco: bits per position component; 0 picks the smallest whose step is at most 1/64 voxel.
  int quantBits = 0;
  /// .glb: a chunk closes at the first slab boundary after it holds this many triangles.
  std::int64_t chunkTriangles = 1 << 19;
  /// .glb: chunks encoded at the same time on threads of their own, while the writer gathers the
  /// next one; 0 encodes on the thread that consumes the chunks. Each holds one chunk's encoder memory.
  int encodeThreads = 0;
  /// The smallest voxel edge in output units, for the default quantization.
  double voxelSize = 1;
  /// .glb: Draco-compressed chunks (KHR_draco_mesh_compression), or plain accessors.
  bool draco = true;
  /// .glb: a root node maps the output space to glTF's frame (Y up, metres, front +Z); false
  /// keeps the raw output frame (positions as written, no node transform).
  bool gltfFrame = true;
  /// .glb with Draco: seam keys (_ISOSLAB_SEAM) on the vertices that chunks share. Without them a
  /// decoder can only weld by position, which is ambiguous; false is for measuring their cost.
  bool seamKeys = true;
};

/// .ply, .stl, .obj, .glb (chunked Draco in glTF 2.0), .drc (one Draco mesh) or .3mf, by extension
/// (case-insensitive). Throws isoslab::Error for any other extension.
std::unique_ptr<MeshFileSink> makeMeshWriter(const std::string& path, const WriterOptions& options = {});

}  // namespace isoslab
