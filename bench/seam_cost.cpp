// The size cost of the .glb seam keys (_ISOSLAB_SEAM): the same extraction written twice, with
// and without keys, with everything else equal. Prints JSON.
// Usage: isoslab_seam_cost INPUT --iso V [--method M] [--chunk-triangles N] [--normals]
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"
#include "encode/mesh_writer.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "io/open_source.h"
#include "stream/pipeline.h"

int main(int argc, char** argv) {
  using namespace isoslab;
  if (argc < 4) {
    std::fprintf(stderr, "usage: isoslab_seam_cost INPUT --iso V [--method M] [--chunk-triangles N] [--normals]\n");
    return 2;
  }
  try {
    ExtractOptions options;
    WriterOptions writer;
    for (int a = 2; a < argc; ++a) {
      const std::string arg = argv[a];
      if (arg == "--iso" && a + 1 < argc) options.iso = std::stod(argv[++a]);
      if (arg == "--method" && a + 1 < argc) options.method = parseMethod(argv[++a]).value_or(Method::kMarchingCubes);
      if (arg == "--chunk-triangles" && a + 1 < argc) writer.chunkTriangles = std::stoll(argv[++a]);
      if (arg == "--normals") options.normals = true;
    }
    options.cellVolumes = false;
    std::int64_t bytes[2] = {0, 0};
    std::uint64_t chunks = 0;
    const std::string out = (std::filesystem::temp_directory_path() / "isoslab_seam_cost.glb").string();
    for (int keys = 0; keys < 2; ++keys) {
      auto source = openSource(std::string(argv[1]), SourceOptions{});
      const VolumeInfo& info = source->info();
      const LatticeFrame frame = LatticeFrame::forSpace(info, "physical");
      writer.seamKeys = keys == 1;
      writer.voxelSize = std::min({info.spacing[0], info.spacing[1], info.spacing[2]});
      auto sink = makeMeshWriter(out, writer);
      auto extractor = makeExtractor(options, info, frame);
      const MeshHeader header = extractionHeader(options, info, frame, *extractor);
      PipelineOptions p;
      p.progress = false;
      p.threads = 1;
      runPipeline(*source, *extractor, *sink, header, p);
      bytes[keys] = sink->bytes();
      chunks = 0;
      for (const auto& [k, v] : sink->details()) {
        if (k == "chunks") chunks = static_cast<std::uint64_t>(v);
      }
    }
    std::filesystem::remove(out);
    std::printf(
        "{\"input\": \"%s\", \"chunks\": %llu, \"bytes_without_keys\": %lld, \"bytes_with_keys\": %lld, "
        "\"cost_percent\": %.4f}\n",
        argv[1], static_cast<unsigned long long>(chunks), static_cast<long long>(bytes[0]),
        static_cast<long long>(bytes[1]),
        100.0 * static_cast<double>(bytes[1] - bytes[0]) / static_cast<double>(bytes[0]));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "isoslab_seam_cost: %s\n", e.what());
    return 1;
  }
  return 0;
}
