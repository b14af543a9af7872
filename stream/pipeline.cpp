#include "stream/pipeline.h"

#include <fmt/format.h>

#include <chrono>
#include <limits>

#include "io/error.h"
#include "stream/progress.h"
#include "stream/slab_ring.h"

namespace isoslab {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace

PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options) {
  const auto start = Clock::now();
  const VolumeInfo& info = source.info();
  const std::int64_t nz = info.dims[2];
  const int below = extractor.slicesBelow();
  const int above = extractor.slicesAbove();
  SlabRing ring(info.sliceVoxels(), below + 2 + above);
  PipelineResult result;
  result.ringBytes = ring.bytes();
  Progress progress("extract", nz - 1, options.progress);

  auto t = Clock::now();
  sink.begin(header);
  result.writeSeconds += since(t);

  std::int64_t loaded = 0;
  MeshChunk chunk;
  VertexId nextVertex = 0;
  for (std::int64_t z = 0; z + 1 < nz; ++z) {
    const std::int64_t need = std::min(nz - 1, z + 1 + above);
    t = Clock::now();
    while (loaded <= need) {
      if (!source.readSlice(ring.acquire(loaded))) {
        throw Error(fmt::format("{}: the data ended after {} of {} slices", info.source, loaded, nz));
      }
      ++loaded;
    }
    result.readSeconds += since(t);

    SlabView view;
    view.z = z;
    view.dims = info.dims;
    view.slices = {below > 0 ? ring.slice(z - 1) : nullptr, ring.slice(z), ring.slice(z + 1),
                   above > 0 ? ring.slice(z + 2) : nullptr};
    chunk.clear();
    chunk.slab = z;
    chunk.firstVertex = nextVertex;
    t = Clock::now();
    extractor.extractSlab(view, chunk);
    result.extractSeconds += since(t);
    if (extractor.vertexCount() > std::numeric_limits<VertexId>::max()) {
      throw Error(fmt::format("{}: the mesh exceeds {} vertices", info.source, std::numeric_limits<VertexId>::max()));
    }
    nextVertex = chunk.endVertex();
    result.vertices += chunk.positions.size();
    result.triangles += chunk.triangles.size();

    t = Clock::now();
    sink.consume(chunk);
    result.writeSeconds += since(t);
    progress.update(z + 1);
  }
  t = Clock::now();
  sink.finish();
  result.writeSeconds += since(t);
  progress.finish();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace isoslab
