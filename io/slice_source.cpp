#include "io/slice_source.h"

#include <fmt/format.h>

#include <limits>

#include "io/error.h"
#include "io/limits.h"

namespace isoslab {

void validateDims(const std::array<std::int64_t, 3>& dims, const std::string& what) {
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 2) {
      throw Error(fmt::format("{}: dims {}x{}x{} are invalid: every axis needs at least 2 points", what, dims[0],
                              dims[1], dims[2]));
    }
    if (dims[a] > std::numeric_limits<std::int32_t>::max()) {
      throw Error(fmt::format("{}: dims {}x{}x{} are invalid: an axis exceeds 2147483647 points", what, dims[0],
                              dims[1], dims[2]));
    }
  }
  // The voxel count, and its byte size for 8-byte voxels, must fit in 63 bits.
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max() / 8;
  if (dims[0] > kMax / dims[1] || dims[0] * dims[1] > kMax / dims[2]) {
    throw Error(
        fmt::format("{}: dims {}x{}x{} are invalid: the voxel count overflows", what, dims[0], dims[1], dims[2]));
  }
  if (dims[0] * dims[1] > limits::kMaxSliceVoxels) {
    throw Error(fmt::format("{}: dims {}x{}x{} are invalid: a slice of {} points exceeds the limit of {}", what,
                            dims[0], dims[1], dims[2], dims[0] * dims[1], limits::kMaxSliceVoxels));
  }
}

}  // namespace isoslab
