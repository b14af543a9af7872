// Marching Cubes: W. E. Lorensen and H. E. Cline, "Marching cubes: a high resolution 3D surface
// construction algorithm", SIGGRAPH 1987; tables generated as described in mc_table.h.
// Marching Tetrahedra and the comparison of decompositions: V. Skala and A. Brus, "Two methods for
// iso-surface extraction from volumetric data and their comparison".
// BCC: C.-S. Chan and E. O. Purisima, Computers & Graphics 22(1), 1998.
#include "extract/lattice_extractor.h"

#include <algorithm>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <cassert>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <tuple>

#include "extract/mc_table.h"
#include "extract/tet_table.h"

namespace isoslab {
namespace {

constexpr VertexId kNoVertex = std::numeric_limits<VertexId>::max();

// A lattice edge as seen from a cell: its two nodes (a is the lower endpoint), and where its
// vertex id lives: anchor plane 0 (slice z), 1 (centre plane) or 2 (slice z+1), and the offset of
// the slot in that plane's cache relative to the cell's (i, j). A plane's cache interleaves its
// edge classes (slot = (j * nx + i) * classes + class), so that a cell's edges share cache lines.
struct EdgeRef {
  std::uint8_t a = 0;
  std::uint8_t b = 0;
  std::uint8_t plane = 0;
  /// On plane 0, whether the slab below has this edge too (as a plane-2 edge of the same class):
  /// true for edges in slice z, false for those rising from it.
  bool shared = false;
  std::size_t edgeClass = 0;
  std::int64_t cell = 0;    // lattice offset of the lower endpoint's anchor from the cell's (i, j)
  std::int64_t stride = 0;  // classes of the plane
  std::int64_t offset = 0;  // cell * stride + edgeClass
};

struct TetRef {
  std::array<std::uint8_t, 4> nodes{};
  double volume = 0;  // in voxel units
};

struct VariantRef {
  std::vector<TetRef> tets;
  std::uint32_t nodeMask = 0;  // nodes whose values the variant reads
  double volume = 0;
  /// The distinct edges of the tetrahedra.
  std::vector<EdgeRef> edges;
  /// Per tetrahedron, its six edges as indices into `edges`.
  std::vector<std::array<std::uint8_t, 6>> tetEdges;
  /// Per node case, built on first use (bcc12's interior variant has 4096 cases, most never seen):
  /// the distinct edges its triangles cut, in order of first use (indices into `edges`), and the
  /// triangles in the order the tetrahedra emit them, as indices into that list. A cell then
  /// looks each vertex up once, however many triangles share it.
  struct CaseSpan {
    std::int32_t firstEdge = -1;  // into caseEdges; -1: not built yet
    std::int32_t firstTriangle = 0;
    std::uint8_t edgeCount = 0;
    std::uint8_t triangleCount = 0;
  };
  std::vector<CaseSpan> cases;
  std::vector<std::uint8_t> caseEdges;
  std::vector<std::array<std::uint8_t, 3>> caseTriangles;

