#include "io/oiio_module.h"

#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

// An object of this file, whose address dladdr maps to the file that holds the code.
const char anchor = 0;

struct Module {
  void* handle = nullptr;
  std::string errors;
};

const Module& module() {
  static const Module loaded = [] {
    Module m;
    std::vector<std::string> candidates;
    if (const char* env = std::getenv("ISOSLAB_OIIO_MODULE")) candidates.emplace_back(env);
    // Installed: relative to the file that holds this code (the program, libisoslab.so or the
    // Python module), then to the program.
    std::error_code ec;
    std::vector<fs::path> places;
    Dl_info self{};
    if (::dladdr(&anchor, &self) != 0 && self.dli_fname != nullptr && fs::path(self.dli_fname).is_absolute()) {
      places.push_back(fs::path(self.dli_fname).parent_path());
    }
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) places.push_back(exe.parent_path());
    for (const fs::path& place : places) {
      for (const char* relative : {ISOSLAB_OIIO_MODULE_RELATIVE_PATHS}) {
        candidates.push_back((place / relative).lexically_normal().string());
      }
    }
    // The build tree's module, for the build tree's own programs, tests and Python module only: an
    // installed copy must not load a module of another build.
    const fs::path build(ISOSLAB_BUILD_DIR);
    for (const fs::path& place : places) {
      const fs::path inside = place.lexically_normal().lexically_relative(build);
      if (!inside.empty() && *inside.begin() != "..") {
        candidates.emplace_back(ISOSLAB_OIIO_MODULE_BUILD_PATH);
        break;
      }
    }
    for (const std::string& path : candidates) {
      if (!fs::exists(path, ec)) continue;
      m.handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (m.handle != nullptr) return m;
      m.errors = ::dlerror();
    }
    return m;
  }();
  return loaded;
}

}  // namespace

void* oiioSymbol(const char* symbol, const char* what) {
  const Module& m = module();
  void* address = m.handle != nullptr ? ::dlsym(m.handle, symbol) : nullptr;
  if (address == nullptr) {
    throw Error(std::string(what) + " need the OpenImageIO module libisoslab_oiio.so, which was not found" +
                (m.errors.empty() ? std::string() : ": " + m.errors));
  }
  return address;
}

}  // namespace isoslab
