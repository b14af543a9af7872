// Reading mesh files back into memory, for `isoslab metrics` and `isoslab decode` and for tests.
// The streaming path never reads a mesh. Only the .glb reader does what no library does (joining
// isoslab's chunk seams by their keys); the tests check the PLY, OBJ and STL readers against
// Draco's and tinyobjloader's (tests/encode/mesh_reader_test.cpp).
#pragma once

#include <string>

#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"

namespace isoslab {

/// Reads a mesh file: a .glb (isoslab's Draco chunks, seams joined by their _ISOSLAB_SEAM keys, or
/// plain accessors), a .drc, binary or ASCII PLY (vertex x, y, z as float or double, optional nx,
/// ny, nz; faces as a list of int/uint indices, polygons fanned into triangles), OBJ, or binary STL
/// (corners welded by exact position). Positions are those of the buffers: a .glb's node transform
/// to glTF's frame is not applied. Fills `metadata` when given, from what the file says (see
/// mesh_metadata.h). Positions are checked to be finite. Throws isoslab::Error naming the file and
/// the problem.
IndexedMesh readMesh(const std::string& path, MeshMetadata* metadata = nullptr);

/// readMesh() on bytes already in memory; `path` names them in messages and its extension helps
/// tell OBJ and STL apart.
IndexedMesh readMeshData(const std::string& path, std::string data, MeshMetadata* metadata = nullptr);

}  // namespace isoslab
