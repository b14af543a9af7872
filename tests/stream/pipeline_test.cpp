#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <condition_variable>
#include <deque>
#include <limits>
#include <map>
#include <mutex>
#include <new>
#include <thread>

#include "core/error.h"
#include "extract/frame.h"
#include "extract/slab_stitcher.h"
#include "stream/pipeline.h"
#include "stream/rank_group.h"
#include "test_support.h"

namespace isoslab {
namespace {

// A sink that checks the streaming contract: chunks in slab order, dense ids, triangles that use
// only the current and the previous chunk.
class ContractSink final : public MeshSink {
 public:
  void begin(const MeshHeader&) override { began = true; }
  void consume(const MeshChunk& c) override {
    EXPECT_EQ(c.slab, chunks);
    EXPECT_EQ(c.firstVertex, next);
    EXPECT_EQ(c.boundary.size(), c.positions.size());
    for (const Triangle& t : c.triangles) {
      for (VertexId v : t) {
        EXPECT_LT(v, c.endVertex());
        EXPECT_GE(v, previousFirst);
      }
    }
    previousFirst = c.firstVertex;
    next = c.endVertex();
    ++chunks;
  }
  void finish() override { finished = true; }
  bool began = false, finished = false;
  std::int64_t chunks = 0;
  VertexId next = 0, previousFirst = 0;
};

TEST(Pipeline, StreamsOneChunkPerSlabAndHonoursTheContract) {
  for (Method m : testing::kAllMethods) {
    for (bool normals : {false, true}) {
      testing::VectorSource source({17, 15, 13}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
        return static_cast<float>((i * 7 + j * 13 + k * 5) % 11);
      });
      ExtractOptions o;
      o.method = m;
      o.iso = 5;
      o.normals = normals;
      auto ex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
      ContractSink sink;
      const PipelineResult r = runPipeline(source, *ex, sink, MeshHeader{});
      EXPECT_TRUE(sink.began && sink.finished);
      EXPECT_EQ(sink.chunks, 12);
      EXPECT_EQ(source.slicesRead(), 13);
      EXPECT_GT(r.triangles, 0u);
      EXPECT_EQ(r.vertices, sink.next);
      // The ring holds at most four slices.
      EXPECT_LE(r.ringBytes, 4u * 17 * 15 * sizeof(float));
      if (!normals && m != Method::kBcc12) {
        EXPECT_EQ(r.ringBytes, 2u * 17 * 15 * sizeof(float));
      }
    }
  }
}

class ShortSource final : public SliceSource {
 public:
  ShortSource() {
    info_.dims = {4, 4, 10};
    info_.source = "short";
  }
  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> s) override {
    std::fill(s.begin(), s.end(), 0.0f);
    return n_++ < 3;
  }

 private:
  VolumeInfo info_;
  int n_ = 0;
};

// An extractor whose kernels run out of memory on slab 2: the error reaches the caller from the
// calling thread and from the workers alike (a noexcept kernel would call std::terminate).
class OutOfMemoryExtractor final : public Extractor {
 public:
  explicit OutOfMemoryExtractor(std::unique_ptr<Extractor> inner) : inner_(std::move(inner)) {}
  int slicesBelow() const noexcept override { return inner_->slicesBelow(); }
  int slicesAbove() const noexcept override { return inner_->slicesAbove(); }
  void extractSlab(const SlabView& slab, MeshChunk& out) override {
    if (slab.z == 2) throw std::bad_alloc();
    inner_->extractSlab(slab, out);
  }
  std::uint64_t vertexCount() const noexcept override { return inner_->vertexCount(); }
  void classifySlice(const float* slice, std::vector<RowSpan>& rows) const override {
    inner_->classifySlice(slice, rows);
  }
  bool cellVolumes() const noexcept override { return inner_->cellVolumes(); }
  std::size_t sliceSlots() const noexcept override { return inner_->sliceSlots(); }
  std::unique_ptr<SlabWorker> makeWorker() const override {
    struct Worker final : SlabWorker {
      std::unique_ptr<SlabWorker> inner;
      void extract(std::span<const SlabView> slabs, SlabPart& out,
                   const std::function<void(const SlabView&)>& before) override {
        for (const SlabView& slab : slabs) {
          if (slab.z == 2) throw std::bad_alloc();
        }
        inner->extract(slabs, out, before);
      }
    };
    auto w = std::make_unique<Worker>();
    w->inner = inner_->makeWorker();
    return w;
  }

