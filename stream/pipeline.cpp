#include "stream/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <exception>
#include <limits>
#include <mutex>
#include <thread>
#include <utility>

#include "core/error.h"
#include "extract/slab_stitcher.h"
#include "io/interrupt.h"
#include "stream/bounded_queue.h"
#include "stream/progress.h"
#include "stream/slab_ring.h"
#include "stream/worker_pool.h"

namespace isoslab {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The smallest and largest value seen, NaN skipped (it compares false both ways).
class ValueRange {
 public:
  void add(const float* values, std::size_t n) noexcept {
    float lo = lo_;
    float hi = hi_;
    for (std::size_t i = 0; i < n; ++i) {
      lo = values[i] < lo ? values[i] : lo;
      hi = values[i] > hi ? values[i] : hi;
    }
    lo_ = lo;
    hi_ = hi;
  }
  std::optional<std::array<double, 2>> range() const {
    if (lo_ > hi_) return std::nullopt;
    return std::array<double, 2>{lo_, hi_};
  }

 private:
  float lo_ = std::numeric_limits<float>::infinity();
  float hi_ = -std::numeric_limits<float>::infinity();
};

}  // namespace

namespace {

// Slices in order from the source: read on the spot into the ring, or by a reader thread ahead
// of time into buffers that the ring adopts (and hands back once evicted, for reuse). The reader
// thread also classifies each slice's rows once, for all the workers whose slabs use it. Every
// slice's value range is tracked on the way (by the reader thread, when there is one).
class SliceFeed {
 public:
  SliceFeed(SliceSource& source, bool threaded, const Extractor* classifier = nullptr)
      : source_(source), threaded_(threaded), queue_(3), free_(4) {
    if (threaded_) {
      reader_ = std::thread([this, classifier] {
        try {
          const auto n = static_cast<std::size_t>(source_.info().sliceVoxels());
          const bool lends = source_.lendsSlices();
          for (;;) {
            throwIfInterrupted();
            auto reused = free_.tryPop();
            SliceBuffer slice = reused ? std::move(*reused) : SliceBuffer{};
            slice.lent = nullptr;
            if (lends) {
              slice.lent = source_.lendSlice();
              if (slice.lent == nullptr) break;
            } else {
              slice.values.resize(n);
              if (!source_.readSlice(slice.values)) break;
            }
            range_.add(slice.data(), n);
            if (classifier != nullptr) {
              classifier->classifySlice(slice.data(), slice.rows);
            } else {
              slice.rows.clear();
            }
            if (!queue_.push(std::move(slice))) return;
          }
        } catch (...) {
          error_ = std::current_exception();
        }
        queue_.close();
      });
    }
  }
  ~SliceFeed() { stop(); }
  SliceFeed(const SliceFeed&) = delete;
  SliceFeed& operator=(const SliceFeed&) = delete;

  /// Reads the next slice into the ring as slice k; false at the end of the data.
  bool next(SlabRing& ring, std::int64_t k) {
    throwIfInterrupted();  // a slice boundary: unwinding joins the threads and removes temporaries
    if (!threaded_) {
      const auto n = static_cast<std::size_t>(source_.info().sliceVoxels());
      if (!source_.lendsSlices()) {
        const std::span<float> slice = ring.acquire(k);
        if (!source_.readSlice(slice)) return false;
        range_.add(slice.data(), n);
        return true;
      }
      const float* lent = source_.lendSlice();
      if (lent == nullptr) return false;
      range_.add(lent, n);
      ring.lend(k, lent);
      return true;
    }
    auto slice = queue_.pop();
    if (!slice) {
      if (error_) std::rethrow_exception(error_);
      return false;
    }
    SliceBuffer evicted = ring.adopt(k, std::move(*slice));
    free_.tryPush(evicted);
    return true;
  }

  /// The value range of the slices read, once every slice has been taken: stops the reader.
  std::optional<std::array<double, 2>> finish() {
    stop();
    return range_.range();
  }

 private:
  void stop() {
    if (threaded_ && reader_.joinable()) {
      queue_.close();
      reader_.join();
    }
  }

  SliceSource& source_;
  bool threaded_;
  BoundedQueue<SliceBuffer> queue_;
  BoundedQueue<SliceBuffer> free_;
  std::thread reader_;
  std::exception_ptr error_;
  ValueRange range_;
};

// Chunks in order to the sink: consumed on the spot, or by a writer thread.
class ChunkDrain {
 public:
  ChunkDrain(MeshSink& sink, bool threaded) : sink_(sink), threaded_(threaded), queue_(4), free_(2) {
    if (threaded_) {
      writer_ = std::thread([this] {
        while (auto chunk = queue_.pop()) {
          if (failed_ || abandoned_) continue;  // drain without consuming after a failure
          try {
            sink_.consume(*chunk);
          } catch (...) {
            error_ = std::current_exception();
            failed_ = true;
          }
          chunk->clear();
          free_.tryPush(*chunk);
        }
      });
    }
  }
  // Without flush() (an error elsewhere), queued chunks are dropped rather than consumed.
  ~ChunkDrain() {
    abandoned_ = true;
    stop();
  }
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
  /// An empty chunk whose buffers may have room from an earlier slab.
  MeshChunk recycled() {
    auto chunk = threaded_ ? free_.tryPop() : std::nullopt;
    return chunk ? std::move(*chunk) : MeshChunk{};
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
  BoundedQueue<MeshChunk> free_;
  std::thread writer_;
  std::exception_ptr error_;
  std::atomic<bool> failed_{false};
  std::atomic<bool> abandoned_{false};
};

// One run of the pipeline: the ring, the feed and the drain, and the two ways of extracting.
class PipelineRun {
 public:
  PipelineRun(SliceSource& source, Extractor& extractor, MeshSink& sink, const PipelineOptions& options)
      : info_(source.info()),
        extractor_(extractor),
        below_(extractor.slicesBelow()),
        above_(extractor.slicesAbove()),
        workers_(std::max(1, options.threads)),
        // Slab z needs slices z - below .. z + 1 + above. With workers, two more slabs than workers
        // are in flight, so that a slow slab does not idle the others, and the ring holds depth - 1
        // more slices.
        depth_(workers_ > 1 ? workers_ + 2 : 1),
        ring_(info_.sliceVoxels(), below_ + 1 + above_ + depth_),
        progress_("extract", info_.dims[2] - 1, options.progress),
        feed_(source, workers_ > 1, workers_ > 1 ? &extractor : nullptr),
        drain_(sink, workers_ > 1) {
    result_.ringBytes = ring_.bytes();
  }

