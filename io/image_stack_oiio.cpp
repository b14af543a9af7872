// OpenImageIO image stacks, built as a module that the io library loads on first use: linking
// OpenImageIO pulls in some 250 libraries whose start-up costs about 120 MiB of resident memory,
// which every other input would pay too.
#include "io/image_stack.h"

#include <fmt/format.h>
#include <fnmatch.h>

#include <OpenImageIO/imageio.h>
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "io/file_list.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

std::string oiioError(const std::string& fallback) {
  std::string e = OIIO::geterror();
  if (e.empty()) return fallback;
  std::replace(e.begin(), e.end(), '\n', ' ');
  while (!e.empty() && e.back() == ' ') e.pop_back();
  return e;
}

std::optional<VoxelType> voxelTypeOf(OIIO::TypeDesc t) {
  switch (t.basetype) {
    case OIIO::TypeDesc::UINT8:
      return VoxelType::kU8;
    case OIIO::TypeDesc::INT8:
      return VoxelType::kI8;
    case OIIO::TypeDesc::UINT16:
      return VoxelType::kU16;
    case OIIO::TypeDesc::INT16:
      return VoxelType::kI16;
    case OIIO::TypeDesc::UINT32:
      return VoxelType::kU32;
    case OIIO::TypeDesc::INT32:
      return VoxelType::kI32;
    case OIIO::TypeDesc::HALF:
    case OIIO::TypeDesc::FLOAT:
      return VoxelType::kF32;
    case OIIO::TypeDesc::DOUBLE:
      return VoxelType::kF64;
    default:
      return std::nullopt;
  }
}

struct Page {
  std::string path;
  int subimage = 0;
};

