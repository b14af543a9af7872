#include "io/volume_file.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "io/error.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

// A file's bytes from an offset, plain or inflated as they are read.
class ByteStream {
 public:
  ByteStream(const std::string& path, std::int64_t offset, Compression compression) : path_(path) {
    file_ = std::fopen(path.c_str(), "rb");
    if (file_ == nullptr) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
    if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0) {
      throw Error(fmt::format("{}: cannot seek to byte {}: {}", path, offset, std::strerror(errno)));
    }
    inflating_ = compression == Compression::kDeflate;
    if (compression == Compression::kAutoGzip) {
      unsigned char magic[2] = {0, 0};
      const std::size_t n = std::fread(magic, 1, 2, file_);
      inflating_ = n == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
      std::fseek(file_, static_cast<long>(offset), SEEK_SET);
    }
    if (inflating_) {
      std::memset(&z_, 0, sizeof z_);
      if (inflateInit2(&z_, 15 + 32) != Z_OK) throw Error(fmt::format("{}: cannot start inflating", path));
      input_.resize(1 << 18);
    }
  }
  ~ByteStream() {
    if (inflating_) inflateEnd(&z_);
    if (file_ != nullptr) std::fclose(file_);
  }
  ByteStream(const ByteStream&) = delete;
  ByteStream& operator=(const ByteStream&) = delete;

  bool inflating() const noexcept { return inflating_; }

  /// Reads exactly n bytes; `expected` (the stream's whole length) is for the message when short.
  void read(void* dst, std::int64_t n, std::int64_t expected) {
    auto* out = static_cast<unsigned char*>(dst);
    std::int64_t got = 0;
    while (got < n) {
      const std::int64_t want = n - got;
      std::int64_t r = 0;
      if (!inflating_) {
        r = static_cast<std::int64_t>(std::fread(out + got, 1, static_cast<std::size_t>(want), file_));
        if (r == 0) {
          if (std::ferror(file_)) throw Error(fmt::format("{}: cannot read: {}", path_, std::strerror(errno)));
          short_(got, expected);
        }
      } else {
        if (ended_) short_(got, expected);
        if (z_.avail_in == 0) {
          z_.avail_in = static_cast<uInt>(std::fread(input_.data(), 1, input_.size(), file_));
          z_.next_in = input_.data();
          if (z_.avail_in == 0) {
            if (std::ferror(file_)) throw Error(fmt::format("{}: cannot read: {}", path_, std::strerror(errno)));
            throw Error(fmt::format("{}: the compressed data is truncated after {} of {} bytes", path_, position_ + got,
                                    expected));
          }
        }
        z_.next_out = out + got;
        z_.avail_out = static_cast<uInt>(std::min<std::int64_t>(want, 1 << 30));
        const int status = inflate(&z_, Z_NO_FLUSH);
        if (status != Z_OK && status != Z_STREAM_END && status != Z_BUF_ERROR) {
          throw Error(
              fmt::format("{}: corrupt compressed data: {}", path_, z_.msg != nullptr ? z_.msg : "inflate failed"));
        }
        r = static_cast<std::int64_t>(z_.next_out - (out + got));
        if (status == Z_STREAM_END) ended_ = true;
      }
      got += r;
    }
    position_ += n;
  }

  void skip(std::int64_t n, std::int64_t expected) {
    std::vector<unsigned char> scratch(static_cast<std::size_t>(std::min<std::int64_t>(n, 1 << 20)));
    while (n > 0) {
      const std::int64_t k = std::min<std::int64_t>(n, static_cast<std::int64_t>(scratch.size()));
      read(scratch.data(), k, expected);
      n -= k;
    }
  }

 private:
  [[noreturn]] void short_(std::int64_t got, std::int64_t expected) {
    throw Error(fmt::format("{}: data ends after {} of {} bytes", path_, position_ + got, expected));
  }

  std::string path_;
  std::FILE* file_ = nullptr;
  bool inflating_ = false;
  bool ended_ = false;
  z_stream z_{};
  std::vector<unsigned char> input_;
  std::int64_t position_ = 0;
};

bool startsWithGzip(const std::string& path, std::int64_t offset) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return false;
  unsigned char magic[2] = {0, 0};
  const bool ok = std::fseek(f, static_cast<long>(offset), SEEK_SET) == 0 && std::fread(magic, 1, 2, f) == 2;
  std::fclose(f);
  return ok && magic[0] == 0x1f && magic[1] == 0x8b;
}

