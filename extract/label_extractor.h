// The label complex: every label's surface in a label volume, in one pass, with the interfaces
// shared (docs/design.md, "Label maps").
//
// The method is SurfaceNets (Frisken, "SurfaceNets for multi-label segmentations with preservation
// of sharp boundaries", JCGT 2022) before relaxation: each cell of the lattice holds a vertex at
// its centre, which is a corner of the voxels' boxes, and each pair of neighbouring samples of
// different labels gives the quad of the four cells around their edge, which is the voxel face
// between them, as two triangles. A face between labels A and B is emitted once, with
// MeshChunk::faceLabels telling its sides, so the two surfaces share its vertices and triangles
// (in opposite orientation): no gap, no overlap. Each label's surface is its voxels' boundary, so
// its enclosed volume is exactly its voxel count times the voxel volume. Vertices split where
// voxels of a label touch only at an edge or a corner (extract/label_cells.h).
//
// The slices come with one sample of background (0) around the volume (PadSource with a fill of
// 0), so every surface is capped where its label meets the volume's faces, half a voxel beyond
// the outermost samples: the lattice is info.dims + 2, its slabs the cell layers from the one
// below the first slice to the one above the last. Samples must hold whole numbers (io/
// label_source.h checks them); each label's value is the sample's, 0 is the background.
#pragma once

#include <memory>

#include "extract/extractor.h"

namespace isoslab {

/// The extractor of the label complex of a volume of `info` (unpadded), in `frame`.
std::unique_ptr<Extractor> makeLabelExtractor(const VolumeInfo& info, const LatticeFrame& frame);

/// What a sink learns of the label complex of a volume of `info` in `frame`: the volume's box and
/// faces are the voxels' boxes (half a voxel beyond the outermost samples), where the caps lie.
MeshHeader labelHeader(const VolumeInfo& info, const LatticeFrame& frame);

}  // namespace isoslab
