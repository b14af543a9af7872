#include "encode/gltf.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <limits>

#include "core/atomic_file.h"
#include "core/error.h"
#include "encode/mesh_metadata.h"

namespace isoslab {
namespace {

std::string unitsOf(const std::string& space) {
  if (space == "lps" || space == "ras") return "millimetre";
  if (space == "voxel") return "voxel";
  return "input units";
}

}  // namespace

std::array<double, 16> gltfFrameMatrix(const std::string& space) {
  constexpr double s = 0.001;  // millimetres to metres
  if (space == "ras") return {-s, 0, 0, 0, 0, 0, s, 0, 0, s, 0, 0, 0, 0, 0, 1};
  return {s, 0, 0, 0, 0, 0, -s, 0, 0, s, 0, 0, 0, 0, 0, 1};
}

nlohmann::ordered_json gltfDocument(const MeshHeader& header, const WriterOptions& options, bool hasMesh,
                                    const nlohmann::ordered_json& extras) {
  nlohmann::ordered_json gltf;
  nlohmann::ordered_json ex = {
      {"method", header.method}, {"iso", header.iso}, {"space", header.space}, {"units", unitsOf(header.space)}};
  const std::string tag = spaceTag(header.space);
  if (!tag.empty()) ex["coordinate_system"] = tag;
  ex["frame"] = options.gltfFrame ? "gltf" : "raw";
  if (header.volumeFaces) {
    ex["volume_bounds"] = header.volumeBounds;
    nlohmann::ordered_json faces = nlohmann::ordered_json::array();
    for (const FacePlane& f : *header.volumeFaces) faces.push_back(f);
    ex["volume_faces"] = faces;
  }
  for (const auto& [key, value] : extras.items()) ex[key] = value;
  gltf["asset"] = {{"version", "2.0"}, {"generator", "isoslab " ISOSLAB_VERSION}, {"extras", ex}};
  gltf["scene"] = 0;
  if (!hasMesh) {
    gltf["scenes"] = {{{"nodes", nlohmann::ordered_json::array()}}};
    return gltf;
  }
  nlohmann::ordered_json meshNode = {{"mesh", 0}, {"name", "isosurface"}};
  if (options.gltfFrame) {
    gltf["scenes"] = {{{"nodes", {0}}}};
    gltf["nodes"] = {{{"name", fmt::format("{} to glTF", tag.empty() ? header.space : tag)},
                      {"matrix", gltfFrameMatrix(header.space)},
                      {"children", {1}}},
                     meshNode};
  } else {
    gltf["scenes"] = {{{"nodes", {0}}}};
    gltf["nodes"] = {meshNode};
  }
  // Without a material, viewers fall back to glTF's default: metalness 1, which renders dark.
  gltf["materials"] = {
      {{"name", "isosurface"},
       {"pbrMetallicRoughness",
        {{"baseColorFactor", {0.9, 0.86, 0.8, 1.0}}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.6}}},
       {"doubleSided", true}}};
  return gltf;
}

std::int64_t writeGlbFile(const std::string& path, const nlohmann::ordered_json& gltf,
                          const std::vector<SpoolFile*>& bin) {
  // Strings from the input (names, metadata) that are not UTF-8 get U+FFFD: JSON holds UTF-8 only.
  std::string json = gltf.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  json.append((4 - json.size() % 4) % 4, ' ');
  std::int64_t binLength = 0;
  for (const SpoolFile* spool : bin) binLength += spool->size();
  const std::int64_t total = 12 + 8 + static_cast<std::int64_t>(json.size()) + (binLength > 0 ? 8 + binLength : 0);
  if (total > std::int64_t{std::numeric_limits<std::uint32_t>::max()}) {
    throw Error(
        fmt::format("{}: the mesh needs {} bytes, over the 4 GiB limit of a .glb; write .ply or .drc, or "
                    "lower `quant_bits`",
                    path, total));
  }
  AtomicFile out(path);
  auto u32 = [&out](std::int64_t v) {
    const auto w = static_cast<std::uint32_t>(v);
    out.write(&w, 4);
  };
  out.write("glTF", 4);
  u32(2);
  u32(total);
  u32(static_cast<std::int64_t>(json.size()));
  u32(0x4E4F534A);  // JSON
  out.write(json.data(), json.size());
  if (binLength > 0) {
    u32(binLength);
    u32(0x004E4942);  // BIN
    for (SpoolFile* spool : bin) spool->copyTo(out);
  }
  const std::int64_t size = out.size();
  out.commit();
  return size;
}

