#include "core/atomic_file.h"

#include <algorithm>
#include <atomic>
#include <memory>
#include <new>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cassert>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <thread>
#include <utility>
#include <vector>

#include "core/error.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

std::FILE* makeTemp(const std::string& folder, const std::string& stem, std::string& tempPath) {
  std::string name = (fs::path(folder) / ("." + stem + ".tmp.XXXXXX")).string();
  std::vector<char> buf(name.begin(), name.end());
  buf.push_back('\0');
  const int fd = ::mkstemp(buf.data());
  if (fd < 0) return nullptr;
  tempPath.assign(buf.data());
  std::FILE* f = ::fdopen(fd, "w+b");
  if (f == nullptr) {
    ::close(fd);
    ::unlink(tempPath.c_str());
  }
  return f;
}

// The file that a chain of symbolic links ends at (which need not exist yet), or `path` itself.
std::string followLinks(const std::string& path) {
  fs::path p = path;
  std::error_code ec;
  for (int hops = 0; fs::is_symlink(fs::symlink_status(p, ec)); ++hops) {
    if (hops == 40) throw Error(std::string(path) + ": cannot create the output: too many levels of symbolic links");
    const fs::path link = fs::read_symlink(p, ec);
    if (ec) throw Error(std::string(path) + ": cannot read the symbolic link: " + ec.message());
    p = link.is_absolute() ? link : p.parent_path() / link;
  }
  return p.string();
}

std::mutex gGroupMutex;
CommitGroup* gActiveGroup = nullptr;

// Background flushes running in the process: at most two, since the disk takes one at a time.
std::atomic<int> gFlushes{0};
constexpr int kMaxFlushes = 2;

// The bytes of IoBuffer's large buffers in use, and their budget.
std::atomic<std::size_t> gBufferBytes{0};
constexpr std::size_t kLargeBuffer = std::size_t{256} << 10;
constexpr std::size_t kBufferBudget = std::size_t{8} << 20;

}  // namespace

// A background fdatasync's state: whether it has finished, and the errno it failed with (0: none).
// Shared by the file and its thread, which is detached: it ends by itself, and its resources with
// it, whether or not the file waits for it.
struct AtomicFile::Flush {
  std::mutex mutex;
  std::condition_variable finished;
  bool done = true;
  int error = 0;
};

IoBuffer::IoBuffer(IoBuffer&& other) noexcept : data_(std::move(other.data_)), size_(std::exchange(other.size_, 0)) {}

IoBuffer::~IoBuffer() {
  if (size_ != 0) gBufferBytes.fetch_sub(size_);
}

void IoBuffer::attach(std::FILE* file) {
  if (gBufferBytes.fetch_add(kLargeBuffer) + kLargeBuffer <= kBufferBudget) {
    data_.reset(new (std::nothrow) char[kLargeBuffer]);
    if (data_ && std::setvbuf(file, data_.get(), _IOFBF, kLargeBuffer) == 0) {
      size_ = kLargeBuffer;
      return;
    }
    data_.reset();
  }
  gBufferBytes.fetch_sub(kLargeBuffer);
}

void makeOutputFolder(const std::string& path) {
  std::error_code ec;
  fs::create_directories(path, ec);
  const std::error_code created = ec;
  if (!created && fs::is_directory(path, ec)) return;
  // The nearest part of the path that exists: a file there is the usual reason.
  fs::path part = path;
  while (!part.empty() && !fs::exists(fs::symlink_status(part, ec))) part = part.parent_path();
  std::string reason = created ? created.message() : std::strerror(ENOTDIR);
  if (!part.empty() && fs::exists(part, ec) && !fs::is_directory(part, ec)) {
    reason = part == fs::path(path) ? "it is a file, not a folder" : part.string() + " is a file, not a folder";
  }
  throw Error(path + ": cannot create the output folder: " + reason);
}

