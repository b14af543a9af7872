// Voxel types of scanner data, and their conversion to the float slices the pipeline works on.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace isoslab {

enum class VoxelType : std::uint8_t { kU8, kI8, kU16, kI16, kU32, kI32, kF32, kF64 };

enum class ByteOrder : std::uint8_t { kLittle, kBig };

/// Bytes per voxel.
std::size_t voxelSize(VoxelType type) noexcept;

/// The short name used on the command line and in reports: u8, i8, u16, i16, u32, i32, f32, f64.
std::string_view voxelTypeName(VoxelType type) noexcept;

/// Parses a short name (case-insensitive; also uint8, int16, float, double, ...). Empty on failure.
std::optional<VoxelType> parseVoxelType(std::string_view name) noexcept;

/// How the volume formats name a voxel type: the NIfTI datatype code, and the canonical NRRD
/// and MetaImage names (writers use these; readers also accept the formats' aliases).
struct VoxelTypeCodes {
  VoxelType type;
  std::int16_t nifti;
  const char* nrrd;
  const char* metaImage;
};

/// One entry per VoxelType.
const VoxelTypeCodes& voxelTypeCodes(VoxelType type) noexcept;

/// The voxel type of a NIfTI datatype code, if isoslab reads it.
std::optional<VoxelType> voxelTypeFromNifti(int code) noexcept;

/// The voxel type of a canonical MetaImage element type (MET_UCHAR, ...).
std::optional<VoxelType> voxelTypeFromMetaImage(std::string_view name) noexcept;

/// The host's byte order.
ByteOrder hostByteOrder() noexcept;

/// Converts `out.size()` voxels of `type` stored in `order` from `bytes` to float. `bytes` must hold
/// exactly out.size() * voxelSize(type) bytes. 32- and 64-bit values beyond 2^24 lose precision,
/// as float does.
void convertToFloat(std::span<const std::byte> bytes, VoxelType type, ByteOrder order, std::span<float> out) noexcept;

/// Converts float values to `type` in host byte order, rounding to nearest and clamping to the
/// type's range. `bytes` must hold in.size() * voxelSize(type) bytes.
void convertFromFloat(std::span<const float> in, VoxelType type, std::span<std::byte> bytes) noexcept;

/// Rounds and clamps `value` to what `type` can hold, as convertFromFloat does, returned as double.
double quantize(double value, VoxelType type) noexcept;

}  // namespace isoslab
