// What every isoslab .glb shares, compressed or not: the asset and its extras, the scene with a
// root node that maps the output space to glTF's frame, the material, and the GLB container.
//
// glTF is Y-up, in metres, with the front facing +Z. Positions stay in the output space's units in
// the buffers (millimetres for scanner data), so that chunk seams stay bit-exact and `decode` gives
// back the output space; the root node's matrix carries the change of frame:
//   LPS (and physical, voxel):  x -> x, z -> y, -y -> z, times 0.001
//   RAS:                       -x -> x, z -> y,  y -> z, times 0.001
// A patient's head is then upright and faces the viewer. WriterOptions::gltfFrame false leaves
// the root node out.
//
// GlbPlainWriter is the uncompressed .glb (--draco off), for readers without Draco (Blender 3.4,
// VTK 9.1's vtkGLTFReader, Open3D): one primitive of plain accessors. It streams positions,
// normals and indices to three spools beside the output, so memory stays at about one chunk;
// there are no seams, since the vertex ids are the extraction's.
#pragma once

#include <array>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "encode/mesh_writer.h"

namespace isoslab {

/// The name of the application-specific attribute that carries seam keys (IndexedMesh::seamKeys).
inline constexpr const char* kSeamAttribute = "_ISOSLAB_SEAM";

/// Column-major 4x4 matrix of the root node for output space `space`.
std::array<double, 16> gltfFrameMatrix(const std::string& space);

/// The glTF document without meshes: asset (with extras), scene, nodes (the root node when
/// options.gltfFrame, and the mesh node when `hasMesh`), and the material.
nlohmann::ordered_json gltfDocument(const MeshHeader& header, const WriterOptions& options, bool hasMesh,
                                    const nlohmann::ordered_json& extras);

/// Writes a GLB container with `json` and, when the spools hold bytes, a BIN chunk of their bytes one
/// after the other. Refuses files over the container's 4 GiB limit. Returns the file size.
std::int64_t writeGlbFile(const std::string& path, const nlohmann::ordered_json& json,
                          const std::vector<SpoolFile*>& bin);

class GlbPlainWriter final : public MeshFileSink {
 public:
  GlbPlainWriter(std::string path, const WriterOptions& options);
  ~GlbPlainWriter() override;
  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;
  std::int64_t bytes() const noexcept override { return bytes_; }

 private:
  std::string path_;
  WriterOptions options_;
  MeshHeader header_;
  std::unique_ptr<SpoolFile> positions_, normals_, indices_;
  std::vector<char> buffer_;
  std::uint64_t vertices_ = 0;
  std::uint64_t triangles_ = 0;
  std::array<float, 3> min_{}, max_{};
  std::int64_t bytes_ = 0;
};

}  // namespace isoslab
