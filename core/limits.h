// The largest inputs isoslab accepts, in one place.
//
// Every count that a header claims (dims, components, frames, data files, mesh elements) is
// checked against the size of the file that must hold it, or against one of these limits, before
// anything is allocated or looped over. Messages that refuse an input name the limit.
#pragma once

#include <cstdint>

namespace isoslab::limits {

/// Lattice points along one axis.
inline constexpr std::int64_t kMaxAxisPoints = 2147483647;
/// Lattice points in one slice (x times y): slices are held in memory, a few at a time, as floats.
inline constexpr std::int64_t kMaxSliceVoxels = std::int64_t{1} << 30;
/// Bytes of one stored slice, all components together: it is read whole before conversion.
inline constexpr std::int64_t kMaxSliceBytes = std::int64_t{8} * 1024 * 1024 * 1024;
/// Components (channels) per voxel in a volume file.
inline constexpr std::int64_t kMaxComponents = 1024;
/// Files named by a data-file list or pattern (NRRD, MetaImage), that is, slices in files.
inline constexpr std::int64_t kMaxDataFiles = 1000000;
/// Frames of one multi-frame DICOM image.
inline constexpr std::int64_t kMaxFrames = 1000000;
/// Bytes of a text header (NRRD, MetaImage) before its data.
inline constexpr std::int64_t kMaxHeaderBytes = 16 * 1024 * 1024;
/// A label table (`--label-table`): FreeSurfer's is 50 KB.
inline constexpr std::uintmax_t kMaxLabelTableBytes = 64 * 1024 * 1024;
/// Bytes of a mesh file read by `metrics` and `decode` (they read it whole).
inline constexpr std::int64_t kMaxMeshFileBytes = std::int64_t{16} * 1024 * 1024 * 1024;
/// Depth of nested DICOM sequences (DCMTK's reader recurses once per level).
inline constexpr int kMaxDicomSequenceDepth = 64;
/// Bytes a deflated DICOM dataset may inflate to (the nesting walk inflates it before DCMTK does).
inline constexpr std::int64_t kMaxInflatedDicomBytes = std::int64_t{1} << 30;

}  // namespace isoslab::limits
