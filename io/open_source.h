// Opens any input isoslab understands by its name: a phantom spec, or raw data described by
// RawOptions. Later readers (DICOM, NRRD, ...) are recognised here too.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "io/raw_reader.h"
#include "io/slice_source.h"

namespace isoslab {

struct SourceOptions {
  /// Set when the user described raw data (--raw-dims and friends).
  std::optional<RawOptions> raw;
};

/// Throws isoslab::Error naming the input and the problem.
std::unique_ptr<SliceSource> openSource(const std::string& input, const SourceOptions& options);

/// Writes every remaining slice of `source` to `path` as raw voxels of `type`, little-endian, x
/// fastest, through an AtomicFile. Returns the bytes written.
std::int64_t writeRaw(SliceSource& source, const std::string& path, VoxelType type);

}  // namespace isoslab
