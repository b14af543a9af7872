#include "extract/label_extractor.h"

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstring>
#include <limits>
#include <new>
#include <unordered_map>
#include <vector>

#include "extract/label_cells.h"
#include "extract/label_planes.h"
#include "extract/slab_run.h"

namespace isoslab {
namespace {

using label_planes::kTopSlots;
using label_planes::Plane;
using label_planes::RowStage;
using label_planes::TopCell;
using label_planes::topVertex;

constexpr VertexId kUnsetId = std::numeric_limits<VertexId>::max();

// A cell's ids in a row buffer: its edges' copies (0..11), then the vertices of its split faces
// x = 0, y = 0 and z = 0, by edge position (12 + 4 * face + position).
constexpr std::size_t kRowIds = 25;  // and at 24, the split faces it owns: bit f of kOwnedFaces

// The faces a cell owns (kLabelFaceCorners 0: x = 0, 2: y = 0, 4: z = 0), in the order of kRowIds.
constexpr std::array<int, 3> kOwnedFaces{0, 2, 4};

// The cell walk of one cell layer (slab). Serves the sequential extractor (layers follow each
// other and the top plane carries over) and the slab worker (a run's first layer names the
// vertices of the layer below by their top-plane slot, for the stitcher).
class LabelKernel {
 public:
  LabelKernel(const std::array<std::int64_t, 3>& padded, const LatticeFrame& frame)
      : frame_(frame),
        flip_(frame.flipsWinding()),
        px_(padded[0]),
        py_(padded[1]),
        pz_(padded[2]),
        cx_(padded[0] - 1),
        cy_(padded[1] - 1) {}

  const LatticeFrame& frame() const noexcept { return frame_; }
  std::array<std::int64_t, 3> dims() const noexcept { return {px_, py_, pz_}; }
  std::size_t sliceSlots() const noexcept { return static_cast<std::size_t>(cx_ * cy_) * kTopSlots; }
  std::size_t slotOf(std::size_t cell, std::size_t k) const noexcept {
    return k < 4 ? cell * 4 + k : static_cast<std::size_t>(cx_ * cy_) * 4 + cell * 8 + (k - 4);
  }
  std::uint64_t vertexCount() const noexcept { return next_; }
  void resetVertexCount() noexcept { next_ = 0; }

  void classifySlice(const float* slice, std::vector<RowSpan>& rows) const { classifyLabelRows(slice, px_, py_, rows); }

  void extractSlab(const SlabView& slab, MeshChunk& out, std::vector<CacheSlot>* foreign) {
    if (!allocated_) {
      for (auto& r : row_) r.allocate(static_cast<std::size_t>(cx_) * kRowIds);
      for (auto& t : top_) t.allocate(static_cast<std::size_t>(cx_ * cy_));
      allocated_ = true;
    }
    out_ = &out;
    foreign_ = foreign;
    z_ = slab.z;
    below_ = slab.slices[0];
    lo_ = slab.slices[1];
    hi_ = slab.slices[2];
    // Each slice is classified once: the upper slice's rows serve the next layer as its lower's.
    const bool carried = classified_ == slab.z;
    classified_ = -1;
    if (carried) std::swap(scratch_[0], scratch_[1]);
    for (int s = 0; s < 2; ++s) {
      const RowSpan* given = slab.rows[static_cast<std::size_t>(s + 1)];
      if (given == nullptr) {
        if (s == 1 || !carried) classifySlice(s == 0 ? lo_ : hi_, scratch_[static_cast<std::size_t>(s)]);
        if (s == 1) classified_ = slab.z + 1;
        given = scratch_[static_cast<std::size_t>(s)].data();
      }
      spans_[static_cast<std::size_t>(s)] = given;
    }
    topSet_.clear();
    for (std::int64_t j = 0; j < cy_; ++j) walkRow(j);
  }

  // A slab worker's kernel: takeTop() is called after a run.
  void trackTop() noexcept { tracksTop_ = true; }

  // After a following layer: its top plane is the next layer's plane below.
  void rollCaches() noexcept { std::swap(top_[0], top_[1]); }

