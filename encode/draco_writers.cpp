// size-exception: the .glb writer's chunking, seam keys and parallel encoders share private state
// (the waiting chunk, the seam keys); the .drc writer beside it is short.
#include "encode/draco_writers.h"

#include "encode/glb_scene.h"

#include "core/fans.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "encode/gltf.h"

namespace isoslab {
namespace {

using Clock = std::chrono::steady_clock;
constexpr VertexId kNone = std::numeric_limits<VertexId>::max();

// The largest distance between a position and its quantized value.
double quantizationError(const IndexedMesh& mesh, const DracoSettings& s) {
  double worst = 0;
  for (const Vec3f& p : mesh.positions) {
    const float c[3] = {p.x, p.y, p.z};
    for (int a = 0; a < 3; ++a) {
      const float q = dracoDequantized(c[a], s.origin[static_cast<std::size_t>(a)], s);
      worst = std::max(worst, std::abs(static_cast<double>(q) - static_cast<double>(c[a])));
    }
  }
  return worst;
}

// Draco quantizes positions on a grid over the volume's box. A position off the grid (a NaN, or a
// decoded mesh whose vertices lie outside the box its metadata states) would overflow the
// quantizer's integers. (A margin of 1/1000 of the grid keeps float rounding on the box's faces in.)
void checkOnGrid(const std::vector<Vec3f>& positions, const DracoSettings& s, const std::string& path) {
  const double margin = 1e-3 * static_cast<double>(s.range);
  for (const Vec3f& p : positions) {
    const float c[3] = {p.x, p.y, p.z};
    for (std::size_t a = 0; a < 3; ++a) {
      const double offset = static_cast<double>(c[a]) - static_cast<double>(s.origin[a]);
      if (!(offset >= -margin && offset <= static_cast<double>(s.range) + margin)) {
        throw Error(
            fmt::format("{}: a vertex at ({}, {}, {}) lies outside the volume's box, which Draco's "
                        "quantization grid covers (from {}, {}, {}, {} on each axis)",
                        path, p.x, p.y, p.z, s.origin[0], s.origin[1], s.origin[2], s.range));
      }
    }
  }
}

void checkOptions(const WriterOptions& options) {
  if (options.dracoLevel < 0 || options.dracoLevel > 10) {
    throw Error(fmt::format("`draco_level`: {} is not in 0..10", options.dracoLevel));
  }
  if (options.quantBits < 0 || options.quantBits > 30) {
    throw Error(fmt::format("`quant_bits`: {} is not in 1..30", options.quantBits));
  }
}

std::vector<std::pair<std::string, double>> dracoDetails(double chunks, double encodeSeconds, double worstError,
                                                         const DracoSettings& s) {
  return {{"chunks", chunks},
          {"encode_seconds", encodeSeconds},
          {"quantization_bits", s.quantBits},
          {"quantization_step", s.range / (std::ldexp(1.0, s.quantBits) - 1)},
          {"worst_quantization_error", worstError},
          {"draco_level", s.level}};
}

}  // namespace

DracoSettings dracoSettingsFor(const std::array<double, 6>& box, const WriterOptions& options) {
  DracoSettings s;
  s.level = options.dracoLevel;
  double range = 0;
  for (int a = 0; a < 3; ++a) {
    // A little margin so that no vertex rounds outside the grid.
    s.origin[static_cast<std::size_t>(a)] =
        static_cast<float>(box[static_cast<std::size_t>(a)] - 1e-3 * options.voxelSize);
    range = std::max(range, box[static_cast<std::size_t>(a + 3)] - box[static_cast<std::size_t>(a)]);
  }
  s.range = static_cast<float>(range + 2e-3 * options.voxelSize);
  s.quantBits = options.quantBits > 0 ? options.quantBits : defaultQuantBits(s.range, options.voxelSize);
  return s;
}

GlbDracoWriter::GlbDracoWriter(std::string path, const WriterOptions& options)
    : path_(std::move(path)), options_(options) {
  checkOptions(options);
  if (options.chunkTriangles < 1)
    throw Error(fmt::format("`chunk_triangles`: {} must be positive", options.chunkTriangles));
}

GlbDracoWriter::GlbDracoWriter(std::string path, const WriterOptions& options, GlbScene& scene, std::string name,
                               std::array<std::uint8_t, 3> color)
    : GlbDracoWriter(std::move(path), options) {
  scene_ = &scene;
  sceneName_ = std::move(name);
  sceneColor_ = color;
}

GlbScene::GlbScene(std::string path, const WriterOptions& options) : path_(std::move(path)), options_(options) {}
GlbScene::~GlbScene() = default;

void GlbScene::begin(const MeshHeader& header) {
  header_ = header;
  AtomicFile probe(path_);  // fail early on an unwritable destination
  spool_ = std::make_unique<SpoolFile>(folderOf(path_), path_);
}

std::size_t GlbScene::addAccessor(nlohmann::ordered_json accessor) {
  accessors_.push_back(std::move(accessor));
  return accessors_.size() - 1;
}

std::size_t GlbScene::addView(nlohmann::ordered_json view) {
  views_.push_back(std::move(view));
  return views_.size() - 1;
}

std::int64_t GlbScene::write(const nlohmann::ordered_json& extras) {
  const bool any = !meshes_.empty();
  nlohmann::ordered_json gltf = gltfDocument(header_, options_, false, extras);
  gltf["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  gltf["extensionsRequired"] = {"KHR_draco_mesh_compression"};
  if (any) {
    nlohmann::ordered_json nodes = nlohmann::ordered_json::array();
    nlohmann::ordered_json meshes = nlohmann::ordered_json::array();
    nlohmann::ordered_json materials = nlohmann::ordered_json::array();
    nlohmann::ordered_json children = nlohmann::ordered_json::array();
    const std::size_t first = options_.gltfFrame ? 1 : 0;
    for (std::size_t k = 0; k < meshes_.size(); ++k) {
      Mesh& m = meshes_[k];
      for (auto& p : m.primitives) p["material"] = k;
      meshes.push_back({{"name", m.name}, {"primitives", m.primitives}});
      nodes.push_back({{"mesh", k}, {"name", m.name}, {"extras", m.extras}});
      children.push_back(first + k);
      // glTF's base colour is linear: the sRGB colour decoded.
      nlohmann::ordered_json rgba = nlohmann::ordered_json::array();
      for (std::uint8_t c : m.color) {
        const double v = c / 255.0;
        rgba.push_back(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
      }
      rgba.push_back(1.0);
      materials.push_back(
          {{"name", m.name},
           {"pbrMetallicRoughness", {{"baseColorFactor", rgba}, {"metallicFactor", 0.0}, {"roughnessFactor", 0.6}}},
           {"doubleSided", false}});
    }
    if (options_.gltfFrame) {
      const std::string tag = header_.space == "lps" || header_.space == "physical" ? "LPS" : header_.space;
      const nlohmann::ordered_json root = {{"name", fmt::format("{} to glTF", header_.space == "ras" ? "RAS" : tag)},
                                           {"matrix", gltfFrameMatrix(header_.space)},
                                           {"children", children}};
      nodes.insert(nodes.begin(), root);
      gltf["scenes"] = {{{"nodes", {0}}}};
    } else {
      gltf["scenes"] = {{{"nodes", children}}};
    }
    gltf["nodes"] = nodes;
    gltf["meshes"] = meshes;
    gltf["materials"] = materials;
    gltf["accessors"] = accessors_;
    gltf["bufferViews"] = views_;
    gltf["buffers"] = {{{"byteLength", spool_->size()}}};
  }
  const std::int64_t bytes = writeGlbFile(path_, gltf, {spool_.get()});
  spool_.reset();
  return bytes;
}

namespace {

// The vertices that Draco's Edgebreaker coder splits into several points: those whose triangles in
// the chunk form more than one fan (core/fans.h) or that lie on an edge of more than two triangles.
// Decoders get one point per fan, at one position.
std::vector<bool> splitByDraco(const IndexedMesh& mesh) {
  std::vector<bool> split(mesh.positions.size(), false);
  {
    const auto fans = fanCounts(mesh.triangles, mesh.positions.size());
    for (std::size_t v = 0; v < split.size(); ++v) split[v] = fans[v] > 1;
  }
  // Edges of more than two triangles: one sorted array (no hash map: its many small nodes would
  // fragment the heap just before Draco's encoder needs it).
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) {
    for (std::size_t k = 0; k < 3; ++k) {
      const VertexId a = t[k];
      const VertexId b = t[(k + 1) % 3];
      edges.push_back((std::uint64_t{std::min(a, b)} << 32) | std::max(a, b));
    }
  }
  std::sort(edges.begin(), edges.end());
  for (std::size_t i = 0; i + 2 < edges.size(); ++i) {
    if (edges[i] == edges[i + 2]) {
      split[static_cast<VertexId>(edges[i] >> 32)] = true;
      split[static_cast<VertexId>(edges[i] & 0xFFFFFFFFu)] = true;
    }
  }
  return split;
}

}  // namespace

GlbDracoWriter::~GlbDracoWriter() = default;

void GlbDracoWriter::begin(const MeshHeader& header) {
  header_ = header;
  settings_ = dracoSettingsFor(header.volumeBounds, options_);
  if (scene_ != nullptr) {
    spool_ = &scene_->spool();
    return;
  }
  // Fail early on an unwritable destination, before any work.
  AtomicFile probe(path_);
  ownSpool_ = std::make_unique<SpoolFile>(folderOf(path_), path_);
  spool_ = ownSpool_.get();
}

VertexId GlbDracoWriter::localVertex(VertexId id) {
  VertexId* slot = nullptr;
  if (id >= chunkFirst_) {
    slot = &local_[id - chunkFirst_];
  } else {
    slot = &seam_.try_emplace(id, kNone).first->second;
  }
  if (*slot == kNone) {
    *slot = static_cast<VertexId>(current_.positions.size());
    current_.positions.push_back(window_.position(id));
    current_.seamKeys.push_back(0);
    if (header_.normals) current_.normals.push_back(window_.normal(id));
  }
  return *slot;
}

void GlbDracoWriter::consume(const MeshChunk& chunk) {
  checkOnGrid(chunk.positions, settings_, path_);
  window_.push(chunk);
  vertices_ += chunk.positions.size();
  if (current_.triangles.empty()) {
    // A chunk closes at the first slab boundary past chunkTriangles: room for that and a few
    // slabs more, so that the vectors do not double past it.
    const auto expected =
        static_cast<std::size_t>(std::min<std::int64_t>(options_.chunkTriangles, 1 << 22)) + 4 * chunk.triangles.size();
    current_.triangles.reserve(expected);
    current_.positions.reserve(expected / 2 + chunk.positions.size());
    current_.seamKeys.reserve(expected / 2 + chunk.positions.size());
    if (header_.normals) current_.normals.reserve(expected / 2 + chunk.positions.size());
  }
  local_.resize(chunk.endVertex() - chunkFirst_, kNone);
  for (const Triangle& t : chunk.triangles) {
    current_.triangles.push_back({localVertex(t[0]), localVertex(t[1]), localVertex(t[2])});
  }
  triangles_ += chunk.triangles.size();
  // Only this slab can reference the waiting chunk's vertices: its keys are complete now.
  if (pending_) {
    if (options_.seamKeys) {
      resolveSeam();
    } else {
      ++seams_;
      flush(std::move(*pending_));
      pending_.reset();
    }
  }
  if (static_cast<std::int64_t>(current_.triangles.size()) >= options_.chunkTriangles) close(chunk);
}

// Closes the current chunk after `last`, its last slab; it waits for the next slab's references.
void GlbDracoWriter::close(const MeshChunk& last) {
  pendingTopFirst_ = last.firstVertex;
  pendingTop_.assign(local_.begin() + (last.firstVertex - chunkFirst_), local_.end());
  pending_ = std::move(current_);
  current_ = IndexedMesh{};
  local_.clear();
  seam_.clear();
  chunkFirst_ = last.endVertex();
}

// Marks the seam between the waiting chunk and the current one so that decoders join it exactly
// (see draco_writers.h): at a quantized position that both chunks hold, one vertex each and the
// same vertex is left unmarked (0), and decoders weld it by position; anywhere else, a shared vertex
// gets its key (global id + 2) in both chunks and every other vertex there gets 1, "never weld".
// Only the waiting chunk's last slab can lie within a quantization step of the current chunk's
// first slab, so only those vertices are compared.
// size-exception: the seam's three cases (one unmarked vertex each side, keyed, never weld) are
// decided together per position group; split, each part would rebuild the groups.
void GlbDracoWriter::keySeam() {
  struct Group {
    std::vector<VertexId> there;  // in the waiting chunk
    std::vector<VertexId> here;   // in the current chunk
  };
  auto quantized = [this](const Vec3f& p) {
    std::array<std::int32_t, 3> q{};
    const float c[3] = {p.x, p.y, p.z};
    for (std::size_t a = 0; a < 3; ++a) q[a] = dracoQuantized(c[a], settings_.origin[a], settings_);
    return q;
  };
  struct Hash {
    std::size_t operator()(const std::array<std::int32_t, 3>& q) const noexcept {
      return (static_cast<std::size_t>(static_cast<std::uint32_t>(q[0])) * 73856093u) ^
             (static_cast<std::size_t>(static_cast<std::uint32_t>(q[1])) * 19349663u) ^
             (static_cast<std::size_t>(static_cast<std::uint32_t>(q[2])) * 83492791u);
    }
  };
  std::unordered_map<std::array<std::int32_t, 3>, Group, Hash> groups;
  groups.reserve(pendingTop_.size());
  for (const VertexId there : pendingTop_) {
    if (there != kNone) groups[quantized(pending_->positions[there])].there.push_back(there);
  }
  // The shared vertices: the current chunk's partner of each waiting-chunk vertex.
  std::unordered_map<VertexId, std::pair<VertexId, VertexId>> partner;  // here -> (there, global id)
  for (const auto& [id, here] : seam_) {
    if (id < pendingTopFirst_ || id - pendingTopFirst_ >= pendingTop_.size()) continue;
    const VertexId there = pendingTop_[id - pendingTopFirst_];
    if (there != kNone) partner.emplace(here, std::make_pair(there, id));
  }
  for (VertexId here = 0; here < current_.positions.size(); ++here) {
    const auto found = groups.find(quantized(current_.positions[here]));
    if (found != groups.end()) found->second.here.push_back(here);
  }
  std::uint32_t keysThisSeam = 0;
  std::vector<std::uint32_t>& thereKeys = pending_->seamKeys;
  std::vector<std::uint32_t>& hereKeys = current_.seamKeys;
  // A vertex that Draco will split cannot be welded by position (the decoder finds two points
  // there): it takes a key. The current chunk's shared vertices have all their triangles already
  // (only this slab could use the waiting chunk's vertices).
  const std::vector<bool> splitThere = splitByDraco(*pending_);
  const std::vector<bool> splitHere = splitByDraco(current_);
  const auto nextKey = [&] {
    const std::uint64_t wide = 2 + 2 * std::uint64_t{keysThisSeam++} + (seams_ & 1);
    if (wide > 0xFFFFFFFFu) throw Error(fmt::format("{}: too many seam keys", path_));
    return static_cast<std::uint32_t>(wide);
  };
  for (auto& [q, g] : groups) {
    if (g.here.empty()) continue;
    if (g.there.size() == 1 && g.here.size() == 1 && thereKeys[g.there[0]] == 0 && !splitThere[g.there[0]] &&
        !splitHere[g.here[0]]) {
      const auto p = partner.find(g.here[0]);
      if (p != partner.end() && p->second.first == g.there[0]) {
        ++seamVertices_;
        continue;  // unambiguous: decoders weld it by position
      }
    }
    for (const VertexId here : g.here) {
      const auto p = partner.find(here);
      if (p == partner.end()) {
        if (hereKeys[here] == 0) {
          hereKeys[here] = 1;
          ++unweldedVertices_;
        }
        continue;
      }
      // Small keys compress well: 2, 4, 6, ... on even seams and 3, 5, 7, ... on odd ones, so that a
      // chunk's keys with its lower and its upper neighbour never collide.
      const std::uint32_t key = nextKey();
      hereKeys[here] = key;
      thereKeys[p->second.first] = key;
      ++seamVertices_;
      ++keyedVertices_;
    }
    for (const VertexId there : g.there) {
      if (thereKeys[there] == 0) {
        thereKeys[there] = 1;
        ++unweldedVertices_;
      }
    }
  }
  // The waiting chunk's other split vertices: a key of their own (of this seam's parity, after its
  // keys), which tells decoders to join the points that Draco made of each.
  for (VertexId v = 0; v < pending_->positions.size(); ++v) {
    if (splitThere[v] && thereKeys[v] < 2) {
      thereKeys[v] = nextKey();
      ++keyedVertices_;
    }
  }
}

// The seam's keys, then the waiting chunk encoded: keySeam()'s maps are gone by then, and the
// encoder's working memory (the peak of a long run at one thread) comes on top of less.
void GlbDracoWriter::resolveSeam() {
  keySeam();
  ++seams_;
  pendingTop_.clear();
  flush(std::move(*pending_));
  pending_.reset();
}

// The last chunks' split vertices, as resolveSeam() keys the others: keys of the parity of the seam
// that would come next, which no lower-seam lookup uses.
void GlbDracoWriter::keySplitVertices(IndexedMesh& mesh, std::uint64_t seam) {
  if (mesh.seamKeys.size() != mesh.positions.size()) return;
  const std::vector<bool> split = splitByDraco(mesh);
  std::uint32_t next = 0;
  for (std::uint32_t k : mesh.seamKeys) next = std::max(next, k);
  for (VertexId v = 0; v < mesh.positions.size(); ++v) {
    if (!split[v] || mesh.seamKeys[v] >= 2) continue;
    std::uint64_t wide = std::max<std::uint64_t>(2, next + 1);
    if ((wide & 1) != ((2 + (seam & 1)) & 1)) ++wide;
    if (wide > 0xFFFFFFFFu) throw Error(fmt::format("{}: too many seam keys", path_));
    mesh.seamKeys[v] = static_cast<std::uint32_t>(wide);
    next = mesh.seamKeys[v];
    ++keyedVertices_;
  }
}

GlbDracoWriter::Encoded GlbDracoWriter::encode(IndexedMesh mesh, const DracoSettings& settings,
                                               const std::string& path) {
  Encoded e;
  Primitive& p = e.primitive;
  p.points = mesh.positions.size();
  p.triangles = mesh.triangles.size();
  p.min = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
  p.max = {-p.min[0], -p.min[1], -p.min[2]};
  for (const Vec3f& v : mesh.positions) {
    const float c[3] = {v.x, v.y, v.z};
    for (std::size_t a = 0; a < 3; ++a) {
      const float q = dracoDequantized(c[a], settings.origin[a], settings);
      p.min[a] = std::min(p.min[a], q);
      p.max[a] = std::max(p.max[a], q);
    }
  }
  e.worstError = quantizationError(mesh, settings);
  const auto start = Clock::now();
  e.bytes = dracoEncode(std::move(mesh), settings, path, &p.ids);
  e.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return e;
}

// Encodes a closed chunk here, or hands it to a thread of its own when chunks are encoded in
// parallel (they are spooled in order, so the file is the same either way).
void GlbDracoWriter::flush(IndexedMesh mesh) {
  if (mesh.triangles.empty()) return;
  if (options_.encodeThreads <= 0) {
    spool(encode(std::move(mesh), settings_, path_));
  } else {
    while (static_cast<int>(encoding_.size()) >= options_.encodeThreads) spoolOldest();
    encoding_.push_back(
        std::async(std::launch::async, [mesh = std::move(mesh), settings = settings_, path = path_]() mutable {
          return encode(std::move(mesh), settings, path);
        }));
  }
}

void GlbDracoWriter::spoolOldest() {
  std::future<Encoded> oldest = std::move(encoding_.front());
  encoding_.pop_front();
  spool(oldest.get());
}

void GlbDracoWriter::spool(const Encoded& e) {
  encodeSeconds_ += e.seconds;
  worstError_ = std::max(worstError_, e.worstError);
  Primitive p = e.primitive;
  p.offset = spool_->size();
  p.length = static_cast<std::int64_t>(e.bytes.size());
  spool_->write(e.bytes.data(), e.bytes.size());
  const char zeros[4] = {0, 0, 0, 0};
  spool_->write(zeros, (4 - e.bytes.size() % 4) % 4);
  primitives_.push_back(p);
}

void GlbDracoWriter::finish() {
  if (pending_) {
    if (options_.seamKeys) keySplitVertices(*pending_, seams_);
    flush(std::move(*pending_));
    pending_.reset();
  }
  if (options_.seamKeys) keySplitVertices(current_, seams_);
  flush(std::move(current_));
  current_ = IndexedMesh{};
  while (!encoding_.empty()) spoolOldest();
  if (scene_ != nullptr) {
    addToScene();
    return;
  }
  const bool hasMesh = !primitives_.empty();
  nlohmann::ordered_json extras = {{"quantization_bits", settings_.quantBits},
                                   {"quantization_step", settings_.range / (std::ldexp(1.0, settings_.quantBits) - 1)},
                                   {"chunks", primitives_.size()}};
  if (primitives_.size() > 1) extras["seam_attribute"] = kSeamAttribute;
  nlohmann::ordered_json gltf = gltfDocument(header_, options_, hasMesh, extras);
  gltf["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  gltf["extensionsRequired"] = {"KHR_draco_mesh_compression"};
  if (hasMesh) {
    nlohmann::ordered_json accessors = nlohmann::ordered_json::array();
    nlohmann::ordered_json views = nlohmann::ordered_json::array();
    nlohmann::ordered_json primitives = nlohmann::ordered_json::array();
    for (const Primitive& p : primitives_) {
      nlohmann::ordered_json attributes;
      nlohmann::ordered_json dracoAttributes;
      attributes["POSITION"] = accessors.size();
      dracoAttributes["POSITION"] = p.ids.position;
      accessors.push_back({{"componentType", 5126},
                           {"count", p.points},
                           {"type", "VEC3"},
                           {"min", {p.min[0], p.min[1], p.min[2]}},
                           {"max", {p.max[0], p.max[1], p.max[2]}}});
      if (p.ids.normal >= 0) {
        attributes["NORMAL"] = accessors.size();
        dracoAttributes["NORMAL"] = p.ids.normal;
        accessors.push_back({{"componentType", 5126}, {"count", p.points}, {"type", "VEC3"}});
      }
      if (p.ids.seam >= 0) {
        // glTF forbids unsigned int for application-specific attributes: two unsigned shorts.
        attributes[kSeamAttribute] = accessors.size();
        dracoAttributes[kSeamAttribute] = p.ids.seam;
        accessors.push_back({{"componentType", 5123}, {"count", p.points}, {"type", "VEC2"}});
      }
      const std::size_t indices = accessors.size();
      accessors.push_back({{"componentType", 5125}, {"count", 3 * p.triangles}, {"type", "SCALAR"}});
      primitives.push_back(
          {{"attributes", attributes},
           {"indices", indices},
           {"mode", 4},
           {"material", 0},
           {"extensions",
            {{"KHR_draco_mesh_compression", {{"bufferView", views.size()}, {"attributes", dracoAttributes}}}}}});
      views.push_back({{"buffer", 0}, {"byteOffset", p.offset}, {"byteLength", p.length}});
    }
    gltf["meshes"] = {{{"name", "isosurface"}, {"primitives", primitives}}};
    gltf["accessors"] = accessors;
    gltf["bufferViews"] = views;
    gltf["buffers"] = {{{"byteLength", spool_->size()}}};
  }
  bytes_ = writeGlbFile(path_, gltf, {spool_});
  ownSpool_.reset();
  spool_ = nullptr;
}

void GlbDracoWriter::addToScene() {
  GlbScene::Mesh mesh;
  mesh.name = sceneName_;
  mesh.color = sceneColor_;
  for (const Primitive& p : primitives_) {
    nlohmann::ordered_json attributes;
    nlohmann::ordered_json dracoAttributes;
    attributes["POSITION"] = scene_->addAccessor({{"componentType", 5126},
                                                  {"count", p.points},
                                                  {"type", "VEC3"},
                                                  {"min", {p.min[0], p.min[1], p.min[2]}},
                                                  {"max", {p.max[0], p.max[1], p.max[2]}}});
    dracoAttributes["POSITION"] = p.ids.position;
    if (p.ids.normal >= 0) {
      attributes["NORMAL"] = scene_->addAccessor({{"componentType", 5126}, {"count", p.points}, {"type", "VEC3"}});
      dracoAttributes["NORMAL"] = p.ids.normal;
    }
    if (p.ids.seam >= 0) {
      attributes[kSeamAttribute] =
          scene_->addAccessor({{"componentType", 5123}, {"count", p.points}, {"type", "VEC2"}});
      dracoAttributes[kSeamAttribute] = p.ids.seam;
    }
    const std::size_t indices =
        scene_->addAccessor({{"componentType", 5125}, {"count", 3 * p.triangles}, {"type", "SCALAR"}});
    const std::size_t view = scene_->addView({{"buffer", 0}, {"byteOffset", p.offset}, {"byteLength", p.length}});
    mesh.primitives.push_back(
        {{"attributes", attributes},
         {"indices", indices},
         {"mode", 4},
         {"extensions", {{"KHR_draco_mesh_compression", {{"bufferView", view}, {"attributes", dracoAttributes}}}}}});
  }
  scene_->addMesh(std::move(mesh));
  spool_ = nullptr;
}

std::vector<std::pair<std::string, double>> GlbDracoWriter::details() const {
  auto d = dracoDetails(static_cast<double>(primitives_.size()), encodeSeconds_, worstError_, settings_);
  d.emplace_back("seam_vertices", static_cast<double>(seamVertices_));
  d.emplace_back("seam_keys", static_cast<double>(keyedVertices_));
  d.emplace_back("seam_unwelded", static_cast<double>(unweldedVertices_));
  return d;
}

DrcWriter::DrcWriter(std::string path, const WriterOptions& options) : path_(std::move(path)), options_(options) {
  checkOptions(options);
}

void DrcWriter::begin(const MeshHeader& header) {
  header_ = header;
  settings_ = dracoSettingsFor(header.volumeBounds, options_);
  file_ = std::make_unique<AtomicFile>(path_);
}

void DrcWriter::consume(const MeshChunk& chunk) {
  checkOnGrid(chunk.positions, settings_, path_);
  mesh_.positions.insert(mesh_.positions.end(), chunk.positions.begin(), chunk.positions.end());
  if (header_.normals) mesh_.normals.insert(mesh_.normals.end(), chunk.normals.begin(), chunk.normals.end());
  mesh_.triangles.insert(mesh_.triangles.end(), chunk.triangles.begin(), chunk.triangles.end());
}

void DrcWriter::finish() {
  worstError_ = quantizationError(mesh_, settings_);
  const auto start = Clock::now();
  const std::vector<char> bytes = dracoEncode(std::move(mesh_), settings_, path_);
  encodeSeconds_ = std::chrono::duration<double>(Clock::now() - start).count();
  mesh_ = IndexedMesh{};
  file_->write(bytes.data(), bytes.size());
  bytes_ = file_->size();
  file_->commit();
  file_.reset();
}

std::vector<std::pair<std::string, double>> DrcWriter::details() const {
  return dracoDetails(1, encodeSeconds_, worstError_, settings_);
}

}  // namespace isoslab