  /// Records a case's triangles (given as indices into `edges`).
  void addCase(unsigned key, const std::vector<std::array<std::uint8_t, 3>>& triangles) {
    CaseSpan& span = cases[key];
    span.firstEdge = static_cast<std::int32_t>(caseEdges.size());
    span.firstTriangle = static_cast<std::int32_t>(caseTriangles.size());
    for (const auto& tri : triangles) {
      std::array<std::uint8_t, 3> local{};
      for (std::size_t c = 0; c < 3; ++c) {
        const auto begin = caseEdges.begin() + span.firstEdge;
        const auto it = std::find(begin, caseEdges.end(), tri[c]);
        local[c] = static_cast<std::uint8_t>(it - begin);
        if (it == caseEdges.end()) caseEdges.push_back(tri[c]);  // may reallocate: index taken first
      }
      caseTriangles.push_back(local);
    }
    span.edgeCount = static_cast<std::uint8_t>(caseEdges.size() - static_cast<std::size_t>(span.firstEdge));
    span.triangleCount = static_cast<std::uint8_t>(triangles.size());
  }
};

// The most distinct edges one case can cut (bcc12's interior cell has fewer lattice edges).
constexpr std::size_t kMaxCaseEdges = 64;

// The smallest float not below iso: for every float v, v >= iso exactly when v >= this.
float insideThreshold(double iso) noexcept {
  const auto f = static_cast<float>(iso);
  if (std::isnan(iso) || static_cast<double>(f) >= iso) return f;
  return std::nextafter(f, std::numeric_limits<float>::infinity());
}

bool lowerNode(const LatticeNode& a, const LatticeNode& b) {
  return std::tie(a.hz, a.hy, a.hx) < std::tie(b.hz, b.hy, b.hx);
}

class LatticeExtractor final : public Extractor, public SlabWorker {
 public:
  LatticeExtractor(const ExtractOptions& options, const std::array<std::int64_t, 3>& dims, const LatticeFrame& frame,
                   std::unique_ptr<CellScheme> scheme)
      : options_(options), frame_(frame), scheme_(std::move(scheme)) {
    nx_ = dims[0];
    ny_ = dims[1];
    nz_ = dims[2];
    planeSize_ = nx_ * ny_;
    flip_ = frame_.flipsWinding();
    threshold_ = insideThreshold(options_.iso);
    cellVolume_ = frame_.cellVolume();
    if (scheme_) {
      nodes_ = scheme_->nodes;
    } else {
      for (int c = 0; c < 8; ++c) {
        nodes_.push_back({static_cast<std::int8_t>(2 * (c & 1)), static_cast<std::int8_t>(2 * ((c >> 1) & 1)),
                          static_cast<std::int8_t>(2 * ((c >> 2) & 1))});
      }
      for (int e = 0; e < 12; ++e) {
        mcCases_.edges.push_back(makeEdge(mc::kEdgeCorners[static_cast<std::size_t>(e)][0],
                                          mc::kEdgeCorners[static_cast<std::size_t>(e)][1]));
      }
      mcCases_.cases.resize(256);
      const auto& table = mc::kCaseTable;
      for (unsigned c = 0; c < 256; ++c) {
        std::vector<std::array<std::uint8_t, 3>> triangles;
        for (int t = 0; t < table.triangleCount[c]; ++t) {
          const auto& tri = table.triangles[c][static_cast<std::size_t>(t)];
          triangles.push_back({static_cast<std::uint8_t>(tri[0]), static_cast<std::uint8_t>(tri[1]),
                               static_cast<std::uint8_t>(tri[2])});
        }
        mcCases_.addCase(c, triangles);
      }
    }
    if (scheme_) {
      for (const auto& variant : scheme_->variants) {
        VariantRef v;
        for (const Tetrahedron& t : variant) {
          TetRef r;
          r.nodes = t.nodes;
          const auto& n = nodes_;
          r.volume = signedVolume6(n[t.nodes[0]], n[t.nodes[1]], n[t.nodes[2]], n[t.nodes[3]]) / 48.0;
          for (auto k : t.nodes) v.nodeMask |= 1u << k;
          v.volume += r.volume;
          std::array<std::uint8_t, 6> ids{};
          for (std::size_t e = 0; e < 6; ++e) {
            const EdgeRef edge = makeEdge(t.nodes[tet::kTetEdges[e][0]], t.nodes[tet::kTetEdges[e][1]]);
            auto same = [&](const EdgeRef& o) { return o.a == edge.a && o.b == edge.b; };
            auto it = std::find_if(v.edges.begin(), v.edges.end(), same);
            if (it == v.edges.end()) it = v.edges.insert(v.edges.end(), edge);
            ids[e] = static_cast<std::uint8_t>(it - v.edges.begin());
          }
          v.tetEdges.push_back(ids);
          v.tets.push_back(r);
        }
        v.cases.resize(std::size_t{1} << nodes_.size());
        if (v.edges.size() > kMaxCaseEdges) throw std::logic_error("a cell scheme variant has too many edges");
        variants_.push_back(std::move(v));
      }
    }
    markSharedEdges();
    needsCentres_ = scheme_ && scheme_->rule == VariantRule::kBoundary;
  }

  // The welding caches and centre planes, allocated on first use (an extractor whose workers do
  // the extracting never needs its own).
  void allocate() {
    for (int p = 0; p < 3; ++p) {
      const std::size_t classes = (p == 1 ? oddClasses_ : evenClasses_).size();
      planes_[static_cast<std::size_t>(p)].assign(classes * static_cast<std::size_t>(planeSize_), kNoVertex);
    }
    if (needsCentres_) {
      const auto cells = static_cast<std::size_t>((nx_ - 1) * (ny_ - 1));
      centres_[0].assign(cells, 0.0f);
      centres_[1].assign(cells, 0.0f);
    }
    allocated_ = true;
  }

  int slicesBelow() const noexcept override { return options_.normals ? 1 : 0; }
  int slicesAbove() const noexcept override { return (options_.normals || needsCentres_) ? 1 : 0; }
  std::uint64_t vertexCount() const noexcept override { return vertexCount_; }
  bool cellVolumes() const noexcept override { return scheme_ != nullptr && options_.cellVolumes; }
  std::size_t sliceSlots() const noexcept override {
    return evenClasses_.size() * static_cast<std::size_t>(planeSize_);
  }

  std::unique_ptr<SlabWorker> makeWorker() const override {
    auto worker = std::make_unique<LatticeExtractor>(options_, std::array{nx_, ny_, nz_}, frame_,
                                                     scheme_ ? std::make_unique<CellScheme>(*scheme_) : nullptr);
    worker->detached_ = true;
    return worker;
  }

