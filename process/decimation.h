// Decimating a streamed mesh: quadric-error edge collapses (process/simplifier.h) on blocks of
// slabs, with no full-resolution band left at the blocks' seams.
//
// The stream is cut into blocks of at least `blockSlabs` (3) slabs and `blockTriangles` triangles
// (closed at a slab boundary, so the cut is the same for every thread count).
//   1. Each block is decimated alone, its border locked: the seams with its neighbours and the
//      rims on the volume's faces keep every vertex, so the blocks still join.
//   2. Each decimated block is split at its middle slab: a triangle with a vertex below the middle
//      is its lower half, the rest its upper half. Once block b is done, the upper half of block
//      b - 1 and the lower half of block b, which meet at the old seam, are decimated again as one
//      region, with its own border locked: the split curves, which lie inside decimated blocks.
//      The old seam is free now, so it is decimated like the rest. A block keeps a little more
//      than the ratio (kBlockSlack), which its regions take off; the stream's first and last half
//      blocks are regions of their own.
// A region is final after step 2 and leaves as one chunk. Its triangles use its own vertices and
// those of the region before it (the split curve between them), so the streaming contract holds.
// Memory: about two blocks of the mesh (and their original triangles, for the error measure), and
// the simplifier's working set for at most `batchTriangles` triangles: a larger block or region
// goes to it in batches of whole connected components.
//
// The simplifier makes no collapse that breaks the surface, and a collapse that moves it at all is
// measured against the original triangles before it is made. Each simplified region is still
// checked: where an edge is used by more than two triangles, wound twice the same way, has become
// a border edge, or a triangle lies beyond the bound, the original triangles a few rings around it
// are frozen (kept as they are, their outline a locked border) and the region is simplified again;
// after kAttempts tries it is kept whole.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/mesh_sink.h"
#include "core/scratch.h"
#include "process/simplifier.h"

