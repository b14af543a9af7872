// The driver: pulls slices from a source into the slab ring, hands each slab to the extractor and
// each resulting chunk to the sink. Single-threaded; memory is the ring (at most four slices), the
// extractor's per-slab caches and one chunk.
#pragma once

#include <cstdint>

#include "extract/extractor.h"
#include "extract/mesh_sink.h"
#include "io/slice_source.h"

namespace isoslab {

struct PipelineOptions {
  /// Show a progress line on stderr (only if stderr is a terminal and the run is long).
  bool progress = false;
  /// 1: everything on the calling thread. 2 or more: the source is read on a thread of its own
  /// and the sink consumes chunks on another, overlapping I/O, decoding, extraction and encoding
  /// through small bounded queues. The output is the same for every value.
  int threads = 1;
};

struct PipelineResult {
  double readSeconds = 0;
  double extractSeconds = 0;
  double writeSeconds = 0;
  double totalSeconds = 0;
  std::uint64_t vertices = 0;
  std::uint64_t triangles = 0;
  std::size_t ringBytes = 0;
};

/// Runs the whole volume. The sink gets begin(header), a chunk per slab in order, and finish(), all
/// from one thread (the calling one unless options.threads > 1). Throws
/// isoslab::Error from the source or the sink, or if the mesh exceeds 2^32 - 1 vertices.
PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options = {});

}  // namespace isoslab