  // A detached extractor derives everything from the slab's own slices (nothing carries over from
  // the slab before) and leaves the vertices on slice z, which the slab below creates, to the
  // stitcher: the same cells are visited and the same vertices created in the same order as in
  // extractSlab, so that stitched ids equal extractSlab's.
  void extract(const SlabView& slab, SlabPart& part) noexcept override {
    assert(detached_);
    part.chunk.clear();
    part.chunk.slab = slab.z;
    part.chunk.firstVertex = 0;
    part.foreign.clear();
    part.top.clear();
    foreign_ = &part.foreign;
    vertexCount_ = 0;
    extractSlab(slab, part.chunk);
    for (std::int64_t slot : touched_[2]) part.top.emplace_back(slot, planes_[2][static_cast<std::size_t>(slot)]);
    for (int p = 0; p < 3; ++p) clearPlane(p);
  }

  void extractSlab(const SlabView& slab, MeshChunk& out) noexcept override {
    if (!allocated_) allocate();
    z_ = slab.z;
    slices_ = slab.slices;
    out_ = &out;
    if (needsCentres_) {
      if (z_ == 0 || detached_) computeCentres(0, centres_[0]);
      if (z_ + 1 <= nz_ - 2) computeCentres(1, centres_[1]);
    }
    double insideVolume = 0;
    const float* s0 = slices_[1];
    const float* s1 = slices_[2];
    const float threshold = threshold_;
    // Flying-edges-style trimming: the rows of each slice are classified once, and a row of cells
    // is visited only where one of the voxel rows it depends on changes state, or where their
    // constant states differ. mc, mt5 and mt6 depend on the four voxel rows of the cells; bcc12
    // also on the next cells along x, y and z (their centres), so on nine voxel rows and one cell
    // further left, and its cells on the volume boundary (pyramids) are always visited.
    const bool bcc = needsCentres_;
    // Row spans of slices z, z+1 (and z+2 for bcc12): from the view when the pipeline classified
    // its slices once for all workers, else classified here, reusing the previous slab's.
    std::array<const RowSpan*, 3> spans{};
    if (slab.rows[1] != nullptr && slab.rows[2] != nullptr && (!bcc || slices_[3] == nullptr || slab.rows[3])) {
      spans = {slab.rows[1], slab.rows[2], slab.rows[3]};
      rowsCarried_ = false;
    } else {
      if (z_ == 0 || detached_ || !rowsCarried_) classifyRows(s0, rows_[0]);
      if (z_ == 0 || !bcc || detached_ || !rowsCarried_) classifyRows(s1, rows_[1]);
      if (bcc && slices_[3] != nullptr) classifyRows(slices_[3], rows_[2]);
      spans = {rows_[0].data(), rows_[1].data(), rows_[2].data()};
      rowsCarried_ = true;
    }
    const std::int64_t cellsPerRow = nx_ - 1;
    auto march = [&](std::int64_t j, std::int64_t begin, std::int64_t end) {
      if (begin >= end) return;
      // The case code is built incrementally: the next cell's x=0 corners are this cell's x=1
      // corners, so each step classifies four new voxels; values are loaded only for cells the
      // surface crosses (and always for the tetrahedral schemes, whose centres need them).
      const float* a0 = s0 + j * nx_;
      const float* a1 = a0 + nx_;
      const float* b0 = s1 + j * nx_;
      const float* b1 = b0 + nx_;
      auto in = [threshold](float v) { return v >= threshold; };
      // bcc12 cells off the volume's faces use the interior variant, whose four centres all exist.
      const bool interiorRow = bcc && j > 0 && j + 2 < ny_ && z_ > 0 && z_ + 2 < nz_;
      const float* centre0 = bcc ? centres_[0].data() + j * (nx_ - 1) : nullptr;
      const float* centre1 = bcc ? centres_[1].data() + j * (nx_ - 1) : nullptr;
      unsigned cornerCase = static_cast<unsigned>(in(a0[begin])) | static_cast<unsigned>(in(a1[begin])) << 2 |
                            static_cast<unsigned>(in(b0[begin])) << 4 | static_cast<unsigned>(in(b1[begin])) << 6;
      for (std::int64_t i = begin; i < end; ++i) {
        cornerCase = (cornerCase & 0x55u) | static_cast<unsigned>(in(a0[i + 1])) << 1 |
                     static_cast<unsigned>(in(a1[i + 1])) << 3 | static_cast<unsigned>(in(b0[i + 1])) << 5 |
                     static_cast<unsigned>(in(b1[i + 1])) << 7;
        const unsigned thisCase = cornerCase;
        cornerCase >>= 1;  // the x=1 corners become the next cell's x=0 corners
        if (thisCase == 0 || thisCase == 255) {
          // Uniform cells: nothing to emit, unless bcc12's centres may still differ.
          if (!scheme_) continue;
          if (!needsCentres_) {
            if (thisCase == 255) insideVolume += variants_[0].volume;  // the whole cube
            continue;
          }
          // bcc12: uniform too when its own centre and the +x, +y, +z centres agree.
          const bool inside = thisCase == 255;
          if (interiorRow && i > 0 && i + 2 < nx_ && in(centre0[i]) == inside && in(centre0[i + 1]) == inside &&
              in(centre0[i + nx_ - 1]) == inside && in(centre1[i]) == inside) {
            if (inside) insideVolume += variants_[0].volume;
            continue;
          }
        }
        const std::array<const float*, 4> corners{a0 + i, a1 + i, b0 + i, b1 + i};
        if (!scheme_) {
          loadCorners(corners);
          marchCube(thisCase, i, j);
        } else {
          insideVolume += marchTetrahedra(thisCase, i, j, corners);
        }
      }
    };
    for (std::int64_t j = 0; j + 1 < ny_; ++j) {
      const bool whole = bcc && (j == 0 || j + 2 == ny_ || z_ == 0 || z_ + 2 == nz_);
      if (whole) {
        march(j, 0, cellsPerRow);
        continue;
      }
      std::array<const RowSpan*, 9> rows{};
      std::size_t count = 0;
      for (std::size_t k = 0; k < (bcc ? 3u : 2u); ++k) {
        for (std::int64_t dj = 0; dj < (bcc ? 3 : 2); ++dj) rows[count++] = spans[k] + j + dj;
      }
      std::int64_t firstChange = nx_;
      std::int64_t lastChange = -1;
      bool leftSame = true;
      bool rightSame = true;
      for (std::size_t k = 0; k < count; ++k) {
        if (rows[k]->first >= 0) {
          firstChange = std::min(firstChange, rows[k]->first);
          lastChange = std::max(lastChange, rows[k]->last);
        }
        leftSame = leftSame && rows[k]->left == rows[0]->left;
        rightSame = rightSame && rows[k]->right == rows[0]->right;
      }
      // Cells [lo, hi) may be crossed; bcc12 keeps its boundary cells 0 and cellsPerRow - 1.
      const std::int64_t edge = bcc ? 1 : 0;
      std::int64_t lo = edge;
      std::int64_t hi = cellsPerRow - edge;
      bool skipLeft = false;
      bool skipRight = false;
      if (lastChange < 0) {
        if (leftSame) skipLeft = skipRight = true, lo = hi;
      } else {
        if (leftSame) {
          lo = std::max(edge, firstChange - (bcc ? 2 : 1));
          skipLeft = true;
        }
        if (rightSame) {
          hi = std::min(cellsPerRow - edge, std::max(lo, lastChange));
          skipRight = true;
        }
      }
      if (!skipLeft) lo = edge;
      if (!skipRight) hi = std::max(lo, cellsPerRow - edge);
      // Uniform cells skipped inside the surface still count whole (one unit cell each).
      if (scheme_) {
        if (skipLeft && rows[0]->left) insideVolume += static_cast<double>(lo - edge);
        if (skipRight && rows[0]->right) insideVolume += static_cast<double>(cellsPerRow - edge - hi);
      }
      if (bcc) march(j, 0, 1);
      march(j, lo, hi);
      // (A row of one cell has one boundary cell, marched above.)
      if (bcc && cellsPerRow > 1) march(j, cellsPerRow - 1, cellsPerRow);
    }
    out.cellVolume = cellVolumes() ? insideVolume * cellVolume_ : 0.0;
    if (detached_) return;  // extract() exports slice z+1's slots and clears the caches
    // Roll the caches: slice z+1 becomes the next slab's slice z.
    clearPlane(0);
    std::swap(planes_[0], planes_[2]);
    std::swap(touched_[0], touched_[2]);
    clearPlane(1);
    if (needsCentres_) std::swap(centres_[0], centres_[1]);
    std::swap(rows_[0], rows_[1]);
    if (bcc) std::swap(rows_[1], rows_[2]);
  }

