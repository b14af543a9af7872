#include "io/volume_file.h"

#include <fmt/format.h>
#include <isa-l/igzip_lib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/limits.h"

namespace fs = std::filesystem;

namespace isoslab {

bool startsWithGzipMagic(std::FILE* file) {
  unsigned char magic[2] = {0, 0};
  return std::fread(magic, 1, 2, file) == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
}

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const noexcept { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

// A file's bytes from an offset, plain or inflated as they are read.
class ByteStream {
 public:
  ByteStream(const std::string& path, std::int64_t offset, Compression compression) : path_(path) {
    // file_ owns the FILE*, so a throw below closes it; the inflater is ended by the destructor,
    // or here if the constructor throws after starting it.
    file_.reset(std::fopen(path.c_str(), "rb"));
    if (file_ == nullptr) throw Error(fmt::format("{}: cannot open: {}", path, std::strerror(errno)));
    if (std::fseek(file_.get(), static_cast<long>(offset), SEEK_SET) != 0) {
      throw Error(fmt::format("{}: cannot seek to byte {}: {}", path, offset, std::strerror(errno)));
    }
    const bool gzip = startsWithGzipMagic(file_.get());
    std::fseek(file_.get(), static_cast<long>(offset), SEEK_SET);
    inflating_ = compression == Compression::kDeflate || (compression == Compression::kAutoGzip && gzip);
    kind_ = gzip ? "gzip" : "zlib";
    if (inflating_) {
      // ISA-L's inflate (Intel's igzip), four to five times zlib's speed here; it checks the gzip
      // header, CRC-32 and length, or the zlib header and Adler-32, as zlib does.
      z_ = std::make_unique<inflate_state>();
      isal_inflate_init(z_.get());
      z_->crc_flag = gzip ? ISAL_GZIP : ISAL_ZLIB;
      input_.resize(1 << 18);
    }
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
        r = static_cast<std::int64_t>(std::fread(out + got, 1, static_cast<std::size_t>(want), file_.get()));
        if (r == 0) {
          if (std::ferror(file_.get())) throw Error(fmt::format("{}: cannot read: {}", path_, std::strerror(errno)));
          short_(got, expected);
        }
      } else {
        if (ended_) short_(got, expected);
        // At the end of the file the inflater may still hold output of its own.
        const bool more = z_->avail_in != 0 || refill();
        z_->next_out = out + got;
        z_->avail_out = static_cast<std::uint32_t>(std::min<std::int64_t>(want, 1 << 30));
        inflateSome();
        r = static_cast<std::int64_t>(z_->next_out - (out + got));
        if (r == 0 && !more && !ended_) {
          throw Error(fmt::format("{}: the compressed data is truncated after {} of {} bytes", path_, position_ + got,
                                  expected));
        }
      }
      got += r;
    }
    position_ += n;
  }

  /// Reads a compressed stream to its end, where zlib checks the gzip CRC-32 and length (or the
  /// zlib Adler-32), and returns how many inflated bytes were left over. A corrupt, truncated or
  /// unterminated stream is an error: the bytes read so far cannot be trusted either.
  std::int64_t finish() {
    std::vector<unsigned char> scratch(1 << 16);
    std::int64_t rest = 0;
    while (inflating_ && !ended_) {
      const bool more = z_->avail_in != 0 || refill();
      z_->next_out = scratch.data();
      z_->avail_out = static_cast<std::uint32_t>(scratch.size());
      inflateSome();
      const auto produced = static_cast<std::int64_t>(scratch.size() - z_->avail_out);
      rest += produced;
      if (produced == 0 && !more && !ended_) {
        throw Error(fmt::format("{}: corrupt {} data: the stream is truncated (its end and checksum are missing)",
                                path_, kind_));
      }
    }
    return rest;
  }

  /// Moves on by n bytes: a plain file seeks (its length was checked when it was opened), a
  /// compressed stream inflates them into a scratch buffer.
  void skip(std::int64_t n, std::int64_t expected) {
    if (!inflating_) {
      if (fseeko(file_.get(), static_cast<off_t>(n), SEEK_CUR) != 0) {
        throw Error(fmt::format("{}: cannot seek to byte {}: {}", path_, position_ + n, std::strerror(errno)));
      }
      position_ += n;
      return;
    }
    std::vector<unsigned char> scratch(static_cast<std::size_t>(std::min<std::int64_t>(n, 1 << 20)));
    while (n > 0) {
      const std::int64_t k = std::min<std::int64_t>(n, static_cast<std::int64_t>(scratch.size()));
      read(scratch.data(), k, expected);
      n -= k;
    }
  }

