// Voxel data stored in files, read slice by slice: the engine behind the raw reader and the
// NRRD, MetaImage and NIfTI readers. Data may be plain, or a gzip/zlib stream that is inflated as
// it is read (never whole, never to disk); it may be one file for the volume or one per slice; it
// may interleave several components, of which one is kept.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "io/slice_source.h"

namespace isoslab {

enum class Compression : std::uint8_t {
  kNone,
  kDeflate,   // gzip or zlib stream (detected by its header)
  kAutoGzip,  // gzip if the data starts with gzip's magic bytes, plain otherwise
};

struct VolumeFileLayout {
  std::vector<std::string> files;  // one for the volume, or one per slice
  bool perSlice = false;
  std::int64_t fileOffset = 0;  // bytes of each file before its data stream (headers)
  std::int64_t skipBytes = 0;   // bytes of the (inflated) stream skipped before the voxels
  Compression compression = Compression::kNone;
  VoxelType type = VoxelType::kU8;
  ByteOrder byteOrder = ByteOrder::kLittle;
  int components = 1;  // interleaved components per voxel
  int component = 0;   // the one to keep; -1: every one, each a plane (VolumeInfo::layers)
  double slope = 1;    // value = stored * slope + intercept
  double intercept = 0;
  /// What the header that described this data is called, for messages ("raw", "NRRD header", ...).
  std::string describedBy = "raw";
  /// Whether data longer than the dims need gives a warning (SliceSource::warnings()): plain
  /// files are measured when opened, a compressed volume file once it has been read to its end
  /// (compressed per-slice files are not checked). Only for components == 1.
  bool warnExtraBytes = false;
};

/// Whether the next two bytes of `file` are gzip's magic bytes (0x1f 0x8b). Reads them (the
/// position moves on by up to two bytes); a file with fewer left is not gzip.
bool startsWithGzipMagic(std::FILE* file);

/// Opens the data described by `layout` for a volume of `info`. Plain files are checked for length
/// up front; compressed streams when they end. Errors name the file.
std::unique_ptr<SliceSource> openVolumeFile(const VolumeInfo& info, const VolumeFileLayout& layout);

}  // namespace isoslab