 private:
  // Registers the edge between nodes a and b and returns how to find its vertex slot.
  EdgeRef makeEdge(int a, int b) {
    const LatticeNode* na = &nodes_[static_cast<std::size_t>(a)];
    const LatticeNode* nb = &nodes_[static_cast<std::size_t>(b)];
    if (lowerNode(*nb, *na)) {
      std::swap(a, b);
      std::swap(na, nb);
    }
    EdgeRef r;
    r.a = static_cast<std::uint8_t>(a);
    r.b = static_cast<std::uint8_t>(b);
    r.plane = static_cast<std::uint8_t>(na->hz);
    assert(r.plane <= 2);
    auto& classes = na->hz == 1 ? oddClasses_ : evenClasses_;
    const std::array<int, 3> dir{nb->hx - na->hx, nb->hy - na->hy, nb->hz - na->hz};
    const auto it = classes.emplace(dir, classes.size()).first;
    const std::int64_t dx = na->hx >> 1;  // corner offsets 0/2 -> 0/1, centres 1 -> 0, 3 -> 1
    const std::int64_t dy = na->hy >> 1;
    r.edgeClass = it->second;
    r.cell = dy * nx_ + dx;
    return r;
  }

  void markSharedEdges() {
    std::vector<EdgeRef*> edges;
    for (auto& e : mcCases_.edges) edges.push_back(&e);
    for (auto& v : variants_) {
      for (auto& e : v.edges) edges.push_back(&e);
    }
    std::vector<bool> onTop(evenClasses_.size(), false);
    for (const EdgeRef* e : edges) {
      if (e->plane == 2) onTop[e->edgeClass] = true;
    }
    for (EdgeRef* e : edges) {
      e->shared = e->plane == 0 && onTop[e->edgeClass];
      e->stride = static_cast<std::int64_t>((e->plane == 1 ? oddClasses_ : evenClasses_).size());
      e->offset = e->cell * e->stride + static_cast<std::int64_t>(e->edgeClass);
    }
  }

