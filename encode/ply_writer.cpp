#include "encode/ply_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/mesh_metadata.h"

namespace isoslab {
namespace {

constexpr std::uint64_t kMaxCount = 4294967295ULL;
// A padding comment line: "comment\n" at least, 80 bytes at most.
constexpr std::size_t kLeastPad = 8;
constexpr std::size_t kLongestPad = 80;

}  // namespace

PlyWriter::PlyWriter(std::string path) : path_(std::move(path)) {}
PlyWriter::~PlyWriter() = default;

std::string PlyWriter::header(std::uint64_t vertices, std::uint64_t faces, std::size_t padTo) const {
  std::string head = "ply\nformat binary_little_endian 1.0\n";
  for (const std::string& line : metadataLines(meshHeader_)) head += "comment " + line + "\n";
  std::string tail = fmt::format("element vertex {}\nproperty float x\nproperty float y\nproperty float z\n", vertices);
  if (meshHeader_.normals) tail += "property float nx\nproperty float ny\nproperty float nz\n";
  tail += fmt::format("element face {}\nproperty list uchar uint vertex_indices\n", faces);
  // A label complex: each face's labels, in front (the side its normal points to) and behind.
  if (meshHeader_.labels) tail += "property int label_front\nproperty int label_back\n";
  tail += "end_header\n";
  // Comment lines of spaces pad the header to exactly padTo bytes (a line is "comment" and up to 72
  // spaces, so that no reader meets a long line); a padTo no larger than the bare header asks for
  // no pad. The pad goes before the counts, which are written last.
  const std::size_t bare = head.size() + tail.size();
  std::size_t pad = padTo - std::min(padTo, bare);
  if (pad > 0 && pad < kLeastPad) throw Error(fmt::format("{}: a PLY header cannot be padded by {} bytes", path_, pad));
  std::string lines;
  while (pad > 0) {
    // The last lines share what is left, each at least a bare "comment\n".
    const std::size_t line = pad <= kLongestPad ? pad : std::min(kLongestPad, pad - kLeastPad);
    lines += "comment";
    lines.append(line - kLeastPad, ' ');
    lines += "\n";
    pad -= line;
  }
  return head + lines + tail;
}

std::string PlyWriter::blockHeader(std::uint64_t vertices, std::uint64_t faces) const {
  // Padded so that the header and the vertices fill whole blocks of 4 KiB: the faces then move up
  // by whole blocks, which ext4 and XFS do without copying them. A fixed unit (not the file
  // system's), so that the bytes are the same on every disk.
  constexpr std::size_t kBlock = 4096;
  const std::size_t vertexBytes = static_cast<std::size_t>(vertices) * (meshHeader_.normals ? 24 : 12);
  const std::size_t bare = header(vertices, faces, 0).size();
  std::size_t pad = (kBlock - (bare + vertexBytes) % kBlock) % kBlock;
  if (pad > 0 && pad < kLeastPad) pad += kBlock;
  return header(vertices, faces, bare + pad);
}

std::int64_t PlyWriter::binaryBytes(std::uint64_t vertices, std::uint64_t triangles, const MeshHeader& header) {
  PlyWriter w("");
  w.meshHeader_ = header;
  const auto headerBytes = static_cast<std::int64_t>(w.blockHeader(vertices, triangles).size());
  return headerBytes + static_cast<std::int64_t>(vertices) * (header.normals ? 24 : 12) +
         static_cast<std::int64_t>(triangles) * (header.labels ? 21 : 13);
}

void PlyWriter::begin(const MeshHeader& header) {
  if constexpr (std::endian::native != std::endian::little) {
    throw Error(fmt::format("{}: PLY output is implemented for little-endian hosts only", path_));
  }
  meshHeader_ = header;
  file_ = std::make_unique<AtomicFile>(path_);
  const std::string folder = std::filesystem::path(path_).parent_path().string();
  spool_ = std::make_unique<SpoolFile>(folder.empty() ? "." : folder, path_);
  // The faces (most of the bytes) go straight to the file, the vertices to the spool; finish() then
  // makes room before the faces for the header and the vertices (AtomicFile::insertFront). A device
  // or a pipe cannot make room: there the vertices go straight to the file after a reserved
  // header, and the faces to the spool.
  facesFirst_ = !file_->direct();
  if (!facesFirst_) {
    // The largest counts' header and room for one pad line, so that any count's header pads to it.
    reserved_ = this->header(kMaxCount, kMaxCount, 0).size() + kLeastPad;
    const std::string blank(reserved_, ' ');
    file_->write(blank.data(), blank.size());
  }
}

namespace {
// Records go out in batches of at most this many bytes: a small buffer, allocated once and reused
// (under malloc's mmap threshold), rather than one the size of the largest chunk.
constexpr std::size_t kBatchBytes = std::size_t{64} << 10;

// Writes `count` records of `size` bytes through `buffer` in batches of kBatchBytes: fill(k, out)
// writes record k at out.
template <class Sink, class Fill>
void writeRecords(std::unique_ptr<char[]>& buffer, Sink& sink, std::size_t count, std::size_t size, Fill fill) {
  if (!buffer) buffer = std::make_unique_for_overwrite<char[]>(kBatchBytes);
  for (std::size_t first = 0; first < count; first += kBatchBytes / size) {
    throwIfInterrupted();  // decode hands over the whole mesh as one chunk
    const std::size_t end = std::min(count, first + kBatchBytes / size);
    char* out = buffer.get();
    for (std::size_t k = first; k < end; ++k, out += size) fill(k, out);
    sink.write(buffer.get(), (end - first) * size);
  }
}
}  // namespace

void PlyWriter::consume(const MeshChunk& chunk) {
  throwIfInterrupted();
  static_assert(sizeof(Vec3f) == 12 && sizeof(Triangle) == 12 && sizeof(LabelPair) == 8);
  AtomicFile& file = *file_;
  SpoolFile& spool = *spool_;
  const auto writeVertices = [&](auto& sink) {
    if (!meshHeader_.normals) {  // the positions are the vertex records as they are
      sink.write(chunk.positions.data(), chunk.positions.size() * sizeof(Vec3f));
      return;
    }
    writeRecords(buffer_, sink, chunk.positions.size(), 24, [&](std::size_t v, char* out) {
      std::memcpy(out, &chunk.positions[v], 12);
      std::memcpy(out + 12, &chunk.normals[v], 12);
    });
  };
  const auto writeFaces = [&](auto& sink) {
    // Each face: its count (3), its ids and, in a label complex, its labels in front and behind.
    const std::size_t record = meshHeader_.labels ? 21 : 13;
    writeRecords(buffer_, sink, chunk.triangles.size(), record, [&](std::size_t n, char* out) {
      *out = 3;
      std::memcpy(out + 1, &chunk.triangles[n], 12);
      if (record == 21) std::memcpy(out + 13, &chunk.faceLabels[n], 8);
    });
  };
  if (facesFirst_) {
    writeVertices(spool);
    writeFaces(file);
  } else {
    writeVertices(file);
    writeFaces(spool);
  }
  vertices_ += chunk.positions.size();
  faceCount_ += chunk.triangles.size();
  if (vertices_ > kMaxCount || faceCount_ > kMaxCount) {
    throw Error(fmt::format("{}: the mesh exceeds PLY's 32-bit counts", path_));
  }
}

void PlyWriter::finish() {
  throwIfInterrupted();  // copying the spool takes a while
  if (facesFirst_) {
    const std::string head = blockHeader(vertices_, faceCount_);
    file_->insertFront(static_cast<std::int64_t>(head.size()) + spool_->size());
    file_->write(head.data(), head.size());
    spool_->copyTo(*file_);
  } else {
    spool_->copyTo(*file_);
    const std::string head = header(vertices_, faceCount_, reserved_);
    file_->seek(0);
    file_->write(head.data(), head.size());
  }
  spool_.reset();
  bytes_ = file_->size();
  file_->commit();
  file_.reset();
}

}  // namespace isoslab
