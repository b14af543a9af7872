// The collapse of degenerate triangles (process/degenerate.h) on small integer volumes, whose
// samples meet the iso value exactly, extracted capped with any method: with remap (as for 3MF) the
// output must keep every edge once in each direction (closed and manifold by index, as the
// extraction is), no triangle may repeat a vertex, and kept plus removed triangles must be the
// extraction's. abort() on a violation.
//
// Input:
//   0..2  dims: 2 + byte % 7 (2..8)
//   3     bits 0-2 the method (modulo the method count)
//   then one byte per voxel, x fastest (missing bytes are 0): value byte % 4, iso 2
#include <map>
#include <utility>

#include <fmt/format.h>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "fuzz_support.h"
#include "io/pad_source.h"
#include "process/degenerate.h"
#include "stream/pipeline.h"

using namespace isoslab;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  VolumeInfo info = fuzz::takeVolumeInfo(in, 7, VoxelType::kF32);
  const std::uint8_t flags = fuzz::takeByte(in);
  ExtractOptions options;
  options.method = kMethods[(flags & 7u) % std::size(kMethods)];
  options.closeBoundary = true;
  options.iso = 2;
  std::vector<float> values(static_cast<std::size_t>(info.sliceVoxels() * info.dims[2]));
  for (float& v : values) v = static_cast<float>(fuzz::takeByte(in) % 4);

  std::unique_ptr<SliceSource> source = std::make_unique<fuzz::MemorySource>(info, std::move(values));
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  source = std::make_unique<PadSource>(std::move(source));
  MemoryMeshSink raw;
  MemoryMeshSink collapsed;
  DegenerateCollapseSink collapse(collapsed, true);
  TeeSink tee({&raw, &collapse});
  try {
    runPipeline(*source, *extractor, tee, header, PipelineOptions{});
  } catch (const Error& e) {
    fuzz::fail(fmt::format("the collapse threw: {}", e.what()));
  }
  const auto& kept = collapsed.mesh().triangles;
  if (kept.size() + static_cast<std::size_t>(collapse.counts().triangles) != raw.mesh().triangles.size()) {
    fuzz::fail("kept and removed triangles do not add up to the extraction's");
  }
  std::map<std::pair<VertexId, VertexId>, int> directed;
  for (const Triangle& t : kept) {
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) fuzz::fail("a kept triangle repeats a vertex");
    for (std::size_t k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  }
  for (const auto& [edge, uses] : directed) {
    const auto back = directed.find({edge.second, edge.first});
    if (uses != 1 || back == directed.end() || back->second != 1) {
      fuzz::fail(fmt::format("{}: edge {}-{} is not used once each way after the collapse", methodName(options.method),
                             edge.first, edge.second));
    }
  }
  return 0;
}