std::string dimsText(const std::array<std::int64_t, 3>& d) {
  return fmt::format("{}x{}x{}", d[0], d[1], d[2]);
}

class VolumeFileSource final : public SliceSource {
 public:
  VolumeFileSource(const VolumeInfo& info, const VolumeFileLayout& layout) : info_(info), layout_(layout) {
    validateDims(info_.dims, layout.files.empty() ? info_.source : layout.files.front());
    if (layout.files.empty()) throw Error(fmt::format("{}: no data file", info_.source));
    if (layout.perSlice && static_cast<std::int64_t>(layout.files.size()) < info_.dims[2]) {
      throw Error(fmt::format("{}: dims {} need {} slice files but only {} exist", info_.source, dimsText(info_.dims),
                              info_.dims[2], layout.files.size()));
    }
    const auto voxel = static_cast<std::int64_t>(voxelSize(layout.type)) * layout.components;
    sliceBytes_ = info_.dims[0] * info_.dims[1] * voxel;
    for (std::size_t f = 0; f < (layout.perSlice ? static_cast<std::size_t>(info_.dims[2]) : 1); ++f) {
      const std::string& path = layout.files[f];
      std::error_code ec;
      if (!fs::is_regular_file(path, ec)) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(ENOENT)));
      if (layout.compression == Compression::kDeflate ||
          (layout.compression == Compression::kAutoGzip && startsWithGzip(path, layout.fileOffset))) {
        continue;  // checked as the stream is inflated
      }
      const auto size = static_cast<std::int64_t>(fs::file_size(path, ec));
      const std::int64_t need =
          layout.fileOffset + layout.skipBytes + (layout.perSlice ? sliceBytes_ : sliceBytes_ * info_.dims[2]);
      if (size < need) {
        throw Error(fmt::format("{}: holds {} bytes, but dims {} of {} after a {}-byte header need {}{}", path, size,
                                dimsText(info_.dims), voxelTypeName(layout.type), layout.fileOffset + layout.skipBytes,
                                need, layout.perSlice ? " (one slice per file)" : ""));
      }
    }
    bytes_.resize(static_cast<std::size_t>(sliceBytes_));
    if (layout.components > 1)
      component_.resize(
          static_cast<std::size_t>(info_.sliceVoxels() * static_cast<std::int64_t>(voxelSize(layout.type))));
  }

  const VolumeInfo& info() const noexcept override { return info_; }

  bool readSlice(std::span<float> slice) override {
    if (next_ >= info_.dims[2]) return false;
    const bool perSlice = layout_.perSlice;
    const std::size_t f = perSlice ? static_cast<std::size_t>(next_) : 0;
    const std::int64_t expected = layout_.skipBytes + sliceBytes_ * (perSlice ? 1 : info_.dims[2]);
    if (!stream_ || perSlice) {
      stream_ = std::make_unique<ByteStream>(layout_.files[f], layout_.fileOffset, layout_.compression);
      if (layout_.skipBytes > 0) stream_->skip(layout_.skipBytes, expected);
    }
    stream_->read(bytes_.data(), sliceBytes_, expected);
    std::span<const std::byte> data(bytes_);
    if (layout_.components > 1) {
      const std::size_t size = voxelSize(layout_.type);
      for (std::int64_t v = 0; v < info_.sliceVoxels(); ++v) {
        std::memcpy(component_.data() + static_cast<std::size_t>(v) * size,
                    bytes_.data() + (static_cast<std::size_t>(v) * static_cast<std::size_t>(layout_.components) +
                                     static_cast<std::size_t>(layout_.component)) *
                                        size,
                    size);
      }
      data = component_;
    }
    convertToFloat(data, layout_.type, layout_.byteOrder, slice);
    if (layout_.slope != 1 || layout_.intercept != 0) {
      for (float& v : slice) v = static_cast<float>(v * layout_.slope + layout_.intercept);
    }
    ++next_;
    return true;
  }

 private:
  VolumeInfo info_;
  VolumeFileLayout layout_;
  std::int64_t sliceBytes_ = 0;
  std::vector<std::byte> bytes_;
  std::vector<std::byte> component_;
  std::unique_ptr<ByteStream> stream_;
  std::int64_t next_ = 0;
};

}  // namespace

std::unique_ptr<SliceSource> openVolumeFile(const VolumeInfo& info, const VolumeFileLayout& layout) {
  return std::make_unique<VolumeFileSource>(info, layout);
}

}  // namespace isoslab
