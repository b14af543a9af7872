// Helpers shared by the libFuzzer targets: a per-process scratch folder, writing the fuzz input to
// files, splitting one input into several files, and running a source through the command line's
// extraction path with sizes capped so that no iteration can legitimately need much memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "io/slice_source.h"

namespace isoslab::fuzz {

using Bytes = std::span<const std::uint8_t>;

/// Separates the files of one fuzz input (a DICOM series, an image stack, a detached header and
/// its data); scripts/make_fuzz_corpus.sh joins seed files with it.
inline constexpr std::string_view kFileSeparator = "\n@@isoslab-fuzz-file@@\n";

/// A fresh, empty folder for this iteration inside this process's scratch folder, which is
/// removed when the process exits.
std::string freshDir();

/// Writes `bytes` to `path`.
void writeFile(const std::string& path, Bytes bytes);

/// Splits `bytes` at kFileSeparator into at most `maxParts` parts (the last keeps the rest).
std::vector<Bytes> splitFiles(Bytes bytes, std::size_t maxParts);

/// Takes the first byte off `bytes` (0 when empty).
std::uint8_t takeByte(Bytes& bytes);

/// A small volume made from the input: its three dims from the next three bytes, each
/// 2 + byte % `span`, of voxel type `type`, read by "fuzz".
VolumeInfo takeVolumeInfo(Bytes& bytes, int span, VoxelType type);

/// Whether a volume of `info` is small enough to read in an iteration: dims are checked by the
/// readers; this only keeps legitimate but large volumes (a gzip bomb, a compressed DICOM that
/// claims 65535 x 65535) out of the fuzzer's memory limit.
bool smallEnough(const VolumeInfo& info);

/// Does what `isoslab extract` does with a source once it is open, with Marching Cubes and one
/// thread, into a mesh statistics sink: reads every slice, then asks for the warnings. Returns
/// without reading when the volume is not smallEnough(). Throws isoslab::Error like the readers.
void extractAll(SliceSource& source);

/// A volume held in memory, for the targets that make their volumes from the input's bytes.
class MemorySource final : public SliceSource {
 public:
  MemorySource(VolumeInfo info, std::vector<float> values) : info_(std::move(info)), values_(std::move(values)) {}
  const VolumeInfo& info() const noexcept override { return info_; }
  bool readSlice(std::span<float> slice) override {
    if (next_ >= info_.dims[2]) return false;
    const auto n = static_cast<std::size_t>(info_.sliceVoxels());
    std::memcpy(slice.data(), values_.data() + n * static_cast<std::size_t>(next_), n * sizeof(float));
    ++next_;
    return true;
  }

 private:
  VolumeInfo info_;
  std::vector<float> values_;
  std::int64_t next_ = 0;
};

/// Aborts with `what` on stderr: a property the fuzzer checks does not hold.
[[noreturn]] void fail(const std::string& what);

}  // namespace isoslab::fuzz
