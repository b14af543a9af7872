#include "core/voxel_type.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <string>

namespace isoslab {
namespace {

template <typename T>
T loadSwapped(const std::byte* p, bool swap) noexcept {
  std::byte b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap) std::reverse(b, b + sizeof(T));
  T v;
  std::memcpy(&v, b, sizeof(T));
  return v;
}

template <typename T>
void convertTyped(std::span<const std::byte> bytes, bool swap, std::span<float> out) noexcept {
  const std::byte* p = bytes.data();
  for (std::size_t i = 0; i < out.size(); ++i, p += sizeof(T)) {
    out[i] = static_cast<float>(loadSwapped<T>(p, swap));
  }
}

template <typename T>
T clampRound(double v) noexcept {
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(v);
  } else {
    const double lo = static_cast<double>(std::numeric_limits<T>::lowest());
    const double hi = static_cast<double>(std::numeric_limits<T>::max());
    if (std::isnan(v)) return T{0};
    return static_cast<T>(std::clamp(std::nearbyint(v), lo, hi));
  }
}

template <typename T>
void fromFloatTyped(std::span<const float> in, std::span<std::byte> bytes) noexcept {
  std::byte* p = bytes.data();
  for (float v : in) {
    const T t = clampRound<T>(v);
    std::memcpy(p, &t, sizeof(T));
    p += sizeof(T);
  }
}

}  // namespace

std::size_t voxelSize(VoxelType type) noexcept {
  switch (type) {
    case VoxelType::kU8:
    case VoxelType::kI8:
      return 1;
    case VoxelType::kU16:
    case VoxelType::kI16:
      return 2;
    case VoxelType::kU32:
    case VoxelType::kI32:
    case VoxelType::kF32:
      return 4;
    case VoxelType::kF64:
      return 8;
  }
  return 1;
}

std::string_view voxelTypeName(VoxelType type) noexcept {
  switch (type) {
    case VoxelType::kU8:
      return "u8";
    case VoxelType::kI8:
      return "i8";
    case VoxelType::kU16:
      return "u16";
    case VoxelType::kI16:
      return "i16";
    case VoxelType::kU32:
      return "u32";
    case VoxelType::kI32:
      return "i32";
    case VoxelType::kF32:
      return "f32";
    case VoxelType::kF64:
      return "f64";
  }
  return "?";
}

std::optional<VoxelType> parseVoxelType(std::string_view name) noexcept {
  std::string s(name);
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  struct Alias {
    const char* name;
    VoxelType type;
  };
  static constexpr Alias kAliases[] = {
      {"u8", VoxelType::kU8},   {"uint8", VoxelType::kU8},    {"uchar", VoxelType::kU8},
      {"i8", VoxelType::kI8},   {"int8", VoxelType::kI8},     {"char", VoxelType::kI8},
      {"u16", VoxelType::kU16}, {"uint16", VoxelType::kU16},  {"ushort", VoxelType::kU16},
      {"i16", VoxelType::kI16}, {"int16", VoxelType::kI16},   {"short", VoxelType::kI16},
      {"u32", VoxelType::kU32}, {"uint32", VoxelType::kU32},  {"uint", VoxelType::kU32},
      {"i32", VoxelType::kI32}, {"int32", VoxelType::kI32},   {"int", VoxelType::kI32},
      {"f32", VoxelType::kF32}, {"float32", VoxelType::kF32}, {"float", VoxelType::kF32},
      {"f64", VoxelType::kF64}, {"float64", VoxelType::kF64}, {"double", VoxelType::kF64},
  };
  for (const Alias& a : kAliases) {
    if (s == a.name) return a.type;
  }
  return std::nullopt;
}

