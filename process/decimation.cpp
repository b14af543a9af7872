// Streamed decimation by blocks and regions (see decimation.h), with the edge collapses of
// process/simplifier.h (ordered by quadric error, Garland and Heckbert 1997), borders locked.
#include "process/decimation.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <functional>
#include <limits>
#include <mutex>
#include <system_error>
#include <thread>
#include <utility>

#include "core/error.h"
#include "core/fans.h"
#include "core/scratch.h"
#include "core/volume_info.h"
#include "process/simplifier.h"

namespace isoslab {
namespace {

constexpr VertexId kNone = 0xffffffffu;
// Tries to simplify a region before it is kept whole.
constexpr int kAttempts = 12;
// Collapses whose error (process/simplifier.h) is above this fraction of the distance bound are
// measured against the original surface before they are made.
constexpr double kCheckAbove = 0.2;
// What a block keeps, as a multiple of the ratio (the regions bring it down).
constexpr double kBlockSlack = 1.2;
// The most simplify calls that run side by side (the memory budget, DecimateOptions::pairBytes, is
// for a pair of blocks).
constexpr std::size_t kSideBySide = 2;
// What a block waiting in the queue holds, a triangle, beyond its chunks' share of the stream: its
// chunks stay until the call (the noisy phantom's fourth block, 263,000 triangles, raised the peak
// at two threads by 11 MB, about 42 bytes a triangle).
constexpr std::size_t kQueuedBytesPerTriangle = 64;

// The least and the greatest of three (std::min of a list is a loop that the compiler keeps).
template <class T>
T min3(T a, T b, T c) {
  return std::min(std::min(a, b), c);
}
template <class T>
T max3(T a, T b, T c) {
  return std::max(std::max(a, b), c);
}

struct EdgeUse {
  std::uint32_t uses = 0;
  std::uint32_t forward = 0;  // uses from the smaller id to the larger
};

using Clock = std::chrono::steady_clock;

// Adds to `into` the seconds from its making to the end of its scope (DecimationReport::Seconds).
class Timed {
 public:
  explicit Timed(double& into) : into_(into), start_(Clock::now()) {}
  ~Timed() { into_ += std::chrono::duration<double>(Clock::now() - start_).count(); }
  Timed(const Timed&) = delete;
  Timed& operator=(const Timed&) = delete;

