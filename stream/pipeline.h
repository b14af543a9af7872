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

/// Runs the whole volume. The sink gets begin(header), a chunk per slab, and finish(). Throws
/// isoslab::Error from the source or the sink, or if the mesh exceeds 2^32 - 1 vertices.
PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options = {});

}  // namespace isoslab
