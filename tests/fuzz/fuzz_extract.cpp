// The extraction kernels (mc, mt5, mt6, bcc12, mt24, mc33) on small random volumes and iso values, NaN and
// infinities included, through the pipeline as `isoslab extract` runs them. Checked here, with
// abort() on a violation: every chunk continues the vertex ids; every triangle uses three distinct
// vertices of its own chunk or the one before (the streaming contract); positions are finite and
// inside the volume's box; and the surface is closed away from the volume's faces: every edge is
// used by exactly two triangles that traverse it in opposite directions, unless both its ends lie
// on one face of the volume. Optionally, two workers must give exactly the mesh one gives.
//
// Input:
//   0..2  dims: 2 + byte % 7 (2..8)
//   3     bits 0-1 and 6 the method (an index into kMethods, modulo their count); bit 2 normals;
//         bit 7 --close-boundary (then no boundary edge at all); bit 3 compare with 2 threads; bits 4-5 the frame:
//         voxel, anisotropic spacing, a left-handed direction, uneven slice origins
//   4     iso: 0 NaN, 1 +inf, 2 -inf, 3 the next 8 bytes as a double, 4 FLT_MAX, else (b - 128) / 4
//   then one byte per voxel, x fastest (missing bytes are 0): 255 NaN, 254 +inf, 253 -inf,
//   252 FLT_MAX, 251 -FLT_MAX, 250 the smallest subnormal, else (b - 128) / 4
#include <cmath>
#include <cstring>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "fuzz_support.h"
#include "io/pad_source.h"
#include "metrics/mesh_stats.h"
#include "stream/pipeline.h"

using namespace isoslab;

namespace {

// Checks every chunk as it streams past.
class CheckSink final : public MeshSink {
 public:
  CheckSink(std::array<double, 6> bounds, bool normals) : bounds_(bounds), normals_(normals) {}
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& c) override {
    if (c.firstVertex != end_) fail(c, fmt::format("vertices start at {}, not {}", c.firstVertex, end_));
    if (c.boundary.size() != c.positions.size()) fail(c, "boundary flags are not one per vertex");
    if (c.normals.size() != (normals_ ? c.positions.size() : 0)) fail(c, "normals are not one per vertex");
    const double tol = 1e-4 * (1 + std::fabs(bounds_[0]) + std::fabs(bounds_[3]) + std::fabs(bounds_[1]) +
                               std::fabs(bounds_[4]) + std::fabs(bounds_[2]) + std::fabs(bounds_[5]));
    for (const Vec3f& p : c.positions) {
      const double x[3] = {p.x, p.y, p.z};
      for (std::size_t a = 0; a < 3; ++a) {
        if (!std::isfinite(x[a]) || x[a] < bounds_[a] - tol || x[a] > bounds_[a + 3] + tol) {
          fail(c, fmt::format("vertex ({}, {}, {}) outside the volume's box", p.x, p.y, p.z));
        }
      }
    }
    for (const Vec3f& n : c.normals) {
      if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) fail(c, "a normal is not finite");
    }
    for (const Triangle& t : c.triangles) {
      for (VertexId v : t) {
        if (v < previousFirst_ || v >= c.endVertex()) fail(c, fmt::format("a triangle uses vertex {}", v));
      }
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) fail(c, "a triangle repeats a vertex");
    }
    previousFirst_ = c.firstVertex;
    end_ = c.endVertex();
  }
  void finish() override {}

 private:
  [[noreturn]] static void fail(const MeshChunk& c, const std::string& what) {
    fuzz::fail(fmt::format("slab {}: {}", c.slab, what));
  }
  std::array<double, 6> bounds_;
  bool normals_;
  VertexId previousFirst_ = 0;
  VertexId end_ = 0;
};

float voxel(std::uint8_t b) {
  switch (b) {
    case 255:
      return std::numeric_limits<float>::quiet_NaN();
    case 254:
      return std::numeric_limits<float>::infinity();
    case 253:
      return -std::numeric_limits<float>::infinity();
    case 252:
      return std::numeric_limits<float>::max();
    case 251:
      return -std::numeric_limits<float>::max();
    case 250:
      return std::numeric_limits<float>::denorm_min();
    default:
      return static_cast<float>(b - 128) / 4.0f;
  }
}