 private:
  std::unique_ptr<Extractor> inner_;
};

TEST(Pipeline, OutOfMemoryInAKernelReachesTheCaller) {
  for (int threads : {1, 3}) {
    testing::VectorSource source({6, 6, 8}, [](std::int64_t i, std::int64_t, std::int64_t) { return float(i); });
    OutOfMemoryExtractor ex(
        makeExtractor(ExtractOptions{Method::kMarchingCubes, 2.5}, source.info(), LatticeFrame::voxel()));
    MemoryMeshSink sink;
    PipelineOptions p;
    p.threads = threads;
    p.sequentialVoxels = 0;  // threads even on a small volume
    EXPECT_THROW(runPipeline(source, ex, sink, MeshHeader{}, p), std::bad_alloc) << threads << " threads";
  }
}

TEST(Pipeline, ASourceThatEndsEarlyIsAnError) {
  for (int threads : {1, 3}) {
    ShortSource source;
    ExtractOptions o;
    auto ex = makeExtractor(o, source.info(), LatticeFrame::voxel());
    MemoryMeshSink sink;
    PipelineOptions p;
    p.threads = threads;
    p.sequentialVoxels = 0;  // threads even on a small volume
    try {
      runPipeline(source, *ex, sink, MeshHeader{}, p);
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), "short: the data ended after 3 of 10 slices");
    }
  }
}

// Keeps every chunk as delivered.
class RecordingSink final : public MeshSink {
 public:
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& c) override { chunks.push_back(c); }
  void finish() override { finished = true; }
  std::vector<MeshChunk> chunks;
  bool finished = false;
};

bool sameChunk(const MeshChunk& a, const MeshChunk& b) {
  return a.slab == b.slab && a.firstVertex == b.firstVertex && a.positions == b.positions && a.normals == b.normals &&
         a.boundary == b.boundary && a.triangles == b.triangles && a.cellVolume == b.cellVolume;
}

// Parallel extraction (detached workers and the stitcher) must reproduce the sequential chunks
// exactly, ids included, for every method. Small integer fields make values equal to the iso value
// common, the hardest case for agreeing on which edges are crossed.
TEST(Pipeline, ThreadsDeliverTheSameChunks) {
  for (Method m : testing::kAllMethods) {
    for (int field = 0; field < 3; ++field) {
      std::vector<MeshChunk> first;
      // Threads 1, 2, 3 and 4, then 1, 2 and 4 again with a source that lends its slices.
      for (int run = 0; run < 7; ++run) {
        const int threads = run < 4 ? run + 1 : (run == 4 ? 1 : (run == 5 ? 2 : 4));
        testing::VectorSource source({19, 17, 23}, [field](std::int64_t i, std::int64_t j, std::int64_t k) {
          if (field == 0) return static_cast<float>((i * 31 + j * 17 + k * 7) % 13);
          if (field == 1) return static_cast<float>((i * i + 3 * j + k * k * j) % 5);
          const double r =
              std::hypot(static_cast<double>(i) - 9.0, static_cast<double>(j) - 8.0, static_cast<double>(k) - 11.0);
          return static_cast<float>(std::round(r));
        });
        source.setLending(run >= 4);
        ExtractOptions o;
        o.method = m;
        o.iso = field == 2 ? 7 : (field == 0 ? 6 : 2);
        o.normals = field != 1;
        auto ex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
        RecordingSink sink;
        PipelineOptions p;
        p.threads = threads;
        p.sequentialVoxels = 0;
        // Runs of 1 slab (field 0), 3 slabs (field 1), and the default, as long as 4 runs a worker
        // allow (5 slabs with 1 worker... 1 with 4).
        p.runVoxels = field == 0 ? 1 : (field == 1 ? 3 * 19 * 17 : p.runVoxels);
        // Run 5 (2 threads, lending) shortens its runs to one slab after the first, by the
        // triangles of the slabs emitted.
        if (run == 5) p.runTriangles = 1;
        const PipelineResult r = runPipeline(source, *ex, sink, MeshHeader{}, p);
        EXPECT_EQ(r.workers, threads);
        if (threads > 1) {
          EXPECT_EQ(r.runSlabs, std::min<std::int64_t>(field == 0 ? 1 : (field == 1 ? 3 : 22), 22 / (4 * threads)));
        }
        // Slab z needs at most slices z-1 .. z+2; with workers, N + 1 runs are in flight.
        const std::int64_t depth = threads > 1 ? (threads + 1) * r.runSlabs : 1;
        EXPECT_LE(r.ringBytes, static_cast<std::size_t>(3 + depth) * 19 * 17 * sizeof(float));
        ASSERT_EQ(sink.chunks.size(), 22u);
        if (run == 0) {
          first = std::move(sink.chunks);
          std::size_t triangles = 0;
          for (const auto& c : first) triangles += c.triangles.size();
          EXPECT_GT(triangles, 500u) << methodName(m) << " field " << field;
          continue;
        }
        for (std::size_t z = 0; z < first.size(); ++z) {
          EXPECT_TRUE(sameChunk(first[z], sink.chunks[z])) << methodName(m) << " field " << field << " threads "
                                                           << threads << " lending " << (run >= 4) << " slab " << z;
        }
      }
    }
  }
}