namespace isoslab {

/// About what a block's simplification holds per triangle (its copy, the simplifier's working set,
/// the grid of its original triangles), measured on the Philips head at 2 threads with
/// meshoptimizer's simplifier (ours holds less).
inline constexpr std::size_t kPairBytesPerTriangle = 256;

struct DecimateOptions {
  /// Keep this fraction of the triangles, in (0, 1]; 1 with maxError set: as few as the error
  /// allows.
  double ratio = 1.0;
  /// The largest error allowed, in voxels (0: none); the collapses' quadric error, a bound on how far
  /// the surface moves.
  double maxError = 0;
  /// Output units per voxel, to turn maxError and the cells of the error measure into output units.
  double voxelSize = 1.0;
  /// The largest distance, in voxels, that a decimated triangle's sample points (centroid and edge
  /// midpoints) may lie from the original surface: collapses beyond it are undone by freezing the
  /// original triangles around them (0: no bound).
  double maxDistance = 0.5;
  std::int64_t blockSlabs = 3;
  std::int64_t blockTriangles = 1 << 18;
  /// The most triangles given to one simplifier call: a larger input goes in batches of whole
  /// connected components (its working set is about 70 bytes a triangle).
  std::size_t batchTriangles = 1 << 17;
  /// A repair simplifies again only the neighbourhood of its bad spots, around the frozen patch
  /// (false: the whole region, replaying the first try; slower, and almost always the same
  /// triangles: for the tests that compare them).
  bool localRepairs = true;
  /// Measure the one-sided distance of every output triangle to the original surface, for the
  /// report (DecimationReport::distanceMean, distanceMax, samples); false leaves them 0.
  bool measure = true;
  /// Threads for the blocks and regions: with two or more, blocks are taken three at a time, while
  /// the first block's triangles times kPairBytesPerTriangle fit in `pairBytes` (a second block and
  /// its working set), or four at a time while a fourth block's chunks would fit there too (64
  /// bytes a triangle of the largest block queued: two blocks for each thread), and two threads
  /// simplify them and their regions (each takes the next block, else the next region whose block
  /// is done). The output is the same for every thread count and budget.
  int threads = 1;
  std::size_t pairBytes = std::size_t{128} << 20;
};

/// The distance bound of a label map's surfaces, in voxels, without --max-error: a label's boundary
/// is known only to the voxel (the true one lies anywhere within half a voxel of the voxel faces on
/// either side), and half a voxel stops the decimation of a 1 mm atlas at a third of its triangles.
inline constexpr double kLabelDistanceBound = 1.0;

/// Checks the options; returns an error message naming the option, or empty when they are valid.
std::string checkDecimateOptions(const DecimateOptions& options);

struct DecimationReport {
  std::uint64_t trianglesIn = 0;
  std::uint64_t trianglesOut = 0;
  std::uint64_t blocks = 0;
  std::uint64_t regions = 0;
  /// Regions (and blocks) simplified only after freezing patches around collapses that broke the
  /// mesh; the original triangles so frozen; and regions left whole after every try failed.
  std::uint64_t repairedRegions = 0;
  std::uint64_t frozenTriangles = 0;
  std::uint64_t keptRegions = 0;
  /// Simplifier runs over the blocks and regions (a repair simplifies again; a region kept whole
  /// counts its tries too).
  std::uint64_t attempts = 0;
  /// Of those runs, the ones whose result the check found broken: with its edges changed where
  /// they should not be (an edge or a pinch that the input did not have, a border or a complex's
  /// junction edge lost, or an input that was no surface to begin with; the simplifier's own tests
  /// leave none on a surface), with a triangle beyond the distance bound, with one label's sheet
  /// through another's (a complex).
  std::uint64_t brokenShape = 0;
  std::uint64_t beyondBound = 0;
  std::uint64_t crossing = 0;
  /// One-sided distance from the decimated surface to the original one, in output units, over
  /// sample points of every output triangle (its centroid and edge midpoints).
  double distanceMean = 0;
  double distanceMax = 0;
  std::uint64_t samples = 0;
  /// Whether the distance was measured (DecimateOptions::measure).
  bool measured = true;
  /// Where the time went, in seconds of the threads that spent it (summed over them): the simplify
  /// calls of the blocks and regions (every try); within them, the simplifier (with the distance
  /// checks that it asks for as it collapses), the checks of each try's result (the input's shape
  /// and the result's, and the distance of the triangles that changed unchecked) and a label
  /// complex's crossing search; and apart from them, the grids of the original triangles for the
  /// checks and the measure of the distance above.
  struct Seconds {
    double calls = 0, simplifier = 0, checks = 0, crossing = 0, grids = 0, measure = 0;
  } seconds;
};

class DecimationSink final : public MeshSink {
 public:
  DecimationSink(MeshSink& next, const DecimateOptions& options);

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  const DecimationReport& report() const noexcept { return report_; }
  const DecimateOptions& options() const noexcept { return options_; }

 private:
  // Chunks [first, end) of the stream: the original triangles a region's error is measured against.
  struct ChunkRange {
    std::size_t first = 0, end = 0;
    bool operator==(const ChunkRange&) const = default;
  };
  struct OriginalSurface {
    using Vec3d = std::array<double, 3>;
    // A dense grid over the triangles' bounding box: cell (x, y, z) spans origin + cell * [x, x + 1)
    // and so on; the triangles whose bounding boxes meet cell i are
    // cellTriangles[cellStart[i] .. cellStart[i + 1]).
    double cell = 1;
    Vec3d origin{};
    std::array<std::int64_t, 3> dims{};
    // A box around every triangle; the least vertex id that a triangle uses.
    Vec3d low{}, high{};
    VertexId minVertex = 0;
    // The original triangles (a chunk's, which outlive the grid, or the measure's copy of a range's),
    // read through the sink's positions; the cells list those on vertices from the sink's base_ on,
    // `count` of them.
    const DecimationSink* sink = nullptr;
    std::span<const Triangle> triangles;
    std::size_t count = 0;
    ScratchVector<std::uint32_t> cellStart, cellTriangles;