IndexedMesh run(const VolumeInfo& info, const std::vector<float>& values, const ExtractOptions& options, int threads,
                bool check) {
  std::unique_ptr<SliceSource> source = std::make_unique<fuzz::MemorySource>(info, values);
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  if (options.closeBoundary) source = std::make_unique<PadSource>(std::move(source));
  MemoryMeshSink memory;
  MeshStatsSink stats;
  CheckSink checks(frame.bounds(info.dims), options.normals);
  TeeSink tee({&checks, &memory, &stats});
  PipelineOptions pipeline;
  pipeline.threads = threads;
  pipeline.sequentialVoxels = 0;  // threads even on a small volume
  try {
    runPipeline(*source, *extractor, tee, header, pipeline);
  } catch (const Error& e) {
    fuzz::fail(fmt::format("extraction threw: {}", e.what()));
  }
  if (check) {
    const MeshStats& s = stats.stats();
    if (s.nonManifoldEdges != 0 || s.inconsistentEdges != 0 || s.interiorBoundaryEdges != 0 ||
        (options.closeBoundary && s.boundaryEdges != 0)) {
      fuzz::fail(
          fmt::format("{} iso {}{}: {} non-manifold, {} inconsistent, {} interior boundary and {} boundary edges",
                      methodName(options.method), options.iso, options.closeBoundary ? " capped" : "",
                      s.nonManifoldEdges, s.inconsistentEdges, s.interiorBoundaryEdges, s.boundaryEdges));
    }
  }
  return memory.mesh();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  VolumeInfo info = fuzz::takeVolumeInfo(in, 7, VoxelType::kF32);
  const std::uint8_t flags = fuzz::takeByte(in);
  ExtractOptions options;
  const unsigned methodIndex = (flags & 3u) | ((flags >> 4) & 4u);
  options.method = kMethods[methodIndex % std::size(kMethods)];
  options.normals = (flags & 4) != 0;
  options.closeBoundary = (flags & 128) != 0;
  const bool compareThreads = (flags & 8) != 0;
  switch ((flags >> 4) & 3) {
    case 0:
      break;
    case 1:
      info.spacing = {0.5, 2, 3};
      break;
    case 2:
      info.direction = {-1, 0, 0, 0, 1, 0, 0, 0, 1};
      break;
    case 3:
      for (std::int64_t k = 0; k < info.dims[2]; ++k) {
        info.sliceOrigins.push_back(
            {0.25 * static_cast<double>(k), 0, static_cast<double>(k * k) * 0.5 + 1.5 * static_cast<double>(k)});
      }
      break;
  }
  const std::uint8_t isoByte = fuzz::takeByte(in);
  switch (isoByte) {
    case 0:
      options.iso = std::numeric_limits<double>::quiet_NaN();
      break;
    case 1:
      options.iso = std::numeric_limits<double>::infinity();
      break;
    case 2:
      options.iso = -std::numeric_limits<double>::infinity();
      break;
    case 3: {
      std::uint8_t bytes[8] = {};
      for (auto& b : bytes) b = fuzz::takeByte(in);
      std::memcpy(&options.iso, bytes, 8);
      break;
    }
    case 4:
      options.iso = std::numeric_limits<float>::max();
      break;
    default:
      options.iso = (isoByte - 128) / 4.0;
      break;
  }
  const auto n = static_cast<std::size_t>(info.dims[0] * info.dims[1] * info.dims[2]);
  std::vector<float> values(n, 0.0f);
  for (std::size_t v = 0; v < n; ++v) values[v] = voxel(fuzz::takeByte(in));

  const IndexedMesh one = run(info, values, options, 1, true);
  if (compareThreads) {
    const IndexedMesh two = run(info, values, options, 2, false);
    // cellVolume is left out: it may be NaN (infinite values), which compares unequal to itself.
    if (two.positions != one.positions || two.normals != one.normals || two.boundary != one.boundary ||
        two.triangles != one.triangles) {
      fuzz::fail("two threads give another mesh than one");
    }
  }
  return 0;
}
