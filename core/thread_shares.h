#pragma once
// A few threads kept waiting for shares of small jobs, where starting threads for each job would
// cost as much as the job (a smoothing step of one chunk takes a fraction of a millisecond).

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace isoslab {

class ThreadShares {
 public:
  /// Up to `threads` shares at once: the caller's thread and threads - 1 others, started at the
  /// first run that needs them.
  explicit ThreadShares(int threads);
  ~ThreadShares();
  ThreadShares(const ThreadShares&) = delete;
  ThreadShares& operator=(const ThreadShares&) = delete;

  /// The most shares that run() runs at once.
  std::size_t size() const noexcept { return size_; }

  /// One caller at a time, and not from within a body.
  /// Runs body(0) .. body(n - 1) and returns when all are done: body(0) on the calling thread, the
  /// next size() - 1 on the waiting threads, and the rest (beyond size(), or whose thread could not
  /// be started) on the calling thread afterwards. Rethrows the first error, in the order of the
  /// shares.
  void run(std::size_t n, const std::function<void(std::size_t)>& body);

 private:
  void work(std::size_t index, std::uint64_t seen);

  std::size_t size_;
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  std::vector<std::thread> threads_;
  const std::function<void(std::size_t)>* body_ = nullptr;
  std::size_t shares_ = 0;
  std::uint64_t generation_ = 0;
  std::size_t pending_ = 0;
  bool stop_ = false;
  std::vector<std::exception_ptr> errors_;
};

}  // namespace isoslab
