// Extractors turn slabs of cells into triangles. One object per run; not thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "extract/frame.h"
#include "extract/mesh_sink.h"
#include "io/slice_source.h"
#include "stream/slab_ring.h"

namespace isoslab {

enum class Method : std::uint8_t { kMarchingCubes, kTetra5, kTetra6, kBcc12 };

/// "mc", "mt5", "mt6", "bcc12".
std::string_view methodName(Method m) noexcept;
std::optional<Method> parseMethod(std::string_view name) noexcept;

struct ExtractOptions {
  Method method = Method::kMarchingCubes;
  double iso = 0;
  bool normals = false;
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
  virtual void extractSlab(const SlabView& slab, MeshChunk& out) noexcept = 0;

  /// Vertices emitted so far (may exceed what VertexId holds; the pipeline checks).
  virtual std::uint64_t vertexCount() const noexcept = 0;

  /// Whether chunks carry the tetrahedral inside volume (cellVolume).
  virtual bool cellVolumes() const noexcept = 0;
};

/// The extractor for `options.method`, for a volume of `info`'s dims, emitting positions in `frame`.
std::unique_ptr<Extractor> makeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                         const LatticeFrame& frame);

}  // namespace isoslab
