#include "stream/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <limits>
#include <thread>

#include "io/error.h"
#include "stream/bounded_queue.h"
#include "stream/progress.h"
#include "stream/slab_ring.h"

namespace isoslab {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

}  // namespace

namespace {

// Slices in order from the source: read on the spot, or by a reader thread ahead of time.
class SliceFeed {
 public:
  SliceFeed(SliceSource& source, bool threaded) : source_(source), threaded_(threaded), queue_(3) {
    if (threaded_) {
      reader_ = std::thread([this] {
        try {
          std::vector<float> slice(static_cast<std::size_t>(source_.info().sliceVoxels()));
          while (source_.readSlice(slice)) {
            if (!queue_.push(slice)) return;
          }
        } catch (...) {
          error_ = std::current_exception();
        }
        queue_.close();
      });
    }
  }
  ~SliceFeed() {
    if (threaded_) {
      queue_.close();
      reader_.join();
    }
  }
  SliceFeed(const SliceFeed&) = delete;
  SliceFeed& operator=(const SliceFeed&) = delete;

  bool next(std::span<float> into) {
    if (!threaded_) return source_.readSlice(into);
    auto slice = queue_.pop();
    if (!slice) {
      if (error_) std::rethrow_exception(error_);
      return false;
    }
    std::copy(slice->begin(), slice->end(), into.begin());
    return true;
  }

 private:
  SliceSource& source_;
  bool threaded_;
  BoundedQueue<std::vector<float>> queue_;
  std::thread reader_;
  std::exception_ptr error_;
};

// Chunks in order to the sink: consumed on the spot, or by a writer thread.
class ChunkDrain {
 public:
  ChunkDrain(MeshSink& sink, bool threaded) : sink_(sink), threaded_(threaded), queue_(4) {
    if (threaded_) {
      writer_ = std::thread([this] {
        while (auto chunk = queue_.pop()) {
          if (failed_) continue;  // drain without consuming after a failure
          try {
            sink_.consume(*chunk);
          } catch (...) {
            error_ = std::current_exception();
            failed_ = true;
          }
        }
      });
    }
  }
  ~ChunkDrain() { stop(); }
  ChunkDrain(const ChunkDrain&) = delete;
  ChunkDrain& operator=(const ChunkDrain&) = delete;

  void push(MeshChunk& chunk) {
    if (!threaded_) {
      sink_.consume(chunk);
      return;
    }
    if (failed_) {
      stop();
      std::rethrow_exception(error_);
    }
    queue_.push(std::move(chunk));
    chunk = MeshChunk{};
  }
  /// Waits for every chunk to be consumed; rethrows the writer's error.
  void flush() {
    stop();
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void stop() {
    if (threaded_ && writer_.joinable()) {
      queue_.close();
      writer_.join();
    }
  }

  MeshSink& sink_;
  bool threaded_;
  BoundedQueue<MeshChunk> queue_;
  std::thread writer_;
  std::exception_ptr error_;
  std::atomic<bool> failed_{false};
};

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

  const bool threaded = options.threads > 1;
  SliceFeed feed(source, threaded);
  ChunkDrain drain(sink, threaded);
  std::int64_t loaded = 0;
  MeshChunk chunk;
  VertexId nextVertex = 0;
  for (std::int64_t z = 0; z + 1 < nz; ++z) {
    const std::int64_t need = std::min(nz - 1, z + 1 + above);
    t = Clock::now();
    while (loaded <= need) {
      if (!feed.next(ring.acquire(loaded))) {
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
    drain.push(chunk);
    result.writeSeconds += since(t);
    progress.update(z + 1);
  }
  t = Clock::now();
  drain.flush();
  sink.finish();
  result.writeSeconds += since(t);
  progress.finish();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace isoslab
