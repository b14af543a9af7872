#include "io/raw_reader.h"

#include <fmt/format.h>
#include <zlib.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "core/error.h"
#include "io/file_list.h"

namespace fs = std::filesystem;

namespace isoslab {

std::unique_ptr<SliceSource> RawReader::open(const std::string& input, const RawOptions& options) {
  if (options.headerBytes < 0) {
    throw Error(fmt::format("{}: the header offset {} is negative", input, options.headerBytes));
  }
  for (int a = 0; a < 3; ++a) {
    if (!(options.spacing[a] > 0) || !std::isfinite(options.spacing[a])) {
      throw Error(fmt::format("{}: spacing {},{},{} is invalid: every value must be positive", input,
                              options.spacing[0], options.spacing[1], options.spacing[2]));
    }
  }
  VolumeFileLayout layout;
  std::error_code ec;
  if (fs::is_directory(input, ec)) {
    layout.files = listFolder(input);
    layout.perSlice = true;
  } else if (!fs::exists(input, ec) && isSlicePattern(input)) {
    layout.files = expandPattern(input);
    layout.perSlice = true;
  } else {
    if (!fs::exists(input, ec)) throw Error(fmt::format("{}: cannot open: {}", input, std::strerror(ENOENT)));
    layout.files = {input};
  }
  std::array<std::int64_t, 3> dims = options.dims;
  if (layout.perSlice && dims[2] == 0) dims[2] = static_cast<std::int64_t>(layout.files.size());
  layout.compression = Compression::kAutoGzip;
  layout.skipBytes = options.headerBytes;
  layout.type = options.type;
  layout.byteOrder = options.byteOrder;
  layout.warnExtraBytes = true;
  VolumeInfo info;
  info.dims = dims;
  info.spacing = options.spacing;
  info.spacingFields = {"--spacing", "--spacing", "--spacing"};
  info.type = options.type;
  info.reader = layout.perSlice ? "raw slices" : "raw";
  info.source = input;
  return openVolumeFile(info, layout);
}

}  // namespace isoslab
