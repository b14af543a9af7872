#include "core/thread_shares.h"

#include <algorithm>
#include <system_error>

namespace isoslab {

ThreadShares::ThreadShares(int threads) : size_(static_cast<std::size_t>(std::max(1, threads))) {}

ThreadShares::~ThreadShares() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void ThreadShares::work(std::size_t index, std::uint64_t seen) {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
    if (stop_) return;
    seen = generation_;
    if (index >= shares_) continue;
    const std::function<void(std::size_t)>& body = *body_;
    lock.unlock();
    std::exception_ptr error;
    try {
      body(index);
    } catch (...) {
      error = std::current_exception();
    }
    lock.lock();
    errors_[index] = error;
    if (--pending_ == 0) done_.notify_one();
  }
}

void ThreadShares::run(std::size_t n, const std::function<void(std::size_t)>& body) {
  if (n == 0) return;
  // Threads, started at the first run that needs them (their index is their share).
  while (threads_.size() + 1 < std::min(n, size_)) {
    try {
      // Started before this run's generation: it waits for that one.
      threads_.emplace_back([this, i = threads_.size() + 1, seen = generation_] { work(i, seen); });
    } catch (const std::system_error&) {
      break;  // no thread to be had: the caller runs the share
    }
  }
  const std::size_t onThreads = std::min({n, size_, threads_.size() + 1});
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    body_ = &body;
    shares_ = onThreads;
    pending_ = onThreads - 1;
    errors_.assign(n, nullptr);
    ++generation_;
  }
  if (onThreads > 1) wake_.notify_all();
  std::exception_ptr first;
  try {
    body(0);
  } catch (...) {
    first = std::current_exception();
  }
  {
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return pending_ == 0; });
    errors_[0] = first;
  }
  for (std::size_t i = onThreads; i < n; ++i) {
    try {
      body(i);
    } catch (...) {
      errors_[i] = std::current_exception();
    }
  }
  for (const std::exception_ptr& e : errors_) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace isoslab
