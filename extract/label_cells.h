// The cells of a label complex (extract/label_extractor.h): how the surfaces of the labels at a
// cell's eight corners meet at the cell's vertex, and where that vertex must be split so that
// every label's surface stays a 2-manifold.
//
// The label complex is dual: each cell of the lattice (the cube between eight samples) holds a
// vertex, and each lattice edge whose two samples differ gives the quad of the four cells around
// it, which is the voxel face between those samples. The quads that meet at a cell's vertex are
// those of its crossed edges. Where a cell face holds one label on a diagonal and other labels on
// the other, four quads share the face's mesh edge; that edge is split in two, around the two
// corners of one diagonal, so that the other diagonal's label passes through (it stays connected)
// and every label has two quads on each copy. The face decides alone, so both cells that share it
// agree. Then the vertex is split into one copy per group of crossed edges that share an edge
// copy: each label's quads around a copy form one fan.
//
// Which diagonal connects: a label that fills one diagonal while two different labels fill the
// other always does (no other split leaves every label with two quads per copy). When two labels
// fill one diagonal each, the one that comes first in connection order does: the background (0),
// then the smaller value. So two voxels of a label that touch only at an edge or a corner give
// two closed surfaces, and the background around them stays one.
#pragma once

#include <array>
#include <bit>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "extract/slab_view.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace isoslab {

/// Corner c of a cell is at offset (c & 1, (c >> 1) & 1, (c >> 2) & 1). Edge e joins corners
/// kLabelEdgeCorners[e]: edges 0-3 run along x (at (y, z) = (0,0), (1,0), (0,1), (1,1)), 4-7 along
/// y (at (x, z) = (0,0), (1,0), (0,1), (1,1)) and 8-11 along z (at (x, y) = (0,0), (1,0), (0,1),
/// (1,1)).
inline constexpr std::array<std::array<int, 2>, 12> kLabelEdgeCorners{
    {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3}, {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}}};

/// The six faces (x = 0, x = 1, y = 0, y = 1, z = 0, z = 1), each as its corners in cyclic order;
/// its edge k joins corners k and k + 1 (mod 4). A face shared by two cells lists the same points
/// in the same order in both.
inline constexpr std::array<std::array<int, 4>, 6> kLabelFaceCorners{
    {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}}};

/// The order in which labels connect across a split edge: the background (0) first, then by value.
/// True if `a` connects before `b`. Without a branch (which of two labels comes first has no
/// pattern that a processor could predict): 0 becomes the least int32, which no label is (labels
/// lie within +-2^24, layered ones below 2^31, core/volume_info.h), and the order is then plain.
constexpr bool connectsBefore(std::int32_t a, std::int32_t b) noexcept {
  const auto rank = [](std::int32_t x) {
    return static_cast<std::int32_t>(static_cast<std::uint32_t>(x) | (static_cast<std::uint32_t>(x == 0) << 31));
  };
  return rank(a) < rank(b);
}
static_assert(connectsBefore(0, 5) && connectsBefore(0, -5) && !connectsBefore(5, 0) && !connectsBefore(0, 0) &&
              connectsBefore(-7, 3) && connectsBefore(3, 7) && !connectsBefore(7, 3) && !connectsBefore(4, 4));

/// The vertex copies of one cell.
struct CellGroups {
  /// Copies (0 for a cell whose eight labels are equal); at most 4.
  std::uint8_t count = 0;
  /// Per edge, its copy; 0xff where the edge is not crossed.
  std::array<std::uint8_t, 12> edge{};
  /// Per face f (kLabelFaceCorners), faceSplit() of its labels in bits 2f and 2f + 1.
  std::uint16_t faceSplits = 0;
  /// The top edges (2, 3, 6, 7, in that order, as k = 0..3): their copies, 2 bits each (0 where
  /// not crossed), and bit k set where edge k is crossed.
  std::uint8_t topCopies = 0;
  std::uint8_t topCrossed = 0;

  int faceSplitOf(int face) const noexcept { return (faceSplits >> (2 * face)) & 3; }
};

/// The copies of a cell with corner labels `labels` (kLabelEdgeCorners' numbering). Copies are
/// numbered in the order of their lowest edge.
CellGroups groupCell(const std::array<std::int32_t, 8>& labels) noexcept;

/// groupCell for cells of exactly two labels, from a table: `mask` has bit c set where corner c
/// holds the label that connects later (connectsBefore). The table is made by groupCell.
extern const std::array<CellGroups, 256> kTwoLabelGroups;
inline const CellGroups& twoLabelGroups(std::uint8_t mask) noexcept {
  return kTwoLabelGroups[mask];
}

/// Where three or more labels meet at a cell, a label may keep two fans at one copy of the vertex:
/// two labels on a face's diagonals with a third beyond (say 3 and 7 in a checkerboard under a
/// layer of 0) pinch whichever of the two is split, since the third label's interfaces with both
/// run through the point. A single point cannot be split there without new, zero-area triangles,
/// so the label's surface keeps a pinched vertex (closed, and manifold at every edge). Calls
/// `pinched(label, extraFans)` for each label that has more than one fan at a copy. Cells of two
/// labels never pinch.
void forEachPinch(const std::array<std::int32_t, 8>& labels, const CellGroups& groups,
                  const std::function<void(std::int32_t label, int extraFans)>& pinched);

