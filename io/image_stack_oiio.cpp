// OpenImageIO image stacks, built as a module that the io library loads on first use: linking
// OpenImageIO pulls in some 250 libraries whose start-up costs about 120 MiB of resident memory,
// which every other input would pay too.
#include "io/image_stack.h"

#include <fmt/format.h>
#include <fnmatch.h>

#include <OpenImageIO/imageio.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <string_view>

#include "core/error.h"
#include "core/limits.h"
#include "io/file_list.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

// Libraries under OpenImageIO (libpng above all) print their own diagnostics on stderr, and
// OpenImageIO's messages run over several lines. Both go into isoslab's one-line error instead:
// stderr (fd 2) is captured while an OpenImageIO call runs, and the lines are joined.
class StderrCapture {
 public:
  StderrCapture() {
    std::fflush(stderr);
    file_ = ::memfd_create("isoslab-stderr", MFD_CLOEXEC);
    if (file_ < 0) return;
    saved_ = ::dup(2);
    if (saved_ < 0 || ::dup2(file_, 2) < 0) {
      restore();
      return;
    }
  }
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture& operator=(const StderrCapture&) = delete;
  ~StderrCapture() { finish(); }

  // Restores stderr and returns what was written to it meanwhile. isoslab's own lines (another
  // thread's progress or warnings) are passed on to the real stderr.
  std::string finish() {
    if (file_ < 0) return {};
    std::fflush(stderr);
    std::string text;
    if (saved_ >= 0) {
      ::dup2(saved_, 2);
      if (::lseek(file_, 0, SEEK_SET) == 0) {
        char buffer[4096];
        for (ssize_t n; text.size() < 65536 && (n = ::read(file_, buffer, sizeof buffer)) > 0;) {
          text.append(buffer, static_cast<std::size_t>(n));
        }
      }
    }
    restore();
    std::string library;
    std::size_t start = 0;
    while (start < text.size()) {
      std::size_t end = text.find('\n', start);
      if (end == std::string::npos) end = text.size();
      const std::string line = text.substr(start, end - start + (end < text.size() ? 1 : 0));
      if (line.find("isoslab") != std::string::npos) {
        std::fputs(line.c_str(), stderr);
      } else {
        library += line;
      }
      start = end + 1;
    }
    return library;
  }

 private:
  void restore() {
    if (saved_ >= 0) ::close(saved_);
    if (file_ >= 0) ::close(file_);
    saved_ = file_ = -1;
  }
  int file_ = -1;
  int saved_ = -1;
};

// One capture at a time: fd 2 is process-wide.
std::mutex& captureMutex() {
  static std::mutex mutex;
  return mutex;
}

// Runs one OpenImageIO call with stderr captured; *noise gets what the libraries printed.
template <typename F>
auto quietly(std::string* noise, F&& call) {
  std::lock_guard lock(captureMutex());
  StderrCapture capture;
  auto result = call();
  *noise += capture.finish();
  return result;
}

// One line from OpenImageIO's messages and the libraries' stderr: lines trimmed, the libraries'
// "libpng error: " and OpenImageIO's "PNG read error: " prefixes dropped, OpenImageIO's closing
// "PNG library error" (which says nothing the line before it does not) dropped, and a line
// dropped when another holds it.
std::string oneLine(const std::string& text, const std::string& fallback) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    for (const char* prefix : {"libpng error: ", "libpng warning: ", "PNG read error: "}) {
      if (line.rfind(prefix, 0) == 0) line = line.substr(std::strlen(prefix));
    }
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
    while (!line.empty() && std::isspace(static_cast<unsigned char>(line.front()))) line.erase(0, 1);
    if (!line.empty() && line != "PNG library error") lines.push_back(line);
    start = end + 1;
  }
  std::string out;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    bool held = false;
    for (std::size_t j = 0; j < lines.size() && !held; ++j) {
      held = j != i && lines[j].find(lines[i]) != std::string::npos && (lines[j] != lines[i] || j < i);
    }
    if (held) continue;
    if (!out.empty()) out += "; ";
    out += lines[i];
  }
  if (out.empty()) return fallback;
  if (out.size() > 400) out = out.substr(0, 400) + "...";
  return out;
}

