// A fixed array of zeros from calloc: a large one comes from fresh pages that the system maps only
// where they are written, so a table indexed by label (most entries never touched) costs memory and
// page faults for what is used, not for its size.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <type_traits>

namespace isoslab {

template <class T>
class ZeroedArray {
  static_assert(std::is_trivial_v<T>, "zero bytes must be a value of T");

 public:
  ZeroedArray() = default;
  /// `n` zeros. Throws std::bad_alloc.
  explicit ZeroedArray(std::size_t n) : data_(static_cast<T*>(std::calloc(n == 0 ? 1 : n, sizeof(T)))), size_(n) {
    if (data_ == nullptr) throw std::bad_alloc();
  }

  std::size_t size() const noexcept { return size_; }
  bool empty() const noexcept { return size_ == 0; }
  T& operator[](std::size_t k) noexcept { return data_.get()[k]; }
  const T& operator[](std::size_t k) const noexcept { return data_.get()[k]; }

 private:
  struct Free {
    void operator()(T* p) const noexcept { std::free(p); }
  };
  std::unique_ptr<T, Free> data_;
  std::size_t size_ = 0;
};

}  // namespace isoslab