std::string folderOf(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)), target_(followLinks(path_)) {
  // Something that is not a regular file cannot be replaced by a rename without destroying it
  // (as root, `--report /dev/null` would replace the device node): write to it in place.
  // The kernel follows the links itself: /dev/stdout ends at /proc/self/fd/1, whose target is no
  // path when it is a pipe ("pipe:[N]"), which followLinks cannot follow.
  struct stat st {};
  if (::stat(path_.c_str(), &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode)) {
    const int fd = ::open(path_.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) throw Error(std::string(path_) + ": cannot open the output: " + std::strerror(errno));
    file_ = ::fdopen(fd, "wb");
    if (file_ == nullptr) {
      const int err = errno;
      ::close(fd);
      throw Error(std::string(path_) + ": cannot open the output: " + std::strerror(err));
    }
    direct_ = true;
    buffer_.attach(file_);
    return;
  }
  const std::string folder = folderOf(target_);
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw Error(std::string(path_) + ": cannot create the output: " +
                (fs::exists(folder, ec) ? "'" + folder + "' is a file, not a folder"
                                        : "the folder '" + folder + "' does not exist"));
  }
  if (fs::is_directory(path_, ec)) {
    throw Error(std::string(path_) + ": cannot create the output: it is a folder");
  }
  file_ = makeTemp(folder, fs::path(target_).filename().string(), tempPath_);
  if (file_ == nullptr) {
    throw Error(std::string(path_) + ": cannot create the output: " + std::strerror(errno));
  }
  // mkstemp creates the file private; give the output the permissions a plain creat() would.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(::fileno(file_), 0666 & ~mask);
  buffer_.attach(file_);
}

AtomicFile::AtomicFile(AtomicFile&& other) noexcept
    : path_(std::move(other.path_)),
      target_(std::move(other.target_)),
      tempPath_(std::move(other.tempPath_)),
      direct_(other.direct_),
      buffer_(std::move(other.buffer_)),
      file_(std::exchange(other.file_, nullptr)),
      size_(other.size_),
      position_(other.position_),
      written_(other.written_),
      flush_(std::move(other.flush_)) {}

AtomicFile::~AtomicFile() {
  joinFlush();
  if (file_ != nullptr) {
    std::fclose(file_);
    if (!direct_) ::unlink(tempPath_.c_str());
  }
}

void AtomicFile::fail(const char* what) {
  failWith(errno, what);
}

void AtomicFile::failWith(int err, const char* what) {
  joinFlush();
  if (file_ != nullptr) {
    std::fclose(file_);
    file_ = nullptr;
    if (!direct_) ::unlink(tempPath_.c_str());
  }
  throw Error(std::string(path_) + ": cannot " + what + ": " + std::strerror(err != 0 ? err : EIO));
}

void AtomicFile::write(const void* data, std::size_t size) {
  if (file_ == nullptr) throw Error(std::string(path_) + ": write after close");
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) fail("write");
  position_ += static_cast<std::int64_t>(size);
  size_ = std::max(size_, position_);
  // Every few MiB written in order, the disk is asked to start writing them (not waited for), and
  // a thread of its own makes what was written so far durable (fdatasync) while the caller goes
  // on. commit()'s fsync then waits only for the last few MiB: a disk's flush takes time in
  // proportion to what was written since the last one (about 0.7 ms a MiB on this project's test
  // machine), and so the flushes overlap the work instead of following it. Where the hint cannot
  // be given (a device, a file system without it), nothing changes.
  if (!direct_ && position_ - written_ >= kWriteBehindBytes) {
    if (std::fflush(file_) != 0) fail("write");
    ::sync_file_range(::fileno(file_), written_, position_ - written_, SYNC_FILE_RANGE_WRITE);
    written_ = position_;
    checkFlush();
    startFlush();
  }
}

void AtomicFile::startFlush() {
  if (!flush_) flush_ = std::make_shared<Flush>();
  {
    const std::lock_guard lock(flush_->mutex);
    if (!flush_->done) return;  // the last one still runs: it is enough
  }
  // At most kMaxFlushes threads in the process; a file that finds none free is synced by commit().
  if (gFlushes.fetch_add(1) >= kMaxFlushes) {
    gFlushes.fetch_sub(1);
    return;
  }
  {
    const std::lock_guard lock(flush_->mutex);
    flush_->done = false;
  }
  try {
    std::thread([fd = ::fileno(file_), flush = flush_] {
      const int err = ::fdatasync(fd) != 0 && errno != EINVAL ? errno : 0;
      gFlushes.fetch_sub(1);
      {
        const std::lock_guard lock(flush->mutex);
        if (err != 0) flush->error = err;
        flush->done = true;
      }
      flush->finished.notify_all();
    }).detach();
  } catch (...) {  // no thread to be had (std::system_error, std::bad_alloc): commit() syncs it all
    gFlushes.fetch_sub(1);
    const std::lock_guard lock(flush_->mutex);
    flush_->done = true;
  }
}

