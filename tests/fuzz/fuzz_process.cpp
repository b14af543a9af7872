// Smoothing and decimation in the stream (process/) on small random volumes, extracted capped
// (--close-boundary) with any method: the output must keep the streaming contract (checked by the
// measuring sink, which throws), stay finite, and stay closed, manifold and consistently wound, as
// the extraction is. abort() on a violation.
//
// Input:
//   0..2  dims: 2 + byte % 9 (2..10)
//   3     bits 0-2 the method (modulo the method count); bit 3 normals; bit 4 Taubin (else sinc);
//         bit 5 faces locked (else sliding); bit 6 decimate with --max-error (else by ratio);
//         bit 7 no smoothing
//   4     smoothing iterations: byte % 24
//   5     decimation: ratio (1 + byte % 100) / 100, or max error (1 + byte % 16) / 8 voxels
//   then one byte per voxel, x fastest (missing bytes are 0): 255 NaN, else (b - 128) / 8
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
#include "process/decimation.h"
#include "process/smoothing.h"
#include "stream/pipeline.h"

using namespace isoslab;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  VolumeInfo info = fuzz::takeVolumeInfo(in, 9, VoxelType::kF32);
  const std::uint8_t flags = fuzz::takeByte(in);
  const std::uint8_t smoothByte = fuzz::takeByte(in);
  const std::uint8_t decimateByte = fuzz::takeByte(in);
  ExtractOptions options;
  options.method = kMethods[(flags & 7u) % std::size(kMethods)];
  options.normals = (flags & 8) != 0;
  options.closeBoundary = true;
  options.iso = 0;
  std::vector<float> values(static_cast<std::size_t>(info.sliceVoxels() * info.dims[2]));
  for (float& v : values) {
    const std::uint8_t b = fuzz::takeByte(in);
    v = b == 255 ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(b - 128) / 8.0f;
  }
  SmoothOptions smooth;
  smooth.iterations = (flags & 128) != 0 ? 0 : smoothByte % 24;
  smooth.method = (flags & 16) != 0 ? SmoothMethod::kTaubin : SmoothMethod::kSinc;
  smooth.faces = (flags & 32) != 0 ? FaceVertices::kLock : FaceVertices::kSlide;
  DecimateOptions decimate;
  if ((flags & 64) != 0) {
    decimate.maxError = (1 + decimateByte % 16) / 8.0;
    decimate.maxDistance = decimate.maxError;
  } else {
    decimate.ratio = (1 + decimateByte % 100) / 100.0;
  }
  decimate.blockSlabs = 2;
  decimate.blockTriangles = 1;
  decimate.batchTriangles = 1 + static_cast<std::size_t>(decimateByte % 64);  // many component batches

  std::unique_ptr<SliceSource> source = std::make_unique<fuzz::MemorySource>(info, std::move(values));
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  source = std::make_unique<PadSource>(std::move(source));
  MemoryMeshSink memory;
  MeshStatsSink stats;
  TeeSink tee({&memory, &stats});
  DecimationSink decimation(tee, decimate);
  SmoothingSink smoothing(decimation, smooth);
  try {
    runPipeline(*source, *extractor, smoothing, header, PipelineOptions{});
  } catch (const Error& e) {
    fuzz::fail(fmt::format("smoothing and decimation threw: {}", e.what()));
  }
  const MeshStats& s = stats.stats();
  if (s.boundaryEdges != 0 || s.nonManifoldEdges != 0 || s.inconsistentEdges != 0) {
    fuzz::fail(fmt::format(
        "{}: {} boundary, {} non-manifold and {} inconsistent edges after smoothing {} and "
        "decimation",
        methodName(options.method), s.boundaryEdges, s.nonManifoldEdges, s.inconsistentEdges, smooth.iterations));
  }
  for (const Vec3f& p : memory.mesh().positions) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) fuzz::fail("a position is not finite");
  }
  return 0;
}
