// size-exception: the single-process pipeline (reader, extraction runs, ordered emit) and its
// rank variants share the run scheduling and result merging kept private here; the rank half
// is the part to move to a file of its own next.
#include "stream/pipeline.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "extract/slab_stitcher.h"
#include "stream/progress.h"
#include "stream/rank_group.h"
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
    const auto n = static_cast<std::size_t>(source_.info().sliceValues());
    if (!source_.lendsSlices()) {
      // The slice's data first, then its slot: the ring grows a slice at a time as data arrives.
      if (!source_.fetchSlice()) return false;
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

  /// Moves past the first n slices without reading them (a rank that starts higher up).
  void skip(std::int64_t n) {
    if (n > 0 && source_.skipSlices(n) != n) {
      throw Error(
          fmt::format("{}: the data ended before slice {} of {}", source_.info().source, n, source_.info().dims[2]));
    }
  }

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
  /// `range`: the slabs to extract (a rank's); `partOut`, if set, takes each run's part in slab
  /// order instead of the stitcher and the sink (a rank above 0). Either forces the staged path,
  /// whose runs can start anywhere.
  PipelineRun(SliceSource& source, Extractor& extractor, MeshSink& sink, const PipelineOptions& options,
              std::optional<SlabRange> range = std::nullopt, std::function<void(SlabPart&)> partOut = {})
      : info_(source.info()),
        extractor_(extractor),
        sink_(sink),
        below_(extractor.slicesBelow()),
        above_(extractor.slicesAbove()),
        range_(range.value_or(SlabRange{0, info_.dims[2] - 1})),
        ranged_(range.has_value()),
        partOut_(std::move(partOut)),
        plan_(stagedPlan(info_, source.lendsSlices(), 3 * extractor.sliceSlots() * sizeof(VertexId), options,
                         range.has_value())),
        // Slab z needs slices z - below .. z + 1 + above; the runs in flight need their slabs' too.
        ring_(info_.sliceValues(), below_ + 1 + above_ + inFlightSlabs()),
        progress_("extract", info_.dims[2] - 1, options.progress && !partOut_),
        onSlab_(partOut_ ? nullptr : options.onSlab),
        feed_(source, !staged()),
        runTriangles_(std::max<std::int64_t>(1, options.runTriangles)) {
    result_.ringBytes = ring_.bytes();
    result_.workers = plan_.workers;
    result_.runSlabs = plan_.runSlabs;
  }

  PipelineResult& result() noexcept { return result_; }
  /// Through the load / extract / emit stages: with threads, or for a rank's range.
  bool staged() const noexcept { return plan_.workers > 1 || ranged_; }
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
    // A rank's range starts at its first slab, whose slices start `below_` lower.
    const std::int64_t skip = std::max<std::int64_t>(0, range_.first - below_);
    feed_.skip(skip);
    slicesRead_ = skip;
    nextSlab_ = range_.first;
    emittedSlabs_ = range_.first;
    places_.resize(static_cast<std::size_t>(plan_.runsInFlight));
    startStitching();
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
    values_.merge(feed_.range());
    return values_.range();
  }
  ValueRange& values() noexcept { return values_; }
  void startStitching() {
    if (!stitcher_) stitcher_.emplace(extractor_.sliceSlots());
  }

  // The emitting stage: stitches a run's chunks and hands them to the sink (or hands the run to
  // partOut_). Returns its triangles. Rank 0 also calls it with the other ranks' runs.
  std::int64_t emitRun(SlabPart& part) {
    std::uint64_t triangles = 0;
    for (const MeshChunk& chunk : part.chunks) triangles += chunk.triangles.size();
    if (partOut_) {
      partOut_(part);
      return static_cast<std::int64_t>(triangles);
    }
    try {
      stitcher_->stitch(part);
    } catch (const Error& e) {
      throw Error(fmt::format("{}: {}", info_.source, e.what()));
    }
    for (MeshChunk& chunk : part.chunks) emit(chunk);
    return static_cast<std::int64_t>(triangles);
  }

 private:
  // A run's place among those in flight: run `index`, and what its worker made of it.
  struct Place {
    std::int64_t index = -1;
    bool extracted = false;
    SlabPart part;
  };

  // The end of the slabs this run extracts (the volume's last slab + 1 without ranks).
  std::int64_t slabs() const noexcept { return range_.end; }
  int inFlightSlabs() const noexcept { return staged() ? plan_.runsInFlight * static_cast<int>(plan_.runSlabs) : 1; }

  // planThreads, and for a rank's range (ranged) a staged plan even on one thread: runs of about
  // options.runVoxels, one in flight.
  static ThreadPlan stagedPlan(const VolumeInfo& info, bool lends, std::size_t cacheBytes,
                               const PipelineOptions& options, bool ranged) {
    ThreadPlan plan = planThreads(info, lends, cacheBytes, options);
    if (ranged && plan.workers == 1) {
      const std::int64_t sliceVoxels = std::max<std::int64_t>(1, info.sliceVoxels());
      plan.runSlabs =
          std::max<std::int64_t>(1, (std::max<std::int64_t>(1, options.runVoxels) + sliceVoxels - 1) / sliceVoxels);
      plan.runsInFlight = 1;
    }
    return plan;
  }
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
            if (v.z == 0) range.add(v.slices[1], sliceValues());
            range.add(v.slices[2], sliceValues());
          });
        });
        const double took = since(t);
        lock.lock();
        if (!extracted) break;
        result_.extractSeconds += took;
        values_.merge(range);
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

  std::size_t sliceValues() const noexcept { return static_cast<std::size_t>(info_.sliceValues()); }

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
    if (onSlab_) onSlab_(chunk.slab + 1, info_.dims[2] - 1);
  }

  const VolumeInfo& info_;
  Extractor& extractor_;
  MeshSink& sink_;
  int below_;
  int above_;
  SlabRange range_;
  bool ranged_ = false;
  std::function<void(SlabPart&)> partOut_;
  ThreadPlan plan_;
  SlabRing ring_;
  PipelineResult result_;
  Progress progress_;
  std::function<void(std::int64_t, std::int64_t)> onSlab_;
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
  ValueRange values_;         // of the slices the workers read
  std::exception_ptr error_;  // the first failure
};

}  // namespace

