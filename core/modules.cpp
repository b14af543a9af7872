#include "core/modules.h"

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
  std::string path;    // the file loaded, or the one the variable named
  std::string errors;  // the loader's reason for the last file that would not load
  bool named = false;  // the variable named the file: nothing else is tried
};

// The module's file name and the variable that may name its path.
struct ModuleName {
  const char* file;
  const char* variable;
  const char* library;  // what it holds, for messages
};
constexpr ModuleName kNames[] = {{"libisoslab_oiio.so", "ISOSLAB_OIIO_MODULE", "OpenImageIO"},
                                 {"libisoslab_dicom.so", "ISOSLAB_DICOM_MODULE", "DICOM"},
                                 {"libisoslab_mpi.so", "ISOSLAB_MPI_MODULE", "MPI"},
                                 {"libisoslab_3mf.so", "ISOSLAB_3MF_MODULE", "3MF"}};

Module load(const ModuleName& name) {
  Module m;
  std::vector<std::string> candidates;
  if (const char* env = std::getenv(name.variable); env != nullptr && *env != 0) {
    // A file the user named is the one to load, or the reason it cannot be is the error.
    m.named = true;
    m.path = env;
    m.handle = ::dlopen(env, RTLD_NOW | RTLD_LOCAL);
    if (m.handle == nullptr) {
      const char* why = ::dlerror();
      m.errors = why != nullptr ? why : "cannot be loaded";
    }
    return m;
  }
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
    for (const char* relative : {ISOSLAB_MODULE_RELATIVE_DIRS}) {
      candidates.push_back((place / relative / name.file).lexically_normal().string());
    }
  }
  // The build tree's module, for the build tree's own programs, tests and Python module only: an
  // installed copy must not load a module of another build.
  const fs::path build(ISOSLAB_BUILD_DIR);
  for (const fs::path& place : places) {
    const fs::path inside = place.lexically_normal().lexically_relative(build);
    if (!inside.empty() && *inside.begin() != "..") {
      candidates.push_back((fs::path(ISOSLAB_MODULE_BUILD_DIR) / name.file).string());
      break;
    }
  }
  for (const std::string& path : candidates) {
    if (!fs::exists(path, ec)) continue;
    m.handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (m.handle != nullptr) {
      m.path = path;
      return m;
    }
    const char* why = ::dlerror();
    m.errors = why != nullptr ? why : "cannot be loaded";
  }
  return m;
}

const Module& module(LoadableModule which) {
  switch (which) {
    case LoadableModule::kOiio: {
      static const Module oiio = load(kNames[0]);
      return oiio;
    }
    case LoadableModule::kDicom: {
      static const Module dicom = load(kNames[1]);
      return dicom;
    }
    case LoadableModule::kThreeMf: {
      static const Module threeMf = load(kNames[3]);
      return threeMf;
    }
    case LoadableModule::kMpi:
      break;
  }
  static const Module mpi = load(kNames[2]);
  return mpi;
}

}  // namespace

void* moduleSymbol(LoadableModule which, const char* symbol, const char* what) {
  const Module& m = module(which);
  void* address = m.handle != nullptr ? ::dlsym(m.handle, symbol) : nullptr;
  if (address == nullptr) {
    const ModuleName& name = kNames[static_cast<std::size_t>(which)];
    const std::string needs = std::string(what) + " need the " + name.library + " module " + name.file;
    if (m.handle != nullptr) throw Error(needs + ", but " + m.path + " lacks its entry " + symbol);
    if (m.named) throw Error(needs + ", but $" + name.variable + " names one that cannot be loaded: " + m.errors);
    throw Error(needs + (m.errors.empty() ? ", which was not found" : ", which could not be loaded: " + m.errors));
  }
  return address;
}

}  // namespace isoslab
