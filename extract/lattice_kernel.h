// The cell walk shared by the four methods: one slab of cells at a time, trimmed to the stretches
// of rows where the surface may cross, each crossed cell's case emitted through the case lists
// (case_lists.h) with vertices welded through the caches (welding_cache.h).
//
// Welding: every lattice edge (corner-corner, face or body diagonal, centre-corner, centre-centre)
// yields exactly one vertex. Each vertex is interpolated once, along its edge from the lower
// endpoint (ordered by z, then y, then x) to the higher, so a cube edge gets the same position
// under every method.
//
// The kernel serves two drivers (lattice_extractor.cpp): the sequential extractor, whose slabs
// follow each other and carry the caches, the row spans and the cube centres over; and the slab
// worker, whose slab stands alone and refers to the vertices on slice z by their cache slot.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "extract/case_lists.h"
#include "extract/extractor.h"
#include "extract/slab_field.h"
#include "extract/welding_cache.h"

namespace isoslab {

class LatticeKernel {
 public:
  /// `scheme` null means Marching Cubes.
  LatticeKernel(const ExtractOptions& options, const std::array<std::int64_t, 3>& dims, const LatticeFrame& frame,
                std::unique_ptr<CellScheme> scheme);

  /// Extracts slab `slab.z` into `out`, numbering new vertices from vertexCount(). With `foreign`
  /// null the slab follows the previous one (z - 1), and the caller rolls the caches afterwards
  /// (rollCaches). Otherwise it stands alone: everything is derived from its own slices, and a
  /// vertex on slice z that the slab below creates gets the id kForeignVertex | k, with its cache
  /// slot appended to `foreign` as entry k. Allocates; throws std::bad_alloc.
  void extractSlab(const SlabView& slab, MeshChunk& out, std::vector<CacheSlot>* foreign);

  /// After a following slab: slice z + 1's caches, spans and centres become slice z's.
  void rollCaches() noexcept;
  /// After a standalone slab: its vertices on slice z + 1, by slot, and empty caches.
  void takeTop(std::vector<std::pair<CacheSlot, LocalVertex>>& top);

  void resetVertexCount() noexcept { vertexCount_ = 0; }
  std::uint64_t vertexCount() const noexcept { return vertexCount_; }
  bool needsCentres() const noexcept { return needsCentres_; }
  bool cellVolumes() const noexcept { return scheme_ != nullptr && options_.cellVolumes; }
  std::size_t sliceSlots() const noexcept { return cases_.sliceClasses() * static_cast<std::size_t>(planeSize_); }
  void classifySlice(const float* slice, std::vector<RowSpan>& rows) const;

  const ExtractOptions& options() const noexcept { return options_; }
  const LatticeFrame& frame() const noexcept { return frame_; }
  std::array<std::int64_t, 3> dims() const noexcept { return {nx_, ny_, nz_}; }
  std::unique_ptr<CellScheme> copyScheme() const;

 private:
  void allocate();
  std::array<const RowSpan*, 3> rowSpans(const SlabView& slab, bool standalone);
  void trimmedRow(std::int64_t j, const std::array<const RowSpan*, 3>& spans, double& insideVolume);
  void marchRow(std::int64_t j, std::int64_t begin, std::int64_t end, double& insideVolume);
  void prefetchRow(std::int64_t j, std::int64_t begin, std::int64_t end) const noexcept;
  void computeCentres(int which, std::vector<float>& dst);
  void loadCorners(const std::array<const float*, 4>& rows) noexcept;
  void ownCentres() noexcept;
  double marchTetrahedra(unsigned cornerCase, std::int64_t i, std::int64_t j,
                         const std::array<const float*, 4>& corners);
  void emitCase(const CaseList& v, unsigned key, std::int64_t i, std::int64_t j);
  void emitTriangle(VertexId a, VertexId b, VertexId c);
  VertexId vertex(const EdgeRef& e, std::int64_t i, std::int64_t j);
  void createVertex(const EdgeRef& e, std::int64_t i, std::int64_t j);
  void createCellPoint(unsigned mask, std::int64_t i, std::int64_t j);
  Vec3d edgeNormal(int a, int b, double t, std::int64_t i, std::int64_t j) const noexcept;
  Vec3d cutPoint(int a, int b, std::int64_t i, std::int64_t j, double& t, bool& leaves) const noexcept;
  Vec3f outputPosition(const Vec3d& lattice) const noexcept;

  ExtractOptions options_;
  LatticeFrame frame_;
  std::unique_ptr<CellScheme> scheme_;
  CellCases cases_;
  WeldingCache cache_;
  std::array<std::vector<float>, 2> centres_;  // cube-centre values of slabs z and z + 1 (bcc12)
  std::vector<double> columns_;
  std::array<std::vector<RowSpan>, 3> rows_;
  bool rowsCarried_ = false;                   // rows_[0..] hold the spans of this slab's slices, rolled from the last
  bool needsCentres_ = false;                  // bcc12: cube centres of this slab and the next
  bool ownCentres_ = false;                    // mt24: face and cube centres of each cell, from its corners
  bool mc33_ = false;                          // mc33: Marching Cubes with the trilinear topology
  const std::uint16_t* cellPoints_ = nullptr;  // mc33: the current case's cell points
  float threshold_ = 0;                        // a value v is inside when v >= threshold_
  std::vector<CacheSlot>* foreign_ = nullptr;
  bool flip_ = false;
  double cellVolume_ = 1;
  std::int64_t nx_ = 0, ny_ = 0, nz_ = 0, planeSize_ = 0;
  std::int64_t z_ = 0;
  std::int64_t pad_ = 0;  // closeBoundary: the lattice's NaN points around the volume, per side
  SlabField field_;
  MeshChunk* out_ = nullptr;
  std::array<float, 16> value_{};  // node values: corners, then the scheme's centres
  std::uint64_t vertexCount_ = 0;
};

}  // namespace isoslab
