#include "io/volume_writer.h"

#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"

namespace isoslab {
namespace {

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// Bytes into the file, plain or through a gzip/zlib deflate stream.
class Sink {
 public:
  Sink(AtomicFile& file, int windowBits) : file_(file), deflating_(windowBits != 0) {
    if (deflating_ && deflateInit2(&z_, 6, Z_DEFLATED, windowBits, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
      throw Error(fmt::format("{}: cannot start compressing", file.path()));
    }
    out_.resize(1 << 18);
  }
  ~Sink() {
    if (deflating_) deflateEnd(&z_);
  }
  void write(const void* data, std::size_t n, int flush = Z_NO_FLUSH) {
    if (!deflating_) {
      file_.write(data, n);
      return;
    }
    z_.next_in = static_cast<Bytef*>(const_cast<void*>(data));
    z_.avail_in = static_cast<uInt>(n);
    do {
      z_.next_out = out_.data();
      z_.avail_out = static_cast<uInt>(out_.size());
      deflate(&z_, flush);
      file_.write(out_.data(), out_.size() - z_.avail_out);
    } while (z_.avail_out == 0 || (flush == Z_FINISH && z_.avail_in > 0));
  }
  void finish() {
    if (deflating_) write(nullptr, 0, Z_FINISH);
  }

 private:
  AtomicFile& file_;
  bool deflating_;
  z_stream z_{};
  std::vector<unsigned char> out_;
};

void swapBytes(std::vector<std::byte>& bytes, std::size_t size) {
  if (size == 1) return;
  for (std::size_t i = 0; i < bytes.size(); i += size)
    std::reverse(bytes.begin() + static_cast<std::ptrdiff_t>(i), bytes.begin() + static_cast<std::ptrdiff_t>(i + size));
}

// Axis a's vector (direction * spacing) and the origin, in the source's frame.
std::array<double, 3> axis(const VolumeInfo& info, int a) {
  return {info.direction[static_cast<std::size_t>(a)] * info.spacing[static_cast<std::size_t>(a)],
          info.direction[static_cast<std::size_t>(3 + a)] * info.spacing[static_cast<std::size_t>(a)],
          info.direction[static_cast<std::size_t>(6 + a)] * info.spacing[static_cast<std::size_t>(a)]};
}

// A NIfTI-1 header (352 bytes with the empty extension flag), sform from the geometry (LPS to RAS).
std::vector<unsigned char> niftiHeader(const VolumeInfo& info, VoxelType type) {
  std::vector<unsigned char> h(352, 0);
  auto put = [&h](std::size_t at, auto v) { std::memcpy(h.data() + at, &v, sizeof v); };
  put(0, std::int32_t{348});
  put(40, std::int16_t{3});
  for (std::size_t a = 0; a < 3; ++a) put(42 + 2 * a, static_cast<std::int16_t>(info.dims[a]));
  for (std::size_t a = 3; a < 7; ++a) put(42 + 2 * a, std::int16_t{1});
  put(70, voxelTypeCodes(type).nifti);
  put(72, static_cast<std::int16_t>(8 * voxelSize(type)));
  put(76, 1.0f);
  for (std::size_t a = 0; a < 3; ++a) put(80 + 4 * a, static_cast<float>(info.spacing[a]));
  put(108, 352.0f);
  put(112, 1.0f);
  put(123, static_cast<char>(2));  // millimetres
  put(254, std::int16_t{2});       // sform: aligned to another file's frame
  const double flip[3] = {-1, -1, 1};
  for (std::size_t r = 0; r < 3; ++r) {
    for (int a = 0; a < 3; ++a)
      put(280 + 16 * r + 4 * static_cast<std::size_t>(a), static_cast<float>(flip[r] * axis(info, a)[r]));
    put(280 + 16 * r + 12, static_cast<float>(flip[r] * info.origin[r]));
  }
  std::memcpy(h.data() + 344, "n+1\0", 4);
  return h;
}

}  // namespace

std::int64_t writeVolume(SliceSource& source, const std::string& path, const VolumeWriteOptions& options) {
  const VolumeInfo& info = source.info();
  AtomicFile file(path);
  const bool nifti = endsWith(path, ".nii") || endsWith(path, ".nii.gz");
  const bool nrrd = endsWith(path, ".nrrd");
  const bool mha = endsWith(path, ".mha");
  ByteOrder order = options.byteOrder;
  if (nifti) order = hostByteOrder();
  int window = 0;
  if (nifti && endsWith(path, ".gz")) window = 15 + 16;
  if (nrrd && options.compress) window = 15 + 16;
  if (mha && options.compress) window = 15;
  const std::size_t size = voxelSize(options.type);
  // Compressed MetaImage: MetaIO (VTK's vtkMetaImageReader, ITK) inflates LOCAL data only when the
  // header gives CompressedDataSize, so a fixed-width field is written, and filled in once the
  // data is (left at zeros on an output that cannot seek, a FIFO or device).
  std::int64_t sizeField = -1;
  std::int64_t dataStart = 0;
  if (nrrd) {
    std::string h = "NRRD0004\n# isoslab\n";
    h += fmt::format("type: {}\ndimension: 3\nsizes: {} {} {}\n", voxelTypeCodes(options.type).nrrd, info.dims[0],
                     info.dims[1], info.dims[2]);
    h += "space: left-posterior-superior\nspace directions:";
    for (int a = 0; a < 3; ++a) {
      const auto v = axis(info, a);
      h += fmt::format(" ({:.17g},{:.17g},{:.17g})", v[0], v[1], v[2]);
    }
    h += fmt::format("\nspace origin: ({:.17g},{:.17g},{:.17g})\n", info.origin[0], info.origin[1], info.origin[2]);
    h += fmt::format("endian: {}\nencoding: {}\n\n", order == ByteOrder::kBig ? "big" : "little",
                     options.compress ? "gzip" : "raw");
    file.write(h.data(), h.size());
  } else if (mha) {
    std::string h = "ObjectType = Image\nNDims = 3\nBinaryData = True\n";
    h += fmt::format("BinaryDataByteOrderMSB = {}\nCompressedData = {}\n", order == ByteOrder::kBig ? "True" : "False",
                     options.compress ? "True" : "False");
    if (options.compress) {
      h += "CompressedDataSize = ";
      sizeField = static_cast<std::int64_t>(h.size());
      h += std::string(20, '0') + "\n";
    }
    h += "TransformMatrix =";
    for (int a = 0; a < 3; ++a)
      h +=
          fmt::format(" {:.17g} {:.17g} {:.17g}", info.direction[static_cast<std::size_t>(a)],
                      info.direction[static_cast<std::size_t>(3 + a)], info.direction[static_cast<std::size_t>(6 + a)]);
    h += fmt::format("\nOffset = {:.17g} {:.17g} {:.17g}\n", info.origin[0], info.origin[1], info.origin[2]);
    h += fmt::format("ElementSpacing = {:.17g} {:.17g} {:.17g}\n", info.spacing[0], info.spacing[1], info.spacing[2]);
    h += fmt::format("DimSize = {} {} {}\nElementType = {}\nElementDataFile = LOCAL\n", info.dims[0], info.dims[1],
                     info.dims[2], voxelTypeCodes(options.type).metaImage);
    file.write(h.data(), h.size());
    dataStart = static_cast<std::int64_t>(h.size());
  }
  Sink sink(file, window);
  if (nifti) {
    const auto h = niftiHeader(info, options.type);
    sink.write(h.data(), h.size());
  }
  std::vector<float> slice;
  std::vector<std::byte> bytes;
  while (readSliceInto(source, slice)) {
    bytes.resize(slice.size() * size);
    throwIfInterrupted();
    convertFromFloat(slice, options.type, bytes);
    if (order != hostByteOrder()) swapBytes(bytes, size);
    sink.write(bytes.data(), bytes.size());
  }
  sink.finish();
  if (sizeField >= 0 && !file.direct()) {
    const std::int64_t end = file.size();
    const std::string digits = fmt::format("{:020}", end - dataStart);
    file.seek(sizeField);
    file.write(digits.data(), digits.size());
    file.seek(end);
  }
  throwIfInterrupted();  // a signal after the last slice: the output must not appear
  file.commit();
  return file.size();
}

}  // namespace isoslab
