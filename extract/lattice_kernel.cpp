// size-exception: one class, LatticeKernel, whose row loop, welding cache, cell points and vertex
// creation are every lattice method's hot path; kept in one translation unit so that they inline
// into each other.
// Marching Tetrahedra and the comparison of decompositions: V. Skala and A. Brus, "Two methods for
// iso-surface extraction from volumetric data and their comparison".
// BCC: C.-S. Chan and E. O. Purisima, Computers & Graphics 22(1), 1998.
#include "extract/lattice_kernel.h"

#include <algorithm>
#include <cmath>

#include "extract/mc33_table.h"
#include "extract/mc_table.h"
#include "extract/row_spans.h"
#include "extract/tet_volume.h"

namespace isoslab {

LatticeKernel::LatticeKernel(const ExtractOptions& options, const std::array<std::int64_t, 3>& dims,
                             const LatticeFrame& frame, std::unique_ptr<CellScheme> scheme)
    : options_(options),
      frame_(frame),
      scheme_(std::move(scheme)),
      cases_(scheme_.get(), dims[0], options.method == Method::kMarchingCubes33) {
  nx_ = dims[0];
  ny_ = dims[1];
  nz_ = dims[2];
  planeSize_ = nx_ * ny_;
  flip_ = frame_.flipsWinding();
  threshold_ = insideThreshold(options_.iso);
  cellVolume_ = frame_.cellVolume();
  needsCentres_ = scheme_ && scheme_->values == NodeValues::kNeighbourCentres;
  ownCentres_ = scheme_ && scheme_->values == NodeValues::kOwnCentres;
  mc33_ = !scheme_ && options_.method == Method::kMarchingCubes33;
  field_.nx = nx_;
  field_.ny = ny_;
  field_.nz = nz_;
  if (options_.closeBoundary) {
    pad_ = 1;
    field_.pad = 1;
    options_.cellVolumes = false;  // tetInsideVolume knows nothing of the caps
  }
}

std::unique_ptr<CellScheme> LatticeKernel::copyScheme() const {
  return scheme_ ? std::make_unique<CellScheme>(*scheme_) : nullptr;
}

// The welding caches and centre planes, allocated on first use (an extractor whose workers do
// the extracting never needs its own).
void LatticeKernel::allocate() {
  cache_.allocate(cases_.sliceClasses(), cases_.centreClasses(), planeSize_);
  if (needsCentres_) {
    const auto cells = static_cast<std::size_t>((nx_ - 1) * (ny_ - 1));
    centres_[0].assign(cells, 0.0f);
    centres_[1].assign(cells, 0.0f);
  }
}

void LatticeKernel::classifySlice(const float* slice, std::vector<RowSpan>& rows) const {
  classifyRows(slice, nx_, ny_, threshold_, rows);
}

// Row spans of slices z, z+1 (and z+2 for bcc12): from the view when the pipeline classified its
// slices once for all workers, else classified here, reusing the previous slab's when it follows.
std::array<const RowSpan*, 3> LatticeKernel::rowSpans(const SlabView& slab, bool standalone) {
  const bool bcc = needsCentres_;
  const auto& s = field_.slices;
  if (slab.rows[1] != nullptr && slab.rows[2] != nullptr && (!bcc || s[3] == nullptr || slab.rows[3])) {
    rowsCarried_ = false;
    return {slab.rows[1], slab.rows[2], slab.rows[3]};
  }
  const bool fresh = z_ == 0 || standalone || !rowsCarried_;
  if (fresh) classifySlice(s[1], rows_[0]);
  if (fresh || !bcc) classifySlice(s[2], rows_[1]);
  if (bcc && s[3] != nullptr) classifySlice(s[3], rows_[2]);
  rowsCarried_ = true;
  return {rows_[0].data(), rows_[1].data(), rows_[2].data()};
}

void LatticeKernel::extractSlab(const SlabView& slab, MeshChunk& out, std::vector<CacheSlot>* foreign) {
  if (!cache_.allocated()) allocate();
  const bool standalone = foreign != nullptr;
  foreign_ = foreign;
  z_ = slab.z;
  field_.z = z_;
  field_.slices = slab.slices;
  out_ = &out;
  if (needsCentres_) {
    if (z_ == 0 || standalone) computeCentres(0, centres_[0]);
    if (z_ + 1 <= nz_ - 2) computeCentres(1, centres_[1]);
  }
  double insideVolume = 0;
  const std::array<const RowSpan*, 3> spans = rowSpans(slab, standalone);
  for (std::int64_t j = 0; j + 1 < ny_; ++j) trimmedRow(j, spans, insideVolume);
  out.cellVolume = cellVolumes() ? insideVolume * cellVolume_ : 0.0;
}

void LatticeKernel::rollCaches() noexcept {
  cache_.roll();
  if (needsCentres_) std::swap(centres_[0], centres_[1]);
  std::swap(rows_[0], rows_[1]);
  if (needsCentres_) std::swap(rows_[1], rows_[2]);
}

void LatticeKernel::takeTop(std::vector<std::pair<CacheSlot, LocalVertex>>& top) {
  for (std::int64_t slot : cache_.touched(2)) {
    top.emplace_back(CacheSlot{slot}, LocalVertex{cache_.get(2, slot)});
  }
  cache_.clearAll();
}

// Flying-edges-style trimming of the row of cells j: the rows of each slice are classified once,
// and a row of cells is visited only where one of the voxel rows it depends on changes state, or
// where their constant states differ. mc, mt5 and mt6 depend on the four voxel rows of the cells;
// bcc12 also on the next cells along x, y and z (their centres), so on nine voxel rows and one cell
// further left, and its cells on the volume boundary (pyramids) are always visited.
void LatticeKernel::trimmedRow(std::int64_t j, const std::array<const RowSpan*, 3>& spans, double& insideVolume) {
  const bool bcc = needsCentres_;
  const std::int64_t cellsPerRow = nx_ - 1;
  if (bcc && (j == 0 || j + 2 == ny_ || z_ == 0 || z_ + 2 == nz_)) {
    marchRow(j, 0, cellsPerRow, insideVolume);
    return;
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
  if (bcc) marchRow(j, 0, 1, insideVolume);
  prefetchRow(j + 2, lo, hi + 1);
  marchRow(j, lo, hi, insideVolume);
  // (A row of one cell has one boundary cell, marched above.)
  if (bcc && cellsPerRow > 1) marchRow(j, cellsPerRow - 1, cellsPerRow, insideVolume);
}

// Asks the processor's cache for the welding-cache slots of points [begin, end) of row j on
// slice z (a hint only): set a slab ago, they are mostly out of the nearest caches by the time the
// cells of row j - 1 look them up, one by one at the crossed cells, too sparsely for the hardware
// to foresee. The cells of row j - 2 call it, over their own span (a surface crosses neighbouring
// rows of cells in much the same places).
void LatticeKernel::prefetchRow(std::int64_t j, std::int64_t begin, std::int64_t end) const noexcept {
  if (j >= ny_ || begin >= end) return;
  const auto classes = static_cast<std::int64_t>(cases_.sliceClasses());
  cache_.prefetch(0, (j * nx_ + begin) * classes, (j * nx_ + std::min(end, nx_)) * classes);
}

// Cells [begin, end) of row j. The case code is built incrementally: the next cell's x=0 corners
// are this cell's x=1 corners, so each step classifies four new voxels; values are loaded only for
// cells the surface crosses (and always for the tetrahedral schemes, whose centres need them).
void LatticeKernel::marchRow(std::int64_t j, std::int64_t begin, std::int64_t end, double& insideVolume) {
  if (begin >= end) return;
  const float* a0 = field_.slices[1] + j * nx_;
  const float* a1 = a0 + nx_;
  const float* b0 = field_.slices[2] + j * nx_;
  const float* b1 = b0 + nx_;
  const float threshold = threshold_;
  auto in = [threshold](float v) { return v >= threshold; };
  const bool bcc = needsCentres_;
  // bcc12 cells off the volume's faces use the interior variant, whose four centres all exist.
  const bool interiorRow = bcc && j > 0 && j + 2 < ny_ && z_ > 0 && z_ + 2 < nz_;
  const float* centre0 = bcc ? centres_[0].data() + j * (nx_ - 1) : nullptr;
  const float* centre1 = bcc ? centres_[1].data() + j * (nx_ - 1) : nullptr;
  const auto& variants = cases_.variants();
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
      if (!bcc) {
        if (thisCase == 255) insideVolume += variants[0].volume;  // the whole cube
        continue;
      }
      // bcc12: uniform too when its own centre and the +x, +y, +z centres agree.
      const bool inside = thisCase == 255;
      if (interiorRow && i > 0 && i + 2 < nx_ && in(centre0[i]) == inside && in(centre0[i + 1]) == inside &&
          in(centre0[i + nx_ - 1]) == inside && in(centre1[i]) == inside) {
        if (inside) insideVolume += variants[0].volume;
        continue;
      }
    }
    const std::array<const float*, 4> corners{a0 + i, a1 + i, b0 + i, b1 + i};
    if (!scheme_) {
      loadCorners(corners);
      if (mc33_) {
        // Only cells with two groups of inside or outside corners can be ambiguous; the rest have
        // mc's topology, and key == case.
        const unsigned key = mc33::mayBeAmbiguous(thisCase) ? mc33::cellKey(value_.data(), threshold_) : thisCase;
        cases_.ensureMc33Case(key);
        cellPoints_ = cases_.mc33CellPoints(key);
        emitCase(cases_.marchingCubes33(), key, i, j);
      } else {
        emitCase(cases_.marchingCubes(), thisCase, i, j);
      }
    } else {
      insideVolume += marchTetrahedra(thisCase, i, j, corners);
    }
  }
}

