// ArraySource: a NumPy array as a SliceSource, for marching_cubes and extract.
//
// Axes: a C-ordered array volume[a0, a1, a2] is a lattice whose x (fastest) is a2, y is a1 and z
// (the slices) is a0, so each volume[k] is one slice, lent in place when the array is float32 and
// C-contiguous.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "core/voxel_type.h"
#include "io/slice_source.h"
#include "stream/value_range.h"

namespace isoslab {

namespace py = pybind11;

// A volume in a NumPy array of any real dtype and strides, as slices of float. The array's
// buffer is read without the GIL (the caller keeps the array alive and unchanged).
class ArraySource final : public SliceSource {
 public:
  explicit ArraySource(const py::array& a) {
    if (a.ndim() != 3) throw py::value_error("volume must be a 3D array");
    data_ = static_cast<const char*>(a.data());
    for (int k = 0; k < 3; ++k) {
      shape_[static_cast<std::size_t>(k)] = a.shape(k);
      strides_[static_cast<std::size_t>(k)] = a.strides(k);
    }
    info_.dims = {shape_[2], shape_[1], shape_[0]};
    info_.type = VoxelType::kF32;
    info_.reader = "numpy";
    info_.source = "volume";
    const py::dtype dt = a.dtype();
    kind_ = dt.kind();
    itemsize_ = static_cast<int>(dt.itemsize());
    if (!((kind_ == 'f' && (itemsize_ == 4 || itemsize_ == 8)) || kind_ == 'i' || kind_ == 'u' || kind_ == 'b')) {
      throw py::value_error("volume must hold real numbers (bool, integer or floating point)");
    }
    if (!dt.attr("isnative").cast<bool>()) throw py::value_error("volume must be in the machine's byte order");
    // Lent in place when the array is one C-ordered, aligned block of native floats.
    lends_ = kind_ == 'f' && itemsize_ == 4 && reinterpret_cast<std::uintptr_t>(data_) % alignof(float) == 0 &&
             strides_[2] == 4 && strides_[1] == 4 * shape_[2] && strides_[0] == 4 * shape_[2] * shape_[1];
  }

  const VolumeInfo& info() const noexcept override { return info_; }
  bool lendsSlices() const noexcept override { return lends_; }
  const float* lendSlice() override {
    if (next_ >= shape_[0]) return nullptr;
    return reinterpret_cast<const float*>(data_ + strides_[0] * next_++);
  }
  bool readSlice(std::span<float> out) override {
    if (next_ >= shape_[0]) return false;
    const char* slice = data_ + strides_[0] * next_++;
    std::size_t n = 0;
    for (py::ssize_t j = 0; j < shape_[1]; ++j) {
      const char* row = slice + strides_[1] * j;
      for (py::ssize_t i = 0; i < shape_[2]; ++i) out[n++] = value(row + strides_[2] * i);
    }
    return true;
  }
  std::int64_t skipSlices(std::int64_t n) override {
    const std::int64_t k = std::min<std::int64_t>(n, shape_[0] - next_);
    next_ += k;
    return k;
  }
  void rewind() noexcept { next_ = 0; }
  /// A fresh source over the same array from its first slice, made without Python (for a pass on
  /// a thread without the GIL; the caller keeps the array alive).
  std::unique_ptr<ArraySource> clone() const { return std::unique_ptr<ArraySource>(new ArraySource(*this, 0)); }
  /// The lattice's geometry: spacing per array axis (a0, a1, a2), and the name of the volume in
  /// messages.
  void setGeometry(const std::array<double, 3>& spacing, const std::string& name) {
    info_.spacing = {spacing[2], spacing[1], spacing[0]};
    info_.source = name;
    // The voxel type that a raw file of this dtype would have (64-bit integers read as float).
    static const std::array<std::pair<const char*, VoxelType>, 9> kTypes{{{"u1", VoxelType::kU8},
                                                                          {"i1", VoxelType::kI8},
                                                                          {"b1", VoxelType::kU8},
                                                                          {"u2", VoxelType::kU16},
                                                                          {"i2", VoxelType::kI16},
                                                                          {"u4", VoxelType::kU32},
                                                                          {"i4", VoxelType::kI32},
                                                                          {"f4", VoxelType::kF32},
                                                                          {"f8", VoxelType::kF64}}};
    const std::string code = std::string(1, kind_) + std::to_string(itemsize_);
    for (const auto& [key, type] : kTypes) {
      if (code == key) info_.type = type;
    }
  }