 private:
  double& into_;
  Clock::time_point start_;
};

// The smallest and largest vertex id of `triangles` (not empty): per-vertex arrays of a region span
// these, not the sink's whole window of vertices.
std::pair<VertexId, VertexId> idRange(std::span<const Triangle> triangles) {
  VertexId low = triangles.front()[0], high = low;
  for (const Triangle& t : triangles) {
    low = std::min(low, min3(t[0], t[1], t[2]));
    high = std::max(high, max3(t[0], t[1], t[2]));
  }
  return {low, high};
}

// Every edge of the triangles, sorted by key (smaller id << 32 | larger id): its uses and how many
// run from the smaller id to the larger. Linear: the uses are bucketed by their smaller id (a
// counting sort over the ids' range), then each vertex's few uses are sorted by the larger id.
ScratchVector<std::pair<std::uint64_t, EdgeUse>> tallyEdges(std::span<const Triangle> triangles) {
  ScratchVector<std::pair<std::uint64_t, EdgeUse>> edges;
  if (triangles.empty()) return edges;
  const auto [low, high] = idRange(triangles);
  ScratchVector<std::uint32_t> offsets(static_cast<std::size_t>(high - low) + 2, 0);
  // An edge from a vertex to itself (a triangle that repeats an id) is no edge.
  for (const Triangle& t : triangles) {
    for (std::size_t k = 0; k < 3; ++k) {
      if (t[k] != t[(k + 1) % 3]) ++offsets[std::min(t[k], t[(k + 1) % 3]) - low + 1];
    }
  }
  for (std::size_t k = 1; k < offsets.size(); ++k) offsets[k] += offsets[k - 1];
  // Per use: the larger id, and 1 when it runs from the smaller id to the larger.
  ScratchVector<std::pair<VertexId, std::uint32_t>> uses(offsets.back());
  ScratchVector<std::uint32_t> fill(offsets.begin(), offsets.end() - 1);
  for (const Triangle& t : triangles) {
    for (std::size_t k = 0; k < 3; ++k) {
      const VertexId a = t[k], b = t[(k + 1) % 3];
      if (a != b) uses[fill[std::min(a, b) - low]++] = {std::max(a, b), a < b ? 1u : 0u};
    }
  }
  // Each vertex's uses sorted by the larger id (few: an insertion sort), and the distinct edges
  // counted, so that the list is made at its size.
  std::size_t distinct = 0;
  for (std::size_t v = 0; v + 1 < offsets.size(); ++v) {
    const std::uint32_t first = offsets[v], last = offsets[v + 1];
    for (std::uint32_t k = first + 1; k < last; ++k) {
      const auto u = uses[k];
      std::uint32_t m = k;
      for (; m > first && u.first < uses[m - 1].first; --m) uses[m] = uses[m - 1];
      uses[m] = u;
    }
    for (std::uint32_t k = first; k < last; ++k) distinct += (k == first || uses[k].first != uses[k - 1].first) ? 1 : 0;
  }
  edges.reserve(distinct);
  for (std::size_t v = 0; v + 1 < offsets.size(); ++v) {
    const std::uint32_t first = offsets[v], last = offsets[v + 1];
    const std::uint64_t lo = low + static_cast<VertexId>(v);
    for (std::uint32_t k = first; k < last;) {
      std::uint32_t end = k;
      EdgeUse e{0, 0};
      for (; end < last && uses[end].first == uses[k].first; ++end) {
        ++e.uses;
        e.forward += uses[end].second;
      }
      edges.push_back({(lo << 32) | uses[k].first, e});
      k = end;
    }
  }
  return edges;
}

struct Shape {
  ScratchVector<std::uint64_t> border;  // edges used once, sorted
  // Their ends: a flag per id from the least of them.
  VertexId borderLow = 0;
  ScratchVector<std::uint8_t> borderFlags;
  ScratchVector<std::uint64_t> amongBorder;  // every edge between two border vertices, sorted
  std::uint64_t nonManifold = 0;             // edges used more than twice
  std::uint64_t inconsistent = 0;            // edges used twice in the same direction
  // Those two kinds, sorted by key: a label complex has them where three or more labels meet.
  ScratchVector<std::pair<std::uint64_t, EdgeUse>> odd;
  bool onBorder(VertexId v) const {
    return v >= borderLow && v - borderLow < borderFlags.size() && borderFlags[v - borderLow] != 0;
  }
};

// Of all the edges, only those between two border vertices are kept: the check after a try needs
// no more (a new edge there is a chord), and the whole list was the largest array of a region's check.
Shape shapeOf(std::span<const Triangle> triangles) {
  Shape s;
  const auto edges = tallyEdges(triangles);
  for (const auto& [key, e] : edges) {
    if (e.uses == 1) s.border.push_back(key);
    if (e.uses > 2) ++s.nonManifold;
    if (e.uses == 2 && e.forward != 1) ++s.inconsistent;
    if (e.uses > 2 || (e.uses == 2 && e.forward != 1)) s.odd.push_back({key, e});
  }
  if (!s.border.empty()) {
    // A border key's first end is the smaller, and the keys are sorted by it.
    s.borderLow = static_cast<VertexId>(s.border.front() >> 32);
    VertexId high = s.borderLow;
    for (std::uint64_t key : s.border) high = std::max(high, static_cast<VertexId>(key & 0xffffffffu));
    s.borderFlags.assign(static_cast<std::size_t>(high - s.borderLow) + 1, 0);
    for (std::uint64_t key : s.border) {
      s.borderFlags[static_cast<VertexId>(key >> 32) - s.borderLow] = 1;
      s.borderFlags[static_cast<VertexId>(key & 0xffffffffu) - s.borderLow] = 1;
    }
  }
  for (const auto& [key, e] : edges) {
    if (s.onBorder(static_cast<VertexId>(key >> 32)) && s.onBorder(static_cast<VertexId>(key & 0xffffffffu))) {
      s.amongBorder.push_back(key);
    }
  }
  return s;
}

using Vec3d = std::array<double, 3>;

Vec3d sub(const Vec3d& a, const Vec3d& b) {
  return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
double dot(const Vec3d& a, const Vec3d& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// Squared distance from p to the triangle abc: the closest point by the triangle's Voronoi regions
// (vertices, edges, face), from the barycentric conditions.
double distanceSquared(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  const auto at = [&](const Vec3d& q) {
    const Vec3d d = sub(p, q);
    return dot(d, d);
  };
  if (d1 <= 0 && d2 <= 0) return at(a);
  const Vec3d bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return at(b);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return at({a[0] + v * ab[0], a[1] + v * ab[1], a[2] + v * ab[2]});
  }
  const Vec3d cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return at(c);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return at({a[0] + w * ac[0], a[1] + w * ac[1], a[2] + w * ac[2]});
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return at({b[0] + w * (c[0] - b[0]), b[1] + w * (c[1] - b[1]), b[2] + w * (c[2] - b[2])});
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return at({a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w});
}

// Whether the bounding box of triangle abc lies farther than sqrt(bound) from p, tested in floats
// axis by axis (q: p rounded to floats). Each gap is lessened by `slack`, more than the rounding of
// p to q and of the subtraction (a few units in the last place of the largest coordinate), so that
// the answer is true only where the exact test's is.
bool boxBeyond(const Vec3f& a, const Vec3f& b, const Vec3f& c, const std::array<float, 3>& q, float slack,
               float bound) {
  float outside = 0;
  const auto axis = [&](float u, float v, float w, float x) {
    const float gap = std::max(std::max(min3(u, v, w) - x, x - max3(u, v, w)) - slack, 0.0f);
    outside += gap * gap;
    return outside > bound;
  };
  return axis(a.z, b.z, c.z, q[2]) || axis(a.y, b.y, c.y, q[1]) || axis(a.x, b.x, c.x, q[0]);
}

// The squared distance from p to the box [low, high] (0 inside).
double boxGapSquared(const Vec3d& p, const Vec3d& low, const Vec3d& high) {
  double sum = 0;
  for (std::size_t d = 0; d < 3; ++d) {
    const double gap = std::max(std::max(low[d] - p[d], p[d] - high[d]), 0.0);
    sum += gap * gap;
  }
  return sum;
}

Vec3d toDouble(const Vec3f& p) {
  return {p.x, p.y, p.z};
}

Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// Whether the segment pq passes through the inside of the triangle abc (Moller and Trumbore's
// ray-triangle test, limited to the segment): touching an edge, a corner or the plane is not
// crossing.
bool segmentCrosses(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  using Vec3 = Vec3d;
  constexpr double eps = 1e-9;
  const Vec3 d = sub(q, p), e1 = sub(b, a), e2 = sub(c, a);
  const Vec3 h = cross(d, e2);
  const double det = dot(e1, h);
  if (std::abs(det) < 1e-15) return false;
  const Vec3 s = sub(p, a);
  const double u = dot(s, h) / det;
  if (!(u > eps && u < 1 - eps)) return false;
  const Vec3 k = cross(s, e1);
  const double v = dot(d, k) / det;
  const double t = dot(e2, k) / det;
  return v > eps && u + v < 1 - eps && t > eps && t < 1 - eps;
}

// How many times each triangle (corner for corner) is in a list, in a table with open addressing:
// the crossing search looks up each triangle a few times, which costs less than sorting the list.
class TriangleCounts {
 public:
  explicit TriangleCounts(std::span<const Triangle> triangles) {
    std::size_t capacity = 16;
    while (capacity < 2 * triangles.size()) capacity *= 2;
    slots_.resize(capacity);
    mask_ = capacity - 1;
    for (const Triangle& t : triangles) {
      Slot& slot = slots_[find(t)];
      slot.key = t;
      ++slot.count;
    }
  }
  std::uint32_t count(const Triangle& t) const { return slots_[find(t)].count; }

 private:
  struct Slot {
    Triangle key{};
    std::uint32_t count = 0;  // 0: empty
  };
  // The slot that holds t, or the empty one where it would go.
  std::size_t find(const Triangle& t) const {
    std::uint64_t h = (std::uint64_t{t[0]} * 0x9e3779b97f4a7c15ull) ^ (std::uint64_t{t[1]} * 0xc2b2ae3d27d4eb4full) ^
                      (std::uint64_t{t[2]} * 0x165667b19e3779f9ull);
    h ^= h >> 32;
    for (std::size_t i = static_cast<std::size_t>(h) & mask_;; i = (i + 1) & mask_) {
      if (slots_[i].count == 0 || slots_[i].key == t) return i;
    }
  }
  ScratchVector<Slot> slots_;
  std::size_t mask_ = 0;
};

}  // namespace

std::string checkDecimateOptions(const DecimateOptions& o) {
  if (!(o.ratio > 0 && o.ratio <= 1)) return "`decimate` must be above 0 and at most 1";
  if (!(o.maxError >= 0) || !std::isfinite(o.maxError)) return "`max_error` must be 0 or more";
  if (!(o.voxelSize > 0)) return "the voxel size must be above 0";
  if (o.blockSlabs < 2) return "a block needs at least 2 slabs";
  if (o.batchTriangles < 1) return "a simplifier batch needs at least 1 triangle";
  return {};
}

DecimationSink::DecimationSink(MeshSink& next, const DecimateOptions& options) : next_(next), options_(options) {
  if (const std::string e = checkDecimateOptions(options); !e.empty()) throw Error(e);
}

void DecimationSink::begin(const MeshHeader& header) {
  header_ = header;
  report_ = DecimationReport{};
  report_.measured = options_.measure;
  distanceSum_ = 0;
  base_ = 0;
  positions_.clear();
  normals_.clear();
  boundary_.clear();
  sent_.clear();
  nextId_ = 0;
  chunkBase_ = 0;
  chunkFirst_.clear();
  chunkSlab_.clear();
  chunkTriangles_.clear();
  chunkGrids_.clear();
  chunks_ = 0;
  blockStart_ = 0;
  queued_.clear();
  scheduleBase_ = 0;
  blockTriangles_ = 0;
  hasPending_ = false;
  pendingUpper_ = Faces{};
  pendingCurve_.clear();
  chunkLabels_.clear();
  complex_ = header.labels;
  MeshHeader out = header;
  out.cellVolumes = false;
  next_.begin(out);
}

void DecimationSink::consume(const MeshChunk& chunk) {
  if (chunk.firstVertex != base_ + positions_.size()) {
    throw Error("decimation: the chunk's vertices do not continue the previous chunk's");
  }
  positions_.insert(positions_.end(), chunk.positions.begin(), chunk.positions.end());
  if (header_.normals) normals_.insert(normals_.end(), chunk.normals.begin(), chunk.normals.end());
  if (chunk.boundary.empty()) {
    boundary_.resize(boundary_.size() + chunk.positions.size(), 0);
  } else {
    boundary_.insert(boundary_.end(), chunk.boundary.begin(), chunk.boundary.end());
  }
  sent_.resize(positions_.size(), kNone);
  chunkFirst_.push_back(chunk.firstVertex);
  chunkSlab_.push_back(chunk.slab);
  chunkTriangles_.emplace_back(chunk.triangles.begin(), chunk.triangles.end());
  chunkGrids_.emplace_back();
  if (complex_) {
    if (chunk.faceLabels.size() != chunk.triangles.size()) {
      throw Error("decimation: a label complex's chunk lacks its triangles' labels");
    }
    chunkLabels_.emplace_back(chunk.faceLabels.begin(), chunk.faceLabels.end());
  }
  ++chunks_;
  report_.trianglesIn += chunk.triangles.size();
  blockTriangles_ += static_cast<std::int64_t>(chunk.triangles.size());
  if (static_cast<std::int64_t>(chunks_ - blockStart_) >= options_.blockSlabs &&
      blockTriangles_ >= options_.blockTriangles) {
    queueBlock();
    // More blocks are taken only with a thread for a second one and memory for the first one's
    // pair: kSideBySide of them and one more, for the first thread that is free (blocks of the
    // same size can take twice as long as one another), or a fourth when its chunks would fit there
    // too, judged by the largest block queued (each thread then has two blocks: with three, one
    // thread ran the third alone while the other had only regions left).
    const auto triangles = [this](const Block& b) { return static_cast<std::size_t>(originalIn(b.start, b.end)); };
    const std::size_t firstTriangles = triangles(queued_.front());
    std::size_t largest = 0;
    for (const Block& b : queued_) largest = std::max(largest, triangles(b));
    const std::size_t pairBytes = firstTriangles * kPairBytesPerTriangle;
    const bool pair = options_.threads > 1 && pairBytes <= options_.pairBytes;
    const bool twoRounds = pair && pairBytes + largest * kQueuedBytesPerTriangle <= options_.pairBytes;
    if (!pair || queued_.size() >= (twoRounds ? 2 * kSideBySide : kSideBySide + 1)) processQueued();
  }
}

void DecimationSink::finish() {
  if (chunks_ > blockStart_) queueBlock();
  // The last blocks' call takes the stream's last half block too, as a region of its own (alone
  // when no block came after the last call).
  processQueued(true);
  if (report_.samples > 0) report_.distanceMean = distanceSum_ / static_cast<double>(report_.samples);
  next_.finish();
}

// The original triangles of chunks [first, end).
std::int64_t DecimationSink::originalIn(std::size_t first, std::size_t end) const {
  std::int64_t n = 0;
  for (std::size_t c = first; c < end; ++c) n += static_cast<std::int64_t>(chunkTriangles_[c - chunkBase_].size());
  return n;
}

// Adds a simplify call's counters to the report.
void DecimationSink::count(const Scope& scope) {
  report_.repairedRegions += scope.repairedRegions;
  report_.frozenTriangles += scope.frozenTriangles;
  report_.keptRegions += scope.keptRegions;
  report_.attempts += scope.attempts;
  report_.brokenShape += scope.brokenShape;
  report_.beyondBound += scope.beyondBound;
  report_.crossing += scope.crossing;
  report_.seconds.calls += scope.seconds.calls;
  report_.seconds.simplifier += scope.seconds.simplifier;
  report_.seconds.checks += scope.seconds.checks;
  report_.seconds.crossing += scope.seconds.crossing;
}

// The chunk (index in the stream) that holds vertex v.
std::size_t DecimationSink::chunkOfVertex(VertexId v) const {
  const auto it = std::upper_bound(chunkFirst_.begin(), chunkFirst_.end(), v);
  return chunkBase_ + static_cast<std::size_t>(it - chunkFirst_.begin()) - 1;
}

// Closes the open block: it waits in queued_ until processQueued().
void DecimationSink::queueBlock() {
  const std::size_t middle = std::max(blockStart_ + 1, (blockStart_ + chunks_) / 2);
  queued_.push_back(Block{blockStart_, chunks_, middle, scheduleBase_});
  // Later regions use only vertices from the middle chunk on; the error measure also reads the
  // original triangles of the chunk below it, which use the vertices of the chunk below that.
  scheduleBase_ = std::max(scheduleBase_, middle >= 2 ? middle - 2 : 0);
  blockStart_ = chunks_;
  blockTriangles_ = 0;
}

// Runs body(0) .. body(n - 1), body(0) here and the others on threads of their own; a share whose
// thread cannot start runs here afterwards. Rethrows the first error, in the order of the shares.
void DecimationSink::onThreads(std::size_t n, const std::function<void(std::size_t)>& body) {
  std::vector<std::exception_ptr> errors(n);
  const auto share = [&](std::size_t i) {
    try {
      body(i);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(n > 0 ? n - 1 : 0);
  for (std::size_t i = 1; i < n; ++i) {
    try {
      threads.emplace_back(share, i);
    } catch (const std::system_error&) {
      break;  // no thread to be had
    }
  }
  if (n > 0) share(0);
  for (std::thread& t : threads) t.join();
  for (std::size_t i = threads.size() + 1; i < n; ++i) share(i);
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

// The stream's last half block, as a region of its own (after the last block's region is made).
void DecimationSink::makeLastRegion(Work& w) {
  w.input = std::move(pendingUpper_);
  pendingUpper_ = Faces{};
  hasPending_ = false;
  w.original = originalIn(pendingMiddle_, chunks_);
  w.slab = chunkSlab_.back();
  ++report_.regions;
  // Clamped as one block at a time would (its last call has trimmed the chunks below this).
  w.range = rangeAround(w.input.triangles, std::max(chunkBase_, scheduleBase_), chunks_);
  if (complex_) w.lock.curve = std::move(pendingCurve_);
  buildGrids({w.range}, 1);
}

// A block's simplify call: its chunks' triangles, the chunks that measure them, and what it locks.
void DecimationSink::makeBlock(const Block& b, Work& w) const {
  // Reserved at its size (a mapped buffer is resident whole: core/scratch.h).
  std::size_t size = 0;
  for (std::size_t c = b.start; c < b.end; ++c) size += chunkTriangles_[c - chunkBase_].size();
  w.input.triangles.reserve(size);
  w.input.labels.reserve(complex_ ? size : 0);
  for (std::size_t c = b.start; c < b.end; ++c) {
    const auto& t = chunkTriangles_[c - chunkBase_];
    w.input.triangles.insert(w.input.triangles.end(), t.begin(), t.end());
    if (complex_) {
      const auto& l = chunkLabels_[c - chunkBase_];
      w.input.labels.insert(w.input.labels.end(), l.begin(), l.end());
    }
  }
  w.original = originalIn(b.start, b.end);
  w.range = rangeAround(w.input.triangles, b.base, b.end);
  w.scope.block = true;
  if (complex_) {
    // The chunk before the block's (the block before it uses them) and its last chunk's (the
    // next block's may).
    w.lock.below = chunkFirst_[b.start - chunkBase_];
    w.lock.from = chunkFirst_[b.end - 1 - chunkBase_];
  }
}

// Makes region k from block k's output, which it splits at the block's middle chunk (a triangle
// with a vertex below it is the lower half): the lower half and the pending upper half (none before
// the first block) are the region; the upper half waits for the next block. Called in block order.
void DecimationSink::makeRegion(const Block& b, Work& block, Work& w) {
  const VertexId middleFirst =
      b.middle < chunks_ ? chunkFirst_[b.middle - chunkBase_] : base_ + static_cast<VertexId>(positions_.size());
  // Each half at its size: the upper one waits for the next block (a grown array's untouched
  // tail would be resident where it lies in a huge page: core/scratch.h).
  const auto isLower = [&](const Triangle& tri) { return min3(tri[0], tri[1], tri[2]) < middleFirst; };
  const auto lowerCount =
      static_cast<std::size_t>(std::count_if(block.output.triangles.begin(), block.output.triangles.end(), isLower));
  Faces lower, upper;
  const bool sided = !block.output.labels.empty();
  lower.triangles.reserve(lowerCount);
  upper.triangles.reserve(block.output.size() - lowerCount);
  lower.labels.reserve(sided ? lowerCount : 0);
  upper.labels.reserve(sided ? block.output.size() - lowerCount : 0);
  for (std::size_t t = 0; t < block.output.size(); ++t) {
    (isLower(block.output.triangles[t]) ? lower : upper).add(block.output, t);
  }
  block.output = Faces{};
  w.slab = chunkSlab_[b.middle - 1 - chunkBase_];
  w.input.triangles.reserve(pendingUpper_.size() + lower.size());
  w.input.labels.reserve(sided ? pendingUpper_.size() + lower.size() : 0);
  w.input.append(pendingUpper_);
  w.input.append(lower);
  pendingUpper_ = Faces{};
  w.original = originalIn(hasPending_ ? pendingMiddle_ : b.start, b.middle);
  ++report_.regions;
  w.range = rangeAround(w.input.triangles, b.base, b.end);
  // Any grid of the region's range not built yet (its blocks built theirs, and the call before
  // kept those of the pending upper half), here: the calls running meanwhile read only the other
  // chunks' grids.
  buildGrids({w.range}, 1);
  block.scope.surface.reset();
  if (complex_) {
    // The split curve before the region and the one after it (the lower half's vertices from
    // the middle chunk on, which the upper half shares).
    w.lock.curve = std::move(pendingCurve_);
    w.lock.from = middleFirst;
    pendingCurve_.clear();
    for (const Triangle& t : lower.triangles) {
      for (VertexId v : t) {
        if (v >= middleFirst) pendingCurve_.push_back(v);
      }
    }
    std::sort(pendingCurve_.begin(), pendingCurve_.end());
    pendingCurve_.erase(std::unique(pendingCurve_.begin(), pendingCurve_.end()), pendingCurve_.end());
  }
  pendingUpper_ = std::move(upper);
  pendingMiddle_ = b.middle;
  hasPending_ = true;
}

// Simplifies the queued blocks, and the regions across their seams, on the threads that the
// options give (kSideBySide at most): each thread takes the next block while one is left (the
// long calls first), else the next region whose block is done (regions are made in block order).
// Then the regions go on in stream order. Every range is clamped to
// what the one-block-at-a-time schedule would hold at that point, and each call depends only on its
// input, so the output is the same however many blocks are queued and whatever runs where.
void DecimationSink::processQueued(bool last) {
  const std::size_t n = queued_.size();
  // With `last`, region n is the last block's upper half (made once region n - 1 is).
  const std::size_t regionCount = last && (n > 0 || hasPending_) ? n + 1 : n;
  if (regionCount == 0) return;
  std::vector<Work> blocks(n), regions(regionCount);
  // The blocks that start at once, here; a later one when it starts (its copy is not held before).
  const std::size_t atOnce = std::min(n, kSideBySide);
  for (std::size_t k = 0; k < atOnce; ++k) makeBlock(queued_[k], blocks[k]);
  report_.blocks += n;
  // The grids for the blocks' checks: those of the blocks that start at once here, side by side; a
  // later block's when it starts.
  const bool checked = options_.maxDistance > 0;
  if (checked) {
    std::vector<ChunkRange> ranges;
    for (std::size_t k = 0; k < atOnce; ++k) ranges.push_back(blocks[k].range);
    buildGrids(ranges, options_.threads);
  }
  {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<std::uint8_t> blockDone(n, 0);
    std::size_t nextBlock = 0, nextRegion = 0;
    bool failed = false;
    // Each input freed once simplified (the output is a copy).
    const auto run = [this](Work& w) {
      w.output = simplify(w.input, w.original, w.range, w.lock, w.scope);
      w.input = Faces{};
    };
    const auto work = [&](std::size_t) {
      std::unique_lock<std::mutex> lock(mutex);
      try {
        while (!failed) {
          if (nextBlock < n) {
            const std::size_t k = nextBlock++;
            if (k >= atOnce) {
              makeBlock(queued_[k], blocks[k]);
              // The calls running meanwhile read only grids built before they started.
              if (checked) buildGrids({blocks[k].range}, 1);
            }
            lock.unlock();
            run(blocks[k]);
            lock.lock();
            blockDone[k] = 1;
            changed.notify_all();
          } else if (nextRegion < regionCount && (n == 0 || blockDone[std::min(nextRegion, n - 1)] != 0)) {
            const std::size_t k = nextRegion++;
            if (k < n) {
              makeRegion(queued_[k], blocks[k], regions[k]);
            } else {
              makeLastRegion(regions[k]);
            }
            lock.unlock();
            run(regions[k]);
            lock.lock();
          } else if (nextRegion == regionCount) {
            return;
          } else {
            changed.wait(lock);
          }
        }
      } catch (...) {
        if (!lock.owns_lock()) lock.lock();
        failed = true;
        changed.notify_all();
        throw;
      }
    };
    onThreads(std::min({static_cast<std::size_t>(std::max(1, options_.threads)), kSideBySide, regionCount}), work);
  }
  for (std::vector<Work>* group : {&blocks, &regions}) {
    for (const Work& w : *group) count(w.scope);
  }
  // The grids freed but those that the next region reads (the pending upper half's chunks and the
  // one below them: rangeAround), which it would otherwise make again; then the regions measured.
  for (Work& w : regions) w.scope.surface.reset();
  const std::size_t keepFrom = hasPending_ ? std::max(pendingMiddle_, std::size_t{1}) - 1 : chunks_;
  for (std::size_t c = chunkBase_; c < std::min(keepFrom, chunks_); ++c) chunkGrids_[c - chunkBase_].reset();
  if (options_.measure) {
    const Timed measuring(report_.seconds.measure);
    for (Work& w : regions) measure(w.output.triangles, w.range);
  }
  for (Work& w : regions) {
    emit(w.output, w.slab);
    w = Work{};
  }
  trim(scheduleBase_);
  queued_.clear();
}

const DecimationSink::Originals& DecimationSink::surfaceFor(ChunkRange range, Scope& scope) const {
  if (!scope.surface || !(scope.surfaceRange == range)) {
    Originals& surface = scope.surface.emplace();
    for (std::size_t c = std::max(chunkBase_, range.first); c < std::min(chunks_, range.end); ++c) {
      const std::unique_ptr<OriginalSurface>& grid = chunkGrids_[c - chunkBase_];
      if (grid == nullptr) throw std::logic_error("decimation: a chunk's grid was not built before its use");
      // Every range starts a chunk above its block's base (queueBlock, rangeAround), whose vertices
      // the window holds, so a grid in use holds all of its chunk's triangles: what a call measures
      // against does not depend on how far down the window reaches (the number of blocks queued).
      if (grid->count != grid->triangles.size()) {
        throw std::logic_error("decimation: a chunk's grid in use lacks triangles below the window");
      }
      if (grid->count > 0) surface.parts.push_back(grid.get());
    }
    surface.index();
    scope.surfaceRange = range;
  }
  return *scope.surface;
}

void DecimationSink::buildGrids(const std::vector<ChunkRange>& ranges, int threads) {
  if (!(options_.maxDistance > 0)) return;  // no check: no grid (the measure builds its own)
  std::vector<std::size_t> missing;
  for (const ChunkRange& range : ranges) {
    for (std::size_t c = std::max(chunkBase_, range.first); c < std::min(chunks_, range.end); ++c) {
      if (chunkGrids_[c - chunkBase_] == nullptr) missing.push_back(c);
    }
  }
  std::sort(missing.begin(), missing.end());
  missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
  // Each grid reads only the chunk's triangles and the positions, and writes only its own slot.
  const std::size_t shares = std::min<std::size_t>(static_cast<std::size_t>(std::max(1, threads)), missing.size());
  std::vector<double> seconds(shares, 0.0);  // each share's, summed after (report_ is not theirs)
  onThreads(shares, [&](std::size_t from) {
    const Timed building(seconds[from]);
    for (std::size_t i = from; i < missing.size(); i += shares) {
      const std::size_t c = missing[i];
      chunkGrids_[c - chunkBase_] = std::make_unique<OriginalSurface>(originalSurface(c));
    }
  });
  for (const double share : seconds) report_.seconds.grids += share;
}

void DecimationSink::trim(std::size_t firstChunk) {
  if (firstChunk <= chunkBase_) return;
  const std::size_t drop = firstChunk - chunkBase_;
  const VertexId newBase = chunkFirst_[drop];
  const std::size_t vertices = newBase - base_;
  positions_.erase(positions_.begin(), positions_.begin() + static_cast<std::ptrdiff_t>(vertices));
  if (!normals_.empty()) normals_.erase(normals_.begin(), normals_.begin() + static_cast<std::ptrdiff_t>(vertices));
  boundary_.erase(boundary_.begin(), boundary_.begin() + static_cast<std::ptrdiff_t>(vertices));
  sent_.erase(sent_.begin(), sent_.begin() + static_cast<std::ptrdiff_t>(vertices));
  base_ = newBase;
  chunkFirst_.erase(chunkFirst_.begin(), chunkFirst_.begin() + static_cast<std::ptrdiff_t>(drop));
  chunkSlab_.erase(chunkSlab_.begin(), chunkSlab_.begin() + static_cast<std::ptrdiff_t>(drop));
  chunkTriangles_.erase(chunkTriangles_.begin(), chunkTriangles_.begin() + static_cast<std::ptrdiff_t>(drop));
  chunkGrids_.erase(chunkGrids_.begin(), chunkGrids_.begin() + static_cast<std::ptrdiff_t>(drop));
  // A grid that holds a triangle on a vertex now dropped is made again when next needed, without it
  // (as every grid leaves out the triangles on vertices below base_).
  for (std::unique_ptr<OriginalSurface>& grid : chunkGrids_) {
    if (grid != nullptr && grid->count > 0 && grid->minVertex < newBase) grid.reset();
  }
  if (complex_) chunkLabels_.erase(chunkLabels_.begin(), chunkLabels_.begin() + static_cast<std::ptrdiff_t>(drop));
  chunkBase_ = firstChunk;
}

// The simplifier on `triangles`, in batches of whole connected components when there are more
// than options_.batchTriangles, each with its share of the target (less what earlier batches kept
// beyond theirs): components share no vertex, so a batch's collapses are those it would make among
// the others, and only the stopping point moves. The last `context` triangles are context (their
// corners pinned, so kept as they are): the target is for the others, and each batch keeps its
// context on top of its share.
DecimationSink::Faces DecimationSink::collapse(Faces faces, std::size_t targetTriangles, std::size_t context,
                                               const Originals* original, const ScratchVector<VertexId>& pinned,
                                               const Steps& steps, ScratchVector<std::uint8_t>& unchecked) const {
  unchecked.clear();
  if (faces.triangles.empty()) return {};
  // The arrays below span the triangles' ids, not the sink's whole window of vertices.
  const auto [low, high] = idRange(faces.triangles);
  const std::size_t span = static_cast<std::size_t>(high - low) + 1;
  // Local ids by vertex (relative to low), ~0u where unused: one array for every batch, each
  // batch resetting the entries it set.
  ScratchVector<unsigned> local(span, ~0u);
  if (faces.size() <= options_.batchTriangles) {
    return collapseBatch(faces.triangles, faces.labels, targetTriangles + context, original, pinned, local, low, &faces,
                         steps, unchecked);
  }
  const std::size_t firstContext = faces.size() - context;
  const ScratchVector<Triangle>& triangles = faces.triangles;
  // Components: union-find over the vertices (ids relative to low), the smaller root winning.
  ScratchVector<std::uint32_t> parent(span);
  for (std::uint32_t v = 0; v < parent.size(); ++v) parent[v] = v;
  const auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const Triangle& t : triangles) {
    const std::uint32_t a = find(t[0] - low);
    for (std::size_t k = 1; k < 3; ++k) {
      const std::uint32_t b = find(t[k] - low);
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  // Triangles grouped by component (components in order of their lowest vertex, triangles in input
  // order), then cut into batches of whole components. The grouped copy replaces the input before
  // any batch runs, and the batches are ranges of it (the simplifier's working set sits beside as
  // little as may be).
  ScratchVector<std::pair<std::uint32_t, std::uint32_t>> order(triangles.size());  // (root, triangle)
  {
    // A counting sort by root: each root's triangles in input order, as sorting the pairs would
    // leave them.
    ScratchVector<std::uint32_t> start(span + 1, 0);
    for (const Triangle& t : triangles) ++start[find(t[0] - low) + 1];
    for (std::size_t r = 0; r < span; ++r) start[r + 1] += start[r];
    for (std::uint32_t t = 0; t < triangles.size(); ++t) {
      const std::uint32_t root = find(triangles[t][0] - low);
      order[start[root]++] = {root, t};
    }
  }
  ScratchVector<std::uint32_t>().swap(parent);  // freed (`= {}` would only empty it)
  ScratchVector<Triangle> grouped(triangles.size());
  for (std::size_t k = 0; k < order.size(); ++k) grouped[k] = triangles[order[k].second];
  ScratchVector<LabelPair> groupedLabels(faces.labels.size());
  for (std::size_t k = 0; k < groupedLabels.size(); ++k) groupedLabels[k] = faces.labels[order[k].second];
  faces = Faces{};
  ScratchVector<std::size_t> starts{0};     // each batch's first triangle in `grouped`
  ScratchVector<std::size_t> contextIn{0};  // and its context triangles
  for (std::size_t i = 0; i < order.size();) {
    std::size_t j = i;
    while (j < order.size() && order[j].first == order[i].first) ++j;
    if (i > starts.back() && j - starts.back() > options_.batchTriangles) {
      starts.push_back(i);
      contextIn.push_back(0);
    }
    for (std::size_t k = i; k < j; ++k) contextIn.back() += order[k].second >= firstContext ? 1 : 0;
    i = j;
  }
  decltype(order)().swap(order);
  starts.push_back(grouped.size());
  Faces out;
  // The target is shared by the triangles other than the context, which every batch keeps on top.
  const std::size_t plain = grouped.size() - context;
  std::size_t plainSoFar = 0, plainKept = 0;
  for (std::size_t b = 0; b + 1 < starts.size(); ++b) {
    // The target's share up to here, rounded, less what earlier batches kept: a batch that its
    // error bound stopped short leaves the later ones to go further.
    plainSoFar += starts[b + 1] - starts[b] - contextIn[b];
    const auto upTo =
        static_cast<std::size_t>(std::llround(static_cast<double>(targetTriangles) * static_cast<double>(plainSoFar) /
                                              static_cast<double>(std::max<std::size_t>(plain, 1))));
    const std::span<const Triangle> batch(grouped.data() + starts[b], starts[b + 1] - starts[b]);
    const std::span<const LabelPair> batchLabels =
        groupedLabels.empty() ? std::span<const LabelPair>()
                              : std::span<const LabelPair>(groupedLabels.data() + starts[b], starts[b + 1] - starts[b]);
    const Faces kept = collapseBatch(batch, batchLabels, (upTo > plainKept ? upTo - plainKept : 0) + contextIn[b],
                                     original, pinned, local, low, nullptr, steps, unchecked);
    plainKept += kept.size() > contextIn[b] ? kept.size() - contextIn[b] : 0;
    out.append(kept);
  }
  return out;
}

// The simplifier on `triangles` with their border locked, as far as the target and the bound.
// `release`, when given, holds the triangles and is emptied once they are copied; `labels` (empty
// outside a label complex) are the triangles' sides, which each kept triangle keeps. Appends to
// `unchecked` a flag per kept triangle: 1 where the collapses that made it were not all measured
// against the original surface (simplifyTriangles).
DecimationSink::Faces DecimationSink::collapseBatch(std::span<const Triangle> triangles,
                                                    std::span<const LabelPair> labels, std::size_t targetTriangles,
                                                    const Originals* original, const ScratchVector<VertexId>& pinned,
                                                    ScratchVector<unsigned>& local, VertexId low, Faces* release,
                                                    const Steps& steps, ScratchVector<std::uint8_t>& unchecked) const {
  if (triangles.empty()) return {};
  // The sides, copied before `release` frees them.
  ScratchVector<LabelPair> sides(labels.begin(), labels.end());
  // Local ids in order of first use; ids[local] is the global id (counted first, and then made at
  // its size: a mapped buffer is resident whole, core/scratch.h).
  ScratchVector<unsigned> indices(triangles.size() * 3);
  unsigned used = 0;
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (std::size_t k = 0; k < 3; ++k) {
      unsigned& l = local[triangles[t][k] - low];
      if (l == ~0u) l = used++;
      indices[3 * t + k] = l;
    }
  }
  // `local` spans the outline too (repairNear gives one over the whole region).
  for (const VertexId v : steps.outline) {
    if (v < low || v - low >= local.size()) throw std::logic_error("collapseBatch: an outline vertex beyond the ids");
    unsigned& l = local[v - low];
    if (l == ~0u) l = used++;
  }
  ScratchVector<VertexId> ids(used);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (std::size_t k = 0; k < 3; ++k) ids[indices[3 * t + k]] = triangles[t][k];
  }
  for (const VertexId v : steps.outline) ids[local[v - low]] = v;
  // The recorded collapses among this batch's vertices, in local ids and in order of pass (a batch
  // may hold components that the recorded try gave to different batches, each numbering its own
  // passes: each pass is gathered from all of them).
  LazyScratchVector<SimplifyStep> replay;
  if (!steps.replay.empty()) {
    std::uint32_t passes = 0;
    for (const SimplifyStep& s : steps.replay) passes = s.isPass() ? std::max(passes, s.to) : passes;
    replay.reserve(steps.replay.size() + passes);
    for (std::uint32_t p = 1; p <= passes; ++p) {
      replay.push_back({SimplifyStep::kPassMark, p});
      std::uint32_t pass = 0;
      for (std::size_t i = 0; i < steps.replay.size(); ++i) {
        const SimplifyStep& s = steps.replay[i];
        if (s.isPass()) {
          pass = s.to;
          continue;
        }
        if (pass != p || s.from < low || s.to < low || s.from - low >= local.size() || s.to - low >= local.size()) {
          continue;
        }
        const unsigned from = local[s.from - low], to = local[s.to - low];
        const bool rename = !steps.renames.empty() && steps.renames[i] != 0;
        if (from != ~0u && to != ~0u) replay.push_back({from, rename ? to | SimplifyStep::kRename : to});
      }
    }
  }
  // The pinned vertices that this batch uses, by their local ids.
  std::vector<std::uint8_t> locked;
  if (!pinned.empty() || !steps.outline.empty()) {
    locked.assign(ids.size(), 0);
    for (const VertexId v : steps.outline) locked[local[v - low]] = SimplifyLimits::kRenamedOnly;
    for (const VertexId v : pinned) {
      if (v >= low && v - low < local.size() && local[v - low] != ~0u) locked[local[v - low]] = 1;
    }
  }
  for (VertexId v : ids) local[v - low] = ~0u;
  if (release != nullptr) *release = Faces{};  // `triangles` and `labels` are gone from here on
  ScratchVector<float> xyz(ids.size() * 3);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const Vec3f& p = position(ids[i]);
    xyz[3 * i] = p.x;
    xyz[3 * i + 1] = p.y;
    xyz[3 * i + 2] = p.z;
  }
  // The collapses' own error bound: --max-error, else half the distance bound (the quadric error
  // underestimates how far a collapse moves the surface; fewer collapses then need undoing).
  SimplifyLimits limits;
  limits.targetTriangles = targetTriangles;
  limits.alongLines = complex_;
  // Recorded in place, in local ids, then renamed: each collapse takes at least two triangles.
  const std::size_t recordedBefore = steps.record != nullptr ? steps.record->size() : 0;
  if (steps.record != nullptr) {
    steps.record->reserve(recordedBefore + indices.size() / 6 + 64);
    limits.record = steps.record;
  }
  limits.replay = replay;
  limits.renameFolds = steps.renameFolds;
  limits.locked = std::move(locked);
  const double bound = options_.maxError > 0 ? options_.maxError : 0.5 * options_.maxDistance;
  limits.maxError = bound > 0 ? bound * options_.voxelSize : INFINITY;
  // A collapse that moves the surface at all is measured against the original surface before it is
  // made, so that the region's check finds nothing to undo.
  const double distanceLimit = options_.maxDistance * options_.voxelSize;
  if (original != nullptr && distanceLimit > 0) {
    limits.checkAbove = kCheckAbove * distanceLimit;
    // The new triangles fan out from `to`: each one's centroid, and the midpoints of the edges
    // from `to` (each once). Their edges between two ring vertices were there before.
    limits.check = [&, ends = ScratchVector<std::uint32_t>(),
                    hint = kNoHint](const std::vector<std::array<std::uint32_t, 3>>& made) mutable {
      ends.clear();
      for (const auto& t : made) {
        const std::array<Vec3d, 3> corners = cornersOf({ids[t[0]], ids[t[1]], ids[t[2]]});
        const std::array<Vec3d, 4> samples = samplePoints(corners);
        if (!nearCorner(samples[0], corners, distanceLimit) && !original->within(samples[0], distanceLimit, hint)) {
          return false;
        }
        for (std::size_t k = 1; k < 3; ++k) {
          // samples[1] is the midpoint of (t[0], t[1]), samples[3] that of (t[2], t[0]).
          const std::uint32_t end = t[k];
          if (std::find(ends.begin(), ends.end(), end) != ends.end()) continue;
          ends.push_back(end);
          const Vec3d& middle = samples[k == 1 ? 1 : 3];
          if (!nearCorner(middle, corners, distanceLimit) && !original->within(middle, distanceLimit, hint)) {
            return false;
          }
        }
      }
      return true;
    };
  }
  ScratchVector<std::uint32_t> keptFrom(sides.empty() ? 0 : indices.size() / 3);
  const std::size_t before = unchecked.size();
  unchecked.resize(before + indices.size() / 3);
  const std::size_t kept =
      simplifyTriangles(std::span<std::uint32_t>(indices), xyz.data(), ids.size(), limits,
                        std::span<std::uint32_t>(keptFrom), std::span<std::uint8_t>(unchecked).subspan(before));
  unchecked.resize(before + kept / 3);
  if (steps.record != nullptr) {
    for (std::size_t i = recordedBefore; i < steps.record->size(); ++i) {
      SimplifyStep& s = (*steps.record)[i];
      if (s.isPass()) continue;
      s.from = ids[s.from];
      s.to = ids[s.to];
    }
  }
  Faces out;
  out.triangles.resize(kept / 3);
  for (std::size_t t = 0; t < out.size(); ++t) {
    out.triangles[t] = {ids[indices[3 * t]], ids[indices[3 * t + 1]], ids[indices[3 * t + 2]]};
  }
  if (!sides.empty()) {
    out.labels.resize(out.size());
    for (std::size_t t = 0; t < out.size(); ++t) out.labels[t] = sides[keptFrom[t]];
  }
  return out;
}

namespace {

// Marks the frozen triangles with an edge between two corners of the input (the triangles not
// frozen) whose other triangle is frozen too; returns how many. Such an edge is in no input triangle,
// so the simplifier's link condition cannot see it, and a collapse could make it again outside the
// frozen ones (four triangles on it): they go to the simplifier as context, every corner fixed, so
// that no collapse changes them, and are taken out of what comes back. An edge listed twice below
// has both its triangles frozen (a label complex's line has three triangles, and may get context
// that it does not need).
std::size_t frozenContext(std::span<const Triangle> triangles, const ScratchVector<bool>& frozen, VertexId first,
                          std::size_t span, ScratchVector<std::uint8_t>& inContext) {
  ScratchVector<std::uint8_t> inInput(span, 0);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (frozen[t]) continue;
    for (const VertexId v : triangles[t]) inInput[v - first] = 1;
  }
  ScratchVector<std::pair<std::uint64_t, std::uint32_t>> edges;  // (edge, frozen triangle)
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    if (!frozen[t]) continue;
    const Triangle& tri = triangles[t];
    for (std::size_t k = 0; k < 3; ++k) {
      const VertexId a = tri[k], b = tri[(k + 1) % 3];
      if (inInput[a - first] == 0 || inInput[b - first] == 0) continue;
      edges.push_back(
          {static_cast<std::uint64_t>(std::min(a, b)) << 32 | std::max(a, b), static_cast<std::uint32_t>(t)});
    }
  }
  std::sort(edges.begin(), edges.end());
  std::size_t count = 0;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i + 1;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    for (std::size_t k = i; k < j && j - i > 1; ++k) {
      count += inContext[edges[k].second] == 0 ? 1 : 0;
      inContext[edges[k].second] = 1;
    }
    i = j;
  }
  return count;
}

}  // namespace