// Ranks as threads of one process (the protocol of stream/rank_group.h without MPI): a mailbox per
// pair of ranks, and agree() as a reduction that every rank waits for.
class ThreadRanks {
 public:
  explicit ThreadRanks(int size) : size_(size) {}

  class Member final : public RankGroup {
   public:
    Member(ThreadRanks& all, int rank) : all_(all), rank_(rank) {}
    int rank() const noexcept override { return rank_; }
    int size() const noexcept override { return all_.size_; }
    void send(int to, std::span<const std::byte> message) override {
      std::lock_guard lock(all_.mutex_);
      all_.boxes_[{rank_, to}].emplace_back(message.begin(), message.end());
      all_.changed_.notify_all();
    }
    std::vector<std::byte> receive(int from) override {
      std::unique_lock lock(all_.mutex_);
      auto& box = all_.boxes_[{from, rank_}];
      all_.changed_.wait(lock, [&] { return !box.empty(); });
      std::vector<std::byte> m = std::move(box.front());
      box.pop_front();
      return m;
    }
    [[noreturn]] void abort(int) override { std::abort(); }
    int agree(bool ok) override {
      std::unique_lock lock(all_.mutex_);
      const std::int64_t round = all_.round_;
      if (!ok) all_.lowest_ = std::min(all_.lowest_, rank_);
      if (++all_.arrived_ == all_.size_) {
        all_.result_ = all_.lowest_ == std::numeric_limits<int>::max() ? -1 : all_.lowest_;
        all_.arrived_ = 0;
        all_.lowest_ = std::numeric_limits<int>::max();
        ++all_.round_;
        all_.changed_.notify_all();
      } else {
        all_.changed_.wait(lock, [&] { return all_.round_ != round; });
      }
      return all_.result_;
    }

   private:
    ThreadRanks& all_;
    int rank_;
  };

 private:
  int size_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::pair<int, int>, std::deque<std::vector<std::byte>>> boxes_;
  int arrived_ = 0;
  int lowest_ = std::numeric_limits<int>::max();
  int result_ = -1;
  std::int64_t round_ = 0;
};

// A source whose slice `bad` cannot be read.
class FailingSource final : public SliceSource {
 public:
  FailingSource(std::unique_ptr<SliceSource> inner, std::int64_t bad) : inner_(std::move(inner)), bad_(bad) {}
  const VolumeInfo& info() const noexcept override { return inner_->info(); }
  bool readSlice(std::span<float> slice) override {
    if (next_++ == bad_) throw Error(fmt::format("slice{}.raw: cannot read: Input/output error", bad_));
    return inner_->readSlice(slice);
  }

 private:
  std::unique_ptr<SliceSource> inner_;
  std::int64_t bad_;
  std::int64_t next_ = 0;
};

float rankField(std::int64_t i, std::int64_t j, std::int64_t k) {
  return static_cast<float>((i * 31 + j * 17 + k * 7) % 13);
}

