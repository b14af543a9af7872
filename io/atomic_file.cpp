#include "io/atomic_file.h"

#include <fmt/format.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <utility>
#include <vector>

#include "io/error.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

std::string folderOf(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

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

}  // namespace

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  const std::string folder = folderOf(path_);
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw Error(fmt::format("{}: cannot create the output: the folder '{}' does not exist", path_, folder));
  }
  if (fs::is_directory(path_, ec)) {
    throw Error(fmt::format("{}: cannot create the output: it is a folder", path_));
  }
  file_ = makeTemp(folder, fs::path(path_).filename().string(), tempPath_);
  if (file_ == nullptr) {
    throw Error(fmt::format("{}: cannot create the output: {}", path_, std::strerror(errno)));
  }
  // mkstemp creates the file private; give the output the permissions a plain creat() would.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(::fileno(file_), 0666 & ~mask);
  std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
}

AtomicFile::AtomicFile(AtomicFile&& other) noexcept
    : path_(std::move(other.path_)),
      tempPath_(std::move(other.tempPath_)),
      file_(std::exchange(other.file_, nullptr)),
      size_(other.size_),
      position_(other.position_) {}

AtomicFile::~AtomicFile() {
  if (file_ != nullptr) {
    std::fclose(file_);
    ::unlink(tempPath_.c_str());
  }
}

void AtomicFile::fail(const char* what) {
  const int err = errno;
  if (file_ != nullptr) {
    std::fclose(file_);
    file_ = nullptr;
    ::unlink(tempPath_.c_str());
  }
  throw Error(fmt::format("{}: cannot {}: {}", path_, what, std::strerror(err != 0 ? err : EIO)));
}

void AtomicFile::write(const void* data, std::size_t size) {
  if (file_ == nullptr) throw Error(fmt::format("{}: write after close", path_));
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) fail("write");
  position_ += static_cast<std::int64_t>(size);
  size_ = std::max(size_, position_);
}

void AtomicFile::seek(std::int64_t offset) {
  if (file_ == nullptr) throw Error(fmt::format("{}: seek after close", path_));
  if (std::fseek(file_, static_cast<long>(offset), SEEK_SET) != 0) fail("seek");
  position_ = offset;
}

void AtomicFile::commit() {
  if (file_ == nullptr) throw Error(fmt::format("{}: commit after close", path_));
  if (std::fflush(file_) != 0) fail("write");
  if (::fsync(::fileno(file_)) != 0 && errno != EINVAL) fail("write");
  std::FILE* f = std::exchange(file_, nullptr);
  if (std::fclose(f) != 0) {
    const int err = errno;
    ::unlink(tempPath_.c_str());
    throw Error(fmt::format("{}: cannot write: {}", path_, std::strerror(err)));
  }
  if (std::rename(tempPath_.c_str(), path_.c_str()) != 0) {
    const int err = errno;
    ::unlink(tempPath_.c_str());
    throw Error(fmt::format("{}: cannot rename the finished output into place: {}", path_, std::strerror(err)));
  }
}

SpoolFile::SpoolFile(const std::string& folder, std::string owner) : owner_(std::move(owner)) {
  std::string tempPath;
  file_ = makeTemp(folder.empty() ? std::string(".") : folder, "isoslab-spool", tempPath);
  if (file_ == nullptr) {
    throw Error(fmt::format("{}: cannot create a spool file in '{}': {}", owner_, folder, std::strerror(errno)));
  }
  ::unlink(tempPath.c_str());
  std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
}

SpoolFile::~SpoolFile() {
  if (file_ != nullptr) std::fclose(file_);
}

void SpoolFile::write(const void* data, std::size_t size) {
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) {
    throw Error(fmt::format("{}: cannot write the spool file: {}", owner_, std::strerror(errno)));
  }
  size_ += static_cast<std::int64_t>(size);
}

void SpoolFile::copyTo(AtomicFile& out) {
  if (std::fflush(file_) != 0 || std::fseek(file_, 0, SEEK_SET) != 0) {
    throw Error(fmt::format("{}: cannot read the spool file back: {}", owner_, std::strerror(errno)));
  }
  std::vector<char> buf(1 << 20);
  std::int64_t left = size_;
  while (left > 0) {
    const std::size_t want =
        static_cast<std::size_t>(std::min<std::int64_t>(left, static_cast<std::int64_t>(buf.size())));
    if (std::fread(buf.data(), 1, want, file_) != want) {
      throw Error(fmt::format("{}: cannot read the spool file back: {}", owner_, std::strerror(errno)));
    }
    out.write(buf.data(), want);
    left -= static_cast<std::int64_t>(want);
  }
}

}  // namespace isoslab
