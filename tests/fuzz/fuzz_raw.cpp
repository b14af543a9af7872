// Raw volumes: fuzzed --raw-dims, --raw-type, --raw-endian, --raw-offset and --spacing, with the
// data as one file (plain or gzip, recognised by its magic bytes), a folder of per-slice files or
// a printf pattern of them.
//
// Input: 8 option bytes, then the data (per-slice files separated by kFileSeparator).
//   0..2  dims x, y, z: the byte itself, except 255 -> 2^31 - 1, 254 -> -1, 253 -> 2^40
//   3     voxel type (mod 8)
//   4     bit 0 big endian; bits 1-2 layout: 0 one file, 1 a folder, 2 a printf pattern
//   5..6  header bytes to skip, little endian
//   7     spacing: 0 -> 1, 1 -> NaN, 2 -> 0, 3 -> -1, 4 -> inf, else byte / 16 (all three axes)
#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "core/error.h"
#include "fuzz_support.h"
#include "io/open_source.h"

using namespace isoslab;

namespace {

std::int64_t dimension(std::uint8_t b) {
  switch (b) {
    case 255:
      return 2147483647;
    case 254:
      return -1;
    case 253:
      return std::int64_t{1} << 40;
    default:
      return b;
  }
}

double spacing(std::uint8_t b) {
  switch (b) {
    case 0:
      return 1;
    case 1:
      return std::numeric_limits<double>::quiet_NaN();
    case 2:
      return 0;
    case 3:
      return -1;
    case 4:
      return std::numeric_limits<double>::infinity();
    default:
      return b / 16.0;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::Bytes in(data, size);
  RawOptions raw;
  for (auto& d : raw.dims) d = dimension(fuzz::takeByte(in));
  raw.type = static_cast<VoxelType>(fuzz::takeByte(in) % 8);
  const std::uint8_t flags = fuzz::takeByte(in);
  raw.byteOrder = (flags & 1) != 0 ? ByteOrder::kBig : ByteOrder::kLittle;
  const int layout = (flags >> 1) & 3;
  raw.headerBytes = fuzz::takeByte(in);
  raw.headerBytes |= std::int64_t{fuzz::takeByte(in)} << 8;
  const double s = spacing(fuzz::takeByte(in));
  raw.spacing = {s, s, s};

  const std::string dir = fuzz::freshDir();
  std::string input;
  if (layout == 0 || layout == 3) {
    input = dir + "/volume.raw";
    fuzz::writeFile(input, in);
  } else {
    const auto parts = fuzz::splitFiles(in, 8);
    for (std::size_t n = 0; n < parts.size(); ++n) fuzz::writeFile(fmt::format("{}/s{}", dir, n + 1), parts[n]);
    input = layout == 1 ? dir : dir + "/s%d";
  }
  SourceOptions options;
  options.raw = raw;
  try {
    auto source = openSource(input, options);
    fuzz::extractAll(*source);
  } catch (const Error&) {
    // A refused input is a normal outcome.
  }
  return 0;
}