// A repair's try (issue 36's local repairs): only the neighbourhood of the bad spots is simplified
// again, as the region-wide replay of the first try's collapses would simplify it. The zone: the
// corners of the newly frozen triangles `fresh` and the last try's result's neighbours of what
// stands for them there, with every vertex that the first try joined to one of those
// (repairs.firstRoot). Its triangles in the last try's result go. In their place, the region's
// triangles on a zone vertex (less the frozen ones, which go in as context, every corner fixed) get
// the first try's collapses among the zone's vertices again, tested as a replay tests them
// (SimplifyLimits::replay). The vertices around the zone stay, but the collapses that the first try
// joined them with come in order too: those made in the last try's result as renames
// (SimplifyStep::kRename), so that the triangles on the zone are renamed as they were; the others
// as steps that fail, which mark what they touch dirty, as they do in a region-wide replay. So
// every step sees the triangles that a region-wide replay would show it, and outside the zone
// nothing changes (what the last try's checks passed there stands: its flags are 0). Where a dirty
// vertex reaches a rename, a region-wide replay might have tested that collapse: its triangles are
// flagged for the checks that follow (every edge and fan of the result is checked anyway), and if
// it turned one over, which only its own test would see, nothing changes and the answer is false.
// So the result can differ from the region-wide replay's where that one would refuse a collapse
// that is only a rename here; it is checked as any try is. The same triangles on the real inputs
// measured and on 142 of 144 small random label complexes (docs/plans/issue36.md, stop 60).
bool DecimationSink::repairNear(const Faces& faces, const ScratchVector<bool>& frozen,
                                std::span<const std::uint32_t> fresh, Repairs& repairs, VertexId first,
                                std::span<const SimplifyStep> log, const Originals* original, Faces& simplified,
                                ScratchVector<std::uint8_t>& unchecked) const {
  const ScratchVector<Triangle>& triangles = faces.triangles;
  const ScratchVector<std::uint32_t>& joined = repairs.firstRoot;
  ScratchVector<std::uint32_t>& root = repairs.root;
  const std::size_t span = root.size();
  // The zone by the first try's classes (each named by its last vertex, relative to `first`): 1 for
  // those on the new frozen triangles, 2 for their neighbours in the last result (marked apart, so
  // that the scan does not go on from them), 3 for those around the zone that the input touches
  // (its context too: a frozen corner whose logged collapse the last result did not make marks
  // its neighbours as its failing step does in a region-wide replay).
  ScratchVector<std::uint8_t> zone(span, 0);
  const auto classOf = [&](VertexId v) -> std::uint8_t& { return zone[joined[v - first]]; };
  for (const std::uint32_t t : fresh) {
    for (const VertexId v : triangles[t]) classOf(v) = 1;
  }
  for (const Triangle& t : repairs.previous.triangles) {
    if (classOf(t[0]) != 1 && classOf(t[1]) != 1 && classOf(t[2]) != 1) continue;
    for (const VertexId v : t) classOf(v) = classOf(v) == 1 ? 1 : 2;
  }
  const auto inZone = [&](VertexId v) { return classOf(v) == 1 || classOf(v) == 2; };
  // The region's triangles on the zone as they are, and its frozen ones there as context.
  Faces input;
  ScratchVector<Triangle> context;
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Triangle& tri = triangles[t];
    if (!inZone(tri[0]) && !inZone(tri[1]) && !inZone(tri[2])) continue;
    if (frozen[t]) {
      context.push_back(tri);
    } else {
      input.add(faces, t);
    }
    for (const VertexId v : tri) {
      if (!inZone(v)) classOf(v) = 3;
    }
  }
  const std::size_t plain = input.size();
  for (std::size_t t = 0; t < triangles.size() && plain > 0 && !context.empty(); ++t) {
    const Triangle& tri = triangles[t];
    if (frozen[t] && (inZone(tri[0]) || inZone(tri[1]) || inZone(tri[2]))) input.add(faces, t);
  }
  if (plain == 0) context.clear();
  ScratchVector<VertexId> pinned;
  for (const Triangle& t : context) pinned.insert(pinned.end(), t.begin(), t.end());
  std::sort(pinned.begin(), pinned.end());
  pinned.erase(std::unique(pinned.begin(), pinned.end()), pinned.end());
  // The steps: the zone's, and those of the classes around it, each a rename where the last result
  // has it made (its `from` stands for another vertex).
  LazyScratchVector<SimplifyStep> replay, made;
  LazyScratchVector<std::uint8_t> renames;
  replay.reserve(log.size());
  renames.reserve(log.size());
  ScratchVector<VertexId> outline;
  for (const SimplifyStep& s : log) {
    const std::uint8_t kind = s.isPass() ? 0 : classOf(s.from);
    if (s.isPass() || kind == 1 || kind == 2) {
      replay.push_back(s);
      renames.push_back(0);
    } else if (kind == 3) {
      replay.push_back(s);
      renames.push_back(root[s.from - first] != s.from - first ? 1 : 0);
      outline.push_back(s.from);
      outline.push_back(s.to);
    }
  }
  for (const Triangle& t : input.triangles) {
    for (const VertexId v : t) {
      if (!inZone(v)) outline.push_back(v);
    }
  }
  std::sort(outline.begin(), outline.end());
  outline.erase(std::unique(outline.begin(), outline.end()), outline.end());
  // No target: a replay makes what its steps say, and with no step nothing is made.
  bool folded = false;
  Steps steps;
  steps.replay = replay;
  steps.renames = renames;
  steps.record = &made;
  steps.outline = outline;
  steps.renameFolds = &folded;
  ScratchVector<std::uint8_t> flags;
  ScratchVector<unsigned> local(span, ~0u);
  const std::size_t contextCount = context.size();
  const Faces zoned = collapseBatch(input.triangles, input.labels, plain + contextCount, original, pinned, local, first,
                                    nullptr, steps, flags);
  if (folded) return false;
  // What stays of the last result, then the zone's triangles less the context.
  // Every array at its size (growing one would leave slack resident: core/scratch.h).
  simplified = Faces{};
  const std::size_t most = repairs.previous.size() + zoned.size();
  simplified.triangles.reserve(most);
  simplified.labels.reserve(faces.labels.empty() ? 0 : most);
  unchecked.clear();
  unchecked.reserve(most);
  for (std::size_t t = 0; t < repairs.previous.size(); ++t) {
    const Triangle& tri = repairs.previous.triangles[t];
    if (!inZone(tri[0]) && !inZone(tri[1]) && !inZone(tri[2])) simplified.add(repairs.previous, t);
  }
  unchecked.assign(simplified.size(), 0);
  std::sort(context.begin(), context.end());
  for (std::size_t t = 0; t < zoned.size(); ++t) {
    if (std::binary_search(context.begin(), context.end(), zoned.triangles[t])) continue;
    simplified.add(zoned, t);
    unchecked.push_back(flags[t]);
  }
  // The zone's vertices stand for themselves again, or for what the collapses made of them.
  ScratchVector<std::uint32_t> members;
  for (std::uint32_t v = 0; v < span; ++v) {
    if (zone[joined[v]] == 1 || zone[joined[v]] == 2) members.push_back(v);
  }
  for (const std::uint32_t v : members) root[v] = v;
  for (const SimplifyStep& s : made) root[s.from - first] = s.to - first;
  for (const std::uint32_t v : members) {
    std::uint32_t r = root[v];
    while (root[r] != r) r = root[r];
    root[v] = r;
  }
  return true;
}

