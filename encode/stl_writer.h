// Binary STL, streamed: triangles are written as they come and the count is patched on finish().
// STL has no shared vertices and no vertex normals; facet normals come from the triangles.
#pragma once

#include <memory>
#include <string>

#include "core/atomic_file.h"
#include "encode/mesh_writer.h"

namespace isoslab {

class StlWriter final : public MeshFileSink {
 public:
  explicit StlWriter(std::string path);
  ~StlWriter() override;

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  std::int64_t bytes() const noexcept override { return bytes_; }

 private:
  std::string path_;
  std::unique_ptr<AtomicFile> file_;
  VertexWindow window_;
  std::uint64_t triangles_ = 0;
  std::int64_t bytes_ = 0;
  std::vector<char> buffer_;
};

}  // namespace isoslab
