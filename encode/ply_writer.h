// Binary little-endian PLY, streamed: the faces (most of the bytes) go straight to the output and
// the vertices to a spool file beside it until the counts are known; finish() makes room before the
// faces (without copying them where the file system can move extents), writes the header and the
// vertices there, and renames the file into place. A device or a pipe gets the vertices straight
// after a reserved header and the faces through the spool.
#pragma once

#include <memory>
#include <string>

#include "core/atomic_file.h"
#include "encode/mesh_writer.h"

namespace isoslab {

class PlyWriter final : public MeshFileSink {
 public:
  /// Nothing is created until begin().
  explicit PlyWriter(std::string path);
  ~PlyWriter() override;

  void begin(const MeshHeader& header) override;
  void consume(const MeshChunk& chunk) override;
  void finish() override;

  /// Size of the binary PLY this writer makes for a mesh of these counts (to a file; a device
  /// output's header is padded otherwise).
  static std::int64_t binaryBytes(std::uint64_t vertices, std::uint64_t triangles, const MeshHeader& header);

  /// Size of the finished file.
  std::int64_t bytes() const noexcept override { return bytes_; }

 private:
  /// The header, padded with comment lines to exactly `padTo` bytes (at least the bare header
  /// plus 8); a `padTo` no larger than the bare header gives the bare header.
  std::string header(std::uint64_t vertices, std::uint64_t faces, std::size_t padTo) const;
  /// The header of a file written faces first: padded so that it and the vertices fill whole
  /// blocks of 4 KiB.
  std::string blockHeader(std::uint64_t vertices, std::uint64_t faces) const;

  std::string path_;
  MeshHeader meshHeader_;
  std::unique_ptr<AtomicFile> file_;
  std::unique_ptr<SpoolFile> spool_;  // the vertices, or the faces of a direct output
  bool facesFirst_ = true;
  std::size_t reserved_ = 0;
  std::uint64_t vertices_ = 0;
  std::uint64_t faceCount_ = 0;
  std::int64_t bytes_ = 0;
  std::unique_ptr<char[]> buffer_;  // a batch of records, filled in place (never zeroed first)
};

}  // namespace isoslab
