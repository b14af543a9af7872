#include "encode/mesh_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "encode/ply_writer.h"
#include "encode/stl_writer.h"
#include "io/error.h"

namespace isoslab {

std::unique_ptr<MeshFileSink> makeMeshWriter(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".ply") return std::make_unique<PlyWriter>(path);
  if (ext == ".stl") return std::make_unique<StlWriter>(path);
  throw Error(fmt::format("{}: unknown mesh format '{}' (use .ply or .stl)", path, ext));
}

}  // namespace isoslab
