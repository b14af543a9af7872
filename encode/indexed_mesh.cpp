#include "encode/indexed_mesh.h"

namespace isoslab {

void feedMesh(const IndexedMesh& mesh, const MeshHeader& header, MeshSink& sink) {
  MeshChunk chunk;
  chunk.positions = mesh.positions;
  chunk.normals = mesh.normals;
  chunk.boundary = mesh.boundary;
  chunk.triangles = mesh.triangles;
  chunk.cellVolume = mesh.cellVolume;
  sink.begin(header);
  sink.consume(chunk);
  sink.finish();
}

}  // namespace isoslab
