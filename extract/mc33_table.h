// Topologically correct Marching Cubes ("mc33"): per-cell decisions and their triangulations.
//
// The surface of a cell has, in every cell, the topology of the trilinear interpolant's iso-surface
// {F = threshold} with inside = {F >= threshold} (Chernyaev's "Marching cubes 33"). Corner, edge and
// face numbering and the orientation of triangles are those of extract/mc_table.h.
//
// Key layout (dense, < kKeyCount):
// - bits 0-7: the Marching Cubes case (bit c set when corner c is inside, v[c] >= threshold);
// - bits 8-13: face bits, bit 8 + 2 * axis + side set when that face is ambiguous (two diagonally
//   opposite inside corners, the other two outside) and its inside corners are joined across it;
// - bits 14-15: the interior code, 0 when the cell's interior joins nothing the faces left apart,
//   else 1 + the index of the joined pair in interiorCandidates(case, face bits).
// A key with face bits 0 and interior code 0 has the triangles of mc::kCaseTable, in the same order.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "extract/mc_table.h"

namespace isoslab::mc33 {

inline constexpr unsigned kKeyCount = 1u << 16;
/// Point 12 + m of a triangle is cell point m of its case; points 0-11 are the crossed cube edges.
inline constexpr std::uint8_t kCellPoint = 12;
/// The most triangles and cell points any key has (the tests check that both are reached).
inline constexpr int kMaxTriangles = 14;
inline constexpr int kMaxCellPoints = 2;

/// The triangles of one key, counter-clockwise seen from outside (from the lower values), as in
/// mc::kCaseTable. Every crossed edge and every cell point is used; a triangle edge joins two
/// points of one cube face only if it is a segment of that face (as the face decision cuts it), so
/// neighbouring cells share those segments and nothing else on the face.
struct Mc33Case {
  std::vector<std::array<std::uint8_t, 3>> triangles;
  /// Per cell point: the mask of crossed edges whose vertices' mean places it (the vertices where
  /// the surface crosses those edges). A cell point fans a disc whose loop has no fan from one of
  /// its points (the mask is the loop), or is a hub of a tunnel (the mask is the hub's neighbours).
  std::vector<std::uint16_t> cellPoints;
};

namespace detail {

/// Corner m (0-3) of face (axis, side) in cyclic (u, v) order (0,0), (1,0), (1,1), (0,1), with
/// u = (axis + 1) % 3 and v = (axis + 2) % 3.
constexpr int faceCorner(int axis, int side, int m) {
  constexpr int kCu[4] = {0, 1, 1, 0};
  constexpr int kCv[4] = {0, 0, 1, 1};
  return (side << axis) | (kCu[m] << ((axis + 1) % 3)) | (kCv[m] << ((axis + 2) % 3));
}

/// The number of groups of corners of one state (inside when `inside`) linked by cube edges.
constexpr int edgeGroups(unsigned cas, bool inside) {
  std::array<int, 8> parent{};
  for (int c = 0; c < 8; ++c) parent[static_cast<std::size_t>(c)] = c;
  auto find = [&parent](int c) {
    while (parent[static_cast<std::size_t>(c)] != c) c = parent[static_cast<std::size_t>(c)];
    return c;
  };
  auto state = [cas](int c) { return ((cas >> c) & 1u) != 0; };
  for (const auto& e : mc::kEdgeCorners) {
    if (state(e[0]) == inside && state(e[1]) == inside) {
      const int a = find(e[0]);
      const int b = find(e[1]);
      if (a != b) parent[static_cast<std::size_t>(a)] = b;
    }
  }
  int groups = 0;
  for (int c = 0; c < 8; ++c) groups += (state(c) == inside && find(c) == c) ? 1 : 0;
  return groups;
}

}  // namespace detail

/// Per case: bit 2 * axis + side set when that face is ambiguous.
inline constexpr std::array<std::uint8_t, 256> kAmbiguousFaces = [] {
  std::array<std::uint8_t, 256> table{};
  for (unsigned cas = 0; cas < 256; ++cas) {
    for (int f = 0; f < 6; ++f) {
      bool s[4] = {};
      for (int m = 0; m < 4; ++m) s[m] = ((cas >> detail::faceCorner(f / 2, f % 2, m)) & 1u) != 0;
      if (s[0] == s[2] && s[1] == s[3] && s[0] != s[1]) table[cas] = static_cast<std::uint8_t>(table[cas] | (1u << f));
    }
  }
  return table;
}();

/// Per case: false when the inside corners form one group and the outside corners one group (along
/// cube edges); then no face is ambiguous, nothing can join in the interior and cellKey == case.
inline constexpr std::array<bool, 256> kMayBeAmbiguous = [] {
  std::array<bool, 256> table{};
  for (unsigned cas = 0; cas < 256; ++cas) {
    table[cas] = detail::edgeGroups(cas, true) > 1 || detail::edgeGroups(cas, false) > 1;
  }
  return table;
}();

constexpr bool mayBeAmbiguous(unsigned cas) {
  return kMayBeAmbiguous[cas & 255u];
}

constexpr unsigned keyCase(unsigned key) {
  return key & 0xFFu;
}
constexpr unsigned keyFaces(unsigned key) {
  return (key >> 8) & 0x3Fu;
}
constexpr unsigned keyInterior(unsigned key) {
  return key >> 14;
}

/// The asymptotic decider on one face: the face's four values shifted by the threshold, in (u, v)
/// order (see detail::faceCorner). True when the face is ambiguous (a00, a11 on one side of 0, a10,
/// a01 on the other, ">= 0" being inside) and the bilinear saddle value is >= 0, i.e. the inside
/// corners are joined across the face; false otherwise, and whenever a value is NaN or infinite.
/// Exact: the sign of A*C - B*D (A, C the inside pair) is found with the products' rounding errors.
bool faceJoinsInside(double a00, double a10, double a11, double a01) noexcept;

/// The key of a cell with corner values v[0..7] (corner c at (c & 1, (c >> 1) & 1, (c >> 2) & 1)),
/// a pure function of its inputs: the kernel passes threshold = insideThreshold(iso). The decisions
/// use the values shifted in double, double(v[c]) - double(threshold). NaN is outside; a face with a
/// NaN or infinite value does not join its inside corners, and a cell with any NaN or infinite
/// value joins nothing through its interior. When !mayBeAmbiguous(case) the key is the case; the
/// interior sweep runs only for case and face bits with an interior candidate. Thread-safe;
/// allocates nothing.
unsigned cellKey(const float* v, float threshold) noexcept;

/// The triangles of a key. Throws std::logic_error for a key that cellKey never returns (face bits
/// on a face that is not ambiguous or that no field produces, an interior code without a
/// candidate). Slow (up to about a millisecond for a tunnel): call it once per key and cache it.
Mc33Case buildCase(unsigned key);

/// True for the keys buildCase accepts (768 of them); cellKey returns only such keys, and each of
/// them for some corner values.
bool isValidKey(unsigned key) noexcept;

/// Every valid key, ascending.
std::vector<unsigned> allKeys();

/// The pairs of boundary regions that the interior of a cell of case `cas` with face bits `faces`
/// may join (at most two), each named by the smallest corner of each region. Empty for an invalid
/// combination.
std::vector<std::array<std::uint8_t, 2>> interiorCandidates(unsigned cas, unsigned faces);

/// The connected components of the inside and of the outside of the whole cell under the trilinear
/// interpolant of `shifted` (corner values minus the threshold, all finite): label[c] is the smallest
/// corner in corner c's component. Found by the exact sweep that cellKey uses.
std::array<std::uint8_t, 8> sweepComponents(const double* shifted) noexcept;

}  // namespace isoslab::mc33