 private:
  // Reads the next piece of compressed input; false at the end of the file.
  bool refill() {
    z_->avail_in = static_cast<std::uint32_t>(std::fread(input_.data(), 1, input_.size(), file_.get()));
    z_->next_in = input_.data();
    if (z_->avail_in == 0 && std::ferror(file_.get())) {
      throw Error(fmt::format("{}: cannot read: {}", path_, std::strerror(errno)));
    }
    return z_->avail_in != 0;
  }

  // Inflates what input there is into the output set; notes the stream's end, and throws on
  // corrupt data with zlib's words for each fault.
  void inflateSome() {
    const int status = isal_inflate(z_.get());
    if (status < 0 || status == ISAL_NEED_DICT) {
      const char* why = status == ISAL_INCORRECT_CHECKSUM   ? "incorrect data check"
                        : status == ISAL_INVALID_WRAPPER    ? "incorrect header check"
                        : status == ISAL_UNSUPPORTED_METHOD ? "unknown compression method"
                        : status == ISAL_INVALID_LOOKBACK   ? "invalid distance too far back"
                        : status == ISAL_NEED_DICT          ? "a preset dictionary is needed"
                        : status == ISAL_INVALID_SYMBOL     ? "invalid code"
                                                            : "invalid block";
      throw Error(fmt::format("{}: corrupt {} data: {}", path_, kind_, why));
    }
    if (z_->block_state == ISAL_BLOCK_FINISH) ended_ = true;
  }

  [[noreturn]] void short_(std::int64_t got, std::int64_t expected) {
    throw Error(fmt::format("{}: data ends after {} of {} bytes", path_, position_ + got, expected));
  }

  std::string path_;
  FilePtr file_;
  const char* kind_ = "gzip";
  bool inflating_ = false;
  bool ended_ = false;
  std::unique_ptr<inflate_state> z_;
  std::vector<unsigned char> input_;
  std::int64_t position_ = 0;
};

bool startsWithGzip(const std::string& path, std::int64_t offset) {
  const FilePtr f(std::fopen(path.c_str(), "rb"));
  if (f == nullptr) return false;
  return std::fseek(f.get(), static_cast<long>(offset), SEEK_SET) == 0 && startsWithGzipMagic(f.get());
}

std::string dimsText(const std::array<std::int64_t, 3>& d) {
  return fmt::format("{}x{}x{}", d[0], d[1], d[2]);
}

// "a 2-byte type (u16 or i16)" for a voxel size that some type has, else empty.
std::string typesOfSize(std::int64_t bytes) {
  std::vector<std::string_view> names;
  for (VoxelType t : {VoxelType::kU8, VoxelType::kI8, VoxelType::kU16, VoxelType::kI16, VoxelType::kU32,
                      VoxelType::kI32, VoxelType::kF32, VoxelType::kF64}) {
    if (static_cast<std::int64_t>(voxelSize(t)) == bytes) names.push_back(voxelTypeName(t));
  }
  if (names.empty()) return {};
  std::string list(names.front());
  for (std::size_t n = 1; n < names.size(); ++n)
    list += fmt::format("{}{}", n + 1 == names.size() ? " or " : ", ", names[n]);
  return fmt::format("{} {}-byte type ({})", bytes == 8 ? "an" : "a", bytes, list);
}