// Simplifies a region so that it stays as closed and manifold as it was, and near the original
// surface. The simplifier's own tests should leave nothing to find; the check stays as a net.
// Where the result has an edge that the region did not (used more than twice, wound twice the same
// way, or a border edge that was not one), a pinched vertex or a triangle beyond the bound, the
// original triangles within a few rings of it are frozen: left out of the next try, so that their
// outline becomes a locked border, and kept as they are. After a few tries the region is kept
// whole.
//
// A label complex has edges used three or more times (where three or more labels meet, which the
// simplifier leaves in place: their ends are no closed fans): the result must have each of them as
// it was, and no other. The vertices in `lock` stay too (their first ring frozen, as a border's).
DecimationSink::Faces DecimationSink::simplify(const Faces& faces, std::int64_t originalTriangles, ChunkRange originals,
                                               const Lock& lock, Scope& scope) const {
  if (faces.empty()) return faces;
  const Timed call(scope.seconds.calls);
  const ScratchVector<Triangle>& triangles = faces.triangles;
  std::optional<Timed> checking(std::in_place, scope.seconds.checks);
  const Shape before = shapeOf(triangles);
  checking.reset();
  // A label complex's vertices on lines where three labels meet, and its other odd edges.
  ScratchVector<VertexId> lineVertices;
  std::size_t otherOdd = 0;
  for (const auto& [key, e] : before.odd) {
    if (e.uses != 3) {
      ++otherOdd;
      continue;
    }
    lineVertices.push_back(static_cast<VertexId>(key >> 32));
    lineVertices.push_back(static_cast<VertexId>(key & 0xffffffffu));
  }
  std::sort(lineVertices.begin(), lineVertices.end());
  lineVertices.erase(std::unique(lineVertices.begin(), lineVertices.end()), lineVertices.end());
  // A block keeps a little more than the ratio: its halves are simplified again in the regions
  // across its seams, which bring them to the ratio. A half that is already below its region's
  // share stays so (nothing can add triangles back), and the whole would fall short of the ratio.
  const double keep = scope.block ? std::min(1.0, kBlockSlack * options_.ratio) : options_.ratio;
  const std::size_t target =
      options_.ratio < 1 ? static_cast<std::size_t>(std::llround(keep * static_cast<double>(originalTriangles))) : 0;
  // The border vertices, which a neighbouring block or region may share. An edge between two of
  // them that the region did not have would be a chord that the neighbour may make too, from its
  // side: four triangles on one edge. So the triangles around them stay as they are (the next pass,
  // across this border, simplifies them), and then no collapse can reach them. A rim of an open
  // surface on a volume face cannot be told from a seam that runs along a cap (both lie in a face),
  // so rims keep their first ring too.
  const auto onBorder = [&](VertexId v) { return before.onBorder(v); };
  // Fans per vertex (core/fans.h), ids relative to `first`: a collapse must not pinch two sheets
  // together at a vertex.
  // Per-vertex arrays span the region's ids only (not the sink's whole window).
  // Plain variables, not a structured binding: the lambdas below capture `first` (clang 14 cannot).
  const std::pair<VertexId, VertexId> range = idRange(triangles);
  const VertexId first = range.first, last = range.second;
  const std::size_t span = static_cast<std::size_t>(last - first) + 1;
  // The fans that the region had, of the vertices that the result gives several (found as needed,
  // and kept for the next try): most vertices have one, and the region is many times the result.
  std::vector<std::pair<VertexId, std::uint32_t>> fansBefore;  // (vertex, fans), sorted
  // The triangles around each vertex (ids relative to `first`), to grow frozen patches by rings.
  ScratchVector<std::uint32_t> aroundFirst, around;
  ScratchVector<bool> frozen(triangles.size(), false);
  std::size_t frozenCount = 0;
  const auto stays = [&](VertexId v) { return onBorder(v) || (complex_ && lock.has(v)); };
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Triangle& tri = triangles[t];
    if (stays(tri[0]) || stays(tri[1]) || stays(tri[2])) {
      frozen[t] = true;
      ++frozenCount;
    }
  }
  const std::size_t sharedRing = frozenCount;
  // The largest distance allowed from the original surface, in output units.
  const double limit = options_.maxDistance * options_.voxelSize;
  LazyScratchVector<SimplifyStep> log;
  CrossingCache crossingCache;
  // For the repairs (repairNear; empty where they replay the whole region) and the triangles
  // frozen since the last try.
  Repairs repairs;
  ScratchVector<std::uint32_t> fresh;
  // Each vertex's vertex after the collapses of `steps` (ids relative to `first`).
  const auto rootsAfter = [&](std::span<const SimplifyStep> steps) {
    ScratchVector<std::uint32_t> root(span);
    for (std::uint32_t v = 0; v < span; ++v) root[v] = v;
    for (const SimplifyStep& s : steps) {
      if (!s.isPass()) root[s.from - first] = s.to - first;
    }
    // A collapse's `to` may move later: each vertex follows its chain to the end.
    for (std::uint32_t v = 0; v < span; ++v) {
      std::uint32_t r = root[v];
      while (root[r] != r) r = root[r];
      root[v] = r;
    }
    return root;
  };
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    const Originals* original = limit > 0 ? &surfaceFor(originals, scope) : nullptr;
    Faces simplified, result;
    ScratchVector<std::uint8_t> unchecked;
    std::optional<Timed> collapsing(std::in_place, scope.seconds.simplifier);
    if (repairs.root.empty() ||
        !repairNear(faces, frozen, fresh, repairs, first, log, original, simplified, unchecked)) {
      // The frozen triangles that go in too, as context (frozenContext).
      ScratchVector<std::uint8_t> inContext(frozenCount > 0 ? triangles.size() : 0, 0);
      const std::size_t contextCount = frozenCount > 0 ? frozenContext(triangles, frozen, first, span, inContext) : 0;
      // Every array at its size (growing one would copy it and leave slack).
      Faces input;
      const std::size_t inputSize = triangles.size() - frozenCount + contextCount;
      input.triangles.reserve(inputSize);
      input.labels.reserve(faces.labels.empty() ? 0 : inputSize);
      for (std::size_t t = 0; t < triangles.size(); ++t) {
        if (!frozen[t]) input.add(faces, t);
      }
      ScratchVector<Triangle> context;
      context.reserve(contextCount);
      for (std::size_t t = 0; t < triangles.size() && contextCount > 0; ++t) {
        if (inContext[t] == 0) continue;
        context.push_back(triangles[t]);
        input.triangles.push_back(triangles[t]);  // not input.add: one call site keeps that inlined
        if (!faces.labels.empty()) input.labels.push_back(faces.labels[t]);
      }
      // Frozen triangles count towards the target: the rest is simplified a little further.
      const std::size_t share = target > frozenCount ? target - frozenCount : 0;
      // The context's corners stay. In a label complex, so does every vertex with a frozen
      // triangle: its triangles in the input can look like a closed fan where three labels meet (a
      // scalar surface shows it a border edge).
      ScratchVector<VertexId> pinned;
      if (complex_) {
        for (std::size_t t = 0; t < triangles.size(); ++t) {
          if (frozen[t]) pinned.insert(pinned.end(), triangles[t].begin(), triangles[t].end());
        }
      } else {
        for (const Triangle& t : context) pinned.insert(pinned.end(), t.begin(), t.end());
      }
      std::sort(pinned.begin(), pinned.end());
      pinned.erase(std::unique(pinned.begin(), pinned.end()), pinned.end());
      // The first try's collapses, replayed by each repair: the frozen patch changes only what it
      // reaches, so the rest is made as before without choosing it again.
      Steps steps;
      LazyScratchVector<SimplifyStep> remade;
      if (attempt == 0) {
        steps.record = &log;
      } else {
        steps.replay = log;
        // repairNear's next try starts from this one.
        if (!repairs.root.empty()) steps.record = &remade;
      }
      simplified = collapse(std::move(input), share, contextCount, original, pinned, steps, unchecked);
      if (!context.empty()) {
        // The context came back as it went in (no corner of it moves): each kept triangle that is
        // one of its triangles, corner for corner, is taken out, with its flag (a surface has no
        // triangle twice).
        std::sort(context.begin(), context.end());
        std::size_t kept = 0;
        for (std::size_t t = 0; t < simplified.size(); ++t) {
          if (std::binary_search(context.begin(), context.end(), simplified.triangles[t])) continue;
          simplified.triangles[kept] = simplified.triangles[t];
          if (!simplified.labels.empty()) simplified.labels[kept] = simplified.labels[t];
          unchecked[kept] = unchecked[t];
          ++kept;
        }
        simplified.triangles.resize(kept);
        if (!simplified.labels.empty()) simplified.labels.resize(kept);
        unchecked.resize(kept);
      }
      if (attempt > 0 && !repairs.root.empty()) repairs.root = rootsAfter(remade);
    }
    collapsing.reset();
    result.triangles.reserve(frozenCount + simplified.size());
    result.labels.reserve(faces.labels.empty() ? 0 : frozenCount + simplified.size());
    for (std::size_t t = 0; t < triangles.size(); ++t) {
      if (frozen[t]) result.add(faces, t);
    }
    result.append(simplified);
    const ScratchVector<Triangle>& out = result.triangles;
    // The result's fans; a vertex whose triangles are one closed fan wound one way has each of its
    // edges in two triangles, once each way (core/fans.h), so only the edges between two other
    // vertices are tallied: those of the triangles that have such an edge (every triangle on such
    // an edge is one of them).
    ScratchVector<std::uint8_t> closed;
    checking.emplace(scope.seconds.checks);
    const ScratchVector<std::uint32_t> fansAfter = fanCounts(out, span, first, &closed);
    const auto open = [&](VertexId v) { return closed[v - first] == 0; };
    ScratchVector<Triangle> openTriangles;
    {
      const auto hasOpenEdge = [&](const Triangle& t) {
        const bool a = open(t[0]), b = open(t[1]), c = open(t[2]);
        return (a && b) || (b && c) || (c && a);
      };
      openTriangles.reserve(static_cast<std::size_t>(std::count_if(out.begin(), out.end(), hasOpenEdge)));
      for (const Triangle& t : out) {
        if (hasOpenEdge(t)) openTriangles.push_back(t);
      }
    }
    // The edges the result should not have; a label complex's odd edges as they were.
    ScratchVector<VertexId> bad;
    std::size_t border = 0, oddKept = 0;
    for (const auto& [key, e] : tallyEdges(openTriangles)) {
      const auto a = static_cast<VertexId>(key >> 32);
      const auto b = static_cast<VertexId>(key & 0xffffffffu);
      if (!open(a) || !open(b)) continue;  // not every triangle on it was tallied
      border += e.uses == 1 ? 1 : 0;
      bool odd = e.uses > 2 || (e.uses == 2 && e.forward != 1);
      if (odd && complex_) {
        // Lines where three labels meet are simplified along themselves: a line's edge joins two
        // vertices that were on such lines. Every other odd edge stays as it was.
        const auto it = std::lower_bound(before.odd.begin(), before.odd.end(), key,
                                         [](const auto& entry, std::uint64_t k) { return entry.first < k; });
        if (it != before.odd.end() && it->first == key && it->second.uses == e.uses &&
            it->second.forward == e.forward) {
          odd = false;
          oddKept += e.uses != 3 ? 1 : 0;
        } else if (e.uses == 3 && std::binary_search(lineVertices.begin(), lineVertices.end(), a) &&
                   std::binary_search(lineVertices.begin(), lineVertices.end(), b)) {
          odd = false;
        }
      }
      const bool wrong = odd || (e.uses == 1 && !std::binary_search(before.border.begin(), before.border.end(), key)) ||
                         (onBorder(a) && onBorder(b) &&
                          !std::binary_search(before.amongBorder.begin(), before.amongBorder.end(), key));
      if (wrong) {
        bad.push_back(static_cast<VertexId>(key >> 32));
        bad.push_back(static_cast<VertexId>(key & 0xffffffffu));
      }
    }
    // Pinched vertices: more fans than before, and more than one.
    {
      ScratchVector<VertexId> several, unknown;
      for (std::size_t v = 0; v < fansAfter.size(); ++v) {
        if (fansAfter[v] < 2) continue;
        const VertexId id = first + static_cast<VertexId>(v);
        several.push_back(id);
        const auto it =
            std::lower_bound(fansBefore.begin(), fansBefore.end(), std::pair<VertexId, std::uint32_t>{id, 0});
        if (it == fansBefore.end() || it->first != id) unknown.push_back(id);
      }
      if (!unknown.empty()) {
        const std::vector<std::uint32_t> counts = fanCountsAt(triangles, unknown);
        for (std::size_t i = 0; i < unknown.size(); ++i) fansBefore.emplace_back(unknown[i], counts[i]);
        std::sort(fansBefore.begin(), fansBefore.end());
      }
      for (const VertexId id : several) {
        const auto it =
            std::lower_bound(fansBefore.begin(), fansBefore.end(), std::pair<VertexId, std::uint32_t>{id, 0});
        if (fansAfter[id - first] > std::max(1u, it->second)) bad.push_back(id);
      }
    }
    // Triangles that moved the surface too far, against the grids of the original triangles. Only
    // those that a collapse changed unchecked: the others are unchanged (an original triangle in a
    // block; in a region, a block's triangle that its own check passed) or were measured as the
    // collapses made them. On a surface (not a label complex, whose lines have three triangles an
    // edge), each edge is run once each way, so an edge's midpoint is measured only where it runs
    // from the smaller id: its other triangle measures it there if that one changed unchecked, and
    // is within the bound whole if not. A result that is no such surface has bad edges already.
    const std::size_t misshapen = bad.size();
    if (original != nullptr) {
      Hint hint = kNoHint;
      for (std::size_t t = 0; t < simplified.size(); ++t) {
        const Triangle& tri = simplified.triangles[t];
        if (unchecked[t] != 0 && !triangleWithin(tri, *original, limit, hint, !complex_))
          bad.insert(bad.end(), tri.begin(), tri.end());
      }
    }
    // A label complex's sheets lie close together (a label one voxel thick): a collapse within the
    // bound can push one through another.
    const std::size_t beyond = bad.size() - misshapen;
    checking.reset();
    if (complex_) {
      const Timed searching(scope.seconds.crossing);
      const ScratchVector<VertexId> crossing = crossingVertices(out, result.labels, crossingCache);
      bad.insert(bad.end(), crossing.begin(), crossing.end());
      scope.crossing += crossing.empty() ? 0 : 1;
    }
    const bool shaped = complex_ ? oddKept == otherOdd : before.odd.empty();
    ++scope.attempts;
    scope.brokenShape += misshapen > 0 || border != before.border.size() || !shaped ? 1 : 0;
    scope.beyondBound += beyond > 0 ? 1 : 0;
    if (bad.empty() && border == before.border.size() && shaped) {
      if (attempt > 0) ++scope.repairedRegions;
      scope.frozenTriangles += frozenCount - sharedRing;
      return result;
    }
    if (!complex_ && !before.odd.empty()) break;  // not a surface to start with
    if (aroundFirst.empty()) {
      aroundFirst.assign(span + 1, 0);
      for (const Triangle& t : triangles) {
        for (VertexId v : t) ++aroundFirst[v - first + 1];
      }
      for (std::size_t v = 0; v < span; ++v) aroundFirst[v + 1] += aroundFirst[v];
      around.resize(aroundFirst.back());
      ScratchVector<std::uint32_t> fill(aroundFirst.begin(), aroundFirst.end() - 1);
      for (std::size_t t = 0; t < triangles.size(); ++t) {
        for (VertexId v : triangles[t]) around[fill[v - first]++] = static_cast<std::uint32_t>(t);
      }
    }
    // A border edge that went missing leaves no bad vertex to freeze around: keep the region whole.
    if (bad.empty()) break;
    // Freeze the original triangles within 1 + attempt / 2 rings of the bad vertices.
    fresh.clear();
    ScratchVector<VertexId> ring = bad;
    for (int step = 0; step < 1 + attempt / 2; ++step) {
      ScratchVector<VertexId> next;
      std::size_t corners = 0;
      for (VertexId v : ring) corners += 3 * (aroundFirst[v - first + 1] - aroundFirst[v - first]);
      next.reserve(corners);
      for (VertexId v : ring) {
        for (std::uint32_t i = aroundFirst[v - first]; i < aroundFirst[v - first + 1]; ++i) {
          const std::uint32_t t = around[i];
          if (!frozen[t]) {
            frozen[t] = true;
            ++frozenCount;
            fresh.push_back(t);
          }
          next.insert(next.end(), triangles[t].begin(), triangles[t].end());
        }
      }
      std::sort(next.begin(), next.end());
      next.erase(std::unique(next.begin(), next.end()), next.end());
      ring = std::move(next);
    }
    // The next try starts from this one's result, near the bad spots only, where the first try
    // made collapses to replay.
    if (attempt == 0 && !log.empty() && options_.localRepairs) {
      repairs.root = rootsAfter(log);
      repairs.firstRoot = repairs.root;
    }
    if (!repairs.root.empty()) repairs.previous = std::move(simplified);
  }
  ++scope.keptRegions;
  return faces;
}

