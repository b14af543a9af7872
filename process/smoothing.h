// Smoothing a streamed mesh: N iterations of a non-shrinking Laplacian filter, Taubin's lambda|mu
// or a windowed sinc as in VTK's vtkWindowedSincPolyDataFilter, run as a wavefront over the chunks.
//
// One iteration moves a vertex by the umbrella operator, the mean of its edge neighbours minus
// itself, taken over the previous iterate (Jacobi order). A vertex's position after i iterations
// therefore depends on its i-ring. Its neighbours lie in its own chunk and the ones on either side
// (core/mesh_sink.h: a triangle uses its own chunk's and the previous chunk's vertices), so
// iteration i of chunk z can run once chunk z + i has arrived: after chunk c arrives, chunk c - 1
// goes to iteration 1, c - 2 to 2, ..., and a chunk that has done all N leaves. The sink holds
// about N + 2 chunks; its result is the whole-mesh filter's, to rounding. Those steps form a chain
// (each reads the one before); with threads, the steps of chunks that are not side by side run at
// once instead, and the sink holds about 1.5N chunks.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/mesh_sink.h"
#include "core/thread_shares.h"

namespace isoslab {

enum class SmoothMethod { kTaubin, kSinc };

/// What happens to vertices on the volume's faces (the caps of --close-boundary and the rims of
/// open surfaces): they slide within their faces (along the edge where two faces meet; a corner
/// stays), or they stay where they are.
enum class FaceVertices { kSlide, kLock };

struct SmoothOptions {
  /// Laplacian iterations (0: off). For sinc, the polynomial's degree, as VTK's NumberOfIterations.
  int iterations = 0;
  SmoothMethod method = SmoothMethod::kSinc;
  /// The pass band k_PB in (0, 2): sinc's cut-off, and Taubin's 1/lambda + 1/mu = k_PB. VTK's default is 0.1;
  /// 0.08 brings every binary sphere of radius 10 to 50 under 1% area error at 20 iterations.
  double passBand = 0.08;
  /// Taubin's lambda (mu follows from the pass band).
  double lambda = 0.5;
  FaceVertices faces = FaceVertices::kSlide;
  /// Normals from the smoothed mesh (area-weighted face normals), or the field's as extracted.
  bool recomputeNormals = true;
  /// A label complex (MeshHeader::labels) only: how far a vertex may move from where it started
  /// (0: no limit). The label job gives half the smallest voxel edge, a ball inside the vertex's
  /// cell, so that no surface passes through another.
  double maxDisplacement = 0;
};

/// What the smoothing did to one label's surface (a label complex only).
struct LabelSmoothing {
  double largestDisplacement = 0;
  /// Vertices of the label's surface that maxDisplacement held back.
  std::int64_t heldBack = 0;
};

/// The pass band of label surfaces when none is given: at 20 iterations every label of the AAL
/// atlas with 1,000 voxels or more keeps its volume within 1% (0.08 loses up to 1.75%).
inline constexpr double kLabelPassBand = 0.3;

/// The fewest vertices of a round's steps that a thread takes: a share of a few thousand vertices
/// takes about as long as waking a thread (measured in docs/performance.md, "Stop 54").
inline constexpr std::size_t kSmoothMinShare = 2048;

/// The most iterations allowed: the sink holds about N + 2 chunks (1.5N with threads).
inline constexpr int kMaxSmoothIterations = 500;

/// Taubin's mu for a lambda and pass band: 1/lambda + 1/mu = k_PB.
double taubinMu(double lambda, double passBand);

/// The filter as a linear recurrence over iterates x^0 = x, x^1, ... x^N:
///   x^(n+1) = a[n] x^n + b[n] L(x^n) + c[n] x^(n-1)     (L: the umbrella operator)
/// and the output  sum_n w[n] x^n. Taubin: a = 1, b alternating lambda and mu, c = 0, w = (0..0, 1).
/// Sinc: Chebyshev polynomials of the windowed low-pass filter.
struct SmoothRecurrence {
  std::vector<double> a, b, c, w;
};
SmoothRecurrence smoothRecurrence(const SmoothOptions& options);

/// Checks the options; returns an error message naming the option, or empty when they are valid.
std::string checkSmoothOptions(const SmoothOptions& options);

class SmoothingSink final : public MeshSink {
 public:
  /// The steps of chunks that are not side by side run at once, their vertices shared among up to
  /// `threads` threads, at least `minShare` each; the output is the same for any count.
  SmoothingSink(MeshSink& next, const SmoothOptions& options, int threads = 1, std::size_t minShare = kSmoothMinShare);

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  /// The most chunks held at once.
  std::size_t peakChunks() const noexcept { return peakChunks_; }
  /// The most vertices held at once (in those chunks).
  std::size_t peakVertices() const noexcept { return peakVertices_; }
  /// A label complex: per label, after finish().
  const std::map<std::int32_t, LabelSmoothing>& labels() const noexcept { return labels_; }

