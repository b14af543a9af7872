// Extractors turn slabs of cells into triangles. One object per run; not thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/mesh_sink.h"
#include "core/volume_info.h"
#include "extract/frame.h"
#include "extract/slab_view.h"

namespace isoslab {

enum class Method : std::uint8_t { kMarchingCubes, kTetra5, kTetra6, kBcc12, kTetra24, kMarchingCubes33 };

/// Every method, in the order the command line and the comparisons list them.
inline constexpr Method kMethods[] = {Method::kMarchingCubes, Method::kTetra5,  Method::kTetra6,
                                      Method::kBcc12,         Method::kTetra24, Method::kMarchingCubes33};

/// A welding-cache slot on one slice plane, below Extractor::sliceSlots(): how a slab worker names
/// a vertex on a slice that another slab creates.
enum class CacheSlot : std::int64_t {};

/// A vertex id within one SlabPart, from 0.
enum class LocalVertex : VertexId {};

/// In a SlabPart's triangles, an id with this bit set is not a LocalVertex but a reference: the
/// vertex of slot foreign[id & ~kForeignVertex], which the slab below created.
constexpr VertexId kForeignVertex = VertexId{1} << 31;

/// What a slab worker (Extractor::makeWorker) makes of a run of consecutive slabs, before stitching
/// (SlabStitcher turns its ids into the global ids of the sequential extractor).
struct SlabPart {
  /// One chunk per slab of the run, in slab order; firstVertex is unset. Their triangles hold
  /// LocalVertex ids, numbered from 0 over the whole run in the order the vertices appear in the
  /// chunks' positions, or kForeignVertex references (only the first slab has those).
  std::vector<MeshChunk> chunks;
  /// The slots on the first slab's slice z that the triangles reference and the slab below owns.
  std::vector<CacheSlot> foreign;
  /// The last slab's vertices on its slice z + 1, for the slab above to reference.
  std::vector<std::pair<CacheSlot, LocalVertex>> top;
};

/// Extracts runs of slabs independently of each other, in any order; one per thread.
class SlabWorker {
 public:
  virtual ~SlabWorker() = default;
  /// Extracts `slabs`, which are consecutive (slabs[k].z = slabs[0].z + k) and not empty, into
  /// `out`, whose chunks it resizes to slabs.size() (keeping their buffers). Calls `before` (if
  /// set) with each slab just before extracting it, while its slices are about to be read anyway
  /// (the pipeline takes their value range there). Allocates; throws std::bad_alloc.
  virtual void extract(std::span<const SlabView> slabs, SlabPart& out,
                       const std::function<void(const SlabView&)>& before) = 0;
};

/// "mc", "mt5", "mt6", "bcc12", "mt24", "mc33".
std::string_view methodName(Method m) noexcept;
std::optional<Method> parseMethod(std::string_view name) noexcept;
/// The names of kMethods, in order.
std::vector<std::string> methodNames();

struct ExtractOptions {
  Method method = Method::kMarchingCubes;
  double iso = 0;
  bool normals = false;
  /// Tetrahedral methods: sum the volume inside the surface over the tetrahedra (the paper's
  /// per-cell volume, MeshChunk::cellVolume).
  bool cellVolumes = true;
  /// The field is outside beyond the volume's faces, so the surface is capped there and closed:
  /// the slices come padded with one NaN point on each side of every axis (io/pad_source.h), the
  /// extractor's lattice is info.dims + 2, and vertices where an edge leaves the volume lie exactly
  /// on its faces. Output coordinates stay those of the unpadded volume. No cellVolumes.
  bool closeBoundary = false;
};

class Extractor {
 public:
  virtual ~Extractor() = default;

  /// Slices the extractor needs beyond slices z and z+1 of slab z: below (z-1) and above (z+2),
  /// each 0 or 1.
  virtual int slicesBelow() const noexcept = 0;
  virtual int slicesAbove() const noexcept = 0;

  /// Extracts slab z (called for z = 0, 1, ..., dims[2]-2 in order) and appends its new vertices
  /// and its triangles to `out`, which the caller has cleared and given its firstVertex.
  /// Allocates; throws std::bad_alloc.
  virtual void extractSlab(const SlabView& slab, MeshChunk& out) = 0;

  /// Vertices emitted so far (may exceed what VertexId holds; the pipeline checks).
  virtual std::uint64_t vertexCount() const noexcept = 0;

  /// The row spans of one slice (ny of them), for SlabView::rows. Thread-safe; lets a pipeline
  /// classify each slice once for all the workers whose slabs use it.
  virtual void classifySlice(const float* slice, std::vector<RowSpan>& rows) const = 0;

  /// Whether chunks carry the tetrahedral inside volume (cellVolume).
  virtual bool cellVolumes() const noexcept = 0;

  /// A worker for parallel extraction. Stitching its parts in slab order (SlabStitcher) gives
  /// exactly the chunks that extractSlab gives, ids included.
  virtual std::unique_ptr<SlabWorker> makeWorker() const = 0;

  /// The number of welding-cache slots per slice: SlabPart's slots are below it.
  virtual std::size_t sliceSlots() const noexcept = 0;
};

/// What a sink learns of an extraction with `options` from a volume of `info` in `frame`.
MeshHeader extractionHeader(const ExtractOptions& options, const VolumeInfo& info, const LatticeFrame& frame,
                            const Extractor& extractor);

/// The extractor for `options.method`, for a volume of `info`'s dims (plus 2 per axis with
/// closeBoundary: it then takes the padded slices), emitting positions in `frame`.
std::unique_ptr<Extractor> makeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                         const LatticeFrame& frame);

}  // namespace isoslab