  void clearPlane(int p) noexcept {
    auto& plane = planes_[static_cast<std::size_t>(p)];
    for (std::int64_t slot : touched_[static_cast<std::size_t>(p)]) plane[static_cast<std::size_t>(slot)] = kNoVertex;
    touched_[static_cast<std::size_t>(p)].clear();
  }

  void classifySlice(const float* slice, std::vector<RowSpan>& rows) const override { classifyRows(slice, rows); }

  void classifyRows(const float* slice, std::vector<RowSpan>& rows) const {
    rows.resize(static_cast<std::size_t>(ny_));
    const float threshold = threshold_;
    for (std::int64_t j = 0; j < ny_; ++j) {
      const float* v = slice + j * nx_;
      RowSpan& r = rows[static_cast<std::size_t>(j)];
      r.left = v[0] >= threshold;
      r.right = v[nx_ - 1] >= threshold;
      r.first = firstDiffering(v, 1, nx_, r.left, threshold);
      if (r.first == nx_) {
        r.first = r.last = -1;
      } else {
        // The last change follows the last voxel whose state differs from the right end's.
        r.last = lastDiffering(v, 0, nx_ - 1, r.right, threshold) + 1;
      }
    }
  }

  // Rows are scanned in blocks of 16 voxels; rows are mostly uniform.
  static constexpr std::int64_t kBlock = 16;

  // Bit k set when v[k] >= threshold, for k < 16.
  static unsigned insideMask16(const float* v, float threshold) noexcept {
#if defined(__SSE2__)
    const __m128 t = _mm_set1_ps(threshold);
    unsigned mask = 0;
    for (int q = 0; q < 4; ++q) {
      mask |= static_cast<unsigned>(_mm_movemask_ps(_mm_cmpge_ps(_mm_loadu_ps(v + 4 * q), t))) << (4 * q);
    }
    return mask;
#else
    unsigned mask = 0;
    for (unsigned k = 0; k < 16; ++k) mask |= static_cast<unsigned>(v[k] >= threshold) << k;
    return mask;
#endif
  }

  // The first i in [from, to) with (v[i] >= threshold) != state, or `to`.
  static std::int64_t firstDiffering(const float* v, std::int64_t from, std::int64_t to, bool state,
                                     float threshold) noexcept {
    std::int64_t i = from;
    const unsigned uniform = state ? 0xFFFFu : 0u;
    for (; i + kBlock <= to; i += kBlock) {
      if (insideMask16(v + i, threshold) != uniform) break;
    }
    for (; i < to; ++i) {
      if ((v[i] >= threshold) != state) return i;
    }
    return to;
  }

  // The last i in [from, to) with (v[i] >= threshold) != state, or from - 1.
  static std::int64_t lastDiffering(const float* v, std::int64_t from, std::int64_t to, bool state,
                                    float threshold) noexcept {
    std::int64_t i = to;
    const unsigned uniform = state ? 0xFFFFu : 0u;
    for (; i - kBlock >= from; i -= kBlock) {
      if (insideMask16(v + i - kBlock, threshold) != uniform) break;
    }
    for (; i > from; --i) {
      if ((v[i - 1] >= threshold) != state) return i - 1;
    }
    return from - 1;
  }

  // Cube-centre values of slab z_ + which: the mean of each cell's eight corners.
  void computeCentres(int which, std::vector<float>& dst) noexcept {
    const float* a = slices_[static_cast<std::size_t>(1 + which)];
    const float* b = slices_[static_cast<std::size_t>(2 + which)];
    // Each voxel column's four values are summed once and shared by the two cells beside it.
    columns_.resize(static_cast<std::size_t>(nx_));
    double* column = columns_.data();
    for (std::int64_t j = 0; j + 1 < ny_; ++j) {
      const float* a0 = a + j * nx_;
      const float* a1 = a0 + nx_;
      const float* b0 = b + j * nx_;
      const float* b1 = b0 + nx_;
      for (std::int64_t i = 0; i < nx_; ++i) {
        column[i] = (static_cast<double>(a0[i]) + a1[i]) + (static_cast<double>(b0[i]) + b1[i]);
      }
      float* out = dst.data() + j * (nx_ - 1);
      for (std::int64_t i = 0; i + 1 < nx_; ++i) out[i] = static_cast<float>((column[i] + column[i + 1]) / 8.0);
    }
  }

