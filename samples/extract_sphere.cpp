// The smallest use of the library: stream a phantom sphere through Marching Cubes into a PLY file
// and print what the statistics sink measured.
//
//   extract_sphere OUT.ply [RADIUS]
#include <cstdio>
#include <cstdlib>
#include <string>

#include "core/error.h"
#include "encode/ply_writer.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "io/open_source.h"
#include "metrics/mesh_stats.h"
#include "stream/pipeline.h"

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: extract_sphere OUT.ply [RADIUS]\n");
    return 2;
  }
  const double radius = argc > 2 ? std::atof(argv[2]) : 20.0;
  try {
    auto source = isoslab::openSource("phantom:sphere?n=64&r=" + std::to_string(radius), {});
    isoslab::ExtractOptions options;
    options.iso = 1000.0 - 10.0 * radius;
    options.normals = true;
    const auto frame = isoslab::LatticeFrame::physical(source->info());
    auto extractor = isoslab::makeExtractor(options, source->info(), frame);

    isoslab::PlyWriter ply(argv[1]);
    isoslab::MeshStatsSink stats;
    isoslab::TeeSink both({&ply, &stats});
    isoslab::MeshHeader header;
    header.normals = true;
    header.method = "mc";
    header.iso = options.iso;
    header.space = frame.name();
    isoslab::runPipeline(*source, *extractor, both, header);

    const isoslab::MeshStats& s = stats.stats();
    std::printf("%llu triangles, area %.3f, volume %.3f, Euler characteristic %lld\n",
                static_cast<unsigned long long>(s.triangles), s.area, s.volume, static_cast<long long>(s.euler));
  } catch (const isoslab::Error& e) {
    std::fprintf(stderr, "extract_sphere: %s\n", e.what());
    return 1;
  }
  return 0;
}
