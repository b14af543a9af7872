#include "stream/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "core/error.h"
#include "extract/slab_stitcher.h"
#include "io/interrupt.h"
#include "stream/progress.h"
#include "stream/slab_ring.h"
#include "stream/value_range.h"

namespace isoslab {
namespace {

using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Slices in order from the source, into the ring (read into its slot, or lent by the source).
// With trackRange, every slice's value range is tracked on the way (a threaded pipeline's workers
// track it instead, each over its run's slices).
class SliceFeed {
 public:
  SliceFeed(SliceSource& source, bool trackRange) : source_(source), trackRange_(trackRange) {}

  /// Reads the next slice into the ring as slice k; false at the end of the data.
  bool next(SlabRing& ring, std::int64_t k) {
    throwIfInterrupted();  // a slice boundary: unwinding joins the threads and removes temporaries
    const auto n = static_cast<std::size_t>(source_.info().sliceVoxels());
    if (!source_.lendsSlices()) {
      const std::span<float> slice = ring.acquire(k);
      if (!source_.readSlice(slice)) return false;
      if (trackRange_) range_.add(slice.data(), n);
      return true;
    }
    const float* lent = source_.lendSlice();
    if (lent == nullptr) return false;
    if (trackRange_) range_.add(lent, n);
    ring.lend(k, lent);
    return true;
  }

  const ValueRange& range() const noexcept { return range_; }

 private:
  SliceSource& source_;
  bool trackRange_;
  ValueRange range_;
};

// One run of the pipeline: the ring and the feed, and the two ways of extracting.
//
// Threaded, it is a pipeline of three stages over runs of consecutive slabs, as in oneTBB's
// parallel_pipeline: loading a run's slices (serial, in order), extracting the run (parallel),
// and stitching and emitting its chunks (serial, in order). There is no thread per stage: each
// of the N threads (the calling one among them) takes whatever is ready, emitting first (which
// frees a run's place), then loading and extracting the next run. At most runsInFlight runs are
// between loading and emitting, so the ring holds every slice they need, and each run's place
// keeps its chunks' buffers for the run that takes the place next.
class PipelineRun {
 public:
  PipelineRun(SliceSource& source, Extractor& extractor, MeshSink& sink, const PipelineOptions& options)
      : info_(source.info()),
        extractor_(extractor),
        sink_(sink),
        below_(extractor.slicesBelow()),
        above_(extractor.slicesAbove()),
        plan_(planThreads(info_, source.lendsSlices(), 3 * extractor.sliceSlots() * sizeof(VertexId), options)),
        // Slab z needs slices z - below .. z + 1 + above; the runs in flight need their slabs' too.
        ring_(info_.sliceVoxels(), below_ + 1 + above_ + inFlightSlabs()),
        progress_("extract", info_.dims[2] - 1, options.progress),
        feed_(source, !threaded()),
        runTriangles_(std::max<std::int64_t>(1, options.runTriangles)) {
    result_.ringBytes = ring_.bytes();
    result_.workers = plan_.workers;
    result_.runSlabs = plan_.runSlabs;
  }

  PipelineResult& result() noexcept { return result_; }
  bool threaded() const noexcept { return plan_.workers > 1; }
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

  void runThreaded() {
    places_.resize(static_cast<std::size_t>(plan_.runsInFlight));
    stitcher_.emplace(extractor_.sliceSlots());
    std::vector<std::unique_ptr<SlabWorker>> workers;
    for (int w = 0; w < plan_.workers; ++w) workers.push_back(extractor_.makeWorker());
    std::vector<std::thread> threads;
    try {
      for (int w = 1; w < plan_.workers; ++w) threads.emplace_back([this, &workers, w] { work(*workers[w]); });
    } catch (...) {
      fail(std::current_exception());  // std::system_error: stop those that started
    }
    work(*workers[0]);
    for (auto& t : threads) t.join();
    if (error_) std::rethrow_exception(error_);
  }

  /// The value range of every slice read.
  std::optional<std::array<double, 2>> valueRange() {
    range_.merge(feed_.range());
    return range_.range();
  }

 private:
  // A run's place among those in flight: run `index`, and what its worker made of it.
  struct Place {
    std::int64_t index = -1;
    bool extracted = false;
    SlabPart part;
  };