class ImageStackSource final : public SliceSource {
 public:
  ImageStackSource(std::vector<std::string> files, const ImageStackOptions& options, std::vector<std::string>* notes)
      : options_(options) {
    std::optional<std::array<double, 2>> resolution;
    for (const std::string& path : files) {
      auto in = OIIO::ImageInput::open(path);
      if (!in) throw Error(fmt::format("{}: cannot read the image: {}", path, oiioError("unknown format")));
      for (int sub = 0; in->seek_subimage(sub, 0); ++sub) {
        const OIIO::ImageSpec& spec = in->spec();
        if (pages_.empty()) {
          width_ = spec.width;
          height_ = spec.height;
          channels_ = spec.nchannels;
          format_ = spec.format.basetype == OIIO::TypeDesc::HALF ? OIIO::TypeDesc(OIIO::TypeDesc::FLOAT) : spec.format;
          const auto type = voxelTypeOf(format_);
          if (!type) throw Error(fmt::format("{}: pixel type {} is not supported", path, spec.format.c_str()));
          info_.type = *type;
          firstPath_ = path;
          resolution = resolutionOf(spec);
        } else if (spec.width != width_ || spec.height != height_ || spec.nchannels != channels_) {
          throw Error(fmt::format("{}: {}x{} with {} channels, but {} is {}x{} with {} channels",
                                  sub > 0 ? fmt::format("{} page {}", path, sub + 1) : path, spec.width, spec.height,
                                  spec.nchannels, firstPath_, width_, height_, channels_));
        }
        pages_.push_back({path, sub});
      }
      in->close();
    }
    if (pages_.size() < 2)
      throw Error(fmt::format("{}: an image stack needs at least 2 slices, found {}", files.front(), pages_.size()));
    if (options.channel >= channels_) throw Error(fmt::format("--channel: {} has {} channels", firstPath_, channels_));
    info_.dims = {width_, height_, static_cast<std::int64_t>(pages_.size())};
    info_.reader = "image stack";
    info_.source = files.size() == 1 ? files.front() : fs::path(files.front()).parent_path().string();
    std::string spacingNote;
    if (options.spacing) {
      info_.spacing = *options.spacing;
      spacingNote = "from --spacing";
    } else if (resolution) {
      info_.spacing = {(*resolution)[0], (*resolution)[1], 1.0};
      spacingNote = fmt::format("x, y {:g} {:g} mm from the resolution tags, z 1 (give --spacing for z)",
                                (*resolution)[0], (*resolution)[1]);
    } else {
      spacingNote = "1 1 1 (no resolution tags; give --spacing)";
    }
    if (notes != nullptr) {
      notes->push_back(fmt::format("image stack of {} slices, {}x{}, {} channel{}; spacing {}", pages_.size(), width_,
                                   height_, channels_, channels_ == 1 ? "" : "s", spacingNote));
    }
    const auto samples =
        static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) * static_cast<std::size_t>(channels_);
    buffer_.resize(samples * format_.size());
    samples_.resize(samples);
  }

  const VolumeInfo& info() const noexcept override { return info_; }

  bool readSlice(std::span<float> out) override {
    if (next_ >= pages_.size()) return false;
    const Page& page = pages_[next_++];
    if (!in_ || openPath_ != page.path) {
      in_ = OIIO::ImageInput::open(page.path);
      if (!in_) throw Error(fmt::format("{}: cannot read the image: {}", page.path, oiioError("unknown format")));
      openPath_ = page.path;
    }
    if (!in_->read_image(page.subimage, 0, 0, channels_, format_, buffer_.data())) {
      throw Error(fmt::format("{}: cannot read the pixels: {}", page.path, oiioError(in_->geterror())));
    }
    const std::size_t n = samples_.size();
    convertToFloat(std::span<const std::byte>(buffer_.data(), buffer_.size()), info_.type, hostByteOrder(), samples_);
    const auto pixels = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
    const auto c = static_cast<std::size_t>(channels_);
    (void)n;
    for (std::size_t p = 0; p < pixels; ++p) {
      const float* s = &samples_[p * c];
      if (options_.channel >= 0) {
        out[p] = s[options_.channel];
      } else if (c >= 3) {
        // A grey pixel keeps its value exactly; colour becomes Rec. 709 luminance.
        out[p] =
            (s[0] == s[1] && s[1] == s[2]) ? s[0] : static_cast<float>(0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]);
      } else {
        out[p] = s[0];  // grey, or grey and alpha
      }
    }
    return true;
  }

 private:
  static std::optional<std::array<double, 2>> resolutionOf(const OIIO::ImageSpec& spec) {
    const float xr = spec.get_float_attribute("XResolution", 0.0f);
    const float yr = spec.get_float_attribute("YResolution", 0.0f);
    if (!(xr > 0) || !(yr > 0)) return std::nullopt;
    const std::string unit = spec.get_string_attribute("ResolutionUnit", "");
    double mmPerUnit = 0;
    if (unit == "in" || unit == "inch") mmPerUnit = 25.4;
    if (unit == "cm") mmPerUnit = 10.0;
    if (unit == "mm") mmPerUnit = 1.0;
    if (mmPerUnit == 0) return std::nullopt;
    return std::array<double, 2>{mmPerUnit / xr, mmPerUnit / yr};
  }

  ImageStackOptions options_;
  VolumeInfo info_;
  std::vector<Page> pages_;
  int width_ = 0, height_ = 0, channels_ = 0;
  OIIO::TypeDesc format_;
  std::string firstPath_;
  std::vector<std::byte> buffer_;
  std::vector<float> samples_;
  std::unique_ptr<OIIO::ImageInput> in_;
  std::string openPath_;
  std::size_t next_ = 0;
};

}  // namespace
}  // namespace isoslab

// The entry point the loader finds with dlsym: opens `files` as a stack. On failure it returns
// null and sets *error; no exception crosses the module boundary.
extern "C" __attribute__((visibility("default"))) isoslab::SliceSource* isoslab_open_image_stack(
    const std::vector<std::string>* files, const isoslab::ImageStackOptions* options, std::vector<std::string>* notes,
    std::string* error) {
  try {
    return new isoslab::ImageStackSource(*files, *options, notes);
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  }
}
