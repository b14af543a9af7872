#include "process/smoothing.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <set>
#include <tuple>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "extract/frame.h"
#include "io/pad_source.h"
#include "stream/pipeline.h"
#include "test_support.h"

namespace isoslab {
namespace {

using Vec3d = std::array<double, 3>;
using Field = std::function<float(std::int64_t, std::int64_t, std::int64_t)>;

struct Extracted {
  MeshHeader header;
  std::vector<MeshChunk> chunks;
  IndexedMesh mesh;
};

class Recorder final : public MeshSink {
 public:
  void begin(const MeshHeader& h) override { header = h; }
  void consume(const MeshChunk& c) override { chunks.push_back(c); }
  void finish() override {}
  MeshHeader header;
  std::vector<MeshChunk> chunks;
};

Extracted extractChunks(const Field& field, std::array<std::int64_t, 3> dims, Method method, double iso,
                        bool closeBoundary = false, bool normals = true) {
  ExtractOptions options;
  options.method = method;
  options.iso = iso;
  options.normals = normals;
  options.closeBoundary = closeBoundary;
  std::unique_ptr<SliceSource> source = std::make_unique<testing::VectorSource>(dims, field);
  const VolumeInfo info = source->info();
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  if (closeBoundary) source = std::make_unique<PadSource>(std::move(source));
  Recorder recorder;
  MemoryMeshSink memory;
  TeeSink tee({&recorder, &memory});
  runPipeline(*source, *extractor, tee, header, PipelineOptions{});
  return {header, recorder.chunks, memory.mesh()};
}

IndexedMesh smoothStreamed(const Extracted& x, const SmoothOptions& options) {
  MemoryMeshSink memory;
  SmoothingSink smooth(memory, options);
  smooth.begin(x.header);
  for (const MeshChunk& c : x.chunks) smooth.consume(c);
  smooth.finish();
  EXPECT_LE(smooth.peakChunks(), static_cast<std::size_t>(options.iterations) + 3);
  return memory.mesh();
}

// The reference: the whole mesh in memory, neighbour sets, every iteration over every vertex.
// Taubin's steps are written out here; sinc takes the library's coefficients (VTK checks those:
// tests/process/vtk_sinc_check.py).
IndexedMesh smoothWhole(const IndexedMesh& mesh, const MeshHeader& header, const SmoothOptions& o) {
  const std::size_t n = mesh.positions.size();
  std::vector<std::set<VertexId>> neighbours(n);
  for (const Triangle& t : mesh.triangles) {
    for (std::size_t k = 0; k < 3; ++k) {
      neighbours[t[k]].insert(t[(k + 1) % 3]);
      neighbours[t[(k + 1) % 3]].insert(t[k]);
    }
  }
  std::vector<Vec3d> origin(n);
  for (std::size_t v = 0; v < n; ++v) origin[v] = {mesh.positions[v].x, mesh.positions[v].y, mesh.positions[v].z};
  const auto constrain = [&](std::size_t v, Vec3d p) -> Vec3d {
    const unsigned bits = mesh.boundary.empty() ? 0u : mesh.boundary[v];
    if (bits == 0) return p;
    if (o.faces == FaceVertices::kLock || std::popcount(bits) >= 3) return origin[v];
    std::vector<Vec3d> normals;
    for (std::size_t f = 0; f < 6; ++f) {
      if (bits & (1u << f)) {
        const auto& plane = (*header.volumeFaces)[f];
        normals.push_back({plane[0], plane[1], plane[2]});
      }
    }
    Vec3d d{p[0] - origin[v][0], p[1] - origin[v][1], p[2] - origin[v][2]};
    if (normals.size() == 1) {
      const double along = d[0] * normals[0][0] + d[1] * normals[0][1] + d[2] * normals[0][2];
      for (std::size_t k = 0; k < 3; ++k) p[k] -= along * normals[0][k];
      return p;
    }
    const Vec3d& a = normals[0];
    const Vec3d& b = normals[1];
    Vec3d t{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    const double len = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    const double along = (d[0] * t[0] + d[1] * t[1] + d[2] * t[2]) / (len * len);
    for (std::size_t k = 0; k < 3; ++k) p[k] = origin[v][k] + along * t[k];
    return p;
  };
  SmoothRecurrence r = smoothRecurrence(o);
  if (o.method == SmoothMethod::kTaubin) {
    const double mu = 1.0 / (o.passBand - 1.0 / o.lambda);
    for (int i = 0; i < o.iterations; ++i) {
      r.a[i] = 1;
      r.b[i] = i % 2 == 0 ? o.lambda : mu;
      r.c[i] = 0;
    }
  }
  std::vector<Vec3d> previous = origin, current = origin, sum(n);
  for (std::size_t v = 0; v < n; ++v) {
    for (std::size_t k = 0; k < 3; ++k) sum[v][k] = r.w[0] * origin[v][k];
  }
  for (int i = 0; i < o.iterations; ++i) {
    std::vector<Vec3d> next(n);
    for (std::size_t v = 0; v < n; ++v) {
      Vec3d lap{0, 0, 0};
      for (VertexId u : neighbours[v]) {
        for (std::size_t k = 0; k < 3; ++k) lap[k] += current[u][k];
      }
      if (!neighbours[v].empty()) {
        for (std::size_t k = 0; k < 3; ++k) lap[k] = lap[k] / double(neighbours[v].size()) - current[v][k];
      }
      for (std::size_t k = 0; k < 3; ++k)
        next[v][k] = r.a[i] * current[v][k] + r.b[i] * lap[k] + r.c[i] * previous[v][k];
      next[v] = constrain(v, next[v]);
    }
    previous = current;
    current = next;
    for (std::size_t v = 0; v < n; ++v) {
      for (std::size_t k = 0; k < 3; ++k) sum[v][k] += r.w[i + 1] * current[v][k];
    }
  }
  IndexedMesh out = mesh;
  const std::vector<Vec3d>& result = o.method == SmoothMethod::kSinc ? sum : current;
  for (std::size_t v = 0; v < n; ++v) {
    const Vec3d p = constrain(v, result[v]);
    out.positions[v] = {float(p[0]), float(p[1]), float(p[2])};
  }
  // Area-weighted normals of the smoothed mesh.
  std::vector<Vec3d> normal(n, Vec3d{0, 0, 0});
  for (const Triangle& t : out.triangles) {
    const Vec3f& p0 = out.positions[t[0]];
    const Vec3f& p1 = out.positions[t[1]];
    const Vec3f& p2 = out.positions[t[2]];
    const Vec3d e1{double(p1.x) - p0.x, double(p1.y) - p0.y, double(p1.z) - p0.z};
    const Vec3d e2{double(p2.x) - p0.x, double(p2.y) - p0.y, double(p2.z) - p0.z};
    const Vec3d c{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    for (VertexId v : t) {
      for (std::size_t k = 0; k < 3; ++k) normal[v][k] += c[k];
    }
  }
  for (std::size_t v = 0; v < n && !out.normals.empty(); ++v) {
    const double len =
        std::sqrt(normal[v][0] * normal[v][0] + normal[v][1] * normal[v][1] + normal[v][2] * normal[v][2]);
    if (len > 0) out.normals[v] = {float(normal[v][0] / len), float(normal[v][1] / len), float(normal[v][2] / len)};
  }
  return out;
}

void expectClose(const IndexedMesh& expected, const IndexedMesh& actual, double tolerance) {
  ASSERT_EQ(expected.positions.size(), actual.positions.size());
  ASSERT_TRUE(expected.triangles == actual.triangles);
  double worst = 0, worstNormal = 0;
  for (std::size_t v = 0; v < expected.positions.size(); ++v) {
    const Vec3f& a = expected.positions[v];
    const Vec3f& b = actual.positions[v];
    worst = std::max({worst, std::abs(double(a.x) - b.x), std::abs(double(a.y) - b.y), std::abs(double(a.z) - b.z)});
    if (expected.normals.empty()) continue;
    const Vec3f& na = expected.normals[v];
    const Vec3f& nb = actual.normals[v];
    worstNormal = std::max(
        {worstNormal, std::abs(double(na.x) - nb.x), std::abs(double(na.y) - nb.y), std::abs(double(na.z) - nb.z)});
  }
  EXPECT_LE(worst, tolerance);
  EXPECT_LE(worstNormal, 1e-4);
}

// A lumpy torus lying across many slabs, and a noisy field (many small parts): every vertex has
// neighbours in the chunks on either side.
Field lumpyTorus() {
  return [](std::int64_t i, std::int64_t j, std::int64_t k) {
    const double x = double(i) - 15.3, y = double(j) - 14.1, z = double(k) - 16.2;
    const double ring = std::hypot(std::hypot(x, z) - 9.0, y);
    return static_cast<float>(4.5 - ring + 0.6 * std::sin(0.9 * x) * std::cos(0.7 * z));
  };
}

TEST(Smoothing, StreamedEqualsTheWholeMeshFilter) {
  // With normals, a chunk leaves one chunk later (its normals need the next chunk's triangles).
  for (bool normals : {true, false}) {
    const Extracted x = extractChunks(lumpyTorus(), {32, 30, 34}, Method::kMarchingCubes, 0.0, false, normals);
    ASSERT_GT(x.chunks.size(), 20u);
    for (SmoothMethod method : {SmoothMethod::kTaubin, SmoothMethod::kSinc}) {
      for (int n : {1, 5, 20}) {
        SCOPED_TRACE(std::string(method == SmoothMethod::kSinc ? "sinc " : "taubin ") + std::to_string(n) +
                     (normals ? " normals" : ""));
        SmoothOptions o;
        o.method = method;
        o.iterations = n;
        const IndexedMesh streamed = smoothStreamed(x, o);
        expectClose(smoothWhole(x.mesh, x.header, o), streamed, 1e-6);
        // It moved: nearly every vertex (a few lie where their neighbours' mean is).
        std::size_t moved = 0;
        for (std::size_t v = 0; v < streamed.positions.size(); ++v)
          moved += streamed.positions[v] == x.mesh.positions[v] ? 0 : 1;
        EXPECT_GT(moved, streamed.positions.size() * 9 / 10);
      }
    }
  }
}

TEST(Smoothing, EveryMethodAndCappedFacesSlideOrLock) {
  // A ball cut by three faces of the volume (centre near a corner), capped: cap vertices lie on the
  // faces, some on two faces (the volume's edges) and the corner's on three.
  const Field ball = [](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<float>(11.0 - std::hypot(double(i) - 2.5, double(j) - 3.5, double(k) - 1.5));
  };
  for (Method method : kMethods) {
    SCOPED_TRACE(std::string(methodName(method)));
    const Extracted x = extractChunks(ball, {20, 21, 22}, method, 0.0, true);
    for (FaceVertices faces : {FaceVertices::kSlide, FaceVertices::kLock}) {
      SmoothOptions o;
      o.iterations = 10;
      o.faces = faces;
      const IndexedMesh streamed = smoothStreamed(x, o);
      expectClose(smoothWhole(x.mesh, x.header, o), streamed, 1e-5);
      std::size_t onFaces = 0, moved = 0;
      for (std::size_t v = 0; v < streamed.positions.size(); ++v) {
        const unsigned bits = x.mesh.boundary[v];
        if (bits == 0) continue;
        ++onFaces;
        const Vec3f& p = streamed.positions[v];
        const Vec3f& q = x.mesh.positions[v];
        if (faces == FaceVertices::kLock) {
          EXPECT_TRUE(p == q);
          continue;
        }
        moved += p == q ? 0 : 1;
        for (std::size_t f = 0; f < 6; ++f) {
          if (bits & (1u << f)) {
            const auto& plane = (*x.header.volumeFaces)[f];
            EXPECT_NEAR(plane[0] * p.x + plane[1] * p.y + plane[2] * p.z, plane[3], 1e-4) << "vertex " << v;
          }
        }
      }
      EXPECT_GT(onFaces, 50u);
      if (faces == FaceVertices::kSlide) {
        EXPECT_GT(moved, onFaces / 2);
      }
    }
  }
}

// The extraction on 1 or 3 threads, and the steps of chunks side by side on 1 to 3 threads (a
// share as small as one vertex here): the same positions and normals as the 1-thread run. With
// threads, the chunks not side by side step at once (two rounds a chunk), which spreads the levels
// over more chunks: the sink holding more than the chain's N + 3 (smoothStreamed's bound) shows
// that the rounds ran (13 here; 10 when each chunk's rounds go on until none can step, which is the
// chain again), and no more than 2N + 2 (one round a chunk: two chunks a level).
TEST(Smoothing, SameForEveryThreadCount) {
  for (const auto& [threads, smoothThreads, method] : {std::tuple{1, 1, SmoothMethod::kSinc},
                                                       {3, 1, SmoothMethod::kSinc},
                                                       {1, 2, SmoothMethod::kSinc},
                                                       {3, 3, SmoothMethod::kSinc},
                                                       {1, 2, SmoothMethod::kTaubin},
                                                       {3, 3, SmoothMethod::kTaubin}}) {
    SCOPED_TRACE(std::to_string(threads) + " extracting, " + std::to_string(smoothThreads) + " smoothing");
    SmoothOptions o;
    o.iterations = 7;
    o.method = method;
    std::unique_ptr<SliceSource> source =
        std::make_unique<testing::VectorSource>(std::array<std::int64_t, 3>{32, 30, 34}, lumpyTorus());
    ExtractOptions e;
    e.iso = 0;
    e.normals = true;
    const VolumeInfo info = source->info();
    const LatticeFrame frame = LatticeFrame::physical(info);
    auto extractor = makeExtractor(e, info, frame);
    MemoryMeshSink memory;
    SmoothingSink smooth(memory, o, smoothThreads, 1);
    PipelineOptions p;
    p.threads = threads;
    p.sequentialVoxels = 0;  // threads even on a small volume
    runPipeline(*source, *extractor, smooth, extractionHeader(e, info, frame, *extractor), p);
    if (smoothThreads > 1) {
      EXPECT_GT(smooth.peakChunks(), static_cast<std::size_t>(o.iterations) + 3);
      EXPECT_LE(smooth.peakChunks(), 2 * static_cast<std::size_t>(o.iterations) + 2);
    }
    const Extracted x = extractChunks(lumpyTorus(), {32, 30, 34}, Method::kMarchingCubes, 0.0);
    const IndexedMesh expected = smoothStreamed(x, o);
    EXPECT_TRUE(memory.mesh().positions == expected.positions);
    EXPECT_TRUE(memory.mesh().normals == expected.normals);
  }
}

TEST(Smoothing, SincCoefficientsHaveUnitGainAndDamp) {
  SmoothOptions o;
  o.iterations = 20;
  const SmoothRecurrence r = smoothRecurrence(o);
  double gain = 0;
  for (double w : r.w) gain += w;
  EXPECT_NEAR(gain, 1.0, 1e-12);
  // The transfer function at Laplacian eigenvalue k: sum w_i T_i(1 - k/2), by the same recurrence
  // on a number. It passes k = 0 and damps k well above the pass band.
  const auto transfer = [&](double k) {
    double previous = 1, current = 1, sum = r.w[0];
    for (int i = 0; i < o.iterations; ++i) {
      const double next = r.a[i] * current + r.b[i] * (-k * current) + r.c[i] * previous;
      previous = current;
      current = next;
      sum += r.w[i + 1] * current;
    }
    return sum;
  };
  EXPECT_NEAR(transfer(0), 1.0, 1e-12);
  EXPECT_LT(std::abs(transfer(1.0)), 0.05);
  EXPECT_LT(std::abs(transfer(1.9)), 0.05);
}

TEST(Smoothing, RefusesBadOptions) {
  MemoryMeshSink memory;
  SmoothOptions o;
  o.iterations = kMaxSmoothIterations + 1;
  EXPECT_EQ(checkSmoothOptions(o), "`smooth` (iterations) must be 0 to 500, not 501");
  EXPECT_THROW(SmoothingSink(memory, o), Error);
  o.iterations = 3;
  o.passBand = 0;
  EXPECT_EQ(checkSmoothOptions(o), "`pass_band` must be above 0 and below 2");
}

}  // namespace
}  // namespace isoslab
