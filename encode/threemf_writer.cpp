#include "encode/threemf_writer.h"

#include <fmt/format.h>

#include <limits>
#include <string_view>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/modules.h"
#include "encode/threemf_module.h"

namespace isoslab {
namespace {

using namespace NMR;

// lib3mf's stream callbacks: 0 is success. An exception must not cross the C library.
struct Sink {
  AtomicFile* file = nullptr;
  std::string error;
};

std::uint32_t writeBytes(unsigned char* data, std::uint32_t size, void* user) {
  auto* sink = static_cast<Sink*>(user);
  try {
    sink->file->write(data, size);
    return 0;
  } catch (const std::exception& e) {
    if (sink->error.empty()) sink->error = e.what();
    return 1;
  }
}

std::uint32_t seekTo(std::uint64_t position, void* user) {
  auto* sink = static_cast<Sink*>(user);
  try {
    sink->file->seek(static_cast<std::int64_t>(position));
    return 0;
  } catch (const std::exception& e) {
    if (sink->error.empty()) sink->error = e.what();
    return 1;
  }
}

// A fixed identity (a version-4 form): `kind` 0 the build, 1 an object, 2 a build item.
std::string uuid(int kind, int index) {
  return fmt::format("{:08x}-0000-4000-8000-{:012x}", kind, index);
}

// A name as an XML attribute can hold it: lib3mf escapes markup but passes on bytes that are no
// UTF-8 and characters that XML 1.0 forbids (C0 controls), which make the model unreadable. Each of
// those becomes U+FFFD, and the name is cut at a character's end to kMaxNameBytes (lib3mf left
// a 5,000-byte name empty).
constexpr std::size_t kMaxNameBytes = 1024;
std::string xmlName(const std::string& name) {
  std::string out;
  const auto* p = reinterpret_cast<const unsigned char*>(name.data());
  const std::size_t n = name.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned char c = p[i];
    const std::size_t length = c < 0x80             ? 1
                               : (c & 0xe0) == 0xc0 ? 2
                               : (c & 0xf0) == 0xe0 ? 3
                               : (c & 0xf8) == 0xf0 ? 4
                                                    : 0;
    std::uint32_t code = length == 1 ? c : length == 2 ? c & 0x1fu : length == 3 ? c & 0x0fu : c & 0x07u;
    bool valid = length > 0 && i + length <= n;
    for (std::size_t k = 1; valid && k < length; ++k) {
      valid = (p[i + k] & 0xc0) == 0x80;
      code = code << 6 | (p[i + k] & 0x3fu);
    }
    // Shortest forms only, no surrogates, and what XML 1.0 allows (tab, newline and return among
    // the controls, which an attribute then reads as spaces: they go too).
    static constexpr std::uint32_t kLeast[5] = {0, 0, 0x80, 0x800, 0x10000};
    valid = valid && code >= kLeast[length] && code <= 0x10ffff && !(code >= 0xd800 && code <= 0xdfff) &&
            code >= 0x20 && code != 0xfffe && code != 0xffff;
    const std::string_view piece = valid ? std::string_view(name).substr(i, length) : std::string_view("\xEF\xBF\xBD");
    if (out.size() + piece.size() > kMaxNameBytes) break;
    out += piece;
    i += valid ? length : 1;
  }
  return out;
}

// lib3mf's functions, from the 3MF module, loaded on first use.
const ThreeMfApi& lib3mf() {
  using Entry = const ThreeMfApi* (*)();
  static const ThreeMfApi* const api =
      reinterpret_cast<Entry>(moduleSymbol(LoadableModule::kThreeMf, kThreeMfModuleEntry, "3MF files"))();
  return *api;
}

// Releases a lib3mf instance at the end of a scope.
struct Released {
  PLib3MFBase* instance = nullptr;
  ~Released() {
    if (instance != nullptr) lib3mf().release(instance);
  }
};

}  // namespace

ThreeMfModel::ThreeMfModel(std::string path) : path_(std::move(path)) {}

ThreeMfModel::~ThreeMfModel() {
  if (materials_ != nullptr) lib3mf().release(materials_);
  if (model_ != nullptr) lib3mf().release(model_);
}

void ThreeMfModel::fail(Handle instance, const char* what) const {
  DWORD code = 0;
  LPCSTR message = nullptr;
  std::string detail;
  if (instance != nullptr && lib3mf().getLastError(instance, &code, &message) == LIB3MF_OK && message != nullptr) {
    detail = fmt::format(": {} (lib3mf error {:#x})", message, code);
  }
  throw Error(fmt::format("{}: cannot {} the 3MF model{}", path_, what, detail));
}

void ThreeMfModel::begin() {
  lib3mf();  // a missing module is said before anything is made
  file_ = std::make_unique<AtomicFile>(path_);
  // A 3MF is a zip package, which lib3mf writes with seeks: a pipe fails here, in one line, not
  // inside lib3mf.
  file_->seek(0);
  if (lib3mf().createModel(&model_) != LIB3MF_OK) fail(nullptr, "create");
  if (lib3mf().setUnit(model_, MODELUNIT_MILLIMETER) != LIB3MF_OK) fail(model_, "set the unit of");
  // The production extension's identities, made up by lib3mf at random, are fixed here: the same
  // run gives the same bytes.
  if (lib3mf().setBuildUuid(model_, uuid(0, 0).c_str()) != LIB3MF_OK) fail(model_, "identify the build of");
}

