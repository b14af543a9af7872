#include <gtest/gtest.h>

#include "extract/frame.h"
#include "io/error.h"
#include "stream/pipeline.h"
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

TEST(Pipeline, ASourceThatEndsEarlyIsAnError) {
  for (int threads : {1, 3}) {
    ShortSource source;
    ExtractOptions o;
    auto ex = makeExtractor(o, source.info(), LatticeFrame::voxel());
    MemoryMeshSink sink;
    PipelineOptions p;
    p.threads = threads;
    try {
      runPipeline(source, *ex, sink, MeshHeader{}, p);
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_STREQ(e.what(), "short: the data ended after 3 of 10 slices");
    }
  }
}

TEST(Pipeline, ThreadsDeliverTheSameChunks) {
  std::vector<IndexedMesh> meshes;
  for (int threads : {1, 2, 4}) {
    testing::VectorSource source({19, 17, 23}, [](std::int64_t i, std::int64_t j, std::int64_t k) {
      return static_cast<float>((i * 31 + j * 17 + k * 7) % 13);
    });
    ExtractOptions o;
    o.method = Method::kBcc12;
    o.iso = 6;
    o.normals = true;
    auto ex = makeExtractor(o, source.info(), LatticeFrame::physical(source.info()));
    MemoryMeshSink sink;
    PipelineOptions p;
    p.threads = threads;
    runPipeline(source, *ex, sink, MeshHeader{}, p);
    meshes.push_back(sink.mesh());
  }
  EXPECT_GT(meshes[0].triangles.size(), 1000u);
  EXPECT_TRUE(meshes[0] == meshes[1]);
  EXPECT_TRUE(meshes[0] == meshes[2]);
}

}  // namespace
}  // namespace isoslab
