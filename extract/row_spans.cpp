#include "extract/row_spans.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#include <cmath>
#include <limits>

namespace isoslab {
namespace {

// Rows are scanned in blocks of 16 voxels; rows are mostly uniform.
constexpr std::int64_t kBlock = 16;

// Bit k set when v[k] >= threshold, for k < 16.
unsigned insideMask16(const float* v, float threshold) noexcept {
#if defined(__SSE2__)
  const __m128 t = _mm_set1_ps(threshold);
  unsigned mask = 0;
  for (int q = 0; q < 4; ++q) {
    mask |= static_cast<unsigned>(_mm_movemask_ps(_mm_cmpge_ps(_mm_loadu_ps(v + 4 * q), t))) << (4 * q);
  }
  return mask;
#else
  unsigned mask = 0;
  for (unsigned k = 0; k < 16; ++k) mask |= static_cast<unsigned>(v[k] >= threshold) << k;
  return mask;
#endif
}

// The first i in [from, to) with (v[i] >= threshold) != state, or `to`.
std::int64_t firstDiffering(const float* v, std::int64_t from, std::int64_t to, bool state, float threshold) noexcept {
  std::int64_t i = from;
  const unsigned uniform = state ? 0xFFFFu : 0u;
  for (; i + kBlock <= to; i += kBlock) {
    if (insideMask16(v + i, threshold) != uniform) break;
  }
  for (; i < to; ++i) {
    if ((v[i] >= threshold) != state) return i;
  }
  return to;
}

// The last i in [from, to) with (v[i] >= threshold) != state, or from - 1.
std::int64_t lastDiffering(const float* v, std::int64_t from, std::int64_t to, bool state, float threshold) noexcept {
  std::int64_t i = to;
  const unsigned uniform = state ? 0xFFFFu : 0u;
  for (; i - kBlock >= from; i -= kBlock) {
    if (insideMask16(v + i - kBlock, threshold) != uniform) break;
  }
  for (; i > from; --i) {
    if ((v[i - 1] >= threshold) != state) return i - 1;
  }
  return from - 1;
}

}  // namespace

float insideThreshold(double iso) noexcept {
  const auto f = static_cast<float>(iso);
  if (std::isnan(iso) || static_cast<double>(f) >= iso) return f;
  return std::nextafter(f, std::numeric_limits<float>::infinity());
}

void classifyRows(const float* slice, std::int64_t nx, std::int64_t ny, float threshold, std::vector<RowSpan>& rows) {
  rows.resize(static_cast<std::size_t>(ny));
  for (std::int64_t j = 0; j < ny; ++j) {
    const float* v = slice + j * nx;
    RowSpan& r = rows[static_cast<std::size_t>(j)];
    r.left = v[0] >= threshold;
    r.right = v[nx - 1] >= threshold;
    r.first = firstDiffering(v, 1, nx, r.left, threshold);
    if (r.first == nx) {
      r.first = r.last = -1;
    } else {
      // The last change follows the last voxel whose state differs from the right end's.
      r.last = lastDiffering(v, 0, nx - 1, r.right, threshold) + 1;
    }
  }
}

}  // namespace isoslab
