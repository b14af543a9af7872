// Several iso-surfaces of one volume in one pass (--iso -400,350): each slab is extracted at every
// value, and the surfaces' chunks are joined into one chunk of a surface set, whose triangles
// carry MeshChunk::faceLabels {0, k + 1} for the k-th value (the side of lower values in front),
// so that the label split (process/label_surfaces.h) and its outputs serve it as they serve labels.
// The surfaces share nothing: each has the triangles of the extractor at its value alone (the split
// numbers its vertices in order of first use).
#pragma once

#include <memory>
#include <vector>

#include "extract/extractor.h"

namespace isoslab {

/// The extractor of `isos` (two or more values) with `options` (its iso ignored). It extracts on
/// one thread: makeWorker() returns nullptr, so the pipeline must run it with threads = 1.
std::unique_ptr<Extractor> makeMultiIsoExtractor(const ExtractOptions& options, const std::vector<double>& isos,
                                                 const VolumeInfo& info, const LatticeFrame& frame);

}  // namespace isoslab