ThreadPlan planThreads(const VolumeInfo& info, bool lends, std::size_t cacheBytes, const PipelineOptions& options) {
  ThreadPlan plan;
  const std::int64_t slabs = info.dims[2] - 1;
  const std::int64_t sliceVoxels = std::max<std::int64_t>(1, info.sliceValues());
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

namespace {

class NullSink final : public MeshSink {
 public:
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk&) override {}
  void finish() override {}
};

// Ranks' messages (rank_group.h): a run, the end of a rank's runs, a rank's failure; rank 0's outcome.
enum class Message : std::uint8_t { kPart = 'P', kEnd = 'E', kFailed = 'X', kOk = 'O', kStop = 'F' };

// Messages in the machine's own byte order (the ranks run one build on one kind of machine).
class MessageWriter {
 public:
  explicit MessageWriter(Message type) { put(static_cast<std::uint8_t>(type)); }
  template <typename T>
  void put(const T& value) {
    append(&value, sizeof(T));
  }
  template <typename T>
  void putVector(const std::vector<T>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    append(values.data(), values.size() * sizeof(T));
  }
  void putString(const std::string& text) {
    put(static_cast<std::uint64_t>(text.size()));
    append(text.data(), text.size());
  }
  std::vector<std::byte>& bytes() noexcept { return bytes_; }

 private:
  // resize and memcpy rather than vector::insert, which GCC 12 at -O2 with TSan takes for an
  // overflow of an empty vector (-Wstringop-overflow).
  void append(const void* data, std::size_t n) {
    if (n == 0) return;
    const std::size_t at = bytes_.size();
    bytes_.resize(at + n);
    std::memcpy(bytes_.data() + at, data, n);
  }
  std::vector<std::byte> bytes_;
};

class MessageReader {
 public:
  explicit MessageReader(std::span<const std::byte> bytes) : bytes_(bytes) {}
  Message type() { return static_cast<Message>(get<std::uint8_t>()); }
  template <typename T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  template <typename T>
  void getVector(std::vector<T>& values) {
    const auto n = get<std::uint64_t>();
    if (n > (bytes_.size() - at_) / sizeof(T)) throw Error("a rank's message is truncated");
    values.resize(static_cast<std::size_t>(n));
    take(values.data(), values.size() * sizeof(T));
  }
  std::string getString() {
    std::vector<char> text;
    getVector(text);
    return {text.begin(), text.end()};
  }

 private:
  void take(void* out, std::size_t n) {
    if (n > bytes_.size() - at_) throw Error("a rank's message is truncated");
    if (n > 0) std::memcpy(out, bytes_.data() + at_, n);
    at_ += n;
  }
  std::span<const std::byte> bytes_;
  std::size_t at_ = 0;
};

void writePart(MessageWriter& w, const SlabPart& part) {
  w.put(static_cast<std::uint64_t>(part.chunks.size()));
  for (const MeshChunk& c : part.chunks) {
    w.put(c.slab);
    w.put(c.cellVolume);
    w.putVector(c.positions);
    w.putVector(c.normals);
    w.putVector(c.boundary);
    w.putVector(c.triangles);
    w.putVector(c.faceLabels);
    w.putVector(c.labelSplits);
    w.putVector(c.labelPinches);
  }
  w.putVector(part.foreign);
  w.put(static_cast<std::uint64_t>(part.top.size()));
  for (const auto& [slot, id] : part.top) {
    w.put(slot);
    w.put(id);
  }
}

void readPart(MessageReader& r, SlabPart& part) {
  const auto chunks = r.get<std::uint64_t>();
  if (chunks > (std::uint64_t{1} << 32)) throw Error("a rank's message is malformed");
  part.chunks.resize(static_cast<std::size_t>(chunks));
  for (MeshChunk& c : part.chunks) {
    c.slab = r.get<std::int64_t>();
    c.firstVertex = 0;
    c.cellVolume = r.get<double>();
    r.getVector(c.positions);
    r.getVector(c.normals);
    r.getVector(c.boundary);
    r.getVector(c.triangles);
    r.getVector(c.faceLabels);
    r.getVector(c.labelSplits);
    r.getVector(c.labelPinches);
  }
  r.getVector(part.foreign);
  const auto top = r.get<std::uint64_t>();
  part.top.clear();
  for (std::uint64_t k = 0; k < top; ++k) {
    const auto slot = r.get<CacheSlot>();
    const auto id = r.get<LocalVertex>();
    part.top.emplace_back(slot, id);
  }
}

// A rank's runs between extracting and sending: length-prefixed messages in a spool file in the
// temporary folder, so that a rank holds one run at a time, however many it extracts.
class PartSpool {
 public:
  explicit PartSpool(int rank)
      : file_(std::filesystem::temp_directory_path().string(), "rank " + std::to_string(rank)) {}

  void add(std::span<const std::byte> message) {
    const auto n = static_cast<std::uint64_t>(message.size());
    file_.write(&n, sizeof n);
    file_.write(message.data(), message.size());
    ++count_;
  }
  /// Calls fn with each message, in the order added.
  void replay(const std::function<void(std::span<const std::byte>)>& fn) {
    file_.rewind();
    std::vector<std::byte> message;
    for (std::int64_t k = 0; k < count_; ++k) {
      std::uint64_t n = 0;
      file_.read(&n, sizeof n);
      if (n > static_cast<std::uint64_t>(file_.size())) throw Error("a rank's spool file is damaged");
      message.resize(static_cast<std::size_t>(n));
      file_.read(message.data(), message.size());
      fn(message);
    }
  }

 private:
  SpoolFile file_;
  std::int64_t count_ = 0;
};

std::string messageOf(const std::exception_ptr& e) {
  try {
    std::rethrow_exception(e);
  } catch (const std::bad_alloc&) {
    return "out of memory";
  } catch (const std::exception& x) {
    return x.what();
  } catch (...) {
    return "an unknown error";
  }
}

// A rank above 0: extracts its range into the spool, sends it to rank 0, and learns the outcome.
PipelineResult runRank(RankGroup& group, SliceSource& source, Extractor& extractor, const PipelineOptions& options) {
  const auto start = Clock::now();
  std::exception_ptr error;
  std::optional<PartSpool> spool;
  NullSink none;
  PipelineResult result;
  ValueRange values;
  try {
    spool.emplace(group.rank());
    const SlabRange range = rankSlabs(source.info().dims[2] - 1, group.rank(), group.size());
    PipelineRun run(source, extractor, none, options, range, [&](SlabPart& part) {
      MessageWriter w(Message::kPart);
      writePart(w, part);
      spool->add(w.bytes());
    });
    if (range.end > range.first) run.runThreaded();
    run.valueRange();
    values = run.values();
    result = run.result();
  } catch (...) {
    error = std::current_exception();
  }
  if (!error) {
    try {
      spool->replay([&](std::span<const std::byte> m) { group.send(0, m); });
    } catch (...) {
      error = std::current_exception();
    }
  }
  spool.reset();
  std::string summary;  // what rank 0 adds up (label voxels): a failure to make it fails the rank
  if (!error && options.rankSummary) {
    try {
      summary = options.rankSummary();
    } catch (...) {
      error = std::current_exception();
    }
  }
  MessageWriter last(error ? Message::kFailed : Message::kEnd);
  if (error) {
    last.putString(messageOf(error));
  } else {
    const auto r = values.range();
    last.put(static_cast<std::uint8_t>(r.has_value()));
    last.put(static_cast<float>(r ? (*r)[0] : 0.0));  // floats' bounds: exact
    last.put(static_cast<float>(r ? (*r)[1] : 0.0));
    last.put(result.readSeconds);
    last.put(result.extractSeconds);
    std::vector<std::string> warnings;
    try {
      warnings = source.warnings();
    } catch (...) {
      // a reader that cannot finish its count has nothing to add
    }
    last.put(static_cast<std::uint64_t>(warnings.size()));
    for (const std::string& w : warnings) last.putString(w);
    last.putString(summary);
  }
  group.send(0, last.bytes());
  const std::vector<std::byte> outcome = group.receive(0);
  MessageReader r(outcome);
  if (r.type() != Message::kOk) {
    group.setFailureShared();
    throw RankFailed(r.get<std::int32_t>());
  }
  result.totalSeconds = since(start);
  return result;
}

// Rank 0: extracts and emits its own range, then the other ranks' runs in rank order, and tells
// every rank the outcome. The first failure (its own, or the lowest rank's) is the one reported.
// size-exception: one sequence (own range, then each rank's runs in order, then the shared
// outcome) whose error paths must stay beside the happy path that they unwind.
PipelineResult runRankZero(RankGroup& group, SliceSource& source, Extractor& extractor, MeshSink& sink,
                           const MeshHeader& header, const PipelineOptions& options) {
  const auto start = Clock::now();
  const SlabRange range = rankSlabs(source.info().dims[2] - 1, 0, group.size());
  std::exception_ptr error;
  std::int32_t failedRank = -1;
  std::optional<PipelineRun> run;
  auto attempt = [&](auto&& fn) {
    if (error) return;
    try {
      fn();
    } catch (...) {
      error = std::current_exception();
      failedRank = 0;
    }
  };
  attempt([&] {
    run.emplace(source, extractor, sink, options, range);
    auto t = Clock::now();
    sink.begin(header);
    run->result().writeSeconds += since(t);
    run->startStitching();
    if (range.end > range.first) run->runThreaded();
  });
  SlabPart part;
  for (int q = 1; q < group.size(); ++q) {
    for (bool more = true; more;) {
      const std::vector<std::byte> m = group.receive(q);
      MessageReader r(m);
      switch (r.type()) {
        case Message::kPart:
          attempt([&] {
            readPart(r, part);
            run->emitRun(part);
          });
          break;
        case Message::kEnd:
          attempt([&] {
            const bool hasRange = r.get<std::uint8_t>() != 0;
            const std::array<float, 2> bounds{r.get<float>(), r.get<float>()};
            if (hasRange) run->values().add(bounds.data(), 2);
            run->result().readSeconds += r.get<double>();
            run->result().extractSeconds += r.get<double>();
            const auto warnings = r.get<std::uint64_t>();
            for (std::uint64_t k = 0; k < warnings; ++k) run->result().rankWarnings.push_back(r.getString());
            const std::string summary = r.getString();
            if (options.mergeRankSummary) options.mergeRankSummary(q, summary);
          });
          more = false;
          break;
        case Message::kFailed:
          if (!error) {
            std::string text = fmt::format("rank {} failed", q);
            try {
              text = r.getString();
            } catch (const Error&) {
              // a truncated message: the rank's number is all there is
            }
            error = std::make_exception_ptr(Error(text));
            failedRank = q;
          }
          more = false;
          break;
        default:
          attempt([&] { throw Error(fmt::format("rank {} sent a message that is not part of the protocol", q)); });
          more = false;
      }
    }
  }
  attempt([&] {
    run->result().valueRange = run->valueRange();
    const auto t = Clock::now();
    sink.finish();
    run->result().writeSeconds += since(t);
  });
  for (int q = 1; q < group.size(); ++q) {
    MessageWriter w(error ? Message::kStop : Message::kOk);
    w.put(failedRank);
    group.send(q, w.bytes());
  }
  if (error) {
    group.setFailureShared();
    std::rethrow_exception(error);
  }
  run->finishProgress();
  PipelineResult result = run->result();
  result.totalSeconds = since(start);
  return result;
}

}  // namespace

