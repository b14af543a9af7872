#include "encode/mesh_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "core/error.h"
#include "encode/draco_writers.h"
#include "encode/gltf.h"
#include "encode/obj_writer.h"
#include "encode/ply_writer.h"
#include "encode/stl_writer.h"
#include "encode/threemf_writer.h"

namespace isoslab {

std::unique_ptr<MeshFileSink> makeMeshWriter(const std::string& path, const WriterOptions& options) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".ply") return std::make_unique<PlyWriter>(path);
  if (ext == ".stl") return std::make_unique<StlWriter>(path);
  if (ext == ".obj") return std::make_unique<ObjWriter>(path);
  if (ext == ".glb") {
    if (!options.draco) return std::make_unique<GlbPlainWriter>(path, options);
    return std::make_unique<GlbDracoWriter>(path, options);
  }
  if (ext == ".drc") return std::make_unique<DrcWriter>(path, options);
  if (ext == ".3mf") return std::make_unique<ThreeMfWriter>(path);
  throw Error(fmt::format("{}: unknown mesh format '{}' (use .ply, .stl, .obj, .glb, .drc or .3mf)", path, ext));
}

}  // namespace isoslab