  void marchCube(unsigned cornerCase, std::int64_t i, std::int64_t j) noexcept {
    emitCase(mcCases_, cornerCase, i, j);
  }

  // Emits the triangles of case `key` of v (built beforehand) in cell (i, j).
  void emitCase(const VariantRef& v, unsigned key, std::int64_t i, std::int64_t j) noexcept {
    const VariantRef::CaseSpan& span = v.cases[key];
    std::array<VertexId, kMaxCaseEdges> ids;
    const std::uint8_t* edges = v.caseEdges.data() + span.firstEdge;
    for (std::size_t k = 0; k < span.edgeCount; ++k) ids[k] = vertex(v.edges[edges[k]], i, j);
    const auto* tri = v.caseTriangles.data() + span.firstTriangle;
    for (std::size_t n = 0; n < span.triangleCount; ++n, ++tri)
      emitTriangle(ids[(*tri)[0]], ids[(*tri)[1]], ids[(*tri)[2]]);
  }

  // Returns the inside volume of the cell's tetrahedra, in voxel units.
  // The eight corner values of a cell, from its four voxel rows (y, then z) starting at its x.
  void loadCorners(const std::array<const float*, 4>& rows) noexcept {
    for (std::size_t r = 0; r < 4; ++r) {
      value_[2 * r] = rows[r][0];
      value_[2 * r + 1] = rows[r][1];
    }
  }

  double marchTetrahedra(unsigned cornerCase, std::int64_t i, std::int64_t j,
                         const std::array<const float*, 4>& corners) noexcept {
    std::size_t variant = 0;
    switch (scheme_->rule) {
      case VariantRule::kSingle:
        break;
      case VariantRule::kParity:
        variant = static_cast<std::size_t>((i + j + z_) & 1);
        break;
      case VariantRule::kBoundary:
        variant = static_cast<std::size_t>((i == 0 ? 1 : 0) | (i + 2 == nx_ ? 2 : 0) | (j == 0 ? 4 : 0) |
                                           (j + 2 == ny_ ? 8 : 0) | (z_ == 0 ? 16 : 0) | (z_ + 2 == nz_ ? 32 : 0));
        break;
    }
    VariantRef& v = variants_[variant];
    unsigned nodeCase = cornerCase;
    if (needsCentres_) {
      const std::int64_t c = j * (nx_ - 1) + i;
      value_[8] = centres_[0][static_cast<std::size_t>(c)];
      if (v.nodeMask & (1u << 9)) value_[9] = centres_[0][static_cast<std::size_t>(c + 1)];
      if (v.nodeMask & (1u << 10)) value_[10] = centres_[0][static_cast<std::size_t>(c + nx_ - 1)];
      if (v.nodeMask & (1u << 11)) value_[11] = centres_[1][static_cast<std::size_t>(c)];
      for (unsigned n = 8; n < 12; ++n) {
        if (v.nodeMask & (1u << n)) nodeCase |= static_cast<unsigned>(value_[n] >= threshold_) << n;
      }
    }
    const unsigned used = v.nodeMask;
    const unsigned key = nodeCase & used;
    if (key == 0) return 0.0;
    if (key == used) return v.volume;
    loadCorners(corners);  // only for cells the surface crosses
    if (v.cases[key].firstEdge < 0) buildCase(v, key);
    emitCase(v, key, i, j);
    if (!options_.cellVolumes) return 0.0;
    double inside = 0;
    for (const TetRef& t : v.tets) {
      unsigned cas = 0;
      for (unsigned k = 0; k < 4; ++k) cas |= ((key >> t.nodes[k]) & 1u) << k;
      if (cas == 15) {
        inside += t.volume;
      } else if (cas != 0) {
        inside += tetInsideVolume(t, cas);
      }
    }
    return inside;
  }

  // The triangles of node case `key` of variant v: the tetrahedra's, in order.
  static void buildCase(VariantRef& v, unsigned key) {
    std::vector<std::array<std::uint8_t, 3>> triangles;
    for (std::size_t n = 0; n < v.tets.size(); ++n) {
      const TetRef& t = v.tets[n];
      unsigned cas = 0;
      for (unsigned k = 0; k < 4; ++k) cas |= ((key >> t.nodes[k]) & 1u) << k;
      const auto& table = tet::kTetCases;
      for (int m = 0; m < table.triangleCount[cas]; ++m) {
        const auto& tri = table.triangles[cas][static_cast<std::size_t>(m)];
        triangles.push_back({v.tetEdges[n][tri[0]], v.tetEdges[n][tri[1]], v.tetEdges[n][tri[2]]});
      }
    }
    v.addCase(key, triangles);
  }

  // Lattice position of node n of cell (i, j, z_).
  Vec3d nodePosition(std::size_t n, std::int64_t i, std::int64_t j) const noexcept {
    const LatticeNode& node = nodes_[n];
    return {static_cast<double>(i) + 0.5 * node.hx, static_cast<double>(j) + 0.5 * node.hy,
            static_cast<double>(z_) + 0.5 * node.hz};
  }

