#include "io/open_source.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

#include "io/atomic_file.h"
#include "io/error.h"
#include "io/file_list.h"
#include "io/phantom.h"

namespace isoslab {

std::unique_ptr<SliceSource> openSource(const std::string& input, const SourceOptions& options) {
  if (PhantomSource::isPhantom(input)) return PhantomSource::open(input);
  if (options.raw) return RawReader::open(input, *options.raw);
  std::error_code ec;
  if (!std::filesystem::exists(input, ec) && !isSlicePattern(input)) {
    throw Error(fmt::format("{}: cannot open: {}", input, std::strerror(ENOENT)));
  }
  throw Error(fmt::format("{}: unrecognised input format; for raw data give --raw-dims X,Y[,Z] and --raw-type", input));
}

std::int64_t writeRaw(SliceSource& source, const std::string& path, VoxelType type) {
  if (hostByteOrder() != ByteOrder::kLittle) {
    throw Error(fmt::format("{}: writing raw data is implemented for little-endian hosts only", path));
  }
  AtomicFile out(path);
  std::vector<float> slice(static_cast<std::size_t>(source.info().sliceVoxels()));
  std::vector<std::byte> bytes(slice.size() * voxelSize(type));
  while (source.readSlice(slice)) {
    convertFromFloat(slice, type, bytes);
    out.write(bytes.data(), bytes.size());
  }
  out.commit();
  return out.size();
}

}  // namespace isoslab