// Whether any of the cell's eight corners (two values from each of four rows) is NaN.
static bool anyNan(const float* a0, const float* a1, const float* b0, const float* b1) noexcept {
  for (int d = 0; d < 2; ++d) {
    if (std::isnan(a0[d]) || std::isnan(a1[d]) || std::isnan(b0[d]) || std::isnan(b1[d])) return true;
  }
  return false;
}

// Cube-centre values of slab z_ + which: the mean of each cell's eight corners.
void LatticeKernel::computeCentres(int which, std::vector<float>& dst) {
  const float* a = field_.slices[static_cast<std::size_t>(1 + which)];
  const float* b = field_.slices[static_cast<std::size_t>(2 + which)];
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
    for (std::int64_t i = 0; i + 1 < nx_; ++i) {
      double mean = (column[i] + column[i + 1]) / 8.0;
      // +inf and -inf corners sum to NaN, which would put the centre outside a cell whose corners
      // are all inside at iso -inf, a cell that the row trimming skips as inside. Such a centre is
      // 0, which agrees with its corners whenever they all agree (iso -inf: inside; a NaN iso:
      // outside), the only cells trimming skips. A NaN corner keeps the centre NaN.
      if (std::isnan(mean) && !anyNan(a0 + i, a1 + i, b0 + i, b1 + i)) mean = 0;
      out[i] = static_cast<float>(mean);
    }
  }
}

