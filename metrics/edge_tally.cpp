#include "metrics/edge_tally.h"

#include <algorithm>

#include <fmt/format.h>

#include "core/error.h"

namespace isoslab {

void EdgeTally::clear() {
  ready_.clear();
  held_.clear();
}

void EdgeTally::add(VertexId from, VertexId to, bool onVolumeFace, VertexId chunkFirst) {
  const VertexId lo = std::min(from, to);
  const VertexId delta = std::max(from, to) - lo;
  if (delta >= (VertexId{1} << 30)) {
    throw Error(fmt::format("the topology check supports edges spanning fewer than 2^30 vertex ids, not {}", delta));
  }
  const EdgeUse use{lo, delta << 2 | static_cast<VertexId>(from < to) << 1 | static_cast<VertexId>(onVolumeFace)};
  (lo < chunkFirst ? ready_ : held_).push_back(use);
}

// Groups the uses in ready_, whose lower ends all lie in [first, end), by lower end with a counting
// sort, then by upper end within each (short) group. offsets_[v] ends at the end of v's group.
void EdgeTally::group(VertexId first, VertexId end) {
  const std::size_t n = end - first;
  offsets_.assign(n + 1, 0);
  for (const EdgeUse& u : ready_) ++offsets_[u.lo - first + 1];
  for (std::size_t v = 0; v < n; ++v) offsets_[v + 1] += offsets_[v];
  sorted_.resize(ready_.size());
  for (const EdgeUse& u : ready_) sorted_[offsets_[u.lo - first]++] = u.packed;
  ready_.clear();
  std::size_t begin = 0;
  for (std::size_t v = 0; v < n; ++v) {
    std::sort(sorted_.begin() + static_cast<std::ptrdiff_t>(begin),
              sorted_.begin() + static_cast<std::ptrdiff_t>(offsets_[v]));
    begin = offsets_[v];
  }
}

}  // namespace isoslab