SlabRange rankSlabs(std::int64_t slabs, int rank, int ranks) noexcept {
  const std::int64_t n = std::max(1, ranks);
  auto at = [&](std::int64_t r) { return slabs * r / n; };
  return {at(rank), at(rank + 1)};
}

PipelineResult runPipeline(SliceSource& source, Extractor& extractor, MeshSink& sink, const MeshHeader& header,
                           const PipelineOptions& options) {
  if (options.ranks != nullptr && options.ranks->size() > 1) {
    RankGroup& group = *options.ranks;
    if (const int failed = group.agree(true); failed >= 0) {
      group.setFailureShared();
      throw RankFailed(failed);
    }
    try {
      if (group.rank() > 0) return runRank(group, source, extractor, options);
      return runRankZero(group, source, extractor, sink, header, options);
    } catch (...) {
      // A failure the protocol carried has been shared; anything else (the transport, memory
      // for a message) leaves ranks waiting for this one: end them all.
      if (!group.failureShared()) group.abort(1);
      throw;
    }
  }
  const auto start = Clock::now();
  PipelineRun run(source, extractor, sink, options);
  PipelineResult& result = run.result();
  auto t = Clock::now();
  sink.begin(header);
  result.writeSeconds += since(t);
  if (run.staged()) {
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