/// Appends to `splits` each label (not 0) whose quads lie in several copies of the cell's vertex,
/// once per extra copy: its surface was split there.
void appendSplits(const std::array<std::int32_t, 8>& labels, const CellGroups& groups,
                  std::vector<std::int32_t>& splits);

/// A cell's eight labels, read from the four rows of samples around it (lower slice rows j and
/// j + 1, upper slice rows j and j + 1) at columns i and i + 1: corner c of `value` is sample
/// (i + (c & 1)) of row c / 2. With SSE2 also as two vectors, so that a label's corners are found
/// in two compares.
struct CellLabels {
  std::array<std::int32_t, 8> value;
#if defined(__SSE2__)
  __m128i lo, hi;  // corners 0-3 and 4-7
#endif

  static CellLabels load(const std::array<const float*, 4>& rows, std::int64_t i) noexcept {
    CellLabels c;
#if defined(__SSE2__)
    const auto pair = [i](const float* row) { return _mm_loadl_epi64(reinterpret_cast<const __m128i*>(row + i)); };
    c.lo = _mm_cvttps_epi32(_mm_castsi128_ps(_mm_unpacklo_epi64(pair(rows[0]), pair(rows[1]))));
    c.hi = _mm_cvttps_epi32(_mm_castsi128_ps(_mm_unpacklo_epi64(pair(rows[2]), pair(rows[3]))));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(c.value.data()), c.lo);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(c.value.data() + 4), c.hi);
#else
    for (std::size_t c2 = 0; c2 < 8; ++c2) c.value[c2] = static_cast<std::int32_t>(rows[c2 / 2][i + (c2 & 1)]);
#endif
    return c;
  }

  /// Bit c set where corner c holds `label`.
  std::uint32_t corners(std::int32_t label) const noexcept {
#if defined(__SSE2__)
    const __m128i l = _mm_set1_epi32(label);
    const int low = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(lo, l)));
    const int high = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(hi, l)));
    return static_cast<std::uint32_t>(low | (high << 4));
#else
    std::uint32_t mask = 0;
    for (std::size_t c = 0; c < 8; ++c) mask |= static_cast<std::uint32_t>(value[c] == label) << c;
    return mask;
#endif
  }
};

/// The copies of cells, fast: a table for cells of two labels; for cells of three labels or more
/// (few, and their patterns fewer), a cache by the ranks of their labels in connection order (3
/// bits a corner), which also keeps their pinches.
class LabelCellCache {
 public:
  /// The copies of a crossed cell; appends its pinches (forEachPinch) to `pinches`, a label per
  /// extra fan.
  const CellGroups& groups(const CellLabels& cell, std::vector<std::int32_t>& pinches) {
    // Two labels a and b: the mask of the corners of the one that connects later, from the table.
    const std::int32_t a = cell.value[0];
    const std::uint32_t isA = cell.corners(a);
    const std::int32_t b = cell.value[static_cast<std::size_t>(std::countr_one(isA) & 7)];
    const std::uint32_t isB = cell.corners(b);
    if ((isA | isB) != 0xffu) return manyLabels(cell, isA, isB, pinches);
    // The mask of b if a connects first, else a's; a select without a branch.
    const std::uint32_t aFirst = 0u - static_cast<std::uint32_t>(connectsBefore(a, b));
    return twoLabelGroups(static_cast<std::uint8_t>((isB & aFirst) | (isA & ~aFirst)));
  }

 private:
  struct Pattern {
    CellGroups groups;
    std::vector<std::pair<std::uint8_t, int>> pinches;  // (rank, extra fans)
  };
  // A cell of three labels or more; isA and isB: the corners of its first two labels.
  const CellGroups& manyLabels(const CellLabels& cell, std::uint32_t isA, std::uint32_t isB,
                               std::vector<std::int32_t>& pinches);
  // Appends the pattern of rank key `key` (3 bits a corner); `background`: rank 0 is label 0.
  void makePattern(std::uint32_t key, bool background);
  // A pattern's copies, its pinches appended for the cell's labels (`distinct`, by rank).
  static const CellGroups& found(const Pattern& p, const std::array<std::int32_t, 8>& distinct,
                                 std::vector<std::int32_t>& pinches);
  // The patterns seen; for cells of four labels or more an open-addressed table of their keys
  // (key + 1, 0: empty) and indices, a power of two in size and at most half full; for three
  // labels, a table of every pattern (3^8) of their indices + 1 (0: not seen).
  std::vector<Pattern> patterns_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> slots_;
  std::size_t hashed_ = 0;  // the patterns in slots_
  std::vector<std::uint32_t> threeLabels_;
};

/// The row spans of a slice of labels (RowSpan::first and last: the first and last x >= 1 where a
/// row changes label; -1 when it does not), for `nx` by `ny` samples.
void classifyLabelRows(const float* slice, std::int64_t nx, std::int64_t ny, std::vector<RowSpan>& rows);

/// Split edges of one face, from its four labels in cyclic order (kLabelFaceCorners): 0 when the
/// face's mesh edge is one, else 1 when the copies go around corners 0 and 2 (so the labels at
/// corners 1 and 3 pass through) and 2 when they go around corners 1 and 3.
int faceSplit(const std::array<std::int32_t, 4>& face) noexcept;

}  // namespace isoslab