  std::int64_t slabs() const noexcept { return info_.dims[2] - 1; }
  int inFlightSlabs() const noexcept { return threaded() ? plan_.runsInFlight * static_cast<int>(plan_.runSlabs) : 1; }
  Place& placeOf(std::int64_t run) noexcept { return places_[static_cast<std::size_t>(run) % places_.size()]; }

  // One thread's part: until every run is emitted, or something failed.
  void work(SlabWorker& worker) {
    std::vector<SlabView> views;
    std::unique_lock lock(mutex_);
    while (!error_ && emittedSlabs_ < slabs()) {
      Place& head = placeOf(emitted_);
      if (!emitting_ && head.index == emitted_ && head.extracted) {
        emitting_ = true;
        lock.unlock();
        std::int64_t triangles = 0;
        const bool ok = attempt([&] { triangles = emitRun(head.part); });
        lock.lock();
        emitting_ = false;
        if (!ok) break;
        head.extracted = false;
        ++emitted_;
        const auto runLength = static_cast<std::int64_t>(head.part.chunks.size());
        emittedSlabs_ += runLength;
        trianglesPerSlab_ = triangles / runLength;
        ready_.notify_all();
        continue;
      }
      if (!loading_ && nextSlab_ < slabs() && loaded_ - emitted_ < plan_.runsInFlight) {
        loading_ = true;
        const std::int64_t run = loaded_;
        const std::int64_t first = nextSlab_;
        nextSlab_ = std::min(slabs(), first + runLength());
        const std::int64_t end = nextSlab_;
        lock.unlock();
        const bool ok = attempt([&] { loadRun(first, end, views); });
        lock.lock();
        loading_ = false;
        if (!ok) break;
        ++loaded_;
        ready_.notify_all();  // another thread may load the next run meanwhile
        lock.unlock();
        Place& place = placeOf(run);
        ValueRange range;
        const auto t = Clock::now();
        const bool extracted = attempt([&] {
          worker.extract(views, place.part, [&](const SlabView& v) {
            if (v.z == 0) range.add(v.slices[1], sliceVoxels());
            range.add(v.slices[2], sliceVoxels());
          });
        });
        const double took = since(t);
        lock.lock();
        if (!extracted) break;
        result_.extractSeconds += took;
        range_.merge(range);
        place.index = run;
        place.extracted = true;
        ready_.notify_all();
        continue;
      }
      ready_.wait(lock);
    }
  }

  // Runs fn; on an exception, records it (the first one wins) and stops every thread.
  template <typename Fn>
  bool attempt(Fn&& fn) {
    try {
      fn();
      return true;
    } catch (...) {
      fail(std::current_exception());
      return false;
    }
  }

  void fail(std::exception_ptr e) {
    std::lock_guard lock(mutex_);
    if (!error_) error_ = std::move(e);
    ready_.notify_all();
  }

  std::size_t sliceVoxels() const noexcept { return static_cast<std::size_t>(info_.sliceVoxels()); }

  // The next run's length: plan_.runSlabs, or fewer when the slabs emitted last held so many
  // triangles that the runs in flight would hold more than options.runTriangles each (each run's
  // place keeps its chunks' buffers). The output does not depend on it.
  std::int64_t runLength() const noexcept {
    if (trianglesPerSlab_ == 0) return plan_.runSlabs;
    return std::clamp<std::int64_t>(runTriangles_ / trianglesPerSlab_, 1, plan_.runSlabs);
  }

  // The loading stage: reads the slices of slabs first .. end - 1 and sets up their views.
  void loadRun(std::int64_t first, std::int64_t end, std::vector<SlabView>& views) {
    views.clear();
    for (std::int64_t z = first; z < end; ++z) {
      load(z);
      views.push_back(view(z));
    }
  }

  // The emitting stage: stitches a run's chunks and hands them to the sink.
  std::int64_t emitRun(SlabPart& part) {
    try {
      stitcher_->stitch(part);
    } catch (const Error& e) {
      throw Error(fmt::format("{}: {}", info_.source, e.what()));
    }
    std::uint64_t triangles = 0;
    for (MeshChunk& chunk : part.chunks) {
      triangles += chunk.triangles.size();
      emit(chunk);
    }
    return static_cast<std::int64_t>(triangles);
  }

