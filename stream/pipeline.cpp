#include "stream/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <limits>
#include <thread>

#include "extract/slab_stitcher.h"
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

// Slices in order from the source: read on the spot into the ring, or by a reader thread ahead
// of time into buffers that the ring adopts (and hands back once evicted, for reuse). The reader
// thread also classifies each slice's rows once, for all the workers whose slabs use it.
class SliceFeed {
 public:
  SliceFeed(SliceSource& source, bool threaded, const Extractor* classifier = nullptr)
      : source_(source), threaded_(threaded), queue_(3), free_(4) {
    if (threaded_) {
      reader_ = std::thread([this, classifier] {
        try {
          const auto n = static_cast<std::size_t>(source_.info().sliceVoxels());
          for (;;) {
            auto reused = free_.tryPop();
            SliceBuffer slice = reused ? std::move(*reused) : SliceBuffer{std::vector<float>(n), {}};
            if (!source_.readSlice(slice.values)) break;
            if (classifier != nullptr) {
              classifier->classifySlice(slice.values.data(), slice.rows);
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
  ~SliceFeed() {
    if (threaded_) {
      queue_.close();
      reader_.join();
    }
  }
  SliceFeed(const SliceFeed&) = delete;
  SliceFeed& operator=(const SliceFeed&) = delete;

  /// Reads the next slice into the ring as slice k; false at the end of the data.
  bool next(SlabRing& ring, std::int64_t k) {
    if (!threaded_) return source_.readSlice(ring.acquire(k));
    auto slice = queue_.pop();
    if (!slice) {
      if (error_) std::rethrow_exception(error_);
      return false;
    }
    SliceBuffer evicted = ring.adopt(k, std::move(*slice));
    free_.tryPush(evicted);
    return true;
  }

 private:
  SliceSource& source_;
  bool threaded_;
  BoundedQueue<SliceBuffer> queue_;
  BoundedQueue<SliceBuffer> free_;
  std::thread reader_;
  std::exception_ptr error_;
};

// Chunks in order to the sink: consumed on the spot, or by a writer thread.
class ChunkDrain {
 public:
  ChunkDrain(MeshSink& sink, bool threaded) : sink_(sink), threaded_(threaded), queue_(4), free_(2) {
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
          chunk->clear();
          free_.tryPush(*chunk);
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
};

// Extraction on several threads: slab z goes to worker z % count, each with its own detached
// extractor, and parts are collected in slab order.
class WorkerPool {
 public:
  WorkerPool(const Extractor& extractor, int count) : slots_(static_cast<std::size_t>(count)) {
    for (auto& slot : slots_) {
      slot = std::make_unique<Slot>();
      slot->worker = extractor.makeWorker();
    }
    for (auto& slot : slots_) slot->thread = std::thread([s = slot.get()] { run(*s); });
  }
  ~WorkerPool() {
    for (auto& slot : slots_) {
      {
        std::lock_guard lock(slot->mutex);
        slot->stop = true;
      }
      slot->wake.notify_all();
    }
    for (auto& slot : slots_) slot->thread.join();
  }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Hands slab view.z to its worker, which must have been collected from.
  void submit(const SlabView& view) {
    Slot& slot = slotOf(view.z);
    {
      std::lock_guard lock(slot.mutex);
      assert(slot.state == State::kIdle);
      slot.view = view;
      slot.state = State::kPending;
    }
    slot.wake.notify_all();
  }

  /// Waits for slab z. The part stays valid until the next submit to that worker.
  SlabPart& collect(std::int64_t z) {
    Slot& slot = slotOf(z);
    std::unique_lock lock(slot.mutex);
    slot.wake.wait(lock, [&] { return slot.state == State::kDone; });
    slot.state = State::kIdle;
    return slot.part;
  }

  /// Seconds spent extracting, summed over the workers.
  double seconds() const noexcept {
    double sum = 0;
    for (const auto& slot : slots_) sum += slot->seconds;
    return sum;
  }

 private:
  enum class State : std::uint8_t { kIdle, kPending, kDone };
  struct Slot {
    std::thread thread;
    std::mutex mutex;
    std::condition_variable wake;
    State state = State::kIdle;
    bool stop = false;
    SlabView view;
    SlabPart part;
    std::unique_ptr<SlabWorker> worker;
    double seconds = 0;  // written by the worker between a submit and its collect
  };

  static void run(Slot& slot) {
    for (;;) {
      {
        std::unique_lock lock(slot.mutex);
        slot.wake.wait(lock, [&] { return slot.state == State::kPending || slot.stop; });
        if (slot.stop) return;
      }
      const auto t = Clock::now();
      slot.worker->extract(slot.view, slot.part);
      slot.seconds += since(t);
      {
        std::lock_guard lock(slot.mutex);
        slot.state = State::kDone;
      }
      slot.wake.notify_all();
    }
  }

  Slot& slotOf(std::int64_t z) { return *slots_[static_cast<std::size_t>(z) % slots_.size()]; }

  std::vector<std::unique_ptr<Slot>> slots_;
};

}  // namespace

PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options) {
  const auto start = Clock::now();
  const VolumeInfo& info = source.info();
  const std::int64_t nz = info.dims[2];
  const int below = extractor.slicesBelow();
  const int above = extractor.slicesAbove();
  // Slab z needs slices z - below .. z + 1 + above; with `workers` slabs in flight, the ring holds
  // one more slice per extra worker.
  const int workers = std::max(1, options.threads);
  SlabRing ring(info.sliceVoxels(), below + 1 + above + workers);
  PipelineResult result;
  result.ringBytes = ring.bytes();
  Progress progress("extract", nz - 1, options.progress);

  auto t = Clock::now();
  sink.begin(header);
  result.writeSeconds += since(t);

  const bool threaded = options.threads > 1;
  SliceFeed feed(source, threaded, workers > 1 ? &extractor : nullptr);
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
    const auto t0 = Clock::now();
    drain.push(chunk);
    result.writeSeconds += since(t0);
    progress.update(chunk.slab + 1);
  };
  const std::int64_t slabs = nz - 1;
  if (workers == 1) {
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
        throw Error(
            fmt::format("{}: the mesh exceeds {} vertices", info.source, std::numeric_limits<VertexId>::max()));
      }
      nextVertex = chunk.endVertex();
      emit(chunk);
    }
  } else {
    // Slabs collected..dispatched-1 are in flight; the ring keeps every slice they need.
    WorkerPool pool(extractor, workers);
    SlabStitcher stitcher(extractor.sliceSlots());
    std::int64_t dispatched = 0;
    for (std::int64_t collected = 0; collected < slabs; ++collected) {
      while (dispatched < slabs && dispatched - collected < workers) {
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
  t = Clock::now();
  drain.flush();
  sink.finish();
  result.writeSeconds += since(t);
  progress.finish();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace isoslab