// The chunks whose original triangles a region is measured against: those that use the vertices of
// its triangles, and one more on either side. The same for the checks and for the report, whatever
// the collapses left.
DecimationSink::ChunkRange DecimationSink::rangeAround(std::span<const Triangle> triangles, std::size_t firstChunk,
                                                       std::size_t end) const {
  if (triangles.empty()) return {firstChunk, firstChunk};
  VertexId lowest = triangles.front()[0], highest = lowest;
  for (const Triangle& t : triangles) {
    lowest = std::min(lowest, min3(t[0], t[1], t[2]));
    highest = std::max(highest, max3(t[0], t[1], t[2]));
  }
  const std::size_t first = chunkOfVertex(lowest);
  return {std::max(firstChunk, first > 0 ? first - 1 : 0), std::min(end, chunkOfVertex(highest) + 2)};
}

// A chunk's grid, for the checks: cells two voxels wide, or wider where the box would hold more than
// about two cells a triangle.
DecimationSink::OriginalSurface DecimationSink::originalSurface(std::size_t chunk) const {
  return gridOver(chunkTriangles_[chunk - chunkBase_], 2.0 * options_.voxelSize, 2.0);
}

// Original triangles (those on vertices from base_ on) in a dense grid over their bounding box, for
// distances to the original surface (the answers do not depend on the cell size, only the time). A
// counting sort with no search: the box (over the span of vertex ids that the triangles use, read
// in order), then each triangle's cells counted and noted, then the lists filled from the notes.
DecimationSink::OriginalSurface DecimationSink::gridOver(std::span<const Triangle> all, double firstCell,
                                                         double cellsPerTriangle) const {
  OriginalSurface surface;
  surface.sink = this;
  surface.triangles = all;
  std::size_t count = 0;
  VertexId lowest = kNone, highest = 0;
  for (const Triangle& t : all) {
    if (t[0] < base_ || t[1] < base_ || t[2] < base_) continue;
    ++count;
    lowest = std::min(lowest, min3(t[0], t[1], t[2]));
    highest = std::max(highest, max3(t[0], t[1], t[2]));
  }
  surface.count = count;
  if (count == 0) return surface;
  Vec3d low{INFINITY, INFINITY, INFINITY}, high{-INFINITY, -INFINITY, -INFINITY};
  for (VertexId v = lowest; v <= highest; ++v) {
    const Vec3d p = toDouble(position(v));
    for (std::size_t d = 0; d < 3; ++d) low[d] = std::min(low[d], p[d]), high[d] = std::max(high[d], p[d]);
  }
  surface.origin = low;
  surface.low = low;
  surface.high = high;
  surface.minVertex = lowest;
  surface.cell = firstCell;
  const double most = cellsPerTriangle * static_cast<double>(count) + 64.0;
  for (;;) {
    double cells = 1;
    for (std::size_t d = 0; d < 3; ++d) {
      surface.dims[d] = static_cast<std::int64_t>(std::floor((high[d] - low[d]) / surface.cell)) + 1;
      cells *= static_cast<double>(surface.dims[d]);
    }
    if (cells <= most) break;
    surface.cell *= 2;
  }
  surface.inverse = 1.0 / surface.cell;
  const auto cells = static_cast<std::size_t>(surface.dims[0] * surface.dims[1] * surface.dims[2]);
  // Each triangle's cells, from the bounding box of its corners.
  const auto cellsOf = [&](const Triangle& t, std::array<std::int64_t, 3>& first, std::array<std::int64_t, 3>& last) {
    const Vec3f &a = position(t[0]), &b = position(t[1]), &c = position(t[2]);
    const std::array<std::array<double, 3>, 3> p{{{a.x, b.x, c.x}, {a.y, b.y, c.y}, {a.z, b.z, c.z}}};
    for (std::size_t d = 0; d < 3; ++d) {
      first[d] = std::clamp(surface.cellOf(min3(p[d][0], p[d][1], p[d][2]), d), std::int64_t{0}, surface.dims[d] - 1);
      last[d] = std::clamp(surface.cellOf(max3(p[d][0], p[d][1], p[d][2]), d), first[d], surface.dims[d] - 1);
    }
  };
  const auto forCells = [&](const std::array<std::int64_t, 3>& first, const std::array<std::int64_t, 3>& last,
                            auto&& visit) {
    for (std::int64_t z = first[2]; z <= last[2]; ++z)
      for (std::int64_t y = first[1]; y <= last[1]; ++y)
        for (std::int64_t x = first[0]; x <= last[0]; ++x) visit(static_cast<std::size_t>(surface.index(x, y, z)));
  };
  // Per triangle, its first cell and how many more it spans along each axis (kWide: 256 or more
  // along some axis, found again from its corners).
  constexpr std::uint8_t kWide = 255;
  struct Note {
    std::uint32_t triangle = 0;  // its place in `all`
    std::uint32_t cell = 0;
    std::array<std::uint8_t, 3> more{};
  };
  ScratchVector<Note> notes(count);
  // Counts at [cell + 1], summed into starts.
  surface.cellStart.assign(cells + 1, 0);
  std::size_t entries = 0, k = 0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const Triangle& t = all[i];
    if (t[0] < base_ || t[1] < base_ || t[2] < base_) continue;
    std::array<std::int64_t, 3> first{}, last{};
    cellsOf(t, first, last);
    Note& note = notes[k++];
    note.triangle = static_cast<std::uint32_t>(i);
    note.cell = static_cast<std::uint32_t>(surface.index(first[0], first[1], first[2]));
    for (std::size_t d = 0; d < 3; ++d) {
      note.more[d] = static_cast<std::uint8_t>(std::min<std::int64_t>(last[d] - first[d], kWide));
    }
    forCells(first, last, [&](std::size_t cell) {
      ++surface.cellStart[cell + 1];
      ++entries;
    });
  }
  for (std::size_t i = 0; i < cells; ++i) surface.cellStart[i + 1] += surface.cellStart[i];
  // The lists, filled by advancing each cell's start, which leaves start[cell] at the next cell's
  // start: shifted back by one place at the end.
  surface.cellTriangles.resize(entries);
  const auto strideY = static_cast<std::size_t>(surface.dims[0]);
  const auto strideZ = static_cast<std::size_t>(surface.dims[0] * surface.dims[1]);
  for (std::size_t n = 0; n < count; ++n) {
    const Note& note = notes[n];
    const std::uint32_t index = note.triangle;
    if (note.more[0] == kWide || note.more[1] == kWide || note.more[2] == kWide) {
      std::array<std::int64_t, 3> first{}, last{};
      cellsOf(all[index], first, last);
      forCells(first, last, [&](std::size_t cell) { surface.cellTriangles[surface.cellStart[cell]++] = index; });
      continue;
    }
    for (std::size_t z = 0; z <= note.more[2]; ++z)
      for (std::size_t y = 0; y <= note.more[1]; ++y)
        for (std::size_t x = 0; x <= note.more[0]; ++x) {
          surface.cellTriangles[surface.cellStart[note.cell + x + y * strideY + z * strideZ]++] = index;
        }
  }
  for (std::size_t i = cells; i > 0; --i) surface.cellStart[i] = surface.cellStart[i - 1];
  surface.cellStart[0] = 0;
  return surface;
}