// What would use every byte of `dataBytes` (the data after the header): the number of slices
// for a whole volume, or a voxel type, or (for one slice) the number of rows. Empty if nothing does.
std::string extraBytesHint(std::int64_t dataBytes, const std::array<std::int64_t, 3>& dims, VoxelType type,
                           bool oneSlice) {
  const auto voxel = static_cast<std::int64_t>(voxelSize(type));
  const std::int64_t voxels = dims[0] * dims[1] * (oneSlice ? 1 : dims[2]);
  if (!oneSlice && dataBytes % (dims[0] * dims[1] * voxel) == 0) {
    return fmt::format("; dims {}x{}x{} would use them all", dims[0], dims[1], dataBytes / (dims[0] * dims[1] * voxel));
  }
  if (dataBytes % voxels == 0 && dataBytes / voxels != voxel) {
    const std::string types = typesOfSize(dataBytes / voxels);
    if (!types.empty()) return fmt::format("; {} would use them all", types);
  }
  if (oneSlice && dataBytes % (dims[0] * voxel) == 0) {
    return fmt::format("; a {}x{} slice would use them all", dims[0], dataBytes / (dims[0] * voxel));
  }
  return {};
}

class VolumeFileSource final : public SliceSource {
 public:
  VolumeFileSource(const VolumeInfo& info, const VolumeFileLayout& layout) : info_(info), layout_(layout) {
    validateDims(info_.dims, layout.files.empty() ? info_.source : layout.files.front());
    if (layout.files.empty()) throw Error(fmt::format("{}: no data file", info_.source));
    validateGeometry(info_, info_.source.empty() ? layout.files.front() : info_.source);
    if (layout.fileOffset < 0 || layout.skipBytes < 0) {
      throw Error(fmt::format("{}: the data starts at a negative offset ({} + {})", layout.files.front(),
                              layout.fileOffset, layout.skipBytes));
    }
    if (layout.perSlice && static_cast<std::int64_t>(layout.files.size()) < info_.dims[2]) {
      throw Error(fmt::format("{}: dims {} need {} slice files but only {} exist", info_.source, dimsText(info_.dims),
                              info_.dims[2], layout.files.size()));
    }
    const auto voxel = static_cast<std::int64_t>(voxelSize(layout.type)) * layout.components;
    sliceBytes_ = info_.dims[0] * info_.dims[1] * voxel;  // validateDims bounds it by 2^30 * 8 * 1024
    if (sliceBytes_ > limits::kMaxSliceBytes) {
      throw Error(fmt::format("{}: one {}x{} slice of {} components of {} takes {} bytes, over the limit of {}",
                              layout.files.front(), info_.dims[0], info_.dims[1], layout.components,
                              voxelTypeName(layout.type), sliceBytes_, limits::kMaxSliceBytes));
    }
    std::int64_t header = 0;
    std::int64_t dataEnd = 0;  // the header and the data of one file
    if (__builtin_add_overflow(layout.fileOffset, layout.skipBytes, &header) ||
        __builtin_mul_overflow(sliceBytes_, layout.perSlice ? 1 : info_.dims[2], &dataEnd) ||
        __builtin_add_overflow(dataEnd, header, &dataEnd)) {
      throw Error(fmt::format("{}: a header of {} + {} bytes and dims {} of {} overflow any file size",
                              layout.files.front(), layout.fileOffset, layout.skipBytes, dimsText(info_.dims),
                              voxelTypeName(layout.type)));
    }
    std::int64_t longFiles = 0;  // plain files with bytes left over
    std::string firstLong;
    std::int64_t firstLongSize = 0;
    for (std::size_t f = 0; f < (layout.perSlice ? static_cast<std::size_t>(info_.dims[2]) : 1); ++f) {
      const std::string& path = layout.files[f];
      std::error_code ec;
      if (!fs::is_regular_file(path, ec)) {
        throw Error(fs::exists(path, ec)
                        ? fmt::format("{}: not a regular file (FIFOs, devices and folders are not read)", path)
                        : fmt::format("{}: cannot open: {}", path, std::strerror(ENOENT)));
      }
      if (layout.compression == Compression::kDeflate ||
          (layout.compression == Compression::kAutoGzip && startsWithGzip(path, layout.fileOffset))) {
        continue;  // checked as the stream is inflated
      }
      const auto size = static_cast<std::int64_t>(fs::file_size(path, ec));
      const std::int64_t need = dataEnd;
      if (size < need) {
        throw Error(fmt::format("{}: holds {} bytes, but dims {} of {} after a {}-byte header need {}{}", path, size,
                                dimsText(info_.dims), voxelTypeName(layout.type), layout.fileOffset + layout.skipBytes,
                                need, layout.perSlice ? " (one slice per file)" : ""));
      }
      if (layout.warnExtraBytes && size > need && ++longFiles == 1) {
        firstLong = path;
        firstLongSize = size;
      }
    }
    if (longFiles > 0 && !layout.perSlice) {
      warnings_.push_back(extraBytesWarning(firstLong, firstLongSize, false));
    } else if (longFiles > 0) {
      const std::string others = longFiles == 1 ? std::string()
                                 : longFiles == info_.dims[2]
                                     ? fmt::format(", as do all {} slice files", longFiles)
                                     : fmt::format(", as do {} of the {} slice files", longFiles, info_.dims[2]);
      const std::int64_t need = header + sliceBytes_;
      warnings_.push_back(fmt::format(
          "{}: holds {} bytes, {} more than one {}x{} slice of {}{} needs{}; the extra bytes are ignored{}", firstLong,
          firstLongSize, firstLongSize - need, info_.dims[0], info_.dims[1], voxelTypeName(layout.type), headerText(),
          others, extraBytesHint(firstLongSize - header, info_.dims, layout.type, true)));
    }
    // The slice's buffers are allocated by fetchSlice, as its data arrives.
  }

