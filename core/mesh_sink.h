// What extraction produces, and the interface of everything that consumes it.
//
// Extraction emits one MeshChunk per slab (the cells between slices z and z+1), in slab order.
// Vertex ids are global, dense and assigned in emission order: chunk z holds the positions of
// vertices firstVertex .. firstVertex + positions.size() - 1.
//
// The streaming contract: a triangle of chunk z references only vertices of chunk z and chunk
// z - 1. A sink that needs positions therefore keeps two chunks' worth (VertexWindow), never the
// whole mesh, and may treat a vertex as retired once the chunk after its own has been consumed.
#pragma once

#include <array>
#include <cassert>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace isoslab {

using VertexId = std::uint32_t;

struct Vec3f {
  float x = 0;
  float y = 0;
  float z = 0;
  friend bool operator==(const Vec3f&, const Vec3f&) = default;
};

using Triangle = std::array<VertexId, 3>;

/// The labels on either side of a triangle of a label complex (extract/label_extractor.h):
/// {front, back}. The triangle is counter-clockwise seen from the front, so it is a face of the
/// back label's surface as it is and of the front label's surface reversed. 0 is the background
/// (and everything beyond the volume).
using LabelPair = std::array<std::int32_t, 2>;

/// Bit flags of the volume faces a vertex lies on (its lattice edge lies in that face).
enum BoundaryFace : std::uint8_t {
  kFaceXMin = 1,
  kFaceXMax = 2,
  kFaceYMin = 4,
  kFaceYMax = 8,
  kFaceZMin = 16,
  kFaceZMax = 32
};

struct MeshChunk {
  std::int64_t slab = 0;
  VertexId firstVertex = 0;
  std::vector<Vec3f> positions;
  /// Unit normals, pointing from higher to lower values; empty unless normals were asked for.
  std::vector<Vec3f> normals;
  /// Per vertex, the BoundaryFace bits of the volume faces it lies on.
  std::vector<std::uint8_t> boundary;
  /// Counter-clockwise seen from the side of lower values (normals point from high to low).
  std::vector<Triangle> triangles;
  /// Volume inside the surface summed over this slab's tetrahedra (tetrahedral methods only).
  double cellVolume = 0;
  /// A label complex's chunks only (MeshHeader::labels): per triangle, the labels on its sides.
  std::vector<LabelPair> faceLabels;
  /// A label complex's chunks only: one entry per split in this chunk, naming the label whose
  /// surface was split there (a point where its voxels touch only at an edge or a corner gets one
  /// vertex per sheet of its surface, so that every label's surface is a 2-manifold).
  std::vector<std::int32_t> labelSplits;
  /// A label complex's chunks only: one entry per extra fan of a label at a vertex that could not
  /// be split (extract/label_cells.h, forEachPinch), naming the label.
  std::vector<std::int32_t> labelPinches;

  void clear() {
    positions.clear();
    normals.clear();
    boundary.clear();
    triangles.clear();
    cellVolume = 0;
    faceLabels.clear();
    labelSplits.clear();
    labelPinches.clear();
  }
  VertexId endVertex() const noexcept { return firstVertex + static_cast<VertexId>(positions.size()); }
};

/// A plane n . p = d in output coordinates: {nx, ny, nz, d}, n a unit vector out of the volume.
using FacePlane = std::array<double, 4>;
/// The lattice's six faces in BoundaryFace order: x min, x max, y min, y max, z min, z max.
using VolumeFaces = std::array<FacePlane, 6>;

/// What a sink learns before the first chunk.
struct MeshHeader {
  bool normals = false;
  std::string method;
  double iso = 0;
  std::string space;  // output coordinate frame: "voxel", "physical", "lps", ...
  /// Bounding box of the volume's lattice in output coordinates: xmin ymin zmin xmax ymax zmax.
  std::array<double, 6> volumeBounds{};
  /// The lattice's faces as planes, when they are planes in the output frame. Unknown (for a mesh
  /// read from a file that does not carry them) or not planar (a curved stack of slices): empty.
  std::optional<VolumeFaces> volumeFaces;
  /// How far positions may lie from where extraction put them (a decoded .glb's quantization).
  double positionTolerance = 0;
  /// Whether the method fills cells with tetrahedra, so that chunks carry cellVolume.
  bool cellVolumes = false;
  /// Whether the chunks are a label complex: every interface once, with faceLabels.
  bool labels = false;
};

/// Consumes a mesh as it streams. begin() once, consume() per chunk in slab order, finish() once.
/// Writers commit their output in finish(); a sink destroyed without finish() leaves no output.
/// Errors are thrown as isoslab::Error. Not thread-safe.
class MeshSink {
 public:
  virtual ~MeshSink() = default;
  virtual void begin(const MeshHeader& header) = 0;
  virtual void consume(const MeshChunk& chunk) = 0;
  virtual void finish() = 0;
};

/// Positions (and normals) of the vertices the next triangles may reference: the last two chunks.
class VertexWindow {
 public:
  void push(const MeshChunk& chunk) {
    std::swap(previous_, current_);
    std::swap(previousNormals_, currentNormals_);
    previousFirst_ = currentFirst_;
    current_ = chunk.positions;
    currentNormals_ = chunk.normals;
    currentFirst_ = chunk.firstVertex;
  }
  const Vec3f& position(VertexId v) const noexcept {
    if (v >= currentFirst_) return current_[v - currentFirst_];
    assert(v >= previousFirst_ && v - previousFirst_ < previous_.size());
    return previous_[v - previousFirst_];
  }
  const Vec3f& normal(VertexId v) const noexcept {
    if (v >= currentFirst_) return currentNormals_[v - currentFirst_];
    return previousNormals_[v - previousFirst_];
  }

 private:
  std::vector<Vec3f> previous_, current_;
  std::vector<Vec3f> previousNormals_, currentNormals_;
  VertexId previousFirst_ = 0;
  VertexId currentFirst_ = 0;
};

/// Forwards everything to several sinks, in order.
class TeeSink final : public MeshSink {
 public:
  explicit TeeSink(std::vector<MeshSink*> sinks) : sinks_(std::move(sinks)) {}
  void begin(const MeshHeader& h) override {
    for (MeshSink* s : sinks_) s->begin(h);
  }
  void consume(const MeshChunk& c) override {
    for (MeshSink* s : sinks_) s->consume(c);
  }
  void finish() override {
    for (MeshSink* s : sinks_) s->finish();
  }

 private:
  std::vector<MeshSink*> sinks_;
};

}  // namespace isoslab