  // The part of tetrahedron t (case cas, neither empty nor full) inside the surface, in voxel
  // units: case groups of the paper's section F. Linear interpolation makes the surface inside a
  // tetrahedron a plane, so the inside part is a small tetrahedron (one node inside), the rest of
  // the tetrahedron (three inside) or a triangular prism (two and two), cut into three tetrahedra.
  //
  // With s the fraction of an edge from its inside node to its outside node where the surface cuts
  // it: one node a inside: V s_ab s_ac s_ad; three inside: V minus the one-outside part; two (a, b)
  // and two (c, d): V (u v (1 - x) + u x (1 - w) + w x) with u, v, w, x the fractions on a-c, a-d,
  // b-c, b-d (the prism cut into the tetrahedra (a, ac, ad, bd), (a, ac, bc, bd), (a, b, bc, bd),
  // whose volumes in barycentric coordinates are those three terms).
  double tetInsideVolume(const TetRef& t, unsigned cas) const noexcept {
    double v[4];
    for (std::size_t k = 0; k < 4; ++k) v[k] = value_[t.nodes[k]];
    const double iso = options_.iso;
    auto s = [&](int from, int to) { return (iso - v[from]) / (v[to] - v[from]); };
    int in[4];
    int out[4];
    int nIn = 0;
    int nOut = 0;
    for (int k = 0; k < 4; ++k) ((cas >> k) & 1 ? in[nIn++] : out[nOut++]) = k;
    if (nIn == 1) {
      const int a = in[0];
      return t.volume * s(a, out[0]) * s(a, out[1]) * s(a, out[2]);
    }
    if (nIn == 3) {
      const int a = out[0];
      return t.volume * (1.0 - s(a, in[0]) * s(a, in[1]) * s(a, in[2]));
    }
    const double u = s(in[0], out[0]), w = s(in[1], out[0]);
    const double x = s(in[1], out[1]), vv = s(in[0], out[1]);
    return t.volume * (u * vv * (1.0 - x) + u * x * (1.0 - w) + w * x);
  }

  void emitTriangle(VertexId a, VertexId b, VertexId c) noexcept {
    if (flip_) std::swap(b, c);
    out_->triangles.push_back({a, b, c});
  }

  VertexId vertex(const EdgeRef& e, std::int64_t i, std::int64_t j) noexcept {
    const std::int64_t slot = e.offset + (j * nx_ + i) * e.stride;
    VertexId& id = planes_[e.plane][static_cast<std::size_t>(slot)];
    if (id == kNoVertex) {
      if (e.shared && detached_ && z_ > 0) {
        // The slab below created this vertex (every edge on slice z that a cell of this slab
        // crosses is an edge of a cell below too): refer to it by slot.
        id = kForeignVertex | static_cast<VertexId>(foreign_->size());
        foreign_->push_back(slot);
        touched_[0].push_back(slot);
        return id;
      }
      id = static_cast<VertexId>(vertexCount_++);
      touched_[e.plane].push_back(slot);
      createVertex(e, i, j);
    }
    return id;
  }