std::string oiioError(const std::string& objectError, const std::string& noise, const std::string& fallback) {
  return oneLine(objectError + "\n" + OIIO::geterror() + "\n" + noise, fallback);
}

// "PATH: the PNG data is truncated or corrupt: DETAIL" for a PNG whose pixels fail to read (libpng
// stops at the first bad or missing byte, so it cannot tell the two apart), or "PATH: cannot read
// the pixels: DETAIL" for another format.
std::string pixelsError(const std::string& path, const OIIO::ImageInput& in, const std::string& detail) {
  if (std::string_view(in.format_name()) == "png") {
    return fmt::format("{}: the PNG data is truncated or corrupt: {}", path, detail);
  }
  return fmt::format("{}: cannot read the pixels: {}", path, detail);
}

std::string baseTypeName(OIIO::TypeDesc t) {
  return OIIO::TypeDesc(static_cast<OIIO::TypeDesc::BASETYPE>(t.basetype)).c_str();
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
      std::string noise;
      auto in = quietly(&noise, [&] { return OIIO::ImageInput::open(path); });
      if (!in) throw Error(fmt::format("{}: cannot read the image: {}", path, oiioError("", noise, "unknown format")));
      for (int sub = 0;; ++sub) {
        if (!quietly(&noise, [&] { return in->seek_subimage(sub, 0); })) {
          // Past the last page OpenImageIO 2.4's TIFF reader leaves libtiff's message (which varies:
          // the file's name, or "Out of memory"), so only the first page's failure is an error; a
          // page whose pixels are cut short fails when it is read.
          const std::string e = in->geterror();
          if (sub > 0) break;
          throw Error(fmt::format("{}: cannot read the image: {}", path, oiioError(e, noise, "unknown error")));
        }
        const OIIO::ImageSpec& spec = in->spec();
        const std::string page = sub > 0 ? fmt::format("{} page {}", path, sub + 1) : path;
        const int bits = spec.get_int_attribute("oiio:BitsPerSample", static_cast<int>(spec.format.size() * 8));
        if (pages_.empty()) {
          // The header's counts, before anything is allocated; a slice needs 2x2 pixels for a cell.
          if (spec.width < 2 || spec.height < 2) {
            throw Error(fmt::format("{}: the image is {}x{} pixels; every axis needs at least 2 points", page,
                                    spec.width, spec.height));
          }
          if (std::int64_t{spec.width} * spec.height > limits::kMaxSliceVoxels) {
            throw Error(fmt::format("{}: the image is {}x{} pixels; a slice of {} points exceeds the limit of {}", page,
                                    spec.width, spec.height, std::int64_t{spec.width} * spec.height,
                                    limits::kMaxSliceVoxels));
          }
          if (spec.nchannels < 1 || spec.nchannels > limits::kMaxComponents) {
            throw Error(
                fmt::format("{}: {} channels; the limit is 1 to {}", page, spec.nchannels, limits::kMaxComponents));
          }
          width_ = spec.width;
          height_ = spec.height;
          channels_ = spec.nchannels;
          stored_ = spec.format;
          bits_ = bits;
          format_ = spec.format.basetype == OIIO::TypeDesc::HALF ? OIIO::TypeDesc(OIIO::TypeDesc::FLOAT) : spec.format;
          const auto type = voxelTypeOf(format_);
          if (!type) throw Error(fmt::format("{}: pixel type {} is not supported", path, spec.format.c_str()));
          info_.type = *type;
          firstPath_ = path;
          resolution = resolutionOf(spec);
        } else if (spec.width != width_ || spec.height != height_ || spec.nchannels != channels_) {
          throw Error(fmt::format("{}: {}x{} with {} channels, but {} is {}x{} with {} channels", page, spec.width,
                                  spec.height, spec.nchannels, firstPath_, width_, height_, channels_));
        } else if (spec.format.basetype != stored_.basetype || bits != bits_) {
          // OpenImageIO would convert them to the first one's type, scaling the values.
          throw Error(
              fmt::format("{}: {}-bit samples ({}), but {} has {}-bit samples ({}); a stack needs one pixel type", page,
                          bits, baseTypeName(spec.format), firstPath_, bits_, baseTypeName(stored_)));
        }
        pages_.push_back({path, sub});
      }
      if (const std::string e = in->geterror(); !e.empty()) {
        throw Error(fmt::format("{}: cannot read the image: {}", path, oiioError(e, noise, "unknown error")));
      }
      in->close();
    }
    if (pages_.size() < 2)
      throw Error(fmt::format("{}: an image stack needs at least 2 slices, found {}", files.front(), pages_.size()));
    if (options.channel >= channels_) throw Error(fmt::format("`channel`: {} has {} channels", firstPath_, channels_));
    info_.dims = {width_, height_, static_cast<std::int64_t>(pages_.size())};
    validateDims(info_.dims, firstPath_);
    info_.reader = "image stack";
    info_.source = files.size() == 1 ? files.front() : fs::path(files.front()).parent_path().string();
    std::string spacingNote;
    if (options.spacing) {
      info_.spacing = *options.spacing;
      info_.spacingFields = {"--spacing", "--spacing", "--spacing"};
      spacingNote = "from `spacing`";
    } else if (resolution) {
      info_.spacing = {(*resolution)[0], (*resolution)[1], 1.0};
      info_.spacingFields = {"the resolution tags", "the resolution tags", "spacing"};
      spacingNote = fmt::format("x, y {:g} {:g} mm from the resolution tags, z 1 (give `spacing` for z)",
                                (*resolution)[0], (*resolution)[1]);
    } else {
      spacingNote = "1 1 1 (no resolution tags; give `spacing`)";
    }
    if (notes != nullptr) {
      notes->push_back(fmt::format("image stack of {} slices, {}x{}, {} channel{}; spacing {}", pages_.size(), width_,
                                   height_, channels_, channels_ == 1 ? "" : "s", spacingNote));
    }
    const auto samples =
        static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_) * static_cast<std::size_t>(channels_);
    try {
      buffer_.resize(samples * format_.size());
      samples_.resize(samples);
    } catch (const std::bad_alloc&) {
      throw Error(fmt::format("{}: out of memory for a slice of {}x{} pixels with {} channels", firstPath_, width_,
                              height_, channels_));
    }
  }

  const VolumeInfo& info() const noexcept override { return info_; }

  // Pages are read by index (read_image takes the subimage), so skipped ones are not decoded.
  std::int64_t skipSlices(std::int64_t n) override {
    const std::int64_t count = std::clamp<std::int64_t>(n, 0, static_cast<std::int64_t>(pages_.size() - next_));
    next_ += static_cast<std::size_t>(count);
    return count;
  }

  bool readSlice(std::span<float> out) override {
    if (next_ >= pages_.size()) return false;
    const Page& page = pages_[next_++];
    std::string noise;
    if (!in_ || openPath_ != page.path) {
      in_.reset();
      openPath_.clear();
      in_ = quietly(&noise, [&] { return OIIO::ImageInput::open(page.path); });
      if (!in_) {
        throw Error(fmt::format("{}: cannot read the image: {}", page.path, oiioError("", noise, "unknown format")));
      }
      openPath_ = page.path;
    }
    const bool read =
        quietly(&noise, [&] { return in_->read_image(page.subimage, 0, 0, channels_, format_, buffer_.data()); });
    // A truncated TIFF reads "successfully", with the missing strips left as they were, but leaves
    // its errors behind: any message at all means the pixels are not all there.
    if (const std::string e = in_->geterror(); !read || !e.empty()) {
      const std::string message = pixelsError(page.path, *in_, oiioError(e, noise, "unknown error"));
      in_.reset();
      openPath_.clear();
      throw Error(message);
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
  OIIO::TypeDesc stored_;  // the first page's sample type, as stored
  int bits_ = 0;           // and its bits per sample
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
  } catch (const isoslab::Error& e) {
    *error = e.what();
  } catch (const std::bad_alloc&) {
    *error = files->front() + ": out of memory while opening the image stack";
  } catch (const std::exception& e) {
    *error = files->front() + ": cannot read the image stack: " + e.what();
  }
  return nullptr;
}
