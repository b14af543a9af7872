// meshoptimizer's whole-mesh simplification, for bench/finish_speed.py: the reference that
// isoslab's streamed decimation is held to (issue 36). Reads a mesh (isoslab's reader), runs
// meshopt_simplify with a locked border to TARGET triangles once, and prints one JSON line: the
// seconds of the call alone, the triangles kept and meshoptimizer's error.
//
//   isoslab_simplify_whole MESH.ply TARGET_TRIANGLES [meshopt|isoslab]
//
// With "isoslab", the call is isoslab's own simplifier (process/simplifier.h) instead, with no
// error limit, for a paired comparison of the two on one mesh.
#include <fmt/format.h>
#include <meshoptimizer.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "core/error.h"
#include "encode/mesh_reader.h"
#include "process/simplifier.h"

int main(int argc, char** argv) {
  const bool own = argc == 4 && std::string(argv[3]) == "isoslab";
  if (argc < 3 || argc > 4 || (argc == 4 && !own && std::string(argv[3]) != "meshopt")) {
    std::fprintf(stderr, "usage: isoslab_simplify_whole MESH TARGET_TRIANGLES [meshopt|isoslab]\n");
    return 2;
  }
  try {
    const isoslab::IndexedMesh mesh = isoslab::readMesh(argv[1]);
    const auto target = static_cast<std::size_t>(std::strtoull(argv[2], nullptr, 10));
    std::vector<unsigned> indices;
    indices.reserve(mesh.triangles.size() * 3);
    for (const isoslab::Triangle& t : mesh.triangles) indices.insert(indices.end(), t.begin(), t.end());
    std::vector<unsigned> out(indices.size());
    float error = 0;
    const auto start = std::chrono::steady_clock::now();
    std::size_t kept = 0;
    if (own) {
      isoslab::SimplifyLimits limits;
      limits.targetTriangles = target;
      limits.maxError = std::numeric_limits<double>::infinity();
      kept = isoslab::simplifyTriangles(indices, &mesh.positions[0].x, mesh.positions.size(), limits);
    } else {
      kept = meshopt_simplify(out.data(), indices.data(), indices.size(), &mesh.positions[0].x, mesh.positions.size(),
                              sizeof(isoslab::Vec3f), target * 3, std::numeric_limits<float>::max(),
                              meshopt_SimplifyLockBorder, &error);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("%s\n", fmt::format("{{\"seconds\": {}, \"triangles_in\": {}, \"triangles\": {}, \"error\": {}}}",
                                    seconds, mesh.triangles.size(), kept / 3, error)
                            .c_str());
    return 0;
  } catch (const isoslab::Error& e) {
    std::fprintf(stderr, "isoslab_simplify_whole: %s\n", e.what());
    return 1;
  }
}