// The eight corner values of a cell, from its four voxel rows (y, then z) starting at its x.
void LatticeKernel::loadCorners(const std::array<const float*, 4>& rows) noexcept {
  for (std::size_t r = 0; r < 4; ++r) {
    value_[2 * r] = rows[r][0];
    value_[2 * r + 1] = rows[r][1];
  }
}

// The mean of four corners: summed in double in one fixed order, so that the two cells sharing a
// face compute the same float. A sum of +inf and -inf (no NaN among them) is 0, as for bcc12's
// centres (computeCentres): it agrees with corners that all agree.
static float cornerMean(const float* v, std::size_t count) noexcept {
  double sum = 0;
  bool nan = false;
  for (std::size_t k = 0; k < count; k += 2) {
    sum += static_cast<double>(v[k]) + static_cast<double>(v[k + 1]);
    nan = nan || std::isnan(v[k]) || std::isnan(v[k + 1]);
  }
  const double mean = sum / static_cast<double>(count);
  return static_cast<float>(std::isnan(mean) && !nan ? 0.0 : mean);
}

// mt24's node values 8..14 from the corners in value_: the six face centres (8 + 2 * axis +
// side), each the mean of its face's corners in the face's own order (the lower remaining axis
// first), and the cube centre, the mean of all eight.
void LatticeKernel::ownCentres() noexcept {
  for (int axis = 0; axis < 3; ++axis) {
    const int p = axis == 0 ? 1 : 0;
    const int q = axis == 2 ? 1 : 2;
    for (int side = 0; side < 2; ++side) {
      const int base = side << axis;
      const float face[4] = {value_[static_cast<std::size_t>(base)], value_[static_cast<std::size_t>(base | 1 << p)],
                             value_[static_cast<std::size_t>(base | 1 << q)],
                             value_[static_cast<std::size_t>(base | 1 << p | 1 << q)]};
      value_[static_cast<std::size_t>(8 + 2 * axis + side)] = cornerMean(face, 4);
    }
  }
  value_[14] = cornerMean(value_.data(), 8);
}