double DecimationSink::OriginalSurface::nearestInCell(std::int64_t x, std::int64_t y, std::int64_t z, const Vec3d& p,
                                                      double best, std::uint32_t& which) const {
  const std::int64_t i = index(x, y, z);
  if (i < 0 || cellStart[static_cast<std::size_t>(i)] == cellStart[static_cast<std::size_t>(i) + 1]) return best;
  // The triangle's box farther than the nearest so far: no point of it is nearer (boxBeyond, with
  // `best` raised by more than its rounding to a float).
  const std::array<float, 3> q{static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])};
  const auto largest = static_cast<float>(std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2]), 1.0}));
  float bound = static_cast<float>(best * (1 + 1e-5) + 1e-9 * cell * cell);
  float slack = 4 * std::numeric_limits<float>::epsilon() * (largest + std::sqrt(bound));
  for (std::uint32_t k = cellStart[static_cast<std::size_t>(i)]; k < cellStart[static_cast<std::size_t>(i) + 1]; ++k) {
    const Triangle& t = triangles[cellTriangles[k]];
    const Vec3f &a = sink->position(t[0]), &b = sink->position(t[1]), &c = sink->position(t[2]);
    if (boxBeyond(a, b, c, q, slack, bound)) continue;
    const double d = distanceSquared(p, toDouble(a), toDouble(b), toDouble(c));
    if (d < best) {
      best = d;
      which = cellTriangles[k];
      bound = static_cast<float>(best * (1 + 1e-5) + 1e-9 * cell * cell);
      slack = 4 * std::numeric_limits<float>::epsilon() * (largest + std::sqrt(bound));
    }
  }
  return best;
}

// A triangle nearer than `best` (the nearest in p's cell, or the one known) meets the ball of that
// radius around p, so it is listed in a cell that the ball's box meets; when p's cell is empty and
// none is known, the cells in growing rings around it, until no cell further out can hold a nearer
// one.
double DecimationSink::OriginalSurface::nearestSquared(const Vec3d& p, double best, std::uint32_t& which) const {
  if (count == 0) return 0;
  const std::int64_t cx = cellOf(p[0], 0), cy = cellOf(p[1], 1), cz = cellOf(p[2], 2);
  best = nearestInCell(cx, cy, cz, p, best, which);
  if (best < INFINITY) {
    // A nearer triangle's nearest point to p lies in a cell that lists it, no farther from p than
    // `best`: a cell farther is skipped.
    visitNear(p, {cx, cy, cz}, std::sqrt(best), best, [&](std::int64_t x, std::int64_t y, std::int64_t z) {
      best = nearestInCell(x, y, z, p, best, which);
      return false;
    });
    return best;
  }
  for (std::int64_t ring = 1;; ++ring) {
    for (std::int64_t z = cz - ring; z <= cz + ring; ++z) {
      for (std::int64_t y = cy - ring; y <= cy + ring; ++y) {
        for (std::int64_t x = cx - ring; x <= cx + ring; ++x) {
          if (std::max({std::abs(x - cx), std::abs(y - cy), std::abs(z - cz)}) != ring) continue;
          best = nearestInCell(x, y, z, p, best, which);
        }
      }
    }
    // Every triangle not yet seen lies outside the cube of cells searched: farther than p's
    // distance to that cube's faces.
    double reach = INFINITY;
    const std::int64_t centre[3] = {cx, cy, cz};
    for (std::size_t a = 0; a < 3; ++a) {
      const double below = p[a] - (origin[a] + static_cast<double>(centre[a] - ring) * cell);
      const double above = origin[a] + static_cast<double>(centre[a] + ring + 1) * cell - p[a];
      reach = std::min({reach, below, above});
    }
    if (best <= reach * reach || ring > 64) return best;
  }
}

std::array<DecimationSink::Vec3d, 3> DecimationSink::cornersOf(const Triangle& t) const {
  return {toDouble(position(t[0])), toDouble(position(t[1])), toDouble(position(t[2]))};
}

// The points where a decimated triangle is measured: its centroid and its edges' midpoints.
std::array<DecimationSink::Vec3d, 4> DecimationSink::samplePoints(const std::array<Vec3d, 3>& corners) {
  const auto& [a, b, c] = corners;
  return {{{(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3, (a[2] + b[2] + c[2]) / 3},
           {(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2},
           {(b[0] + c[0]) / 2, (b[1] + c[1]) / 2, (b[2] + c[2]) / 2},
           {(c[0] + a[0]) / 2, (c[1] + a[1]) / 2, (c[2] + a[2]) / 2}}};
}

// Whether p lies within `limit` of one of a triangle's corners. The corners are the input's
// vertices, each on an original triangle (the block's or region's own, which its grids list): the
// search would find one within the limit too. About a quarter of the brain's centroids at half a
// voxel, and over half of the atlas's samples at one voxel, end here without a search.
bool DecimationSink::nearCorner(const Vec3d& p, const std::array<Vec3d, 3>& corners, double limit) {
  const double limit2 = limit * limit;
  for (const Vec3d& c : corners) {
    const Vec3d d = sub(p, c);
    if (dot(d, d) <= limit2) return true;
  }
  return false;
}

// Whether some original triangle lies within `limit` of p: the hinted triangle, then the cells that
// the ball around p touches, p's own first, stopping at the first triangle near enough.
bool DecimationSink::OriginalSurface::within(const Vec3d& p, double limit, std::uint32_t& hint, Cells cells) const {
  if (count == 0) return true;
  const double limit2 = limit * limit;
  // The triangle's bounding box first, in floats: most triangles of a cell are farther than the
  // limit.
  const std::array<float, 3> q{static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])};
  const auto largest = static_cast<float>(std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2]), 1.0}));
  const float slack = 4 * std::numeric_limits<float>::epsilon() * (largest + static_cast<float>(limit));
  const auto limit2f = static_cast<float>(limit2);
  const auto near = [&](std::uint32_t k) {
    const Triangle& t = triangles[k];
    const Vec3f &a = sink->position(t[0]), &b = sink->position(t[1]), &c = sink->position(t[2]);
    if (boxBeyond(a, b, c, q, slack, limit2f)) return false;
    return distanceSquared(p, toDouble(a), toDouble(b), toDouble(c)) <= limit2;
  };
  if (cells != Cells::kAround && hint < triangles.size() && near(hint)) return true;
  const auto search = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    const std::int64_t i = index(x, y, z);
    if (i < 0) return false;
    for (std::uint32_t e = cellStart[static_cast<std::size_t>(i)]; e < cellStart[static_cast<std::size_t>(i) + 1];
         ++e) {
      if (near(cellTriangles[e])) {
        hint = cellTriangles[e];
        return true;
      }
    }
    return false;
  };
  const std::int64_t cx = cellOf(p[0], 0), cy = cellOf(p[1], 1), cz = cellOf(p[2], 2);
  if (cells != Cells::kAround && search(cx, cy, cz)) return true;
  // A triangle within the limit has a point within it in a cell that lists it: cells farther are
  // skipped.
  return cells != Cells::kOwn && visitNear(p, {cx, cy, cz}, limit, limit2, search);
}

