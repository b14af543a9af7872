// The slab workers of a threaded pipeline (stream/pipeline.cpp): slabs queue up and go to
// whichever worker is free (a slab worker gives the same part for a slab whichever worker runs
// it); up to `depth` slabs are in flight, and parts are collected in slab order. An exception a
// worker throws (std::bad_alloc, say) is handed to the collector of that slab.
#pragma once

#include <cassert>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

#include "extract/extractor.h"

namespace isoslab {

class WorkerPool {
 public:
  WorkerPool(const Extractor& extractor, int workers, int depth) : results_(static_cast<std::size_t>(depth)) {
    for (int w = 0; w < workers; ++w) extractors_.push_back(extractor.makeWorker());
    try {
      for (auto& ex : extractors_) threads_.emplace_back([this, e = ex.get()] { run(*e); });
    } catch (...) {
      stop();
      throw;
    }
  }
  ~WorkerPool() { stop(); }
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Queues slab view.z, whose result slot must have been collected from.
  void submit(const SlabView& view) {
    {
      std::lock_guard lock(mutex_);
      Result& r = slotOf(view.z);
      assert(!r.done);
      r.z = view.z;
      jobs_.push_back(view);
    }
    jobReady_.notify_one();
  }

  /// Waits for slab z. The part stays valid until slab z + depth is submitted.
  SlabPart& collect(std::int64_t z) {
    std::unique_lock lock(mutex_);
    Result& r = slotOf(z);
    partReady_.wait(lock, [&] { return r.done && r.z == z; });
    r.done = false;
    if (r.error) std::rethrow_exception(std::exchange(r.error, nullptr));  // std::bad_alloc, say
    return r.part;
  }

  /// Seconds spent extracting, summed over the workers.
  double seconds() const noexcept { return seconds_; }

 private:
  struct Result {
    std::int64_t z = -1;
    bool done = false;
    SlabPart part;
    std::exception_ptr error;  // what the worker threw instead of extracting the part
  };

  void run(SlabWorker& worker) {
    for (;;) {
      SlabView view;
      {
        std::unique_lock lock(mutex_);
        jobReady_.wait(lock, [&] { return !jobs_.empty() || stop_; });
        if (stop_) return;
        view = jobs_.front();
        jobs_.pop_front();
      }
      // Only this worker touches the slot's part until it is marked done.
      SlabPart& part = slotOf(view.z).part;
      const auto t = std::chrono::steady_clock::now();
      std::exception_ptr error;
      try {
        worker.extract(view, part);
      } catch (...) {
        error = std::current_exception();
      }
      const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      {
        std::lock_guard lock(mutex_);
        slotOf(view.z).error = error;
        slotOf(view.z).done = true;
        seconds_ += took;
      }
      partReady_.notify_all();
    }
  }

  Result& slotOf(std::int64_t z) { return results_[static_cast<std::size_t>(z) % results_.size()]; }

  void stop() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    jobReady_.notify_all();
    for (auto& t : threads_) t.join();
    threads_.clear();
  }

  std::vector<std::unique_ptr<SlabWorker>> extractors_;
  std::vector<std::thread> threads_;
  std::mutex mutex_;
  std::condition_variable jobReady_, partReady_;
  std::deque<SlabView> jobs_;
  std::vector<Result> results_;
  double seconds_ = 0;
  bool stop_ = false;
};

}  // namespace isoslab
