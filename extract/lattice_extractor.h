// The extraction engine shared by the four methods. Marching Cubes walks the 256-case table of
// mc_table.h; the tetrahedral methods walk a CellScheme with the kernel of tet_table.h.
//
// Welding: every lattice edge (corner-corner, face or body diagonal, centre-corner, centre-centre)
// yields exactly one vertex, found through dense caches indexed by the edge's lower endpoint.
// The caches cover three anchor planes (slice z, the cube-centre plane z+1/2 and slice z+1) and
// roll from slab to slab, so edges on slice z+1 are shared with the next slab. Each vertex is
// interpolated once, along its edge from the lower endpoint (ordered by z, then y, then x) to the
// higher, so a cube edge gets the same position under every method.
#pragma once

#include <memory>

#include "extract/cell_schemes.h"
#include "extract/extractor.h"

namespace isoslab {

/// `scheme` null means Marching Cubes.
std::unique_ptr<Extractor> makeLatticeExtractor(const ExtractOptions& options, const VolumeInfo& info,
                                                const LatticeFrame& frame, std::unique_ptr<CellScheme> scheme);

}  // namespace isoslab