void ThreeMfModel::addObject(const std::string& given, const std::optional<std::array<std::uint8_t, 3>>& color,
                             const std::vector<Vec3f>& positions, const std::vector<Triangle>& triangles) {
  const std::string name = xmlName(given);
  if (positions.size() > std::numeric_limits<DWORD>::max() || triangles.size() > std::numeric_limits<DWORD>::max()) {
    throw Error(fmt::format("{}: '{}' has more than 2^32 vertices or triangles, which 3MF cannot index", path_, name));
  }
  // An empty surface is no object: 3MF meshes hold triangles (the file then has an empty build).
  if (triangles.empty()) return;
  // The vertices in order of first use: the ones merged away or never used are left out.
  constexpr DWORD kUnused = std::numeric_limits<DWORD>::max();
  std::vector<DWORD> index(positions.size(), kUnused);
  std::vector<MODELMESHVERTEX> vertices;
  std::vector<MODELMESHTRIANGLE> faces(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    throwIfInterruptedEvery(t);
    for (int k = 0; k < 3; ++k) {
      const VertexId v = triangles[t][static_cast<std::size_t>(k)];
      if (index[v] == kUnused) {
        index[v] = static_cast<DWORD>(vertices.size());
        const Vec3f& p = positions[v];
        vertices.push_back(MODELMESHVERTEX{{p.x, p.y, p.z}});
      }
      faces[t].m_nIndices[k] = index[v];
    }
  }
  // lib3mf 1.8 checks each new identity against all before it: time grows with the square of the
  // objects (10,000 took 13 s, 100,000 did not end in 15 minutes).
  if (objects_ >= kMaxObjects) {
    throw Error(
        fmt::format("{}: more than {} surfaces, which a .3mf holds here (lib3mf's time grows with the "
                    "square of the count); write a .glb or a file per label",
                    path_, kMaxObjects));
  }
  Released mesh;
  ++objects_;
  if (lib3mf().addMeshObject(model_, &mesh.instance) != LIB3MF_OK) fail(model_, "add an object to");
  if (lib3mf().setObjectUuid(mesh.instance, uuid(1, objects_).c_str()) != LIB3MF_OK) {
    fail(mesh.instance, "identify an object of");
  }
  if (lib3mf().setObjectName(mesh.instance, name.c_str()) != LIB3MF_OK) fail(mesh.instance, "name an object of");
  if (lib3mf().setGeometry(mesh.instance, vertices.data(), static_cast<DWORD>(vertices.size()), faces.data(),
                           static_cast<DWORD>(faces.size())) != LIB3MF_OK) {
    fail(mesh.instance, "set an object's mesh in");
  }
  if (color) {
    if (materials_ == nullptr) {
      if (lib3mf().addBaseMaterialGroup(model_, &materials_) != LIB3MF_OK) fail(model_, "add materials to");
      DWORD id = 0;
      if (lib3mf().getResourceId(materials_, &id) != LIB3MF_OK) fail(materials_, "add materials to");
      materialGroup_ = id;
    }
    DWORD material = 0;
    const auto [r, g, b] = *color;
    if (lib3mf().addMaterial(materials_, name.c_str(), r, g, b, &material) != LIB3MF_OK) {
      fail(materials_, "add a material to");
    }
    Released handler;
    if (lib3mf().createDefaultPropertyHandler(mesh.instance, &handler.instance) != LIB3MF_OK ||
        lib3mf().setBaseMaterial(handler.instance, materialGroup_, material) != LIB3MF_OK) {
      fail(mesh.instance, "colour an object of");
    }
  }
  Released item;
  if (lib3mf().addBuildItem(model_, mesh.instance, nullptr, &item.instance) != LIB3MF_OK ||
      lib3mf().setBuildItemUuid(item.instance, uuid(2, objects_).c_str()) != LIB3MF_OK) {
    fail(model_, "add a build item to");
  }
}

std::int64_t ThreeMfModel::write() {
  Released writer;
  if (lib3mf().queryWriter(model_, "3mf", &writer.instance) != LIB3MF_OK) fail(model_, "make a writer for");
  Sink sink{file_.get(), {}};
  const auto result = lib3mf().writeToCallback(writer.instance, reinterpret_cast<void*>(&writeBytes),
                                               reinterpret_cast<void*>(&seekTo), &sink);
  if (!sink.error.empty()) throw Error(sink.error);
  if (result != LIB3MF_OK) fail(writer.instance, "write");
  // The model is written: its memory goes before the file is committed.
  lib3mf().release(model_);
  model_ = nullptr;
  const std::int64_t bytes = file_->size();
  file_->commit();
  file_.reset();
  return bytes;
}

ThreeMfWriter::ThreeMfWriter(std::string path)
    : own_(std::make_unique<ThreeMfModel>(std::move(path))), model_(own_.get()), name_("surface") {}

ThreeMfWriter::ThreeMfWriter(ThreeMfModel& model, std::string name, std::array<std::uint8_t, 3> color)
    : model_(&model), name_(std::move(name)), color_(color) {}

ThreeMfWriter::~ThreeMfWriter() = default;

void ThreeMfWriter::begin(const MeshHeader& header) {
  if (own_) {
    model_->begin();
    name_ = fmt::format("isoslab {} iso {}", header.method, header.iso);
  }
}

void ThreeMfWriter::consume(const MeshChunk& chunk) {
  if (!started_) {
    first_ = chunk.firstVertex;
    started_ = true;
  }
  positions_.insert(positions_.end(), chunk.positions.begin(), chunk.positions.end());
  for (const Triangle& t : chunk.triangles) triangles_.push_back({t[0] - first_, t[1] - first_, t[2] - first_});
}

void ThreeMfWriter::finish() {
  model_->addObject(name_, color_, positions_, triangles_);
  std::vector<Vec3f>().swap(positions_);
  std::vector<Triangle>().swap(triangles_);
  if (own_) bytes_ = model_->write();
}

}  // namespace isoslab
