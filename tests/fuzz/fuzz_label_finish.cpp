// Smoothing and decimating a label complex in the stream (process/, issue 37) on small random label
// volumes, in blocks of two to four slabs, after the per-label component rules when asked: every
// label's surface must stay closed (each directed edge as often as its reverse) with its Euler
// characteristic, every triangle must keep its two labels, and the rules applied again to the
// relabelled volume must drop nothing. abort() on a violation.
//
// Input:
//   0..2  dims: 2 + byte % 9 (2..10)
//   3     bits 0-2 labels 2 + bits % 6 (background included); bit 3 no smoothing; bit 4 two
//         threads for the decimation; bit 5 --keep-largest 1, bit 6 --min-volume 2 (voxels)
//   4     ratio (1 + byte % 100) / 100
//   5     slabs a block: 2 + byte % 3
//   then one byte per voxel, x fastest (missing bytes are 0): its label, byte % labels
#include <map>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "extract/frame.h"
#include "extract/label_extractor.h"
#include "fuzz_support.h"
#include "io/label_components.h"
#include "io/label_source.h"
#include "io/pad_source.h"
#include "process/decimation.h"
#include "process/smoothing.h"
#include "stream/pipeline.h"

using namespace isoslab;

namespace {

// The whole complex as it streams past.
class Collect final : public MeshSink {
 public:
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& chunk) override {
    if (chunk.faceLabels.size() != chunk.triangles.size())
      fuzz::fail("a chunk's triangles and labels differ in number");
    vertices += chunk.positions.size();
    triangles.insert(triangles.end(), chunk.triangles.begin(), chunk.triangles.end());
    sides.insert(sides.end(), chunk.faceLabels.begin(), chunk.faceLabels.end());
  }
  void finish() override {}

  std::size_t vertices = 0;
  std::vector<Triangle> triangles;
  std::vector<LabelPair> sides;
};

// A label's surface: its directed edges' balance (0: closed) and Euler characteristic.
std::pair<std::int64_t, std::int64_t> shapeOf(const Collect& c, std::int32_t label) {
  std::map<std::pair<VertexId, VertexId>, std::int64_t> directed;
  std::set<std::pair<VertexId, VertexId>> edges;
  std::set<VertexId> used;
  std::int64_t faces = 0;
  for (std::size_t t = 0; t < c.triangles.size(); ++t) {
    const bool back = c.sides[t][1] == label, front = c.sides[t][0] == label;
    if (!back && !front) continue;
    const Triangle& tri = c.triangles[t];
    for (std::size_t k = 0; k < 3; ++k) {
      const VertexId a = tri[k], b = tri[(k + 1) % 3];
      directed[back ? std::pair{a, b} : std::pair{b, a}] += 1;
      edges.insert(std::minmax(a, b));
      used.insert(a);
    }
    ++faces;
  }
  std::int64_t unbalanced = 0;
  for (const auto& [e, n] : directed) {
    const auto it = directed.find({e.second, e.first});
    unbalanced += std::abs(n - (it == directed.end() ? 0 : it->second));
  }
  return {unbalanced, static_cast<std::int64_t>(used.size()) - static_cast<std::int64_t>(edges.size()) + faces};
}

// The per-label component rules' relabelling of `values`; abort()s unless applying the rules again
// to the relabelled volume drops nothing.
LabelRelabelling relabelled(const VolumeInfo& info, const std::vector<float>& values,
                            const LabelComponentRules& rules) {
  const auto components = [&](SliceSource& source) {
    auto finder = std::make_unique<LabelComponentFinder>(info, "fuzz");
    std::vector<float> slice(static_cast<std::size_t>(info.sliceValues()));
    while (source.readSlice(slice)) finder->addSlice(slice);
    return finder;
  };
  fuzz::MemorySource first(info, values);
  const auto found = components(first);
  LabelRelabelling relabelling = found->relabelling(selectLabelComponents(found->components(), rules));
  RelabelSource again(std::make_unique<fuzz::MemorySource>(info, values), "fuzz", relabelling);
  const auto left = components(again);
  const std::vector<bool> keep = selectLabelComponents(left->components(), rules);
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (!keep[i]) {
      fuzz::fail(fmt::format("the relabelled volume's component {} (label {}, {} voxels) breaks the rules", i,
                             left->components()[i].label, left->components()[i].voxels));
    }
  }
  return relabelling;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  VolumeInfo info = fuzz::takeVolumeInfo(in, 9, VoxelType::kU8);
  const std::uint8_t flags = fuzz::takeByte(in);
  const std::uint8_t ratioByte = fuzz::takeByte(in);
  const std::uint8_t slabsByte = fuzz::takeByte(in);
  const int labels = 2 + (flags & 7) % 6;
  std::vector<float> values(static_cast<std::size_t>(info.sliceVoxels() * info.dims[2]));
  for (float& v : values) v = static_cast<float>(fuzz::takeByte(in) % labels);
  SmoothOptions smooth;
  smooth.iterations = (flags & 8) != 0 ? 0 : 20;
  smooth.passBand = kLabelPassBand;
  smooth.maxDisplacement = 0.5;
  DecimateOptions decimate;
  decimate.ratio = (1 + ratioByte % 100) / 100.0;
  decimate.maxDistance = kLabelDistanceBound;
  decimate.blockSlabs = 2 + slabsByte % 3;
  decimate.blockTriangles = 1;
  decimate.threads = (flags & 16) != 0 ? 2 : 1;

  LabelComponentRules rules;
  if ((flags & 32) != 0) rules.keepLargest = 1;
  if ((flags & 64) != 0) rules.minVolume = 2;
  std::optional<LabelRelabelling> relabelling;
  if (rules.keepLargest || rules.minVolume) relabelling = relabelled(info, values, rules);
  auto memory = std::make_unique<fuzz::MemorySource>(info, std::move(values));
  std::unique_ptr<SliceSource> checked = std::make_unique<LabelSource>(std::move(memory), "fuzz", std::nullopt);
  if (relabelling) checked = std::make_unique<RelabelSource>(std::move(checked), "fuzz", std::move(*relabelling));
  PadSource source(std::move(checked), 0.0f);
  const LatticeFrame frame = LatticeFrame::physical(info);
  auto extractor = makeLabelExtractor(info, frame);
  Collect before, after;
  DecimationSink decimation(after, decimate);
  TeeSink tee({&before, &decimation});
  SmoothingSink smoothing(tee, smooth);
  MeshSink& head = smooth.iterations > 0 ? static_cast<MeshSink&>(smoothing) : static_cast<MeshSink&>(tee);
  try {
    runPipeline(source, *extractor, head, labelHeader(info, frame), PipelineOptions{});
  } catch (const Error& e) {
    fuzz::fail(fmt::format("smoothing and decimation threw: {}", e.what()));
  }
  std::set<std::int32_t> present;
  for (const LabelPair& p : before.sides) present.insert(p.begin(), p.end());
  present.erase(0);
  for (const std::int32_t label : present) {
    const auto was = shapeOf(before, label), now = shapeOf(after, label);
    if (now.first != 0) fuzz::fail(fmt::format("label {}: {} unbalanced edge uses after decimation", label, now.first));
    if (now.second != was.second) {
      fuzz::fail(fmt::format("label {}: Euler characteristic {} became {}", label, was.second, now.second));
    }
  }
  return 0;
}