// Whether some original triangle lies within `limit` of p: the hinted grid's hinted triangle, then
// each grid whose box is within `limit` of p.
bool DecimationSink::Originals::within(const Vec3d& p, double limit, Hint& hint) const {
  if (parts.empty()) return true;
  using Cells = OriginalSurface::Cells;
  // The hinted grid's hinted triangle and p's own cell first.
  std::size_t hinted = parts.size();
  std::uint32_t k = ~0u;
  if (hint != kNoHint) {
    const std::size_t part = hint >> 32;
    k = static_cast<std::uint32_t>(hint & 0xffffffffu);
    if (part < parts.size() && k < parts[part]->triangles.size()) {
      hinted = part;
      if (parts[part]->within(p, limit, k, Cells::kOwn)) {
        hint = static_cast<Hint>(part) << 32 | k;
        return true;
      }
    }
  }
  const double limit2 = limit * limit;
  const auto search = [&](std::size_t i, Cells cells) {
    std::uint32_t which = i == hinted ? k : ~0u;
    if (!parts[i]->within(p, limit, which, cells)) return false;
    hint = static_cast<Hint>(i) << 32 | which;
    return true;
  };
  // The other grids whose boxes begin below p + limit along the axis, from the last down, until
  // none before reaches p - limit; those whose boxes come within the limit, nearest first.
  const double from = p[axis] - limit, to = p[axis] + limit;
  const auto end = std::upper_bound(parts.begin(), parts.end(), to,
                                    [&](double x, const OriginalSurface* g) { return x < g->low[axis]; });
  std::array<std::pair<double, std::size_t>, 8> near{};
  std::size_t found = 0;
  for (auto i = static_cast<std::size_t>(end - parts.begin()); i-- > 0;) {
    if (reach[i] < from) break;
    const double gap = boxGapSquared(p, parts[i]->low, parts[i]->high);
    if (gap > limit2 || i == hinted) continue;
    if (found == near.size()) {
      // Many boxes about p (chunks that are not slabs across the axis): each in turn.
      if (search(i, Cells::kAll)) return true;
      continue;
    }
    near[found++] = {gap, i};
  }
  for (std::size_t n = 1; n < found; ++n) {  // a few: an insertion sort
    const auto x = near[n];
    std::size_t m = n;
    for (; m > 0 && x < near[m - 1]; --m) near[m] = near[m - 1];
    near[m] = x;
  }
  // Each grid's own cell before any grid's cells around it: a point near a slab's face most often
  // has its triangle in the next slab's grid, in its own cell there.
  for (std::size_t n = 0; n < found; ++n) {
    if (search(near[n].second, Cells::kOwn)) return true;
  }
  if (hinted < parts.size() && search(hinted, Cells::kAround)) return true;
  for (std::size_t n = 0; n < found; ++n) {
    if (search(near[n].second, Cells::kAround)) return true;
  }
  return false;
}

void DecimationSink::Originals::index() {
  std::array<double, 3> extent{};
  for (const OriginalSurface* g : parts) {
    for (std::size_t a = 0; a < 3; ++a) extent[a] += g->high[a] - g->low[a];
  }
  axis = static_cast<std::size_t>(std::min_element(extent.begin(), extent.end()) - extent.begin());
  std::stable_sort(parts.begin(), parts.end(),
                   [&](const OriginalSurface* a, const OriginalSurface* b) { return a->low[axis] < b->low[axis]; });
  reach.resize(parts.size());
  for (std::size_t i = 0; i < parts.size(); ++i) {
    reach[i] = i > 0 ? std::max(reach[i - 1], parts[i]->high[axis]) : parts[i]->high[axis];
  }
}

// The distance from p to the nearest original triangle: the grid nearest by its box first, then
// every grid whose box is nearer than the nearest triangle found.
double DecimationSink::Originals::distance(const Vec3d& p, Hint& hint) const {
  if (parts.empty()) return 0;
  // The hinted triangle's distance bounds the search.
  double best = INFINITY;  // squared
  if (hint != kNoHint) {
    const std::size_t part = hint >> 32;
    const auto k = static_cast<std::uint32_t>(hint & 0xffffffffu);
    if (part < parts.size() && parts[part]->listed(k)) {
      const Triangle& t = parts[part]->triangles[k];
      const DecimationSink& sink = *parts[part]->sink;
      // Not NaN (a triangle with two corners on one point can give it): the search ignores those.
      const double d = distanceSquared(p, toDouble(sink.position(t[0])), toDouble(sink.position(t[1])),
                                       toDouble(sink.position(t[2])));
      if (d < best) best = d;
    }
  }
  const auto search = [&](std::size_t i) {
    std::uint32_t which = ~0u;
    best = parts[i]->nearestSquared(p, best, which);
    if (which != ~0u) hint = static_cast<Hint>(i) << 32 | which;
  };
  // A first answer from the part nearest by its box among those about p along the axis.
  const auto byLow = [&](double x, const OriginalSurface* g) { return x < g->low[axis]; };
  const auto at =
      static_cast<std::size_t>(std::upper_bound(parts.begin(), parts.end(), p[axis], byLow) - parts.begin());
  std::size_t nearest = at > 0 ? at - 1 : 0;
  double nearestGap = INFINITY;
  for (std::size_t i = at > 3 ? at - 3 : 0; i < std::min(parts.size(), at + 3); ++i) {
    const double gap = boxGapSquared(p, parts[i]->low, parts[i]->high);
    if (gap < nearestGap) nearestGap = gap, nearest = i;
  }
  search(nearest);
  // Then every part whose box is nearer than that (with room for rounding): those that begin below
  // p + r along the axis (r: the distance so far), from the last down, until none before reaches
  // p - r.
  const double r = std::sqrt(best);
  const double from = p[axis] - r, to = p[axis] + r;
  const auto end = std::upper_bound(parts.begin(), parts.end(), to, byLow);
  for (auto i = static_cast<std::size_t>(end - parts.begin()); i-- > 0;) {
    if (reach[i] < from) break;
    const double slack = 1e-9 * parts[i]->cell * parts[i]->cell;
    if (i == nearest || boxGapSquared(p, parts[i]->low, parts[i]->high) > best * (1 + 1e-9) + slack) continue;
    search(i);
  }
  return std::sqrt(best);
}

// Whether every sample point of the triangle (centroid and edge midpoints) lies within `limit` of
// the original surface.
bool DecimationSink::triangleWithin(const Triangle& t, const Originals& surface, double limit, Hint& hint,
                                    bool forwardEdges) const {
  const std::array<Vec3d, 3> corners = cornersOf(t);
  const std::array<Vec3d, 4> samples = samplePoints(corners);
  for (std::size_t k = 0; k < 4; ++k) {
    // samples[k] (k from 1) is the midpoint of the edge from t[k - 1] to t[k % 3].
    if (forwardEdges && k > 0 && t[k - 1] > t[k % 3]) continue;
    if (!nearCorner(samples[k], corners, limit) && !surface.within(samples[k], limit, hint)) return false;
  }
  return true;
}

bool DecimationSink::Originals::holds(std::span<const VertexId> corners, const Vec3d& point, Hint& hint) const {
  // A listed triangle with every one of the corners.
  const auto same = [&](const OriginalSurface& g, std::uint32_t k) {
    const Triangle& o = g.triangles[k];
    for (const VertexId v : corners) {
      if (o[0] != v && o[1] != v && o[2] != v) return false;
    }
    return g.listed(k);
  };
  if (hint != kNoHint) {
    const std::size_t part = hint >> 32;
    const auto k = static_cast<std::uint32_t>(hint & 0xffffffffu);
    if (part < parts.size()) {
      const OriginalSurface& g = *parts[part];
      constexpr std::uint32_t kAhead = 4;
      for (std::uint32_t j = k + 1; j <= k + kAhead && j < g.triangles.size(); ++j) {
        if (same(g, j)) {
          hint = static_cast<Hint>(part) << 32 | j;
          return true;
        }
      }
    }
  }
  // The point lies in the box of such a triangle, so in its part's box, and the part's grid lists
  // it in the point's cell.
  const auto byLow = [&](double x, const OriginalSurface* g) { return x < g->low[axis]; };
  const auto end = std::upper_bound(parts.begin(), parts.end(), point[axis], byLow);
  for (auto i = static_cast<std::size_t>(end - parts.begin()); i-- > 0;) {
    if (reach[i] < point[axis]) break;
    const OriginalSurface& g = *parts[i];
    if (boxGapSquared(point, g.low, g.high) > 0) continue;
    // Clamped as the triangles' cells are: at the box's high end, cellOf can give one past the
    // last cell (the grid's size comes from a division, cellOf from a multiplication).
    const auto at = [&](std::size_t d) { return std::clamp(g.cellOf(point[d], d), std::int64_t{0}, g.dims[d] - 1); };
    const std::int64_t cell = g.index(at(0), at(1), at(2));
    if (cell < 0) continue;
    const auto c = static_cast<std::size_t>(cell);
    for (std::uint32_t e = g.cellStart[c]; e < g.cellStart[c + 1]; ++e) {
      if (same(g, g.cellTriangles[e])) {
        hint = static_cast<Hint>(i) << 32 | g.cellTriangles[e];
        return true;
      }
    }
  }
  return false;
}

// The one-sided distance from the final triangles to the original surface, for the report: at each
// triangle's centroid and edge midpoints. A triangle that decimation left as it was lies on the
// original surface, and so do its edges and every edge of an original triangle: their samples'
// distance is 0 (the search would find the triangle itself, up to rounding). An edge's midpoint is
// measured once for the triangles on both sides (within a batch of triangles in their order, which
// holds most of the pairs); the sum and the largest are taken in the triangles' order.
//
// The original triangles are in one grid of their own, not the chunks' grids of the checks: the
// chunks are slabs about a voxel thick, so that a point near a slab's face was searched for in two
// or three grids, each of p's cells there in full.
void DecimationSink::measure(std::span<const Triangle> triangles, ChunkRange originals) {
  if (triangles.empty()) return;
  const std::size_t firstChunk = std::max(chunkBase_, originals.first);
  const std::size_t endChunk = std::min(chunks_, originals.end);
  ScratchVector<Triangle> all;
  all.reserve(static_cast<std::size_t>(originalIn(firstChunk, endChunk)));
  for (std::size_t c = firstChunk; c < endChunk; ++c) {
    for (const Triangle& t : chunkTriangles_[c - chunkBase_]) {
      // As in surfaceFor: a range starts a chunk above its block's base, whose vertices the window holds.
      if (t[0] < base_ || t[1] < base_ || t[2] < base_) {
        throw std::logic_error("decimation: a measured range lacks triangles below the window");
      }
      all.push_back(t);
    }
  }
  const OriginalSurface grid = gridOver(all, options_.voxelSize, 4.0);
  Originals surface;
  if (grid.count > 0) surface.parts.push_back(&grid);
  surface.index();
  // The first search bounded too (every later one is, by the triangle that the last one found): by
  // an original triangle on the first triangle's first corner, or any listed one.
  Hint hint = kNoHint;
  if (grid.count > 0) {
    const std::array<VertexId, 1> corner{triangles.front()[0]};
    if (!surface.holds(corner, toDouble(position(corner[0])), hint)) hint = 0;
  }
  constexpr std::size_t kBatch = 8192;
  struct Use {
    VertexId a = 0, b = 0;    // the edge's corners, a < b
    std::uint32_t place = 0;  // 3 * (triangle in the batch) + edge
    bool held = false;        // on a triangle left as it was
  };
  std::vector<Use> uses;
  std::vector<double> centroid, midpoint;  // distances (0 for held ones)
  for (std::size_t from = 0; from < triangles.size(); from += kBatch) {
    const std::size_t n = std::min(kBatch, triangles.size() - from);
    uses.clear();
    centroid.assign(n, 0.0);
    midpoint.assign(3 * n, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      const Triangle& t = triangles[from + i];
      const Vec3d a = toDouble(position(t[0])), b = toDouble(position(t[1])), c = toDouble(position(t[2]));
      const Vec3d middle{(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3, (a[2] + b[2] + c[2]) / 3};
      const bool held = surface.holds(t, middle, hint);
      centroid[i] = held ? 0.0 : surface.distance(middle, hint);
      for (std::uint32_t k = 0; k < 3; ++k) {
        const VertexId u = t[k], v = t[(k + 1) % 3];
        uses.push_back({std::min(u, v), std::max(u, v), static_cast<std::uint32_t>(3 * i + k), held});
      }
    }
    std::sort(uses.begin(), uses.end(), [](const Use& x, const Use& y) {
      return x.a != y.a ? x.a < y.a : x.b != y.b ? x.b < y.b : x.held > y.held;
    });
    for (std::size_t e = 0; e < uses.size();) {
      std::size_t end = e + 1;
      while (end < uses.size() && uses[end].a == uses[e].a && uses[end].b == uses[e].b) ++end;
      double d = 0;  // held sorts first: the edge is an original triangle's
      if (!uses[e].held) {
        const Vec3d a = toDouble(position(uses[e].a)), b = toDouble(position(uses[e].b));
        const Vec3d middle{(a[0] + b[0]) / 2, (a[1] + b[1]) / 2, (a[2] + b[2]) / 2};
        const std::array<VertexId, 2> ends{uses[e].a, uses[e].b};
        if (!surface.holds(ends, middle, hint)) d = surface.distance(middle, hint);
      }
      for (; e < end; ++e) midpoint[uses[e].place] = d;
    }
    for (std::size_t i = 0; i < n; ++i) {
      for (const double d : {centroid[i], midpoint[3 * i], midpoint[3 * i + 1], midpoint[3 * i + 2]}) {
        report_.distanceMax = std::max(report_.distanceMax, d);
        distanceSum_ += d;
      }
      report_.samples += 4;
    }
  }
}

// Sends a final region on as one chunk: its vertices that no earlier chunk sent, in the order the
// triangles first use them.
void DecimationSink::emit(const Faces& faces, std::int64_t slab) {
  const ScratchVector<Triangle>& triangles = faces.triangles;
  out_.clear();
  out_.slab = slab;
  out_.firstVertex = nextId_;
  out_.triangles.reserve(triangles.size());
  for (const Triangle& t : triangles) {
    Triangle mapped{};
    for (std::size_t k = 0; k < 3; ++k) {
      VertexId& id = sent_[t[k] - base_];
      if (id == kNone) {
        id = nextId_++;
        out_.positions.push_back(position(t[k]));
        if (header_.normals) out_.normals.push_back(normals_[t[k] - base_]);
        out_.boundary.push_back(boundary_[t[k] - base_]);
      }
      mapped[k] = id;
    }
    out_.triangles.push_back(mapped);
  }
  out_.faceLabels.assign(faces.labels.begin(), faces.labels.end());
  report_.trianglesOut += out_.triangles.size();
  next_.consume(out_);
}

}  // namespace isoslab