// Every rank count (2, 3 and 5 ranks on 22 slabs; 30 ranks, more than slabs, so that some ranks
// have none), with one and two threads a rank, gives rank 0's sink the chunks of one process; the
// other ranks' sinks get nothing; the value range covers every rank's slices.
TEST(Pipeline, RanksDeliverTheChunksOfOneProcess) {
  for (Method m : testing::kAllMethods) {
    ExtractOptions o;
    o.method = m;
    o.iso = 6;
    o.normals = true;
    testing::VectorSource whole({19, 17, 23}, rankField);
    auto ex = makeExtractor(o, whole.info(), LatticeFrame::physical(whole.info()));
    RecordingSink expected;
    const PipelineResult single = runPipeline(whole, *ex, expected, MeshHeader{});
    ASSERT_EQ(expected.chunks.size(), 22u);
    for (const int size : {2, 3, 5, 30}) {
      for (const int threads : {1, 2}) {
        ThreadRanks all(size);
        std::vector<RecordingSink> sinks(static_cast<std::size_t>(size));
        std::vector<PipelineResult> results(static_cast<std::size_t>(size));
        std::vector<std::thread> ranks;
        for (int r = 0; r < size; ++r) {
          ranks.emplace_back([&, r] {
            ThreadRanks::Member me(all, r);
            testing::VectorSource source({19, 17, 23}, rankField);
            source.setLending(r % 2 == 1);
            auto rex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
            PipelineOptions p;
            p.threads = threads;
            p.sequentialVoxels = 0;
            p.runVoxels = 2 * 19 * 17;
            p.ranks = &me;
            results[static_cast<std::size_t>(r)] =
                runPipeline(source, *rex, sinks[static_cast<std::size_t>(r)], MeshHeader{}, p);
          });
        }
        for (auto& t : ranks) t.join();
        const std::string what = fmt::format("{} on {} ranks, {} threads", methodName(m), size, threads);
        ASSERT_EQ(sinks[0].chunks.size(), 22u) << what;
        for (std::size_t z = 0; z < 22; ++z)
          EXPECT_TRUE(sameChunk(expected.chunks[z], sinks[0].chunks[z])) << what << " slab " << z;
        for (std::size_t r = 1; r < sinks.size(); ++r) EXPECT_TRUE(sinks[r].chunks.empty()) << what;
        EXPECT_EQ(results[0].vertices, single.vertices) << what;
        EXPECT_EQ(results[0].triangles, single.triangles) << what;
        EXPECT_EQ(results[0].valueRange, single.valueRange) << what;
      }
    }
  }
}

// A slice that fails on one rank: rank 0 throws that rank's error, every other rank RankFailed,
// and rank 0's sink is never finished.
TEST(Pipeline, ARankThatFailsStopsEveryRank) {
  for (const int bad : {1, 12, 22}) {  // rank 0's range, rank 1's, rank 2's (of 3)
    ThreadRanks all(3);
    std::vector<RecordingSink> sinks(3);
    std::vector<std::string> errors(3);
    std::vector<int> failedRank(3, -2);
    std::vector<std::thread> ranks;
    for (int r = 0; r < 3; ++r) {
      ranks.emplace_back([&, r] {
        ThreadRanks::Member me(all, r);
        auto inner = std::make_unique<testing::VectorSource>(std::array<std::int64_t, 3>{19, 17, 23}, rankField);
        FailingSource source(std::move(inner), bad);
        ExtractOptions o;
        o.iso = 6;
        auto ex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
        PipelineOptions p;
        p.ranks = &me;
        try {
          runPipeline(source, *ex, sinks[static_cast<std::size_t>(r)], MeshHeader{}, p);
        } catch (const RankFailed& e) {
          failedRank[static_cast<std::size_t>(r)] = e.failedRank();
          EXPECT_TRUE(me.failureShared());
        } catch (const Error& e) {
          errors[static_cast<std::size_t>(r)] = e.what();
          EXPECT_TRUE(me.failureShared());
        }
      });
    }
    for (auto& t : ranks) t.join();
    // Ranges of slabs 0..6, 7..13 and 14..21, reading slices up to 7, 14 and 22. The source skips by
    // reading, so the higher ranks meet a low bad slice too; rank 0 reports the lowest rank's.
    const int owner = bad <= 7 ? 0 : (bad <= 14 ? 1 : 2);
    EXPECT_EQ(errors[0], fmt::format("slice{}.raw: cannot read: Input/output error", bad)) << "bad slice " << bad;
    for (int r = 1; r < 3; ++r) {
      EXPECT_EQ(failedRank[static_cast<std::size_t>(r)], owner) << "bad slice " << bad << " rank " << r;
      EXPECT_EQ(errors[static_cast<std::size_t>(r)], "") << "bad slice " << bad << " rank " << r;
    }
    EXPECT_FALSE(sinks[0].finished) << "bad slice " << bad;
  }
}

