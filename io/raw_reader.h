// Raw voxel data without a header: one file holding the whole volume (plain or gzip), or one file
// per slice given as a printf pattern ("CThead.%d") or as a folder in natural numeric order.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "io/volume_file.h"

#include "io/slice_source.h"

namespace isoslab {

struct RawOptions {
  /// Lattice points along x, y, z. For per-slice inputs z may be 0: the number of files.
  std::array<std::int64_t, 3> dims{0, 0, 0};
  VoxelType type = VoxelType::kU8;
  ByteOrder byteOrder = ByteOrder::kLittle;
  /// Bytes skipped at the start of the file (of every file, for per-slice inputs).
  std::int64_t headerBytes = 0;
  std::array<double, 3> spacing{1.0, 1.0, 1.0};
};

class RawReader {
 public:
  /// Opens `input`: a file (gzip is recognised by its magic bytes and inflated as a stream), a
  /// printf pattern, or a folder. Checks dims and, for plain files, that every file is long enough.
  /// Data longer than the dims need is read, with a warning from the source's warnings() that
  /// says how many bytes are left over and which dims or voxel type would use them all.
  static std::unique_ptr<SliceSource> open(const std::string& input, const RawOptions& options);
};

}  // namespace isoslab
