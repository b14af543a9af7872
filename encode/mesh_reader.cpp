#include <fmt/format.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "encode/draco_codec.h"
#include "encode/indexed_mesh.h"
#include "io/error.h"

namespace isoslab {
namespace {

struct Property {
  std::string name;
  std::string type;       // scalar type, or the item type of a list
  std::string countType;  // set for lists
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

std::size_t typeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

double decode(const char* p, const std::string& t) {
  auto get = [p]<typename T>(T) {
    T v;
    std::memcpy(&v, p, sizeof v);
    return static_cast<double>(v);
  };
  if (t == "char" || t == "int8") return get(std::int8_t{});
  if (t == "uchar" || t == "uint8") return get(std::uint8_t{});
  if (t == "short" || t == "int16") return get(std::int16_t{});
  if (t == "ushort" || t == "uint16") return get(std::uint16_t{});
  if (t == "int" || t == "int32") return get(std::int32_t{});
  if (t == "uint" || t == "uint32") return get(std::uint32_t{});
  if (t == "float" || t == "float32") return get(float{});
  return get(double{});
}

class Input {
 public:
  Input(const std::string& path, std::string data) : path_(path), data_(std::move(data)) {}
  const char* take(std::size_t n) {
    if (pos_ + n > data_.size()) throw Error(fmt::format("{}: the file is truncated", path_));
    const char* p = data_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::string line() {
    const std::size_t end = data_.find('\n', pos_);
    if (end == std::string::npos) throw Error(fmt::format("{}: the PLY header is not terminated", path_));
    std::string l = data_.substr(pos_, end - pos_);
    pos_ = end + 1;
    if (!l.empty() && l.back() == '\r') l.pop_back();
    return l;
  }
  std::string rest() const { return data_.substr(pos_); }

 private:
  std::string path_;
  std::string data_;
  std::size_t pos_ = 0;
};

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

IndexedMesh readPly(const std::string& path, std::string data) {
  Input in(path, std::move(data));
  if (in.line() != "ply") throw Error(fmt::format("{}: not a PLY file", path));
  std::string format;
  std::vector<Element> elements;
  for (std::string l = in.line(); l != "end_header"; l = in.line()) {
    std::istringstream s(l);
    std::string word;
    s >> word;
    if (word == "format") {
      s >> format;
    } else if (word == "element") {
      Element e;
      s >> e.name >> e.count;
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) throw Error(fmt::format("{}: a PLY property precedes every element", path));
      Property p;
      std::string t;
      s >> t;
      if (t == "list") {
        s >> p.countType >> p.type >> p.name;
      } else {
        p.type = t;
        s >> p.name;
      }
      if (typeSize(p.type) == 0 || (!p.countType.empty() && typeSize(p.countType) == 0)) {
        throw Error(fmt::format("{}: unknown PLY property type in '{}'", path, l));
      }
      elements.back().properties.push_back(p);
    }
  }
  if (format != "binary_little_endian" && format != "ascii") {
    throw Error(fmt::format("{}: PLY format '{}' is not supported (binary_little_endian or ascii)", path, format));
  }
  const bool ascii = format == "ascii";
  IndexedMesh mesh;
  std::istringstream text(ascii ? in.rest() : std::string());
  auto scalar = [&](const std::string& type) -> double {
    if (ascii) {
      double v;
      if (!(text >> v)) throw Error(fmt::format("{}: the PLY data is truncated", path));
      return v;
    }
    return decode(in.take(typeSize(type)), type);
  };
  for (const Element& e : elements) {
    for (std::uint64_t n = 0; n < e.count; ++n) {
      double xyz[6] = {0, 0, 0, 0, 0, 0};
      bool hasNormal = false;
      std::vector<std::uint64_t> poly;
      for (const Property& p : e.properties) {
        if (!p.countType.empty()) {
          const auto count = static_cast<std::uint64_t>(scalar(p.countType));
          std::vector<std::uint64_t> items;
          for (std::uint64_t k = 0; k < count; ++k) items.push_back(static_cast<std::uint64_t>(scalar(p.type)));
          if (e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index")) poly = std::move(items);
          continue;
        }
        const double v = scalar(p.type);
        static const char* kNames[6] = {"x", "y", "z", "nx", "ny", "nz"};
        for (int k = 0; k < 6; ++k) {
          if (p.name == kNames[k]) {
            xyz[k] = v;
            if (k >= 3) hasNormal = true;
          }
        }
      }
      if (e.name == "vertex") {
        mesh.positions.push_back({static_cast<float>(xyz[0]), static_cast<float>(xyz[1]), static_cast<float>(xyz[2])});
        if (hasNormal)
          mesh.normals.push_back({static_cast<float>(xyz[3]), static_cast<float>(xyz[4]), static_cast<float>(xyz[5])});
      } else if (e.name == "face") {
        addPolygon(mesh, poly, path);
      }
    }
  }
  return mesh;
}

IndexedMesh readStl(const std::string& path, const std::string& data) {
  if (data.size() < 84) throw Error(fmt::format("{}: the STL file is truncated", path));
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
IndexedMesh readObj(const std::string& path, const std::string& data) {
  IndexedMesh mesh;
  std::istringstream in(data);
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    std::istringstream s(line);
    std::string word;
    s >> word;
    if (word == "v" || word == "vn") {
      float x, y, z;
      if (!(s >> x >> y >> z)) throw Error(fmt::format("{}: line {}: a vertex needs three numbers", path, lineNo));
      (word == "v" ? mesh.positions : mesh.normals).push_back({x, y, z});
    } else if (word == "f") {
      std::vector<std::uint64_t> poly;
      std::string item;
      while (s >> item) {
        const long long v = std::stoll(item.substr(0, item.find('/')));
        poly.push_back(static_cast<std::uint64_t>(v > 0 ? v - 1 : static_cast<long long>(mesh.positions.size()) + v));
      }
      addPolygon(mesh, poly, path);
    }
  }
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) mesh.normals.clear();
  return mesh;
}

// A .glb of Draco-compressed primitives: every primitive is decoded, and a vertex of a later
// primitive whose position equals (bit for bit) a vertex of an earlier one is welded to it, which
// rejoins the chunks along their seams. Vertices within one primitive are never merged.
IndexedMesh readGlb(const std::string& path, const std::string& data) {
  auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    if (at + 4 > data.size()) throw Error(fmt::format("{}: the glTF binary is truncated", path));
    std::memcpy(&v, data.data() + at, 4);
    return v;
  };
  if (data.size() < 20 || data.compare(0, 4, "glTF") != 0 || u32(4) != 2) {
    throw Error(fmt::format("{}: not a glTF 2.0 binary file", path));
  }
  const std::uint32_t jsonLength = u32(12);
  if (u32(16) != 0x4E4F534A || 20 + std::uint64_t{jsonLength} > data.size()) {
    throw Error(fmt::format("{}: the glTF binary has no JSON chunk", path));
  }
  nlohmann::json gltf;
  try {
    gltf = nlohmann::json::parse(data.begin() + 20, data.begin() + 20 + jsonLength);
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: the glTF JSON is invalid: {}", path, e.what()));
  }
  const std::size_t binStart = 20 + jsonLength + 8;
  const std::size_t binLength = data.size() >= binStart ? u32(20 + jsonLength) : 0;
  if (binStart + binLength > data.size()) throw Error(fmt::format("{}: the glTF binary is truncated", path));
  IndexedMesh mesh;
  struct Key {
    std::uint32_t x, y, z;
    bool operator==(const Key&) const = default;
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      return (std::size_t{k.x} * 73856093u) ^ (std::size_t{k.y} * 19349663u) ^ (std::size_t{k.z} * 83492791u);
    }
  };
  std::unordered_map<Key, VertexId, Hash> earlier;
  try {
    for (const auto& m : gltf.value("meshes", nlohmann::json::array())) {
      for (const auto& p : m.at("primitives")) {
        const auto& draco = p.at("extensions").at("KHR_draco_mesh_compression");
        const auto& view = gltf.at("bufferViews").at(draco.at("bufferView").get<std::size_t>());
        const std::size_t offset = view.value("byteOffset", std::size_t{0});
        const std::size_t length = view.at("byteLength").get<std::size_t>();
        if (offset + length > binLength) throw Error(fmt::format("{}: a bufferView lies outside the BIN chunk", path));
        const IndexedMesh part = dracoDecode(data.data() + binStart + offset, length, path);
        std::vector<VertexId> ids(part.positions.size());
        std::vector<Key> keys(part.positions.size());
        for (std::size_t v = 0; v < part.positions.size(); ++v) {
          std::memcpy(&keys[v], &part.positions[v], sizeof(Key));
          auto found = earlier.find(keys[v]);
          if (found != earlier.end()) {
            ids[v] = found->second;
          } else {
            ids[v] = static_cast<VertexId>(mesh.positions.size());
            mesh.positions.push_back(part.positions[v]);
            if (!part.normals.empty()) mesh.normals.push_back(part.normals[v]);
          }
        }
        for (std::size_t v = 0; v < part.positions.size(); ++v) earlier.emplace(keys[v], ids[v]);
        for (const Triangle& t : part.triangles) mesh.triangles.push_back({ids[t[0]], ids[t[1]], ids[t[2]]});
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(fmt::format("{}: the glTF JSON lacks a Draco primitive's fields: {}", path, e.what()));
  }
  return mesh;
}

}  // namespace

IndexedMesh readMesh(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  std::string data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (data.compare(0, 4, "ply\n") == 0 || data.compare(0, 5, "ply\r\n") == 0) return readPly(path, std::move(data));
  if (data.compare(0, 5, "solid") == 0) throw Error(fmt::format("{}: ASCII STL is not supported", path));
  const std::size_t dot = path.rfind('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".stl") return readStl(path, data);
  if (ext == ".obj") return readObj(path, data);
  if (data.compare(0, 4, "glTF") == 0) return readGlb(path, data);
  if (data.compare(0, 5, "DRACO") == 0) return dracoDecode(data.data(), data.size(), path);
  throw Error(fmt::format("{}: unknown mesh format (PLY, binary STL, .glb or .drc expected)", path));
}

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
