// Owners for output files: an output that appears complete or not at all, and an anonymous spool.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace isoslab {

/// A file written under a temporary name in the destination's folder and renamed to the
/// destination by commit(). If it is destroyed without commit() (an error, an exception), the
/// temporary file is removed and the destination is left as it was. Move-only; every failure
/// throws isoslab::Error naming the destination.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  AtomicFile(AtomicFile&& other) noexcept;
  AtomicFile& operator=(AtomicFile&&) = delete;
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();

  void write(const void* data, std::size_t size);
  /// Moves the write position to `offset` bytes from the start.
  void seek(std::int64_t offset);
  /// Bytes written so far (the current end of file).
  std::int64_t size() const noexcept { return size_; }
  /// Flushes, closes and renames onto the destination. Throws on any failure, removing the
  /// temporary file.
  void commit();

  const std::string& path() const noexcept { return path_; }

 private:
  [[noreturn]] void fail(const char* what);

  std::string path_;
  std::string tempPath_;
  std::FILE* file_ = nullptr;
  std::int64_t size_ = 0;
  std::int64_t position_ = 0;
};

/// A scratch file in a chosen folder, unlinked as soon as it is created so that it disappears
/// whatever happens to the process. Written sequentially, then read back from the start.
class SpoolFile {
 public:
  /// `folder` is where it lives (the output's folder, so that it shares its disk); `owner` names the
  /// output in error messages.
  SpoolFile(const std::string& folder, std::string owner);
  SpoolFile(const SpoolFile&) = delete;
  SpoolFile& operator=(const SpoolFile&) = delete;
  ~SpoolFile();

  void write(const void* data, std::size_t size);
  std::int64_t size() const noexcept { return size_; }
  /// Copies the whole spool to `out`.
  void copyTo(AtomicFile& out);

 private:
  std::string owner_;
  std::FILE* file_ = nullptr;
  std::int64_t size_ = 0;
};

}  // namespace isoslab