  // Reads the slices slab z needs.
  void load(std::int64_t z) {
    const std::int64_t nz = info_.dims[2];
    const std::int64_t need = std::min(nz - 1, z + 1 + above_);
    const auto t0 = Clock::now();
    while (slicesRead_ <= need) {
      if (!feed_.next(ring_, slicesRead_)) {
        throw Error(fmt::format("{}: the data ended after {} of {} slices", info_.source, slicesRead_, nz));
      }
      ++slicesRead_;
    }
    result_.readSeconds += since(t0);
  }

  SlabView view(std::int64_t z) const {
    SlabView v;
    v.z = z;
    v.dims = info_.dims;
    v.slices = {below_ > 0 ? ring_.slice(z - 1) : nullptr, ring_.slice(z), ring_.slice(z + 1),
                above_ > 0 ? ring_.slice(z + 2) : nullptr};
    return v;
  }

  void emit(MeshChunk& chunk) {
    result_.vertices += chunk.positions.size();
    result_.triangles += chunk.triangles.size();
    const auto t0 = Clock::now();
    sink_.consume(chunk);
    result_.writeSeconds += since(t0);
    progress_.update(chunk.slab + 1);
  }

  const VolumeInfo& info_;
  Extractor& extractor_;
  MeshSink& sink_;
  int below_;
  int above_;
  ThreadPlan plan_;
  SlabRing ring_;
  PipelineResult result_;
  Progress progress_;
  SliceFeed feed_;
  std::int64_t slicesRead_ = 0;

  // Threaded: the stages' state, guarded by mutex_ (the loading stage owns the ring, the feed and
  // readSeconds while loading_; the emitting stage owns the stitcher, the sink and the counts
  // while emitting_).
  std::mutex mutex_;
  std::condition_variable ready_;
  std::int64_t loaded_ = 0;   // runs
  std::int64_t emitted_ = 0;  // runs
  std::int64_t nextSlab_ = 0;
  std::int64_t emittedSlabs_ = 0;
  std::int64_t trianglesPerSlab_ = 0;  // in the last run emitted
  std::int64_t runTriangles_;
  bool loading_ = false;
  bool emitting_ = false;
  std::vector<Place> places_;
  std::optional<SlabStitcher> stitcher_;
  ValueRange range_;          // of the slices the workers read
  std::exception_ptr error_;  // the first failure
};

}  // namespace

ThreadPlan planThreads(const VolumeInfo& info, bool lends, std::size_t cacheBytes, const PipelineOptions& options) {
  ThreadPlan plan;
  const std::int64_t slabs = info.dims[2] - 1;
  const std::int64_t sliceVoxels = std::max<std::int64_t>(1, info.sliceVoxels());
  int workers = std::max(1, options.threads);
  if (workers == 1 || slabs < 2 || sliceVoxels * info.dims[2] < options.sequentialVoxels) return plan;
  std::int64_t runSlabs = (std::max<std::int64_t>(1, options.runVoxels) + sliceVoxels - 1) / sliceVoxels;
  runSlabs = std::max<std::int64_t>(1, std::min(runSlabs, slabs / (4 * std::int64_t{workers})));
  if (options.maxThreadBytes > 0) {
    // What threads add to one thread's memory: the ring's slices of (workers + 1) runs beyond the
    // one slab in flight (nothing when the source lends them), each worker's caches beyond the
    // one extractor's, and the stitcher's slots (a third of a worker's).
    const auto sliceBytes = lends ? 0.0 : static_cast<double>(sliceVoxels) * sizeof(float);
    const auto caches = static_cast<double>(cacheBytes);
    const auto budget = static_cast<double>(options.maxThreadBytes);
    auto extra = [&](int w, std::int64_t k) {
      return static_cast<double>((w + 1) * k - 1) * sliceBytes + (w - 1) * caches + caches / 3;
    };
    while (workers > 1 && extra(workers, 1) > budget) --workers;
    if (workers == 1) return plan;
    while (runSlabs > 1 && extra(workers, runSlabs) > budget) --runSlabs;
  }
  plan.workers = workers;
  plan.runSlabs = runSlabs;
  plan.runsInFlight = workers + 1;
  return plan;
}

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
  result.valueRange = run.valueRange();
  t = Clock::now();
  sink.finish();
  result.writeSeconds += since(t);
  run.finishProgress();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace isoslab