// Emits the cell's triangles and returns the inside volume of its tetrahedra, in voxel units.
double LatticeKernel::marchTetrahedra(unsigned cornerCase, std::int64_t i, std::int64_t j,
                                      const std::array<const float*, 4>& corners) {
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
  CaseList& v = cases_.variants()[variant];
  unsigned nodeCase = cornerCase;
  if (ownCentres_) {
    loadCorners(corners);
    ownCentres();
    for (unsigned n = 8; n < 15; ++n) nodeCase |= static_cast<unsigned>(value_[n] >= threshold_) << n;
  } else if (needsCentres_) {
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
  if (!ownCentres_) loadCorners(corners);  // only for cells the surface crosses
  v.ensureCase(key);
  emitCase(v, key, i, j);
  if (!options_.cellVolumes) return 0.0;
  double inside = 0;
  for (const TetRef& t : v.tets) {
    unsigned cas = 0;
    for (unsigned k = 0; k < 4; ++k) cas |= ((key >> t.nodes[k]) & 1u) << k;
    if (cas == 15) {
      inside += t.volume;
    } else if (cas != 0) {
      std::array<double, 4> values{};
      for (std::size_t k = 0; k < 4; ++k) values[k] = value_[t.nodes[k]];
      inside += tetInsideVolume(values, t.volume, cas, options_.iso);
    }
  }
  return inside;
}

// Emits the triangles of case `key` of v (built beforehand) in cell (i, j).
void LatticeKernel::emitCase(const CaseList& v, unsigned key, std::int64_t i, std::int64_t j) {
  const CaseList::CaseSpan& span = v.cases[key];
  std::array<VertexId, kMaxCaseEdges> ids;
  const std::uint8_t* edges = v.caseEdges.data() + span.firstEdge;
  for (std::size_t k = 0; k < span.edgeCount; ++k) ids[k] = vertex(v.edges[edges[k]], i, j);
  const auto* tri = v.caseTriangles.data() + span.firstTriangle;
  for (std::size_t n = 0; n < span.triangleCount; ++n, ++tri)
    emitTriangle(ids[(*tri)[0]], ids[(*tri)[1]], ids[(*tri)[2]]);
}

void LatticeKernel::emitTriangle(VertexId a, VertexId b, VertexId c) {
  if (flip_) std::swap(b, c);
  out_->triangles.push_back({a, b, c});
}

VertexId LatticeKernel::vertex(const EdgeRef& e, std::int64_t i, std::int64_t j) {
  if (e.cellOnly) {
    // Looked up once per cell (a case lists each edge once), and no other cell has it.
    const auto id = static_cast<VertexId>(vertexCount_++);
    createVertex(e, i, j);
    return id;
  }
  const std::int64_t slot = e.slot(i, j, nx_);
  VertexId id = cache_.get(e.plane, slot);
  if (id == WeldingCache::kNone) {
    if (e.shared && foreign_ != nullptr && z_ > 0) {
      // The slab below created this vertex (every edge on slice z that a cell of this slab
      // crosses is an edge of a cell below too): refer to it by slot.
      id = kForeignVertex | static_cast<VertexId>(foreign_->size());
      foreign_->push_back(CacheSlot{slot});
      cache_.set(e.plane, slot, id);
      cache_.touch(0, slot);
      return id;
    }
    id = static_cast<VertexId>(vertexCount_++);
    cache_.set(e.plane, slot, id);
    cache_.touch(e.plane, slot);
    createVertex(e, i, j);
  }
  return id;
}

// The fraction along the edge from node a (value va) to node b where the field meets the iso value.
static double cutFraction(double iso, double va, double vb) noexcept {
  const double t = (iso - va) / (vb - va);
  // An infinite iso value or end value, or a NaN end (outside), leave no fraction to interpolate:
  // the vertex goes to the edge's middle, so that it stays on its edge.
  return std::isnan(t) ? 0.5 : std::clamp(t, 0.0, 1.0);
}

// Where the vertex of the edge from node a to node b of cell (i, j) lies, in lattice coordinates,
// and its fraction t from a (for the normal's interpolation); sets `leaves` when the edge leaves the
// volume (closeBoundary): the vertex is then the point where it crosses the volume's face, exactly.
Vec3d LatticeKernel::cutPoint(int a, int b, std::int64_t i, std::int64_t j, double& t, bool& leaves) const noexcept {
  const auto& nodes = cases_.nodes();
  const Vec3d pa = field_.position(nodes[static_cast<std::size_t>(a)], i, j);
  const Vec3d pb = field_.position(nodes[static_cast<std::size_t>(b)], i, j);
  leaves = false;
  if (pad_ != 0) {
    const std::array<double, 3> lo{1.0, 1.0, 1.0};
    const std::array<double, 3> hi{static_cast<double>(nx_ - 2), static_cast<double>(ny_ - 2),
                                   static_cast<double>(nz_ - 2)};
    auto outside = [&](const Vec3d& p) {
      for (std::size_t k = 0; k < 3; ++k) {
        if (p[k] < lo[k] || p[k] > hi[k]) return true;
      }
      return false;
    };
    const bool outA = outside(pa);
    if (outA != outside(pb)) {
      // From the end inside the volume towards the one outside, to the first face it crosses.
      const Vec3d& p = outA ? pb : pa;
      const Vec3d& q = outA ? pa : pb;
      double s = 1;
      for (std::size_t k = 0; k < 3; ++k) {
        if (q[k] < lo[k]) s = std::min(s, (lo[k] - p[k]) / (q[k] - p[k]));
        if (q[k] > hi[k]) s = std::min(s, (hi[k] - p[k]) / (q[k] - p[k]));
      }
      leaves = true;
      t = outA ? 1 - s : s;
      return {p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1]), p[2] + s * (q[2] - p[2])};
    }
  }
  t = cutFraction(options_.iso, value_[static_cast<std::size_t>(a)], value_[static_cast<std::size_t>(b)]);
  return {pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]), pa[2] + t * (pb[2] - pa[2])};
}