  // After a standalone run: the last layer's top edges, by slot.
  void takeTop(std::vector<std::pair<CacheSlot, LocalVertex>>& top) const {
    top.clear();
    top.reserve(topSet_.size() * 4);
    for (const std::size_t cell : topSet_) {
      const TopCell& c = top_[1][cell];
      for (std::size_t k = 0; k < kTopSlots; ++k) {
        const bool used = k < 4 ? ((c.crossed >> k) & 1u) != 0 : ((c.meta >> (3 + (k - 4) / 4)) & 1u) != 0;
        if (used) top.emplace_back(CacheSlot{static_cast<std::int64_t>(slotOf(cell, k))}, LocalVertex{topVertex(c, k)});
      }
    }
  }

 private:
  // The cells of row j whose eight samples may differ, from the four sample rows' spans.
  void walkRow(std::int64_t j) {
    const std::array<const float*, 4> rows{lo_ + j * px_, lo_ + (j + 1) * px_, hi_ + j * px_, hi_ + (j + 1) * px_};
    const std::array<const RowSpan*, 4> spans{spans_[0] + j, spans_[0] + j + 1, spans_[1] + j, spans_[1] + j + 1};
    // Cells [0, begin) lie in every row's uniform start, cells [end, cx) in every row's uniform end.
    std::int64_t begin = cx_;
    std::int64_t end = 0;
    for (const RowSpan* s : spans) {
      if (s->first < 0) continue;
      begin = std::min(begin, s->first - 1);
      end = std::max(end, s->last);
    }
    const float a0 = rows[0][0];
    const bool startsEqual = rows[1][0] == a0 && rows[2][0] == a0 && rows[3][0] == a0;
    const float b0 = rows[0][px_ - 1];
    const bool endsEqual = rows[1][px_ - 1] == b0 && rows[2][px_ - 1] == b0 && rows[3][px_ - 1] == b0;
    if (begin == cx_) {  // four uniform rows
      if (startsEqual) return;
      begin = 0;
      end = cx_;
    }
    if (!startsEqual) begin = 0;
    if (!endsEqual) end = cx_;
    end = std::min(end, cx_);
    VertexId* here = &row_[static_cast<std::size_t>(j & 1)][0];
    const VertexId* below = &row_[static_cast<std::size_t>((j + 1) & 1)][0];
    begin = std::max<std::int64_t>(begin, 0);
    if (begin >= end) return;
    // Which cells are crossed: a cell is when any of its eight samples differs from its first, 64
    // cells to a mask word (crossedCells), whose set bits are then walked.
    const auto n = static_cast<std::size_t>(end - begin);  // cells begin .. end - 1
    const std::array<const float*, 4> from{rows[0] + begin, rows[1] + begin, rows[2] + begin, rows[3] + begin};
    stage_.reserve(static_cast<std::size_t>(cx_));
    rowMap_ = LatticeFrame::Row(frame_, static_cast<double>(j) - 0.5, static_cast<double>(z_) - 0.5);
    rowFaces_ = static_cast<std::uint8_t>((j == 0 ? kFaceYMin : 0) | (j == cy_ - 1 ? kFaceYMax : 0) |
                                          (z_ == 0 ? kFaceZMin : 0) | (z_ == pz_ - 2 ? kFaceZMax : 0));
    for (std::size_t base = 0; base < n; base += 64) {
      for (std::uint64_t word = crossedCells(from, base, std::min<std::size_t>(64, n - base)); word != 0;
           word &= word - 1) {
        const std::int64_t i = begin + static_cast<std::int64_t>(base) + std::countr_zero(word);
        cell(i, j, CellLabels::load(rows, i), here + i * static_cast<std::int64_t>(kRowIds), below);
      }
    }
    stage_.flush(*out_);
  }