  PipelineResult& result() noexcept { return result_; }
  bool threaded() const noexcept { return workers_ > 1; }
  auto finishFeed() { return feed_.finish(); }
  void flush() { drain_.flush(); }
  void finishProgress() { progress_.finish(); }

  void runSequential() {
    MeshChunk chunk;
    VertexId nextVertex = 0;
    for (std::int64_t z = 0; z < slabs(); ++z) {
      load(z);
      chunk.clear();
      chunk.slab = z;
      chunk.firstVertex = nextVertex;
      const auto t = Clock::now();
      extractor_.extractSlab(view(z), chunk);
      result_.extractSeconds += since(t);
      if (extractor_.vertexCount() > std::numeric_limits<VertexId>::max()) {
        throw Error(
            fmt::format("{}: the mesh exceeds {} vertices", info_.source, std::numeric_limits<VertexId>::max()));
      }
      nextVertex = chunk.endVertex();
      emit(chunk);
    }
  }

  // Slabs collected..dispatched-1 are in flight; the ring keeps every slice they need.
  void runThreaded() {
    WorkerPool pool(extractor_, workers_, depth_);
    SlabStitcher stitcher(extractor_.sliceSlots());
    std::int64_t dispatched = 0;
    for (std::int64_t collected = 0; collected < slabs(); ++collected) {
      while (dispatched < slabs() && dispatched - collected < depth_) {
        load(dispatched);
        pool.submit(view(dispatched));
        ++dispatched;
      }
      SlabPart& part = pool.collect(collected);
      try {
        stitcher.stitch(part);
      } catch (const Error& e) {
        throw Error(fmt::format("{}: {}", info_.source, e.what()));
      }
      emit(part.chunk);
      part.chunk = drain_.recycled();
    }
    result_.extractSeconds = pool.seconds();
  }

 private:
  std::int64_t slabs() const noexcept { return info_.dims[2] - 1; }

  // Reads the slices slab z needs.
  void load(std::int64_t z) {
    const std::int64_t nz = info_.dims[2];
    const std::int64_t need = std::min(nz - 1, z + 1 + above_);
    const auto t0 = Clock::now();
    while (loaded_ <= need) {
      if (!feed_.next(ring_, loaded_)) {
        throw Error(fmt::format("{}: the data ended after {} of {} slices", info_.source, loaded_, nz));
      }
      ++loaded_;
    }
    result_.readSeconds += since(t0);
  }

  SlabView view(std::int64_t z) const {
    SlabView v;
    v.z = z;
    v.dims = info_.dims;
    v.slices = {below_ > 0 ? ring_.slice(z - 1) : nullptr, ring_.slice(z), ring_.slice(z + 1),
                above_ > 0 ? ring_.slice(z + 2) : nullptr};
    v.rows = {nullptr, ring_.rows(z), ring_.rows(z + 1), above_ > 0 ? ring_.rows(z + 2) : nullptr};
    return v;
  }

  void emit(MeshChunk& chunk) {
    result_.vertices += chunk.positions.size();
    result_.triangles += chunk.triangles.size();
    const std::int64_t slab = chunk.slab;
    const auto t0 = Clock::now();
    drain_.push(chunk);  // may move the chunk away
    result_.writeSeconds += since(t0);
    progress_.update(slab + 1);
  }

  const VolumeInfo& info_;
  Extractor& extractor_;
  int below_;
  int above_;
  int workers_;
  int depth_;
  SlabRing ring_;
  PipelineResult result_;
  Progress progress_;
  SliceFeed feed_;
  ChunkDrain drain_;
  std::int64_t loaded_ = 0;
};

}  // namespace

PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options) {
  const auto start = Clock::now();
  PipelineRun run(source, extractor, sink, options);
  PipelineResult& result = run.result();
  auto t = Clock::now();
  sink.begin(header);
  result.writeSeconds += since(t);
  if (run.threaded()) {
    run.runThreaded();
  } else {
    run.runSequential();
  }
  result.valueRange = run.finishFeed();
  t = Clock::now();
  run.flush();
  sink.finish();
  result.writeSeconds += since(t);
  run.finishProgress();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace isoslab
