#include "stream/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <utility>
#include <limits>
#include <mutex>
#include <thread>

#include "extract/slab_stitcher.h"
#include "core/error.h"
#include "io/interrupt.h"
#include "stream/bounded_queue.h"
#include "stream/progress.h"
#include "stream/slab_ring.h"

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

// Extraction on several threads. Slabs queue up and go to whichever worker is free (a detached
// extractor gives the same part for a slab whichever worker runs it); up to `depth` slabs are in
// flight, and parts are collected in slab order.
class WorkerPool {
 public:
  WorkerPool(const Extractor& extractor, int workers, int depth) : results_(static_cast<std::size_t>(depth)) {
    for (int w = 0; w < workers; ++w) extractors_.push_back(extractor.makeWorker());
    try {
      for (auto& ex : extractors_) threads_.emplace_back([this, e = ex.get()] { run(*e); });
    } catch (...) {
      stop();
      throw;
    }
  }
  ~WorkerPool() { stop(); }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Queues slab view.z, whose result slot must have been collected from.
  void submit(const SlabView& view) {
    {
      std::lock_guard lock(mutex_);
      Result& r = slotOf(view.z);
      assert(!r.done);
      r.z = view.z;
      jobs_.push_back(view);
    }
    jobReady_.notify_one();
  }

  /// Waits for slab z. The part stays valid until slab z + depth is submitted.
  SlabPart& collect(std::int64_t z) {
    std::unique_lock lock(mutex_);
    Result& r = slotOf(z);
    partReady_.wait(lock, [&] { return r.done && r.z == z; });
    r.done = false;
    if (r.error) std::rethrow_exception(std::exchange(r.error, nullptr));  // std::bad_alloc, say
    return r.part;
  }

  /// Seconds spent extracting, summed over the workers.
  double seconds() const noexcept { return seconds_; }

 private:
  struct Result {
    std::int64_t z = -1;
    bool done = false;
    SlabPart part;
    std::exception_ptr error;  // what the worker threw instead of extracting the part
  };

  void run(SlabWorker& worker) {
    for (;;) {
      SlabView view;
      {
        std::unique_lock lock(mutex_);
        jobReady_.wait(lock, [&] { return !jobs_.empty() || stop_; });
        if (stop_) return;
        view = jobs_.front();
        jobs_.pop_front();
      }
      // Only this worker touches the slot's part until it is marked done.
      SlabPart& part = slotOf(view.z).part;
      const auto t = Clock::now();
      std::exception_ptr error;
      try {
        worker.extract(view, part);
      } catch (...) {
        error = std::current_exception();
      }
      const double took = since(t);
      {
        std::lock_guard lock(mutex_);
        slotOf(view.z).error = error;
        slotOf(view.z).done = true;
        seconds_ += took;
      }
      partReady_.notify_all();
    }
  }

  Result& slotOf(std::int64_t z) { return results_[static_cast<std::size_t>(z) % results_.size()]; }

  void stop() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    jobReady_.notify_all();
    for (auto& t : threads_) t.join();
    threads_.clear();
  }

  std::vector<std::unique_ptr<SlabWorker>> extractors_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable jobReady_, partReady_;
  std::deque<SlabView> jobs_;
  std::vector<Result> results_;
  double seconds_ = 0;
  bool stop_ = false;
};

}  // namespace

PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options) {
  const auto start = Clock::now();
  const VolumeInfo& info = source.info();
  const std::int64_t nz = info.dims[2];
  const int below = extractor.slicesBelow();
  const int above = extractor.slicesAbove();
  const int workers = std::max(1, options.threads);
  const bool threaded = workers > 1;
  // Slab z needs slices z - below .. z + 1 + above. With workers, two more slabs than workers are
  // in flight, so that a slow slab does not idle the others, and the ring holds depth - 1 more
  // slices.
  const int depth = threaded ? workers + 2 : 1;
  SlabRing ring(info.sliceVoxels(), below + 1 + above + depth);
  PipelineResult result;
  result.ringBytes = ring.bytes();
  Progress progress("extract", nz - 1, options.progress);

  auto t = Clock::now();
  sink.begin(header);
  result.writeSeconds += since(t);

  SliceFeed feed(source, threaded, threaded ? &extractor : nullptr);
  ChunkDrain drain(sink, threaded);
  std::int64_t loaded = 0;
  auto load = [&](std::int64_t z) {  // the slices slab z needs
    const std::int64_t need = std::min(nz - 1, z + 1 + above);
    const auto t0 = Clock::now();
    while (loaded <= need) {
      if (!feed.next(ring, loaded)) {
        throw Error(fmt::format("{}: the data ended after {} of {} slices", info.source, loaded, nz));
      }
      ++loaded;
    }
    result.readSeconds += since(t0);
  };
  auto view = [&](std::int64_t z) {
    SlabView v;
    v.z = z;
    v.dims = info.dims;
    v.slices = {below > 0 ? ring.slice(z - 1) : nullptr, ring.slice(z), ring.slice(z + 1),
                above > 0 ? ring.slice(z + 2) : nullptr};
    v.rows = {nullptr, ring.rows(z), ring.rows(z + 1), above > 0 ? ring.rows(z + 2) : nullptr};
    return v;
  };
  auto emit = [&](MeshChunk& chunk) {
    result.vertices += chunk.positions.size();
    result.triangles += chunk.triangles.size();
    const std::int64_t slab = chunk.slab;
    const auto t0 = Clock::now();
    drain.push(chunk);  // may move the chunk away
    result.writeSeconds += since(t0);
    progress.update(slab + 1);
  };
  const std::int64_t slabs = nz - 1;
  if (!threaded) {
    MeshChunk chunk;
    VertexId nextVertex = 0;
    for (std::int64_t z = 0; z < slabs; ++z) {
      load(z);
      chunk.clear();
      chunk.slab = z;
      chunk.firstVertex = nextVertex;
      t = Clock::now();
      extractor.extractSlab(view(z), chunk);
      result.extractSeconds += since(t);
      if (extractor.vertexCount() > std::numeric_limits<VertexId>::max()) {
        throw Error(fmt::format("{}: the mesh exceeds {} vertices", info.source, std::numeric_limits<VertexId>::max()));
      }
      nextVertex = chunk.endVertex();
      emit(chunk);
    }
  } else {
    // Slabs collected..dispatched-1 are in flight; the ring keeps every slice they need.
    WorkerPool pool(extractor, workers, depth);
    SlabStitcher stitcher(extractor.sliceSlots());
    std::int64_t dispatched = 0;
    for (std::int64_t collected = 0; collected < slabs; ++collected) {
      while (dispatched < slabs && dispatched - collected < depth) {
        load(dispatched);
        pool.submit(view(dispatched));
        ++dispatched;
      }
      SlabPart& part = pool.collect(collected);
      try {
        stitcher.stitch(part);
      } catch (const Error& e) {
        throw Error(fmt::format("{}: {}", info.source, e.what()));
      }
      emit(part.chunk);
      part.chunk = drain.recycled();
    }
    result.extractSeconds = pool.seconds();
  }
  result.valueRange = feed.finish();
  t = Clock::now();
  drain.flush();
  sink.finish();
  result.writeSeconds += since(t);
  progress.finish();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace isoslab