  // The smallest and largest value (NaN skipped); nothing if every value is NaN.
  std::optional<std::array<double, 2>> range() const {
    if (lends_) {
      ValueRange r;
      const auto n = static_cast<std::size_t>(shape_[1] * shape_[2]);
      for (py::ssize_t k = 0; k < shape_[0]; ++k) r.add(reinterpret_cast<const float*>(data_ + strides_[0] * k), n);
      return r.range();
    }
    double lo = std::numeric_limits<double>::infinity();
    double hi = -lo;
    for (py::ssize_t k = 0; k < shape_[0]; ++k) {
      for (py::ssize_t j = 0; j < shape_[1]; ++j) {
        const char* row = data_ + strides_[0] * k + strides_[1] * j;
        for (py::ssize_t i = 0; i < shape_[2]; ++i) {
          const double v = value(row + strides_[2] * i);
          lo = v < lo ? v : lo;
          hi = v > hi ? v : hi;
        }
      }
    }
    if (lo > hi) return std::nullopt;
    return std::array<double, 2>{lo, hi};
  }

  // The array's floats when it is lent (C-ordered float32), else null.
  const float* lentData() const noexcept { return lends_ ? reinterpret_cast<const float*>(data_) : nullptr; }

  // The value at index (k, j, i) = (a0, a1, a2).
  float at(std::int64_t k, std::int64_t j, std::int64_t i) const noexcept {
    if (lends_) return reinterpret_cast<const float*>(data_)[(k * shape_[1] + j) * shape_[2] + i];
    return value(data_ + strides_[0] * k + strides_[1] * j + strides_[2] * i);
  }

 private:
  ArraySource(const ArraySource& o, int /*clone*/)
      : info_(o.info_),
        data_(o.data_),
        shape_(o.shape_),
        strides_(o.strides_),
        kind_(o.kind_),
        itemsize_(o.itemsize_),
        lends_(o.lends_) {}

  float value(const char* p) const noexcept {
    switch (kind_) {
      case 'f':
        if (itemsize_ == 4) return load<float>(p);
        return static_cast<float>(load<double>(p));
      case 'b':
        return static_cast<float>(load<std::uint8_t>(p) != 0);
      case 'i':
        return integer<std::int8_t, std::int16_t, std::int32_t, std::int64_t>(p);
      default:
        return integer<std::uint8_t, std::uint16_t, std::uint32_t, std::uint64_t>(p);
    }
  }
  // An integer of itemsize_ bytes, of the type given for that size.
  template <typename T1, typename T2, typename T4, typename T8>
  float integer(const char* p) const noexcept {
    switch (itemsize_) {
      case 1:
        return static_cast<float>(load<T1>(p));
      case 2:
        return static_cast<float>(load<T2>(p));
      case 4:
        return static_cast<float>(load<T4>(p));
      default:
        return static_cast<float>(load<T8>(p));
    }
  }
  template <typename T>
  static T load(const char* p) noexcept {
    T v;
    std::memcpy(&v, p, sizeof v);
    return v;
  }

  VolumeInfo info_;
  const char* data_ = nullptr;
  std::array<py::ssize_t, 3> shape_{};
  std::array<py::ssize_t, 3> strides_{};
  char kind_ = 'f';
  int itemsize_ = 4;
  bool lends_ = false;
  std::int64_t next_ = 0;
};

}  // namespace isoslab