GlbPlainWriter::GlbPlainWriter(std::string path, const WriterOptions& options)
    : path_(std::move(path)), options_(options) {}

GlbPlainWriter::~GlbPlainWriter() = default;

void GlbPlainWriter::begin(const MeshHeader& header) {
  header_ = header;
  AtomicFile probe(path_);  // fail early on an unwritable destination
  const std::string folder = folderOf(path_);
  positions_ = std::make_unique<SpoolFile>(folder, path_);
  if (header.normals) normals_ = std::make_unique<SpoolFile>(folder, path_);
  indices_ = std::make_unique<SpoolFile>(folder, path_);
  min_ = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
  max_ = {-min_[0], -min_[1], -min_[2]};
}

void GlbPlainWriter::consume(const MeshChunk& chunk) {
  if (chunk.firstVertex != vertices_) {
    throw Error(fmt::format("{}: internal error: chunk {} starts at vertex {}, not {}", path_, chunk.slab,
                            chunk.firstVertex, vertices_));
  }
  for (const Vec3f& p : chunk.positions) {
    const float c[3] = {p.x, p.y, p.z};
    for (std::size_t a = 0; a < 3; ++a) {
      min_[a] = std::min(min_[a], c[a]);
      max_[a] = std::max(max_[a], c[a]);
    }
  }
  static_assert(sizeof(Vec3f) == 12 && sizeof(Triangle) == 12);
  positions_->write(chunk.positions.data(), chunk.positions.size() * sizeof(Vec3f));
  if (normals_) normals_->write(chunk.normals.data(), chunk.normals.size() * sizeof(Vec3f));
  indices_->write(chunk.triangles.data(), chunk.triangles.size() * sizeof(Triangle));
  vertices_ += chunk.positions.size();
  triangles_ += chunk.triangles.size();
}

void GlbPlainWriter::finish() {
  const bool hasMesh = triangles_ > 0;
  nlohmann::ordered_json gltf = gltfDocument(header_, options_, hasMesh, nlohmann::ordered_json::object());
  std::vector<SpoolFile*> bin;
  if (hasMesh) {
    nlohmann::ordered_json views = nlohmann::ordered_json::array();
    nlohmann::ordered_json accessors = nlohmann::ordered_json::array();
    nlohmann::ordered_json attributes;
    std::int64_t offset = 0;
    auto view = [&](const SpoolFile& spool, int target) {
      views.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", spool.size()}, {"target", target}});
      offset += spool.size();
      return views.size() - 1;
    };
    attributes["POSITION"] = accessors.size();
    accessors.push_back({{"bufferView", view(*positions_, 34962)},
                         {"componentType", 5126},
                         {"count", vertices_},
                         {"type", "VEC3"},
                         {"min", min_},
                         {"max", max_}});
    if (normals_) {
      attributes["NORMAL"] = accessors.size();
      accessors.push_back(
          {{"bufferView", view(*normals_, 34962)}, {"componentType", 5126}, {"count", vertices_}, {"type", "VEC3"}});
    }
    const std::size_t indices = accessors.size();
    accessors.push_back({{"bufferView", view(*indices_, 34963)},
                         {"componentType", 5125},
                         {"count", 3 * triangles_},
                         {"type", "SCALAR"}});
    gltf["meshes"] = {
        {{"name", "isosurface"},
         {"primitives", {{{"attributes", attributes}, {"indices", indices}, {"mode", 4}, {"material", 0}}}}}};
    gltf["accessors"] = accessors;
    gltf["bufferViews"] = views;
    gltf["buffers"] = {{{"byteLength", offset}}};
    // One BIN chunk: the spools one after the other (each a multiple of 4 bytes).
    for (SpoolFile* spool : {positions_.get(), normals_.get(), indices_.get()}) {
      if (spool != nullptr) bin.push_back(spool);
    }
  }
  bytes_ = writeGlbFile(path_, gltf, bin);
  positions_.reset();
  normals_.reset();
  indices_.reset();
}

}  // namespace isoslab