  // Bit k set where cell base + k of the four rows (each from the row span's first cell) is crossed,
  // for `count` cells (at most 64): when any of its eight samples (columns base + k and base + k + 1
  // of the four rows) differs from the first. The column after the last cell is read, none beyond.
  static std::uint64_t crossedCells(const std::array<const float*, 4>& r, std::size_t base,
                                    std::size_t count) noexcept {
    std::uint64_t word = 0;
    std::size_t k = 0;
#if defined(__SSE2__)
    // Four cells at a time while their columns' last (k + 4) is one of the row's.
    for (; k + 4 <= count; k += 4) {
      const std::size_t at = base + k;
      const __m128 a = _mm_loadu_ps(r[0] + at);
      __m128 differ = _mm_cmpneq_ps(a, _mm_loadu_ps(r[0] + at + 1));
      for (std::size_t row = 1; row < 4; ++row) {
        differ = _mm_or_ps(differ, _mm_cmpneq_ps(a, _mm_loadu_ps(r[row] + at)));
        differ = _mm_or_ps(differ, _mm_cmpneq_ps(a, _mm_loadu_ps(r[row] + at + 1)));
      }
      word |= static_cast<std::uint64_t>(_mm_movemask_ps(differ)) << k;
    }
#endif
    for (; k < count; ++k) {
      const std::size_t at = base + k;
      const float a = r[0][at];
      bool differ = a != r[0][at + 1];
      for (std::size_t row = 1; row < 4; ++row) differ = differ || a != r[row][at] || a != r[row][at + 1];
      word |= static_cast<std::uint64_t>(differ) << k;
    }
    return word;
  }