void AtomicFile::joinFlush() {
  if (!flush_) return;
  std::unique_lock lock(flush_->mutex);
  flush_->finished.wait(lock, [this] { return flush_->done; });
}

void AtomicFile::checkFlush() {
  if (!flush_) return;
  int err = 0;
  {
    const std::lock_guard lock(flush_->mutex);
    if (flush_->done) err = flush_->error;
  }
  if (err != 0) failWith(err, "write");
}

void AtomicFile::seek(std::int64_t offset) {
  if (file_ == nullptr) throw Error(std::string(path_) + ": seek after close");
  if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0) fail("seek");
  position_ = offset;
  written_ = std::min(written_, offset);
}

bool AtomicFile::insertFront(std::int64_t bytes) {
  if (file_ == nullptr) throw Error(std::string(path_) + ": write after close");
  if (direct_) throw Error(std::string(path_) + ": cannot move data in a device or pipe");
  if (std::fflush(file_) != 0) fail("write");
  joinFlush();
  checkFlush();
  const int fd = ::fileno(file_);
  bool moved = false;
  // The file-size limit (ulimit -f): fallocate does not check it, so a file that would pass it is
  // copied, and the copy's write fails as any write past the limit does.
  struct rlimit limit {};
  const bool underLimit = ::getrlimit(RLIMIT_FSIZE, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY ||
                          static_cast<rlim_t>(size_ + bytes) <= limit.rlim_cur;
  if (bytes > 0 && size_ > 0 && underLimit) {
    // The extents after 0 move up by `bytes`; the file system first writes the data out (most of it
    // is on its way already, through the write-behind), then drops it from the page cache.
    moved = ::fallocate(fd, FALLOC_FL_INSERT_RANGE, 0, bytes) == 0;
  }
  if (!moved && bytes > 0 && size_ > 0) {
    // Copied up, from the end, in 1 MiB steps (a step never overwrites what it has not read yet).
    // A short transfer is retried for the rest, so that a failure reports its own reason (a full
    // disk, the size limit), not whatever errno held before.
    const auto transfer = [&](auto call, char* data, std::size_t n, std::int64_t at) {
      while (n > 0) {
        errno = 0;
        const ssize_t done = call(fd, data, n, at);
        if (done < 0 && errno == EINTR) continue;
        if (done <= 0) {
          if (errno == 0) errno = EIO;
          fail("write");
        }
        data += done;
        n -= static_cast<std::size_t>(done);
        at += done;
      }
    };
    constexpr std::int64_t kStep = std::int64_t{1} << 20;
    const std::unique_ptr<char[]> buf(new char[static_cast<std::size_t>(std::min(kStep, size_))]);
    for (std::int64_t end = size_; end > 0;) {
      const std::int64_t start = std::max<std::int64_t>(0, end - kStep);
      const auto n = static_cast<std::size_t>(end - start);
      transfer([](int f, char* d, std::size_t c, std::int64_t o) { return ::pread(f, d, c, o); }, buf.get(), n, start);
      transfer([](int f, char* d, std::size_t c, std::int64_t o) { return ::pwrite(f, d, c, o); }, buf.get(), n,
               start + bytes);
      end = start;
    }
  }
  size_ += bytes;
  if (std::fseek(file_, 0, SEEK_SET) != 0) fail("seek");
  position_ = 0;
  written_ = 0;
  return moved;
}

void AtomicFile::commit() {
  if (file_ == nullptr) throw Error(std::string(path_) + ": commit after close");
  if (std::fflush(file_) != 0) fail("write");
  if (direct_) {
    if (std::fclose(std::exchange(file_, nullptr)) != 0) {
      throw Error(std::string(path_) + ": cannot write: " + std::strerror(errno));
    }
    return;
  }
  joinFlush();
  checkFlush();
  if (::fsync(::fileno(file_)) != 0 && errno != EINVAL) fail("write");
  std::FILE* f = std::exchange(file_, nullptr);
  if (std::fclose(f) != 0) {
    const int err = errno;
    ::unlink(tempPath_.c_str());
    throw Error(std::string(path_) + ": cannot write: " + std::strerror(err));
  }
  if (CommitGroup::stage({path_, target_, tempPath_})) return;
  if (std::rename(tempPath_.c_str(), target_.c_str()) != 0) {
    const int err = errno;
    ::unlink(tempPath_.c_str());
    throw Error(std::string(path_) + ": cannot rename the finished output into place: " + std::strerror(err));
  }
}

CommitGroup::CommitGroup() {
  const std::lock_guard lock(gGroupMutex);
  assert(gActiveGroup == nullptr);
  gActiveGroup = this;
}

CommitGroup::~CommitGroup() {
  {
    const std::lock_guard lock(gGroupMutex);
    if (gActiveGroup == this) gActiveGroup = nullptr;
  }
  for (const Staged& s : staged_) ::unlink(s.tempPath.c_str());
}

bool CommitGroup::stage(Staged staged) {
  const std::lock_guard lock(gGroupMutex);
  if (gActiveGroup == nullptr) return false;
  const std::lock_guard groupLock(gActiveGroup->mutex_);
  gActiveGroup->staged_.push_back(std::move(staged));
  return true;
}

void CommitGroup::commit() {
  {
    const std::lock_guard lock(gGroupMutex);
    if (gActiveGroup == this) gActiveGroup = nullptr;
  }
  const std::lock_guard lock(mutex_);
  std::vector<Staged> staged = std::exchange(staged_, {});
  for (std::size_t n = 0; n < staged.size(); ++n) {
    if (std::rename(staged[n].tempPath.c_str(), staged[n].target.c_str()) != 0) {
      const int err = errno;
      for (std::size_t m = n; m < staged.size(); ++m) ::unlink(staged[m].tempPath.c_str());
      throw Error(std::string(staged[n].path) +
                  ": cannot rename the finished output into place: " + std::strerror(err));
    }
  }
}

SpoolFile::SpoolFile(const std::string& folder, std::string owner) : owner_(std::move(owner)) {
  std::string tempPath;
  file_ = makeTemp(folder.empty() ? std::string(".") : folder, "isoslab-spool", tempPath);
  if (file_ == nullptr) {
    throw Error(std::string(owner_) + ": cannot create a spool file in '" + folder + "': " + std::strerror(errno));
  }
  ::unlink(tempPath.c_str());
  buffer_.attach(file_);
}

SpoolFile::~SpoolFile() {
  if (file_ != nullptr) std::fclose(file_);
}

void SpoolFile::write(const void* data, std::size_t size) {
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) {
    throw Error(std::string(owner_) + ": cannot write the spool file: " + std::strerror(errno));
  }
  size_ += static_cast<std::int64_t>(size);
}

