// Binary STL and Wavefront OBJ into an IndexedMesh, and the polygon fan both PLY and OBJ use.
#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <sstream>
#include <unordered_map>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/format_readers.h"

namespace isoslab::format {

void addPolygon(IndexedMesh& mesh, const std::vector<std::uint64_t>& poly, const std::string& path) {
  for (std::uint64_t v : poly) {
    if (v >= mesh.positions.size())
      throw Error(fmt::format("{}: a face references vertex {} of {}", path, v, mesh.positions.size()));
  }
  for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
    mesh.triangles.push_back(
        {static_cast<VertexId>(poly[0]), static_cast<VertexId>(poly[k]), static_cast<VertexId>(poly[k + 1])});
  }
}

IndexedMesh readStl(const std::string& path, const std::string& data, MeshMetadata& meta) {
  if (data.size() < 84) throw Error(fmt::format("{}: the STL file is truncated", path));
  parseMetadataLine(data.substr(0, 80), meta);
  std::uint32_t count = 0;
  std::memcpy(&count, data.data() + 80, 4);
  if (data.size() < 84 + std::uint64_t{count} * 50) throw Error(fmt::format("{}: the STL file is truncated", path));
  IndexedMesh mesh;
  struct Key {
    float x, y, z;
    bool operator==(const Key& o) const { return std::memcmp(this, &o, sizeof(Key)) == 0; }
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      std::uint32_t b[3];
      std::memcpy(b, &k, sizeof b);
      return (std::size_t{b[0]} * 73856093u) ^ (std::size_t{b[1]} * 19349663u) ^ (std::size_t{b[2]} * 83492791u);
    }
  };
  std::unordered_map<Key, VertexId, Hash> ids;
  for (std::uint32_t t = 0; t < count; ++t) {
    throwIfInterruptedEvery(t);
    const char* rec = data.data() + 84 + std::size_t{t} * 50 + 12;
    Triangle tri{};
    for (int k = 0; k < 3; ++k) {
      Key key{};
      std::memcpy(&key, rec + 12 * k, 12);
      auto [it, added] = ids.emplace(key, static_cast<VertexId>(mesh.positions.size()));
      if (added) mesh.positions.push_back({key.x, key.y, key.z});
      tri[static_cast<std::size_t>(k)] = it->second;
    }
    mesh.triangles.push_back(tri);
  }
  return mesh;
}

// Wavefront OBJ: "v" and "vn" lines and triangular or polygonal "f" lines (v, v/t, v//n, v/t/n).
IndexedMesh readObj(const std::string& path, const std::string& data, MeshMetadata& meta) {
  // OBJ is text: a NUL or another control byte means a binary file with the wrong name.
  for (std::size_t at = 0; at < data.size(); ++at) {
    const auto c = static_cast<unsigned char>(data[at]);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r' && c != '\f' && c != '\v') {
      throw Error(fmt::format("{}: not an OBJ file: byte {} is binary (0x{:02x})", path, at, c));
    }
  }
  bool anyElement = false;
  IndexedMesh mesh;
  std::istringstream in(data);
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    throwIfInterruptedEvery(static_cast<std::size_t>(lineNo));
    ++lineNo;
    std::istringstream s(line);
    std::string word;
    s >> word;
    if (!word.empty() && word[0] == '#') {
      const std::size_t text = line.find_first_not_of("# ");
      if (text != std::string::npos) parseMetadataLine(line.substr(text), meta);
    } else if (word == "v" || word == "vn") {
      float x, y, z;
      if (!(s >> x >> y >> z)) throw Error(fmt::format("{}: line {}: a vertex needs three numbers", path, lineNo));
      (word == "v" ? mesh.positions : mesh.normals).push_back({x, y, z});
      anyElement = true;
    } else if (word == "f") {
      std::vector<std::uint64_t> poly;
      std::string item;
      while (s >> item) {
        // "v", "v/t", "v//n" or "v/t/n": v counts from 1, or back from the last vertex when negative.
        const std::string index = item.substr(0, item.find('/'));
        errno = 0;
        char* end = nullptr;
        const long long v = std::strtoll(index.c_str(), &end, 10);
        const auto count = static_cast<long long>(mesh.positions.size());
        if (index.empty() || end != index.c_str() + index.size() || errno == ERANGE || v == 0) {
          throw Error(fmt::format("{}: line {}: a face has the vertex index '{}', not a whole number other than 0",
                                  path, lineNo, index.substr(0, 40)));
        }
        if (v > count || v < -count) {
          throw Error(
              fmt::format("{}: line {}: a face references vertex {} of the {} before it", path, lineNo, v, count));
        }
        poly.push_back(static_cast<std::uint64_t>(v > 0 ? v - 1 : count + v));
      }
      if (poly.size() < 3) throw Error(fmt::format("{}: line {}: a face needs three vertices", path, lineNo));
      addPolygon(mesh, poly, path);
      anyElement = true;
    }
  }
  // An OBJ written by isoslab for an empty surface still names its header in comments.
  if (!anyElement && meta.method.empty() && !meta.iso)
    throw Error(fmt::format("{}: not an OBJ mesh: no vertex or face lines", path));
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) mesh.normals.clear();
  return mesh;
}

}  // namespace isoslab::format
