// Runs of equal floats, found four at a time: label volumes are mostly long runs of one value
// (LabelSource checks and counts each run once; the label kernel classifies rows by where they
// change). NaN equals nothing, so a run never holds one.
#pragma once

#include <bit>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace isoslab {

/// The first k in [from, end) with p[k] != v, or end when there is none.
inline std::int64_t runEnd(const float* p, std::int64_t from, std::int64_t end, float v) noexcept {
  std::int64_t k = from;
#if defined(__SSE2__)
  const __m128 value = _mm_set1_ps(v);
  for (; k + 4 <= end; k += 4) {
    const int equal = _mm_movemask_ps(_mm_cmpeq_ps(_mm_loadu_ps(p + k), value));
    if (equal != 0xf) return k + std::countr_one(static_cast<unsigned>(equal));
  }
#endif
  while (k < end && p[k] == v) ++k;
  return k;
}

/// The last k in [begin, end) with p[k] != v, or begin - 1 when there is none.
inline std::int64_t runStart(const float* p, std::int64_t begin, std::int64_t end, float v) noexcept {
  std::int64_t k = end;  // p[k .. end) all equal v
#if defined(__SSE2__)
  const __m128 value = _mm_set1_ps(v);
  for (; k - 4 >= begin; k -= 4) {
    const int equal = _mm_movemask_ps(_mm_cmpeq_ps(_mm_loadu_ps(p + k - 4), value));
    if (equal != 0xf) return k - 1 - std::countl_one(static_cast<unsigned>(equal) << 28);
  }
#endif
  while (k > begin && p[k - 1] == v) --k;
  return k - 1;
}

}  // namespace isoslab