namespace isoslab {

// Pairs of triangles in a grid over their bounding boxes (cells two voxels wide, or wider where
// there would be more than about two cells a triangle), each pair tested in the one cell that holds
// the low corner of their boxes' overlap: an edge of either through the other (for two triangles
// with a corner in common, a fold: the edge opposite it), or both on the same three points.
ScratchVector<VertexId> DecimationSink::crossingVertices(std::span<const Triangle> triangles,
                                                         std::span<const LabelPair> labels,
                                                         CrossingCache& cache) const {
  // The layers of a segmentation may overlap (core/volume_info.h): their surfaces may cross, and
  // only triangles of one layer are tested against each other. A triangle's layer is that of its
  // label (the background, 0, is every layer's).
  const auto layerOf = [&](std::uint32_t t) {
    return labels.empty() ? 0 : labelLayer(labels[t][0] != 0 ? labels[t][0] : labels[t][1]);
  };
  ScratchVector<VertexId> out;
  // The triangles of the last try that are here again (each once here and once there): a pair of
  // them is not tested again, and crosses if it crossed then.
  ScratchVector<std::uint8_t> known(triangles.size(), 0);
  std::vector<std::pair<Triangle, Triangle>> pairs;
  if (!cache.tested.empty()) {
    const TriangleCounts then(cache.tested), now(triangles);
    const auto once = [&](const Triangle& t) { return then.count(t) == 1 && now.count(t) == 1; };
    for (std::size_t t = 0; t < triangles.size(); ++t) known[t] = once(triangles[t]) ? 1 : 0;
    for (const auto& [s, t] : cache.pairs) {
      if (once(s) && once(t)) {
        out.insert(out.end(), s.begin(), s.end());
        out.insert(out.end(), t.begin(), t.end());
        pairs.emplace_back(s, t);
      }
    }
  }
  const auto keep = [&] {
    cache.tested.assign(triangles.begin(), triangles.end());
    cache.pairs = std::move(pairs);
    return std::move(out);
  };
  if (triangles.size() < 2) return keep();
  struct Box {
    Vec3d low, high;
  };
  // Each triangle's plane (its corners' cross product and that one's squared length) and its
  // longest edge squared, for the side tests below: made once here rather than for every pair.
  struct Plane {
    Vec3d normal;
    double normal2 = 0, size = 0;
  };
  ScratchVector<Box> boxes(triangles.size());
  ScratchVector<Plane> planes(triangles.size());
  Vec3d low{INFINITY, INFINITY, INFINITY}, high{-INFINITY, -INFINITY, -INFINITY};
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const std::array<Vec3d, 3> p{toDouble(position(triangles[t][0])), toDouble(position(triangles[t][1])),
                                 toDouble(position(triangles[t][2]))};
    Box& b = boxes[t];
    b.low = b.high = p[0];
    for (std::size_t k = 1; k < 3; ++k) {
      for (std::size_t d = 0; d < 3; ++d)
        b.low[d] = std::min(b.low[d], p[k][d]), b.high[d] = std::max(b.high[d], p[k][d]);
    }
    for (std::size_t d = 0; d < 3; ++d) low[d] = std::min(low[d], b.low[d]), high[d] = std::max(high[d], b.high[d]);
    Plane& plane = planes[t];
    plane.normal = cross(sub(p[1], p[0]), sub(p[2], p[0]));
    plane.normal2 = dot(plane.normal, plane.normal);
    for (std::size_t k = 0; k < 3; ++k) {
      const Vec3d e = sub(p[(k + 1) % 3], p[k]);
      plane.size = std::max(plane.size, dot(e, e));
    }
  }
  double cell = 2.0 * options_.voxelSize;
  std::array<std::int64_t, 3> dims{};
  for (;;) {
    double cells = 1;
    for (std::size_t d = 0; d < 3; ++d) {
      dims[d] = static_cast<std::int64_t>(std::floor((high[d] - low[d]) / cell)) + 1;
      cells *= static_cast<double>(dims[d]);
    }
    if (cells <= 2.0 * static_cast<double>(triangles.size()) + 4096.0) break;
    cell *= 2;
  }
  // By the inverse width (one function for every cell found below); x is within the box, so
  // truncating is flooring.
  const double inverse = 1.0 / cell;
  const auto cellOf = [&](double x, std::size_t d) {
    return std::clamp(static_cast<std::int64_t>((x - low[d]) * inverse), std::int64_t{0}, dims[d] - 1);
  };
  const auto indexOf = [&](std::int64_t x, std::int64_t y, std::int64_t z) {
    return static_cast<std::size_t>(x + dims[0] * (y + dims[1] * z));
  };
  // Each triangle's first and last cell along each axis. cellOf does not decrease, so the cell of
  // the larger of two lows is the larger of their cells.
  struct Span {
    // Each of dims is at most 2 n + 4096 (the cells' product is), n the triangles: under 2^31.
    std::array<std::int32_t, 3> first, last;
  };
  ScratchVector<Span> spans(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    for (std::size_t d = 0; d < 3; ++d) {
      spans[t].first[d] = static_cast<std::int32_t>(cellOf(boxes[t].low[d], d));
      spans[t].last[d] = static_cast<std::int32_t>(cellOf(boxes[t].high[d], d));
    }
  }
  const auto forCells = [&](const Span& c, auto&& visit) {
    for (std::int64_t z = c.first[2]; z <= c.last[2]; ++z)
      for (std::int64_t y = c.first[1]; y <= c.last[1]; ++y)
        for (std::int64_t x = c.first[0]; x <= c.last[0]; ++x) visit(indexOf(x, y, z));
  };
  ScratchVector<std::uint32_t> start(static_cast<std::size_t>(dims[0] * dims[1] * dims[2]) + 1, 0);
  for (const Span& c : spans) forCells(c, [&](std::size_t i) { ++start[i + 1]; });
  for (std::size_t i = 1; i < start.size(); ++i) start[i] += start[i - 1];
  ScratchVector<std::uint32_t> list(start.back()), fill(start.begin(), start.end() - 1);
  // Each cell lists its new triangles first: a pair is tested from its first triangle, which must
  // be new unless the last try had both.
  for (const int listed : {0, 1}) {
    for (std::uint32_t t = 0; t < boxes.size(); ++t) {
      if (known[t] == listed) forCells(spans[t], [&](std::size_t i) { list[fill[i]++] = t; });
    }
  }
  for (std::size_t i = 0; i + 1 < start.size(); ++i) {
    for (std::uint32_t m = start[i]; m < start[i + 1] && known[list[m]] == 0; ++m) {
      for (std::uint32_t n = m + 1; n < start[i + 1]; ++n) {
        const Triangle &s = triangles[list[m]], &t = triangles[list[n]];
        const Box &bs = boxes[list[m]], &bt = boxes[list[n]];
        bool apart = layerOf(list[m]) != layerOf(list[n]);
        for (std::size_t d = 0; d < 3; ++d) apart = apart || bs.low[d] > bt.high[d] || bt.low[d] > bs.high[d];
        // A pair is tested in one cell: that of the larger low corner of their boxes.
        const Span &cs = spans[list[m]], &ct = spans[list[n]];
        if (apart || indexOf(std::max(cs.first[0], ct.first[0]), std::max(cs.first[1], ct.first[1]),
                             std::max(cs.first[2], ct.first[2])) != i) {
          continue;
        }
        // Corners in common: none, every edge is tested; one, the edges opposite it (those from it
        // cannot pass through the other's inside); an edge, whether they are folded onto each
        // other (below).
        std::size_t shared = 0, sharedInS = 0, sharedInT = 0;
        for (std::size_t a = 0; a < 3; ++a) {
          for (std::size_t b = 0; b < 3; ++b) {
            if (s[a] == t[b]) ++shared, sharedInS = a, sharedInT = b;
          }
        }
        // Two triangles on the same three points (by id, or by position: the copies of a split
        // vertex lie on one point) press a label flat or fold a sheet onto itself.
        const std::array<Vec3f, 3> pf{position(s[0]), position(s[1]), position(s[2])};
        const std::array<Vec3f, 3> qf{position(t[0]), position(t[1]), position(t[2])};
        const auto among = [](const Vec3f& x, const std::array<Vec3f, 3>& set) {
          return x == set[0] || x == set[1] || x == set[2];
        };
        if (among(pf[0], qf) && among(pf[1], qf) && among(pf[2], qf) && among(qf[0], pf) && among(qf[1], pf) &&
            among(qf[2], pf)) {
          out.insert(out.end(), s.begin(), s.end());
          out.insert(out.end(), t.begin(), t.end());
          pairs.emplace_back(s, t);
          continue;
        }
        if (shared > 2) continue;
        const std::array<Vec3d, 3> p{toDouble(pf[0]), toDouble(pf[1]), toDouble(pf[2])};
        const std::array<Vec3d, 3> q{toDouble(qf[0]), toDouble(qf[1]), toDouble(qf[2])};
        const Plane &sPlane = planes[list[m]], &tPlane = planes[list[n]];
        if (shared == 2) {
          // Two triangles on an edge, folded onto each other: the other corner of one in the
          // other's plane, on the same side of the edge. Two sheets then lie on one another (a
          // label of one voxel pressed flat onto its neighbour's face, the two faces split along
          // different diagonals, so that no two triangles have the same three points).
          std::size_t x = 0, y = 0;  // the corners not shared
          while (s[x] == t[0] || s[x] == t[1] || s[x] == t[2]) ++x;
          while (t[y] == s[0] || t[y] == s[1] || t[y] == s[2]) ++y;
          const Vec3d& a = p[(x + 1) % 3];
          const Vec3d& b = p[(x + 2) % 3];
          const double tolerance = 1e-6 * std::sqrt(sPlane.normal2 * tPlane.size);
          const Vec3d edge = sub(b, a);
          if (std::abs(dot(sPlane.normal, sub(q[y], a))) <= tolerance &&
              dot(cross(edge, sub(p[x], a)), cross(edge, sub(q[y], a))) > 0) {
            out.insert(out.end(), s.begin(), s.end());
            out.insert(out.end(), t.begin(), t.end());
            pairs.emplace_back(s, t);
          }
          continue;
        }
        // Where the corners of one that it does not share lie strictly on one side of the other's
        // plane (by more than rounding), neither passes through the other: one's edges do not reach
        // the plane, and the other's edges lie in it, where the first has no point but a shared
        // corner. Most pairs in a cell end here.
        const auto oneSide = [](const std::array<Vec3d, 3>& x, const Triangle& xi, const Plane& xPlane,
                                const std::array<Vec3d, 3>& y, const Triangle& yi, const Plane& yPlane) {
          const Vec3d& normal = yPlane.normal;
          const double tolerance = 1e-6 * std::sqrt(yPlane.normal2 * xPlane.size);
          int above = 0, below = 0, free = 0;
          for (std::size_t k = 0; k < 3; ++k) {
            if (xi[k] == yi[0] || xi[k] == yi[1] || xi[k] == yi[2]) continue;
            ++free;
            const double d = dot(normal, sub(x[k], y[0]));
            above += d > tolerance ? 1 : 0;
            below += d < -tolerance ? 1 : 0;
          }
          return free > 0 && (above == free || below == free);
        };
        if (oneSide(p, s, sPlane, q, t, tPlane) || oneSide(q, t, tPlane, p, s, sPlane)) continue;
        bool hit = false;
        for (std::size_t k = 0; k < 3 && !hit; ++k) {
          const bool fromS = shared == 1 && (k == sharedInS || (k + 1) % 3 == sharedInS);
          const bool fromT = shared == 1 && (k == sharedInT || (k + 1) % 3 == sharedInT);
          hit = (!fromS && segmentCrosses(p[k], p[(k + 1) % 3], q[0], q[1], q[2])) ||
                (!fromT && segmentCrosses(q[k], q[(k + 1) % 3], p[0], p[1], p[2]));
        }
        if (hit) {
          out.insert(out.end(), s.begin(), s.end());
          out.insert(out.end(), t.begin(), t.end());
          pairs.emplace_back(s, t);
        }
      }
    }
  }
  return keep();
}

}  // namespace isoslab
