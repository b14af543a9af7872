// The extraction engine shared by the four methods: Marching Cubes walks the 256-case table of
// mc_table.h; the tetrahedral methods walk a CellScheme with the kernel of tet_table.h. The engine
// is in named parts: row_spans (trimming), case_lists, welding_cache, slab_field (gradients),
// tet_volume, and lattice_kernel (the cell walk), driven by lattice_extractor.cpp.
#pragma once

#include <memory>

#include "extract/cell_schemes.h"
#include "extract/extractor.h"

namespace isoslab {

/// `scheme` null means Marching Cubes.
std::unique_ptr<Extractor> makeLatticeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                                const LatticeFrame& frame, std::unique_ptr<CellScheme> scheme);

}  // namespace isoslab
