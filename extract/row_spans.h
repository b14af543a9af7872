// Row classification: which voxels of a row are inside (value >= iso), summarised as a RowSpan so
// that the extractor can skip the uniform stretches of a slab (flying-edges-style trimming).
#pragma once

#include <cstdint>
#include <vector>

#include "extract/slab_view.h"

namespace isoslab {

/// The smallest float not below iso: for every float v, v >= iso exactly when v >= this.
float insideThreshold(double iso) noexcept;

/// The spans of the ny rows of nx voxels of `slice` (row-major, x fastest), with v inside when
/// v >= threshold. Scans 16 voxels at a time (SSE2 where available) from both ends of each row.
void classifyRows(const float* slice, std::int64_t nx, std::int64_t ny, float threshold, std::vector<RowSpan>& rows);

}  // namespace isoslab