  const VolumeInfo& info() const noexcept override { return info_; }

  std::vector<std::string> warnings() override { return warnings_; }

  // Per-slice files are not opened; a plain volume file seeks; a compressed one is inflated (and,
  // once it has been skipped to its end, checked as readSlice checks it). A fetched slice counts
  // as the first one skipped.
  std::int64_t skipSlices(std::int64_t n) override {
    if (n > 0 && fetched_) {
      fetched_ = false;
      ++next_;
      return 1 + skipSlices(n - 1);
    }
    const std::int64_t count = std::clamp<std::int64_t>(n, 0, info_.dims[2] - next_);
    if (count == 0 || layout_.perSlice) {
      next_ += count;
      return count;
    }
    const std::int64_t expected = layout_.skipBytes + sliceBytes_ * info_.dims[2];
    openVolumeStream(expected);
    if (!stream_->inflating()) {
      stream_->skip(sliceBytes_ * count, expected);
      next_ += count;
      return count;
    }
    for (std::int64_t k = 0; k < count; ++k) {
      throwIfInterrupted();
      stream_->skip(sliceBytes_, expected);
      ++next_;
    }
    if (next_ == info_.dims[2]) finishStream(expected);
    return count;
  }

  // Reads the next slice's bytes. A compressed stream may hold fewer bytes than the header
  // promises, so the first slice's buffer grows as the stream yields them: data that ends early
  // fails holding about what it found, not a whole slice. A plain file's length was checked when it
  // was opened, so its buffer takes the whole slice at once.
  bool fetchSlice() override {
    if (fetched_) return true;
    if (next_ >= info_.dims[2]) return false;
    const bool perSlice = layout_.perSlice;
    const std::size_t f = perSlice ? static_cast<std::size_t>(next_) : 0;
    const std::int64_t expected = layout_.skipBytes + sliceBytes_ * (perSlice ? 1 : info_.dims[2]);
    if (!stream_ || perSlice) openStream(layout_.files[f], expected);
    std::int64_t got = 0;
    while (got < sliceBytes_) {
      if (bytesSize_ < sliceBytes_) {
        growBytes(stream_->inflating() ? std::min(sliceBytes_, std::max(kFirstReadBytes, 2 * got)) : sliceBytes_, got);
      }
      const std::int64_t n = std::min(bytesSize_, sliceBytes_) - got;
      stream_->read(bytes_.get() + got, n, expected);
      got += n;
    }
    // The last slice of a compressed stream: read it to its end, where its CRC is checked.
    if (stream_->inflating() && (perSlice || next_ + 1 == info_.dims[2])) finishStream(expected);
    fetched_ = true;
    return true;
  }

