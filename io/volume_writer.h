// Writes a volume slice by slice, keeping its geometry: raw voxels, NIfTI-1 (.nii, or .nii.gz
// gzip-compressed), NRRD (.nrrd, data attached, raw or gzip) or MetaImage (.mha, data inline,
// plain or zlib). Used by `isoslab phantom` and by the tests of the readers.
#pragma once

#include <cstdint>
#include <string>

#include "io/slice_source.h"

namespace isoslab {

struct VolumeWriteOptions {
  VoxelType type = VoxelType::kU8;
  ByteOrder byteOrder = ByteOrder::kLittle;
  /// NRRD and MetaImage: deflate the data (gzip for NRRD, zlib for MetaImage). NIfTI: by name.
  bool compress = false;
};

/// Writes every remaining slice of `source` to `path`; the format comes from the extension
/// (.raw and anything else unknown: raw voxels). Returns the bytes written. The file appears only
/// when complete.
std::int64_t writeVolume(SliceSource& source, const std::string& path, const VolumeWriteOptions& options);

}  // namespace isoslab
