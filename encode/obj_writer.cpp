#include "encode/obj_writer.h"

#include <fmt/format.h>

#include "core/interrupt.h"
#include "encode/mesh_metadata.h"

namespace isoslab {

ObjWriter::ObjWriter(std::string path) : path_(std::move(path)) {}
ObjWriter::~ObjWriter() = default;

void ObjWriter::begin(const MeshHeader& header) {
  normals_ = header.normals;
  file_ = std::make_unique<AtomicFile>(path_);
  std::string head;
  for (const std::string& line : metadataLines(header)) head += "# " + line + "\n";
  file_->write(head.data(), head.size());
}

void ObjWriter::consume(const MeshChunk& chunk) {
  buffer_.clear();
  // Shortest round-trip formatting keeps every float exact.
  // Formatting is the slowest of the writers' loops; decode hands over the whole mesh as one chunk.
  for (std::size_t v = 0; v < chunk.positions.size(); ++v) {
    throwIfInterruptedEvery(v);
    const Vec3f& p = chunk.positions[v];
    fmt::format_to(std::back_inserter(buffer_), "v {} {} {}\n", p.x, p.y, p.z);
  }
  if (normals_) {
    for (std::size_t v = 0; v < chunk.normals.size(); ++v) {
      throwIfInterruptedEvery(v);
      const Vec3f& n = chunk.normals[v];
      fmt::format_to(std::back_inserter(buffer_), "vn {} {} {}\n", n.x, n.y, n.z);
    }
  }
  for (std::size_t n = 0; n < chunk.triangles.size(); ++n) {
    throwIfInterruptedEvery(n);
    const Triangle& t = chunk.triangles[n];
    if (normals_) {
      fmt::format_to(std::back_inserter(buffer_), "f {0}//{0} {1}//{1} {2}//{2}\n", t[0] + 1ull, t[1] + 1ull,
                     t[2] + 1ull);
    } else {
      fmt::format_to(std::back_inserter(buffer_), "f {} {} {}\n", t[0] + 1ull, t[1] + 1ull, t[2] + 1ull);
    }
  }
  file_->write(buffer_.data(), buffer_.size());
}

void ObjWriter::finish() {
  bytes_ = file_->size();
  file_->commit();
  file_.reset();
}

}  // namespace isoslab