void SpoolFile::rewind() {
  // The buffer's last bytes are written here: their failure (a full disk, the size limit) is a write's.
  if (std::fflush(file_) != 0) {
    throw Error(std::string(owner_) + ": cannot write the spool file: " + std::strerror(errno));
  }
  if (std::fseek(file_, 0, SEEK_SET) != 0) {
    throw Error(std::string(owner_) + ": cannot read the spool file back: " + std::strerror(errno));
  }
  std::clearerr(file_);
  read_ = 0;
}

void SpoolFile::read(void* data, std::size_t size) {
  if (size == 0) return;
  if (static_cast<std::int64_t>(size) > size_ - read_) {
    throw Error(std::string(owner_) + ": cannot read the spool file back: it is short");
  }
  if (std::fread(data, 1, size, file_) != size) {
    throw Error(std::string(owner_) + ": cannot read the spool file back: " +
                (std::ferror(file_) != 0 ? std::strerror(errno) : "it is short"));
  }
  read_ += static_cast<std::int64_t>(size);
}

void SpoolFile::copyTo(AtomicFile& out) {
  rewind();
  // At most 64 KiB (under malloc's mmap threshold, so reused rather than mapped afresh, page by
  // page), no more than the spool holds, and not zeroed: a run with a file per label copies many
  // small spools.
  const auto capacity = static_cast<std::size_t>(std::clamp<std::int64_t>(size_, 1, 1 << 16));
  const std::unique_ptr<char[]> buf(new char[capacity]);
  while (read_ < size_) {
    const std::size_t want =
        static_cast<std::size_t>(std::min<std::int64_t>(size_ - read_, static_cast<std::int64_t>(capacity)));
    read(buf.get(), want);
    out.write(buf.get(), want);
  }
}

}  // namespace isoslab
