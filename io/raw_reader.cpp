#include "io/raw_reader.h"

#include <fmt/format.h>
#include <zlib.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "io/error.h"
#include "io/file_list.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

bool isGzip(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  unsigned char magic[2] = {0, 0};
  const std::size_t n = std::fread(magic, 1, 2, f);
  std::fclose(f);
  return n == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
}

std::string dimsText(const std::array<std::int64_t, 3>& d) {
  return fmt::format("{}x{}x{}", d[0], d[1], d[2]);
}

}  // namespace

std::unique_ptr<RawReader> RawReader::open(const std::string& input, const RawOptions& options) {
  std::unique_ptr<RawReader> r(new RawReader());
  r->options_ = options;
  if (options.headerBytes < 0) {
    throw Error(fmt::format("{}: the header offset {} is negative", input, options.headerBytes));
  }
  for (int a = 0; a < 3; ++a) {
    if (!(options.spacing[a] > 0) || !std::isfinite(options.spacing[a])) {
      throw Error(fmt::format("{}: spacing {},{},{} is invalid: every value must be positive", input,
                              options.spacing[0], options.spacing[1], options.spacing[2]));
    }
  }

  std::error_code ec;
  bool perSlice = false;
  if (fs::is_directory(input, ec)) {
    r->files_ = listFolder(input);
    perSlice = true;
  } else if (!fs::exists(input, ec) && isSlicePattern(input)) {
    r->files_ = expandPattern(input);
    perSlice = true;
  } else {
    if (!fs::exists(input, ec)) {
      throw Error(fmt::format("{}: cannot open: {}", input, std::strerror(ENOENT)));
    }
    r->files_ = {input};
  }

  std::array<std::int64_t, 3> dims = options.dims;
  if (perSlice) {
    const auto count = static_cast<std::int64_t>(r->files_.size());
    if (dims[2] == 0) dims[2] = count;
    if (dims[2] > count) {
      throw Error(
          fmt::format("{}: dims {} need {} slice files but only {} exist", input, dimsText(dims), dims[2], count));
    }
    r->files_.resize(static_cast<std::size_t>(dims[2]));
  }
  validateDims(dims, input);

  const std::int64_t sliceBytes = dims[0] * dims[1] * static_cast<std::int64_t>(voxelSize(options.type));
  // Plain files are checked up front; gzip data can only be checked as it is inflated.
  for (const std::string& f : r->files_) {
    if (!fs::is_regular_file(f, ec)) {
      throw Error(fmt::format("{}: cannot open: not a regular file", f));
    }
    if (isGzip(f)) continue;
    const auto size = static_cast<std::int64_t>(fs::file_size(f, ec));
    if (ec) throw Error(fmt::format("{}: cannot read its size: {}", f, ec.message()));
    const std::int64_t need = options.headerBytes + (perSlice ? sliceBytes : sliceBytes * dims[2]);
    if (size < need) {
      throw Error(fmt::format("{}: holds {} bytes, but dims {} of {} after a {}-byte header need {}{}", f, size,
                              dimsText(dims), voxelTypeName(options.type), options.headerBytes, need,
                              perSlice ? " (one slice per file)" : ""));
    }
  }

  VolumeInfo& info = r->info_;
  info.dims = dims;
  info.spacing = options.spacing;
  info.type = options.type;
  info.reader = perSlice ? "raw slices" : "raw";
  info.source = input;
  r->bytes_.resize(static_cast<std::size_t>(sliceBytes));
  return r;
}

RawReader::~RawReader() {
  if (gz_ != nullptr) gzclose(static_cast<gzFile>(gz_));
}

void RawReader::openFile(const std::string& path) {
  if (gz_ != nullptr) {
    gzclose(static_cast<gzFile>(gz_));
    gz_ = nullptr;
  }
  gzFile f = gzopen(path.c_str(), "rb");
  if (f == nullptr) {
    throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
  }
  gzbuffer(f, 1 << 18);
  gz_ = f;
  openPath_ = path;
  if (options_.headerBytes > 0) {
    std::vector<std::byte> skip(static_cast<std::size_t>(std::min<std::int64_t>(options_.headerBytes, 1 << 20)));
    std::int64_t left = options_.headerBytes;
    while (left > 0) {
      const auto n = std::min<std::int64_t>(left, static_cast<std::int64_t>(skip.size()));
      readBytes(path, skip.data(), n, options_.headerBytes - left, options_.headerBytes);
      left -= n;
    }
  }
}

void RawReader::readBytes(const std::string& path, std::byte* dst, std::int64_t n, std::int64_t alreadyRead,
                          std::int64_t expected) {
  auto* f = static_cast<gzFile>(gz_);
  std::int64_t got = 0;
  while (got < n) {
    const auto chunk = static_cast<unsigned>(std::min<std::int64_t>(n - got, 1 << 30));
    const int r = gzread(f, dst + got, chunk);
    if (r < 0) {
      int errnum = 0;
      const char* msg = gzerror(f, &errnum);
      throw Error(fmt::format("{}: cannot read: {}", path, errnum == Z_ERRNO ? std::strerror(errno) : msg));
    }
    if (r == 0) {
      int errnum = 0;
      const char* msg = gzerror(f, &errnum);
      if (errnum != Z_OK && errnum != Z_BUF_ERROR) {
        throw Error(fmt::format("{}: corrupt compressed data: {}", path, msg));
      }
      throw Error(fmt::format("{}: data ends after {} of {} bytes", path, alreadyRead + got, expected));
    }
    got += r;
  }
}

bool RawReader::readSlice(std::span<float> slice) {
  if (nextSlice_ >= info_.dims[2]) return false;
  const bool perSlice = files_.size() > 1 || info_.reader == "raw slices";
  const auto sliceBytes = static_cast<std::int64_t>(bytes_.size());
  std::int64_t expected = options_.headerBytes + sliceBytes * (perSlice ? 1 : info_.dims[2]);
  std::int64_t before = options_.headerBytes + (perSlice ? 0 : nextSlice_ * sliceBytes);
  const std::string& path = files_[perSlice ? static_cast<std::size_t>(nextSlice_) : 0];
  if (gz_ == nullptr || perSlice) openFile(path);
  readBytes(path, bytes_.data(), sliceBytes, before, expected);
  convertToFloat(bytes_, options_.type, options_.byteOrder, slice);
  ++nextSlice_;
  return true;
}

}  // namespace isoslab
