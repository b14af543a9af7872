// Streamed Laplacian smoothing (see smoothing.h). Taubin's lambda|mu: G. Taubin, "A signal
// processing approach to fair surface design", SIGGRAPH 1995. The windowed sinc: G. Taubin,
// T. Zhang and G. Golub, "Optimal surface smoothing as filter design", ECCV 1996; its
// coefficients and recurrence as documented for VTK's vtkWindowedSincPolyDataFilter.
#include "process/smoothing.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include "core/error.h"

namespace isoslab {
namespace {

using Vec3d = std::array<double, 3>;

// With threads, the rounds of steps side by side after each chunk arrives (sweep()): one keeps
// about 2N chunks, each round stepping about N at once; two keep about 1.5N, each round stepping
// about N/2 (measured on the atlas at --smooth 20 and 2 threads: 0.82 of the chained steps' time, at
// the same peak; one round 0.78, at 6 MB more). docs/performance.md, "Stop 63".
constexpr int kThreadRounds = 2;

Vec3d toDouble(const Vec3f& p) {
  return {p.x, p.y, p.z};
}
Vec3f toFloat(const Vec3d& p) {
  return {static_cast<float>(p[0]), static_cast<float>(p[1]), static_cast<float>(p[2])};
}
double dot(const Vec3d& a, const Vec3d& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
// q, or where the segment from `start` to q leaves the ball of radius `limit` about start (and
// `held` set, when given).
Vec3d withinReach(const Vec3d& start, const Vec3d& q, double limit, bool* held) {
  const Vec3d d{q[0] - start[0], q[1] - start[1], q[2] - start[2]};
  const double length = std::sqrt(dot(d, d));
  if (!(length > limit)) return q;
  if (held != nullptr) *held = true;
  const double scale = limit / length;
  return {start[0] + d[0] * scale, start[1] + d[1] * scale, start[2] + d[2] * scale};
}

}  // namespace

double taubinMu(double lambda, double passBand) {
  return 1.0 / (passBand - 1.0 / lambda);
}

std::string checkSmoothOptions(const SmoothOptions& o) {
  if (o.iterations < 0 || o.iterations > kMaxSmoothIterations) {
    return "`smooth` (iterations) must be 0 to " + std::to_string(kMaxSmoothIterations) + ", not " +
           std::to_string(o.iterations);
  }
  if (!(o.passBand > 0 && o.passBand < 2)) return "`pass_band` must be above 0 and below 2";
  if (!(o.lambda > 0 && o.lambda < 1)) return "`lambda` must be above 0 and below 1";
  if (o.method == SmoothMethod::kTaubin && !(o.passBand < 1.0 / o.lambda)) {
    return "`pass_band` must be below 1 / `lambda` for Taubin smoothing";
  }
  return {};
}

SmoothRecurrence smoothRecurrence(const SmoothOptions& o) {
  const auto n = static_cast<std::size_t>(o.iterations);
  SmoothRecurrence r;
  r.a.assign(n, 1.0);
  r.b.assign(n, 0.0);
  r.c.assign(n, 0.0);
  r.w.assign(n + 1, 0.0);
  if (o.method == SmoothMethod::kTaubin) {
    const double mu = taubinMu(o.lambda, o.passBand);
    for (std::size_t i = 0; i < n; ++i) r.b[i] = i % 2 == 0 ? o.lambda : mu;
    r.w[n] = 1.0;
    return r;
  }
  // Chebyshev polynomials T_i(1 - k/2) of the operator I + L/2 (k: the Laplacian's eigenvalue):
  // x^1 = x + L(x)/2, x^(i+1) = 2 x^i + L(x^i) - x^(i-1).
  for (std::size_t i = 0; i < n; ++i) {
    r.a[i] = i == 0 ? 1.0 : 2.0;
    r.b[i] = i == 0 ? 0.5 : 1.0;
    r.c[i] = i == 0 ? 0.0 : -1.0;
  }
  // The low-pass filter's Chebyshev coefficients in the Hamming window, as VTK's
  // vtkWindowedSincPolyDataFilter (9.1) computes them: the pass band's angle theta is shifted by
  // sigma, found by Newton's method (VTK's slope and its 1e-3 tolerance), until the gain at the pass
  // band is 1. VTK leaves the gain at frequency 0 (where every T_i is 1) a little off 1 (0.9984 for
  // 20 iterations), which shrinks the mesh towards the coordinates' origin; isoslab divides by it,
  // so that its result is VTK's up to that factor, and independent of where the origin lies.
  const double pi = std::numbers::pi;
  const double y = 1.0 - 0.5 * o.passBand;
  const double theta = std::acos(y);
  std::vector<double> window(n + 1), slope(n + 1);
  for (std::size_t i = 0; i <= n; ++i) {
    window[i] = 0.54 + 0.46 * std::cos(static_cast<double>(i) * pi / static_cast<double>(n + 1));
  }
  const auto chebyshevAt = [&](std::size_t i) { return i == 1 ? y : std::cos(static_cast<double>(i) * theta); };
  double sigma = 0;
  for (int step = 0; step < 500; ++step) {
    r.w[0] = window[0] * (theta + sigma) / pi;
    for (std::size_t i = 1; i <= n; ++i) {
      const double di = static_cast<double>(i);
      r.w[i] = 2.0 * window[i] * std::sin(di * (theta + sigma)) / (di * pi);
    }
    if (n < 2) break;
    // The Chebyshev coefficients of the polynomial's derivative.
    slope[n] = slope[n - 1] = 0;
    slope[n - 2] = 2.0 * static_cast<double>(n - 1) * r.w[n - 1];
    for (std::size_t i = n - 2; i-- > 0;) slope[i] = slope[i + 2] + 2.0 * static_cast<double>(i + 1) * r.w[i + 1];
    double gain = r.w[0];
    double derivative = slope[0];
    for (std::size_t i = 1; i <= n; ++i) {
      gain += r.w[i] * chebyshevAt(i);
      derivative += slope[i] * chebyshevAt(i);
    }
    if (std::abs(gain - 1.0) < 1e-3) break;
    sigma -= (gain - 1.0) / derivative;
  }
  double total = 0;
  for (double w : r.w) total += w;
  for (double& w : r.w) w /= total;
  return r;
}

SmoothingSink::SmoothingSink(MeshSink& next, const SmoothOptions& options, int threads, std::size_t minShare)
    : next_(next),
      options_(options),
      recurrence_(smoothRecurrence(options)),
      minShare_(std::max<std::size_t>(1, minShare)) {
  if (const std::string e = checkSmoothOptions(options); !e.empty()) throw Error(e);
  if (threads > 1) threads_ = std::make_unique<ThreadShares>(threads);
}

void SmoothingSink::begin(const MeshHeader& header) {
  header_ = header;
  chunks_.clear();
  finished_ = false;
  peakChunks_ = 0;
  peakVertices_ = 0;
  labels_.clear();
  MeshHeader out = header;
  out.cellVolumes = false;  // the slabs' tetrahedron volumes were the unsmoothed surface's
  next_.begin(out);
}

SmoothingSink::Chunk* SmoothingSink::chunkOf(VertexId v) {
  // The chunks are contiguous in ids; v lies in one of the last few.
  for (auto it = chunks_.rbegin(); it != chunks_.rend(); ++it) {
    if (v >= it->mesh.firstVertex) return v < it->end() ? &*it : nullptr;
  }
  return nullptr;
}

void SmoothingSink::consume(const MeshChunk& chunk) {
  const VertexId expected = chunks_.empty() ? 0 : chunks_.back().end();
  if (!chunks_.empty() && chunk.firstVertex != expected) {
    throw Error("smoothing: the chunk's vertices do not continue the previous chunk's");
  }
  Chunk& c = chunks_.emplace_back();
  c.mesh.slab = chunk.slab;
  c.mesh.firstVertex = chunk.firstVertex;
  c.mesh.normals = chunk.normals;
  c.mesh.boundary = chunk.boundary;
  c.mesh.triangles = chunk.triangles;
  c.mesh.cellVolume = chunk.cellVolume;
  c.mesh.faceLabels = chunk.faceLabels;
  c.mesh.labelSplits = chunk.labelSplits;
  c.mesh.labelPinches = chunk.labelPinches;
  c.count = chunk.positions.size();
  if (header_.labels) {
    c.starts = chunk.positions;
    c.faceBits.assign(c.count, 0);
    // The faces of a label complex are its voxels' box: a vertex of a cell in the background's
    // padding lies on one, the others a voxel inside.
    if (header_.volumeFaces) {
      for (std::size_t v = 0; v < c.count; ++v) {
        const Vec3d p = toDouble(chunk.positions[v]);
        for (std::size_t f = 0; f < 6; ++f) {
          const FacePlane& plane = (*header_.volumeFaces)[f];
          const double tolerance =
              options_.maxDisplacement > 0 ? 0.5 * options_.maxDisplacement : 1e-6 * (1 + std::abs(plane[3]));
          if (plane[0] * p[0] + plane[1] * p[1] + plane[2] * p[2] - plane[3] > -tolerance) {
            c.faceBits[v] = static_cast<std::uint8_t>(c.faceBits[v] | (1u << f));
          }
        }
      }
    }
  }
  for (std::size_t v = 0; v < chunk.boundary.size(); ++v) {
    if (chunk.boundary[v] != 0) c.origins.emplace_back(static_cast<std::uint32_t>(v), chunk.positions[v]);
  }
  c.current.resize(chunk.positions.size());
  for (std::size_t v = 0; v < chunk.positions.size(); ++v) c.current[v] = toDouble(chunk.positions[v]);
  if (options_.method == SmoothMethod::kSinc) {
    c.sum.resize(c.current.size());
    for (std::size_t v = 0; v < c.current.size(); ++v) {
      for (std::size_t k = 0; k < 3; ++k) c.sum[v][k] = recurrence_.w[0] * c.current[v][k];
    }
  }
  // A triangle uses this chunk's vertices and the previous one's (whose neighbours are not yet
  // listed); its edges are read again when the lists are made.
  const Chunk* previous = chunks_.size() >= 2 ? &chunks_[chunks_.size() - 2] : nullptr;
  for (const Triangle& t : chunk.triangles) {
    for (VertexId v : t) {
      const bool here = v >= c.mesh.firstVertex && v < c.end();
      const bool before =
          previous != nullptr && !previous->linked && v >= previous->mesh.firstVertex && v < previous->end();
      if (!here && !before) throw Error("smoothing: a triangle uses a vertex outside this chunk and the previous one");
    }
  }
  // The chunk before this one has all its neighbours now.
  if (chunks_.size() >= 2) link(chunks_.size() - 2);
  peakChunks_ = std::max(peakChunks_, chunks_.size());
  std::size_t held = 0;
  for (const Chunk& k : chunks_) held += k.count;
  peakVertices_ = std::max(peakVertices_, held);
  // With threads, kThreadRounds rounds of steps side by side (sweep()); one round of the chain else.
  for (int round = 0; round < (threads_ ? kThreadRounds : 1) && sweep(); ++round) {
  }
  emitReady(false);
}

void SmoothingSink::finish() {
  if (!chunks_.empty()) link(chunks_.size() - 1);
  finished_ = true;
  while (sweep()) {
  }
  emitReady(true);
  chunks_.clear();
  next_.finish();
}

// Makes the chunk's neighbour lists, each neighbour once, from the edges of its triangles and of
// the next chunk's (the only ones that use its vertices). Each vertex's neighbours, once per
// triangle at the edge, are placed by counting (a vertex has a handful), then sorted in place.
void SmoothingSink::link(std::size_t index) {
  Chunk& chunk = chunks_[index];
  if (chunk.linked) return;
  const VertexId first = chunk.mesh.firstVertex;
  const VertexId end = chunk.end();
  const std::size_t n = chunk.count;
  const std::vector<Triangle>* next = index + 1 < chunks_.size() ? &chunks_[index + 1].mesh.triangles : nullptr;
  const auto eachEnd = [&](auto&& use) {
    const auto edges = [&](const std::vector<Triangle>& triangles) {
      for (const Triangle& t : triangles) {
        for (std::size_t k = 0; k < 3; ++k) {
          const VertexId a = t[k];
          const VertexId b = t[(k + 1) % 3];
          if (a == b) continue;
          if (a >= first && a < end) use(a - first, b);
          if (b >= first && b < end) use(b - first, a);
        }
      }
    };
    edges(chunk.mesh.triangles);
    if (next != nullptr) edges(*next);
  };
  std::vector<std::uint32_t> starts(n + 1, 0);
  eachEnd([&](VertexId local, VertexId) { ++starts[local + 1]; });
  for (std::size_t v = 0; v < n; ++v) starts[v + 1] += starts[v];
  std::vector<VertexId> all(starts[n]);
  {
    std::vector<std::uint32_t> fill(starts.begin(), starts.end() - 1);
    eachEnd([&](VertexId local, VertexId neighbour) { all[fill[local]++] = neighbour; });
  }
  for (std::size_t v = 0; v < n; ++v) std::sort(all.begin() + starts[v], all.begin() + starts[v + 1]);
  if (header_.labels) {
    classify(chunk, starts, all);
    chunk.linked = true;
    return;
  }
  chunk.offsets.assign(n + 1, 0);
  std::size_t kept = 0;
  for (std::size_t v = 0; v < n; ++v) {
    for (std::uint32_t i = starts[v]; i < starts[v + 1]; ++i) {
      if (i == starts[v] || all[i] != all[i - 1]) all[kept++] = all[i];
    }
    chunk.offsets[v + 1] = static_cast<std::uint32_t>(kept);
  }
  chunk.neighbours.assign(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(kept));
  chunk.linked = true;
}

namespace {

// The kinds of a label complex's vertices (vtkSurfaceNets3D smooths the same way): on one
// interface (a sheet), on a line where three or more regions meet (its edges of three or more
// triangles), or where such lines meet or end (fixed).
enum Kind : std::uint8_t { kSheet, kLine, kFixed };

// Keeps a move on the volume's faces that `bits` names: within the face, along the line where two
// meet; a corner stays.
Vec3d projectToFaces(std::uint8_t bits, const VolumeFaces& planes, const Vec3d& origin, const Vec3d& p) {
  const int faces = std::popcount(static_cast<unsigned>(bits));
  if (faces == 0) return p;
  if (faces >= 3) return origin;
  std::array<Vec3d, 2> normal{};
  std::size_t found = 0;
  for (std::size_t f = 0; f < 6 && found < 2; ++f) {
    if (bits & (1u << f)) normal[found++] = {planes[f][0], planes[f][1], planes[f][2]};
  }
  const Vec3d delta{p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]};
  if (faces == 1) {
    const double along = dot(delta, normal[0]);
    return {p[0] - along * normal[0][0], p[1] - along * normal[0][1], p[2] - along * normal[0][2]};
  }
  Vec3d t{normal[0][1] * normal[1][2] - normal[0][2] * normal[1][1],
          normal[0][2] * normal[1][0] - normal[0][0] * normal[1][2],
          normal[0][0] * normal[1][1] - normal[0][1] * normal[1][0]};
  const double length = std::sqrt(dot(t, t));
  if (length == 0) return origin;
  for (double& x : t) x /= length;
  const double along = dot(delta, t);
  return {origin[0] + along * t[0], origin[1] + along * t[1], origin[2] + along * t[2]};
}

}  // namespace

// A label complex's neighbour lists: `all[starts[v] .. starts[v + 1])` (sorted, once per triangle at
// an edge) tell how many triangles each edge has. A sheet vertex takes all its neighbours, a line
// vertex its two neighbours along the line, a fixed vertex none.
void SmoothingSink::classify(Chunk& chunk, const std::vector<std::uint32_t>& starts, const std::vector<VertexId>& all) {
  const std::size_t n = chunk.count;
  chunk.offsets.assign(n + 1, 0);
  chunk.kind.assign(n, kSheet);
  chunk.neighbours.clear();
  chunk.neighbours.reserve(all.size() / 2);
  std::vector<VertexId> each;
  std::vector<VertexId> line;
  for (std::size_t v = 0; v < n; ++v) {
    each.clear();
    line.clear();
    for (std::uint32_t i = starts[v]; i < starts[v + 1];) {
      std::uint32_t j = i;
      while (j < starts[v + 1] && all[j] == all[i]) ++j;
      each.push_back(all[i]);
      if (j - i >= 3) line.push_back(all[i]);
      i = j;
    }
    const std::vector<VertexId>* keep = &each;
    if (line.size() == 2) {
      chunk.kind[v] = kLine;
      keep = &line;
    } else if (!line.empty()) {
      chunk.kind[v] = kFixed;
      keep = nullptr;
    }
    if (keep != nullptr) chunk.neighbours.insert(chunk.neighbours.end(), keep->begin(), keep->end());
    chunk.offsets[v + 1] = static_cast<std::uint32_t>(chunk.neighbours.size());
  }
}

// A label complex's vertex: a fixed one stays; the others keep to the volume's faces they lie
// beyond, and within maxDisplacement of where they started (`held` says whether that held them).
SmoothingSink::Vec3d SmoothingSink::constrainLabel(const Chunk& chunk, std::size_t local, const Vec3d& p,
                                                   bool* held) const {
  const Vec3d start = toDouble(chunk.starts[local]);
  if (!chunk.kind.empty() && chunk.kind[local] == kFixed) return start;
  Vec3d q = p;
  if (chunk.faceBits[local] != 0 && header_.volumeFaces) {
    q = options_.faces == FaceVertices::kLock ? start
                                              : projectToFaces(chunk.faceBits[local], *header_.volumeFaces, start, q);
  }
  return options_.maxDisplacement > 0 ? withinReach(start, q, options_.maxDisplacement, held) : q;
}

// Per label, the largest move of its surface's vertices and how many were held back. A vertex's
// move counts for each label of a triangle that uses it; a held vertex once per label.
void SmoothingSink::tallyLabels(const Chunk& c) {
  std::vector<double> moved(c.count);
  for (std::size_t v = 0; v < c.count; ++v) {
    const Vec3d a = toDouble(c.output[v]);
    const Vec3d b = toDouble(c.starts[v]);
    const Vec3d d{a[0] - b[0], a[1] - b[1], a[2] - b[2]};
    moved[v] = std::sqrt(dot(d, d));
  }
  std::vector<std::pair<std::int32_t, std::uint32_t>> held;  // (label, local vertex)
  std::int32_t lastLabel = 0;
  LabelSmoothing* last = nullptr;
  for (std::size_t t = 0; t < c.mesh.triangles.size() && t < c.mesh.faceLabels.size(); ++t) {
    double largest = 0;
    bool here = false, anyHeld = false;
    for (const VertexId v : c.mesh.triangles[t]) {
      if (v < c.mesh.firstVertex || v >= c.end()) continue;
      largest = here ? std::max(largest, moved[v - c.mesh.firstVertex]) : moved[v - c.mesh.firstVertex];
      here = true;
      anyHeld = anyHeld || c.held[v - c.mesh.firstVertex] != 0;
    }
    if (!here) continue;  // no vertex of this chunk
    for (const std::int32_t label : c.mesh.faceLabels[t]) {
      if (label == 0) continue;
      if (last == nullptr || label != lastLabel) {
        last = &labels_[label];
        lastLabel = label;
      }
      last->largestDisplacement = std::max(last->largestDisplacement, largest);
      if (!anyHeld) continue;
      for (const VertexId v : c.mesh.triangles[t]) {
        if (v >= c.mesh.firstVertex && v < c.end() && c.held[v - c.mesh.firstVertex] != 0) {
          held.emplace_back(label, static_cast<std::uint32_t>(v - c.mesh.firstVertex));
        }
      }
    }
  }
  std::sort(held.begin(), held.end());
  held.erase(std::unique(held.begin(), held.end()), held.end());
  for (const auto& [label, v] : held) ++labels_[label].heldBack;
}

// Whether the chunk at `index` can go from iteration L to L + 1: its neighbour lists are complete,
// and the chunks on either side hold iterate L (as their current or previous one).
bool SmoothingSink::canAdvance(std::size_t index) const {
  const Chunk& c = chunks_[index];
  const int level = c.level;
  if (level >= options_.iterations || !c.linked) return false;
  const auto holds = [&](const Chunk& other) { return other.level == level || other.level == level + 1; };
  if (index + 1 < chunks_.size()) {
    if (!holds(chunks_[index + 1])) return false;
  } else if (!finished_) {
    return false;
  }
  return index == 0 || holds(chunks_[index - 1]);
}

// What the step of the chunk at `index` from its iterate L to L + 1 reads, and where it writes: over
// the chunk's iterate L - 1, which only the vertex's own step reads (the recurrence's third term),
// before it writes there (a neighbour that needs iterate L - 1 would keep the chunk from stepping).
SmoothingSink::Step SmoothingSink::stepOf(std::size_t index) {
  Chunk& c = chunks_[index];
  const auto level = static_cast<std::size_t>(c.level);
  // Iterate `level` of a vertex: current in a chunk at this level, previous in one a step ahead.
  // A vertex's neighbours lie in its chunk and the ones on either side.
  const auto iterateOf = [&](const Chunk& o) { return o.level == c.level ? o.current.data() : o.previous.data(); };
  Step step;
  step.a = recurrence_.a[level];
  step.b = recurrence_.b[level];
  step.c = recurrence_.c[level];
  step.first = c.mesh.firstVertex;
  step.end = c.end();
  step.own = c.current.data();
  if (index > 0) {
    step.before = iterateOf(chunks_[index - 1]);
    step.beforeFirst = chunks_[index - 1].mesh.firstVertex;
  }
  if (index + 1 < chunks_.size()) step.after = iterateOf(chunks_[index + 1]);
  if (options_.method == SmoothMethod::kSinc) step.w = recurrence_.w[level + 1];
  c.previous.resize(c.current.size());
  step.out = c.previous.data();
  return step;
}

// One step of the vertices [from, to) of a chunk into step.out (and the sinc's sum).
void SmoothingSink::run(Chunk& c, const Step& step, std::size_t from, std::size_t to) {
  const bool sum = options_.method == SmoothMethod::kSinc;
  const double limit = options_.maxDisplacement;
  const double limitSquared = limit * limit * (1 - 1e-12);
  for (std::size_t v = from; v < to; ++v) {
    const Vec3d& x = c.current[v];
    Vec3d lap{0, 0, 0};
    const std::uint32_t begin = c.offsets[v];
    const std::uint32_t end = c.offsets[v + 1];
    if (end > begin) {
      for (std::uint32_t k = begin; k < end; ++k) {
        const VertexId id = c.neighbours[k];
        const Vec3d& u = id < step.first ? step.before[id - step.beforeFirst]
                         : id < step.end ? step.own[id - step.first]
                                         : step.after[id - step.end];
        for (std::size_t d = 0; d < 3; ++d) lap[d] += u[d];
      }
      const double inv = 1.0 / static_cast<double>(end - begin);
      for (std::size_t d = 0; d < 3; ++d) lap[d] = lap[d] * inv - x[d];
    }
    Vec3d next;
    for (std::size_t d = 0; d < 3; ++d) {
      next[d] = step.a * x[d] + step.b * lap[d];
      if (step.c != 0) next[d] += step.c * c.previous[v][d];
    }
    // Most vertices lie inside the volume, and (a label complex's) well within their limit; one
    // beyond it (a staircase's corner, often) is drawn back here as constrainLabel would.
    bool free = false;
    if (!header_.labels) {
      free = c.mesh.boundary.empty() || c.mesh.boundary[v] == 0;
    } else if (c.faceBits[v] == 0 && (c.kind.empty() || c.kind[v] != kFixed)) {
      const Vec3d start = toDouble(c.starts[v]);
      const Vec3d d{next[0] - start[0], next[1] - start[1], next[2] - start[2]};
      if (limit > 0 && dot(d, d) > limitSquared) next = withinReach(start, next, limit, nullptr);
      free = true;
    }
    const Vec3d result = free ? next : constrain(c, v, next);
    step.out[v] = result;
    if (sum) {
      for (std::size_t d = 0; d < 3; ++d) c.sum[v][d] += step.w * result[d];
    }
  }
}

// One round. One thread: newest to oldest, each chunk that can step, so that each sees its
// successor's step of the round (a chain: the sink holds about N + 2 chunks). More threads: the
// chunks that can step now, no two side by side (a step reads its neighbours' iterates and writes
// only its own chunk's), all at once, their vertices shared among the threads (at least minShare_
// each). A round for each chunk that arrives then steps every other chunk, the sink holding about
// 2N chunks: about N steps a round at once, where the chain had one (kThreadRounds rounds: about
// N / kThreadRounds at once). The same iterates either way, so the same bytes for any count.
// Returns whether a chunk stepped.
bool SmoothingSink::sweep() {
  const auto finishStep = [](Chunk& c) {
    std::swap(c.previous, c.current);
    ++c.level;
  };
  if (!threads_) {
    bool stepped = false;
    for (std::size_t i = chunks_.size(); i-- > 0;) {
      if (!canAdvance(i)) continue;
      Chunk& c = chunks_[i];
      run(c, stepOf(i), 0, c.count);
      finishStep(c);
      stepped = true;
    }
    return stepped;
  }
  chosen_.clear();
  for (std::size_t i = chunks_.size(); i-- > 0;) {
    if ((chosen_.empty() || chosen_.back() > i + 1) && canAdvance(i)) chosen_.push_back(i);
  }
  if (chosen_.empty()) return false;
  steps_.clear();
  std::size_t total = 0;
  for (const std::size_t i : chosen_) {
    steps_.push_back(stepOf(i));
    total += chunks_[i].count;
  }
  // Share s takes the vertices [total * s / shares, total * (s + 1) / shares) of the chosen chunks
  // in turn.
  const std::size_t shares = std::clamp<std::size_t>(total / minShare_, 1, threads_->size());
  const auto share = [&](std::size_t s) {
    const std::size_t from = total * s / shares, to = total * (s + 1) / shares;
    std::size_t offset = 0;
    for (std::size_t j = 0; j < chosen_.size() && offset < to; ++j) {
      Chunk& c = chunks_[chosen_[j]];
      const std::size_t lo = std::max(from, offset), hi = std::min(to, offset + c.count);
      if (lo < hi) run(c, steps_[j], lo - offset, hi - offset);
      offset += c.count;
    }
  };
  if (shares == 1) {
    share(0);
  } else {
    threads_->run(shares, share);
  }
  for (const std::size_t i : chosen_) finishStep(chunks_[i]);
  return true;
}

// Keeps a vertex on the volume's faces that it lies on: projected into its face, onto the line
// where its two faces meet, or (a corner, a locked vertex, faces that are not planes) back where
// it was.
SmoothingSink::Vec3d SmoothingSink::constrain(const Chunk& chunk, std::size_t local, const Vec3d& p) const {
  if (header_.labels) return constrainLabel(chunk, local, p, nullptr);
  const std::uint8_t bits = chunk.mesh.boundary.empty() ? 0 : chunk.mesh.boundary[local];
  if (bits == 0) return p;
  const auto it = std::lower_bound(chunk.origins.begin(), chunk.origins.end(), static_cast<std::uint32_t>(local),
                                   [](const auto& o, std::uint32_t l) { return o.first < l; });
  const Vec3d origin = toDouble(it->second);
  if (options_.faces == FaceVertices::kLock || !header_.volumeFaces) return origin;
  return projectToFaces(bits, *header_.volumeFaces, origin, p);
}

// Sends on, in order, the chunks that have done every iteration and whose normals can be made:
// those need the next chunk's triangles at their final positions too.
void SmoothingSink::emitReady(bool finished) {
  const bool normals = header_.normals && options_.recomputeNormals;
  for (std::size_t i = 0; i < chunks_.size(); ++i) {
    Chunk& c = chunks_[i];
    if (c.emitted) continue;
    if (c.level < options_.iterations) break;
    if (normals) {
      const bool last = i + 1 == chunks_.size();
      if (last ? !finished : chunks_[i + 1].level < options_.iterations) break;
    }
    emit(i);
  }
  // An emitted chunk's iterates are needed until the next chunk has done every iteration.
  for (std::size_t i = 0; i < chunks_.size(); ++i) {
    Chunk& c = chunks_[i];
    if (!c.emitted) break;
    const bool nextDone = i + 1 < chunks_.size() ? chunks_[i + 1].level >= options_.iterations : finished;
    if (nextDone && !c.current.empty()) {
      c.current = {};
      c.previous = {};
      c.sum = {};
    }
  }
  // A chunk is needed until the one after it has left (for that one's iterates and normals).
  while (chunks_.size() >= 2 && chunks_[0].emitted && chunks_[1].emitted) chunks_.pop_front();
}

// The chunk's final positions (constrained once more: a sum of constrained iterates may leave its
// face by rounding).
void SmoothingSink::finalize(Chunk& c) {
  assert(c.level == options_.iterations);
  if (c.output.size() == c.count) return;
  const std::vector<Vec3d>& result = options_.method == SmoothMethod::kSinc ? c.sum : c.current;
  c.output.resize(result.size());
  if (header_.labels) {
    c.held.assign(result.size(), 0);
    for (std::size_t v = 0; v < result.size(); ++v) {
      bool held = false;
      c.output[v] = toFloat(constrainLabel(c, v, result[v], &held));
      c.held[v] = held ? 1 : 0;
    }
    return;
  }
  for (std::size_t v = 0; v < result.size(); ++v) c.output[v] = toFloat(constrain(c, v, result[v]));
}

const Vec3f& SmoothingSink::finalPosition(VertexId v) {
  const Chunk* c = chunkOf(v);
  return c->output[v - c->mesh.firstVertex];
}

void SmoothingSink::emit(std::size_t index) {
  Chunk& c = chunks_[index];
  finalize(c);
  out_.clear();
  out_.slab = c.mesh.slab;
  out_.firstVertex = c.mesh.firstVertex;
  out_.positions = c.output;
  out_.boundary = c.mesh.boundary;
  out_.triangles = c.mesh.triangles;
  out_.faceLabels = c.mesh.faceLabels;
  out_.labelSplits = c.mesh.labelSplits;
  out_.labelPinches = c.mesh.labelPinches;
  if (header_.labels) tallyLabels(c);
  if (header_.normals) {
    out_.normals = c.mesh.normals;
    if (options_.recomputeNormals) {
      // The next chunk has done every iteration too (emitReady waits for it).
      if (index + 1 < chunks_.size()) finalize(chunks_[index + 1]);
      // Area-weighted face normals of the triangles that use the chunk's vertices: its own, and the
      // next chunk's.
      std::vector<Vec3d> sum(c.output.size(), Vec3d{0, 0, 0});
      const auto add = [&](const std::vector<Triangle>& triangles) {
        for (const Triangle& t : triangles) {
          const Vec3d p0 = toDouble(finalPosition(t[0]));
          const Vec3d p1 = toDouble(finalPosition(t[1]));
          const Vec3d p2 = toDouble(finalPosition(t[2]));
          const Vec3d e1{p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
          const Vec3d e2{p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
          const Vec3d n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
          for (VertexId v : t) {
            if (v < c.mesh.firstVertex || v >= c.end()) continue;
            for (std::size_t d = 0; d < 3; ++d) sum[v - c.mesh.firstVertex][d] += n[d];
          }
        }
      };
      add(c.mesh.triangles);
      if (index + 1 < chunks_.size()) add(chunks_[index + 1].mesh.triangles);
      for (std::size_t v = 0; v < sum.size(); ++v) {
        const double length = std::sqrt(dot(sum[v], sum[v]));
        if (length > 0) out_.normals[v] = toFloat({sum[v][0] / length, sum[v][1] / length, sum[v][2] / length});
      }
    }
  }
  c.emitted = true;
  next_.consume(out_);
}

}  // namespace isoslab
