// Edge-collapse simplification that keeps a surface a surface: quadric error (Garland and Heckbert
// 1997) orders half-edge collapses (a vertex moves onto a neighbour, so the kept positions are
// original ones), and a collapse is made only where it keeps the mesh what it was:
//   - only a vertex whose triangles form one closed fan moves (a disk): vertices on a border, on a
//     non-manifold edge or at a pinch stay, so an open border and whatever touches it keep every
//     vertex (the blocks and regions of process/decimation.h rely on that);
//   - the link condition (Dey et al. 1999): the two ends may share no neighbour but the two
//     opposite the edge, so no edge comes to be used by more than two triangles, no vertex pinches
//     and no triangle is made twice;
//   - no triangle around the moved vertex turns over or loses its area.
// Optionally (a label complex), a vertex inside a line where three sheets meet moves too, onto a
// neighbour on the line: each sheet then loses the triangle on the collapsed edge, and the line
// keeps three sheets on each edge.
// meshoptimizer 0.18's meshopt_simplify has no such test: it can join two sheets where a surface is
// thin, and the decimation then had to find each such spot and simplify the whole region again
// (docs/design.md, "Our own simplifier").
//
// Collapses go in passes, as in meshoptimizer: a pass sorts the candidate collapses by error and
// makes them in that order, each only where nothing around it has changed in the pass (its ends
// and the moved vertex's neighbours are left alone for the rest of it), so every test reads the
// mesh as it is. Deterministic: the order is by error, then by position in the input.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "core/scratch.h"

namespace isoslab {

/// A collapse that was made: `from` moved onto `to` (ids as in the input). A log of them begins each
/// pass with a mark: `from` kPassMark, `to` the pass's number (from 1). In a replay (below), a step
/// whose `to` has kRename set only renames `from` in the triangles that have it, with no test: a
/// collapse that was made around the input, which its triangles on `from` took part in (the flag
/// takes the ids' top bit: a replay with renames needs fewer than 2^31 vertices).
struct SimplifyStep {
  static constexpr std::uint32_t kPassMark = 0xffffffffu;
  static constexpr std::uint32_t kRename = 0x80000000u;
  std::uint32_t from = 0, to = 0;
  bool isPass() const { return from == kPassMark; }
  bool isRename() const { return !isPass() && (to & kRename) != 0; }
  std::uint32_t target() const { return to & ~kRename; }
};

struct SimplifyLimits {
  /// Stop at this many triangles or fewer.
  std::size_t targetTriangles = 0;
  /// The largest error of a collapse: the root mean square of the distances from the moved
  /// vertex's new position to the planes of the original triangles merged into it, weighted by
  /// area, in the positions' units (infinite: no limit).
  double maxError = INFINITY;
  /// Asked before each collapse whose error is above `checkAbove` (same units), with the triangles
  /// that would replace those around the moved vertex (ids as in the input): false refuses the
  /// collapse. The decimation measures them against the original surface there.
  std::function<bool(const std::vector<std::array<std::uint32_t, 3>>&)> check;
  double checkAbove = INFINITY;
  /// Per vertex, nonzero where it must stay whatever its triangles look like (empty: none): a
  /// vertex whose other triangles are left out of the input. kRenamedOnly in a replay: a vertex
  /// whose triangles in the input are as the recorded run had them, and that moves only by the
  /// replay's renames (its other steps fail, as it stays).
  static constexpr std::uint8_t kRenamedOnly = 2;
  std::vector<std::uint8_t> locked;
  /// A label complex's lines where three labels meet (three sheets on each of their edges) are
  /// simplified along themselves: a vertex inside such a line moves onto one of its two neighbours
  /// on the line, with the tests above for every sheet (false: such vertices stay).
  bool alongLines = false;
  /// When set, each collapse made is appended to it, in order, each pass after its mark (a replay
  /// appends its collapses without the marks; a lazy buffer: reserve it for the most that may come,
  /// and only what is written is resident).
  LazyScratchVector<SimplifyStep>* record = nullptr;
  /// When not empty (a log as `record` makes, its pass marks in increasing order and below 2^16 - 1:
  /// the replay stops at a mark beyond), the simplifier makes these collapses again, pass by pass
  /// and in order, instead of choosing its own, and stops after them: each only where the tests
  /// pass on the mesh as it is then, with the errors and the check as above. A repair replays a run's
  /// collapses on its input less a frozen patch, so the run's choices stand wherever the patch does
  /// not reach. A collapse whose moving vertex has the triangles and the quadric that it had in the
  /// recorded run makes the same triangles: `check`, which passed them then, is not asked again.
  /// The `unchecked` flags (below) are then 0 for every kept triangle with a corner whose triangles
  /// are as the recorded run left them: it is a triangle of that run's result, which the caller
  /// has measured. Renames among the steps (SimplifyStep::kRename) are made with no test: a local
  /// repair (process/decimation.cpp, repairNear) replays a zone's collapses, with those of the
  /// vertices around it as renames, on the input's triangles on the zone.
  std::span<const SimplifyStep> replay;
  /// A pass after one that made few collapses takes over its candidates and finds again only those
  /// around its collapses (false: every pass finds them all; the same collapses, for the tests).
  bool carryKeys = true;
  /// Set (when given) where a replay's rename turned a triangle over or flattened it: among
  /// triangles that may differ from the recorded run's (a corner's triangles or quadric changed
  /// since), where the recorded collapse's tests would have refused it.
  bool* renameFolds = nullptr;
};

/// Simplifies the triangles `indices` (three ids a triangle, into `xyz`: three floats a vertex) in
/// place, as far as the limits allow; returns how many indices are kept, at the front (three a
/// triangle, in the order of the triangles they came from). With `keptFrom` (at least one entry a
/// triangle), its first entries are set to each kept triangle's index in the input (a collapse only
/// renames a vertex, so a kept triangle keeps what it carried: a label complex's sides, say). With
/// `unchecked` (as long), its first entries are set to 1 for each kept triangle that a collapse
/// changed without `limits.check` seeing it, or that came from such a triangle, and 0 for the
/// rest: those are unchanged, or a check saw their centroid and the edges that the collapse made
/// (and their other edge was one of an unchanged or checked triangle's).
std::size_t simplifyTriangles(std::span<std::uint32_t> indices, const float* xyz, std::size_t vertexCount,
                              const SimplifyLimits& limits, std::span<std::uint32_t> keptFrom = {},
                              std::span<std::uint8_t> unchecked = {});
/// The same on a vector, resized to the indices kept (and `keptFrom` to the triangles kept).
std::size_t simplifyTriangles(std::vector<std::uint32_t>& indices, const float* xyz, std::size_t vertexCount,
                              const SimplifyLimits& limits, std::vector<std::uint32_t>* keptFrom = nullptr);

}  // namespace isoslab
