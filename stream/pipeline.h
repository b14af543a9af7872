// The driver: pulls slices from a source into the slab ring, hands each slab to the extractor (or
// runs of consecutive slabs to its workers) and each resulting chunk to the sink. Memory is the
// ring (at most four slices, plus the slabs of the runs in flight with workers), a few slices
// queued by the reader, the extractors' per-slab caches (one set per worker) and a few chunks.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/mesh_sink.h"
#include "extract/extractor.h"
#include "io/slice_source.h"

namespace isoslab {

class RankGroup;

struct PipelineOptions {
  /// Show a progress line on stderr (only if stderr is a terminal and the run is long).
  bool progress = false;
  /// Called after each slab's chunk went to the sink, on the thread that feeds it, with the slabs
  /// done and their total (on rank 0 alone under ranks). It may throw (Interrupted) to stop the
  /// run, which then unwinds as for a failing sink.
  std::function<void(std::int64_t done, std::int64_t total)> onSlab;
  /// 1: everything on the calling thread. N > 1: up to N extraction workers (planThreads), each
  /// with a detached extractor taking runs of consecutive slabs, stitched in slab order; the
  /// source is read on a thread of its own and the sink fed on another, through small bounded
  /// queues. The output is the same for every value.
  int threads = 1;
  /// With threads > 1, the most bytes that threads may add to what one thread holds: the slices
  /// of the runs in flight (nothing when the source lends them), each extra worker's welding
  /// caches and the stitcher's slots. It shortens the runs, then takes workers away; 0: no cap.
  std::size_t maxThreadBytes = 0;
  /// The cost model (planThreads). Volumes of fewer voxels are extracted on one thread, as threads
  /// would cost more than they save (bench/peers.py measures the crossover).
  std::int64_t sequentialVoxels = std::int64_t{1} << 24;
  /// A run is long enough to hold about this many voxels (a few milliseconds of extraction), so
  /// that handing it over costs little against extracting it.
  std::int64_t runVoxels = std::int64_t{1} << 20;
  /// Runs shorten (down to one slab) where the slabs hold so many triangles that a run would hold
  /// more than this many: the runs in flight keep their chunks' buffers, so this bounds their
  /// memory on dense surfaces (foams). The output does not depend on it.
  std::int64_t runTriangles = std::int64_t{1} << 17;
  /// Processes that share the run (stream/rank_group.h; not owned): with more than one, each rank
  /// extracts its range of slabs (rankSlabs) with its own threads, and rank 0 stitches them and
  /// feeds `sink`; the other ranks' sinks get nothing. Every rank calls runPipeline() with the
  /// same source and options. The output is the same for every number of ranks.
  RankGroup* ranks = nullptr;
  /// With ranks: what each rank but 0 adds to its last message, asked once its range is done
  /// (counts that its source kept of its own slices, such as label voxels), and rank 0's use of
  /// each, in rank order. Either may be empty.
  std::function<std::string()> rankSummary;
  std::function<void(int rank, const std::string& summary)> mergeRankSummary;
};

/// How a threaded pipeline divides the work.
struct ThreadPlan {
  /// Extraction workers; 1 means everything on the calling thread.
  int workers = 1;
  /// Slabs per run (a job of one worker), and runs in flight.
  std::int64_t runSlabs = 1;
  int runsInFlight = 1;
};

/// The plan for a volume of `info` whose extractor needs `cacheBytes` of welding caches per
/// worker, with `options`; `lends`: the source lends its slices. Runs hold about
/// options.runVoxels but are short enough for each worker to get four; runs in flight are one more than the workers.
ThreadPlan planThreads(const VolumeInfo& info, bool lends, std::size_t cacheBytes, const PipelineOptions& options);

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
  /// The plan's workers and run length (ThreadPlan).
  int workers = 1;
  std::int64_t runSlabs = 1;
  /// The smallest and largest value over every slice read (NaN is skipped); empty when no slice
  /// held a value that is not NaN. Tracked as the slices stream past, so the volume is never held.
  std::optional<std::array<double, 2>> valueRange;
  /// With ranks, on rank 0: the other ranks' readers' warnings (SliceSource::warnings), in rank
  /// order (a compressed file's trailing bytes are found by the last rank, which reads its end).
  std::vector<std::string> rankWarnings;
};

/// Runs the whole volume. The sink gets begin(header), a chunk per slab in order, and finish(), all
/// from one thread (the calling one unless options.threads > 1). Throws
/// isoslab::Error from the source or the sink, or if the mesh exceeds 2^32 - 1 vertices.
PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options = {});

}  // namespace isoslab
