// Draco output.
//
// GlbDracoWriter: a glTF 2.0 binary file with one mesh whose primitives are independently
// compressed chunks (KHR_draco_mesh_compression, listed in extensionsRequired). A chunk closes at
// the first slab boundary after it reaches WriterOptions::chunkTriangles. Every chunk is quantized
// on one grid (explicit quantization with the volume's box), so a seam vertex decodes to the same
// floats in both chunks, and decoders weld the seams by position. But distinct vertices can share
// a quantized position (lattice points at the iso value, vertices closer than a step), where
// position alone is ambiguous. There, and only there, the vertices carry the application-specific
// attribute _ISOSLAB_SEAM (two 16-bit halves of a 32-bit value): a key on a vertex that both chunks
// hold, the same in both (2, 4, 6, ... on the seam after chunk 0, 2, 4, ...; 3, 5, 7, ... after
// chunk 1, 3, 5, ...), and 1 ("never weld by position") on the others; 0 elsewhere. A decoder joins
// equal keys of the seam's parity with the previous chunk, and welds a 0 vertex to the previous chunk's 0
// vertex at its position when each chunk has exactly one there. A vertex that Draco's Edgebreaker
// coder splits into one point per fan (its triangles in the chunk form several fans) is keyed too,
// and a decoder joins the points of one primitive that carry one key. Chunks without any mark
// carry no attribute. The marks are known when the next chunk's first slab has been consumed, so a closed
// chunk waits one slab
// before it is encoded and appended to a spool beside the output: memory stays at about two
// chunks. The document itself (frame node, material, extras) is described in gltf.h.
//
// DrcWriter: one standard Draco mesh (readable by draco_decoder). Draco's encoder needs the whole
// mesh, so this writer holds every vertex and triangle until finish(): about 28 bytes per
// triangle, plus Draco's own working memory while encoding.
#pragma once

#include <array>
#include <chrono>
#include <deque>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/atomic_file.h"
#include "encode/draco_codec.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_writer.h"

namespace isoslab {

class GlbScene;  // encode/glb_scene.h

class GlbDracoWriter final : public MeshFileSink {
 public:
  GlbDracoWriter(std::string path, const WriterOptions& options);
  /// A mesh of `scene`, named `name`, of colour `color` (sRGB); `path` names it in messages.
  GlbDracoWriter(std::string path, const WriterOptions& options, GlbScene& scene, std::string name,
                 std::array<std::uint8_t, 3> color);
  ~GlbDracoWriter() override;
  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;
  std::int64_t bytes() const noexcept override { return bytes_; }
  std::vector<std::pair<std::string, double>> details() const override;

 private:
  struct Primitive {
    DracoAttributeIds ids;
    std::uint64_t points = 0;
    std::uint64_t triangles = 0;
    std::array<float, 3> min{};
    std::array<float, 3> max{};
    std::int64_t offset = 0;
    std::int64_t length = 0;
  };
  struct Encoded {
    std::vector<char> bytes;
    Primitive primitive;
    double seconds = 0;
    double worstError = 0;
  };
  static Encoded encode(IndexedMesh mesh, const DracoSettings& settings, const std::string& path);
  VertexId localVertex(VertexId id);
  void close(const MeshChunk& last);
  // Keys the seam between the waiting chunk and the current one, then encodes the waiting chunk.
  void resolveSeam();
  // The seam keys of both chunks (its working maps are freed before the encoding).
  void keySeam();
  void keySplitVertices(IndexedMesh& mesh, std::uint64_t seam);
  void flush(IndexedMesh mesh);
  void spoolOldest();
  void spool(const Encoded& e);
  void addToScene();

  std::string path_;
  WriterOptions options_;
  MeshHeader header_;
  DracoSettings settings_;
  std::unique_ptr<SpoolFile> ownSpool_;
  SpoolFile* spool_ = nullptr;  // ownSpool_, or the scene's
  GlbScene* scene_ = nullptr;
  std::string sceneName_;
  std::array<std::uint8_t, 3> sceneColor_{};
  VertexWindow window_;
  IndexedMesh current_;
  VertexId chunkFirst_ = 0;
  std::vector<VertexId> local_;                  // for ids >= chunkFirst_
  std::unordered_map<VertexId, VertexId> seam_;  // for ids < chunkFirst_
  // The closed chunk waiting for its seam keys, and its local ids of the vertices that the next
  // slab may reference (those of its last slab, ids pendingTopFirst_ ..).
  std::optional<IndexedMesh> pending_;
  std::vector<VertexId> pendingTop_;
  VertexId pendingTopFirst_ = 0;
  std::uint64_t seamVertices_ = 0;
  std::uint64_t keyedVertices_ = 0;
  std::uint64_t unweldedVertices_ = 0;
  std::uint64_t seams_ = 0;  // seams resolved so far
  std::vector<Primitive> primitives_;
  std::deque<std::future<Encoded>> encoding_;  // chunks being encoded, oldest first
  std::uint64_t triangles_ = 0;
  std::uint64_t vertices_ = 0;
  double encodeSeconds_ = 0;
  double worstError_ = 0;
  std::int64_t bytes_ = 0;
};

class DrcWriter final : public MeshFileSink {
 public:
  DrcWriter(std::string path, const WriterOptions& options);
  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;
  std::int64_t bytes() const noexcept override { return bytes_; }
  std::vector<std::pair<std::string, double>> details() const override;

 private:
  std::string path_;
  WriterOptions options_;
  MeshHeader header_;
  DracoSettings settings_;
  std::unique_ptr<AtomicFile> file_;
  IndexedMesh mesh_;
  double encodeSeconds_ = 0;
  double worstError_ = 0;
  std::int64_t bytes_ = 0;
};

/// Quantization settings for a volume box (xmin ymin zmin xmax ymax zmax) and writer options.
DracoSettings dracoSettingsFor(const std::array<double, 6>& box, const WriterOptions& options);

}  // namespace isoslab