// The output position of lattice point p (the padding's offset removed: exact, the coordinates
// being at least 1).
Vec3f LatticeKernel::outputPosition(const Vec3d& p) const noexcept {
  const auto pad = static_cast<double>(pad_);
  const Vec3d w = frame_.map(p[0] - pad, p[1] - pad, p[2] - pad);
  return {static_cast<float>(w[0]), static_cast<float>(w[1]), static_cast<float>(w[2])};
}

// An mc33 cell point: the mean of the cut points of the cube edges in its mask, in lattice
// coordinates; its normal is the normalised sum of their unit normals (the first one's where they
// cancel).
void LatticeKernel::createCellPoint(unsigned mask, std::int64_t i, std::int64_t j) {
  Vec3d sum{0, 0, 0};
  Vec3d normal{0, 0, 0};
  Vec3d first{0, 0, 0};
  double count = 0;
  for (unsigned e = 0; e < 12; ++e) {
    if (((mask >> e) & 1u) == 0) continue;
    const auto& corners = mc::kEdgeCorners[e];
    double t = 0;
    bool leaves = false;
    const Vec3d p = cutPoint(corners[0], corners[1], i, j, t, leaves);
    for (std::size_t k = 0; k < 3; ++k) sum[k] += p[k];
    if (options_.normals) {
      const Vec3d n = edgeNormal(corners[0], corners[1], t, i, j);
      if (count == 0) first = n;
      for (std::size_t k = 0; k < 3; ++k) normal[k] += n[k];
    }
    count += 1;
  }
  out_->positions.push_back(outputPosition({sum[0] / count, sum[1] / count, sum[2] / count}));
  out_->boundary.push_back(0);
  if (!options_.normals) return;
  const double len = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
  const Vec3d n = len > 1e-6 ? Vec3d{normal[0] / len, normal[1] / len, normal[2] / len} : first;
  out_->normals.push_back({static_cast<float>(n[0]), static_cast<float>(n[1]), static_cast<float>(n[2])});
}