  void createVertex(const EdgeRef& e, std::int64_t i, std::int64_t j) noexcept {
    const double va = value_[e.a];
    const double vb = value_[e.b];
    double t = (options_.iso - va) / (vb - va);
    // An infinite iso value or end value, or a NaN end (outside), leave no fraction to
    // interpolate: the vertex goes to the edge's middle, so that it stays on its edge.
    if (std::isnan(t)) t = 0.5;
    t = std::clamp(t, 0.0, 1.0);
    const Vec3d a = nodePosition(e.a, i, j);
    const Vec3d b = nodePosition(e.b, i, j);
    const Vec3d lattice{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
    const Vec3d w = frame_.map(lattice[0], lattice[1], lattice[2]);
    out_->positions.push_back({static_cast<float>(w[0]), static_cast<float>(w[1]), static_cast<float>(w[2])});
    std::uint8_t faces = 0;
    auto on = [&](int axis, double value) {
      return a[static_cast<std::size_t>(axis)] == value && b[static_cast<std::size_t>(axis)] == value;
    };
    if (on(0, 0.0)) faces |= kFaceXMin;
    if (on(0, static_cast<double>(nx_ - 1))) faces |= kFaceXMax;
    if (on(1, 0.0)) faces |= kFaceYMin;
    if (on(1, static_cast<double>(ny_ - 1))) faces |= kFaceYMax;
    if (on(2, 0.0)) faces |= kFaceZMin;
    if (on(2, static_cast<double>(nz_ - 1))) faces |= kFaceZMax;
    out_->boundary.push_back(faces);
    if (options_.normals) {
      const Vec3d ga = nodeGradient(e.a, i, j);
      const Vec3d gb = nodeGradient(e.b, i, j);
      Vec3d g =
          frame_.gradient({ga[0] + t * (gb[0] - ga[0]), ga[1] + t * (gb[1] - ga[1]), ga[2] + t * (gb[2] - ga[2])});
      double len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
      if (!(len > 0) || !std::isfinite(len)) {
        // The central differences cancel (a symmetric extremum at the vertex), or are infinite or
        // NaN (infinite or NaN values nearby): take the direction of the vertex's own edge, from
        // its outside end to its inside end (the edge crosses the iso value, so one end is inside).
        const Vec3d d{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double sign = vb >= options_.iso ? 1.0 : -1.0;
        g = frame_.gradient({d[0] * sign, d[1] * sign, d[2] * sign});
        len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
      }
      // The normal points down the gradient, from higher to lower values.
      const double s = len > 0 ? -1.0 / len : 0.0;
      out_->normals.push_back(
          {static_cast<float>(g[0] * s), static_cast<float>(g[1] * s), static_cast<float>(g[2] * s)});
    }
  }

  // Value at global lattice point (gi, gj) of slice z_ + dz, dz in -1..2.
  float at(std::int64_t gi, std::int64_t gj, std::int64_t dz) const noexcept {
    return slices_[static_cast<std::size_t>(dz + 1)][gj * nx_ + gi];
  }

  // Central difference along one axis at index g of n points; one-sided at the ends.
  template <typename F>
  static double difference(std::int64_t g, std::int64_t n, F&& value) noexcept {
    if (g == 0) return value(1) - value(0);
    if (g == n - 1) return value(0) - value(-1);
    return 0.5 * (value(1) - value(-1));
  }

  // Gradient of the field at node n of cell (i, j, z_), with respect to lattice coordinates.
  // Corners: central differences. Cube centres: the gradient of the trilinear interpolant of the
  // centre's cell, taken at the centre (the mean of the cell's four edge differences per axis).
  Vec3d nodeGradient(std::size_t n, std::int64_t i, std::int64_t j) const noexcept {
    const LatticeNode& node = nodes_[n];
    if (node.isCentre()) {
      const std::int64_t ci = i + (node.hx - 1) / 2;
      const std::int64_t cj = j + (node.hy - 1) / 2;
      const std::int64_t cz = (node.hz - 1) / 2;  // slab offset 0 or 1
      double c[8];
      for (int k = 0; k < 8; ++k) c[k] = at(ci + (k & 1), cj + ((k >> 1) & 1), cz + ((k >> 2) & 1));
      return {0.25 * ((c[1] - c[0]) + (c[3] - c[2]) + (c[5] - c[4]) + (c[7] - c[6])),
              0.25 * ((c[2] - c[0]) + (c[3] - c[1]) + (c[6] - c[4]) + (c[7] - c[5])),
              0.25 * ((c[4] - c[0]) + (c[5] - c[1]) + (c[6] - c[2]) + (c[7] - c[3]))};
    }
    const std::int64_t gi = i + node.hx / 2;
    const std::int64_t gj = j + node.hy / 2;
    const std::int64_t dz = node.hz / 2;
    return {difference(gi, nx_, [&](std::int64_t d) { return static_cast<double>(at(gi + d, gj, dz)); }),
            difference(gj, ny_, [&](std::int64_t d) { return static_cast<double>(at(gi, gj + d, dz)); }),
            difference(z_ + dz, nz_, [&](std::int64_t d) { return static_cast<double>(at(gi, gj, dz + d)); })};
  }

  ExtractOptions options_;
  LatticeFrame frame_;
  std::unique_ptr<CellScheme> scheme_;
  std::vector<LatticeNode> nodes_;
  VariantRef mcCases_;  // Marching Cubes as one "variant" whose cases come from mc_table.h
  std::vector<VariantRef> variants_;
  std::map<std::array<int, 3>, std::size_t> evenClasses_;
  std::map<std::array<int, 3>, std::size_t> oddClasses_;
  std::array<std::vector<VertexId>, 3> planes_;
  std::array<std::vector<std::int64_t>, 3> touched_;
  std::array<std::vector<float>, 2> centres_;
  std::vector<double> columns_;
  std::array<std::vector<RowSpan>, 3> rows_;
  bool rowsCarried_ = false;  // rows_[0..] hold the spans of this slab's slices, rolled from the last
  bool needsCentres_ = false;
  bool detached_ = false;
  bool allocated_ = false;
  float threshold_ = 0;  // a value v is inside when v >= threshold_
  std::vector<std::int64_t>* foreign_ = nullptr;
  bool flip_ = false;
  double cellVolume_ = 1;
  std::int64_t nx_ = 0, ny_ = 0, nz_ = 0, planeSize_ = 0;
  std::int64_t z_ = 0;
  std::array<const float*, 4> slices_{};
  MeshChunk* out_ = nullptr;
  std::array<float, 12> value_{};
  std::uint64_t vertexCount_ = 0;
};

}  // namespace

std::unique_ptr<Extractor> makeLatticeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                                const LatticeFrame& frame, std::unique_ptr<CellScheme> scheme) {
  return std::make_unique<LatticeExtractor>(options, info.dims, frame, std::move(scheme));
}

}  // namespace isoslab