  void cell(std::int64_t i, std::int64_t j, const CellLabels& corners, VertexId* ids, const VertexId* below) {
    const std::array<std::int32_t, 8>& labels = corners.value;
    const CellGroups& g = cells_.groups(corners, out_->labelPinches);
    // The copies' vertices, at the cell's centre: the corner of the voxels' boxes.
    const VertexId first = static_cast<VertexId>(next_);
    const Vec3d p = rowMap_.at(static_cast<double>(i) - 0.5);
    const Vec3f position{static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])};
    const auto faces =
        static_cast<label_planes::FaceBits>(rowFaces_ | (i == 0 ? kFaceXMin : 0) | (i == cx_ - 1 ? kFaceXMax : 0));
    for (int c = 0; c < g.count; ++c) stage_.addVertex(position, faces);
    next_ += g.count;
    if (g.count > 1) appendSplits(labels, g, out_->labelSplits);
    const auto cellIndex = static_cast<std::size_t>(j * cx_ + i);
    // Every edge's id, without a branch: an edge that is not crossed gets a value that nothing reads
    // (its neighbours read only crossed edges, which are crossed in both cells).
#if defined(__SSE2__)
    static_assert(offsetof(CellGroups, edge) + 16 <= sizeof(CellGroups));
    const __m128i edges = _mm_loadu_si128(reinterpret_cast<const __m128i*>(g.edge.data()));  // and 4 bytes more
    const __m128i zero = _mm_setzero_si128();
    const __m128i low = _mm_unpacklo_epi8(edges, zero), high = _mm_unpackhi_epi8(edges, zero);
    const __m128i base = _mm_set1_epi32(static_cast<int>(first));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ids), _mm_add_epi32(base, _mm_unpacklo_epi16(low, zero)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ids + 4), _mm_add_epi32(base, _mm_unpackhi_epi16(low, zero)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(ids + 8), _mm_add_epi32(base, _mm_unpacklo_epi16(high, zero)));
#else
    for (std::size_t e = 0; e < 12; ++e) ids[e] = first + g.edge[e];
#endif
    TopCell top{first, g.topCopies, g.topCrossed, g.count, 0};
    // Split faces: two vertices at the face's centre, one per copy of its mesh edge, so that the
    // copies stay two edges even where both cells join them into one vertex copy.
    VertexId owned = 0;
    constexpr std::uint16_t kOwnedSplits = 0x333;  // faceSplits' bits of faces 0, 2 and 4
    for (std::size_t f = 0; f < 3 && (g.faceSplits & kOwnedSplits) != 0; ++f) {
      const int split = g.faceSplitOf(kOwnedFaces[f]);
      if (split == 0) continue;
      owned |= VertexId{1} << f;
      const std::array<double, 3> c{static_cast<double>(i) - (f == 0 ? 1.0 : 0.5),
                                    static_cast<double>(j) - (f == 1 ? 1.0 : 0.5),
                                    static_cast<double>(z_) - (f == 2 ? 1.0 : 0.5)};
      const VertexId a = addVertex(c), b = addVertex(c);
      // Copy a holds positions 3, 0 (split 1) or 0, 1 (split 2); copy b the other two.
      const std::array<VertexId, 4> byPosition = split == 1 ? std::array{a, b, b, a} : std::array{a, a, b, b};
      for (std::size_t k = 0; k < 4; ++k) ids[12 + 4 * f + k] = byPosition[k];
      if (f < 2) {
        top.meta = static_cast<std::uint8_t>(top.meta | (8u << f) | (split == 1 ? 32u << f : 0u));
      }
    }
    top_[1][cellIndex] = top;
    if (tracksTop_) topSet_.push_back(cellIndex);
    ids[24] = owned;
    emitQuads(i, j, labels, g, ids, below);
  }

  // The quads of the edges at the cell's lowest corner, whose other cells are done: the z edge
  // (cells of this layer, rows j - 1 and j), the x and y edges on slice z (cells of this layer
  // and the one below). Each is crossed only away from the padding, so i, j >= 1 where a cell to
  // the left or behind is read. Per quad: its four cells' vertices, counter-clockwise around the
  // edge's direction, and the faces that its sides cross (owner cell, face, the edge's position).
  void emitQuads(std::int64_t i, std::int64_t j, const std::array<std::int32_t, 8>& labels, const CellGroups& g,
                 VertexId* ids, const VertexId* below) {
    const std::int64_t n = static_cast<std::int64_t>(kRowIds);
    const auto cellBelow = [&](std::int64_t ii) { return below + ii * n; };  // cell (ii, j - 1)
    const VertexId* left = ids - n;                                          // cell (i - 1, j)
    if (g.edge[8] != 0xff) {
      const std::array<VertexId, 4> v{cellBelow(i - 1)[11], cellBelow(i)[10], ids[8], left[9]};
      const std::array<VertexId, 4> m{sideVertex(i, j - 1, 0, 0, 1, cellBelow(i)), sideVertex(i, j, 0, 1, 3, ids),
                                      sideVertex(i, j, 0, 0, 3, ids), sideVertex(i - 1, j, 0, 1, 1, left)};
      quad(v, m, {static_cast<double>(i) - 1, static_cast<double>(j) - 1, static_cast<double>(z_) - 0.5}, labels[0],
           labels[4]);
    }
    if (g.edge[0] != 0xff) {
      const std::array<VertexId, 4> v{lower(i, j - 1, 1), lower(i, j, 0), ids[0], cellBelow(i)[1]};
      const std::array<VertexId, 4> m{sideVertex(i, j, -1, 1, 2, nullptr), sideVertex(i, j, 0, 2, 0, ids),
                                      sideVertex(i, j, 0, 1, 0, ids), sideVertex(i, j - 1, 0, 2, 2, cellBelow(i))};
      quad(v, m, {static_cast<double>(i) - 0.5, static_cast<double>(j) - 1, static_cast<double>(z_) - 1}, labels[0],
           labels[1]);
    }
    if (g.edge[4] != 0xff) {
      const std::array<VertexId, 4> v{lower(i - 1, j, 3), left[5], ids[4], lower(i, j, 2)};
      const std::array<VertexId, 4> m{sideVertex(i - 1, j, 0, 2, 1, left), sideVertex(i, j, 0, 0, 0, ids),
                                      sideVertex(i, j, 0, 2, 3, ids), sideVertex(i, j, -1, 0, 2, nullptr)};
      quad(v, m, {static_cast<double>(i) - 1, static_cast<double>(j) - 0.5, static_cast<double>(z_) - 1}, labels[0],
           labels[2]);
    }
  }

  // The labels of face kLabelFaceCorners[face] of a cell, in its cyclic order.
  static std::array<std::int32_t, 4> faceOf(const std::array<std::int32_t, 8>& labels, int face) noexcept {
    const auto& c = kLabelFaceCorners[static_cast<std::size_t>(face)];
    return {labels[static_cast<std::size_t>(c[0])], labels[static_cast<std::size_t>(c[1])],
            labels[static_cast<std::size_t>(c[2])], labels[static_cast<std::size_t>(c[3])]};
  }

  // The label of sample (i, j) of slice z + dz (dz -1, 0 or 1).
  std::int32_t sample(std::int64_t i, std::int64_t j, int dz) const noexcept {
    const float* s = dz < 0 ? below_ : dz == 0 ? lo_ : hi_;
    return static_cast<std::int32_t>(s[j * px_ + i]);
  }

  // The vertex where a quad's side crosses owned face f (0: x = 0, 1: y = 0, 2: z = 0) of cell
  // (ci, cj) of this layer (dz 0, its ids given) or the layer below (dz -1, from the top plane), at
  // the edge's position k in the face; kUnsetId where the face is not split.
  VertexId sideVertex(std::int64_t ci, std::int64_t cj, int dz, int f, int k, const VertexId* ownerIds) {
    if (dz == 0) return ((ownerIds[24] >> f) & 1) != 0 ? ownerIds[12 + 4 * f + k] : kUnsetId;
    if (foreign_ == nullptr) {  // the cell below, crossed (the quad's edge is one of its edges), wrote its plane entry
      const TopCell& c = top_[0][static_cast<std::size_t>(cj * cx_ + ci)];
      if (((c.meta >> (3 + f)) & 1u) == 0) return kUnsetId;
      return topVertex(c, static_cast<std::size_t>(4 + 4 * f + k));
    }
    const auto& corners = kLabelFaceCorners[static_cast<std::size_t>(kOwnedFaces[static_cast<std::size_t>(f)])];
    std::array<std::int32_t, 4> face{};
    for (std::size_t c = 0; c < 4; ++c) {
      const int corner = corners[c];
      face[c] = sample(ci + (corner & 1), cj + ((corner >> 1) & 1), dz + (corner >> 2));
    }
    if (faceSplit(face) == 0) return kUnsetId;
    return lower(ci, cj, 4 + 4 * f + k);
  }

  VertexId addVertex(const std::array<double, 3>& lattice) {
    const Vec3d p = frame_.map(lattice[0], lattice[1], lattice[2]);
    stage_.addVertex({static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])},
                     label_planes::FaceBits{0});
    return static_cast<VertexId>(next_++);
  }

  // The vertex in slot k of cell (i, j) of the layer below (kTopSlots).
  VertexId lower(std::int64_t i, std::int64_t j, int k) {
    const auto cell = static_cast<std::size_t>(j * cx_ + i);
    if (foreign_ == nullptr) return topVertex(top_[0][cell], static_cast<std::size_t>(k));
    const std::size_t slot = slotOf(cell, static_cast<std::size_t>(k));
    const auto id = kForeignVertex | static_cast<VertexId>(foreign_->size());
    foreign_->push_back(CacheSlot{static_cast<std::int64_t>(slot)});
    return id;
  }

  // The quad v (counter-clockwise around the edge's direction) of the edge from a sample of label
  // `a` to the next sample, of label `b`: a face of the later-connecting label's surface. m[k] is
  // the vertex on its side v[k] -> v[k + 1] where that side crosses a split face (kUnsetId: none);
  // a quad with such vertices is fanned from a vertex of its own at `centre`.
  void quad(const std::array<VertexId, 4>& v, const std::array<VertexId, 4>& m, const std::array<double, 3>& centre,
            std::int32_t a, std::int32_t b) {
    const bool backIsA = !connectsBefore(a, b);  // the back label's face points from it to the front
    // {b, a} if backIsA, else {a, b}: a swap without a branch.
    const std::int32_t swap = (a ^ b) & -static_cast<std::int32_t>(backIsA);
    const LabelPair sides{a ^ swap, b ^ swap};
    const bool reverse = backIsA == flip_;
    if (m[0] == kUnsetId && m[1] == kUnsetId && m[2] == kUnsetId && m[3] == kUnsetId) {
      const VertexId second = reverse ? v[3] : v[1];
      const VertexId fourth = reverse ? v[1] : v[3];
      stage_.addTriangle({v[0], second, v[2]}, sides);
      stage_.addTriangle({v[0], v[2], fourth}, sides);
      return;
    }
    std::array<VertexId, 8> ring{};
    std::size_t n = 0;
    for (std::size_t k = 0; k < 4; ++k) {
      ring[n++] = v[k];
      if (m[k] != kUnsetId) ring[n++] = m[k];
    }
    if (reverse) std::reverse(ring.begin() + 1, ring.begin() + static_cast<std::ptrdiff_t>(n));
    const VertexId c = addVertex(centre);
    for (std::size_t k = 0; k < n; ++k) {
      stage_.addTriangle({c, ring[k], ring[(k + 1) % n]}, sides);
    }
  }

  LatticeFrame frame_;
  LatticeFrame::Row rowMap_{frame_, 0, 0};  // the row being walked
  std::uint8_t rowFaces_ = 0;               // its cells' volume faces (kFaceYMin ...), but for x
  bool flip_ = false;
  std::int64_t px_ = 0, py_ = 0, pz_ = 0, cx_ = 0, cy_ = 0;
  std::int64_t z_ = 0;
  const float* below_ = nullptr;  // slice z - 1 (the faces of the layer below)
  const float* lo_ = nullptr;
  const float* hi_ = nullptr;
  std::array<const RowSpan*, 2> spans_{};
  std::array<std::vector<RowSpan>, 2> scratch_;
  std::int64_t classified_ = -1;        // the slab whose lower slice scratch_[1] classifies (-1: none)
  std::array<Plane<VertexId>, 2> row_;  // per cell of rows j and j - 1 (alternating): the id of each edge's copy
  std::array<Plane<TopCell>, 2> top_;   // per crossed cell: [0] the layer below, [1] this layer
  std::vector<std::size_t> topSet_;     // the crossed cells of this layer (for takeTop)
  bool tracksTop_ = false;
  LabelCellCache cells_;
  RowStage stage_;
  bool allocated_ = false;
  MeshChunk* out_ = nullptr;
  std::vector<CacheSlot>* foreign_ = nullptr;
  std::uint64_t next_ = 0;
};

