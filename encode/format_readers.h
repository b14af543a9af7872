// The per-format mesh readers behind readMesh() (mesh_reader.h); internal to encode/. Each takes
// the whole file's bytes and its path for messages, fills `meta` from what the file states, and
// throws isoslab::Error naming the file and the problem.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"

namespace isoslab::format {

/// Binary little-endian or ASCII PLY.
IndexedMesh readPly(const std::string& path, std::string data, MeshMetadata& meta);
/// Binary STL; corners welded by exact position, in the order they first appear.
IndexedMesh readStl(const std::string& path, const std::string& data, MeshMetadata& meta);
/// Wavefront OBJ: v, vn and f lines.
IndexedMesh readObj(const std::string& path, const std::string& data, MeshMetadata& meta);
/// glTF 2.0 binary: Draco or plain primitives, chunk seams joined (see draco_writers.h).
IndexedMesh readGlb(const std::string& path, const std::string& data, MeshMetadata& meta);

/// Appends the polygon `poly` (vertex indices, checked against the mesh's positions) as a fan of
/// triangles.
void addPolygon(IndexedMesh& mesh, const std::vector<std::uint64_t>& poly, const std::string& path);

}  // namespace isoslab::format
