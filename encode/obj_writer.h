// Wavefront OBJ, streamed: each chunk's vertices ("v", and "vn" with normals) then its faces.
#pragma once

#include <memory>
#include <string>

#include "core/atomic_file.h"
#include "encode/mesh_writer.h"

namespace isoslab {

class ObjWriter final : public MeshFileSink {
 public:
  explicit ObjWriter(std::string path);
  ~ObjWriter() override;
  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;
  std::int64_t bytes() const noexcept override { return bytes_; }

 private:
  std::string path_;
  bool normals_ = false;
  std::unique_ptr<AtomicFile> file_;
  std::int64_t bytes_ = 0;
  std::string buffer_;
};

}  // namespace isoslab
