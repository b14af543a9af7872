// Picks a mesh writer by the output's extension.
#pragma once

#include <memory>
#include <string>

#include "extract/mesh_sink.h"

namespace isoslab {

/// A writer whose bytes() can be asked after finish().
class MeshFileSink : public MeshSink {
 public:
  virtual std::int64_t bytes() const noexcept = 0;
};

/// .ply or .stl (case-insensitive). Throws isoslab::Error for any other extension.
std::unique_ptr<MeshFileSink> makeMeshWriter(const std::string& path);

}  // namespace isoslab
