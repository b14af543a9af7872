// Owners for output files: an output that appears complete or not at all, and an anonymous spool.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace isoslab {

class CommitGroup;

/// A stdio buffer of its own for a file that AtomicFile or SpoolFile writes (glibc's own is one
/// block, 4 KiB, whatever setvbuf asks without a buffer). Large while few are in use in the process,
/// so that a run with a file per label does not spend its memory on them.
class IoBuffer {
 public:
  IoBuffer() = default;
  IoBuffer(IoBuffer&& other) noexcept;
  IoBuffer& operator=(IoBuffer&&) = delete;
  IoBuffer(const IoBuffer&) = delete;
  IoBuffer& operator=(const IoBuffer&) = delete;
  ~IoBuffer();
  /// Gives `file` a buffer: a large one of this object's while the process's budget allows (it must
  /// outlive the file), else the default.
  void attach(std::FILE* file);

 private:
  std::unique_ptr<char[]> data_;
  std::size_t size_ = 0;
};

/// The folder that holds `path` (its parent path), or "." when `path` names none: where an
/// output's temporary and spool files go.
std::string folderOf(const std::string& path);

/// Makes `path` a folder, creating it and any missing parents. Throws isoslab::Error
/// "PATH: cannot create the output folder: REASON" when it cannot, naming the part of the path
/// that is a file rather than a folder if that is why (never the standard library's own text).
void makeOutputFolder(const std::string& path);

/// A file written under a temporary name in the destination's folder and renamed to the
/// destination by commit(). If it is destroyed without commit() (an error, an exception), the
/// temporary file is removed and the destination is left as it was. Move-only; every failure
/// throws isoslab::Error naming the destination.
///
/// The destination is never replaced by anything but a regular file:
/// - a symbolic link is followed, and its final target is replaced (the temporary file lives in the
///   target's folder), so the link stays;
/// - an existing non-regular file (a character device such as /dev/null or /dev/stdout, a FIFO, a
///   socket) is opened and written directly, since there is nothing to rename: such an output is
///   not atomic, and seek() on it fails unless the file is seekable;
/// - a folder is an error.
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
  /// Makes room for `bytes` at the start of the file: what was written moves up by `bytes`, the
  /// write position goes to 0, and the caller writes the first `bytes` bytes before commit(). Where
  /// the file system can (ext4 and XFS: FALLOC_FL_INSERT_RANGE, with `bytes` a multiple of its
  /// block size, 4096 on most, and the file not empty), the data stays where it is on the disk and
  /// only its extents move; elsewhere it is copied up, from the end. Not for a direct output.
  /// Returns whether the data was moved without a copy.
  bool insertFront(std::int64_t bytes);
  /// Flushes, closes and renames onto the destination. Throws on any failure, removing the
  /// temporary file. While a CommitGroup is active, the rename is left to the group.
  void commit();
  /// True when the destination is written directly (a device or FIFO), not through a rename.
  bool direct() const noexcept { return direct_; }

  const std::string& path() const noexcept { return path_; }

 private:
  [[noreturn]] void fail(const char* what);
  [[noreturn]] void failWith(int err, const char* what);
  // The background flush (see write()): a detached thread, started when none of this file's is
  // running, waited for before the file's data moves or it closes. Its error, if any, fails the
  // next write or the commit.
  struct Flush;
  void startFlush();
  void joinFlush();
  void checkFlush();

  std::string path_;
  std::string target_;  // path_ with symbolic links resolved: what is replaced
  std::string tempPath_;
  bool direct_ = false;
  IoBuffer buffer_;  // declared before file_: destroyed after it is closed
  std::FILE* file_ = nullptr;
  std::int64_t size_ = 0;
  std::int64_t position_ = 0;
  std::int64_t written_ = 0;  // bytes before this were handed to the disk's write-behind
  static constexpr std::int64_t kWriteBehindBytes = std::int64_t{4} << 20;
  std::shared_ptr<Flush> flush_;  // shared with the flush's thread
};

/// Outputs that appear together or not at all. While a group is active (it is process-wide; one at
/// a time), AtomicFile::commit() completes each file under its temporary name and hands the rename
/// to the group. commit() then renames them all, in the order they were staged; the destructor
/// removes every temporary not renamed (an error or an interruption before the group's commit).
/// The renames are not one atomic step, but each is a rename within one folder, which fails only
/// when the folder itself goes away. Thread-safe: writers may commit from their own threads.
class CommitGroup {
 public:
  CommitGroup();
  CommitGroup(const CommitGroup&) = delete;
  CommitGroup& operator=(const CommitGroup&) = delete;
  ~CommitGroup();

  /// Renames every staged file into place; throws isoslab::Error naming the first that fails (the
  /// rest are then removed).
  void commit();

 private:
  friend class AtomicFile;
  struct Staged {
    std::string path;      // as the user named it, for messages
    std::string target;    // what the rename replaces
    std::string tempPath;  // the completed temporary file
  };
  /// Takes over a completed temporary file; false when no group is active.
  static bool stage(Staged staged);

  std::mutex mutex_;
  std::vector<Staged> staged_;
};

/// A scratch file in a chosen folder, unlinked as soon as it is created so that it disappears
/// whatever happens to the process. Written sequentially, then read back from the start: copied
/// into an output (the writers' spools), or read in pieces (a rank's parts, stream/pipeline.cpp).
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
  /// Ends the writing and goes back to the start: read() then returns what was written, in order.
  /// Nothing may be written after a rewind.
  void rewind();
  /// The next `size` bytes written. Throws isoslab::Error if fewer are left.
  void read(void* data, std::size_t size);
  /// Copies the whole spool to `out` (after a rewind).
  void copyTo(AtomicFile& out);

 private:
  std::string owner_;
  IoBuffer buffer_;
  std::FILE* file_ = nullptr;
  std::int64_t size_ = 0;  // bytes written
  std::int64_t read_ = 0;  // bytes read back since rewind()
};

}  // namespace isoslab