  bool readSlice(std::span<float> slice) override {
    if (!fetchSlice()) return false;
    fetched_ = false;
    std::span<const std::byte> data(bytes_.get(), static_cast<std::size_t>(sliceBytes_));
    if (layout_.components > 1) {
      if (component_.empty()) {
        try {
          component_.resize(
              static_cast<std::size_t>(info_.sliceValues() * static_cast<std::int64_t>(voxelSize(layout_.type))));
        } catch (const std::exception&) {  // std::bad_alloc, std::length_error
          throw Error(fmt::format("{}: out of memory for one slice of {} bytes", layout_.files.front(), sliceBytes_));
        }
      }
      // One component, or (component -1) every one as a plane of its own.
      const std::size_t size = voxelSize(layout_.type);
      const auto voxels = static_cast<std::size_t>(info_.sliceVoxels());
      const auto components = static_cast<std::size_t>(layout_.components);
      const std::size_t first = layout_.component < 0 ? 0 : static_cast<std::size_t>(layout_.component);
      const std::size_t end = layout_.component < 0 ? components : first + 1;
      for (std::size_t c = first; c < end; ++c) {
        std::byte* plane = component_.data() + (c - first) * voxels * size;
        for (std::size_t v = 0; v < voxels; ++v) {
          std::memcpy(plane + v * size, bytes_.get() + (v * components + c) * size, size);
        }
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
  // The first step of a compressed first slice's buffer; it doubles from there.
  static constexpr std::int64_t kFirstReadBytes = std::int64_t{1} << 20;

  // Makes the slice buffer `size` bytes, keeping its first `kept`. The new bytes are not
  // initialised, so memory is committed only as the stream fills them.
  void growBytes(std::int64_t size, std::int64_t kept) {
    try {
      auto bigger = std::make_unique_for_overwrite<std::byte[]>(static_cast<std::size_t>(size));
      if (kept > 0) std::memcpy(bigger.get(), bytes_.get(), static_cast<std::size_t>(kept));
      bytes_ = std::move(bigger);
      bytesSize_ = size;
    } catch (const std::exception&) {  // std::bad_alloc, std::length_error
      throw Error(fmt::format("{}: out of memory for one slice of {} bytes", layout_.files.front(), sliceBytes_));
    }
  }

  VolumeInfo info_;
  VolumeFileLayout layout_;
  std::int64_t sliceBytes_ = 0;
  std::unique_ptr<std::byte[]> bytes_;  // the stored slice, bytesSize_ bytes (sliceBytes_ once filled)
  std::int64_t bytesSize_ = 0;
  bool fetched_ = false;  // bytes_ holds slice next_, not yet converted
  std::vector<std::byte> component_;
  // " after a 16-byte header", or empty without one.
  std::string headerText() const {
    const std::int64_t header = layout_.fileOffset + layout_.skipBytes;
    return header > 0 ? fmt::format(" after a {}-byte header", header) : std::string();
  }

  // The warning for a whole-volume file of `size` bytes (inflated ones if `inflated`).
  std::string extraBytesWarning(const std::string& path, std::int64_t size, bool inflated) const {
    const std::int64_t header = layout_.fileOffset + layout_.skipBytes;
    const std::int64_t need = header + sliceBytes_ * info_.dims[2];
    return fmt::format("{}: holds {} bytes{}, {} more than dims {} of {}{} need; the extra bytes are ignored{}", path,
                       size, inflated ? " once inflated" : "", size - need, dimsText(info_.dims),
                       voxelTypeName(layout_.type), headerText(),
                       extraBytesHint(size - header, info_.dims, layout_.type, false));
  }

  void openStream(const std::string& path, std::int64_t expected) {
    stream_ = std::make_unique<ByteStream>(path, layout_.fileOffset, layout_.compression);
    if (layout_.skipBytes > 0) stream_->skip(layout_.skipBytes, expected);
  }

  // The whole-volume file's stream, opened on first use.
  void openVolumeStream(std::int64_t expected) {
    if (!stream_) openStream(layout_.files.front(), expected);
  }

  // Reads a compressed stream to its end (its CRC is checked there) and counts what is left over.
  void finishStream(std::int64_t expected) {
    const std::int64_t rest = stream_->finish();
    if (layout_.warnExtraBytes && !layout_.perSlice && rest > 0) {
      warnings_.push_back(extraBytesWarning(layout_.files.front(), expected + rest, true));
    }
  }

  std::unique_ptr<ByteStream> stream_;
  std::int64_t next_ = 0;
  std::vector<std::string> warnings_;
};

}  // namespace

std::unique_ptr<SliceSource> openVolumeFile(const VolumeInfo& info, const VolumeFileLayout& layout) {
  return std::make_unique<VolumeFileSource>(info, layout);
}

}  // namespace isoslab