 private:
  using Vec3d = std::array<double, 3>;
  struct Chunk {
    MeshChunk mesh;         // as it arrived, less its positions (the iterates start from them)
    std::size_t count = 0;  // vertices
    // The original positions of the vertices on the volume's faces (local index, position), which
    // their constraint needs.
    std::vector<std::pair<std::uint32_t, Vec3f>> origins;
    // A label complex: every vertex's original position, its volume-face bits (the complex lies
    // half a voxel beyond the faces, in the background's padding), and its kind (Kind).
    std::vector<Vec3f> starts;
    std::vector<std::uint8_t> faceBits;
    std::vector<std::uint8_t> kind;
    std::vector<std::uint8_t> held;  // the final position was held back by maxDisplacement
    VertexId end() const noexcept { return mesh.firstVertex + static_cast<VertexId>(count); }
    // The neighbour lists, once the next chunk has arrived: neighbours[offsets[v] .. offsets[v + 1]).
    std::vector<std::uint32_t> offsets;
    std::vector<VertexId> neighbours;
    bool linked = false;
    int level = 0;
    std::vector<Vec3d> current, previous, sum;
    std::vector<Vec3f> output;  // the final positions, once every iteration is done
    bool emitted = false;
  };

  Chunk* chunkOf(VertexId v);
  void link(std::size_t index);
  bool canAdvance(std::size_t index) const;
  // What one step of a chunk reads: the recurrence's coefficients, and the iterates of the chunk's
  // vertices [first, end) and of the chunks on either side.
  struct Step {
    double a = 0, b = 0, c = 0, w = 0;
    VertexId first = 0, end = 0, beforeFirst = 0;
    const Vec3d* own = nullptr;
    const Vec3d* before = nullptr;
    const Vec3d* after = nullptr;
    Vec3d* out = nullptr;  // the new iterate
  };
  Step stepOf(std::size_t index);
  void run(Chunk& chunk, const Step& step, std::size_t from, std::size_t to);
  bool sweep();
  void emitReady(bool finished);
  void emit(std::size_t index);
  void finalize(Chunk& chunk);
  const Vec3f& finalPosition(VertexId v);
  Vec3d constrain(const Chunk& chunk, std::size_t local, const Vec3d& p) const;
  Vec3d constrainLabel(const Chunk& chunk, std::size_t local, const Vec3d& p, bool* held) const;
  void classify(Chunk& chunk, const std::vector<std::uint32_t>& starts, const std::vector<VertexId>& all);
  void tallyLabels(const Chunk& chunk);

  MeshSink& next_;
  SmoothOptions options_;
  SmoothRecurrence recurrence_;
  MeshHeader header_;
  std::deque<Chunk> chunks_;
  bool finished_ = false;
  std::size_t peakChunks_ = 0;
  std::size_t peakVertices_ = 0;
  MeshChunk out_;
  // A round's chunks that step at once, and their steps (sweep()).
  std::vector<std::size_t> chosen_;
  std::vector<Step> steps_;
  std::map<std::int32_t, LabelSmoothing> labels_;
  std::size_t minShare_;
  std::unique_ptr<ThreadShares> threads_;  // none for one thread
};

}  // namespace isoslab