void LatticeKernel::createVertex(const EdgeRef& e, std::int64_t i, std::int64_t j) {
  if (e.cellPoint != 0) {
    createCellPoint(cellPoints_[e.cellPoint - 1], i, j);
    return;
  }
  double t = 0;
  bool leaves = false;
  const Vec3d lattice = cutPoint(e.a, e.b, i, j, t, leaves);
  out_->positions.push_back(outputPosition(lattice));
  std::uint8_t faces = 0;
  if (pad_ == 0) {
    const auto& nodes = cases_.nodes();
    const Vec3d a = field_.position(nodes[e.a], i, j);
    const Vec3d b = field_.position(nodes[e.b], i, j);
    auto on = [&](int axis, double value) {
      return a[static_cast<std::size_t>(axis)] == value && b[static_cast<std::size_t>(axis)] == value;
    };
    if (on(0, 0.0)) faces |= kFaceXMin;
    if (on(0, static_cast<double>(nx_ - 1))) faces |= kFaceXMax;
    if (on(1, 0.0)) faces |= kFaceYMin;
    if (on(1, static_cast<double>(ny_ - 1))) faces |= kFaceYMax;
    if (on(2, 0.0)) faces |= kFaceZMin;
    if (on(2, static_cast<double>(nz_ - 1))) faces |= kFaceZMax;
  } else {
    // Capped: the faces the vertex lies on.
    if (lattice[0] == 1.0) faces |= kFaceXMin;
    if (lattice[0] == static_cast<double>(nx_ - 2)) faces |= kFaceXMax;
    if (lattice[1] == 1.0) faces |= kFaceYMin;
    if (lattice[1] == static_cast<double>(ny_ - 2)) faces |= kFaceYMax;
    if (lattice[2] == 1.0) faces |= kFaceZMin;
    if (lattice[2] == static_cast<double>(nz_ - 2)) faces |= kFaceZMax;
  }
  out_->boundary.push_back(faces);
  if (!options_.normals) return;
  Vec3d n{};
  if (leaves) {
    // A cap's vertex: the cap lies in the face, so its normal is the face's outward normal (of the
    // first face the edge crosses, for a vertex on a volume edge or corner).
    Vec3d out{0, 0, 0};
    for (std::size_t k = 0; k < 3 && out == Vec3d{0, 0, 0}; ++k) {
      if (faces & (1u << (2 * k))) out[k] = -1;
      if (faces & (1u << (2 * k + 1))) out[k] = 1;
    }
    // Normals map by the inverse transpose, as gradients do.
    const Vec3d g = frame_.gradient(out);
    const double len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    n = {g[0] / len, g[1] / len, g[2] / len};
  } else {
    n = edgeNormal(e.a, e.b, t, i, j);
  }
  out_->normals.push_back({static_cast<float>(n[0]), static_cast<float>(n[1]), static_cast<float>(n[2])});
}

// The unit normal at fraction t along the edge from node a to node b of cell (i, j), in the output
// frame: down the interpolated gradient, from higher to lower values.
Vec3d LatticeKernel::edgeNormal(int a, int b, double t, std::int64_t i, std::int64_t j) const noexcept {
  const auto& nodes = cases_.nodes();
  const auto na = nodes[static_cast<std::size_t>(a)];
  const auto nb = nodes[static_cast<std::size_t>(b)];
  const Vec3d ga = field_.gradient(na, i, j);
  const Vec3d gb = field_.gradient(nb, i, j);
  Vec3d g = frame_.gradient({ga[0] + t * (gb[0] - ga[0]), ga[1] + t * (gb[1] - ga[1]), ga[2] + t * (gb[2] - ga[2])});
  double len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  if (!(len > 0) || !std::isfinite(len)) {
    // The central differences cancel (a symmetric extremum at the vertex), or are infinite or NaN
    // (infinite or NaN values nearby): take the direction of the vertex's own edge, from its
    // outside end to its inside end (the edge crosses the iso value, so one end is inside).
    const Vec3d pa = field_.position(na, i, j);
    const Vec3d pb = field_.position(nb, i, j);
    const double sign = value_[static_cast<std::size_t>(b)] >= options_.iso ? 1.0 : -1.0;
    g = frame_.gradient({(pb[0] - pa[0]) * sign, (pb[1] - pa[1]) * sign, (pb[2] - pa[2]) * sign});
    len = std::sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
  }
  const double s = len > 0 ? -1.0 / len : 0.0;
  return {g[0] * s, g[1] * s, g[2] * s};
}

}  // namespace isoslab
