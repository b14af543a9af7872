// Several surfaces of one volume in one pass, their chunks joined into one chunk of a surface set
// per slab, whose triangles carry MeshChunk::faceLabels, so that the label split
// (process/label_surfaces.h) and its outputs serve every set alike:
// - several iso values (--iso -400,350): each slab is extracted at every value, and the k-th
//   value's triangles carry {0, k + 1} (the side of lower values in front);
// - the layers of a segmentation read in one pass (VolumeInfo::layers): each layer's plane of the
//   slices is a label complex of its own, whose labels become layeredLabel(layer, value).
// The members share nothing: each has the triangles of its own extractor alone, its vertices
// following the members' before it in each joined chunk. Threads and ranks run the members'
// slab workers side by side, and their parts are joined as the chunks are, so they give the bytes
// of one thread.
#pragma once

#include <memory>
#include <vector>

#include "extract/extractor.h"

namespace isoslab {

/// The extractor of `isos` (two or more values) with `options` (its iso ignored).
std::unique_ptr<Extractor> makeMultiIsoExtractor(const ExtractOptions& options, const std::vector<double>& isos,
                                                 const VolumeInfo& info, const LatticeFrame& frame);

/// The label complexes of every layer of a volume of `info` (unpadded; info.layers planes a slice),
/// in `frame`: the padded slices hold info.layers padded planes one after another. With one layer,
/// makeLabelExtractor()'s.
std::unique_ptr<Extractor> makeLayeredLabelExtractor(const VolumeInfo& info, const LatticeFrame& frame);

}  // namespace isoslab
