#include "io/image_stack.h"

#include <fmt/format.h>
#include <fnmatch.h>

#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "core/modules.h"
#include "io/file_list.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

std::string lowerExt(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

bool isGlob(const std::string& s) {
  return s.find_first_of("*?[") != std::string::npos;
}

std::vector<std::string> expandGlob(const std::string& pattern) {
  const fs::path p(pattern);
  const std::string folder = p.parent_path().empty() ? "." : p.parent_path().string();
  const std::string name = p.filename().string();
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; it != end; it.increment(ec)) {
    if (ec) break;
    const std::string n = it->path().filename().string();
    if (it->is_regular_file(ec) && fnmatch(name.c_str(), n.c_str(), 0) == 0) names.push_back(n);
  }
  if (names.empty()) throw Error(fmt::format("{}: the pattern matches no file", pattern));
  std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) { return naturalLess(a, b); });
  std::vector<std::string> paths;
  for (const std::string& n : names) paths.push_back((fs::path(folder) / n).string());
  return paths;
}

std::vector<std::string> stackFiles(const std::vector<std::string>& inputs) {
  std::vector<std::string> files;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      for (const std::string& f : listFolder(in)) {
        if (isImageFile(f)) files.push_back(f);
      }
    } else if (!fs::exists(in, ec) && isSlicePattern(in)) {
      const auto found = expandPattern(in);
      files.insert(files.end(), found.begin(), found.end());
    } else if (!fs::exists(in, ec) && isGlob(in)) {
      const auto found = expandGlob(in);
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(in);
    }
  }
  return files;
}

using OpenFunction = SliceSource* (*)(const std::vector<std::string>*, const ImageStackOptions*,
                                      std::vector<std::string>*, std::string*);

}  // namespace

bool isImageFile(const std::string& path) {
  static const char* kExts[] = {".tif", ".tiff", ".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm",
                                ".pnm", ".exr",  ".hdr", ".tga", ".webp", ".jp2", ".sgi"};
  const std::string e = lowerExt(path);
  return std::any_of(std::begin(kExts), std::end(kExts), [&](const char* x) { return e == x; });
}

bool isImageStack(const std::vector<std::string>& inputs) {
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      bool any = false;
      for (fs::directory_iterator it(in, ec), end; it != end && !any; it.increment(ec)) {
        any = it->is_regular_file(ec) && isImageFile(it->path().string());
      }
      if (!any) return false;
    } else if (!isImageFile(in)) {
      return false;
    }
  }
  return !inputs.empty();
}

std::unique_ptr<SliceSource> openImageStack(const std::vector<std::string>& inputs, const ImageStackOptions& options,
                                            std::vector<std::string>* notes) {
  const auto files = stackFiles(inputs);
  if (files.empty()) throw Error(fmt::format("{}: no image file found", inputs.front()));
  std::string error;
  const auto open =
      reinterpret_cast<OpenFunction>(moduleSymbol(LoadableModule::kOiio, "isoslab_open_image_stack", "image stacks"));
  SliceSource* source = open(&files, &options, notes, &error);
  if (source == nullptr) throw Error(error);
  return std::unique_ptr<SliceSource>(source);
}

}  // namespace isoslab

#if defined(__SANITIZE_ADDRESS__)
// OpenImageIO 2.4's PNG reader leaks the string of its error message when libpng longjmps out of
// a truncated file (a standalone OpenImageIO program leaks it too). Sanitizer builds suppress
// leaks from inside OpenImageIO only; this object is in every program that reads image stacks.
extern "C" __attribute__((visibility("default"), used)) const char* __lsan_default_suppressions() {
  return "leak:libOpenImageIO.so\n";
}
// ... and do not print the table of suppressions used, which would be a second stderr line.
extern "C" __attribute__((visibility("default"), used)) const char* __lsan_default_options() {
  return "print_suppressions=0";
}
#endif