namespace {
// Indexed by VoxelType. NIfTI-1 datatype codes (nifti1.h); NRRD and MetaImage type names.
constexpr VoxelTypeCodes kCodes[] = {
    {VoxelType::kU8, 2, "uint8", "MET_UCHAR"},      {VoxelType::kI8, 256, "int8", "MET_CHAR"},
    {VoxelType::kU16, 512, "uint16", "MET_USHORT"}, {VoxelType::kI16, 4, "int16", "MET_SHORT"},
    {VoxelType::kU32, 768, "uint32", "MET_UINT"},   {VoxelType::kI32, 8, "int32", "MET_INT"},
    {VoxelType::kF32, 16, "float", "MET_FLOAT"},    {VoxelType::kF64, 64, "double", "MET_DOUBLE"},
};
static_assert([] {
  for (std::size_t i = 0; i < std::size(kCodes); ++i) {
    if (static_cast<std::size_t>(kCodes[i].type) != i) return false;
  }
  return std::size(kCodes) == 8;
}());
}  // namespace

const VoxelTypeCodes& voxelTypeCodes(VoxelType type) noexcept {
  return kCodes[static_cast<std::size_t>(type)];
}

std::optional<VoxelType> voxelTypeFromNifti(int code) noexcept {
  for (const auto& c : kCodes) {
    if (c.nifti == code) return c.type;
  }
  return std::nullopt;
}

std::optional<VoxelType> voxelTypeFromMetaImage(std::string_view name) noexcept {
  for (const auto& c : kCodes) {
    if (name == c.metaImage) return c.type;
  }
  return std::nullopt;
}

ByteOrder hostByteOrder() noexcept {
  return std::endian::native == std::endian::little ? ByteOrder::kLittle : ByteOrder::kBig;
}

void convertToFloat(std::span<const std::byte> bytes, VoxelType type, ByteOrder order, std::span<float> out) noexcept {
  const bool swap = order != hostByteOrder();
  switch (type) {
    case VoxelType::kU8:
      convertTyped<std::uint8_t>(bytes, false, out);
      break;
    case VoxelType::kI8:
      convertTyped<std::int8_t>(bytes, false, out);
      break;
    case VoxelType::kU16:
      convertTyped<std::uint16_t>(bytes, swap, out);
      break;
    case VoxelType::kI16:
      convertTyped<std::int16_t>(bytes, swap, out);
      break;
    case VoxelType::kU32:
      convertTyped<std::uint32_t>(bytes, swap, out);
      break;
    case VoxelType::kI32:
      convertTyped<std::int32_t>(bytes, swap, out);
      break;
    case VoxelType::kF32:
      convertTyped<float>(bytes, swap, out);
      break;
    case VoxelType::kF64:
      convertTyped<double>(bytes, swap, out);
      break;
  }
}

void convertFromFloat(std::span<const float> in, VoxelType type, std::span<std::byte> bytes) noexcept {
  switch (type) {
    case VoxelType::kU8:
      fromFloatTyped<std::uint8_t>(in, bytes);
      break;
    case VoxelType::kI8:
      fromFloatTyped<std::int8_t>(in, bytes);
      break;
    case VoxelType::kU16:
      fromFloatTyped<std::uint16_t>(in, bytes);
      break;
    case VoxelType::kI16:
      fromFloatTyped<std::int16_t>(in, bytes);
      break;
    case VoxelType::kU32:
      fromFloatTyped<std::uint32_t>(in, bytes);
      break;
    case VoxelType::kI32:
      fromFloatTyped<std::int32_t>(in, bytes);
      break;
    case VoxelType::kF32:
      fromFloatTyped<float>(in, bytes);
      break;
    case VoxelType::kF64:
      fromFloatTyped<double>(in, bytes);
      break;
  }
}

double quantize(double value, VoxelType type) noexcept {
  switch (type) {
    case VoxelType::kU8:
      return clampRound<std::uint8_t>(value);
    case VoxelType::kI8:
      return clampRound<std::int8_t>(value);
    case VoxelType::kU16:
      return clampRound<std::uint16_t>(value);
    case VoxelType::kI16:
      return clampRound<std::int16_t>(value);
    case VoxelType::kU32:
      return clampRound<std::uint32_t>(value);
    case VoxelType::kI32:
      return clampRound<std::int32_t>(value);
    case VoxelType::kF32:
      return static_cast<float>(value);
    case VoxelType::kF64:
      return value;
  }
  return value;
}

}  // namespace isoslab
