// The driver: pulls slices from a source into the slab ring, hands each slab to the extractor (or
// to its workers) and each resulting chunk to the sink. Memory is the ring (at most four slices,
// plus N + 1 with N workers), a few slices queued by the reader, the extractors' per-slab caches
// (one set per worker) and a few chunks.
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "core/mesh_sink.h"
#include "extract/extractor.h"
#include "io/slice_source.h"

namespace isoslab {

struct PipelineOptions {
  /// Show a progress line on stderr (only if stderr is a terminal and the run is long).
  bool progress = false;
  /// 1: everything on the calling thread. N > 1: N extraction workers (each with a detached
  /// extractor; up to N + 2 slabs in flight, stitched in slab order), the source read on a thread
  /// of its own and the sink fed on another, through small bounded queues. The ring holds N + 1
  /// more slices.
  /// The output is the same for every value.
  int threads = 1;
};

struct PipelineResult {
  /// Time the driving thread waited for slices.
  double readSeconds = 0;
  /// Time spent extracting, summed over the workers (so it can exceed the wall time).
  double extractSeconds = 0;
  /// Time the driving thread spent handing chunks to the sink (waiting for it when it is slower).
  double writeSeconds = 0;
  double totalSeconds = 0;
  std::uint64_t vertices = 0;
  std::uint64_t triangles = 0;
  std::size_t ringBytes = 0;
  /// The smallest and largest value over every slice read (NaN is skipped); empty when no slice
  /// held a value that is not NaN. Tracked as the slices stream past, so the volume is never held.
  std::optional<std::array<double, 2>> valueRange;
};

/// Runs the whole volume. The sink gets begin(header), a chunk per slab in order, and finish(), all
/// from one thread (the calling one unless options.threads > 1). Throws
/// isoslab::Error from the source or the sink, or if the mesh exceeds 2^32 - 1 vertices.
PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options = {});

}  // namespace isoslab
