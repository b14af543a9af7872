#include "encode/stl_writer.h"

#include <fmt/format.h>

#include <bit>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/binary_buffer.h"
#include "encode/mesh_metadata.h"

namespace isoslab {

StlWriter::StlWriter(std::string path) : path_(std::move(path)) {}
StlWriter::~StlWriter() = default;

void StlWriter::begin(const MeshHeader& header) {
  if constexpr (std::endian::native != std::endian::little) {
    throw Error(fmt::format("{}: STL output is implemented for little-endian hosts only", path_));
  }
  file_ = std::make_unique<AtomicFile>(path_);
  // The 80-byte header must not start with "solid", which marks ASCII STL.
  // 3D Slicer reads SPACE=LPS or SPACE=RAS anywhere in it.
  std::string text = fmt::format("isoslab {} iso {} space {}", header.method, header.iso, header.space);
  const std::string tag = spaceTag(header.space);
  if (!tag.empty()) text += " SPACE=" + tag;
  text.resize(80, ' ');
  file_->write(text.data(), text.size());
  const std::uint32_t zero = 0;
  file_->write(&zero, sizeof zero);
}

void StlWriter::consume(const MeshChunk& chunk) {
  window_.push(chunk);
  buffer_.clear();
  for (std::size_t k = 0; k < chunk.triangles.size(); ++k) {
    throwIfInterruptedEvery(k);  // decode hands over the whole mesh as one chunk
    const Triangle& t = chunk.triangles[k];
    const Vec3f& a = window_.position(t[0]);
    const Vec3f& b = window_.position(t[1]);
    const Vec3f& c = window_.position(t[2]);
    const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
    const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
    double n[3] = {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (double& x : n) x = len > 0 ? x / len : 0.0;
    for (double x : n) appendBytes(buffer_, static_cast<float>(x));
    for (const Vec3f* p : {&a, &b, &c}) {
      appendBytes(buffer_, p->x);
      appendBytes(buffer_, p->y);
      appendBytes(buffer_, p->z);
    }
    appendBytes(buffer_, std::uint16_t{0});
  }
  file_->write(buffer_.data(), buffer_.size());
  triangles_ += chunk.triangles.size();
  if (triangles_ > 4294967295ULL) throw Error(fmt::format("{}: the mesh exceeds STL's 32-bit triangle count", path_));
}

void StlWriter::finish() {
  const auto count = static_cast<std::uint32_t>(triangles_);
  file_->seek(80);
  file_->write(&count, sizeof count);
  bytes_ = file_->size();
  file_->commit();
  file_.reset();
}

}  // namespace isoslab
