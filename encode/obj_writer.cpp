#include "encode/obj_writer.h"

#include <fmt/format.h>

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
  for (const Vec3f& p : chunk.positions) fmt::format_to(std::back_inserter(buffer_), "v {} {} {}\n", p.x, p.y, p.z);
  if (normals_) {
    for (const Vec3f& n : chunk.normals) fmt::format_to(std::back_inserter(buffer_), "vn {} {} {}\n", n.x, n.y, n.z);
  }
  for (const Triangle& t : chunk.triangles) {
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
