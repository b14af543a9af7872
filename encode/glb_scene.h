// One .glb of several meshes, for label surfaces (job/label_job.cpp). Not installed: like gltf.h,
// it speaks nlohmann's JSON.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "encode/mesh_writer.h"

namespace isoslab {

/// One .glb of several meshes (label surfaces): each GlbDracoWriter made with the scene spools its
/// chunks into the scene's one buffer and, at its finish(), adds its mesh, named and coloured, with
/// its own node (a child of the frame's root node) and material. write() then writes the file.
class GlbScene {
 public:
  GlbScene(std::string path, const WriterOptions& options);
  ~GlbScene();
  /// Checks that the file can be written and opens the buffer's spool.
  void begin(const MeshHeader& header);
  SpoolFile& spool() { return *spool_; }
  std::size_t addAccessor(nlohmann::ordered_json accessor);
  std::size_t addView(nlohmann::ordered_json view);
  struct Mesh {
    std::string name;
    std::array<std::uint8_t, 3> color{};  // sRGB
    nlohmann::ordered_json extras = nlohmann::ordered_json::object();
    nlohmann::ordered_json primitives = nlohmann::ordered_json::array();  // their "material" is set by write()
  };
  void addMesh(Mesh mesh) { meshes_.push_back(std::move(mesh)); }
  std::vector<Mesh>& meshes() noexcept { return meshes_; }
  /// Writes the file (through AtomicFile, committed with the run): the asset with `extras`, the
  /// frame's root node, a node, mesh and material per mesh in the order added. Returns its size.
  std::int64_t write(const nlohmann::ordered_json& extras);
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  WriterOptions options_;
  MeshHeader header_;
  std::unique_ptr<SpoolFile> spool_;
  nlohmann::ordered_json accessors_ = nlohmann::ordered_json::array();
  nlohmann::ordered_json views_ = nlohmann::ordered_json::array();
  std::vector<Mesh> meshes_;
};

}  // namespace isoslab
