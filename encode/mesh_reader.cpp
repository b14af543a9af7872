#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "encode/draco_codec.h"
#include "encode/gltf.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"
#include "core/error.h"
#include "core/limits.h"

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
  std::size_t remaining() const { return data_.size() - pos_; }

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

IndexedMesh readPly(const std::string& path, std::string data, MeshMetadata& meta) {
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
    } else if (word == "comment" || word == "obj_info") {
      const std::size_t text = l.find_first_not_of(' ', word.size());
      if (text != std::string::npos) parseMetadataLine(l.substr(text), meta);
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
  // Every element takes at least one byte per property (two in ASCII, with its separator), so the
  // counts are checked against the data's size before anything is read or allocated.
  {
    std::uint64_t need = 0;
    const std::uint64_t have = in.remaining();
    for (const Element& e : elements) {
      if (e.count == 0) continue;
      if (e.properties.empty()) {
        throw Error(fmt::format("{}: PLY element '{}' claims {} items but has no properties", path, e.name, e.count));
      }
      std::uint64_t least = 0;
      for (const Property& p : e.properties)
        least += ascii ? 2 : (p.countType.empty() ? typeSize(p.type) : typeSize(p.countType));
      if (ascii) --least;
      if (e.count > (have - std::min(have, need)) / least) {
        throw Error(fmt::format("{}: PLY element '{}' claims {} items, more than its {} data bytes hold", path, e.name,
                                e.count, have));
      }
      need += e.count * least;
    }
  }
  IndexedMesh mesh;
  std::istringstream text(ascii ? in.rest() : std::string());
  auto scalar = [&](const std::string& type) -> double {
    if (ascii) {
      std::string word;
      if (!(text >> word)) throw Error(fmt::format("{}: the PLY data is truncated", path));
      char* end = nullptr;
      const double v = std::strtod(word.c_str(), &end);
      if (end != word.c_str() + word.size()) {
        throw Error(fmt::format("{}: the PLY data holds '{}', not a number", path, word.substr(0, 40)));
      }
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
          const double claimed = scalar(p.countType);
          if (!(claimed >= 0 && claimed <= static_cast<double>(ascii ? text.str().size() : in.remaining()))) {
            throw Error(fmt::format("{}: a PLY list claims {} items, more than the file holds", path, claimed));
          }
          if (claimed != std::floor(claimed)) {
            throw Error(fmt::format("{}: a PLY list claims {} items, not a whole number", path, claimed));
          }
          const auto count = static_cast<std::uint64_t>(claimed);
          const bool indices = e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index");
          std::vector<std::uint64_t> items;
          for (std::uint64_t k = 0; k < count; ++k) {
            const double v = scalar(p.type);
            // A vertex index is a whole number from 0; a cast would truncate 1.5 and wrap -1.
            if (indices && !(v >= 0 && v == std::floor(v) && v < 18446744073709551616.0)) {
              throw Error(fmt::format("{}: a PLY face has the vertex index {}, not a whole number from 0", path, v));
            }
            if (indices) items.push_back(static_cast<std::uint64_t>(v));
          }
          if (indices) poly = std::move(items);
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
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.positions.size()) {
    throw Error(fmt::format("{}: the PLY file has {} normals for {} vertices", path, mesh.normals.size(),
                            mesh.positions.size()));
  }
  return mesh;
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

// nlohmann's message without its "[json.exception.type_error.302] " prefix, on one line.
std::string jsonReason(const nlohmann::json::exception& e) {
  std::string reason = e.what();
  const std::size_t bracket = reason.find("] ");
  if (reason.rfind("[json.exception.", 0) == 0 && bracket != std::string::npos) reason = reason.substr(bracket + 2);
  for (char& c : reason) {
    if (static_cast<unsigned char>(c) < 0x20) c = ' ';
  }
  return reason;
}

// Overflow-safe bounds: [offset, offset + length) within [0, size).
bool within(std::uint64_t offset, std::uint64_t length, std::uint64_t size) {
  return offset <= size && length <= size - offset;
}

class GlbReader {
 public:
  GlbReader(const std::string& path, const std::string& data) : path_(path), data_(data) {}

  IndexedMesh read(MeshMetadata& meta) {
    if (data_.size() < 20 || data_.compare(0, 4, "glTF") != 0 || u32(4) != 2) {
      throw Error(fmt::format("{}: not a glTF 2.0 binary file", path_));
    }
    const std::uint64_t jsonLength = u32(12);
    if (u32(16) != 0x4E4F534A || !within(20, jsonLength, data_.size())) {
      throw Error(fmt::format("{}: the glTF binary has no JSON chunk", path_));
    }
    try {
      gltf_ = nlohmann::json::parse(data_.begin() + 20, data_.begin() + 20 + static_cast<std::ptrdiff_t>(jsonLength));
    } catch (const nlohmann::json::exception& e) {
      throw Error(fmt::format("{}: the glTF JSON is invalid: {}", path_, jsonReason(e)));
    }
    const std::uint64_t binHeader = 20 + jsonLength;
    if (within(binHeader, 8, data_.size())) {
      binStart_ = binHeader + 8;
      binLength_ = u32(binHeader);
      if (u32(binHeader + 4) != 0x004E4942 || !within(binStart_, binLength_, data_.size())) {
        throw Error(fmt::format("{}: the glTF binary is truncated", path_));
      }
    }
    try {
      readExtras(meta);
      for (const auto& m : gltf_.value("meshes", nlohmann::json::array())) {
        for (const auto& p : m.at("primitives")) readPrimitive(p);
      }
    } catch (const nlohmann::json::exception& e) {
      throw Error(
          fmt::format("{}: the glTF JSON lacks a field or has one of the wrong type ({})", path_, jsonReason(e)));
    }
    return std::move(mesh_);
  }

 private:
  std::uint32_t u32(std::uint64_t at) const {
    std::uint32_t v = 0;
    if (!within(at, 4, data_.size())) throw Error(fmt::format("{}: the glTF binary is truncated", path_));
    std::memcpy(&v, data_.data() + at, 4);
    return v;
  }

  void readExtras(MeshMetadata& meta) {
    const auto asset = gltf_.value("asset", nlohmann::json::object());
    const auto extras = asset.value("extras", nlohmann::json::object());
    if (!extras.is_object()) return;
    if (extras.contains("method") && extras["method"].is_string()) meta.method = extras["method"].get<std::string>();
    if (extras.contains("iso") && extras["iso"].is_number()) meta.iso = extras["iso"].get<double>();
    if (extras.contains("space") && extras["space"].is_string()) meta.space = extras["space"].get<std::string>();
    if (extras.contains("volume_bounds") && extras["volume_bounds"].is_array() && extras["volume_bounds"].size() == 6) {
      meta.volumeBounds = extras["volume_bounds"].get<std::array<double, 6>>();
    }
    if (extras.contains("volume_faces") && extras["volume_faces"].is_array() && extras["volume_faces"].size() == 6) {
      meta.volumeFaces = extras["volume_faces"].get<VolumeFaces>();
    }
    if (extras.contains("quantization_step") && extras["quantization_step"].is_number()) {
      meta.positionTolerance = 0.5 * extras["quantization_step"].get<double>();
    }
  }

  // The bytes of a bufferView, checked against the BIN chunk.
  std::pair<const char*, std::uint64_t> view(std::uint64_t index) const {
    const auto& v = gltf_.at("bufferViews").at(index);
    const std::uint64_t offset = v.value("byteOffset", std::uint64_t{0});
    const std::uint64_t length = v.at("byteLength").get<std::uint64_t>();
    if (v.value("buffer", 0) != 0 || !within(offset, length, binLength_)) {
      throw Error(fmt::format("{}: bufferView {} lies outside the BIN chunk", path_, index));
    }
    return {data_.data() + binStart_ + offset, length};
  }

  // A plain accessor of `components` values per element, as doubles.
  std::vector<double> accessor(std::uint64_t index, int components) const {
    const auto& a = gltf_.at("accessors").at(index);
    const std::uint64_t count = a.at("count").get<std::uint64_t>();
    const int type = a.at("componentType").get<int>();
    const std::uint64_t size = type == 5126 || type == 5125 ? 4 : type == 5123 || type == 5122 ? 2 : 1;
    if (type != 5126 && type != 5125 && type != 5123 && type != 5121) {
      throw Error(fmt::format("{}: accessor {} has component type {}, which is not supported", path_, index, type));
    }
    const auto [bytes, length] = view(a.at("bufferView").get<std::uint64_t>());
    const auto& v = gltf_.at("bufferViews").at(a.at("bufferView").get<std::uint64_t>());
    const std::uint64_t element = size * static_cast<std::uint64_t>(components);
    const std::uint64_t stride = v.value("byteStride", element);
    const std::uint64_t offset = a.value("byteOffset", std::uint64_t{0});
    if (count > 0 && (stride < element || count - 1 > (length - std::min(length, offset + element)) / stride ||
                      !within(offset, element, length))) {
      throw Error(fmt::format("{}: accessor {} lies outside its bufferView", path_, index));
    }
    std::vector<double> out;
    out.reserve(count * static_cast<std::uint64_t>(components));
    for (std::uint64_t e = 0; e < count; ++e) {
      const char* at = bytes + offset + e * stride;
      for (int c = 0; c < components; ++c) {
        const char* p = at + static_cast<std::uint64_t>(c) * size;
        if (type == 5126) {
          float f;
          std::memcpy(&f, p, 4);
          out.push_back(f);
        } else if (type == 5125) {
          std::uint32_t u;
          std::memcpy(&u, p, 4);
          out.push_back(u);
        } else if (type == 5123) {
          std::uint16_t u;
          std::memcpy(&u, p, 2);
          out.push_back(u);
        } else {
          out.push_back(static_cast<unsigned char>(*p));
        }
      }
    }
    return out;
  }

  IndexedMesh plainPrimitive(const nlohmann::json& p) const {
    IndexedMesh part;
    const auto& attributes = p.at("attributes");
    const std::vector<double> pos = accessor(attributes.at("POSITION").get<std::uint64_t>(), 3);
    for (std::size_t k = 0; k + 2 < pos.size(); k += 3) {
      part.positions.push_back(
          {static_cast<float>(pos[k]), static_cast<float>(pos[k + 1]), static_cast<float>(pos[k + 2])});
    }
    if (attributes.contains("NORMAL")) {
      const std::vector<double> n = accessor(attributes.at("NORMAL").get<std::uint64_t>(), 3);
      if (n.size() == pos.size()) {
        for (std::size_t k = 0; k + 2 < n.size(); k += 3) {
          part.normals.push_back(
              {static_cast<float>(n[k]), static_cast<float>(n[k + 1]), static_cast<float>(n[k + 2])});
        }
      }
    }
    if (attributes.contains(kSeamAttribute)) {
      const std::vector<double> k = accessor(attributes.at(kSeamAttribute).get<std::uint64_t>(), 2);
      if (k.size() != pos.size() / 3 * 2) {
        throw Error(
            fmt::format("{}: a primitive has {} seam keys for {} vertices", path_, k.size() / 2, pos.size() / 3));
      }
      for (std::size_t v = 0; v + 1 < k.size(); v += 2) {
        if (!(k[v] >= 0 && k[v] <= 65535 && k[v + 1] >= 0 && k[v + 1] <= 65535)) {
          throw Error(fmt::format("{}: a primitive has a seam key out of range", path_));
        }
        part.seamKeys.push_back(static_cast<std::uint32_t>(k[v]) | (static_cast<std::uint32_t>(k[v + 1]) << 16));
      }
    }
    if (!p.contains("indices")) throw Error(fmt::format("{}: a primitive has no indices", path_));
    const std::vector<double> idx = accessor(p.at("indices").get<std::uint64_t>(), 1);
    for (std::size_t t = 0; t + 2 < idx.size(); t += 3) {
      Triangle tri{};
      for (std::size_t c = 0; c < 3; ++c) {
        if (!(idx[t + c] >= 0 && idx[t + c] < static_cast<double>(part.positions.size()))) {
          throw Error(fmt::format("{}: an index references vertex {} of {}", path_, idx[t + c], part.positions.size()));
        }
        tri[c] = static_cast<VertexId>(idx[t + c]);
      }
      part.triangles.push_back(tri);
    }
    return part;
  }

  void readPrimitive(const nlohmann::json& p) {
    if (p.value("mode", 4) != 4) throw Error(fmt::format("{}: a primitive is not made of triangles", path_));
    IndexedMesh part;
    const auto extensions = p.value("extensions", nlohmann::json::object());
    if (extensions.contains("KHR_draco_mesh_compression")) {
      const auto& draco = extensions.at("KHR_draco_mesh_compression");
      const auto& attributes = draco.at("attributes");
      const int seamId = attributes.contains(kSeamAttribute) ? attributes.at(kSeamAttribute).get<int>() : -1;
      const auto [bytes, length] = view(draco.at("bufferView").get<std::uint64_t>());
      part = dracoDecode(bytes, length, path_, seamId);
    } else {
      part = plainPrimitive(p);
    }
    if ((!part.seamKeys.empty() && part.seamKeys.size() != part.positions.size()) ||
        (!part.normals.empty() && part.normals.size() != part.positions.size())) {
      throw Error(fmt::format("{}: a primitive's attributes differ in length from its {} positions", path_,
                              part.positions.size()));
    }
    // Join the seam with the previous primitive (see draco_writers.h): equal keys (>= 2) are one
    // vertex; an unmarked vertex (0) is the previous primitive's unmarked vertex at its position
    // when each primitive has exactly one there; 1 is never joined.
    const bool keyed = !part.seamKeys.empty();
    auto mark = [&](std::size_t v) { return keyed ? part.seamKeys[v] : 0u; };
    std::unordered_map<PositionKey, int, PositionHash> unmarkedHere;
    for (std::size_t v = 0; v < part.positions.size(); ++v) {
      if (mark(v) == 0) ++unmarkedHere[positionKey(part.positions[v])];
    }
    std::unordered_map<PositionKey, std::pair<VertexId, int>, PositionHash> unmarkedNext;
    std::unordered_map<std::uint32_t, VertexId> keysNext;
    std::vector<VertexId> ids(part.positions.size());
    for (std::size_t v = 0; v < part.positions.size(); ++v) {
      const std::uint32_t m = mark(v);
      const PositionKey at = positionKey(part.positions[v]);
      bool joined = false;
      if (m >= 2 && ((m - 2) & 1) == ((primitives_ - 1) & 1)) {
        const auto found = keys_.find(m);
        if (found != keys_.end()) {
          ids[v] = found->second;
          joined = true;
        }
      } else if (m == 0 && unmarkedHere[at] == 1) {
        const auto found = unmarkedPrevious_.find(at);
        if (found != unmarkedPrevious_.end() && found->second.second == 1) {
          ids[v] = found->second.first;
          joined = true;
        }
      }
      if (!joined) {
        ids[v] = static_cast<VertexId>(mesh_.positions.size());
        mesh_.positions.push_back(part.positions[v]);
        if (!part.normals.empty()) mesh_.normals.push_back(part.normals[v]);
      }
      if (m >= 2 && ((m - 2) & 1) == (primitives_ & 1)) keysNext.emplace(m, ids[v]);
      if (m == 0) {
        auto& slot = unmarkedNext.try_emplace(at, ids[v], 0).first->second;
        ++slot.second;
      }
    }
    unmarkedPrevious_ = std::move(unmarkedNext);
    keys_ = std::move(keysNext);
    ++primitives_;
    for (const Triangle& t : part.triangles) mesh_.triangles.push_back({ids[t[0]], ids[t[1]], ids[t[2]]});
  }

  struct PositionKey {
    std::uint32_t x, y, z;
    bool operator==(const PositionKey&) const = default;
  };
  struct PositionHash {
    std::size_t operator()(const PositionKey& k) const noexcept {
      return (std::size_t{k.x} * 73856093u) ^ (std::size_t{k.y} * 19349663u) ^ (std::size_t{k.z} * 83492791u);
    }
  };
  static PositionKey positionKey(const Vec3f& p) noexcept {
    PositionKey k{};
    std::memcpy(&k, &p, sizeof k);
    return k;
  }

  const std::string& path_;
  const std::string& data_;
  nlohmann::json gltf_;
  std::uint64_t binStart_ = 0;
  std::uint64_t binLength_ = 0;
  IndexedMesh mesh_;
  // The previous primitive's keys for the seam with this one, and how many primitives came before.
  std::unordered_map<std::uint32_t, VertexId> keys_;
  std::uint64_t primitives_ = 0;
  // The previous primitive's unmarked vertices: position -> (id, how many there).
  std::unordered_map<PositionKey, std::pair<VertexId, int>, PositionHash> unmarkedPrevious_;
};

// A binary STL is exactly 84 + 50 n bytes, n being its triangle count; its 80-byte header may
// begin with "solid" all the same (some exporters write that), so the size decides first.
bool isBinaryStl(const std::string& data) {
  if (data.size() < 84) return false;
  std::uint32_t count = 0;
  std::memcpy(&count, data.data() + 80, 4);
  return data.size() == 84 + std::uint64_t{count} * 50;
}

IndexedMesh readMeshData(const std::string& path, std::string data, MeshMetadata& meta) {
  if (data.compare(0, 4, "ply\n") == 0 || data.compare(0, 5, "ply\r\n") == 0)
    return readPly(path, std::move(data), meta);
  const std::size_t dot = path.rfind('.');
  std::string ext = dot == std::string::npos ? "" : path.substr(dot);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (isBinaryStl(data) && (ext == ".stl" || data.compare(0, 5, "solid") == 0)) return readStl(path, data, meta);
  if (data.compare(0, 5, "solid") == 0) throw Error(fmt::format("{}: ASCII STL is not supported", path));
  if (ext == ".stl") return readStl(path, data, meta);
  if (ext == ".obj") return readObj(path, data, meta);
  if (data.compare(0, 4, "glTF") == 0) return GlbReader(path, data).read(meta);
  if (data.compare(0, 5, "DRACO") == 0) return dracoDecode(data.data(), data.size(), path);
  throw Error(fmt::format("{}: unknown mesh format (PLY, binary STL, OBJ, .glb or .drc expected)", path));
}

}  // namespace

IndexedMesh readMesh(const std::string& path, MeshMetadata* metadata) {
  MeshMetadata scratch;
  MeshMetadata& meta = metadata != nullptr ? *metadata : scratch;
  meta = MeshMetadata{};
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
  IndexedMesh mesh = readMeshData(path, std::move(data), meta);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const Vec3f& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw Error(fmt::format("{}: vertex {} is at ({},{},{}): not finite", path, v, p.x, p.y, p.z));
    }
  }
  return mesh;
}

std::vector<std::uint8_t> volumeFaceFlags(const std::vector<Vec3f>& positions, const VolumeFaces& faces, double extra) {
  // The tolerance of float positions a few roundings away from a plane: relative to the volume's
  // distance from the origin and its size.
  double scale = 0;
  for (const FacePlane& f : faces) scale = std::max(scale, std::abs(f[3]));
  const double tolerance = 4e-6 * scale + 1e-9 + extra;
  std::vector<std::uint8_t> flags(positions.size(), 0);
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const Vec3f& p = positions[v];
    for (std::size_t k = 0; k < 6; ++k) {
      const FacePlane& f = faces[k];
      const double d = f[0] * p.x + f[1] * p.y + f[2] * p.z - f[3];
      if (std::abs(d) <= tolerance) flags[v] |= static_cast<std::uint8_t>(1u << k);
    }
  }
  return flags;
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
