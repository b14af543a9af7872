#include "core/volume_info.h"

#include <limits>

#include "core/error.h"
#include "core/limits.h"

namespace isoslab {

void validateDims(const std::array<std::int64_t, 3>& dims, const std::string& what) {
  const std::string text = std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" + std::to_string(dims[2]);
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 2) throw Error(what + ": dims " + text + " are invalid: every axis needs at least 2 points");
    if (dims[a] > std::numeric_limits<std::int32_t>::max()) {
      throw Error(what + ": dims " + text + " are invalid: an axis exceeds 2147483647 points");
    }
  }
  // The voxel count, and its byte size for 8-byte voxels, must fit in 63 bits.
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max() / 8;
  if (dims[0] > kMax / dims[1] || dims[0] * dims[1] > kMax / dims[2]) {
    throw Error(what + ": dims " + text + " are invalid: the voxel count overflows");
  }
  if (dims[0] * dims[1] > limits::kMaxSliceVoxels) {
    throw Error(what + ": dims " + text + " are invalid: a slice of " + std::to_string(dims[0] * dims[1]) +
                " points exceeds the limit of " + std::to_string(limits::kMaxSliceVoxels));
  }
}

}  // namespace isoslab