class LabelSlabWorker final : public SlabWorker {
 public:
  explicit LabelSlabWorker(const LabelKernel& like) : kernel_(like.dims(), like.frame()) { kernel_.trackTop(); }

  void extract(std::span<const SlabView> slabs, SlabPart& part,
               const std::function<void(const SlabView&)>& before) override {
    extractRun(kernel_, slabs, part, before);
  }

 private:
  LabelKernel kernel_;
};

class LabelExtractor final : public Extractor {
 public:
  LabelExtractor(const std::array<std::int64_t, 3>& padded, const LatticeFrame& frame) : kernel_(padded, frame) {}

  int slicesBelow() const noexcept override { return 1; }  // the split faces of the layer below
  int slicesAbove() const noexcept override { return 0; }
  std::uint64_t vertexCount() const noexcept override { return kernel_.vertexCount(); }
  bool cellVolumes() const noexcept override { return false; }
  std::size_t sliceSlots() const noexcept override { return kernel_.sliceSlots(); }
  void classifySlice(const float* slice, std::vector<RowSpan>& rows) const override {
    kernel_.classifySlice(slice, rows);
  }
  std::unique_ptr<SlabWorker> makeWorker() const override { return std::make_unique<LabelSlabWorker>(kernel_); }
  void extractSlab(const SlabView& slab, MeshChunk& out) override {
    kernel_.extractSlab(slab, out, nullptr);
    kernel_.rollCaches();
  }

 private:
  LabelKernel kernel_;
};

}  // namespace

std::unique_ptr<Extractor> makeLabelExtractor(const VolumeInfo& info, const LatticeFrame& frame) {
  std::array<std::int64_t, 3> padded = info.dims;
  for (auto& d : padded) d += 2;
  return std::make_unique<LabelExtractor>(padded, frame);
}

MeshHeader labelHeader(const VolumeInfo& info, const LatticeFrame& frame) {
  MeshHeader header;
  header.method = "labels";
  header.space = frame.name();
  header.volumeBounds = frame.bounds(info.dims, 0.5);
  header.volumeFaces = frame.faces(info.dims, 0.5);
  header.labels = true;
  return header;
}

}  // namespace isoslab
