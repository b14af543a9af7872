// The smallest and largest value over the slices of a run, NaN skipped, tracked as they stream past
// (the volume is never held). Ranges of parts of the volume merge into the whole's.
#pragma once

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <array>
#include <cstddef>
#include <limits>
#include <optional>

namespace isoslab {

class ValueRange {
 public:
  // NaN compares false both ways, so it never replaces a bound. Eight lanes at a time (SSE's
  // minps(v, lo) is exactly `v < lo ? v : lo`), which the compiler does not do by itself.
  void add(const float* values, std::size_t n) noexcept {
    float lo = lo_;
    float hi = hi_;
    std::size_t i = 0;
#if defined(__SSE2__)
    if (n >= 8) {
      __m128 lo0 = _mm_set1_ps(lo), lo1 = lo0, hi0 = _mm_set1_ps(hi), hi1 = hi0;
      for (; i + 8 <= n; i += 8) {
        const __m128 a = _mm_loadu_ps(values + i);
        const __m128 b = _mm_loadu_ps(values + i + 4);
        lo0 = _mm_min_ps(a, lo0);
        lo1 = _mm_min_ps(b, lo1);
        hi0 = _mm_max_ps(a, hi0);
        hi1 = _mm_max_ps(b, hi1);
      }
      alignas(16) float l[8], h[8];
      _mm_store_ps(l, lo0);
      _mm_store_ps(l + 4, lo1);
      _mm_store_ps(h, hi0);
      _mm_store_ps(h + 4, hi1);
      for (int k = 0; k < 8; ++k) {
        lo = l[k] < lo ? l[k] : lo;
        hi = h[k] > hi ? h[k] : hi;
      }
    }
#endif
    for (; i < n; ++i) {
      lo = values[i] < lo ? values[i] : lo;
      hi = values[i] > hi ? values[i] : hi;
    }
    lo_ = lo;
    hi_ = hi;
  }
  void merge(const ValueRange& other) noexcept {
    lo_ = other.lo_ < lo_ ? other.lo_ : lo_;
    hi_ = other.hi_ > hi_ ? other.hi_ : hi_;
  }
  /// Empty when no value that is not NaN was seen.
  std::optional<std::array<double, 2>> range() const {
    if (lo_ > hi_) return std::nullopt;
    return std::array<double, 2>{lo_, hi_};
  }

 private:
  float lo_ = std::numeric_limits<float>::infinity();
  float hi_ = -std::numeric_limits<float>::infinity();
};

}  // namespace isoslab
