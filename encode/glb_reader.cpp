// glTF 2.0 binary (.glb) into an IndexedMesh: Draco-compressed or plain primitives, and the one
// thing no library does for isoslab's files, joining the chunks' seams by their _ISOSLAB_SEAM keys
// (see draco_writers.h).
#include <fmt/format.h>

#include <cstring>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/draco_codec.h"
#include "encode/format_readers.h"
#include "encode/gltf.h"

namespace isoslab::format {
namespace {

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
        primitiveIndex_ = 0;
        for (const auto& p : m.at("primitives")) {
          readPrimitive(p);
          ++primitiveIndex_;
        }
        ++meshIndex_;
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
      throwIfInterruptedEvery(e);
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
      // readPrimitive() has held every attribute's count to POSITION's.
      const std::vector<double> n = accessor(attributes.at("NORMAL").get<std::uint64_t>(), 3);
      for (std::size_t k = 0; k + 2 < n.size(); k += 3) {
        part.normals.push_back({static_cast<float>(n[k]), static_cast<float>(n[k + 1]), static_cast<float>(n[k + 2])});
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
    if (idx.size() % 3 != 0) {
      throw Error(
          fmt::format("{}: a primitive of triangles has {} indices, which is not a multiple of 3", path_, idx.size()));
    }
    for (std::size_t t = 0; t + 2 < idx.size(); t += 3) {
      throwIfInterruptedEvery(t / 3);
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

  // glTF 2.0 (3.7.2.1): every attribute accessor of a primitive has the same count, whether its
  // data is plain or in a KHR_draco_mesh_compression buffer (whose accessors still carry the
  // count). The Khronos validator reports MESH_PRIMITIVE_UNEQUAL_ACCESSOR_COUNT; a reader that
  // went on would pair positions with another vertex's normals or drop some.
  void checkAttributeCounts(const nlohmann::json& p) const {
    const auto& attributes = p.at("attributes");
    if (!attributes.is_object() || !attributes.contains("POSITION")) {
      throw Error(
          fmt::format("{}: mesh {} primitive {} has no POSITION attribute", path_, meshIndex_, primitiveIndex_));
    }
    const auto countOf = [&](const nlohmann::json& index) {
      return gltf_.at("accessors").at(index.get<std::uint64_t>()).at("count").get<std::uint64_t>();
    };
    const std::uint64_t positions = countOf(attributes.at("POSITION"));
    for (const auto& [name, index] : attributes.items()) {
      const std::uint64_t count = countOf(index);
      if (count != positions) {
        throw Error(fmt::format(
            "{}: mesh {} primitive {}: attribute {} has {} elements but POSITION has {} (glTF requires every "
            "attribute of a primitive to have the same count)",
            path_, meshIndex_, primitiveIndex_, name, count, positions));
      }
    }
  }

  void readPrimitive(const nlohmann::json& p) {
    throwIfInterrupted();  // a chunk's decoding and joining take a fraction of a second
    if (p.value("mode", 4) != 4) throw Error(fmt::format("{}: a primitive is not made of triangles", path_));
    checkAttributeCounts(p);
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
    // Points of this primitive with one key are one vertex (Draco splits a vertex whose triangles
    // in the chunk form several fans into one point per fan).
    std::unordered_map<std::uint32_t, VertexId> keysHere;
    std::vector<VertexId> ids(part.positions.size());
    for (std::size_t v = 0; v < part.positions.size(); ++v) {
      throwIfInterruptedEvery(v);
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
      if (!joined && m >= 2) {
        const auto found = keysHere.find(m);
        if (found != keysHere.end()) {
          ids[v] = found->second;
          joined = true;
        }
      }
      if (!joined) {
        ids[v] = static_cast<VertexId>(mesh_.positions.size());
        mesh_.positions.push_back(part.positions[v]);
        if (!part.normals.empty()) mesh_.normals.push_back(part.normals[v]);
      }
      if (m >= 2) keysHere.emplace(m, ids[v]);
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
    mesh_.partEnds.push_back(mesh_.triangles.size());
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
  // Where the reading is, for messages.
  std::uint64_t meshIndex_ = 0;
  std::uint64_t primitiveIndex_ = 0;
  // The previous primitive's keys for the seam with this one, and how many primitives came before.
  std::unordered_map<std::uint32_t, VertexId> keys_;
  std::uint64_t primitives_ = 0;
  // The previous primitive's unmarked vertices: position -> (id, how many there).
  std::unordered_map<PositionKey, std::pair<VertexId, int>, PositionHash> unmarkedPrevious_;
};

}  // namespace

IndexedMesh readGlb(const std::string& path, const std::string& data, MeshMetadata& meta) {
  return GlbReader(path, data).read(meta);
}

}  // namespace isoslab::format