// The inside volume per tetrahedron is optional and changes nothing else.
TEST(Pipeline, CellVolumesAreOptional) {
  std::vector<MeshChunk> with, without;
  for (bool cellVolumes : {true, false}) {
    testing::VectorSource source({16, 16, 16}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
      return static_cast<float>(
          std::hypot(static_cast<double>(i) - 7.5, static_cast<double>(j) - 7.0, static_cast<double>(k) - 8.0));
    });
    ExtractOptions o;
    o.method = Method::kTetra6;
    o.iso = 5;
    o.cellVolumes = cellVolumes;
    auto ex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
    EXPECT_EQ(ex->cellVolumes(), cellVolumes);
    RecordingSink sink;
    runPipeline(source, *ex, sink, MeshHeader{});
    (cellVolumes ? with : without) = std::move(sink.chunks);
  }
  ASSERT_EQ(with.size(), without.size());
  double volume = 0;
  for (std::size_t z = 0; z < with.size(); ++z) {
    volume += with[z].cellVolume;
    EXPECT_EQ(without[z].cellVolume, 0.0);
    without[z].cellVolume = with[z].cellVolume;
    EXPECT_TRUE(sameChunk(with[z], without[z])) << "slab " << z;
  }
  // The volume outside the sphere of radius 5 (values >= iso are inside): 15^3 - 4/3 pi 5^3.
  EXPECT_NEAR(volume, 15.0 * 15.0 * 15.0 - 4.0 / 3.0 * M_PI * 125.0, 15.0);
}

class FailingSink final : public MeshSink {
 public:
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& c) override {
    if (c.slab == 5) throw Error("disk full");
  }
  void finish() override { finished = true; }
  bool finished = false;
};

// An error in the sink (in the emit stage, on any thread, when threaded) reaches the caller, whatever the
// thread count, and nothing hangs. (Source errors: ASourceThatEndsEarlyIsAnError.)
TEST(Pipeline, ErrorsOnOtherThreadsReachTheCaller) {
  for (int threads : {1, 2, 4}) {
    testing::VectorSource source({12, 11, 30}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
      return static_cast<float>((i + 2 * j + 3 * k) % 7);
    });
    ExtractOptions o;
    o.iso = 3;
    auto ex = makeExtractor(o, source.info(), LatticeFrame::voxel());
    FailingSink sink;
    PipelineOptions p;
    p.threads = threads;
    p.sequentialVoxels = 0;  // threads even on a small volume
    try {
      runPipeline(source, *ex, sink, MeshHeader{}, p);
      ADD_FAILURE() << "no error with " << threads << " threads";
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), "disk full");
    }
    EXPECT_FALSE(sink.finished);
  }
}

TEST(Pipeline, TracksTheValueRangeOfEverySliceSkippingNaN) {
  for (int threads : {1, 3}) {
    for (bool lending : {false, true}) {
      testing::VectorSource source({6, 5, 7}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
        if (i == 2 && j == 3) return std::numeric_limits<float>::quiet_NaN();
        return static_cast<float>(i * 10 + j - k * 100);
      });
      source.setLending(lending);
      ExtractOptions o;
      o.iso = 5000;
      auto ex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
      ContractSink sink;
      PipelineOptions p;
      p.threads = threads;
      p.sequentialVoxels = 0;  // threads even on a small volume
      const PipelineResult r = runPipeline(source, *ex, sink, MeshHeader{}, p);
      EXPECT_EQ(r.triangles, 0u);
      ASSERT_TRUE(r.valueRange.has_value()) << threads << " " << lending;
      EXPECT_EQ((*r.valueRange)[0], -600.0);  // i = j = 0, k = 6
      EXPECT_EQ((*r.valueRange)[1], 54.0);    // i = 5, j = 4, k = 0
    }
  }
  testing::VectorSource nan({3, 3, 3}, std::vector<float>(27, std::numeric_limits<float>::quiet_NaN()));
  auto ex = makeExtractor(ExtractOptions{}, nan.info(), LatticeFrame::physical(nan.info()));
  ContractSink sink;
  EXPECT_FALSE(runPipeline(nan, *ex, sink, MeshHeader{}).valueRange.has_value());
}

TEST(SlabStitcher, RejectsPartsOutOfOrder) {
  testing::VectorSource source({5, 5, 5}, [](std::int64_t, std::int64_t, std::int64_t) { return 0.0f; });
  auto ex = makeExtractor(ExtractOptions{}, source.info(), LatticeFrame::voxel());
  SlabStitcher stitcher(ex->sliceSlots());
  SlabPart part;
  part.chunks.resize(1);
  part.chunks[0].slab = 1;
  try {
    stitcher.stitch(part);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "internal error: slab 1 stitched after slab -1");
  }
}

}  // namespace
}  // namespace isoslab
