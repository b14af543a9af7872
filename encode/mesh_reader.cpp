// readMesh(): the file's bytes, a format chosen by content (and the extension where content cannot
// tell OBJ from STL), then the format's reader (format_readers.h).
#include "encode/mesh_reader.h"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/limits.h"
#include "encode/draco_codec.h"
#include "encode/format_readers.h"

namespace isoslab {
namespace {

// A binary STL is exactly 84 + 50 n bytes, n being its triangle count; its 80-byte header may
// begin with "solid" all the same (some exporters write that), so the size decides first.
bool isBinaryStl(const std::string& data) {
  if (data.size() < 84) return false;
  std::uint32_t count = 0;
  std::memcpy(&count, data.data() + 80, 4);
  return data.size() == 84 + std::uint64_t{count} * 50;
}

IndexedMesh readFormat(const std::string& path, std::string data, MeshMetadata& meta) {
  if (data.compare(0, 4, "ply\n") == 0 || data.compare(0, 5, "ply\r\n") == 0)
    return format::readPly(path, std::move(data), meta);
  const std::size_t dot = path.rfind('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (isBinaryStl(data) && (ext == ".stl" || data.compare(0, 5, "solid") == 0))
    return format::readStl(path, data, meta);
  if (data.compare(0, 5, "solid") == 0) throw Error(fmt::format("{}: ASCII STL is not supported", path));
  if (ext == ".stl") return format::readStl(path, data, meta);
  if (ext == ".obj") return format::readObj(path, data, meta);
  if (data.compare(0, 4, "glTF") == 0) return format::readGlb(path, data, meta);
  if (data.compare(0, 5, "DRACO") == 0) return dracoDecode(data.data(), data.size(), path);
  throw Error(fmt::format("{}: unknown mesh format (PLY, binary STL, OBJ, .glb or .drc expected)", path));
}

std::string readFile(const std::string& path) {
  std::error_code statError;
  const auto status = std::filesystem::status(path, statError);
  if (!statError && std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) {
    throw Error(fmt::format("{}: not a regular file (FIFOs, devices and folders are not read)", path));
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  const std::uintmax_t size = std::filesystem::file_size(path, statError);
  if (!statError && size > static_cast<std::uintmax_t>(limits::kMaxMeshFileBytes)) {
    throw Error(fmt::format("{}: {} bytes exceed the limit of {} bytes for a mesh file", path, size,
                            limits::kMaxMeshFileBytes));
  }
  std::string data;
  try {
    data.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  } catch (const std::bad_alloc&) {
    throw Error(fmt::format("{}: out of memory reading {} bytes", path, size));
  } catch (const std::exception&) {  // libstdc++'s "basic_filebuf::underflow error reading the file"
    throw Error(fmt::format("{}: cannot read: {}", path, std::strerror(errno != 0 ? errno : EIO)));
  }
  return data;
}

}  // namespace

IndexedMesh readMeshData(const std::string& path, std::string data, MeshMetadata* metadata) {
  MeshMetadata scratch;
  MeshMetadata& meta = metadata != nullptr ? *metadata : scratch;
  meta = MeshMetadata{};
  IndexedMesh mesh = readFormat(path, std::move(data), meta);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3f& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw Error(fmt::format("{}: vertex {} is at ({},{},{}): not finite", path, v, p.x, p.y, p.z));
    }
  }
  return mesh;
}

IndexedMesh readMesh(const std::string& path, MeshMetadata* metadata) {
  if (metadata != nullptr) *metadata = MeshMetadata{};
  return readMeshData(path, readFile(path), metadata);
}

}  // namespace isoslab