    // The cell's width and its inverse (the cells are found by multiplying: the same function for
    // the triangles listed and the points asked about, and monotonic, so that the answers do not
    // depend on it).
    double inverse = 1;
    std::int64_t cellOf(double x, std::size_t axis) const {
      // floor, inline (std::floor is a call to libm on this target).
      const double q = (x - origin[axis]) * inverse;
      const auto t = static_cast<std::int64_t>(q);
      return t - (q < static_cast<double>(t) ? 1 : 0);
    }
    // The squared distance from p to the slab of cells i along `axis`, widened by more than the
    // rounding of cellOf (so that a point that cellOf puts in cell i is within it).
    double gapSquared(const Vec3d& p, std::size_t axis, std::int64_t i) const {
      const double widen = 1e-6 * cell;
      const double from = origin[axis] + static_cast<double>(i) * cell - widen;
      const double to = origin[axis] + static_cast<double>(i + 1) * cell + widen;
      const double g = std::max({from - p[axis], p[axis] - to, 0.0});
      return g * g;
    }
    // Visits the cells of the box about p that reaches `reach` along each axis, but for p's own
    // cell `own`, whose squared distance from p is at most `bound` (read again for each cell: the
    // visits may lessen it), until `visit(x, y, z)` returns true; whether one did.
    template <class Visit>
    bool visitNear(const Vec3d& p, const std::array<std::int64_t, 3>& own, double reach, const double& bound,
                   Visit&& visit) const {
      std::array<std::int64_t, 3> lo{}, hi{};
      for (std::size_t a = 0; a < 3; ++a) {
        lo[a] = std::max<std::int64_t>(0, cellOf(p[a] - reach, a));
        hi[a] = std::min(dims[a] - 1, cellOf(p[a] + reach, a));
      }
      for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
        const double gz = gapSquared(p, 2, z);
        if (gz > bound) continue;
        for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
          const double gy = gz + gapSquared(p, 1, y);
          if (gy > bound) continue;
          for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
            if (std::array<std::int64_t, 3>{x, y, z} != own && gy + gapSquared(p, 0, x) <= bound && visit(x, y, z)) {
              return true;
            }
          }
        }
      }
      return false;
    }
    // Whether triangle k is listed (its corners from the least vertex on: the others' may be gone).
    bool listed(std::size_t k) const {
      return k < triangles.size() && std::min({triangles[k][0], triangles[k][1], triangles[k][2]}) >= minVertex;
    }
    // The cell's index, or -1 outside the grid.
    std::int64_t index(std::int64_t x, std::int64_t y, std::int64_t z) const {
      if (x < 0 || y < 0 || z < 0 || x >= dims[0] || y >= dims[1] || z >= dims[2]) return -1;
      return x + dims[0] * (y + dims[1] * z);
    }
    // The squared distance from p to the nearest triangle in the cell if it is below `best`
    // (squared), else `best`; `which` is set to that triangle. A triangle whose box is farther than
    // `best` (by more than rounding) is not measured.
    double nearestInCell(std::int64_t x, std::int64_t y, std::int64_t z, const Vec3d& p, double best,
                         std::uint32_t& which) const;
    // The squared distance from p to the nearest listed triangle if it is below `best` (squared: a
    // triangle at that distance is known), else `best` (0 for a grid without triangles); `which` is
    // set to that triangle. Exact, except that without a bound and with p's cell empty the search
    // stops after 64 rings of cells.
    double nearestSquared(const Vec3d& p, double best, std::uint32_t& which) const;
    // Whether some original triangle lies within `limit` of p. `hint` names a triangle to try first
    // (the last one found, as the points asked about in turn lie close together) and is set to the
    // one found; the answer does not depend on it. In `cells`: every cell, only the hinted triangle
    // and p's own cell, or only the cells around it.
    enum class Cells { kAll, kOwn, kAround };
    bool within(const Vec3d& p, double limit, std::uint32_t& hint, Cells cells = Cells::kAll) const;
  };

  // Where the last point was found near the original surface: a grid (its place in the parts) and
  // a triangle of it, tried first for the next point (kNoHint: none).
  using Hint = std::uint64_t;
  static constexpr Hint kNoHint = ~Hint{0};
  // The original surface of a range of chunks: for the checks, each chunk's grid, built the first
  // time that a block or region needs it and kept until the regions go downstream, so that a block,
  // its tries and the regions across its seams share them; for the report's measure, one grid of the
  // whole range (measure()).
  struct Originals {
    using Vec3d = OriginalSurface::Vec3d;
    // The chunks' grids that hold triangles, in order of their boxes' low end along `axis` (the
    // one along which the boxes are thinnest: the chunks are slabs across it); reach[i], the
    // furthest that the boxes of parts[0 .. i] reach along it.
    std::vector<const OriginalSurface*> parts;
    // Set by index(). No initializer: clang 14 then cannot default-construct the class in
    // std::optional (a nested class's initializers, needed within the enclosing class).
    std::size_t axis;
    std::vector<double> reach;

    // Orders the parts, once they are all in.
    void index();

    // The distance from p to the nearest original triangle (0 where there is none). `hint` names a
    // triangle measured first (the last one found: the points asked about in turn lie close
    // together), and is set to the one found; it bounds the search, so the answer does not depend
    // on it (but for the ring search's limit above, which a bound avoids).
    double distance(const Vec3d& p, Hint& hint) const;
    // Whether some original triangle lies within `limit` of p (true where there is none); the
    // answer does not depend on `hint`.
    bool within(const Vec3d& p, double limit, Hint& hint) const;
    // Whether an original triangle has every one of `corners` (a triangle's or an edge's) among
    // its own: the points between them then lie on the original surface. `point` lies between
    // them (a centroid, a midpoint); `hint` names a triangle whose successors are tried first
    // (decimated triangles that were not touched come in their input order), and is set to the one
    // found. The answer does not depend on it: the point's cell in every part whose box holds the
    // point is searched otherwise.
    bool holds(std::span<const VertexId> corners, const Vec3d& point, Hint& hint) const;
  };

  // What one simplify call keeps for itself, so that calls can run side by side: its view of the
  // original triangles (the range it was made for) and its counters.
  struct Scope {
    std::optional<Originals> surface;
    ChunkRange surfaceRange;
    std::uint64_t repairedRegions = 0, frozenTriangles = 0, keptRegions = 0, attempts = 0;
    std::uint64_t brokenShape = 0, beyondBound = 0, crossing = 0;  // DecimationReport's
    DecimationReport::Seconds seconds;                             // calls, simplifier, checks, crossing
    bool block = false;  // a block's simplification (which keeps kBlockSlack times the ratio)
  };
  // Triangles and, in a label complex, each one's sides (MeshChunk::faceLabels; empty otherwise),
  // in step.
  struct Faces {
    ScratchVector<Triangle> triangles;
    ScratchVector<LabelPair> labels;
    std::size_t size() const noexcept { return triangles.size(); }
    bool empty() const noexcept { return triangles.empty(); }
    void add(const Faces& from, std::size_t t) {
      triangles.push_back(from.triangles[t]);
      if (!from.labels.empty()) labels.push_back(from.labels[t]);
    }
    void append(const Faces& from) {
      triangles.insert(triangles.end(), from.triangles.begin(), from.triangles.end());
      labels.insert(labels.end(), from.labels.begin(), from.labels.end());
    }
  };
  // In a label complex, the vertices that a simplify call must not move because triangles outside
  // its input use them: a junction of labels can look like a closed fan within the input while the
  // rest of its triangles lie beyond (a scalar surface shows such a vertex a border edge). Those
  // below `below`, from `from` on, and those in `curve` (sorted).
  struct Lock {
    VertexId below = 0;
    VertexId from = 0xffffffffu;
    std::vector<VertexId> curve;
    bool has(VertexId v) const { return v < below || v >= from || std::binary_search(curve.begin(), curve.end(), v); }
  };
  // A block waiting to be simplified: chunks [start, end), split at `middle`; `base` is the first
  // chunk that the one-block-at-a-time schedule would still hold then (its ranges are clamped to
  // it, so that the output does not depend on how many blocks are taken at once).
  struct Block {
    std::size_t start = 0, end = 0, middle = 0, base = 0;
  };
  // A simplify call's input and output.
  struct Work {
    Faces input, output;
    Lock lock;
    std::int64_t original = 0;
    ChunkRange range;
    std::int64_t slab = 0;
    Scope scope;
  };

  void queueBlock();
  // `last`: the stream's last blocks, whose call takes the last half block too.
  void processQueued(bool last = false);
  void makeBlock(const Block& b, Work& block) const;
  void makeRegion(const Block& b, Work& block, Work& region);
  void makeLastRegion(Work& region);
  static void onThreads(std::size_t n, const std::function<void(std::size_t)>& body);
  Faces simplify(const Faces& faces, std::int64_t originalTriangles, ChunkRange originals, const Lock& lock,
                 Scope& scope) const;
  // A try's collapses, in the sink's vertex ids: the first try records them (`record`), a repair
  // replays them (`replay`) on its input less the frozen patch (SimplifyLimits::replay).
  struct Steps {
    LazyScratchVector<SimplifyStep>* record = nullptr;
    std::span<const SimplifyStep> replay;
    // Per replayed step, nonzero for a rename (SimplifyStep::kRename, set on the batch's own ids;
    // empty: none).
    std::span<const std::uint8_t> renames;
    // A local repair's vertices outside its zone (sorted): they stay, and move only by the replay's
    // renames (SimplifyLimits::kRenamedOnly); numbered even where no triangle has them yet.
    std::span<const VertexId> outline;
    bool* renameFolds = nullptr;  // SimplifyLimits::renameFolds
  };
  // What a region's repairs carry from try to try (repairNear): the last try's simplified
  // triangles; per vertex (ids relative to the region's first), the vertex that stands for it in
  // them (itself, or the vertex that the collapses moved it onto), and the same after the first
  // try, whose collapses the repairs replay.
  struct Repairs {
    Faces previous;
    ScratchVector<std::uint32_t> root, firstRoot;
  };
  // A repair's try near the bad spots only: the zone around the newly frozen triangles `fresh` is
  // taken out of the last try's result and simplified again from the region's own triangles.
  // False where the zone's replay reached beyond it (nothing changed: the whole region is replayed
  // instead).
  bool repairNear(const Faces& faces, const ScratchVector<bool>& frozen, std::span<const std::uint32_t> fresh,
                  Repairs& repairs, VertexId first, std::span<const SimplifyStep> log, const Originals* original,
                  Faces& simplified, ScratchVector<std::uint8_t>& unchecked) const;
  // The simplifier on a try's triangles (in batches of whole components when there are many);
  // `unchecked` gets a flag per kept triangle (collapseBatch).
  Faces collapse(Faces faces, std::size_t targetTriangles, std::size_t context, const Originals* original,
                 const ScratchVector<VertexId>& pinned, const Steps& steps,
                 ScratchVector<std::uint8_t>& unchecked) const;
  Faces collapseBatch(std::span<const Triangle> triangles, std::span<const LabelPair> labels,
                      std::size_t targetTriangles, const Originals* original, const ScratchVector<VertexId>& pinned,
                      ScratchVector<unsigned>& local, VertexId low, Faces* release, const Steps& steps,
                      ScratchVector<std::uint8_t>& unchecked) const;
  // Sends a final region on (measured before, when asked: measure()).
  void emit(const Faces& faces, std::int64_t slab);
  void measure(std::span<const Triangle> triangles, ChunkRange originals);
  // The chunks whose original triangles measure `triangles`, within chunks [firstChunk, end).
  ChunkRange rangeAround(std::span<const Triangle> triangles, std::size_t firstChunk, std::size_t end) const;
  OriginalSurface originalSurface(std::size_t chunk) const;
  // A grid of `all`'s triangles on vertices from base_ on: cells `firstCell` wide, doubled until
  // there are at most about `cellsPerTriangle` cells a triangle.
  OriginalSurface gridOver(std::span<const Triangle> all, double firstCell, double cellsPerTriangle) const;
  // Builds the grids of the chunks in the ranges that have none, on up to `threads` threads (each
  // chunk's grid is its own).
  void buildGrids(const std::vector<ChunkRange>& ranges, int threads);
  // The original surface of `range` (its grids built), kept in the scope for the next caller with
  // the same range: the tries and the simplifier's checks share it.
  const Originals& surfaceFor(ChunkRange range, Scope& scope) const;
  // What a region's crossing search found in its last try: the triangles it tested and the pairs
  // that cross. A pair of triangles that were both in that try, once each, crosses now as it did
  // then, so the next try tests only the pairs with a triangle that is new.
  struct CrossingCache {
    ScratchVector<Triangle> tested;
    std::vector<std::pair<Triangle, Triangle>> pairs;
  };
  // The vertices of triangles that pass through one another (or fold over a corner they share).
  ScratchVector<VertexId> crossingVertices(std::span<const Triangle> triangles, std::span<const LabelPair> labels,
                                           CrossingCache& cache) const;
  // Whether the triangle's centroid and edge midpoints are within `limit` of the original surface
  // (with `forwardEdges`, only the midpoints of the edges that run from the smaller id).
  bool triangleWithin(const Triangle& t, const Originals& surface, double limit, Hint& hint,
                      bool forwardEdges = false) const;
  using Vec3d = std::array<double, 3>;
  std::array<Vec3d, 3> cornersOf(const Triangle& t) const;
  static std::array<Vec3d, 4> samplePoints(const std::array<Vec3d, 3>& corners);
  // Whether p is within `limit` of one of a triangle's corners (input vertices, so on the original
  // surface).
  static bool nearCorner(const Vec3d& p, const std::array<Vec3d, 3>& corners, double limit);
  std::size_t chunkOfVertex(VertexId v) const;
  std::int64_t originalIn(std::size_t first, std::size_t end) const;
  void count(const Scope& scope);
  const Vec3f& position(VertexId v) const { return positions_[v - base_]; }
  void trim(std::size_t firstChunk);

  MeshSink& next_;
  DecimateOptions options_;
  MeshHeader header_;
  DecimationReport report_;
  double distanceSum_ = 0;

  // The vertices from base_ on (every one that a later region may still use), by global id.
  VertexId base_ = 0;
  std::vector<Vec3f> positions_, normals_;
  std::vector<std::uint8_t> boundary_;
  // New ids of the vertices already sent on (kNone: not yet).
  std::vector<VertexId> sent_;
  VertexId nextId_ = 0;
  // Per chunk of the stream from chunkBase_ on: its first vertex id, slab, original triangles.
  std::size_t chunkBase_ = 0;
  std::vector<VertexId> chunkFirst_;
  std::vector<std::int64_t> chunkSlab_;
  std::vector<std::vector<Triangle>> chunkTriangles_;
  std::vector<std::vector<LabelPair>> chunkLabels_;  // a label complex's only
  // Each chunk's grid of its original triangles (none until a range needs it).
  std::vector<std::unique_ptr<OriginalSurface>> chunkGrids_;
  std::size_t chunks_ = 0;  // chunks seen

  // The open block: chunks [blockStart_, chunks_); the blocks closed and not yet simplified; the
  // chunk where the one-block-at-a-time schedule's data would start now; the pending upper half of
  // the last block simplified.
  std::size_t blockStart_ = 0;
  std::vector<Block> queued_;
  std::size_t scheduleBase_ = 0;
  std::int64_t blockTriangles_ = 0;
  bool hasPending_ = false;
  Faces pendingUpper_;
  std::size_t pendingMiddle_ = 0;  // the chunk where the pending upper half starts
  // A label complex's: the vertices that the pending upper half shares with the region before it.
  std::vector<VertexId> pendingCurve_;
  bool complex_ = false;
  MeshChunk out_;
};

}  // namespace isoslab
