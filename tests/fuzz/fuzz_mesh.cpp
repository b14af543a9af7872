// Mesh files as `isoslab metrics` and `isoslab decode` read them: readMesh() on a PLY, STL, OBJ,
// GLB or DRC file, the metrics' measures, then the decode's rewrite into another format.
//
// Input: one selector byte, then the file.
//   selector % 5: the input's extension .ply .stl .obj .glb .drc;
//   selector / 5 % 6: decode to .ply .stl .obj .glb .drc, or no decode.
#include <algorithm>
#include <array>
#include <limits>

#include "core/error.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"
#include "encode/mesh_reader.h"
#include "encode/mesh_writer.h"
#include "fuzz_support.h"
#include "metrics/mesh_stats.h"

using namespace isoslab;

namespace {

const char* const kExtensions[] = {".ply", ".stl", ".obj", ".glb", ".drc"};

// The metrics command's measures.
void metrics(IndexedMesh mesh, const MeshMetadata& meta) {
  if (meta.volumeFaces) mesh.boundary = volumeFaceFlags(mesh.positions, *meta.volumeFaces, meta.positionTolerance);
  MeshStatsSink stats;
  feedMesh(mesh, MeshHeader{}, stats);
}

// The decode command: the header from the file's metadata, then a writer for `output`.
void decode(IndexedMesh mesh, const MeshMetadata& meta, const std::string& output) {
  if (meta.volumeFaces) mesh.boundary = volumeFaceFlags(mesh.positions, *meta.volumeFaces, meta.positionTolerance);
  const MeshHeader header = headerForDecodedMesh(meta, mesh.positions, !mesh.normals.empty());
  WriterOptions options;
  const auto& vb = header.volumeBounds;
  options.voxelSize = 1e-3 * std::max({vb[3] - vb[0], vb[4] - vb[1], vb[5] - vb[2], 1e-30});
  auto writer = makeMeshWriter(output, options);
  feedMesh(mesh, header, *writer);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  const std::uint8_t selector = fuzz::takeByte(in);
  const std::string dir = fuzz::freshDir();
  const std::string input = dir + "/mesh" + kExtensions[selector % 5];
  fuzz::writeFile(input, in);
  const int output = selector / 5 % 6;
  try {
    MeshMetadata meta;
    const IndexedMesh mesh = readMesh(input, &meta);
    metrics(mesh, meta);
    if (output < 5) decode(mesh, meta, dir + "/out" + kExtensions[output]);
  } catch (const Error&) {
    // A refused input is a normal outcome.
  }
  return 0;
}
